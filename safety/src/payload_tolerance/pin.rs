//! The pinned load of a payload declared unknown: once the grasp is over, the load may no longer
//! change, so the monitor detects against one load (m, m·c) instead of whatever plausible load
//! explains the current cycle.
//!
//! What is pinned is the load's gravity parameters θ_p = (m, h = m·c) \[kg, kg·m\] (last DH
//! frame), never a torque vector: a move changes the load's joint torques, not the load. The
//! poses the load was seen at determine it only in the directions their regressors span (the
//! information Σ YᵀWY); one pose leaves the centre of mass's height along gravity open. Each cycle
//! the fit is θ_p plus the step along the open directions that best explains the current pose,
//! kept inside the plausible cone (the longest plausible part of the step: exact for one open
//! direction, the common case). A change of the load in the pinned directions is therefore seen
//! in full by the detector: at the detector's thresholds, it is a contact.

use nalgebra::{Matrix4, SMatrix, SVector, Vector3, Vector4};

use super::fit::{normal_plane, to_full_coordinates};
use super::plausible::{FlangeLoadBounds, inside};

/// Eigenvalues of a pin's information at or below this share of the largest leave their
/// direction open (the rule of the hypothesis' centre-of-mass uncertainty).
const OPEN_SHARE: f64 = 1e-6;
/// Bisection steps toward the plausible cone's boundary along the open step.
const BOUNDARY_STEPS: usize = 40;
/// Directions in the plane normal to gravity tried for the centre-of-mass tolerance.
const COM_DIRECTIONS: usize = 16;

/// What pinned the load.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PinSource {
    /// The apparent load changed after the declaration (the grasp) and then stayed within the
    /// settle band for the settle time, at rest: pinned to its mean over that time.
    Settled,
    /// The grasp window ended: pinned to the load of the last stretch at rest (or the current
    /// fit when the arm never rested in the window).
    GraspWindow,
    /// The service started moving the arm during the grasp window (a workflow: the grasp is
    /// over): pinned to the load of the last stretch at rest.
    Move,
    /// Static samples were refitted (`estimate-payload`, `tare`): pinned to their fit, with the
    /// number of samples.
    Samples(u32),
}

/// A pinned load and what it tolerates (fixed-size: built on the real-time thread).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinnedLoad {
    /// The pinned gravity parameters (m \[kg\], m·c \[kg·m\], last DH frame), plausible.
    pub parameters: Vector4<f64>,
    /// Σ YᵀWY of the poses that determine it (W = diag 1/θ_j²).
    pub information: Matrix4<f64>,
    /// Controller time of the pin \[s\].
    pub at_s: f64,
    /// What pinned it.
    pub source: PinSource,
    /// The largest mass change \[kg\] at the pinned centre of mass (at the flange point for a
    /// massless pin) that stays under every threshold at the pose it was pinned at; a vertical
    /// flange force up to this times g is not seen there. +∞ until evaluated.
    pub mass_tolerance_kg: f64,
    /// The largest shift \[m\] of the centre of mass normal to gravity, in the least visible
    /// direction, that stays under every threshold at the pose it was pinned at (at most the
    /// declared radius).
    pub com_tolerance_m: f64,
    open: [Vector4<f64>; 4],
    open_count: usize,
    evaluated: bool,
}

impl PinnedLoad {
    /// Pins `parameters` determined by `information` at controller time `at_s`; the
    /// tolerances are evaluated at the next pose ([`Self::evaluate`]).
    pub(crate) fn new(
        parameters: Vector4<f64>,
        information: Matrix4<f64>,
        at_s: f64,
        source: PinSource,
    ) -> Self {
        let eigen = information.symmetric_eigen();
        let largest = eigen.eigenvalues.amax().max(f64::MIN_POSITIVE);
        let mut open = [Vector4::zeros(); 4];
        let mut open_count = 0;
        for k in 0..4 {
            if eigen.eigenvalues[k] <= OPEN_SHARE * largest {
                open[open_count] = eigen.eigenvectors.column(k).into_owned();
                open_count += 1;
            }
        }
        Self {
            parameters,
            information,
            at_s,
            source,
            mass_tolerance_kg: f64::INFINITY,
            com_tolerance_m: f64::INFINITY,
            open,
            open_count,
            evaluated: false,
        }
    }

    /// The directions of θ the pinning poses leave open (after one pose: the centre of mass's
    /// height along gravity there), orthonormal.
    pub fn open_directions(&self) -> &[Vector4<f64>] {
        &self.open[..self.open_count]
    }

    /// Mass \[kg\] of the pinned load.
    pub fn mass_kg(&self) -> f64 {
        self.parameters[0]
    }

    /// Centre of mass \[m\] (last DH frame); `None` for a massless pin.
    pub fn com(&self) -> Option<Vector3<f64>> {
        let m = self.parameters[0];
        (m > 0.0).then(|| self.parameters.fixed_rows::<3>(1) / m)
    }

    /// Whether the tolerances were evaluated (at the first pose after the pin).
    pub(crate) fn evaluated(&self) -> bool {
        self.evaluated
    }

    /// Evaluates the tolerances at the pose of regressor `y` (gravity `gravity_in_last`, unit,
    /// last DH frame) with thresholds `thresholds` \[Nm\].
    pub(crate) fn evaluate<const N: usize>(
        &mut self,
        y: &SMatrix<f64, N, 4>,
        gravity_in_last: &Vector3<f64>,
        thresholds: &SVector<f64, N>,
        flange: &Vector3<f64>,
        bounds: &FlangeLoadBounds,
    ) {
        // Largest |x| with |y_j·d|·|x| ≤ θ_j on every joint.
        let undetected = |d: &Vector4<f64>| {
            let t = y * d;
            (0..N)
                .filter(|&j| t[j] != 0.0)
                .map(|j| thresholds[j] / t[j].abs())
                .fold(f64::INFINITY, f64::min)
        };
        let m = self.parameters[0];
        let centre = self.com().unwrap_or(*flange);
        self.mass_tolerance_kg = undetected(&Vector4::new(1.0, centre.x, centre.y, centre.z));
        let (e1, e2) = normal_plane(gravity_in_last);
        let mut worst: f64 = 0.0;
        for k in 0..COM_DIRECTIONS {
            let a = std::f64::consts::PI * k as f64 / COM_DIRECTIONS as f64;
            let d = (e1 * a.cos() + e2 * a.sin()) * m;
            worst = worst.max(undetected(&Vector4::new(0.0, d.x, d.y, d.z)));
        }
        self.com_tolerance_m = worst.min(bounds.radius_m);
        self.evaluated = true;
    }

    /// The load that best explains the load torque `z` \[Nm\] at the pose of regressor `y`
    /// (weights `weights` 1/θ²): the pin plus the longest plausible part of the best step along
    /// the open directions. Allocation-free.
    pub(crate) fn fit<const N: usize>(
        &self,
        y: &SMatrix<f64, N, 4>,
        z: &SVector<f64, N>,
        weights: &SVector<f64, N>,
        flange: &Vector3<f64>,
        bounds: &FlangeLoadBounds,
    ) -> Vector4<f64> {
        let k = self.open_count;
        if k == 0 {
            return self.parameters;
        }
        let misfit = z - y * self.parameters;
        let mut h = Matrix4::identity();
        let mut g = Vector4::zeros();
        for a in 0..k {
            let ya = y * self.open[a];
            for b in 0..k {
                let yb = y * self.open[b];
                h[(a, b)] = (0..N).map(|j| weights[j] * ya[j] * yb[j]).sum::<f64>();
            }
            g[a] = (0..N).map(|j| weights[j] * ya[j] * misfit[j]).sum::<f64>();
        }
        let ridge = 1e-10 * h.trace().abs() + f64::MIN_POSITIVE;
        let Some(s) = (h + Matrix4::identity() * ridge)
            .cholesky()
            .map(|c| c.solve(&g))
            .filter(|s| s.iter().all(|v| v.is_finite()))
        else {
            return self.parameters;
        };
        let mut step = Vector4::zeros();
        for a in 0..k {
            step += self.open[a] * s[a];
        }
        let plausible = |t: f64| {
            inside(
                &to_full_coordinates(flange, &(self.parameters + step * t)),
                bounds,
            )
        };
        if plausible(1.0) {
            return self.parameters + step;
        }
        if !plausible(0.0) {
            return self.parameters;
        }
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..BOUNDARY_STEPS {
            let mid = 0.5 * (lo + hi);
            if plausible(mid) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        self.parameters + step * lo
    }
}

#[cfg(test)]
mod tests {
    use super::super::fit::{gravity_in_last, normal_equations, weights};
    use super::super::plausible::TEST_BOUNDS;
    use super::*;
    use dynamics::{Data, forward_kinematics, payload_gravity_regressor};

    type V7 = SVector<f64, 7>;

    #[test]
    fn one_pose_pins_all_but_the_height_along_gravity_and_a_change_is_seen_in_full() {
        let model = dynamics::lwr4();
        let mut data = Data::new(&model);
        let flange = model.flange().translation.vector;
        let q = V7::from(dynamics::LWR4_PICK_POSE_RAD);
        let w = weights(&V7::repeat(6.0));
        let y = payload_gravity_regressor(&model, &mut data, &q);
        let (h, _) = normal_equations(&y, &V7::zeros(), &w);
        let truth = Vector4::new(3.0, 0.01, -0.02, 3.0 * 0.12);
        let pin = PinnedLoad::new(truth, h, 0.0, PinSource::Settled);
        assert_eq!(pin.open_directions().len(), 1);
        // At the pinning pose the pin explains its load and nothing else: 20 N down on the
        // flange (a change the single-pose fit would take for a heavier payload) stays whole.
        let z = y * truth;
        assert!((y * pin.fit(&y, &z, &w, &flange, &TEST_BOUNDS) - z).amax() < 1e-9);
        let push = y * Vector4::new(2.0, 2.0 * flange.x, 2.0 * flange.y, 2.0 * flange.z);
        let e = y * pin.fit(&y, &(z + push), &w, &flange, &TEST_BOUNDS) - (z + push);
        assert!((e + push).amax() < 1e-9, "{e} vs {push}");
        // At another orientation the open height follows the pose: the true load (whose centre
        // of mass is elsewhere along gravity than the pin's) is explained.
        let mut q2 = q;
        q2[5] += 0.4;
        let rotation = forward_kinematics(&model, &mut data, &q)[6].rotation;
        let u = gravity_in_last(&rotation, &model.gravity());
        let shifted = truth + Vector4::new(0.0, u.x, u.y, u.z) * 0.3;
        let pin = PinnedLoad::new(shifted, h, 0.0, PinSource::Settled);
        let y2 = payload_gravity_regressor(&model, &mut data, &q2);
        let z2 = y2 * truth;
        let e2 = y2 * pin.fit(&y2, &z2, &w, &flange, &TEST_BOUNDS) - z2;
        assert!(e2.amax() < 1e-6, "{e2}");
    }

    #[test]
    fn tolerances_are_the_largest_changes_under_every_threshold() {
        let model = dynamics::lwr4();
        let mut data = Data::new(&model);
        let flange = model.flange().translation.vector;
        let q = V7::from(dynamics::LWR4_PICK_POSE_RAD);
        let thresholds = V7::repeat(6.0);
        let y = payload_gravity_regressor(&model, &mut data, &q);
        let (h, _) = normal_equations(&y, &V7::zeros(), &weights(&thresholds));
        let rotation = forward_kinematics(&model, &mut data, &q)[6].rotation;
        let u = gravity_in_last(&rotation, &model.gravity());
        let mut pin = PinnedLoad::new(
            Vector4::new(3.0, 0.0, 0.0, 0.36),
            h,
            0.0,
            PinSource::GraspWindow,
        );
        pin.evaluate(&y, &u, &thresholds, &flange, &TEST_BOUNDS);
        let dm = pin.mass_tolerance_kg;
        let torque = |m: f64| (y * Vector4::new(m, 0.0, 0.0, m * 0.12)).amax();
        assert!((torque(dm) - 6.0).abs() < 1e-9, "{dm}");
        assert!(dm > 0.1 && dm < 7.0);
        assert!(pin.com_tolerance_m > 0.0 && pin.com_tolerance_m <= 0.3);
    }
}
