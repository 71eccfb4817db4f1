//! The complete per-cycle pipeline: observer → detector → isolation/identification → reaction.
//!
//! The monitor is *live* (its residual means something and onsets react) only once the observer
//! has run `warmup_s` on consecutive samples since it started or was [restarted]
//! (CollisionMonitor::restart): the velocity filter and the residual start from zero, so the
//! first tens of milliseconds carry start-up transients, not contacts. The service restarts the
//! monitor after a controller restart or a gap too long to bridge, never integrating across it.

use dynamics::Data;
use nalgebra::{SVector, Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::config::ObserverConfig;
use crate::detector::{CollisionDetector, Detection, DetectorConfig};
use crate::envelope::{FeatureTracker, MotionFeatures};
use crate::error::ConfigError;
use crate::fault::Fault;
use crate::isolation::{ContactEstimate, ContactIsolator, LinkSurface, estimate_contact_wrench};
use crate::observer::{MomentumObserver, ObserverInput, ObserverOutput, ObserverStatus};
use crate::payload::PayloadCompensation;
use crate::reaction::{ReactionPolicy, ReactionRequest, ReactionState, ReactionSupervisor};
use dynamics::Model;

/// Default damping λ of the contact-wrench least-squares inverse (J entries in m and 1).
pub const DEFAULT_WRENCH_DAMPING: f64 = 0.01;

/// Configuration of the whole collision monitor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MonitorConfig<const N: usize> {
    /// Observer settings.
    pub observer: ObserverConfig<N>,
    /// Detector settings.
    pub detector: DetectorConfig<N>,
    /// Reaction to a collision (default: pause 2 s, then resume).
    pub reaction: ReactionPolicy,
    /// Reaction to an observer fault (default: stop).
    pub fault_reaction: ReactionPolicy,
    /// Assumed contact point for last-link contacts \[m\], in the last DH frame; `None` = the
    /// flange origin of the model.
    pub contact_point: Option<Vector3<f64>>,
    /// Damping λ of the contact-wrench estimate (0 = plain pseudo-inverse).
    pub wrench_damping: f64,
    /// Samples after a (re)start in which the residual is not trusted, as time \[s\]
    /// (0…10 s; default [`DEFAULT_WARMUP_S`]).
    pub warmup_s: f64,
    /// Link surfaces for the contact fit through the links' Jacobians
    /// ([`ContactIsolator`]); `None`: only the most-distal-joint rule (e.g. for a model whose
    /// geometry is unknown). The LWR's: [`crate::isolation::lwr4_link_surfaces`].
    #[serde(skip)]
    pub link_surfaces: Option<[LinkSurface; N]>,
    /// Ratio of the effective threshold to the residual's noise per joint, θ_j/σ_j (> 0): the
    /// contact fit weighs each joint by 1/σ_j². A calibration sets it to its extreme-value
    /// scale (θ = s·envelope); default [`DEFAULT_THRESHOLD_TO_NOISE`].
    pub threshold_to_noise: SVector<f64, N>,
}

/// Default ratio of a threshold to the residual's noise on its joint (uncalibrated thresholds
/// sit at a few times the free-motion level).
pub const DEFAULT_THRESHOLD_TO_NOISE: f64 = 4.0;

/// Default warm-up after a (re)start \[s\]: 50 ms, twenty residual time constants at the
/// default K_I = 400 1/s, and longer than the velocity filter's settling.
pub const DEFAULT_WARMUP_S: f64 = 0.05;

impl<const N: usize> MonitorConfig<N> {
    /// Defaults around an observer with period `sample_period_s` \[s\] and gain `gain` \[1/s\].
    pub fn new(sample_period_s: f64, gain: f64) -> Self {
        Self {
            observer: ObserverConfig::new(sample_period_s, gain),
            detector: DetectorConfig::default(),
            reaction: ReactionPolicy::default(),
            fault_reaction: ReactionPolicy::Stop,
            contact_point: None,
            wrench_damping: DEFAULT_WRENCH_DAMPING,
            warmup_s: DEFAULT_WARMUP_S,
            link_surfaces: None,
            threshold_to_noise: SVector::repeat(DEFAULT_THRESHOLD_TO_NOISE),
        }
    }
}

/// Result of one monitor cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MonitorOutput<const N: usize> {
    /// Observer result (residual, velocity, status).
    pub observer: ObserverOutput<N>,
    /// Detector result; `None` when the residual was not updated this cycle (state held).
    pub detection: Option<Detection<N>>,
    /// Request for the service, when the reaction state changed this cycle.
    pub reaction: Option<ReactionRequest<N>>,
    /// Reaction state after this cycle.
    pub reaction_state: ReactionState,
    /// False during the warm-up after a (re)start: the residual is not to be trusted or
    /// published, and the detector was not updated.
    pub live: bool,
}

/// Observer + detector + isolation + reaction for N joints; `step` is allocation-free.
#[derive(Debug, Clone)]
pub struct CollisionMonitor<const N: usize> {
    observer: MomentumObserver<N>,
    detector: CollisionDetector<N>,
    supervisor: ReactionSupervisor,
    wrench_data: Data<N>,
    contact_point: Vector3<f64>,
    wrench_damping: f64,
    warmup_samples: u32,
    warmup_left: u32,
    features: Option<FeatureTracker<N>>,
    isolator: Option<ContactIsolator<N>>,
    threshold_to_noise: SVector<f64, N>,
    /// Best contact fit of the running contact and the weighted residual norm it was made at.
    contact: Option<(ContactEstimate, f64)>,
}

impl<const N: usize> CollisionMonitor<N> {
    /// Monitor for the unloaded robot `model`.
    pub fn new(model: Model<N>, config: MonitorConfig<N>) -> Result<Self, ConfigError> {
        if !(config.wrench_damping.is_finite() && config.wrench_damping >= 0.0) {
            return Err(ConfigError::Damping(config.wrench_damping));
        }
        if !(config.warmup_s.is_finite() && (0.0..=10.0).contains(&config.warmup_s)) {
            return Err(ConfigError::Warmup(config.warmup_s));
        }
        if let Some(joint) = config
            .threshold_to_noise
            .iter()
            .position(|x| !(x.is_finite() && *x > 0.0))
        {
            return Err(ConfigError::ThresholdToNoise { joint });
        }
        let period = config.observer.sample_period_s;
        // Validated by the observer below; a bad period yields its error, not ours.
        let warmup_samples = if period.is_finite() && period > 0.0 {
            (config.warmup_s / period).ceil() as u32
        } else {
            0
        };
        let contact_point = config
            .contact_point
            .unwrap_or_else(|| model.flange().translation.vector);
        let wrench_data = Data::new(&model);
        let features = config
            .detector
            .schedule
            .uses_model_features()
            .then(|| FeatureTracker::new(&model, &PayloadCompensation::None));
        let isolator = config
            .link_surfaces
            .as_ref()
            .map(|s| ContactIsolator::new(&model, s));
        Ok(Self {
            observer: MomentumObserver::new(model, config.observer)?,
            detector: CollisionDetector::new(config.detector)?,
            supervisor: ReactionSupervisor::new(config.reaction, config.fault_reaction)?,
            wrench_data,
            contact_point,
            wrench_damping: config.wrench_damping,
            warmup_samples,
            warmup_left: warmup_samples,
            features,
            isolator,
            threshold_to_noise: config.threshold_to_noise,
            contact: None,
        })
    }

    /// Arms (true) or disarms (false) the reaction (see [`ReactionSupervisor::set_armed`]).
    /// Arming also re-arms the detector: a residual already over its threshold is a fresh
    /// onset on the next live sample, so arming into a contact reacts at once.
    pub fn set_armed(&mut self, armed: bool) {
        self.supervisor.set_armed(armed);
        if armed {
            self.detector.reset();
        }
    }

    /// Whether the reaction is armed.
    pub fn is_armed(&self) -> bool {
        self.supervisor.is_armed()
    }

    /// Ends a hold from the service's side (see [`ReactionSupervisor::release`]) and re-arms
    /// the detector, so a contact that is still present is detected again at once.
    pub fn release_reaction(&mut self) {
        self.supervisor.release();
        self.detector.reset();
    }

    /// The service does not hold for this onset (report only): the supervisor is ready for the
    /// next onset, while the detector keeps the running contact until it is released, so one
    /// contact is reported once (not again on every cycle it lasts).
    pub fn pass_reaction(&mut self) {
        self.supervisor.release();
    }

    /// Forgets the observer's state and the detector's latch; the next sample starts a new
    /// warm-up. For a controller restart or a gap that cannot be bridged: integrating across
    /// it would turn the missing samples into a residual step.
    pub fn restart(&mut self) {
        self.observer.reset();
        self.detector.reset();
        if let Some(f) = &mut self.features {
            f.reset();
        }
        self.contact = None;
        self.warmup_left = self.warmup_samples;
    }

    /// The motion features the thresholds were scheduled with at the last step (speed only when
    /// the schedule uses no model features).
    pub fn features(&self) -> Option<&MotionFeatures<N>> {
        self.features.as_ref().map(|f| f.features())
    }

    /// The best contact fit of the running (or last) contact, when link surfaces are set.
    pub fn contact(&self) -> Option<&ContactEstimate> {
        self.contact.as_ref().map(|(c, _)| c)
    }

    /// Whether the residual is trusted (warm-up over).
    pub fn is_live(&self) -> bool {
        self.warmup_left == 0 && self.observer.residual_trusted()
    }

    /// The observer.
    pub fn observer(&self) -> &MomentumObserver<N> {
        &self.observer
    }

    /// Switches the observer's matched filtering on or off: see
    /// [`MomentumObserver::set_matched_torque_filter`].
    pub fn set_matched_torque_filter(&mut self, on: bool) {
        self.observer.set_matched_torque_filter(on);
    }

    /// Per joint, Σ_k |M_jk(q)|·|q̇_k| \[N·m·s\]: see [`MomentumObserver::momentum_bound`].
    pub fn momentum_bound(&mut self, q: &SVector<f64, N>, qd: &SVector<f64, N>) -> SVector<f64, N> {
        self.observer.momentum_bound(q, qd)
    }

    /// The detector.
    pub fn detector(&self) -> &CollisionDetector<N> {
        &self.detector
    }

    /// Sets absolute per-joint isolation levels \[Nm\] (see
    /// [`CollisionDetector::set_isolation_levels`]); detection is unchanged.
    pub fn set_isolation_levels(
        &mut self,
        levels: Option<SVector<f64, N>>,
    ) -> Result<(), ConfigError> {
        self.detector.set_isolation_levels(levels)
    }

    /// Installs a payload estimate (see [`MomentumObserver::set_payload`]).
    pub fn set_payload(&mut self, payload: PayloadCompensation) -> Result<(), Fault> {
        if let Some(f) = &mut self.features
            && payload.validate().is_ok()
        {
            f.set_payload(&payload);
        }
        self.observer.set_payload(payload)
    }

    /// Operator acknowledgement (resume after a stop or an operator hold).
    pub fn acknowledge(&mut self) {
        self.supervisor.acknowledge();
    }

    /// Damped least-squares contact wrench (F \[N\]; moment about the contact point \[Nm\], base
    /// frame) for a contact on the last link at the configured contact point, from the current
    /// residual at configuration `q` \[rad\]. Meaningful once the residual has converged
    /// (t > 5/K_I after the contact started). `None` if the damped system is singular.
    pub fn last_link_wrench(&mut self, q: &SVector<f64, N>) -> Option<Vector6<f64>> {
        let residual = *self.observer.residual();
        estimate_contact_wrench(
            self.observer.model(),
            &mut self.wrench_data,
            q,
            &residual,
            N - 1,
            &self.contact_point,
            self.wrench_damping,
        )
    }

    /// Fits the contact again when the residual has grown by a fifth (in noise units) since the
    /// last fit: a better signal-to-noise ratio, at most a few fits per contact.
    fn refine_contact(
        &mut self,
        q: &SVector<f64, N>,
        residual: &SVector<f64, N>,
        features: &MotionFeatures<N>,
    ) {
        let Some(isolator) = &mut self.isolator else {
            return;
        };
        let noise = self
            .detector
            .config()
            .thresholds_for(features)
            .component_div(&self.threshold_to_noise);
        let strength = residual.component_div(&noise).norm();
        if self
            .contact
            .as_ref()
            .is_some_and(|(_, at)| strength < 1.2 * at)
        {
            return;
        }
        if let Some(c) = isolator.isolate(self.observer.model(), q, residual, &noise) {
            self.contact = Some((c, strength));
        }
    }

    /// Processes one sample.
    pub fn step(&mut self, input: &ObserverInput<N>) -> MonitorOutput<N> {
        self.step_with(input, |_, observed, _| observed.residual)
    }

    /// Processes one sample; the detector (and isolation) sees `explain(input, observer output,
    /// the thresholds scheduled for this motion)` \[Nm\] instead of the observer's residual, e.g. the part of it an
    /// unknown payload does not explain ([`crate::payload_tolerance::PayloadTolerance`]). Called
    /// only when the detector runs (residual updated, warm-up over).
    pub fn step_with(
        &mut self,
        input: &ObserverInput<N>,
        explain: impl FnOnce(&ObserverInput<N>, &ObserverOutput<N>, &SVector<f64, N>) -> SVector<f64, N>,
    ) -> MonitorOutput<N> {
        let observed = self.observer.step(input);
        let mut detection = None;
        let mut onset = None;
        let warming = self.warmup_left > 0;
        if warming && !matches!(observed.status, ObserverStatus::Rejected(_)) {
            self.warmup_left -= 1;
        }
        let features = match &mut self.features {
            Some(tracker) if observed.status.residual_updated() => {
                *tracker.step(&input.q, &observed.velocity, input.dt_s)
            }
            Some(tracker) => *tracker.features(),
            None => MotionFeatures::from_speed(&observed.velocity),
        };
        if observed.status.residual_updated() && !warming {
            // The detector sees what is left to explain, against the thresholds scheduled for
            // this motion (the unknown-payload mode tolerates up to them).
            let thresholds = self.detector.config().thresholds_for(&features);
            let residual = explain(input, &observed, &thresholds);
            let mut d =
                self.detector
                    .update_for(&residual, &features, observed.cycle, observed.time_s);
            if matches!(d, Detection::Onset(_)) {
                self.contact = None;
            }
            if matches!(d, Detection::Onset(_) | Detection::InContact) {
                self.refine_contact(&input.q, &residual, &features);
            }
            if let Detection::Onset(event) = &mut d {
                if let Some((c, _)) = &self.contact {
                    event.contact = Some(*c);
                    event.isolated_link = c.link;
                }
                if event.isolated_link + 1 == N {
                    event.contact_wrench = estimate_contact_wrench(
                        self.observer.model(),
                        &mut self.wrench_data,
                        &input.q,
                        &residual,
                        N - 1,
                        &self.contact_point,
                        self.wrench_damping,
                    );
                }
                onset = Some(*event);
            }
            detection = Some(d);
        }
        let fault = match observed.status {
            ObserverStatus::Rejected(f) | ObserverStatus::Degraded(f) => Some(f),
            _ => None,
        };
        let reaction = self.supervisor.update(
            observed.time_s,
            onset.as_ref(),
            self.detector.in_contact(),
            fault,
        );
        MonitorOutput {
            observer: observed,
            detection,
            reaction,
            reaction_state: self.supervisor.state(),
            live: self.is_live(),
        }
    }
}
