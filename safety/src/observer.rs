//! The payload-compensated generalised-momentum observer (paper eq. 48).
//!
//! r = K_I ( M(q)q̇ − p(0) − ∫ (τ_J + Cᵀ(q, q̇)q̇ − g_L(q) + r) ds ), with p(0) = M(q₀)q̇₀.
//! M and Cᵀq̇ come from the unloaded model (or the model with the payload's full inertia when
//! [`PayloadCompensation::Full`] is set); g_L = g(q) of the unloaded robot (model or controller)
//! plus the payload's gravity Y_L(q)·(m, m·c). The recursion is in [`crate::discretisation`].

use dynamics::{
    Data, Model, compute_generalized_gravity, coriolis_transpose_times_velocity, crba,
    payload_gravity_regressor,
};
use nalgebra::SVector;
use serde::{Deserialize, Serialize};

use crate::config::{GravitySource, ObserverConfig};
use crate::discretisation::ResidualIntegrator;
use crate::error::ConfigError;
use crate::fault::{Fault, FaultLog, Signal};
use crate::payload::PayloadCompensation;
use crate::velocity::{MatchedLowPass, VelocityEstimator};

/// One controller sample as the observer needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObserverInput<const N: usize> {
    /// Measured joint positions q \[rad\].
    pub q: SVector<f64, N>,
    /// Measured link-side joint torques τ_J \[Nm\] (FRI `msrJntTrq`), sign as τ = M q̈ + C q̇ + g.
    pub tau: SVector<f64, N>,
    /// Time since the previous sample \[s\]: the controller's nominal period times the number of
    /// periods elapsed (from its sequence counter), never host receive times.
    pub dt_s: f64,
    /// Measured joint velocities \[rad/s\], if available; otherwise q̇ is estimated from q.
    pub velocity: Option<SVector<f64, N>>,
    /// Controller's unloaded gravity vector \[Nm\] (FRI `data.gravity`), needed with
    /// [`GravitySource::Controller`].
    pub controller_gravity: Option<SVector<f64, N>>,
}

impl<const N: usize> ObserverInput<N> {
    /// A sample with positions \[rad\], torques \[Nm\] and time step \[s\], no velocity or gravity.
    pub fn new(q: SVector<f64, N>, tau: SVector<f64, N>, dt_s: f64) -> Self {
        Self {
            q,
            tau,
            dt_s,
            velocity: None,
            controller_gravity: None,
        }
    }
}

/// What became of one sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum ObserverStatus {
    /// First sample: p(0) = M(q₀)q̇₀ stored, residual zero.
    Initialised,
    /// Residual updated.
    Valid,
    /// Residual updated, but a configuration fault is pending (e.g. a rejected payload estimate:
    /// the previous payload is still in use).
    Degraded(Fault),
    /// First good sample after rejected ones: momentum reference re-anchored, residual held.
    Resynchronised,
    /// Sample rejected; residual held at its last value.
    Rejected(Fault),
}

impl ObserverStatus {
    /// True when the residual was updated from this sample (Valid or Degraded).
    pub fn residual_updated(&self) -> bool {
        matches!(self, ObserverStatus::Valid | ObserverStatus::Degraded(_))
    }

    /// The fault carried by this status, if any.
    pub fn fault(&self) -> Option<Fault> {
        match self {
            ObserverStatus::Degraded(f) | ObserverStatus::Rejected(f) => Some(*f),
            _ => None,
        }
    }
}

/// Result of one observer step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObserverOutput<const N: usize> {
    /// Number of samples seen so far (1 for the first).
    pub cycle: u64,
    /// Sum of accepted time steps since the first sample \[s\].
    pub time_s: f64,
    /// Residual r ≈ τ_ext filtered by K_I/(s + K_I) \[Nm\].
    pub residual: SVector<f64, N>,
    /// Joint velocity used \[rad/s\] (supplied or estimated).
    pub velocity: SVector<f64, N>,
    /// What became of the sample.
    pub status: ObserverStatus,
}

/// Model terms of one sample.
struct Terms<const N: usize> {
    momentum: SVector<f64, N>,
    drive: SVector<f64, N>,
}

/// Generalised-momentum residual observer with payload compensation, for N joints.
#[derive(Debug, Clone)]
pub struct MomentumObserver<const N: usize> {
    config: ObserverConfig<N>,
    unloaded: Model<N>,
    /// The unloaded model carrying the payload's full inertia; built at creation and updated in
    /// place, so that a payload change in the real-time loop does not allocate.
    loaded: Model<N>,
    /// Whether M and Cᵀq̇ come from `loaded` ([`PayloadCompensation::Full`]).
    inertia_loaded: bool,
    data: Data<N>,
    payload: PayloadCompensation,
    payload_gravity: SVector<f64, 4>,
    /// Change of the payload's gravity parameters not yet applied to the residual.
    payload_shift: Option<SVector<f64, 4>>,
    integrator: ResidualIntegrator<N>,
    velocity: VelocityEstimator<N>,
    /// The torque terms through the velocity filter's low-pass stages (`matched_torque_filter`).
    drive_filter: MatchedLowPass<N>,
    faults: FaultLog,
    payload_fault: Option<Fault>,
    cycle: u64,
    time_s: f64,
    started: bool,
    resync_pending: bool,
    previous_q: SVector<f64, N>,
    previous_tau: SVector<f64, N>,
    repeats: u32,
    last_velocity: SVector<f64, N>,
}

impl<const N: usize> MomentumObserver<N> {
    /// Observer on the unloaded robot model `model` with configuration `config`, no payload.
    pub fn new(model: Model<N>, config: ObserverConfig<N>) -> Result<Self, ConfigError> {
        config.validate()?;
        let data = Data::new(&model);
        Ok(Self {
            integrator: ResidualIntegrator::new(
                config.discretisation,
                config.gains,
                config.sample_period_s,
            ),
            velocity: VelocityEstimator::new(config.velocity_filter),
            drive_filter: MatchedLowPass::new(config.velocity_filter),
            config,
            loaded: model.clone(),
            unloaded: model,
            inertia_loaded: false,
            data,
            payload: PayloadCompensation::None,
            payload_gravity: SVector::zeros(),
            payload_shift: None,
            faults: FaultLog::default(),
            payload_fault: None,
            cycle: 0,
            time_s: 0.0,
            started: false,
            resync_pending: false,
            previous_q: SVector::zeros(),
            previous_tau: SVector::zeros(),
            repeats: 0,
            last_velocity: SVector::zeros(),
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &ObserverConfig<N> {
        &self.config
    }

    /// The unloaded robot model.
    pub fn model(&self) -> &Model<N> {
        &self.unloaded
    }

    /// Switches matched filtering of the torque terms on or off from the next sample
    /// (`ObserverConfig::matched_torque_filter`).
    pub fn set_matched_torque_filter(&mut self, on: bool) {
        self.config.matched_torque_filter = on;
    }

    /// Per joint, Σ_k |M_jk(q)|·|q̇_k| \[N·m·s\] on the model in use: a bound of the momentum a
    /// stop from velocity `qd` \[rad/s\] at `q` \[rad\] removes (allocation-free).
    pub fn momentum_bound(&mut self, q: &SVector<f64, N>, qd: &SVector<f64, N>) -> SVector<f64, N> {
        let model = if self.inertia_loaded {
            &self.loaded
        } else {
            &self.unloaded
        };
        crba(model, &mut self.data, q).abs() * qd.abs()
    }

    /// The payload compensation in use.
    pub fn payload(&self) -> &PayloadCompensation {
        &self.payload
    }

    /// Fault counters and the latest fault.
    pub fn faults(&self) -> &FaultLog {
        &self.faults
    }

    /// Pending configuration fault (a rejected payload), if any.
    pub fn payload_fault(&self) -> Option<Fault> {
        self.payload_fault
    }

    /// Clears the fault log (not a pending payload fault: that clears with a valid payload).
    pub fn clear_faults(&mut self) {
        self.faults.clear();
    }

    /// Current residual \[Nm\].
    pub fn residual(&self) -> &SVector<f64, N> {
        self.integrator.residual()
    }

    /// Installs a new payload estimate (allocation-free: the loaded model for
    /// [`PayloadCompensation::Full`] is updated in place). A non-physical estimate (negative mass, non-finite
    /// values) is rejected: the previous payload stays in use, the fault is logged and every
    /// following step reports [`ObserverStatus::Degraded`] until a valid estimate is set.
    /// The momentum reference is re-anchored on the next sample so that switching M does not
    /// produce a step in the residual.
    pub fn set_payload(&mut self, payload: PayloadCompensation) -> Result<(), Fault> {
        if let Err(fault) = payload.validate() {
            self.faults.record(self.cycle, fault);
            self.payload_fault = Some(fault);
            return Err(fault);
        }
        self.payload_fault = None;
        let mass_matrix_changes =
            self.inertia_loaded || matches!(payload, PayloadCompensation::Full(_));
        let parameters = payload.gravity_parameters();
        if self.started {
            // The residual's steady state at rest is g_L − τ: it moves with the gravity term at
            // once (applied on the next sample, where q is known), instead of filtering the step
            // in over 1/K_I; an operator may arm right after applying an estimate.
            let pending = self.payload_shift.unwrap_or_default();
            self.payload_shift = Some(pending + parameters - self.payload_gravity);
        }
        self.payload_gravity = parameters;
        self.inertia_loaded = match &payload {
            PayloadCompensation::Full(p) => {
                self.loaded.load_payload(&self.unloaded, p);
                true
            }
            _ => false,
        };
        if mass_matrix_changes && self.started {
            self.resync_pending = true;
        }
        self.payload = payload;
        Ok(())
    }

    /// Whether a first good sample initialised p(0) since creation or [`Self::reset`].
    pub fn residual_trusted(&self) -> bool {
        self.started
    }

    /// Forgets all state: the next sample re-initialises p(0) and the residual.
    pub fn reset(&mut self) {
        self.started = false;
        self.payload_shift = None;
        self.resync_pending = false;
        self.velocity.reset();
        self.repeats = 0;
        self.time_s = 0.0;
        self.cycle = 0;
        self.integrator.reset(&SVector::zeros());
    }

    fn output(&self, status: ObserverStatus) -> ObserverOutput<N> {
        ObserverOutput {
            cycle: self.cycle,
            time_s: self.time_s,
            residual: *self.integrator.residual(),
            velocity: self.last_velocity,
            status,
        }
    }

    fn reject(&mut self, fault: Fault) -> ObserverOutput<N> {
        self.faults.record(self.cycle, fault);
        if self.started {
            self.resync_pending = true;
        }
        self.output(ObserverStatus::Rejected(fault))
    }

    fn check_input(&mut self, input: &ObserverInput<N>) -> Result<(), Fault> {
        let dt = input.dt_s;
        let nominal = self.config.sample_period_s;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Fault::InvalidTimeStep { dt_s: dt });
        }
        if self.started
            && (dt < self.config.min_dt_factor * nominal
                || dt > self.config.max_dt_factor * nominal)
        {
            return Err(Fault::TimeStepOffNominal {
                dt_s: dt,
                nominal_s: nominal,
            });
        }
        let signals = [
            (Signal::Position, Some(&input.q)),
            (Signal::Torque, Some(&input.tau)),
            (Signal::Velocity, input.velocity.as_ref()),
            (Signal::ControllerGravity, input.controller_gravity.as_ref()),
        ];
        for (signal, values) in signals {
            if let Some(joint) = values.and_then(|v| v.iter().position(|x| !x.is_finite())) {
                return Err(Fault::NonFiniteInput { signal, joint });
            }
        }
        if self.config.gravity_source == GravitySource::Controller
            && input.controller_gravity.is_none()
        {
            return Err(Fault::MissingControllerGravity);
        }
        if let Some(limit) = self.config.stale_limit {
            let identical = self.started
                && input
                    .q
                    .iter()
                    .zip(self.previous_q.iter())
                    .all(|(a, b)| a.to_bits() == b.to_bits())
                && input
                    .tau
                    .iter()
                    .zip(self.previous_tau.iter())
                    .all(|(a, b)| a.to_bits() == b.to_bits());
            self.repeats = if identical {
                self.repeats.saturating_add(1)
            } else {
                0
            };
            self.previous_q = input.q;
            self.previous_tau = input.tau;
            if self.repeats >= limit {
                return Err(Fault::StaleMeasurement {
                    repeated_samples: self.repeats,
                });
            }
        }
        Ok(())
    }

    fn terms(&mut self, input: &ObserverInput<N>, qd: &SVector<f64, N>) -> Result<Terms<N>, Fault> {
        let q = &input.q;
        let dynamic_model = if self.inertia_loaded {
            &self.loaded
        } else {
            &self.unloaded
        };
        let mass_matrix = crba(dynamic_model, &mut self.data, q);
        let momentum = mass_matrix * qd;
        let coriolis_t = coriolis_transpose_times_velocity(dynamic_model, &mut self.data, q, qd);
        let mut gravity = match (self.config.gravity_source, input.controller_gravity) {
            (GravitySource::Controller, Some(g)) => g,
            (GravitySource::Controller, None) => return Err(Fault::MissingControllerGravity),
            (GravitySource::Model, _) => {
                compute_generalized_gravity(&self.unloaded, &mut self.data, q)
            }
        };
        if self.payload_gravity[0] != 0.0 || self.payload_gravity.fixed_rows::<3>(1).norm() != 0.0 {
            gravity +=
                payload_gravity_regressor(&self.unloaded, &mut self.data, q) * self.payload_gravity;
        }
        let mut tau = input.tau;
        if let Some(friction) = &self.config.friction {
            tau -= friction.torque(qd);
        }
        // drive = τ − β with β = g_L − Cᵀq̇.
        let drive = tau - gravity + coriolis_t;
        if !momentum.iter().chain(drive.iter()).all(|x| x.is_finite()) {
            return Err(Fault::NonFiniteModelTerms);
        }
        Ok(Terms { momentum, drive })
    }

    /// Processes one sample (allocation-free, never panics). Faulty samples are rejected with
    /// their fault in the status and the residual held; see [`ObserverStatus`].
    pub fn step(&mut self, input: &ObserverInput<N>) -> ObserverOutput<N> {
        self.cycle += 1;
        if let Err(fault) = self.check_input(input) {
            return self.reject(fault);
        }
        let gap = self.resync_pending;
        let qd = match input.velocity {
            Some(v) => {
                self.velocity.start_at(&input.q, &v);
                v
            }
            None if gap => {
                // After rejected samples the position difference spans an unknown interval:
                // keep the last velocity estimate and restart differencing from here.
                let v = self.last_velocity;
                self.velocity.start_at(&input.q, &v);
                v
            }
            None => self.velocity.update(&input.q, input.dt_s),
        };
        let terms = match self.terms(input, &qd) {
            Ok(t) => t,
            Err(fault) => return self.reject(fault),
        };
        self.last_velocity = qd;
        if let Some(change) = self.payload_shift.take()
            && self.started
        {
            let shift =
                payload_gravity_regressor(&self.unloaded, &mut self.data, &input.q) * change;
            self.integrator.shift(&shift);
            // The torque terms step by −shift in this sample: the matched filter takes the
            // step at once, as the residual does.
            self.drive_filter.offset(&-shift);
        }
        // Matched filtering: the torque terms lag as the velocity estimate in the momentum does,
        // so a fast deceleration (the controller braking) leaves no residual of M·q̈·delay.
        if !self.started || gap {
            self.drive_filter.start_at(&terms.drive);
        }
        // The filter runs always, so that switching it on (`set_matched_torque_filter`) starts
        // from its settled state; the residual, a first-order filter of its input, moves to
        // the matched value within 1/K_I.
        let filtered = self.drive_filter.update(&terms.drive, input.dt_s);
        let drive = if self.config.matched_torque_filter {
            filtered
        } else {
            terms.drive
        };
        if !self.started {
            self.integrator.reset(&terms.momentum);
            self.started = true;
            self.resync_pending = false;
            return self.output(ObserverStatus::Initialised);
        }
        if gap {
            self.integrator.resynchronise(&terms.momentum);
            self.resync_pending = false;
            self.time_s += input.dt_s;
            return self.output(ObserverStatus::Resynchronised);
        }
        self.integrator.update(&terms.momentum, &drive, input.dt_s);
        self.time_s += input.dt_s;
        if !self.integrator.residual().iter().all(|x| x.is_finite()) {
            // Cannot happen with finite inputs and a validated configuration; guard anyway so a
            // NaN never reaches the detector, and restart cleanly.
            self.integrator.reset(&terms.momentum);
            return self.reject(Fault::NonFiniteModelTerms);
        }
        match self.payload_fault {
            Some(f) => self.output(ObserverStatus::Degraded(f)),
            None => self.output(ObserverStatus::Valid),
        }
    }
}
