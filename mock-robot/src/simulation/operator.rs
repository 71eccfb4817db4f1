//! What an operator does to the running simulation between two cycles (the control socket's
//! requests, or a test): hand a payload to the arm or take it away, push a link, stop command
//! mode from the pendant, restart the controller.

use std::fmt;

use dynamics::InertialParameters;

use super::{MAX_PUSHES, Simulation};
use crate::config::PayloadSpec;
use crate::contact::{ContactProfile, ContactSpec};
use crate::krl::FriState;
use crate::models::payload_parameters;

/// Heaviest payload an operator may attach, kg (the LWR 4+ is rated for 7 kg; twice that lets a
/// test overload it on purpose).
pub const MAX_PAYLOAD_KG: f64 = 14.0;
/// Farthest payload centre of mass from the flange frame's origin, per axis, m.
pub const MAX_PAYLOAD_COM_M: f64 = 0.5;
/// Largest push force, N (a person's hard shove; the scenario files allow more).
pub const MAX_PUSH_FORCE_N: f64 = 500.0;
/// Longest push, s.
pub const MAX_PUSH_DURATION_S: f64 = 60.0;

/// A request to the running simulation.
#[derive(Debug, Clone, PartialEq)]
pub enum OperatorCommand {
    /// Attach a payload of `mass_kg` with its centre of mass at `com_m` (frame 7, m); inertia
    /// of the default solid cylinder (docs/mock-robot.md). Replaces an attached one.
    Attach {
        /// Mass, kg, in (0, [`MAX_PAYLOAD_KG`]].
        mass_kg: f64,
        /// Centre of mass in DH frame 7, m, each within ±[`MAX_PAYLOAD_COM_M`].
        com_m: [f64; 3],
    },
    /// Take the payload off.
    Detach,
    /// Push `link` (1..=7) at `point_m` (link frame, m) with `profile`, starting now.
    Push {
        /// Link, 1..=7.
        link: usize,
        /// Point in the link's DH frame, m.
        point_m: [f64; 3],
        /// Force time profile (base frame).
        profile: ContactProfile,
    },
    /// Stop command mode from the pendant (reason 8); nothing to do in monitor mode.
    MonitorMode,
    /// Restart the controller (sequence counter, statistics, KRL program).
    Restart,
}

/// Why a request was not carried out.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OperatorError {
    /// A field is out of its range.
    #[error("{field}: {value} is out of range; {range}")]
    OutOfRange {
        /// The field, as the request names it.
        field: &'static str,
        /// The value given.
        value: String,
        /// The allowed range, in words.
        range: String,
    },
    /// Every slot for pushes is used.
    #[error("push refused: {MAX_PUSHES} pushes were made in this run already; restart mock-robot")]
    TooManyPushes,
}

/// What a carried-out request did, at which simulation time.
#[derive(Debug, Clone, PartialEq)]
pub struct Applied {
    /// Simulation time, s.
    pub time_s: f64,
    /// What happened, in words.
    pub what: Outcome,
}

/// What a request did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Outcome {
    /// A payload is attached (mass kg, CoM m).
    Attached(f64, [f64; 3]),
    /// The payload was taken off (false: there was none).
    Detached(bool),
    /// A push started (its contact index in `contacts()`).
    Pushed(usize),
    /// Command mode was stopped (false: the controller was in monitor mode already).
    Stopped(bool),
    /// The controller restarted.
    Restarted,
}

impl fmt::Display for Applied {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "t = {:.3} s: ", self.time_s)?;
        match self.what {
            Outcome::Attached(m, c) => write!(
                f,
                "payload attached: {m:.3} kg at ({:.3}, {:.3}, {:.3}) m",
                c[0], c[1], c[2]
            ),
            Outcome::Detached(true) => write!(f, "payload detached"),
            Outcome::Detached(false) => write!(f, "no payload was attached; nothing to detach"),
            Outcome::Pushed(i) => write!(f, "push started (contact {i})"),
            Outcome::Stopped(true) => write!(f, "command mode stopped from the pendant (reason 8)"),
            Outcome::Stopped(false) => write!(f, "already in monitor mode; nothing to stop"),
            Outcome::Restarted => write!(f, "controller restarted"),
        }
    }
}

fn out_of_range(field: &'static str, value: impl fmt::Display, range: &str) -> OperatorError {
    OperatorError::OutOfRange {
        field,
        value: value.to_string(),
        range: range.to_owned(),
    }
}

impl OperatorCommand {
    /// Checks every field against its range.
    pub fn validate(&self) -> Result<(), OperatorError> {
        match self {
            Self::Attach { mass_kg, com_m } => {
                if !(mass_kg.is_finite() && *mass_kg > 0.0 && *mass_kg <= MAX_PAYLOAD_KG) {
                    return Err(out_of_range(
                        "mass_kg",
                        mass_kg,
                        &format!("a payload weighs more than 0 and at most {MAX_PAYLOAD_KG} kg"),
                    ));
                }
                check_vector("com_m", com_m, MAX_PAYLOAD_COM_M, "m")
            }
            Self::Push {
                link,
                point_m,
                profile,
            } => {
                if !(1..=7).contains(link) {
                    return Err(out_of_range("link", link, "links are 1..=7"));
                }
                check_vector("point_m", point_m, 0.5, "m")?;
                check_profile(profile)
            }
            Self::Detach | Self::MonitorMode | Self::Restart => Ok(()),
        }
    }
}

fn check_vector(
    field: &'static str,
    v: &[f64; 3],
    max: f64,
    unit: &str,
) -> Result<(), OperatorError> {
    if v.iter().all(|c| c.is_finite() && c.abs() <= max) {
        Ok(())
    } else {
        Err(out_of_range(
            field,
            format!("{v:?}"),
            &format!("each component within ±{max} {unit}"),
        ))
    }
}

fn check_duration(d: f64) -> Result<(), OperatorError> {
    if d.is_finite() && d > 0.0 && d <= MAX_PUSH_DURATION_S {
        Ok(())
    } else {
        Err(out_of_range(
            "profile.duration_s",
            d,
            &format!("more than 0 and at most {MAX_PUSH_DURATION_S} s"),
        ))
    }
}

fn check_direction(field: &'static str, v: &[f64; 3]) -> Result<(), OperatorError> {
    let norm = v.iter().map(|c| c * c).sum::<f64>().sqrt();
    if v.iter().all(|c| c.is_finite()) && norm > 1e-9 && norm <= 1e6 {
        Ok(())
    } else {
        Err(out_of_range(
            field,
            format!("{v:?}"),
            "a direction: finite, not zero",
        ))
    }
}

fn check_profile(profile: &ContactProfile) -> Result<(), OperatorError> {
    match profile {
        ContactProfile::HalfSine {
            peak_force_n,
            duration_s,
        } => {
            let norm = peak_force_n.iter().map(|c| c * c).sum::<f64>().sqrt();
            if !(peak_force_n.iter().all(|c| c.is_finite()) && norm <= MAX_PUSH_FORCE_N) {
                return Err(out_of_range(
                    "profile.peak_force_n",
                    format!("{peak_force_n:?}"),
                    &format!("a force of at most {MAX_PUSH_FORCE_N} N"),
                ));
            }
            check_duration(*duration_s)
        }
        ContactProfile::Ramp {
            direction,
            rate_n_per_s,
            max_force_n,
            duration_s,
        } => {
            check_direction("profile.direction", direction)?;
            if !(rate_n_per_s.is_finite() && *rate_n_per_s > 0.0 && *rate_n_per_s <= 1e5) {
                return Err(out_of_range(
                    "profile.rate_n_per_s",
                    rate_n_per_s,
                    "more than 0 and at most 100000 N/s",
                ));
            }
            if !(max_force_n.is_finite() && (0.0..=MAX_PUSH_FORCE_N).contains(max_force_n)) {
                return Err(out_of_range(
                    "profile.max_force_n",
                    max_force_n,
                    &format!("0 to {MAX_PUSH_FORCE_N} N"),
                ));
            }
            check_duration(*duration_s)
        }
        ContactProfile::Wall {
            normal,
            plane_point_m,
            stiffness_n_per_m,
            duration_s,
        } => {
            check_direction("profile.normal", normal)?;
            if let Some(p) = plane_point_m {
                check_vector("profile.plane_point_m", p, 2.0, "m")?;
            }
            if !(stiffness_n_per_m.is_finite() && (1e3..=1e6).contains(stiffness_n_per_m)) {
                return Err(out_of_range(
                    "profile.stiffness_n_per_m",
                    stiffness_n_per_m,
                    "1000 to 1000000 N/m",
                ));
            }
            check_duration(*duration_s)
        }
    }
}

impl Simulation {
    /// Carries out `command` now, between two cycles (validated first; nothing changes on an
    /// error). Allocation-free.
    pub fn operate(&mut self, command: &OperatorCommand) -> Result<Applied, OperatorError> {
        command.validate()?;
        let what = match command {
            OperatorCommand::Attach { mass_kg, com_m } => {
                let payload: InertialParameters = payload_parameters(&PayloadSpec {
                    mass_kg: *mass_kg,
                    com_m: *com_m,
                    inertia_about_com: None,
                    attached_at_start: true,
                    events: Vec::new(),
                });
                self.arm.attach_payload(&payload);
                Outcome::Attached(*mass_kg, *com_m)
            }
            OperatorCommand::Detach => {
                let was = self.arm.payload().is_some();
                self.arm.set_payload_attached(false);
                Outcome::Detached(was)
            }
            OperatorCommand::Push {
                link,
                point_m,
                profile,
            } => {
                let spec = ContactSpec {
                    link: *link,
                    point_m: *point_m,
                    // The force starts with the next physics substep.
                    onset_s: self.time_s,
                    profile: profile.clone(),
                };
                let index = self
                    .arm
                    .add_contact(&spec)
                    .ok_or(OperatorError::TooManyPushes)?;
                Outcome::Pushed(index)
            }
            OperatorCommand::MonitorMode => {
                let was_command = self.krl.state() == FriState::Command;
                self.operator_stop();
                Outcome::Stopped(was_command)
            }
            OperatorCommand::Restart => {
                self.restart_controller();
                Outcome::Restarted
            }
        };
        Ok(Applied {
            time_s: self.time_s,
            what,
        })
    }
}
