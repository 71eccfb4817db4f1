//! When the grasp is over: the declaration's timing and the settle detection of the apparent
//! load.
//!
//! The load may change only at the grasp. After the declaration the fitted load is watched at
//! rest: a stretch ("segment") lasts while the fit stays within [`SETTLE_BAND`] of the
//! segment's first fit; a larger deviation starts a new segment. The load has settled when a
//! segment that differs from the declaration's load by more than the band (the grasp happened)
//! has lasted the settle time: it is pinned to the segment's fits averaged over the last tenth
//! of the settle time ([`PIN_AVERAGE_SHARE`]). A real grasp (the load
//! attached over 0.1–1 s, then static) changes the fit by more than the band every few tens of
//! milliseconds while it lasts, so no segment settles before it is over. A push that comes and
//! goes returns to the declaration's load and pins nothing. A move suspends the watch (the
//! fit's open direction follows the pose, which is no change of the load); the first stretch at
//! rest after it starts over from its own load, so a grasp during a move is pinned only at the
//! grasp window's end. A restart of the monitor (a gap, a loss of command mode) is treated as a
//! move: the grasp may have happened while no fit was made. Allocation-free, fixed-size.

use nalgebra::{Matrix4, SMatrix, SVector, Vector4};

use super::fit::normal_equations;
use serde::{Deserialize, Serialize};

use crate::error::ConfigError;

/// Share of each joint's threshold within which the apparent load counts as unchanged: its
/// torque at the current pose stays within a quarter of θ_j of the segment's first fit. Far
/// above the residual's noise at rest (a few hundredths of a Nm against θ of 1–6 Nm) and far
/// below a grasp (a 3 kg payload changes joint 2 by about 20 Nm).
pub const SETTLE_BAND: f64 = 0.25;

/// Time constant of the average a settled load is pinned to, as a share of the settle time:
/// the tail of the grasp within the band has faded from it to e^(−10) when the load has
/// settled, and at the default settle time it averages the residual's noise over some fifty
/// cycles (τ = 50 ms).
pub const PIN_AVERAGE_SHARE: f64 = 0.1;

/// Default grasp window \[s\]: the load may change for this long after the declaration.
pub const DEFAULT_GRASP_WINDOW_S: f64 = 10.0;
/// Default settle time \[s\]: a changed load that stays within the band this long is pinned.
pub const DEFAULT_SETTLE_S: f64 = 0.5;
/// Default expiry \[s\]: the mode ends this long after the declaration or the last refit of
/// static samples, unless an estimate was applied.
pub const DEFAULT_EXPIRE_S: f64 = 120.0;

/// When the load of a payload declared unknown may change, and how long the mode lasts
/// (controller time).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GraspTiming {
    /// Longest time after the declaration in which the load may change \[s\] (the grasp); at
    /// its end the load is pinned whatever it is. 0: pinned at the first cycle (the payload is
    /// held already).
    pub grasp_window_s: f64,
    /// Time a changed load must stay within [`SETTLE_BAND`] at rest to be pinned \[s\].
    pub settle_s: f64,
    /// Time without an estimate (since the declaration or the last refit of static samples)
    /// after which the mode ends and the monitor detects against the applied payload again \[s\].
    pub expire_s: f64,
}

impl Default for GraspTiming {
    fn default() -> Self {
        Self {
            grasp_window_s: DEFAULT_GRASP_WINDOW_S,
            settle_s: DEFAULT_SETTLE_S,
            expire_s: DEFAULT_EXPIRE_S,
        }
    }
}

impl GraspTiming {
    /// Checks the times: finite and non-negative, the expiry positive.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let ok = |x: f64| x.is_finite() && x >= 0.0;
        if ok(self.grasp_window_s) && ok(self.settle_s) && ok(self.expire_s) && self.expire_s > 0.0
        {
            Ok(())
        } else {
            Err(ConfigError::GraspTiming {
                grasp_window_s: self.grasp_window_s,
                settle_s: self.settle_s,
                expire_s: self.expire_s,
            })
        }
    }
}

/// Largest deviation of load `a` from load `b` at the pose of regressor `y`, in units of the
/// thresholds: max_j |Y_j (a − b)| / θ_j.
pub(crate) fn deviation<const N: usize>(
    y: &SMatrix<f64, N, 4>,
    a: &Vector4<f64>,
    b: &Vector4<f64>,
    thresholds: &SVector<f64, N>,
) -> f64 {
    let t = y * (a - b);
    (0..N)
        .map(|j| {
            if thresholds[j] > 0.0 {
                t[j].abs() / thresholds[j]
            } else {
                0.0
            }
        })
        .fold(0.0, f64::max)
}

/// The settle detection of the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SettleTracker {
    /// The load at the declaration (or at the first rest after a move).
    baseline: Option<Vector4<f64>>,
    /// The current segment's first fit.
    reference: Vector4<f64>,
    /// The current segment's fits averaged over [`PIN_AVERAGE_SHARE`] of the settle time, and
    /// whether a segment exists.
    average: Vector4<f64>,
    started: bool,
    /// Controller time of the segment's start and of its last fit \[s\].
    since_s: f64,
    last_s: f64,
    /// Σ YᵀWY at the segment's pose: what its loads determine.
    information: Matrix4<f64>,
    /// The arm moved since the segment started.
    moved: bool,
}

impl SettleTracker {
    /// Nothing seen yet.
    pub(crate) fn new() -> Self {
        Self {
            baseline: None,
            reference: Vector4::zeros(),
            average: Vector4::zeros(),
            started: false,
            since_s: 0.0,
            last_s: 0.0,
            information: Matrix4::zeros(),
            moved: false,
        }
    }

    fn start<const N: usize>(
        &mut self,
        load: &Vector4<f64>,
        y: &SMatrix<f64, N, 4>,
        weights: &SVector<f64, N>,
        now_s: f64,
    ) {
        self.reference = *load;
        self.average = *load;
        self.started = true;
        self.since_s = now_s;
        self.last_s = now_s;
        self.information = normal_equations(y, &SVector::zeros(), weights).0;
    }

    /// The fits stopped for a while (the monitor restarted after a gap or a loss of command
    /// mode): the load may have changed unseen, so the last segment is no longer the load and
    /// the first stretch at rest after it starts over from its own load, as after a move.
    pub(crate) fn interrupt(&mut self) {
        self.started = false;
        self.moved = true;
    }

    fn mean(&self) -> (Vector4<f64>, Matrix4<f64>) {
        (self.average, self.information)
    }

    /// The last segment at rest, if any: its averaged load and what its pose determines.
    pub(crate) fn last(&self) -> Option<(Vector4<f64>, Matrix4<f64>)> {
        self.started.then(|| self.mean())
    }

    /// The last segment at rest if it lasted at least `settle_s` (its load was steady, whether
    /// or not it differs from the declaration's): its averaged load and what its pose
    /// determines.
    pub(crate) fn last_settled(&self, settle_s: f64) -> Option<(Vector4<f64>, Matrix4<f64>)> {
        (self.started && self.last_s - self.since_s >= settle_s).then(|| self.mean())
    }

    /// Watches the fitted load `load` of this cycle (regressor `y`, weights `weights` = 1/θ²,
    /// thresholds `thresholds`) at controller time `now_s`; returns the load to pin and what
    /// its pose determines once it has settled after a change.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn observe<const N: usize>(
        &mut self,
        load: &Vector4<f64>,
        y: &SMatrix<f64, N, 4>,
        weights: &SVector<f64, N>,
        thresholds: &SVector<f64, N>,
        at_rest: bool,
        now_s: f64,
        settle_s: f64,
    ) -> Option<(Vector4<f64>, Matrix4<f64>)> {
        if !at_rest {
            self.moved = true;
            return None;
        }
        let Some(baseline) = self.baseline.filter(|_| !self.moved) else {
            // The first rest after the declaration or after a move: the load as it is now.
            self.baseline = Some(*load);
            self.moved = false;
            self.start(load, y, weights, now_s);
            return None;
        };
        if deviation(y, load, &self.reference, thresholds) > SETTLE_BAND {
            self.start(load, y, weights, now_s);
            return None;
        }
        let dt = (now_s - self.last_s).max(0.0);
        self.last_s = now_s;
        let tau = PIN_AVERAGE_SHARE * settle_s;
        let weight = if tau > 0.0 {
            1.0 - (-dt / tau).exp()
        } else {
            1.0
        };
        self.average += (load - self.average) * weight;
        let grasped = deviation(y, &self.reference, &baseline, thresholds) > SETTLE_BAND;
        (grasped && now_s - self.since_s >= settle_s).then(|| self.mean())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynamics::{Data, payload_gravity_regressor};

    type V7 = SVector<f64, 7>;

    /// The fitted load of a payload attached linearly over `ramp_s` from `at_s`.
    fn grasp(t: f64, at_s: f64, ramp_s: f64, full: &Vector4<f64>) -> Vector4<f64> {
        full * ((t - at_s) / ramp_s).clamp(0.0, 1.0)
    }

    #[test]
    fn a_grasp_settles_after_its_ramp_and_a_passing_push_pins_nothing() {
        let model = dynamics::lwr4();
        let mut data = Data::new(&model);
        let q = V7::from(dynamics::LWR4_PICK_POSE_RAD);
        let y = payload_gravity_regressor(&model, &mut data, &q);
        let th = V7::repeat(6.0);
        let w = super::super::fit::weights(&th);
        let full = Vector4::new(3.0, 0.0, 0.0, 0.36);
        for ramp in [0.001, 0.1, 0.5, 1.0] {
            let mut s = SettleTracker::new();
            let mut pinned = None;
            for k in 0..4000 {
                let t = k as f64 * 1e-3;
                let load = grasp(t, 1.0, ramp, &full);
                if let Some((p, _)) = s.observe(&load, &y, &w, &th, true, t, 0.5) {
                    pinned = Some((t, p));
                    break;
                }
            }
            let (t, p) = pinned.expect("a grasp settles");
            assert!(
                t >= 1.0 + ramp + 0.4 && t < 1.0 + ramp + 0.6,
                "ramp {ramp}: {t}"
            );
            assert!(
                deviation(&y, &p, &full, &th) < SETTLE_BAND,
                "ramp {ramp}: {p}"
            );
        }
        // A push on the empty flange that comes and goes: back at the declaration's load.
        let mut s = SettleTracker::new();
        for k in 0..4000 {
            let t = k as f64 * 1e-3;
            let push = if (1.0..1.3).contains(&t) { 2.0 } else { 0.0 };
            let load = Vector4::new(push, 0.0, 0.0, 0.078 * push);
            assert!(s.observe(&load, &y, &w, &th, true, t, 0.5).is_none(), "{t}");
        }
    }
    #[test]
    fn after_an_interruption_the_stretch_before_it_is_never_the_load() {
        let model = dynamics::lwr4();
        let mut data = Data::new(&model);
        let q = V7::from(dynamics::LWR4_PICK_POSE_RAD);
        let y = payload_gravity_regressor(&model, &mut data, &q);
        let th = V7::repeat(6.0);
        let w = super::super::fit::weights(&th);
        let empty = Vector4::zeros();
        let full = Vector4::new(3.0, 0.0, 0.0, 0.36);
        let mut s = SettleTracker::new();
        for k in 0..1000 {
            let t = k as f64 * 1e-3;
            assert!(s.observe(&empty, &y, &w, &th, true, t, 0.5).is_none());
        }
        assert!(s.last_settled(0.5).is_some(), "the empty flange was steady");
        // The grasp happens while nothing is fitted.
        s.interrupt();
        assert!(s.last_settled(0.5).is_none() && s.last().is_none());
        // The payload from the first rest after it is the new baseline: steady, never a grasp
        // (the window's end pins it), and steady for the settle time it is the last segment.
        for k in 1100..3000 {
            let t = k as f64 * 1e-3;
            assert!(s.observe(&full, &y, &w, &th, true, t, 0.5).is_none(), "{t}");
        }
        let (p, _) = s.last_settled(0.5).expect("the payload was steady");
        assert!(deviation(&y, &p, &full, &th) < SETTLE_BAND, "{p}");
    }
}
