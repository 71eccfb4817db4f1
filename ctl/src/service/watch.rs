//! `fri-ctl watch`: the service's events, one line each, until interrupted.

use std::io::{self, Write};

use clap::Args;

use fri_api::ipc::flags;
use fri_api::protocol::Command;
use fri_api::results::{Event, ResyncReason, StopCause, WatchResult};

use super::JsonFlag;
use super::error::controller;
use super::format::fixed;
use super::runner::Operation;

/// Long help of `watch`.
pub(super) const HELP: &str = "\
Stream the service's events until interrupted (Ctrl-C) or the service ends the stream: \
collisions (link, joints, time in s, residual in Nm), stops and their cause with the \
controller's view, resumes, aborted moves, restarts of the collision monitor, and the audit \
trail's changes (who armed, configured, applied). A workflow's progress goes to the client that \
started it (its progress bar), not to watchers. With `--state-every N` also a state line every N cycles (1…100000; at 1 ms, 1000 is \
one line per second) with positions in deg and the residual in Nm. The arm does not move.

With `--json` every event is one JSON line `{\"event\": …, \"data\": …}`.";

/// `fri-ctl watch`.
#[derive(Debug, Clone, Args)]
pub struct WatchArgs {
    /// Also print a state line every N cycles: 1…100000.
    #[arg(long, value_name = "N", value_parser = super::counts::state_every)]
    pub state_every: Option<u32>,
    /// Output format.
    #[command(flatten)]
    pub output: JsonFlag,
}

impl Operation for WatchArgs {
    type Output = WatchResult;

    fn request(&self) -> Result<Command, String> {
        Ok(Command::Watch {
            state_every: self.state_every,
        })
    }

    fn json(&self) -> bool {
        self.output.json
    }

    fn prints_events(&self) -> bool {
        true
    }

    fn print_event(&self, event: &Event, out: &mut dyn Write) -> io::Result<()> {
        print_event(event, out)
    }

    fn print(&self, r: &WatchResult, out: &mut dyn Write) -> io::Result<()> {
        writeln!(out, "watch {}", r.watch)
    }
}

/// Seven values with `digits` decimals, space-separated.
fn values(v: &[f64; 7], digits: usize) -> String {
    v.iter()
        .map(|x| fixed(*x, digits))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The set flags of a state as words.
fn flag_words(bits: u32) -> String {
    let names = [
        (flags::COMMAND_MODE, "command-mode"),
        (flags::MONITOR_ARMED, "armed"),
        (flags::COLLISION, "collision"),
        (flags::STOPPED, "stopped"),
        (flags::PAYLOAD_APPLIED, "payload"),
        (flags::OBSERVER_FAULT, "observer-fault"),
        (flags::MOVING, "moving"),
        (flags::RESIDUAL_INVALID, "residual-invalid"),
    ];
    let set: Vec<&str> = names
        .iter()
        .filter(|(b, _)| bits & b != 0)
        .map(|(_, n)| *n)
        .collect();
    if set.is_empty() {
        "none".to_owned()
    } else {
        set.join(",")
    }
}

/// One event as one line (two with the controller's view).
pub(super) fn print_event(event: &Event, out: &mut dyn Write) -> io::Result<()> {
    match event {
        Event::State(s) => writeln!(
            out,
            "state      cycle {} t = {} s flags {} q [deg] {} residual [Nm] {}",
            s.cycle,
            fixed(s.time_s, 3),
            flag_words(s.flags),
            values(&s.q.map(f64::to_degrees), 2),
            values(&s.residual, 2)
        ),
        Event::Collision(c) => {
            let joints: Vec<String> = c.joints.iter().map(|j| j.to_string()).collect();
            writeln!(
                out,
                "collision  t = {} s cycle {}: contact on link {} (joints {} over threshold) residual [Nm] {}",
                fixed(c.time_s, 3),
                c.cycle,
                c.link,
                joints.join(","),
                values(&c.residual, 2)
            )
        }
        Event::Stopped(s) => {
            let cause = match &s.cause {
                StopCause::Operator => String::new(),
                StopCause::Collision { link, time_s, .. } => {
                    format!(" (link {link} at t = {} s)", fixed(*time_s, 3))
                }
                StopCause::ObserverFault { .. } => String::new(),
            };
            writeln!(out, "stopped    cycle {}: {}{cause}", s.cycle, s.detail)?;
            writeln!(out, "           {}", controller(&s.fri))
        }
        Event::Resumed(r) => writeln!(out, "resumed    cycle {}", r.cycle),
        Event::Watching(w) => match w.cycle {
            Some(c) => writeln!(out, "watching   from cycle {c} (Ctrl-C ends)"),
            None => writeln!(out, "watching   (no measurement yet; Ctrl-C ends)"),
        },
        Event::MoveAborted(m) => {
            writeln!(out, "move-aborted cycle {}: {}", m.cycle, m.detail)?;
            writeln!(out, "           {}", controller(&m.fri))
        }
        Event::MonitorRestarted(m) => {
            let extra = match m.reason {
                ResyncReason::Gap { cycles } | ResyncReason::StoppedInGap { cycles } => {
                    format!(" ({cycles} cycles)")
                }
                ResyncReason::ControllerRestarted => String::new(),
            };
            writeln!(
                out,
                "monitor-restarted cycle {}: {}{extra}; residual invalid until the warm-up ends",
                m.cycle, m.detail
            )
        }
        Event::Audit(a) => writeln!(out, "audit      {}: {}", a.origin, a.change),
        Event::Progress(p) => {
            let phase = serde_json::to_value(p.phase).unwrap_or_default();
            let step = match (p.step, p.of) {
                (Some(s), Some(of)) => format!(" {s}/{of}"),
                _ => String::new(),
            };
            writeln!(out, "progress   {}{step}", phase.as_str().unwrap_or("?"))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fri_api::results::StateLine;

    #[test]
    fn a_state_line_names_its_flags_and_units() {
        let mut out = Vec::new();
        let s = StateLine {
            cycle: 7,
            time_s: 0.007,
            q: [0.0; 7],
            tau: [0.0; 7],
            residual: [f64::NAN; 7],
            flags: flags::COMMAND_MODE | flags::RESIDUAL_INVALID,
        };
        print_event(&Event::State(s), &mut out).unwrap();
        let line = String::from_utf8(out).unwrap();
        assert!(line.starts_with("state"), "{line}");
        assert!(
            line.contains("flags command-mode,residual-invalid"),
            "{line}"
        );
        assert!(line.contains("residual [Nm] n/a"), "{line}");
    }
}
