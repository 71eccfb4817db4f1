//! `expect-payload`: the payload is unknown; the armed monitor detects against what a plausible
//! flange load explains (docs/collision-detection.md, "Estimating with the monitor armed").

use serde::{Deserialize, Serialize};

/// Who declared the payload unknown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DeclaredBy {
    /// The operator's `expect-payload`.
    Operator,
    /// `estimate-payload`, because the applied payload did not explain the residual at its start.
    EstimatePayload,
}

/// The unknown-payload mode (in `status` under `unknown_payload`, and the result of
/// `expect-payload`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UnknownPayload {
    /// Who declared it.
    pub declared_by: DeclaredBy,
    /// Whose request declared it (absent from older daemons).
    #[serde(default)]
    pub origin: Option<crate::origin::Origin>,
    /// Largest plausible payload mass, kg.
    pub max_mass: f64,
    /// Radius around the flange point that holds the payload (its mass and centre of mass), m.
    pub max_radius: f64,
    /// Static samples fitted since the declaration (0: only a plausible load at the current pose
    /// is tolerated).
    pub samples: usize,
    /// Mass of the load fitted to the samples, kg (`null` before the first sample).
    pub mass: Option<f64>,
    /// Its centre of mass in frame 7, m (`null` before the first sample or for a massless fit).
    pub com: Option<[f64; 3]>,
    /// Whether the samples are explained by one flange load within the thresholds (false: a
    /// contact across the poses; the monitor holds the arm until the payload is declared again
    /// or applied).
    pub consistent: bool,
    /// Controller time at which the loop took the declaration, s (the clock of `status`'s
    /// `time_s`; `null` until the loop took it, e.g. while no controller sends).
    #[serde(default)]
    pub declared_at_s: Option<f64>,
    /// End of the grasp window, controller time, s: until then (or until the load has settled)
    /// any plausible flange load is tolerated; `null` until the loop took the declaration.
    #[serde(default)]
    pub grasp_window_end_s: Option<f64>,
    /// When the mode expires unless an estimate is applied or static samples refit the load
    /// (each refit starts the expiry over), controller time, s.
    #[serde(default)]
    pub expires_at_s: Option<f64>,
    /// Seconds until `expires_at_s` from the newest state (`null` when either is unknown).
    #[serde(default)]
    pub expires_in_s: Option<f64>,
    /// The pinned load: after it, any change of the load beyond the thresholds is a contact
    /// (`null` during the grasp window).
    #[serde(default)]
    pub pinned: Option<PinnedPayload>,
}

/// What pinned the load of a payload declared unknown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PinnedBy {
    /// The load changed after the declaration (the grasp) and then stayed settled at rest.
    Settled,
    /// The grasp window ended.
    GraspWindow,
    /// The service started moving the arm (a workflow) during the grasp window: the grasp is
    /// over.
    Move,
    /// Static samples (`estimate-payload`, `tare`) were refitted.
    Samples,
}

impl PinnedBy {
    /// The name as sent (`settled`, `grasp-window`, `samples`).
    pub fn name(&self) -> &'static str {
        match self {
            PinnedBy::Settled => "settled",
            PinnedBy::GraspWindow => "grasp-window",
            PinnedBy::Move => "move",
            PinnedBy::Samples => "samples",
        }
    }
}

/// The load pinned after the grasp, and how much of a change of it goes unseen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PinnedPayload {
    /// Pinned mass, kg.
    pub mass: f64,
    /// Its centre of mass in frame 7, m (`null` for a massless pin: an empty flange).
    pub com: Option<[f64; 3]>,
    /// Largest mass change at that centre of mass (at the flange point for an empty flange)
    /// that stays under every threshold at the pose it was pinned at, kg: a vertical force on
    /// the flange up to this × 9.81 N goes unseen there.
    pub mass_tolerance: f64,
    /// Largest shift of the centre of mass normal to gravity, in its least visible direction,
    /// that stays under every threshold at the pose it was pinned at, m (at most `max_radius`).
    pub com_tolerance: f64,
    /// Whether the centre of mass's height along gravity at the pinning pose is still open: it
    /// follows the current pose within `max_radius` until static samples at a second
    /// orientation determine it (one pose never shows it).
    pub com_height_open: bool,
    /// What pinned it.
    pub by: PinnedBy,
    /// Static samples of the refit that pinned it (`null` unless `by` is `samples`).
    pub samples: Option<u32>,
    /// Controller time of the pin, s.
    pub at_s: f64,
}

/// Result of `expect-payload`: the mode now in force (`null` after `end`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExpectPayloadResult {
    /// The unknown-payload mode, or `null` when it ended.
    pub unknown_payload: Option<UnknownPayload>,
}
