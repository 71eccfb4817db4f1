//! The 1 Hz diagnostics: the service's `status` (FRI state, quality, the controller's answer
//! statistics, monitor state) and the bridge's own counters, as one `DiagnosticArray`.

use std::sync::atomic::{AtomicU64, Ordering};

use fri_api::results::StatusResult;
use fri_ros_msgs::builtin_interfaces::Time;
use fri_ros_msgs::diagnostic_msgs::{
    DiagnosticArray, DiagnosticStatus, ERROR, KeyValue, OK, STALE, WARN,
};
use fri_ros_msgs::std_msgs::Header;

/// Hardware id of every status.
pub const HARDWARE_ID: &str = "kuka_lwr4";

/// The bridge's counters (shared by the input thread and the diagnostics).
#[derive(Debug, Default)]
pub struct Stats {
    /// Robot states received over iceoryx2.
    pub states: AtomicU64,
    /// Joint-state messages published.
    pub joint_states: AtomicU64,
    /// Collision events published.
    pub collisions: AtomicU64,
    /// Cycle of the newest state.
    pub last_cycle: AtomicU64,
    /// Times the iceoryx2 subscriptions were (re)opened.
    pub opened: AtomicU64,
    /// Command requests received (services and `apply_payload`).
    pub requests: AtomicU64,
    /// Replies sent (results, refusals and `busy`).
    pub answered: AtomicU64,
    /// Requests answered `busy` (too many commands in flight).
    pub busy: AtomicU64,
    /// Requests ignored as replays, too old, issued before the start or without a timestamp.
    pub ignored: AtomicU64,
    /// Requests neither answered nor executed: ignored, undecodable, lost before the bridge read
    /// them (gaps in a writer's sequence numbers) or whose reply could not be sent.
    pub dropped: AtomicU64,
    /// Commands forwarded to the service.
    pub executed: AtomicU64,
    /// Commands the bridge refused itself (disarm not enabled, invalid payload).
    pub refused: AtomicU64,
}

/// What the diagnostics say of who may command.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CommandAccess {
    /// The enabled commands (`ros2.commands`).
    pub commands: Vec<String>,
    /// `ros2.allow_unauthenticated_commands` is in force.
    pub unauthenticated: bool,
    /// DDS Security is on (an enclave).
    pub secured: bool,
    /// The device the DDS sockets are bound to (`None`: every interface).
    pub sockets_bound_to: Option<String>,
}

fn access_status(name: String, a: &CommandAccess, stats: &Stats) -> DiagnosticStatus {
    let (level, message) = if a.commands.is_empty() {
        (OK, "read-only: no command enabled".to_owned())
    } else if a.unauthenticated {
        (
            WARN,
            "UNAUTHENTICATED commands: any DDS participant on the domain may call them \
             (ros2.allow_unauthenticated_commands)"
                .to_owned(),
        )
    } else {
        (
            OK,
            "commands for DDS Security-authenticated participants".to_owned(),
        )
    };
    let load = |a: &AtomicU64| a.load(Ordering::Relaxed);
    DiagnosticStatus {
        level,
        name,
        message,
        hardware_id: HARDWARE_ID.into(),
        values: vec![
            KeyValue::new("commands", a.commands.join(", ")),
            KeyValue::new("unauthenticated commands", a.unauthenticated),
            KeyValue::new("DDS Security", a.secured),
            KeyValue::new(
                "sockets bound to",
                a.sockets_bound_to.as_deref().unwrap_or("every interface"),
            ),
            KeyValue::new("requests", load(&stats.requests)),
            KeyValue::new("answered", load(&stats.answered)),
            KeyValue::new("busy", load(&stats.busy)),
            KeyValue::new("executed", load(&stats.executed)),
            KeyValue::new("refused", load(&stats.refused)),
            KeyValue::new("ignored requests", load(&stats.ignored)),
            KeyValue::new("dropped_requests", load(&stats.dropped)),
        ],
    }
}

/// The components' statuses; `status` is the service's answer (or why there is none).
pub fn report(
    prefix: &str,
    status: &Result<StatusResult, String>,
    stats: &Stats,
    access: &CommandAccess,
) -> DiagnosticArray {
    let name = |c: &str| format!("{prefix}: {c}");
    let mut out = Vec::new();
    match status {
        Ok(s) => {
            out.push(fri_status(name("FRI"), s));
            out.push(monitor_status(name("collision monitor"), s));
        }
        Err(e) => out.push(DiagnosticStatus {
            level: ERROR,
            name: name("service"),
            message: format!("no status from the service: {e}"),
            hardware_id: HARDWARE_ID.into(),
            values: Vec::new(),
        }),
    }
    let load = |a: &AtomicU64| a.load(Ordering::Relaxed);
    out.push(DiagnosticStatus {
        level: OK,
        name: name("ROS 2 bridge"),
        message: "running".into(),
        hardware_id: HARDWARE_ID.into(),
        values: vec![
            KeyValue::new("states received", load(&stats.states)),
            KeyValue::new("joint states published", load(&stats.joint_states)),
            KeyValue::new("collisions published", load(&stats.collisions)),
            KeyValue::new("last cycle", load(&stats.last_cycle)),
            KeyValue::new("iceoryx2 (re)opened", load(&stats.opened)),
        ],
    });
    out.push(access_status(name("ROS 2 commands"), access, stats));
    let time_s = status.as_ref().ok().and_then(|s| s.time_s).unwrap_or(0.0);
    DiagnosticArray {
        header: Header {
            stamp: Time::from_seconds(time_s),
            frame_id: String::new(),
        },
        status: out,
    }
}

fn fri_status(name: String, s: &StatusResult) -> DiagnosticStatus {
    let Some(f) = &s.fri else {
        return DiagnosticStatus {
            level: STALE,
            name,
            message: "no FRI endpoint snapshot".into(),
            hardware_id: HARDWARE_ID.into(),
            values: Vec::new(),
        };
    };
    let (level, message) = if !s.connected {
        (ERROR, "controller not connected".to_owned())
    } else {
        match f.quality.as_str() {
            "Perfect" | "Ok" => (OK, format!("{} mode, quality {}", f.state, f.quality)),
            "Bad" => (WARN, format!("{} mode, quality {}", f.state, f.quality)),
            _ => (ERROR, format!("{} mode, quality {}", f.state, f.quality)),
        }
    };
    let c = &f.controller_statistics;
    DiagnosticStatus {
        level,
        name,
        message,
        hardware_id: HARDWARE_ID.into(),
        values: vec![
            KeyValue::new("state", &f.state),
            KeyValue::new("quality", &f.quality),
            KeyValue::new("KRL status", &f.krl_status),
            KeyValue::new("drop reason", &f.drop_reason),
            KeyValue::new("answer rate", c.answer_rate),
            KeyValue::new("latency (s)", c.latency),
            KeyValue::new("jitter (s)", c.jitter),
            KeyValue::new("miss rate", c.miss_rate),
            KeyValue::new("misses", c.miss_counter),
            KeyValue::new("cycles", f.cycles),
            KeyValue::new("controller time (s)", s.time_s.unwrap_or(f64::NAN)),
        ],
    }
}

fn monitor_status(name: String, s: &StatusResult) -> DiagnosticStatus {
    let (level, message) = if s.observer_fault {
        (ERROR, "observer fault".to_owned())
    } else if s.collision {
        (WARN, "collision reaction active".to_owned())
    } else if s.stopped {
        (WARN, "arm held".to_owned())
    } else if !s.monitor.armed {
        (WARN, "disarmed".to_owned())
    } else if let Some(u) = &s.unknown_payload {
        // Weaker than the configuration while it lasts: say what is tolerated and until when.
        (WARN, unknown_payload_message(u))
    } else if !s.residual_valid {
        (OK, "armed, warming up".to_owned())
    } else {
        (OK, "armed".to_owned())
    };
    let state = s
        .state
        .as_ref()
        .and_then(|st| serde_json::to_string(st).ok())
        .unwrap_or_else(|| "unknown".into());
    DiagnosticStatus {
        level,
        name,
        message,
        hardware_id: HARDWARE_ID.into(),
        values: vec![
            KeyValue::new("armed", s.monitor.armed),
            KeyValue::new("residual valid", s.residual_valid),
            KeyValue::new("stopped", s.stopped),
            KeyValue::new("collision", s.collision),
            KeyValue::new("service state", state),
            KeyValue::new(
                "payload mass (kg)",
                s.payload.as_ref().map_or(0.0, |p| p.mass),
            ),
            KeyValue::new(
                "tare samples",
                s.tare_samples.map_or("none".to_owned(), |n| n.to_string()),
            ),
            KeyValue::new(
                "unknown payload",
                s.unknown_payload
                    .as_ref()
                    .map_or("none".to_owned(), unknown_payload_message),
            ),
            KeyValue::new("robot model", robot_model(s)),
            KeyValue::new(
                "unknown payload expires at (s)",
                s.unknown_payload
                    .as_ref()
                    .and_then(|u| u.expires_at_s)
                    .unwrap_or(f64::NAN),
            ),
        ],
    }
}

/// The model the service predicts torque with: `lwr4 nominal`, or `lwr4 identified <file>`.
fn robot_model(s: &StatusResult) -> String {
    match &s.robot {
        None => "unknown (service older than this field)".to_owned(),
        Some(r) => match &r.calibration {
            None => format!("{} nominal (no robot.calibration)", r.model),
            Some(c) => format!("{} identified {}", r.model, c.path),
        },
    }
}

/// What the unknown-payload mode tolerates now and until when (controller time, s).
fn unknown_payload_message(u: &fri_api::results::UnknownPayload) -> String {
    let until = u
        .expires_at_s
        .map_or(String::new(), |t| format!("; expires at t = {t:.3} s"));
    match (&u.pinned, u.grasp_window_end_s) {
        (Some(p), _) => format!(
            "armed, payload unknown: load pinned at {:.3} kg ({}), a change beyond {:.3} kg is a contact{until}",
            p.mass,
            p.by.name(),
            p.mass_tolerance
        ),
        (None, Some(end)) => format!(
            "armed, payload unknown: grasp window until t = {end:.3} s, any plausible flange load up to {:.2} kg within {:.3} m is tolerated{until}",
            u.max_mass, u.max_radius
        ),
        (None, None) => format!(
            "armed, payload unknown: any plausible flange load up to {:.2} kg within {:.3} m is tolerated until the loop pins it{until}",
            u.max_mass, u.max_radius
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unreachable_service_is_an_error_status_next_to_the_bridge_counters() {
        let stats = Stats::default();
        stats.states.store(5, Ordering::Relaxed);
        let access = CommandAccess {
            commands: vec!["stop".into()],
            unauthenticated: true,
            secured: false,
            sockets_bound_to: Some("lo".into()),
        };
        stats.dropped.store(3, Ordering::Relaxed);
        let a = report("lwr", &Err("connection refused".into()), &stats, &access);
        assert_eq!(a.status.len(), 3);
        // Unauthenticated commands: a WARN for as long as they are served.
        assert_eq!(a.status[2].level, WARN);
        assert!(a.status[2].message.contains("UNAUTHENTICATED"));
        assert!(
            a.status[2]
                .values
                .contains(&KeyValue::new("unauthenticated commands", true))
        );
        assert!(
            a.status[2]
                .values
                .contains(&KeyValue::new("dropped_requests", 3))
        );
        assert_eq!(a.status[0].level, ERROR);
        assert!(a.status[0].message.contains("connection refused"));
        assert_eq!(a.status[1].name, "lwr: ROS 2 bridge");
        assert_eq!(a.status[1].values[0], KeyValue::new("states received", 5));
    }

    #[test]
    fn the_unknown_payload_mode_says_what_it_tolerates_and_until_when() {
        use fri_api::results::{DeclaredBy, PinnedBy, PinnedPayload, UnknownPayload};
        let mut u = UnknownPayload {
            declared_by: DeclaredBy::Operator,
            origin: None,
            max_mass: 7.0,
            max_radius: 0.3,
            samples: 0,
            mass: None,
            com: None,
            consistent: true,
            declared_at_s: Some(5.0),
            grasp_window_end_s: Some(15.0),
            expires_at_s: Some(125.0),
            expires_in_s: Some(119.0),
            pinned: None,
        };
        let m = unknown_payload_message(&u);
        assert!(m.contains("grasp window until t = 15.000 s"), "{m}");
        assert!(
            m.contains("7.00 kg") && m.contains("expires at t = 125.000 s"),
            "{m}"
        );
        u.pinned = Some(PinnedPayload {
            mass: 3.028,
            com: Some([0.0, 0.0, 0.119]),
            mass_tolerance: 0.9,
            com_tolerance: 0.05,
            com_height_open: true,
            by: PinnedBy::GraspWindow,
            samples: None,
            at_s: 15.0,
        });
        let m = unknown_payload_message(&u);
        assert!(m.contains("pinned at 3.028 kg (grasp-window)"), "{m}");
        assert!(m.contains("beyond 0.900 kg is a contact"), "{m}");
    }

    #[test]
    fn the_monitor_status_names_the_robot_model_in_force() {
        let mut s: StatusResult = serde_json::from_value(serde_json::json!({
            "connected": true, "residual_valid": true, "fri": null, "cycle": 5, "time_s": 0.005,
            "q": null, "qd": null, "tau": null, "gravity": null, "tau_ext": null,
            "residual": null, "command_mode": false, "stopped": false, "collision": false,
            "observer_fault": false, "moving": false, "payload": null, "tare_samples": null,
            "monitor": {"armed": true, "thresholds": ([6.0; 7]), "gains": ([400.0; 7])},
            "robot": {"model": "lwr4", "calibration": null},
        }))
        .unwrap();
        let value = |s: &StatusResult| {
            monitor_status("m".into(), s)
                .values
                .into_iter()
                .find(|v| v.key == "robot model")
                .map(|v| v.value)
        };
        assert_eq!(
            value(&s).as_deref(),
            Some("lwr4 nominal (no robot.calibration)")
        );
        if let Some(r) = &mut s.robot {
            r.calibration = Some(fri_api::results::ArmCalibration {
                path: "/etc/fri-service/arm.toml".into(),
                logs: vec![],
                duration_s: 25.0,
                residual_rms_nominal: vec![],
                heldout_rms: vec![],
                offset: vec![],
            });
        }
        assert_eq!(
            value(&s).as_deref(),
            Some("lwr4 identified /etc/fri-service/arm.toml")
        );
    }
}
