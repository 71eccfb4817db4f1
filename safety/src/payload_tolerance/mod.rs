//! Collision detection while the payload is unknown: the monitor stays armed and detects
//! contacts against the payload torque it predicts.
//!
//! An undeclared payload is, for the observer, a constant external torque: the armed monitor
//! trips as soon as it is picked (the paper's point). Once the operator declares the payload
//! unknown, [`PayloadTolerance`] gives the detector, instead of the observer's residual r, the
//! part of it no plausible flange load explains:
//!
//! - the data are load torques z = Y(q)·θ_c − r (θ_c the payload the observer compensates,
//!   Y the payload gravity regressor): at rest z = Y(q)·θ_true − τ_contact;
//! - **before the first static sample** (the grasp itself) the fit is the plausible load that
//!   best explains z at the current pose alone: force vertical and downward, 0 ≤ m ≤ M, centre
//!   of mass within R of the flange point ([`FlangeLoadBounds`], [`plausible`]); the unexplained
//!   part e = Y θ* − z (and all of an implausible one) is what the detector sees;
//! - **after static samples** ([`PayloadHypothesis`], refitted by the service after every
//!   sample) the fit is over the samples (each weighing [`fit::STATIC_SAMPLE_WEIGHT`] cycles)
//!   plus the current pose, so only what the samples leave open can follow the current pose;
//!   a set of samples that no plausible load explains within the thresholds is itself a
//!   contact (its worst misfit is added to what the detector sees);
//! - **while the service moves the arm**, the payload's inertia, which no gravity fit predicts,
//!   gets an allowance derived from the motion (the move's peak acceleration along its line and
//!   the measured velocities), the mass bound and, once the samples locate it, the centre of
//!   mass ([`inertia`]): the detector sees
//!   sign(e_j)·max(|e_j| − a_j, 0), i.e. the threshold grows by a_j.
//!
//! The payload itself never trips; a contact a flange load cannot explain does, at the
//! detector's thresholds. What is tolerated is in docs/collision-detection.md, "Estimating with
//! the monitor armed". Per-cycle work is fixed-size and allocation-free.

pub mod fit;
mod hypothesis;
mod inertia;
pub mod plausible;

use dynamics::{Data, Model, forward_kinematics, payload_gravity_regressor};
use nalgebra::{SVector, Vector3, Vector4};

use crate::error::ConfigError;
pub use hypothesis::{LoadSample, PayloadHypothesis, fit_hypothesis};
use inertia::{InertiaEnvelope, KnownCentre};
pub use plausible::FlangeLoadBounds;

/// An active declaration: its number and bounds.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Declaration {
    id: u32,
    bounds: FlangeLoadBounds,
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
            moving: false,
            peak_acceleration: SVector::zeros(),
            unexplained: SVector::zeros(),
            allowance: SVector::zeros(),
            load: Vector4::zeros(),
        }
    }

    /// Declares the payload unknown (declaration `id`, a fresh number each time): the samples of
    /// an earlier declaration are forgotten and only a plausible load within `bounds` is
    /// tolerated until samples arrive. Refuses invalid bounds (the mode is then unchanged).
    pub fn declare(&mut self, id: u32, bounds: FlangeLoadBounds) -> Result<(), ConfigError> {
        bounds.validate()?;
        self.declaration = Some(Declaration { id, bounds });
        self.hypothesis = None;
        Ok(())
    }

    /// Ends the mode: the payload is known again (applied, or declared so by the operator).
    pub fn end(&mut self) {
        self.declaration = None;
        self.hypothesis = None;
        self.unexplained = SVector::zeros();
        self.allowance = SVector::zeros();
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

    /// Installs a refitted hypothesis; refused (false) when it belongs to another declaration
    /// or none is active (a late refit never re-enters the mode or mixes payloads).
    pub fn set_hypothesis(&mut self, hypothesis: PayloadHypothesis<N>) -> bool {
        let current = self
            .declaration
            .is_some_and(|d| d.id == hypothesis.declaration);
        if current {
            self.hypothesis = Some(hypothesis);
        }
        current
    }

    /// The motion of this cycle: whether the arm is being moved (or still settling after a
    /// move), and that move's peak acceleration vector \[rad/s²\] (its line times the peak of
    /// its profile, see [`inertia`]).
    pub fn set_motion(&mut self, moving: bool, peak_acceleration: &SVector<f64, N>) {
        self.moving = moving;
        self.peak_acceleration = *peak_acceleration;
    }

    /// The residual \[Nm\] of the last cycle that no plausible load explained (before the
    /// inertia allowance): what a detected contact is reported with.
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
    /// Inactive, it is `residual` itself. Allocation-free.
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
        let (load, mass_bound, centre) = match &self.hypothesis {
            None => {
                let orientation =
                    forward_kinematics(&self.model, &mut self.data, q)[N - 1].rotation;
                let u = fit::gravity_in_last(&orientation, &self.model.gravity());
                let load = fit::fit_at_pose(&y, &z, &w, &self.flange, &u, &bounds);
                (load, bounds.max_mass_kg, None)
            }
            Some(h) => {
                let (hq, gq) = fit::normal_equations(&y, &z, &w);
                let s = fit::STATIC_SAMPLE_WEIGHT;
                let anchor = fit::to_full_coordinates(&self.flange, &h.parameters);
                let load = fit::best_load(
                    &fit::full_frame(&self.flange),
                    &(h.information * s + hq),
                    &(h.weighted_load * s + gq),
                    &anchor,
                    &bounds,
                );
                let located = h
                    .com()
                    .filter(|_| h.com_uncertainty_m < bounds.radius_m)
                    .map(|centre| KnownCentre {
                        centre,
                        radius: h.com_uncertainty_m,
                    });
                (load, h.mass_bound_kg, located)
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
}
