//! The daemon: the real-time cycle processor on the FRI endpoint thread, the fan-out of its
//! state to tokio and iceoryx2, the operator workflows and the command handler.
//!
//! Data path per cycle (architecture.md): `fri::endpoint` thread receives and validates the
//! measurement → [`cycle::CycleProcessor`] (observer step, reaction, motion, handshake) →
//! reply; the cycle's events and state go through a bounded queue to the stream thread
//! ([`stream::spawn`], `fri-stream`), which feeds the tokio side ([`stream::Shared`]), the
//! audit thread and iceoryx2's publishing thread. Operator requests go back through a bounded
//! queue read with `try_recv` by the processor.

pub mod arm;
pub mod core;
pub mod cycle;
pub mod dispatch;
pub mod loop_audit;
pub mod output;
pub mod pattern;
pub mod replay;
pub mod settle;
pub mod state;
pub mod stream;
pub mod workflow;

use std::net::SocketAddr;
use std::sync::mpsc::sync_channel;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::Context as _;
use dynamics::Model;
use fri::endpoint::{Endpoint, EndpointConfig};
use safety::{CollisionMonitor, ReactionPolicy};
use tokio::sync::watch;

use crate::config::{Config, ReactionMode};
use crate::ipc::{IpcNames, IpcThread};
use crate::operator::server::{self, AccessPolicy, ServerLimits};
use crate::operator::stop_socket::{self, StopLimits};
use crate::persistence::lock::InstanceLock;
use crate::persistence::{AppliedPayload, StateStore, StoredMonitor};
use arm::ArmModel;
use core::{ServiceCore, compensation};
use cycle::{CycleProcessor, CycleRequest, ProcessorSettings};
use dispatch::Dispatcher;
use fri_api::origin::Origin;
use fri_api::results::Change;

/// Capacity of the loop → fan-out queue, messages (≈ 4 s at 1 kHz).
const EVENT_QUEUE: usize = 4096;
/// Longest wait at shutdown for the controller to leave command mode after the brake.
pub const LEAVE_COMMAND_TIMEOUT: Duration = Duration::from_secs(3);
/// Capacity of the operator → loop queue, requests.
const REQUEST_QUEUE: usize = 64;

/// Builds the collision monitor from the configuration (unloaded nominal `model`; the payload is
/// set separately), with static thresholds.
pub fn build_monitor(
    config: &Config,
    model: Model<7>,
) -> Result<CollisionMonitor<7>, safety::ConfigError> {
    build_scheduled_monitor(config, &ArmModel::nominal(model), None)
}

/// Builds the collision monitor from the configuration on `arm` (its observer model, and its
/// offset and friction subtracted at the observer's velocity) with the thresholds' motion
/// `schedule` of a calibration (`collision-calibrate`; its θ0 replaces the configuration's
/// thresholds). The contact is fitted through the LWR's link surfaces (`safety::ContactIsolator`).
pub fn build_scheduled_monitor(
    config: &Config,
    arm: &ArmModel,
    schedule: Option<&fri_api::results::ThresholdSchedule>,
) -> Result<CollisionMonitor<7>, safety::ConfigError> {
    let reaction = match config.reaction.policy {
        ReactionMode::Pause => ReactionPolicy::PauseThenResume {
            pause_s: config.reaction.pause_s,
        },
        ReactionMode::Stop | ReactionMode::Report => ReactionPolicy::Stop,
    };
    let setup = fri_api::monitor::MonitorSetup {
        period_s: config.fri.cycle_s,
        gains: config.observer.gains,
        thresholds: config.observer.thresholds,
        schedule,
        reaction,
    };
    fri_api::monitor::build_monitor(arm.observer_model().clone(), arm.joint_terms(), &setup)
}

/// `config` with the monitor settings a `collision configure` stored in place of its own
/// `[observer]` thresholds and gains and `[reaction]` (arming stays the configuration's).
pub fn with_stored_monitor(config: &Config, m: &StoredMonitor) -> Config {
    let mut c = config.clone();
    c.observer.thresholds = m.thresholds;
    c.observer.gains = m.gains;
    c.reaction.policy = m.reaction;
    c.reaction.pause_s = m.pause_s;
    c
}

/// Records what the configuration file puts in force at start (`Origin::Configuration`): the
/// arming, and the monitor's settings unless `collision configure` stored its own (those are
/// recorded as restored).
fn audit_configuration(audit: &crate::audit::Audit, config: &Config, stored_monitor: bool) {
    use fri_api::origin::Origin;
    use fri_api::results::Change;
    let origin = Origin::Configuration;
    if !stored_monitor {
        audit.record(
            &origin,
            Change::MonitorConfigured {
                thresholds: config.observer.thresholds,
                gains: config.observer.gains,
                reaction: config.reaction.policy,
                weaker_than_configuration: Vec::new(),
            },
        );
    }
    let arming = if config.observer.armed {
        Change::Armed
    } else {
        Change::Disarmed
    };
    audit.record(&origin, arming);
}

/// A running service: endpoint, fan-out and iceoryx2 threads, the shared core, the bound
/// operator and stop sockets and the state directory's instance lock.
pub struct RunningService {
    /// The core shared with the operator handler.
    pub core: Arc<ServiceCore>,
    endpoint: Option<Arc<Endpoint>>,
    ipc: Option<IpcThread>,
    stream: Option<std::thread::JoinHandle<()>>,
    /// Bound at start, served by [`RunningService::serve_operator`].
    listener: Mutex<Option<std::os::unix::net::UnixListener>>,
    /// The stop socket, bound at start like the operator socket.
    stop_listener: Mutex<Option<std::os::unix::net::UnixListener>>,
    /// Held until the loop has stopped.
    lock: Option<InstanceLock>,
}

impl std::fmt::Debug for RunningService {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RunningService").finish_non_exhaustive()
    }
}

impl RunningService {
    /// Starts the service: everything that can fail happens before the FRI endpoint answers
    /// anything, in this order: the configuration is validated, the state directory checked
    /// and locked (one service per state directory) and its state restored, the recording
    /// directory checked, the operator socket bound (served by
    /// [`RunningService::serve_operator`]), iceoryx2 set up, and last the UDP port bound
    /// (exclusively) and the endpoint started.
    pub fn start(config: Config) -> anyhow::Result<Self> {
        config.validate()?;
        let arm = ArmModel::load(&config.robot, dynamics::lwr4())?;
        match arm.status().calibration {
            Some(c) => tracing::info!(
                calibration = %c.path,
                heldout_rms_nm = ?c.heldout_rms,
                offset_nm = ?c.offset,
                "robot model: the identified arm (robot.calibration)"
            ),
            None => tracing::info!("robot model: nominal (no robot.calibration)"),
        }
        let store = StateStore::open(&config.state.dir)?;
        let lock = InstanceLock::acquire(store.checked_dir())?;
        let payload = store
            .load_payload()
            .context("reloading the applied payload")?;
        let tare = store.load_tare().context("reloading the tare")?;
        let stored_monitor = store
            .load_monitor()
            .context("reloading the collision monitor's settings")?;
        // The stored settings are checked against this configuration's ranges (the gain bound
        // follows fri.cycle_s): a file that no longer fits stops the start rather than running
        // with other settings than the operator set.
        let effective = match &stored_monitor {
            Some(m) => {
                let c = with_stored_monitor(&config, m);
                c.validate().with_context(|| {
                    format!(
                        "the collision monitor's settings in {} (written by `collision \
                         configure`; correct them there or remove the file to use the \
                         configuration's)",
                        store.monitor_path().display()
                    )
                })?;
                if !core::same_payload(m.set_for_payload.as_ref(), payload.as_ref()) {
                    tracing::warn!(
                        set_for = ?m.set_for_payload,
                        applied = ?payload,
                        "the collision thresholds were set for another payload; check them"
                    );
                }
                c
            }
            None => config.clone(),
        };
        // Checked now so a bad `state.record_dir` stops the start, not a recording.
        crate::recordings::RecordDir::open(&config.state.record_dir())?;
        // The stop path first: no operator socket is created when the stop socket cannot be.
        let stop_path = config.operator.stop_socket_path();
        let stop_listener = crate::operator::listener::bind(&stop_path)
            .with_context(|| format!("operator.stop_socket {}", stop_path.display()))?;
        let listener = crate::operator::listener::bind(&config.operator.socket)
            .with_context(|| format!("operator.socket {}", config.operator.socket.display()))?;

        let (ipc_thread, ipc) = if config.iceoryx2.enabled {
            let names = IpcNames {
                service_prefix: config.iceoryx2.service_prefix.clone(),
                global_prefix: config.iceoryx2.global_prefix.clone(),
            };
            let (t, s) = IpcThread::spawn(names).context("starting iceoryx2 publication")?;
            (Some(t), Some(s))
        } else {
            (None, None)
        };

        let shared = stream::Shared::new();
        let audit = Arc::new(crate::audit::Audit::new());
        let (event_tx, event_rx) = sync_channel(EVENT_QUEUE);
        let (request_tx, request_rx) = sync_channel(REQUEST_QUEUE);
        let stream = stream::spawn(event_rx, shared.clone(), ipc.clone(), audit.clone())
            .context("starting the stream thread")?;

        let schedule = stored_monitor.as_ref().and_then(|m| m.schedule.as_ref());
        let monitor = build_scheduled_monitor(&effective, &arm, schedule)
            .context("observer configuration")?;
        let settings = ProcessorSettings::from_config(&effective);
        let processor = CycleProcessor::new(settings, monitor, request_rx, event_tx);
        let stop_latch = processor.stop_latch();
        let dropped_events = processor.dropped_events();
        if let Some(p) = &payload {
            request_tx
                .try_send(CycleRequest::SetPayload(Some(compensation(p))))
                .ok();
        }

        let mut ec = EndpointConfig::default();
        ec.socket.bind = config.fri.bind;
        ec.session.controller_ip = config.fri.controller;
        ec.session.controller_port = config.fri.controller_port;
        ec.session.resync_after = Duration::from_secs_f64(config.fri.resync_after_s);
        ec.session.max_joint_step = config.fri.max_joint_step;
        // The endpoint publishes its view of the controller's silence at every receive
        // timeout: four times per connection timeout, so a silence is seen when it begins.
        ec.socket.receive_timeout = core::connection_timeout(config.fri.cycle_s) / 4;
        let endpoint =
            Arc::new(Endpoint::spawn(ec, processor).map_err(|e| endpoint_error(e, &config))?);
        audit_configuration(&audit, &config, stored_monitor.is_some());
        // A weak handle: the core must not keep the loop alive after shutdown.
        let source = Arc::downgrade(&endpoint);
        let restored = Restored {
            monitor: stored_monitor.is_some(),
            payload,
            tare: tare.is_some(),
        };
        let core = Arc::new(ServiceCore::new(
            config,
            arm,
            shared,
            request_tx,
            store,
            payload,
            tare,
            stored_monitor,
            ipc,
            Some(Arc::new(move || {
                source.upgrade().map(|e| e.latest()).unwrap_or_default()
            })),
            audit,
            stop_latch,
            dropped_events,
        ));
        restored.audit(&core);
        Ok(Self {
            core,
            endpoint: Some(endpoint),
            ipc: ipc_thread,
            stream: Some(stream),
            listener: Mutex::new(Some(listener)),
            stop_listener: Mutex::new(Some(stop_listener)),
            lock: Some(lock),
        })
    }

    /// The FRI endpoint's bound address (useful with port 0).
    pub fn fri_addr(&self) -> Option<SocketAddr> {
        self.endpoint.as_ref().map(|e| e.local_addr())
    }

    /// Serves the operator socket until `shutdown` becomes true, then shuts down in order: the
    /// loop brakes any move at once, every pending request is answered, the connection tasks end,
    /// and the loop leaves command mode through the handshake (waited for at most
    /// [`LEAVE_COMMAND_TIMEOUT`]).
    pub async fn serve_operator(&self, shutdown: watch::Receiver<bool>) -> anyhow::Result<()> {
        let c = &self.core.config().operator;
        let take = |m: &Mutex<Option<std::os::unix::net::UnixListener>>| match m.lock() {
            Ok(mut l) => l.take(),
            Err(p) => p.into_inner().take(),
        };
        let (bound, stop_bound) = (take(&self.listener), take(&self.stop_listener));
        let (bound, stop_bound) = bound
            .zip(stop_bound)
            .context("the operator socket is already being served")?;
        // The stop path first: by the time the operator socket answers, `stop` has its own.
        let stop_path = c.stop_socket_path();
        let stop_listener = tokio::net::UnixListener::from_std(stop_bound)
            .with_context(|| format!("operator.stop_socket {}", stop_path.display()))?;
        tracing::info!(socket = %stop_path.display(), "stop socket listening");
        let listener = tokio::net::UnixListener::from_std(bound)
            .with_context(|| format!("operator.socket {}", c.socket.display()))?;
        tracing::info!(socket = %c.socket.display(), "operator socket listening");
        let policy = AccessPolicy {
            allowed_uids: c.allowed_uids.clone(),
            allowed_gids: c.allowed_gids.clone(),
            ros2_bridge_uids: c.ros2_bridge_uids.clone(),
        };
        let limits = ServerLimits {
            max_line_bytes: c.max_line_bytes,
            max_clients: c.max_clients,
            idle_timeout: std::time::Duration::from_secs_f64(c.idle_timeout_s),
            ..ServerLimits::default()
        };
        let mut flag = shutdown.clone();
        let core = self.core.clone();
        // Braking does not wait for the clients: the arm stops moving as soon as asked.
        let brake = async move {
            if flag.wait_for(|s| *s).await.is_ok() {
                let _ = core.send(CycleRequest::Shutdown);
            }
        };
        let dispatcher = Arc::new(Dispatcher(self.core.clone()));
        let stopping = stop_socket::serve(
            stop_listener,
            dispatcher.clone(),
            policy.clone(),
            StopLimits::default(),
            shutdown.clone(),
        );
        // The loop's own changes of the unknown-payload mode (pins, an expiry) reach the audit.
        let follow = self.core.follow_unknown_payload(shutdown.clone());
        let serving = server::serve(listener, dispatcher, policy, limits, shutdown);
        tokio::join!(serving, stopping, brake, follow);
        let _ = std::fs::remove_file(&c.socket);
        let _ = std::fs::remove_file(&stop_path);
        self.core.leave_command_mode(LEAVE_COMMAND_TIMEOUT).await;
        Ok(())
    }

    /// Stops the loop and the helper threads.
    pub fn shutdown(mut self) {
        self.stop();
    }

    fn stop(&mut self) {
        if let Some(e) = self.endpoint.take() {
            // The core holds a clone for `status`; the loop stops when the last one goes.
            match Arc::try_unwrap(e) {
                Ok(e) => {
                    let _ = e.shutdown();
                }
                Err(e) => drop(e),
            }
        }
        if let Some(f) = self.stream.take() {
            // Ends once the processor (on the endpoint thread) is gone: joined when it does so
            // within STREAM_JOIN_TIMEOUT, left to end on its own (logged) otherwise.
            let deadline = std::time::Instant::now() + STREAM_JOIN_TIMEOUT;
            while !f.is_finished() && std::time::Instant::now() < deadline {
                std::thread::sleep(std::time::Duration::from_millis(5));
            }
            if f.is_finished() {
                let _ = f.join();
            } else {
                tracing::warn!(
                    timeout_s = STREAM_JOIN_TIMEOUT.as_secs_f64(),
                    "the stream thread did not end at shutdown; left to end on its own"
                );
            }
        }
        if let Some(t) = self.ipc.take() {
            // Waits until its iceoryx2 resources are released (the next start finds none).
            t.stop();
        }
        // Released last: the loop no longer answers the controller.
        self.lock.take();
    }
}

/// Longest wait at shutdown for the stream thread to end after the endpoint stopped.
const STREAM_JOIN_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(1);

/// The endpoint's error, saying when another program holds the UDP port.
fn endpoint_error(e: fri::endpoint::EndpointError, config: &Config) -> anyhow::Error {
    use fri::endpoint::EndpointError;
    match &e {
        EndpointError::Socket { source, .. } if source.kind() == std::io::ErrorKind::AddrInUse => {
            anyhow::anyhow!(
                "fri.bind {}: the UDP port is in use (another fri-service, fri-monitor or FRI \
                 program?); the service binds it exclusively so no other program can take the \
                 controller's datagrams: {e}",
                config.fri.bind
            )
        }
        _ => anyhow::Error::new(e).context("starting the FRI endpoint"),
    }
}

/// What the start restored from the state directory, for the audit trail.
struct Restored {
    monitor: bool,
    payload: Option<AppliedPayload>,
    tare: bool,
}

impl Restored {
    /// One audit record per restored file (origin: restored state), a warning when it makes
    /// the monitor weaker than the configuration: higher thresholds, lower gains, a report-only
    /// reaction, or a payload the configuration does not apply (a wrong one shifts the residual
    /// by its gravity torque, which can hide a contact).
    fn audit(&self, core: &ServiceCore) {
        let store = &core.store;
        if self.monitor {
            let weaker = core.weaker_than_configuration(&core.monitor_settings());
            core.audit.record(
                &Origin::Restored,
                Change::Restored {
                    file: store.monitor_path().display().to_string(),
                    weaker_than_configuration: weaker,
                },
            );
        }
        if let Some(p) = &self.payload {
            core.audit.record(
                &Origin::Restored,
                Change::Restored {
                    file: store.payload_path().display().to_string(),
                    weaker_than_configuration: vec![format!(
                        "payload {:.3} kg at ({:.3}, {:.3}, {:.3}) m compensated; the \
                         configuration compensates none",
                        p.mass, p.com[0], p.com[1], p.com[2]
                    )],
                },
            );
        }
        if self.tare {
            core.audit.record(
                &Origin::Restored,
                Change::Restored {
                    file: store.tare_path().display().to_string(),
                    weaker_than_configuration: Vec::new(),
                },
            );
        }
    }
}

impl Drop for RunningService {
    fn drop(&mut self) {
        self.stop();
    }
}
