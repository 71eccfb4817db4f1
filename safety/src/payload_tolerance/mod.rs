//! Collision detection while the payload is unknown: the monitor stays armed and detects
//! contacts against the payload torque it predicts.
//!
//! An undeclared payload is, for the observer, a constant external torque: the armed monitor
//! trips as soon as it is picked (the paper's point). Once the operator declares the payload
//! unknown, [`PayloadTolerance`] gives the detector, instead of the observer's residual r, the
//! part of it the load does not explain:
//!
//! - the data are load torques z = Y(q)·θ_c − r (θ_c the payload the observer compensates,
//!   Y the payload gravity regressor): at rest z = Y(q)·θ_true − τ_contact;
//! - **during the grasp** (from the declaration until the load has settled or the grasp window
//!   has ended, [`GraspTiming`], [`settle`]) the fit is the plausible load that best explains z
//!   at the current pose alone: force vertical and downward, 0 ≤ m ≤ M, centre of mass within R
//!   of the flange point ([`FlangeLoadBounds`], [`plausible`]); the unexplained part
//!   e = Y θ* − z (and all of an implausible one) is what the detector sees;
//! - **once pinned** ([`PinnedLoad`]: the settled load, the load at the window's end, or the
//!   fit of the static samples the service hands over after each one, [`PayloadHypothesis`])
//!   the load may no longer change: the fit is the pinned (m, m·c) plus only what its poses
//!   leave open (after one pose, the centre of mass's height along gravity there), so a change
//!   of the load is a contact at the thresholds; a set of samples that no plausible load
//!   explains within the thresholds is itself a contact (its worst misfit is added to what the
//!   detector sees);
//! - **while the service moves the arm**, the payload's inertia, which no gravity fit predicts,
//!   gets an allowance derived from the motion (the move's peak acceleration along its line and
//!   the measured velocities), the mass bound (the pinned mass plus its tolerance, or the
//!   samples' fit plus three standard deviations) and, once the samples locate it, the centre
//!   of mass ([`inertia`]): the detector sees sign(e_j)·max(|e_j| − a_j, 0), i.e. the threshold
//!   grows by a_j;
//! - **the mode expires** `expire_s` after the declaration or the last refit of static samples
//!   ([`PayloadTolerance::advance`]): the detector sees the residual against the applied payload
//!   again.
//!
//! The payload itself never trips; a contact a flange load cannot explain does, at the
//! detector's thresholds, and after the grasp any change of the load does. What is tolerated,
//! and for how long, is in docs/collision-detection.md §8. Per-cycle work is fixed-size and
//! allocation-free.

pub mod fit;
mod hypothesis;
mod inertia;
mod pin;
pub mod plausible;
pub mod settle;

use dynamics::{Data, Model, forward_kinematics, payload_gravity_regressor};
use nalgebra::{SVector, Vector3, Vector4};

use crate::error::ConfigError;
pub use hypothesis::{LoadSample, PayloadHypothesis, fit_hypothesis};
use inertia::{InertiaEnvelope, KnownCentre};
pub use pin::{PinSource, PinnedLoad};
pub use plausible::FlangeLoadBounds;
pub use settle::GraspTiming;
use settle::SettleTracker;

/// Joint speed \[rad/s\] below which the arm counts as at rest for the settle detection (the
/// service's own rest speed).
pub const AT_REST_SPEED: f64 = 0.02;

/// An active declaration: its number, bounds and times (controller time, s).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Declaration {
    id: u32,
    bounds: FlangeLoadBounds,
    timing: GraspTiming,
    declared_at_s: f64,
    expires_at_s: f64,
}

/// Why the mode ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModeEnd {
    /// A payload was applied (or cleared): the payload is known again.
    Applied,
    /// The operator ended it.
    Ended,
    /// No estimate within the expiry time.
    Expired,
}

/// What was pinned, in a few numbers (for the service's status).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinSummary {
    /// Pinned mass \[kg\].
    pub mass_kg: f64,
    /// Pinned centre of mass \[m\], last DH frame (`None` for a massless pin).
    pub com: Option<Vector3<f64>>,
    /// [`PinnedLoad::mass_tolerance_kg`] \[kg\].
    pub mass_tolerance_kg: f64,
    /// [`PinnedLoad::com_tolerance_m`] \[m\].
    pub com_tolerance_m: f64,
    /// Directions of the load its poses leave open (1 after one pose: the height of the centre
    /// of mass along gravity there).
    pub open_directions: u8,
    /// Controller time of the pin \[s\].
    pub at_s: f64,
    /// What pinned it.
    pub source: PinSource,
}

/// The mode as the service reports it (fixed-size).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToleranceStatus {
    /// The declaration's number.
    pub declaration: u32,
    /// What the load may be.
    pub bounds: FlangeLoadBounds,
    /// Controller time of the declaration \[s\].
    pub declared_at_s: f64,
    /// End of the grasp window \[s\] (controller time): the load may change until then, or
    /// until it has settled.
    pub grasp_window_end_s: f64,
    /// When the mode expires \[s\] (controller time) unless static samples are refitted before.
    pub expires_at_s: f64,
    /// The pinned load (`None` during the grasp).
    pub pinned: Option<PinSummary>,
}

/// The monitor's view of an unknown payload (see the module documentation).
#[derive(Debug, Clone)]
pub struct PayloadTolerance<const N: usize> {
    model: Model<N>,
    data: Data<N>,
    inertia: InertiaEnvelope<N>,
    flange: Vector3<f64>,
    declaration: Option<Declaration>,
    hypothesis: Option<PayloadHypothesis<N>>,
    pinned: Option<PinnedLoad>,
    settle: SettleTracker,
    now_s: f64,
    changed: bool,
    last_end: Option<(u32, ModeEnd)>,
    moving: bool,
    peak_acceleration: SVector<f64, N>,
    unexplained: SVector<f64, N>,
    allowance: SVector<f64, N>,
    load: Vector4<f64>,
}

impl<const N: usize> PayloadTolerance<N> {
    /// Inactive, for the unloaded robot `model` (not real-time: copies the model twice).
    pub fn new(model: &Model<N>) -> Self {
        Self {
            data: Data::new(model),
            inertia: InertiaEnvelope::new(model),
            flange: model.flange().translation.vector,
            model: model.clone(),
            declaration: None,
            hypothesis: None,
            pinned: None,
            settle: SettleTracker::new(),
            now_s: 0.0,
            changed: false,
            last_end: None,
            moving: false,
            peak_acceleration: SVector::zeros(),
            unexplained: SVector::zeros(),
            allowance: SVector::zeros(),
            load: Vector4::zeros(),
        }
    }

    /// Declares the payload unknown at controller time `now_s` (declaration `id`, a fresh number
    /// each time): the samples and the pin of an earlier, ended declaration are forgotten; a
    /// plausible load within `bounds` is tolerated until it is pinned (`timing`). Refuses invalid
    /// bounds or timing, and any declaration while one is active
    /// ([`ConfigError::AlreadyDeclared`]: the grasp window opens once per declaration, the pin
    /// and the expiry stay); the mode is then unchanged.
    pub fn declare(
        &mut self,
        id: u32,
        bounds: FlangeLoadBounds,
        timing: GraspTiming,
        now_s: f64,
    ) -> Result<(), ConfigError> {
        if let Some(d) = self.declaration {
            return Err(ConfigError::AlreadyDeclared { active: d.id });
        }
        bounds.validate()?;
        timing.validate()?;
        self.declaration = Some(Declaration {
            id,
            bounds,
            timing,
            declared_at_s: now_s,
            expires_at_s: now_s + timing.expire_s,
        });
        self.now_s = self.now_s.max(now_s);
        self.hypothesis = None;
        self.pinned = None;
        self.settle = SettleTracker::new();
        self.changed = true;
        Ok(())
    }

    /// Ends the mode (`reason`): the payload is the applied one again.
    pub fn end(&mut self, reason: ModeEnd) {
        if let Some(d) = self.declaration.take() {
            self.last_end = Some((d.id, reason));
            self.changed = true;
        }
        self.hypothesis = None;
        self.pinned = None;
        self.unexplained = SVector::zeros();
        self.allowance = SVector::zeros();
    }

    /// Advances the clock to controller time `now_s` (every cycle, before the monitor steps);
    /// ends an expired mode and returns its declaration's number then.
    pub fn advance(&mut self, now_s: f64) -> Option<u32> {
        self.now_s = now_s;
        let d = self.declaration?;
        (now_s >= d.expires_at_s).then(|| {
            self.end(ModeEnd::Expired);
            d.id
        })
    }

    /// Whether the payload is declared unknown.
    pub fn is_active(&self) -> bool {
        self.declaration.is_some()
    }

    /// The active declaration's number and bounds.
    pub fn declaration(&self) -> Option<(u32, FlangeLoadBounds)> {
        self.declaration.map(|d| (d.id, d.bounds))
    }

    /// The hypothesis in use (`None` before the first static sample).
    pub fn hypothesis(&self) -> Option<&PayloadHypothesis<N>> {
        self.hypothesis.as_ref()
    }

    /// The pinned load (`None` during the grasp or when inactive).
    pub fn pinned(&self) -> Option<&PinnedLoad> {
        self.pinned.as_ref()
    }

    /// The last end of the mode: the declaration's number and why.
    pub fn last_end(&self) -> Option<(u32, ModeEnd)> {
        self.last_end
    }

    /// Whether the mode changed (declared, pinned, re-pinned, ended) since the last call.
    pub fn take_changed(&mut self) -> bool {
        std::mem::take(&mut self.changed)
    }

    /// The mode for the service's status (`None` when inactive).
    pub fn status(&self) -> Option<ToleranceStatus> {
        let d = self.declaration?;
        Some(ToleranceStatus {
            declaration: d.id,
            bounds: d.bounds,
            declared_at_s: d.declared_at_s,
            grasp_window_end_s: d.declared_at_s + d.timing.grasp_window_s,
            expires_at_s: d.expires_at_s,
            pinned: self.pinned.as_ref().map(|p| PinSummary {
                mass_kg: p.mass_kg(),
                com: p.com(),
                mass_tolerance_kg: p.mass_tolerance_kg,
                com_tolerance_m: p.com_tolerance_m,
                open_directions: p.open_directions().len() as u8,
                at_s: p.at_s,
                source: p.source,
            }),
        })
    }

    /// Installs a refitted hypothesis and pins its load (the samples' fit; the expiry starts
    /// over); refused (false) when it belongs to another declaration or none is active (a late
    /// refit never re-enters the mode or mixes payloads).
    pub fn set_hypothesis(&mut self, hypothesis: PayloadHypothesis<N>) -> bool {
        let Some(d) = self
            .declaration
            .as_mut()
            .filter(|d| d.id == hypothesis.declaration)
        else {
            return false;
        };
        d.expires_at_s = d.expires_at_s.max(self.now_s + d.timing.expire_s);
        self.pinned = Some(PinnedLoad::new(
            hypothesis.parameters,
            hypothesis.information,
            self.now_s,
            PinSource::Samples(hypothesis.samples),
        ));
        self.hypothesis = Some(hypothesis);
        self.changed = true;
        true
    }

    /// The monitor restarted (a gap in the controller's cycles, a controller restart, a loss
    /// of command mode): the load may have changed while no fit was made, so the stretch at
    /// rest before it is never pinned (not by a move either) and the settle watch starts over
    /// at the first rest after it. A pinned load stays.
    pub fn interrupt(&mut self) {
        self.settle.interrupt();
    }

    /// The service starts moving the arm: the grasp is over. During the grasp window the load
    /// of the last stretch at rest is pinned now if it was steady for the settle time; a load
    /// still changing (a grasp the move interrupted, the residual still rising) pins nothing:
    /// the settle watch after the move or the window's end pins then. A pinned load stays.
    pub fn end_grasp(&mut self) {
        let Some(declaration) = self.declaration.filter(|_| self.pinned.is_none()) else {
            return;
        };
        if let Some((parameters, information)) =
            self.settle.last_settled(declaration.timing.settle_s)
        {
            self.pinned = Some(PinnedLoad::new(
                parameters,
                information,
                self.now_s,
                PinSource::Move,
            ));
            self.changed = true;
        }
    }

    /// The motion of this cycle: whether the arm is being moved (or still settling after a
    /// move), and that move's peak acceleration vector \[rad/s²\] (its line times the peak of
    /// its profile, see [`inertia`]).
    pub fn set_motion(&mut self, moving: bool, peak_acceleration: &SVector<f64, N>) {
        self.moving = moving;
        self.peak_acceleration = *peak_acceleration;
    }

    /// The residual \[Nm\] of the last cycle that the load did not explain (before the inertia
    /// allowance): what a detected contact is reported with.
    pub fn unexplained(&self) -> &SVector<f64, N> {
        &self.unexplained
    }

    /// The inertia allowance \[Nm\] of the last cycle (zero at rest).
    pub fn allowance(&self) -> &SVector<f64, N> {
        &self.allowance
    }

    /// The load fitted in the last cycle: (m \[kg\], m·c \[kg·m\]) in the last DH frame.
    pub fn load(&self) -> &Vector4<f64> {
        &self.load
    }

    /// What the detector sees this cycle, from the observer's residual `residual` \[Nm\] at
    /// positions `q` \[rad\] and velocities `qd` \[rad/s\], with the observer compensating the
    /// gravity parameters `applied` (m, m·c) and the detector's thresholds `thresholds` \[Nm\].
    /// Inactive, it is `residual` itself. Pins the load once it has settled after the grasp or
    /// the grasp window has ended. Allocation-free.
    pub fn contact_residual(
        &mut self,
        q: &SVector<f64, N>,
        qd: &SVector<f64, N>,
        residual: &SVector<f64, N>,
        applied: &Vector4<f64>,
        thresholds: &SVector<f64, N>,
    ) -> SVector<f64, N> {
        let Some(declaration) = self.declaration else {
            return *residual;
        };
        let bounds = declaration.bounds;
        let w = fit::weights(thresholds);
        let y = payload_gravity_regressor(&self.model, &mut self.data, q);
        let z = y * applied - residual;
        let unevaluated = self.pinned.as_ref().is_some_and(|p| !p.evaluated());
        let u = if self.pinned.is_none() || unevaluated {
            let orientation = forward_kinematics(&self.model, &mut self.data, q)[N - 1].rotation;
            fit::gravity_in_last(&orientation, &self.model.gravity())
        } else {
            Vector3::z()
        };
        if let Some(pin) = self.pinned.as_mut().filter(|p| !p.evaluated()) {
            pin.evaluate(&y, &u, thresholds, &self.flange, &bounds);
            self.changed = true;
        }
        let (load, mass_bound, centre) = match (&self.pinned, &self.hypothesis) {
            (Some(pin), hypothesis) => {
                let load = pin.fit(&y, &z, &w, &self.flange, &bounds);
                match hypothesis {
                    Some(h) => {
                        let located = h
                            .com()
                            .filter(|_| h.com_uncertainty_m < bounds.radius_m)
                            .map(|centre| KnownCentre {
                                centre,
                                radius: h.com_uncertainty_m,
                            });
                        (load, h.mass_bound_kg, located)
                    }
                    None => {
                        let bound = (pin.mass_kg() + pin.mass_tolerance_kg).min(bounds.max_mass_kg);
                        (load, bound, None)
                    }
                }
            }
            (None, _) => {
                let load = fit::fit_at_pose(&y, &z, &w, &self.flange, &u, &bounds);
                self.grasp(&load, &y, &w, qd, thresholds, &declaration);
                (load, bounds.max_mass_kg, None)
            }
        };
        let mut unexplained = y * load - z;
        if let Some(h) = self.hypothesis.as_ref().filter(|h| !h.consistent) {
            for j in 0..N {
                if h.worst_misfit[j].abs() > unexplained[j].abs() {
                    unexplained[j] = h.worst_misfit[j];
                }
            }
        }
        self.allowance = if self.moving {
            self.inertia.allowance(
                q,
                qd,
                &self.peak_acceleration,
                mass_bound,
                bounds.radius_m,
                centre,
            )
        } else {
            SVector::zeros()
        };
        self.load = load;
        self.unexplained = unexplained;
        unexplained.zip_map(&self.allowance, |e, a| e.signum() * (e.abs() - a).max(0.0))
    }

    /// During the grasp: watches the fitted `load` (regressor `y`, weights `w`) and pins it
    /// once it has settled after a change, or at the end of the grasp window (from the next
    /// cycle on).
    fn grasp(
        &mut self,
        load: &Vector4<f64>,
        y: &nalgebra::SMatrix<f64, N, 4>,
        w: &SVector<f64, N>,
        qd: &SVector<f64, N>,
        thresholds: &SVector<f64, N>,
        declaration: &Declaration,
    ) {
        let at_rest = !self.moving && qd.amax() < AT_REST_SPEED;
        let now = self.now_s;
        let timing = declaration.timing;
        let settled = self
            .settle
            .observe(load, y, w, thresholds, at_rest, now, timing.settle_s);
        let pin = match settled {
            Some((parameters, information)) => Some((parameters, information, PinSource::Settled)),
            None if now >= declaration.declared_at_s + timing.grasp_window_s => {
                // The window is over: the load of the last stretch at rest, or this cycle's.
                let (parameters, information) = self
                    .settle
                    .last()
                    .unwrap_or_else(|| (*load, fit::normal_equations(y, &SVector::zeros(), w).0));
                Some((parameters, information, PinSource::GraspWindow))
            }
            None => None,
        };
        if let Some((parameters, information, source)) = pin {
            self.pinned = Some(PinnedLoad::new(parameters, information, now, source));
            self.changed = true;
        }
    }
}

#[cfg(test)]
mod tests;
