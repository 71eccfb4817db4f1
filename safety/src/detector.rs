//! Collision detection on the residual: per-joint thresholds scheduled by the motion,
//! hysteresis and debounce.
//!
//! A joint is *over* when |r_j| > θ_j with θ_j = min(θ0_j + c_j·|q̇_j| + Σ_k s_jk·φ_jk, ceiling_j)
//! (φ the motion features of [`crate::envelope`], s the [`ThresholdSchedule`]). A contact starts after
//! `debounce_samples` consecutive samples with at least one joint over (the onset sample is the
//! last of them) and ends after `release_samples` consecutive samples with every
//! |r_j| < release_ratio·θ_j. Samples whose residual was not updated (rejected, resynchronised)
//! leave the state and counters unchanged.

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

use crate::envelope::MotionFeatures;
use crate::error::ConfigError;
use crate::isolation::ContactEstimate;

/// Default collision threshold on every joint \[Nm\] (the paper's 6 Nm).
pub const DEFAULT_THRESHOLD_NM: f64 = 6.0;

/// Set of joints as a bit mask (bit j = joint j, 0-based; N ≤ 32).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct JointSet(pub u32);

impl JointSet {
    /// Whether joint `j` (0-based) is in the set.
    pub fn contains(self, j: usize) -> bool {
        j < 32 && self.0 & (1 << j) != 0
    }
    /// Adds joint `j` (0-based; ignored for j ≥ 32).
    pub fn insert(&mut self, j: usize) {
        if j < 32 {
            self.0 |= 1 << j;
        }
    }
    /// True when no joint is in the set.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }
    /// Highest (most distal) joint index in the set, 0-based.
    pub fn most_distal(self) -> Option<usize> {
        if self.0 == 0 {
            None
        } else {
            Some(31 - self.0.leading_zeros() as usize)
        }
    }
    /// Number of joints in the set.
    pub fn len(self) -> usize {
        self.0.count_ones() as usize
    }
}

/// Threshold scheduling by the motion features of [`crate::envelope`] (all zero: no scheduling):
/// θ_j = θ0_j + c_j·|q̇_j| + noise_j·φ_noise,j + payload_j·φ_payload,j + inertial_j·φ_inertial,j
/// plus gravity_j·φ_gravity,j, at most `ceiling_nm`_j. Fitted by [`crate::calibration`] (θ0 and every coefficient are the
/// extreme-value scale s_j times the envelope's coefficients).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ThresholdSchedule<const N: usize> {
    /// Coefficient of the velocity-noise feature \[Nm per kg·m²\].
    pub velocity_noise: SVector<f64, N>,
    /// Coefficient of the payload's unmodelled dynamics |τ_L,j| (dimensionless).
    pub payload_dynamics: SVector<f64, N>,
    /// Coefficient of the arm's inertial torque |(M q̈)_j| (dimensionless).
    pub inertial: SVector<f64, N>,
    /// Coefficient of the compensated gravity torque |g_L,j(q)| (dimensionless: the static
    /// model error's share).
    pub gravity: SVector<f64, N>,
    /// Largest scheduled threshold per joint \[Nm\] (the service: a quarter of the torque limit;
    /// a larger threshold would leave detection effectively off).
    pub ceiling_nm: SVector<f64, N>,
}

impl<const N: usize> Default for ThresholdSchedule<N> {
    /// No scheduling, no ceiling.
    fn default() -> Self {
        Self {
            velocity_noise: SVector::zeros(),
            payload_dynamics: SVector::zeros(),
            inertial: SVector::zeros(),
            gravity: SVector::zeros(),
            ceiling_nm: SVector::repeat(f64::MAX),
        }
    }
}

impl<const N: usize> ThresholdSchedule<N> {
    /// Whether any model-based feature is scheduled (the monitor then runs a
    /// [`crate::envelope::FeatureTracker`]).
    pub fn uses_model_features(&self) -> bool {
        self.velocity_noise
            .iter()
            .chain(self.payload_dynamics.iter())
            .chain(self.inertial.iter())
            .chain(self.gravity.iter())
            .any(|c| *c != 0.0)
    }

    fn is_valid(&self) -> bool {
        let coefficient = |c: &f64| c.is_finite() && *c >= 0.0;
        self.velocity_noise.iter().all(coefficient)
            && self.payload_dynamics.iter().all(coefficient)
            && self.inertial.iter().all(coefficient)
            && self.gravity.iter().all(coefficient)
            && self.ceiling_nm.iter().all(|c| !c.is_nan() && *c > 0.0)
    }
}

/// Detector configuration for N joints.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DetectorConfig<const N: usize> {
    /// Static thresholds θ0 \[Nm\] per joint.
    pub thresholds_nm: SVector<f64, N>,
    /// Velocity scheduling c \[Nm·s/rad\] per joint: θ = θ0 + c·|q̇| (zero = static threshold).
    pub velocity_coefficients: SVector<f64, N>,
    /// Release level as a fraction of θ (hysteresis), in (0, 1].
    pub release_ratio: f64,
    /// Consecutive samples over threshold before a contact is declared (≥ 1).
    pub debounce_samples: u32,
    /// Consecutive samples below the release level before a contact ends (≥ 1).
    pub release_samples: u32,
    /// Isolation level as a fraction of θ, in (0, 1]: once a contact is detected, the isolated
    /// link is the most distal joint with |r_j| > isolation_ratio·θ_j. With 1.0 this is the
    /// textbook rule; lower values isolate earlier, because at the onset the residual has only
    /// risen part of the way (all joints rise together through K/(s + K)).
    pub isolation_ratio: f64,
    /// Scheduling by the motion features (default: none).
    #[serde(default)]
    pub schedule: ThresholdSchedule<N>,
}

impl<const N: usize> Default for DetectorConfig<N> {
    /// 6 Nm static thresholds, release at 80 % of θ, debounce 1 sample (the onset is the first
    /// sample over θ; the observer's low-pass already smooths the residual), release after 20,
    /// isolation at 50 % of θ.
    fn default() -> Self {
        Self {
            thresholds_nm: SVector::repeat(DEFAULT_THRESHOLD_NM),
            velocity_coefficients: SVector::zeros(),
            release_ratio: 0.8,
            debounce_samples: 1,
            release_samples: 20,
            isolation_ratio: 0.5,
            schedule: ThresholdSchedule::default(),
        }
    }
}

impl<const N: usize> DetectorConfig<N> {
    /// Checks thresholds, coefficients and counts.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for j in 0..N {
            let t = self.thresholds_nm[j];
            let c = self.velocity_coefficients[j];
            if !(t.is_finite() && t > 0.0 && c.is_finite() && c >= 0.0) {
                return Err(ConfigError::Threshold { joint: j });
            }
        }
        if !self.schedule.is_valid() {
            return Err(ConfigError::Schedule);
        }
        let in_unit_interval = |x: f64| x > 0.0 && x <= 1.0;
        if !in_unit_interval(self.release_ratio)
            || !in_unit_interval(self.isolation_ratio)
            || self.debounce_samples == 0
            || self.release_samples == 0
        {
            return Err(ConfigError::Hysteresis);
        }
        Ok(())
    }

    /// Effective thresholds θ0 + c·|q̇| \[Nm\] at joint velocity `qd` \[rad/s\] (no model
    /// features: the arm's inertial and the payload's torque counted as zero).
    pub fn thresholds_at(&self, qd: &SVector<f64, N>) -> SVector<f64, N> {
        self.thresholds_for(&MotionFeatures::from_speed(qd))
    }

    /// Effective thresholds \[Nm\] for the motion features `f` (see [`ThresholdSchedule`]).
    pub fn thresholds_for(&self, f: &MotionFeatures<N>) -> SVector<f64, N> {
        let s = &self.schedule;
        (self.thresholds_nm
            + self.velocity_coefficients.component_mul(&f.speed)
            + s.velocity_noise.component_mul(&f.velocity_noise)
            + s.payload_dynamics.component_mul(&f.payload_dynamics)
            + s.inertial.component_mul(&f.inertial)
            + s.gravity.component_mul(&f.gravity))
        .inf(&s.ceiling_nm)
    }
}

/// A detected collision (emitted once, at the onset).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CollisionEvent<const N: usize> {
    /// Observer cycle of the onset sample.
    pub cycle: u64,
    /// Time of the onset sample since the observer started \[s\].
    pub time_s: f64,
    /// Joints over threshold at the onset.
    pub joints_over: JointSet,
    /// Residual at the onset \[Nm\].
    pub residual: SVector<f64, N>,
    /// Effective thresholds at the onset \[Nm\].
    pub thresholds: SVector<f64, N>,
    /// Isolated link, 0-based (link i moves with joint i): the most distal joint with
    /// |r_j| > isolation_ratio·θ_j at the onset.
    pub isolated_link: usize,
    /// Estimated contact wrench (F \[N\]; moment \[Nm\] about the contact point), base frame, for
    /// contacts isolated on the last link; filled by [`crate::monitor::CollisionMonitor`].
    pub contact_wrench: Option<SVector<f64, 6>>,
    /// The contact fitted through each link's Jacobian (link, point, force, confidence), filled
    /// by [`crate::monitor::CollisionMonitor`]; when present, `isolated_link` is its link.
    #[serde(default)]
    pub contact: Option<ContactEstimate>,
}

/// Detector state after a sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Detection<const N: usize> {
    /// No contact.
    Clear,
    /// Some joint over threshold, debounce not yet satisfied.
    Pending,
    /// A contact started at this sample.
    Onset(CollisionEvent<N>),
    /// Contact continues.
    InContact,
    /// Contact ended at this sample.
    Released {
        /// Contact duration since the onset \[s\].
        duration_s: f64,
        /// Most distal link isolated at any sample of the contact (0-based), a refinement of
        /// the onset's `isolated_link`.
        episode_link: usize,
        /// Peak |r_j| per joint over the contact \[Nm\].
        peak_residual: SVector<f64, N>,
    },
}

impl<const N: usize> Detection<N> {
    /// The onset event, if this sample is one.
    pub fn onset(&self) -> Option<&CollisionEvent<N>> {
        match self {
            Detection::Onset(e) => Some(e),
            _ => None,
        }
    }
}

/// Threshold/hysteresis/debounce state machine.
#[derive(Debug, Clone)]
pub struct CollisionDetector<const N: usize> {
    config: DetectorConfig<N>,
    over_count: u32,
    below_count: u32,
    in_contact: bool,
    onset_time_s: f64,
    events: u64,
    episode_link: usize,
    peak_residual: SVector<f64, N>,
    isolation_levels: Option<SVector<f64, N>>,
}

impl<const N: usize> CollisionDetector<N> {
    /// New detector; refuses an invalid configuration.
    pub fn new(config: DetectorConfig<N>) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(Self {
            config,
            over_count: 0,
            below_count: 0,
            in_contact: false,
            onset_time_s: 0.0,
            events: 0,
            episode_link: 0,
            peak_residual: SVector::zeros(),
            isolation_levels: None,
        })
    }

    /// Sets absolute isolation levels \[Nm\] per joint, used instead of
    /// `isolation_ratio`·θ_j once a contact has been detected: the isolated link is then the most
    /// distal joint with |r_j| > level_j. Detection (thresholds, debounce, release) is unchanged.
    ///
    /// Why: a contact on link i puts no torque on joints distal to i, so any joint whose
    /// residual clearly exceeds its own free-motion level proves the contact is on its link or
    /// beyond. One level for all joints (a fraction of θ) is far above the wrist joints' noise
    /// (≈ 0.1–0.3 Nm) while a 50 N push on the forearm or the tool gives them only a few Nm, so
    /// the textbook rule then names a proximal link. Calibrate the levels as a multiple
    /// (e.g. 2×) of the peak |r_j| of a recorded free-motion run with the final payload estimate.
    /// `None` restores the ratio rule. Refuses non-finite or non-positive levels.
    pub fn set_isolation_levels(
        &mut self,
        levels: Option<SVector<f64, N>>,
    ) -> Result<(), ConfigError> {
        if let Some(l) = &levels
            && let Some(joint) = l.iter().position(|x| !(x.is_finite() && *x > 0.0))
        {
            return Err(ConfigError::IsolationLevel { joint });
        }
        self.isolation_levels = levels;
        Ok(())
    }

    /// The absolute isolation levels \[Nm\], when set.
    pub fn isolation_levels(&self) -> Option<&SVector<f64, N>> {
        self.isolation_levels.as_ref()
    }

    /// The configuration in use.
    pub fn config(&self) -> &DetectorConfig<N> {
        &self.config
    }

    /// Whether a contact is currently active.
    pub fn in_contact(&self) -> bool {
        self.in_contact
    }

    /// Number of onsets since construction.
    pub fn event_count(&self) -> u64 {
        self.events
    }

    /// Returns to the no-contact state.
    pub fn reset(&mut self) {
        self.over_count = 0;
        self.below_count = 0;
        self.in_contact = false;
    }

    /// Joints with |r_j| over the effective threshold at velocity `qd`.
    pub fn joints_over(
        &self,
        residual: &SVector<f64, N>,
        qd: &SVector<f64, N>,
    ) -> (JointSet, SVector<f64, N>) {
        self.joints_over_for(residual, &MotionFeatures::from_speed(qd))
    }

    /// Joints with |r_j| over the effective threshold for the motion features `features`.
    pub fn joints_over_for(
        &self,
        residual: &SVector<f64, N>,
        features: &MotionFeatures<N>,
    ) -> (JointSet, SVector<f64, N>) {
        let thresholds = self.config.thresholds_for(features);
        let mut over = JointSet::default();
        for j in 0..N {
            if residual[j].abs() > thresholds[j] {
                over.insert(j);
            }
        }
        (over, thresholds)
    }

    /// Most distal joint with |r_j| over its isolation level (the absolute level when set,
    /// else isolation_ratio·θ_j), 0-based.
    fn isolate(&self, residual: &SVector<f64, N>, thresholds: &SVector<f64, N>) -> Option<usize> {
        (0..N).rev().find(|&j| {
            let level = match &self.isolation_levels {
                Some(levels) => levels[j],
                None => self.config.isolation_ratio * thresholds[j],
            };
            residual[j].abs() > level
        })
    }

    /// Processes one updated residual `residual` \[Nm\] at velocity `qd` \[rad/s\], observer
    /// cycle `cycle` and time `time_s` \[s\] (thresholds scheduled by the speed only).
    pub fn update(
        &mut self,
        residual: &SVector<f64, N>,
        qd: &SVector<f64, N>,
        cycle: u64,
        time_s: f64,
    ) -> Detection<N> {
        self.update_for(residual, &MotionFeatures::from_speed(qd), cycle, time_s)
    }

    /// Processes one updated residual `residual` \[Nm\] with the motion features `features`
    /// (from a [`crate::envelope::FeatureTracker`]), observer cycle `cycle`, time `time_s` \[s\].
    pub fn update_for(
        &mut self,
        residual: &SVector<f64, N>,
        features: &MotionFeatures<N>,
        cycle: u64,
        time_s: f64,
    ) -> Detection<N> {
        let (over, thresholds) = self.joints_over_for(residual, features);
        if self.in_contact {
            if let Some(link) = self.isolate(residual, &thresholds) {
                self.episode_link = self.episode_link.max(link);
            }
            self.peak_residual = self.peak_residual.sup(&residual.abs());
            let released =
                (0..N).all(|j| residual[j].abs() < self.config.release_ratio * thresholds[j]);
            self.below_count = if released { self.below_count + 1 } else { 0 };
            if self.below_count >= self.config.release_samples {
                self.in_contact = false;
                self.below_count = 0;
                self.over_count = 0;
                return Detection::Released {
                    duration_s: time_s - self.onset_time_s,
                    episode_link: self.episode_link,
                    peak_residual: self.peak_residual,
                };
            }
            return Detection::InContact;
        }
        if over.is_empty() {
            self.over_count = 0;
            return Detection::Clear;
        }
        self.over_count += 1;
        if self.over_count < self.config.debounce_samples {
            return Detection::Pending;
        }
        self.in_contact = true;
        self.below_count = 0;
        self.onset_time_s = time_s;
        self.events += 1;
        let isolated_link = self
            .isolate(residual, &thresholds)
            .or(over.most_distal())
            .unwrap_or(0);
        self.episode_link = isolated_link;
        self.peak_residual = residual.abs();
        Detection::Onset(CollisionEvent {
            cycle,
            time_s,
            joints_over: over,
            residual: *residual,
            thresholds,
            isolated_link,
            contact_wrench: None,
            contact: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn detector(debounce: u32, release: u32) -> CollisionDetector<3> {
        CollisionDetector::new(DetectorConfig {
            thresholds_nm: Vector3::new(6.0, 6.0, 2.0),
            velocity_coefficients: Vector3::new(0.0, 4.0, 0.0),
            release_ratio: 0.5,
            debounce_samples: debounce,
            release_samples: release,
            isolation_ratio: 1.0,
            schedule: ThresholdSchedule::default(),
        })
        .unwrap()
    }

    #[test]
    fn debounce_hysteresis_and_isolation() {
        let mut d = detector(3, 2);
        let v0 = Vector3::zeros();
        let hit = Vector3::new(7.0, 0.0, 2.5);
        assert_eq!(
            d.update(&Vector3::new(5.9, 0.0, 1.9), &v0, 1, 0.001),
            Detection::Clear
        );
        assert_eq!(d.update(&hit, &v0, 2, 0.002), Detection::Pending);
        assert_eq!(d.update(&hit, &v0, 3, 0.003), Detection::Pending);
        let Detection::Onset(event) = d.update(&hit, &v0, 4, 0.004) else {
            panic!("no onset")
        };
        assert_eq!(event.cycle, 4);
        assert_eq!(event.isolated_link, 2);
        assert!(
            event.joints_over.contains(0)
                && !event.joints_over.contains(1)
                && event.joints_over.contains(2)
        );
        // Between release level (3 Nm / 1 Nm) and threshold: contact continues.
        assert_eq!(
            d.update(&Vector3::new(4.0, 0.0, 0.5), &v0, 5, 0.005),
            Detection::InContact
        );
        assert_eq!(
            d.update(&Vector3::new(2.0, 0.0, 0.5), &v0, 6, 0.006),
            Detection::InContact
        );
        let Detection::Released {
            duration_s,
            episode_link,
            peak_residual,
        } = d.update(&Vector3::new(2.0, 0.0, 0.5), &v0, 7, 0.007)
        else {
            panic!("no release")
        };
        assert!((duration_s - 0.003).abs() < 1e-12);
        assert_eq!(episode_link, 2);
        assert_eq!(peak_residual, Vector3::new(7.0, 0.0, 2.5));
        assert_eq!(d.event_count(), 1);
    }

    #[test]
    fn absolute_isolation_levels_name_the_distal_link_without_changing_detection() {
        // Joint 2 carries 0.8 Nm: under the ratio rule (0.5 × 2 Nm) it is ignored and link 0 is
        // named; with a 0.5 Nm level on joint 2 the contact is isolated on link 2.
        let v0 = Vector3::zeros();
        let hit = Vector3::new(7.0, 3.0, 0.8);
        let mut ratio = detector(1, 1);
        let Detection::Onset(e) = ratio.update(&hit, &v0, 1, 0.0) else {
            panic!("no onset")
        };
        assert_eq!(e.isolated_link, 0);
        let mut levels = detector(1, 1);
        levels
            .set_isolation_levels(Some(Vector3::new(1.0, 1.0, 0.5)))
            .unwrap();
        let Detection::Onset(e) = levels.update(&hit, &v0, 1, 0.0) else {
            panic!("no onset")
        };
        assert_eq!(e.isolated_link, 2);
        // Detection is unchanged: below every threshold there is no onset, however far the
        // residual is above the isolation levels.
        let mut quiet = detector(1, 1);
        quiet
            .set_isolation_levels(Some(Vector3::new(0.1, 0.1, 0.1)))
            .unwrap();
        assert_eq!(
            quiet.update(&Vector3::new(5.9, 5.0, 1.9), &v0, 1, 0.0),
            Detection::Clear
        );
        // The episode link follows the levels too.
        let _ = levels.update(&Vector3::new(7.0, 0.4, 0.6), &v0, 2, 0.001);
        let Detection::Released { episode_link, .. } =
            levels.update(&Vector3::zeros(), &v0, 3, 0.002)
        else {
            panic!("no release")
        };
        assert_eq!(episode_link, 2);
        assert!(
            levels
                .set_isolation_levels(Some(Vector3::new(1.0, 0.0, 1.0)))
                .is_err()
        );
        assert!(
            levels
                .set_isolation_levels(Some(Vector3::new(1.0, f64::NAN, 1.0)))
                .is_err()
        );
        assert_eq!(
            levels.isolation_levels(),
            Some(&Vector3::new(1.0, 1.0, 0.5))
        );
        levels.set_isolation_levels(None).unwrap();
        assert!(levels.isolation_levels().is_none());
    }

    #[test]
    fn debounce_restarts_after_a_gap() {
        let mut d = detector(2, 1);
        let v0 = Vector3::zeros();
        let hit = Vector3::new(0.0, 0.0, 3.0);
        assert_eq!(d.update(&hit, &v0, 1, 0.0), Detection::Pending);
        assert_eq!(d.update(&Vector3::zeros(), &v0, 2, 0.0), Detection::Clear);
        assert_eq!(d.update(&hit, &v0, 3, 0.0), Detection::Pending);
        assert!(matches!(d.update(&hit, &v0, 4, 0.0), Detection::Onset(_)));
    }

    #[test]
    fn velocity_scheduled_threshold_raises_the_level() {
        let mut d = detector(1, 1);
        let r = Vector3::new(0.0, 8.0, 0.0);
        assert!(matches!(
            d.update(&r, &Vector3::new(0.0, 0.4, 0.0), 1, 0.0),
            Detection::Onset(_)
        ));
        let mut d = detector(1, 1);
        assert_eq!(
            d.update(&r, &Vector3::new(0.0, -0.6, 0.0), 1, 0.0),
            Detection::Clear
        );
    }

    #[test]
    fn invalid_configurations_are_refused() {
        let mut c = DetectorConfig::<3>::default();
        c.thresholds_nm[1] = f64::NAN;
        assert!(CollisionDetector::new(c).is_err());
        let c = DetectorConfig::<3> {
            release_ratio: 1.5,
            ..Default::default()
        };
        assert!(CollisionDetector::new(c).is_err());
        let c = DetectorConfig::<3> {
            debounce_samples: 0,
            ..Default::default()
        };
        assert!(CollisionDetector::new(c).is_err());
    }
}
