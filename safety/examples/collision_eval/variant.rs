//! Observer/detector settings compared side by side, and the observers built from them.

use dynamics::Model;
use safety::{
    CollisionDetector, DetectorConfig, GravitySource, MomentumObserver, ObserverConfig,
    PayloadCompensation, VelocityFilter,
};

use crate::support::V7;
use crate::world::World;
use crate::{GAIN, T};

/// One observer/detector setting evaluated side by side on the same simulated data.
#[derive(Clone)]
pub struct Variant {
    pub label: String,
    pub gain: f64,
    pub filter: VelocityFilter,
    pub detector: DetectorConfig<7>,
    /// Absolute per-joint isolation levels [Nm] (`CollisionDetector::set_isolation_levels`).
    pub isolation_levels: Option<V7>,
    /// Compensate the estimated payload as a point mass in the full dynamics (M, C, g) instead
    /// of gravity only (eq. 48).
    pub point_mass_dynamics: bool,
}

impl Variant {
    pub fn default_with_gain(gain: f64) -> Self {
        Self {
            label: format!(
                "K = {gain}, θ = 6 Nm, debounce {}",
                DetectorConfig::<7>::default().debounce_samples
            ),
            gain,
            filter: VelocityFilter::default(),
            detector: DetectorConfig::default(),
            isolation_levels: None,
            point_mass_dynamics: false,
        }
    }

    /// This variant's detector.
    pub fn detector(&self) -> CollisionDetector<7> {
        let mut d = CollisionDetector::new(self.detector).unwrap();
        d.set_isolation_levels(self.isolation_levels).unwrap();
        d
    }

    /// Observer with this variant's gain and filter and the run's gravity-only estimate.
    pub fn observer(&self, world: &World) -> MomentumObserver<7> {
        let (model, payload) = (
            &world.nominal,
            if self.point_mass_dynamics {
                world.payload_point_mass()
            } else {
                world.payload()
            },
        );
        let mut config = observer_config();
        config.gains = V7::repeat(self.gain);
        config.velocity_filter = self.filter;
        let mut o = MomentumObserver::new(model.clone(), config).unwrap();
        o.set_payload(payload).unwrap();
        o
    }
}

/// The velocity filter of every observer in this run (`--velocity-cutoff-hz`; unset: the default).
static VELOCITY_FILTER: std::sync::OnceLock<VelocityFilter> = std::sync::OnceLock::new();

/// Sets the velocity filter of every observer built afterwards (once, before the first).
pub fn use_velocity_filter(filter: VelocityFilter) {
    VELOCITY_FILTER
        .set(filter)
        .expect("the velocity filter is chosen once, before any observer is built");
}

/// K_I = `GAIN` (the default), exact ZOH, g(q) from the controller's packet (`data.gravity`, no
/// payload), the run's velocity filter.
pub fn observer_config() -> ObserverConfig<7> {
    let mut config = ObserverConfig::new(T, GAIN);
    config.gravity_source = GravitySource::Controller;
    config.velocity_filter = *VELOCITY_FILTER.get_or_init(VelocityFilter::default);
    config
}

pub fn observer(model: &Model<7>, payload: PayloadCompensation) -> MomentumObserver<7> {
    let mut o = MomentumObserver::new(model.clone(), observer_config()).unwrap();
    o.set_payload(payload).unwrap();
    o
}

/// First-order low-pass K/(s + K) (exact ZOH), to give the controller signal the residual's
/// bandwidth.
pub struct LowPass {
    pub state: V7,
    pub a: f64,
}
impl LowPass {
    pub fn new(gain: f64) -> Self {
        Self {
            state: V7::zeros(),
            a: (-gain * T).exp(),
        }
    }
    pub fn update(&mut self, x: &V7) -> V7 {
        self.state = self.state * self.a + x * (1.0 - self.a);
        self.state
    }
}

/// A candidate setting for the delay targets: gain K \[1/s\], velocity filter, debounce count
/// (θ = 6 Nm and everything else at the detector defaults).
pub fn candidate(gain: f64, filter: VelocityFilter, debounce: u32) -> Variant {
    let filter_label = match filter {
        VelocityFilter::BackwardDifference => "backward difference".to_string(),
        VelocityFilter::FirstOrder { cutoff_hz } => format!("first order {cutoff_hz} Hz"),
        VelocityFilter::SecondOrder { cutoff_hz } => format!("second order {cutoff_hz} Hz"),
    };
    Variant {
        label: format!("K = {gain}, {filter_label}, debounce {debounce}"),
        gain,
        filter,
        detector: DetectorConfig {
            debounce_samples: debounce,
            ..DetectorConfig::default()
        },
        isolation_levels: None,
        point_mass_dynamics: false,
    }
}

/// File-name tag of a variant label.
pub fn variant_tag(label: &str) -> String {
    if label.contains("point mass") {
        format!("K{GAIN}_point_mass_isolation_levels")
    } else if label.contains("isolation levels") {
        format!("K{GAIN}_isolation_levels")
    } else if label.contains("θ = (") {
        format!("K{GAIN}_tuned")
    } else if label.contains("backward") {
        "K500_bd_debounce1".to_string()
    } else {
        label
            .split(',')
            .next()
            .unwrap_or("")
            .replace("K = ", "K")
            .replace(' ', "")
            + if label.contains("debounce 2") {
                "_debounce2"
            } else {
                ""
            }
    }
}
