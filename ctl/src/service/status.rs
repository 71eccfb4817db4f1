//! `fri-ctl status`: the controller link, the measured state, the payload and the monitor.

use std::io::{self, Write};

use clap::Args;

use fri_api::protocol::Command;
use fri_api::results::{
    RejectionCounters, ResyncKind, RobotModelStatus, ServiceState, StatusResult, StopCause,
};

use super::JsonFlag;
use super::format::{fixed, joint_header, joint_row, joint_row_deg, ms, percent, xyz_mm, yes_no};
use super::runner::Operation;

/// Long help of `status`.
pub(super) const HELP: &str = "\
Controller link, measured state, residual, payload and collision monitor (read only; the arm \
does not move).

Shows whether the controller is connected (a measurement within 100 ms, or ten controller \
cycles), the FRI state and quality with the KRL program's report, rejected datagrams by \
reason, what the service dropped rather than delay its 1 kHz loop, the controller's statistics \
of our answers, and per joint: positions (deg and rad), \
velocities (deg/s), measured torques τ_J, model gravity, the controller's external-torque \
estimate and the collision-observer residual (Nm). Then the applied payload (kg, mm in \
frame 7), whether the payload is declared unknown (`expect-payload`: the armed monitor then tolerates a plausible flange load, fitted to the static samples taken since), the stored tare and the monitor's thresholds (Nm) and gains (1/s).";

/// `fri-ctl status`.
#[derive(Debug, Clone, Args)]
pub struct StatusArgs {
    /// Output format.
    #[command(flatten)]
    pub output: JsonFlag,
}

impl Operation for StatusArgs {
    type Output = StatusResult;

    fn request(&self) -> Result<Command, String> {
        Ok(Command::Status)
    }

    fn json(&self) -> bool {
        self.output.json
    }

    fn print(&self, r: &StatusResult, out: &mut dyn Write) -> io::Result<()> {
        print(r, out)
    }
}

/// Writes the human-readable status.
pub(super) fn print(r: &StatusResult, out: &mut dyn Write) -> io::Result<()> {
    let resync = r.fri.as_ref().and_then(|f| f.resync.as_ref());
    match (r.connected, resync) {
        (true, _) => writeln!(out, "controller     connected")?,
        (false, Some(p)) => {
            let who = match p.kind {
                ResyncKind::Restart => "a restarted controller",
                ResyncKind::NewSource => "a controller on a new address or port",
            };
            writeln!(
                out,
                "controller     RESYNCHRONISING with {who} ({}): {} datagrams refused so far, accepted in {} s (fri.resync_after_s = {} s of silence of the previous one)",
                p.source,
                p.refused,
                fixed(p.remaining_s, 2),
                fixed(p.resync_after_s, 2)
            )?;
        }
        (false, None) => writeln!(
            out,
            "controller     NOT connected (no measurement within the timeout)"
        )?,
    }
    match &r.state {
        Some(ServiceState::Stopped { cause, .. } | ServiceState::Fault { cause, .. }) => {
            let why = match cause {
                StopCause::Operator => "operator stop; `resume` releases it".to_owned(),
                StopCause::Collision { link, time_s, .. } => format!(
                    "collision reaction, contact on link {link} at t = {} s; `resume` releases it",
                    fixed(*time_s, 3)
                ),
                StopCause::ObserverFault { .. } => {
                    "the collision monitor faulted; `resume` releases it".to_owned()
                }
            };
            writeln!(
                out,
                "state          {} ({why})",
                r.state.as_ref().map_or("", |s| s.word())
            )?;
        }
        Some(state) => writeln!(out, "state          {}", state.word())?,
        None => {}
    }
    if let Some(f) = &r.fri {
        // Disconnected, the endpoint's view is the last measurement's, not the link's now.
        let when = if r.connected {
            ""
        } else {
            "last measurement: "
        };
        writeln!(
            out,
            "fri            {when}state {}, quality {}; KRL {} (last drop to monitor mode: {})",
            f.state, f.quality, f.krl_status, f.drop_reason
        )?;
        let c = &f.controller_statistics;
        writeln!(
            out,
            "answers        rate {}, latency {}, jitter {}, missed {} in total ({} of the last 100)",
            percent(c.answer_rate),
            ms(c.latency, 2),
            ms(c.jitter, 2),
            c.miss_counter,
            percent(c.miss_rate)
        )?;
        rejections(&f.statistics.rejections, out)?;
    }
    if let Some(d) = &r.dropped {
        let ipc = d.ipc_messages.map_or_else(
            || "iceoryx2 off".to_owned(),
            |n| format!("{n} iceoryx2 messages"),
        );
        writeln!(
            out,
            "dropped        {} loop events (workflows and watch missed them), {ipc}",
            d.loop_events
        )?;
    }
    match (r.cycle, r.time_s) {
        (Some(cycle), Some(t)) => writeln!(out, "cycle          {cycle}  t = {} s", fixed(t, 3))?,
        _ => writeln!(out, "cycle          none (no measurement yet)")?,
    }
    writeln!(
        out,
        "flags          command mode {}, moving {}, stopped {}, collision {}, observer fault {}, residual valid {}",
        yes_no(r.command_mode),
        yes_no(r.moving),
        yes_no(r.stopped),
        yes_no(r.collision),
        yes_no(r.observer_fault),
        yes_no(r.residual_valid)
    )?;
    if let Some(q) = &r.q {
        joint_header(out)?;
        joint_row_deg(out, "q", q, 2)?;
        joint_row(out, "q", "rad", q, 4)?;
        let rows = [
            ("qd", &r.qd),
            ("tau_J", &r.tau),
            ("gravity", &r.gravity),
            ("tau_ext", &r.tau_ext),
            ("residual", &r.residual),
        ];
        for (label, values) in rows {
            match (label, values) {
                ("qd", Some(v)) => joint_row(out, label, "deg/s", &v.map(f64::to_degrees), 2)?,
                (_, Some(v)) => joint_row(out, label, "Nm", v, 2)?,
                _ => {}
            }
        }
    }
    match &r.payload {
        Some(p) => writeln!(
            out,
            "payload        {} kg, centre of mass [mm] {} in frame {}",
            fixed(p.mass, 4),
            xyz_mm(&p.com, 2),
            p.frame
        )?,
        None => writeln!(out, "payload        none")?,
    }
    if let Some(u) = &r.unknown_payload {
        super::expect_payload::print_mode(u, out)?;
    }
    match r.tare_samples {
        Some(n) => writeln!(out, "tare           {n} samples stored")?,
        None => writeln!(out, "tare           none")?,
    }
    if let Some(robot) = &r.robot {
        robot_model(robot, out)?;
    }
    if r.ros2_unauthenticated_commands {
        writeln!(
            out,
            "ros2           UNAUTHENTICATED commands accepted from any ROS 2 participant \
             ([ros2] allow_unauthenticated_commands)"
        )?;
    }
    super::collision::print_monitor(&r.monitor, out)
}

/// The model the service predicts torque with: nominal, or the identified arm with its held-out
/// residual next to the nominal model's.
fn robot_model(r: &RobotModelStatus, out: &mut dyn Write) -> io::Result<()> {
    match &r.calibration {
        None => writeln!(
            out,
            "robot model    {} nominal (no robot.calibration: the real arm's offsets and friction \
             stay in the residual)",
            r.model
        ),
        Some(c) => {
            writeln!(out, "robot model    {} identified, {}", r.model, c.path)?;
            let list = |v: &[f64]| v.iter().map(|x| fixed(*x, 2)).collect::<Vec<_>>().join(" ");
            writeln!(
                out,
                "               from {} ({} s); residual RMS [Nm] nominal {} → held-out {}",
                c.logs.join(", "),
                fixed(c.duration_s, 1),
                list(&c.residual_rms_nominal),
                list(&c.heldout_rms)
            )
        }
    }
}

/// The session's rejected datagrams by reason, non-zero ones only, largest first.
fn rejections(counters: &RejectionCounters, out: &mut dyn Write) -> io::Result<()> {
    let Ok(serde_json::Value::Object(map)) = serde_json::to_value(counters) else {
        return Ok(());
    };
    let mut nonzero: Vec<(String, u64)> = map
        .into_iter()
        .filter_map(|(k, v)| v.as_u64().filter(|n| *n > 0).map(|n| (k, n)))
        .collect();
    if nonzero.is_empty() {
        return writeln!(out, "rejected       none");
    }
    nonzero.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let total = nonzero.iter().fold(0u64, |t, (_, n)| t.saturating_add(*n));
    let list: Vec<String> = nonzero.iter().map(|(k, n)| format!("{k} {n}")).collect();
    writeln!(out, "rejected       {total} datagrams: {}", list.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn text(r: &StatusResult) -> String {
        let mut out = Vec::new();
        print(r, &mut out).unwrap();
        String::from_utf8(out).unwrap()
    }

    fn status(rejections: serde_json::Value) -> StatusResult {
        let mut statistics =
            serde_json::to_value(fri_api::results::SessionStatistics::default()).unwrap();
        statistics["rejections"] = rejections;
        serde_json::from_value(json!({
            "connected": true, "residual_valid": true,
            "fri": {"valid": true, "state": "Monitor", "quality": "Perfect", "krl_status": "x",
                    "drop_reason": "None", "cycles": 5, "statistics": statistics,
                    "controller_statistics": fri_api::results::InterfaceStatistics::default()},
            "cycle": 5, "time_s": 0.005, "q": ([0.5; 7]), "qd": ([0.0; 7]), "tau": ([1.0; 7]),
            "gravity": ([1.0; 7]), "tau_ext": ([0.0; 7]), "residual": ([-0.001; 7]),
            "command_mode": false, "stopped": true, "collision": false, "observer_fault": false,
            "moving": false, "payload": null, "tare_samples": null,
            "monitor": {"armed": true, "thresholds": ([6.0; 7]), "gains": ([400.0; 7])},
        }))
        .unwrap()
    }

    fn zero_rejections() -> serde_json::Value {
        serde_json::to_value(RejectionCounters::default()).unwrap()
    }

    #[test]
    fn status_shows_the_non_zero_rejection_counters() {
        let mut counters = zero_rejections();
        counters["truncated"] = json!(2);
        counters["unexpected_source"] = json!(40);
        let text = text(&status(counters));
        let line = text
            .lines()
            .find(|l| l.starts_with("rejected"))
            .unwrap_or_else(|| panic!("no rejection line in\n{text}"));
        assert!(line.contains("42 datagrams"), "{line}");
        assert!(
            line.contains("unexpected_source 40") && line.contains("truncated 2"),
            "{line}"
        );
        assert!(
            !line.contains("duplicate") && !line.contains("empty"),
            "{line}"
        );
    }

    #[test]
    fn status_says_it_is_resynchronising_and_for_how_long() {
        let mut r = status(zero_rejections());
        r.connected = false;
        let text_of = |r: &StatusResult| text(r).lines().next().unwrap_or_default().to_owned();
        assert!(text_of(&r).contains("NOT connected"), "{}", text_of(&r));
        // The endpoint's view is the last measurement's, never the link's quality now.
        assert!(
            text(&r).contains("fri            last measurement: state"),
            "{}",
            text(&r)
        );
        if let Some(f) = &mut r.fri {
            f.resync = Some(fri_api::results::PendingResync {
                kind: ResyncKind::Restart,
                source: "127.0.0.1:49938".parse().unwrap(),
                refused: 420,
                remaining_s: 0.58,
                resync_after_s: 1.0,
            });
        }
        let line = text_of(&r);
        assert!(
            line.contains("RESYNCHRONISING with a restarted controller")
                && line.contains("420 datagrams refused")
                && line.contains("accepted in 0.58 s")
                && line.contains("fri.resync_after_s = 1.00 s"),
            "{line}"
        );
    }

    #[test]
    fn status_says_none_rejected_and_shows_units_and_words() {
        let text = text(&status(zero_rejections()));
        assert!(text.contains("rejected       none"), "{text}");
        assert!(text.contains("q [deg]") && text.contains("28.65"), "{text}");
        assert!(
            text.contains("residual [Nm]") && text.contains("stopped yes"),
            "{text}"
        );
        assert!(!text.contains("-0.00"), "{text}");
    }

    #[test]
    fn status_names_the_robot_model_and_the_identified_arm() {
        let mut r = status(zero_rejections());
        assert!(!text(&r).contains("robot model"), "older daemon: no line");
        r.robot = Some(RobotModelStatus {
            model: "lwr4".into(),
            calibration: None,
        });
        assert!(
            text(&r).contains("robot model    lwr4 nominal"),
            "{}",
            text(&r)
        );
        r.robot = Some(RobotModelStatus {
            model: "lwr4".into(),
            calibration: Some(fri_api::results::ArmCalibration {
                path: "/etc/fri-service/arm.toml".into(),
                logs: vec!["run1.csv".into()],
                duration_s: 25.0,
                residual_rms_nominal: vec![1.32, 0.77, 0.56, 0.8, 1.31, 0.67, 0.27],
                heldout_rms: vec![0.2; 7],
                offset: vec![0.9; 7],
            }),
        });
        let t = text(&r);
        assert!(
            t.contains("robot model    lwr4 identified, /etc/fri-service/arm.toml")
                && t.contains("from run1.csv (25.0 s)")
                && t.contains("nominal 1.32 0.77")
                && t.contains("held-out 0.20"),
            "{t}"
        );
    }
}
