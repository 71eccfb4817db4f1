//! `status`: the newest cycle, the controller's FRI view, the applied payload, the tare and
//! the collision monitor's settings, read at once.

use fri_api::results::{FriStatus, StatusResult};

use crate::persistence::AppliedPayload;

use crate::service::core::ServiceCore;

impl ServiceCore {
    /// `status`.
    pub fn status(&self) -> StatusResult {
        // One read: `connected` and the values shown must describe the same state.
        let newest = self.shared.latest_with_age();
        let connected = self.connected(newest).is_ok();
        let snapshot = newest.map(|(s, _)| s);
        let latest = snapshot.map(|s| s.robot);
        let (payload, payload_origin, tare) = self.persistent(|p| {
            (
                p.payload,
                p.payload_origin.clone(),
                p.tare.as_ref().map(|t| t.samples.len()),
            )
        });
        let monitor = self.monitor_settings();
        let weaker_than_configuration = self.weaker_than_configuration(&monitor);
        let fri = self.fri_state.as_ref().map(|f| {
            let s = f();
            FriStatus {
                valid: s.valid,
                state: format!("{:?}", s.measurement.interface.state),
                quality: format!("{:?}", s.measurement.interface.quality),
                krl_status: format!("{:?}", s.handshake.status),
                drop_reason: format!("{:?}", s.handshake.drop_reason),
                cycles: s.cycle,
                statistics: s.statistics,
                controller_statistics: s.measurement.interface.statistics,
                // Only while disconnected: a controller that talks ends a resync at its next
                // accepted datagram, so a single refused replay is no resynchronisation.
                resync: s.resync.filter(|_| !connected),
            }
        });
        StatusResult {
            connected,
            state: snapshot.map(|s| s.state.to_api()),
            residual_valid: snapshot.is_some_and(|s| s.residual_valid()),
            fri,
            cycle: latest.map(|s| s.cycle),
            time_s: latest.map(|s| s.time_s),
            q: latest.map(|s| s.q),
            qd: latest.map(|s| s.qd),
            tau: latest.map(|s| s.tau),
            gravity: latest.map(|s| s.gravity),
            tau_ext: latest.map(|s| s.tau_ext),
            residual: latest.map(|s| s.residual),
            command_mode: snapshot.is_some_and(|s| s.command_mode()),
            stopped: snapshot.is_some_and(|s| s.state.is_held()),
            collision: snapshot.is_some_and(|s| s.collision()),
            observer_fault: snapshot.is_some_and(|s| s.observer_fault()),
            moving: snapshot.is_some_and(|s| s.moving()),
            payload: payload.map(|p| applied(&p)),
            payload_origin,
            tare_samples: tare,
            weaker_than_configuration,
            monitor,
            ros2_unauthenticated_commands: self.config.ros2_unauthenticated_commands(),
            unknown_payload: self.unknown_payload_status(),
            robot: Some(self.arm.status()),
            dropped: Some(fri_api::results::DroppedCounts {
                loop_events: self.dropped_events.count(),
                ipc_messages: self.ipc.as_ref().map(crate::ipc::IpcSender::dropped),
            }),
        }
    }
}

/// What clients see of an applied payload (its CoM in the flange frame, "7").
pub(crate) fn applied(p: &AppliedPayload) -> fri_api::results::AppliedPayload {
    fri_api::results::AppliedPayload {
        mass: p.mass,
        com: p.com,
        frame: "7".to_owned(),
    }
}
