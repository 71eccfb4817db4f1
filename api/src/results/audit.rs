//! The audit trail: one record per safety-relevant change, with who made it. The service logs
//! each as one structured line (target `fri_service::audit`) and streams it to `watch` as the
//! `audit` event.

use serde::{Deserialize, Serialize};

use crate::origin::Origin;
use crate::protocol::ReactionMode;
use crate::results::{ResyncReason, StopCause};

/// One safety-relevant change and its origin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AuditRecord {
    /// When the service made the change, s since the Unix epoch (host clock).
    pub time_unix_s: f64,
    /// Who asked for it.
    pub origin: Origin,
    /// What changed.
    pub change: Change,
    /// Records dropped before this one by the audit log's volume bound (log lines only; every
    /// record still reaches `watch`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub suppressed_before: u64,
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

/// A safety-relevant change.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "what", rename_all = "kebab-case")]
pub enum Change {
    /// A command that changes the arm or the monitor was accepted (before it runs).
    Command {
        /// The command's protocol name (`tare`, `collision`, …).
        command: String,
    },
    /// The collision monitor was armed.
    Armed,
    /// The collision monitor was disarmed: contacts are no longer reacted to.
    Disarmed,
    /// The monitor's thresholds, gains or reaction were set.
    MonitorConfigured {
        /// Detection thresholds, Nm (joints 1..7).
        thresholds: [f64; 7],
        /// Observer gains, 1/s.
        gains: [f64; 7],
        /// Reaction to a contact.
        reaction: ReactionMode,
        /// What makes these settings weaker than the configuration file's (empty: none).
        weaker_than_configuration: Vec<String>,
    },
    /// Calibrated thresholds were installed (`collision calibrate --apply`).
    CalibrationInstalled {
        /// Static thresholds θ₀, Nm.
        thresholds: [f64; 7],
        /// False alarms per hour the calibration was fitted for, whole arm.
        budget_per_hour: f64,
        /// What makes them weaker than the configuration: thresholds at rest above
        /// `[observer] calibration_ceiling_nm`, installed with `allow_weaker` (empty: none).
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        weaker_than_configuration: Vec<String>,
    },
    /// A payload was applied to the monitor (and persisted).
    PayloadApplied {
        /// Mass, kg.
        mass: f64,
        /// Centre of mass in frame 7, m.
        com: [f64; 3],
        /// The check's refusal `force` overrode: the payload may not be the one carried, and a
        /// contact of the difference may pass (absent: the check passed, or an estimate's
        /// `apply`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        forced_past: Option<super::PayloadRefusal>,
    },
    /// The applied payload was removed.
    PayloadCleared,
    /// The payload was declared unknown (`expect-payload`).
    PayloadDeclaredUnknown {
        /// Largest tolerated mass, kg.
        max_mass: f64,
        /// Radius around the flange point that holds the load, m.
        max_radius: f64,
    },
    /// The load of the payload declared unknown was pinned: from now on a change of it is a
    /// contact (`expect-payload`; docs/collision-detection.md §8).
    PayloadPinned {
        /// Pinned mass, kg.
        mass: f64,
        /// Its centre of mass in frame 7, m (`null` for a massless pin).
        com: Option<[f64; 3]>,
        /// What pinned it: `settled`, `grasp-window`, `move` or `samples`.
        by: super::expect_payload::PinnedBy,
    },
    /// The unknown-payload mode ended.
    UnknownPayloadEnded {
        /// Why (`applied`, `ended`, `expired`, …).
        reason: String,
    },
    /// The arm was stopped by the operator.
    Stopped,
    /// The arm was released after a stop or a collision reaction.
    Resumed,
    /// A tare was stored.
    TareStored {
        /// Static samples in it.
        samples: usize,
        /// The load its samples saw, stored anyway with `replace_loaded` (absent: none seen).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        loaded: Option<super::TareLoad>,
    },
    /// The monitor detected a contact.
    Collision {
        /// Isolated link, 1..7.
        link: u32,
        /// Residual at the onset, Nm (joints 1..7).
        residual: [f64; 7],
    },
    /// The service held the arm on its own: the armed collision reaction, or an observer fault
    /// (the monitor could no longer vouch for the arm).
    HeldByService {
        /// Why, with its data.
        cause: StopCause,
        /// Operator-facing text of the cause.
        detail: String,
    },
    /// The service released the arm on its own.
    ReleasedByService {
        /// Why.
        reason: ReleaseReason,
    },
    /// The collision monitor restarted: no contact is detected until its warm-up ends (50 ms).
    MonitorRestarted {
        /// Why.
        reason: ResyncReason,
    },
    /// The controller left command mode during a move and brakes the arm: until the arm rests
    /// (20 ms under 0.02 rad/s, at most 2 s) a contact is detected only when its residual
    /// exceeds the threshold plus this allowance.
    BrakingWatched {
        /// Allowance per joint, Nm (joints 1..7): 20 1/s × Σ_k |M_jk(q)|·|q̇_k| at the loss.
        allowance_nm: [f64; 7],
    },
    /// Settings restored at start from the state directory.
    Restored {
        /// Which file (`monitor.json`, `payload.json`, …).
        file: String,
        /// What makes the restored settings weaker than the configuration file's (empty: none).
        weaker_than_configuration: Vec<String>,
    },
}

/// Why the service released the arm on its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReleaseReason {
    /// The `pause` reaction's pause elapsed: the interrupted move continues.
    PauseElapsed,
    /// The contact a latched `resume` waited for ended.
    ContactEnded,
}

impl std::fmt::Display for Change {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let values = |v: &[f64; 7], digits: usize| {
            v.iter()
                .map(|x| format!("{x:.digits$}"))
                .collect::<Vec<_>>()
                .join(" ")
        };
        match self {
            Change::Command { command } => write!(f, "command `{command}` accepted"),
            Change::Armed => f.write_str("collision monitor armed"),
            Change::Disarmed => f.write_str("collision monitor DISARMED"),
            Change::MonitorConfigured {
                thresholds,
                gains,
                reaction,
                weaker_than_configuration,
            } => {
                write!(
                    f,
                    "monitor configured: thresholds [Nm] {}, gains [1/s] {}, reaction {}",
                    values(thresholds, 2),
                    values(gains, 0),
                    reaction.name()
                )?;
                weaker(f, weaker_than_configuration)
            }
            Change::CalibrationInstalled {
                thresholds,
                budget_per_hour,
                weaker_than_configuration,
            } => {
                write!(
                    f,
                    "calibrated thresholds installed: θ0 [Nm] {} for {budget_per_hour} false alarms/h",
                    values(thresholds, 2)
                )?;
                weaker(f, weaker_than_configuration)
            }
            Change::PayloadApplied {
                mass,
                com,
                forced_past,
            } => {
                write!(
                    f,
                    "payload applied: {mass:.4} kg at ({:.1}, {:.1}, {:.1}) mm in frame 7",
                    com[0] * 1e3,
                    com[1] * 1e3,
                    com[2] * 1e3
                )?;
                match forced_past {
                    Some(r) => write!(f, "; FORCED past the payload check, WEAKER: {r}"),
                    None => Ok(()),
                }
            }
            Change::PayloadCleared => f.write_str("payload cleared"),
            Change::PayloadDeclaredUnknown {
                max_mass,
                max_radius,
            } => write!(
                f,
                "payload declared unknown: up to {max_mass} kg within {max_radius} m of the flange"
            ),
            Change::PayloadPinned { mass, com, by } => {
                write!(f, "unknown payload pinned ({}): {mass:.4} kg", by.name())?;
                match com {
                    Some(c) => write!(
                        f,
                        " at ({:.1}, {:.1}, {:.1}) mm in frame 7",
                        c[0] * 1e3,
                        c[1] * 1e3,
                        c[2] * 1e3
                    ),
                    None => Ok(()),
                }
            }
            Change::UnknownPayloadEnded { reason } => {
                write!(f, "unknown-payload mode ended ({reason})")
            }
            Change::Stopped => f.write_str("arm stopped"),
            Change::Resumed => f.write_str("arm released"),
            Change::TareStored { samples, loaded } => {
                write!(f, "tare stored ({samples} samples)")?;
                match loaded {
                    Some(l) => write!(
                        f,
                        "; it sees a LOAD of {:.4} ± {:.4} kg against {} (stored with replace_loaded)",
                        l.mass_kg,
                        l.mass_std_kg,
                        l.against.describe()
                    ),
                    None => Ok(()),
                }
            }
            Change::Collision { link, residual } => write!(
                f,
                "collision on link {link}, residual [Nm] {}",
                values(residual, 2)
            ),
            Change::HeldByService { detail, .. } => write!(f, "arm held by the service: {detail}"),
            Change::ReleasedByService { reason } => match reason {
                ReleaseReason::PauseElapsed => {
                    f.write_str("arm released by the service: the reaction's pause elapsed")
                }
                ReleaseReason::ContactEnded => f.write_str(
                    "arm released by the service: the contact a latched resume waited for ended",
                ),
            },
            Change::MonitorRestarted { reason } => write!(
                f,
                "collision monitor restarted ({}): blind until its warm-up ends",
                reason.describe()
            ),
            Change::BrakingWatched { allowance_nm } => write!(
                f,
                "the controller brakes the arm after leaving command mode: until it rests, contacts are detected above the thresholds plus [Nm] {}",
                values(allowance_nm, 2)
            ),
            Change::Restored {
                file,
                weaker_than_configuration,
            } => {
                write!(f, "restored from {file}")?;
                weaker(f, weaker_than_configuration)
            }
        }
    }
}

fn weaker(f: &mut std::fmt::Formatter<'_>, what: &[String]) -> std::fmt::Result {
    if what.is_empty() {
        Ok(())
    } else {
        write!(f, "; WEAKER than the configuration: {}", what.join("; "))
    }
}
