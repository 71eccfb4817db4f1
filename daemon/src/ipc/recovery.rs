//! Removing the service's own stale iceoryx2 resources at start, so the service comes back
//! after any stop, a SIGKILL included.
//!
//! iceoryx2 cleans up after dead nodes (their ports and their registration in the services,
//! [`cleanup_dead_nodes`]), but two states of a service have no owner left to finish them:
//! - *hangs in creation*: its creator died after writing the static configuration and before
//!   the dynamic one (or before even finalising the static one, which iceoryx2's own forced
//!   removal then does not see);
//! - *marked for destruction*: its last node died while removing it.
//!
//! `open_or_create` waits `creation_timeout` (1 s) for the owner and then fails with
//! `HangsInCreation` or `IsMarkedForDestruction`, and so would every later start. The service
//! then removes the stuck service ([`remove_stuck_service`]) and opens it once more. Nobody can
//! be using such a service: ports attach through the dynamic configuration, which is missing or
//! being removed.

use std::ffi::OsStr;
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::PermissionsExt;
use std::path::PathBuf;
use std::time::Duration;

use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::publish_subscribe::PortFactory;
use iceoryx2::service::service_hash::ServiceHash;

use super::error::IpcError;
use iceoryx2::service::builder::publish_subscribe::{
    PublishSubscribeOpenError, PublishSubscribeOpenOrCreateError as OpenOrCreate,
};

/// Longest wait for another process that is cleaning up the same dead node, per node.
const CLEANUP_WAIT: Duration = Duration::from_millis(500);

/// Mode iceoryx2 gives a static service configuration until it is finalised (`OWNER_READ_WRITE`;
/// final: `OWNER_READ`).
const UNFINALISED_MODE: u32 = 0o600;

/// Removes the resources of dead nodes (this service's killed predecessors among them) under
/// the node's configuration; logs what it did.
pub fn cleanup_dead_nodes(node: &Node<ipc::Service>) {
    let state = node.blocking_cleanup_dead_nodes(CLEANUP_WAIT);
    if state.cleanups > 0 || state.failed_cleanups > 0 {
        tracing::info!(
            removed = state.cleanups,
            failed = state.failed_cleanups,
            "iceoryx2: removed the resources of dead nodes"
        );
    }
}

/// Whether `e` says the service is stuck (see the module documentation).
pub fn is_stuck(e: &OpenOrCreate) -> bool {
    matches!(
        e,
        OpenOrCreate::PublishSubscribeOpenError(
            PublishSubscribeOpenError::HangsInCreation
                | PublishSubscribeOpenError::IsMarkedForDestruction
        )
    )
}

/// Opens or creates a service with `open`; when it is stuck, removes it and opens once more.
pub fn open_recovering<T: std::fmt::Debug + ZeroCopySend>(
    node: &Node<ipc::Service>,
    name: &ServiceName,
    open: impl Fn() -> Result<PortFactory<ipc::Service, T, ()>, OpenOrCreate>,
) -> Result<PortFactory<ipc::Service, T, ()>, IpcError> {
    let setup = |e: OpenOrCreate| IpcError::Setup {
        what: "service",
        message: format!("{name}: {e:?}"),
    };
    match open() {
        Err(e) if is_stuck(&e) => {
            tracing::warn!(
                service = %name,
                error = ?e,
                "iceoryx2 service left stuck by a process that died; removing it"
            );
            remove_stuck_service(node, name)?;
            open().map_err(setup)
        }
        r => r.map_err(setup),
    }
}

/// Removes the stuck publish-subscribe service `name` (see the module documentation).
pub fn remove_stuck_service(node: &Node<ipc::Service>, name: &ServiceName) -> Result<(), IpcError> {
    // SAFETY: the service is stuck in creation or destruction, so no port of any process is
    // attached to it (ports attach through its dynamic configuration, which is missing or
    // marked for destruction), and the instance lock keeps a second service away.
    let removed = unsafe { node.force_remove_service(name, MessagingPattern::PublishSubscribe) }
        .map_err(|e| IpcError::Setup {
            what: "removal of a stuck service",
            message: format!("{name}: {e:?}"),
        })?;
    if removed {
        return Ok(());
    }
    // Not finalised: iceoryx2 does not see it, its file is removed here.
    let path = static_config_path(node.config(), name);
    match std::fs::symlink_metadata(&path) {
        Ok(m) if m.file_type().is_file() && m.permissions().mode() & 0o777 == UNFINALISED_MODE => {
            std::fs::remove_file(&path).map_err(|e| IpcError::Setup {
                what: "removal of a stuck service",
                message: format!("{name}: {}: {e}", path.display()),
            })?;
            tracing::warn!(service = %name, file = %path.display(), "removed an unfinished iceoryx2 service");
            Ok(())
        }
        _ => Ok(()),
    }
}

/// Where iceoryx2 keeps the static configuration of the publish-subscribe service `name`
/// under `config` (`<root>/services/<prefix><service hash>.service`).
pub fn static_config_path(config: &Config, name: &ServiceName) -> PathBuf {
    let global = &config.global;
    let hash = ServiceHash::new::<<ipc::Service as iceoryx2::service::Service>::ServiceNameHasher>(
        name,
        MessagingPattern::PublishSubscribe,
    );
    let mut file = global.prefix.as_bytes().to_vec();
    file.extend_from_slice(hash.as_str().as_bytes());
    file.extend_from_slice(global.service.static_config_storage_suffix.as_bytes());
    PathBuf::from(OsStr::from_bytes(global.service_dir().as_bytes())).join(OsStr::from_bytes(&file))
}
