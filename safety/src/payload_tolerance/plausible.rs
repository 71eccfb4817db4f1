//! The plausible static flange loads and the least-squares fit of one inside them.
//!
//! A payload's gravity parameters θ = (m, h = m·c) \[kg, kg·m\] (last DH frame) are plausible when
//! 0 ≤ m ≤ M and the centre of mass lies within R of the flange point f:
//! ‖h − m f‖ ≤ R m. In the coordinates x = (m, w), w = h − m f, that set is the truncated
//! second-order cone K = {‖w‖ ≤ R m, m ≤ M}: convex, and symmetric about the m axis, so the
//! Euclidean projection onto it reduces to the projection of (m, ‖w‖) onto the triangle
//! (0, 0), (M, 0), (M, R M) of the half-plane.
//!
//! Fits minimise the quadratic ½ xᵀH x − gᵀx over K. Everything is fixed-size and
//! allocation-free (it runs on the real-time thread).

use nalgebra::{SMatrix, SVector, Vector2};
use serde::{Deserialize, Serialize};

use crate::error::ConfigError;

/// What an unknown payload may be: the bounds of a plausible static flange load.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FlangeLoadBounds {
    /// Largest payload mass \[kg\] (the LWR 4+ is rated for 7 kg).
    pub max_mass_kg: f64,
    /// Radius \[m\] of the sphere around the flange point that holds the payload: its centre of
    /// mass (the gravity fit) and all of its mass (the inertia allowance while moving).
    pub radius_m: f64,
}

impl FlangeLoadBounds {
    /// Checks both bounds: finite and positive.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        if ok(self.max_mass_kg) && ok(self.radius_m) {
            Ok(())
        } else {
            Err(ConfigError::FlangeLoad {
                max_mass_kg: self.max_mass_kg,
                radius_m: self.radius_m,
            })
        }
    }
}

/// Relative ridge added to a fit's normal matrix: directions the data do not determine stay at
/// the anchor instead of being amplified noise.
const RIDGE: f64 = 1e-10;

/// Closest point of the segment p–q to x (2-D).
fn onto_segment(x: Vector2<f64>, p: Vector2<f64>, q: Vector2<f64>) -> Vector2<f64> {
    let d = q - p;
    let n = d.norm_squared();
    if n == 0.0 {
        return p;
    }
    p + d * ((x - p).dot(&d) / n).clamp(0.0, 1.0)
}

/// Whether x = (m, w) lies in the cone of `bounds` (with a relative tolerance for rounding).
pub(crate) fn inside<const D: usize>(x: &SVector<f64, D>, bounds: &FlangeLoadBounds) -> bool {
    let m = x[0];
    let tol = 1e-12 * (1.0 + bounds.max_mass_kg);
    let radial = x.rows(1, D - 1).norm();
    m >= -tol && m <= bounds.max_mass_kg + tol && radial <= bounds.radius_m * m.max(0.0) + tol
}

/// Euclidean projection of x = (m, w) onto the cone of `bounds`.
pub(crate) fn project<const D: usize>(
    x: &SVector<f64, D>,
    bounds: &FlangeLoadBounds,
) -> SVector<f64, D> {
    if inside(x, bounds) {
        return *x;
    }
    let (big_m, r) = (bounds.max_mass_kg, bounds.radius_m);
    let radial = x.rows(1, D - 1).norm();
    let point = Vector2::new(x[0], radial);
    let (o, a, c) = (
        Vector2::new(0.0, 0.0),
        Vector2::new(big_m, 0.0),
        Vector2::new(big_m, r * big_m),
    );
    let best = [
        onto_segment(point, o, a),
        onto_segment(point, a, c),
        onto_segment(point, o, c),
    ]
    .into_iter()
    .min_by(|p, q| (p - point).norm().total_cmp(&(q - point).norm()))
    .unwrap_or(o);
    let mut out = SVector::<f64, D>::zeros();
    out[0] = best.x;
    if radial > 0.0 {
        let scale = best.y / radial;
        for i in 1..D {
            out[i] = x[i] * scale;
        }
    }
    out
}

/// Value of ½ xᵀH x − gᵀx.
fn objective<const D: usize>(
    h: &SMatrix<f64, D, D>,
    g: &SVector<f64, D>,
    x: &SVector<f64, D>,
) -> f64 {
    0.5 * x.dot(&(h * x)) - g.dot(x)
}

/// Solves (H + ρI) δ = rhs with ρ the relative ridge; `None` when H is not positive
/// semi-definite enough to factor.
fn ridge_solve<const D: usize>(
    h: &SMatrix<f64, D, D>,
    rhs: &SVector<f64, D>,
) -> Option<SVector<f64, D>> {
    damped_solve(h, rhs, RIDGE * h.trace().abs() + f64::MIN_POSITIVE)
}

/// Solves (H + μI) δ = rhs; `None` when it cannot be factored.
fn damped_solve<const D: usize>(
    h: &SMatrix<f64, D, D>,
    rhs: &SVector<f64, D>,
    ridge: f64,
) -> Option<SVector<f64, D>> {
    let regularised = h + SMatrix::<f64, D, D>::identity() * ridge;
    let x = regularised.cholesky()?.solve(rhs);
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Bisection steps of the damped step's search (factor 10⁻⁶·trace … 10⁶·trace of μ).
const DAMPING_STEPS: usize = 40;

/// The step from `anchor` along the damped path δ(μ) = (H + μI)⁻¹(g − H·anchor) with the least
/// damping μ that keeps anchor + δ(μ) plausible (a trust region around the anchor): directions
/// the data barely determine shrink first, well-determined ones keep their fit. `None` when the
/// anchor itself is not plausible or no damping makes the step plausible.
fn damped_into_cone<const D: usize>(
    h: &SMatrix<f64, D, D>,
    g: &SVector<f64, D>,
    anchor: &SVector<f64, D>,
    bounds: &FlangeLoadBounds,
) -> Option<SVector<f64, D>> {
    if !inside(anchor, bounds) {
        return None;
    }
    let rhs = g - h * anchor;
    let scale = h.trace().abs().max(f64::MIN_POSITIVE);
    let at =
        |log_mu: f64| damped_solve(h, &rhs, scale * 10f64.powf(log_mu)).map(|step| anchor + step);
    let (mut lo, mut hi) = (-6.0, 6.0);
    let mut best = at(hi).filter(|x| inside(x, bounds))?;
    for _ in 0..DAMPING_STEPS {
        let mid = 0.5 * (lo + hi);
        match at(mid) {
            Some(x) if inside(&x, bounds) => {
                best = x;
                hi = mid;
            }
            _ => lo = mid,
        }
    }
    Some(best)
}

/// Minimises ½ xᵀH x − gᵀx over the cone K of `bounds` (x = (m, w) as in the module
/// documentation). Directions H does not determine stay at `anchor`. Exact when the
/// unconstrained minimum is plausible; otherwise the best of: the least-damped plausible step
/// from the anchor (so a barely determined direction that the data would push out of K does not
/// drag the well-determined ones with it), the projection of the minimum, the minimum on the
/// face it projects to (m = M, or its ray on the lateral surface) and the apex. The result is
/// always inside K, so the misfit it leaves is never smaller than the best plausible one: an
/// implausible load is reported as at least as unexplained as it is.
pub(crate) fn minimise_in_cone<const D: usize>(
    h: &SMatrix<f64, D, D>,
    g: &SVector<f64, D>,
    anchor: &SVector<f64, D>,
    bounds: &FlangeLoadBounds,
) -> SVector<f64, D> {
    let apex = SVector::<f64, D>::zeros();
    let Some(step) = ridge_solve(h, &(g - h * anchor)) else {
        // Not factorable (non-finite data): explain nothing.
        return apex;
    };
    let free = anchor + step;
    if inside(&free, bounds) {
        return free;
    }
    let projected = project(&free, bounds);
    let mut best = projected;
    let mut best_value = objective(h, g, &projected);
    let mut consider = |x: SVector<f64, D>| {
        let value = objective(h, g, &x);
        if value.is_finite() && value < best_value {
            best = x;
            best_value = value;
        }
    };
    consider(apex);
    if let Some(x) = damped_into_cone(h, g, anchor, bounds) {
        consider(x);
    }
    let big_m = bounds.max_mass_kg;
    if (projected[0] - big_m).abs() <= 1e-9 * (1.0 + big_m) {
        // On the top face: the best w for m = M, from the block H_ww w = g_w − H_wm M (written
        // as a D × D system with m's row and column replaced by the identity's).
        let mut system = *h;
        let mut rhs = g - h.column(0) * big_m;
        for j in 0..D {
            system[(0, j)] = 0.0;
            system[(j, 0)] = 0.0;
        }
        system[(0, 0)] = 1.0;
        rhs[0] = big_m;
        if let Some(x) = ridge_solve(&system, &rhs) {
            consider(project(&x, bounds));
        }
    }
    let radial = projected.rows(1, D - 1).norm();
    if radial > 0.0 && projected[0] > 0.0 {
        // On the lateral surface: the best point of the ray through the projection.
        let direction = projected / projected[0];
        let curvature = direction.dot(&(h * direction));
        if curvature > 0.0 {
            let t = (direction.dot(g) / curvature).clamp(0.0, big_m);
            consider(direction * t);
        }
    }
    best
}

/// The service's default bounds (the LWR 4+'s rated 7 kg within 0.3 m), for the tests.
#[cfg(test)]
pub(crate) const TEST_BOUNDS: FlangeLoadBounds = FlangeLoadBounds {
    max_mass_kg: 7.0,
    radius_m: 0.3,
};

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};

    const BOUNDS: FlangeLoadBounds = TEST_BOUNDS;

    #[test]
    fn projection_lands_on_the_nearest_face() {
        // Inside: unchanged.
        let x = Vector3::new(3.0, 0.5, -0.2);
        assert_eq!(project(&x, &BOUNDS), x);
        // Too heavy: onto the top face.
        let p = project(&Vector3::new(9.0, 0.1, 0.0), &BOUNDS);
        assert!((p - Vector3::new(7.0, 0.1, 0.0)).norm() < 1e-12);
        // Negative mass: to the apex.
        assert_eq!(
            project(&Vector3::new(-1.0, 0.0, 0.0), &BOUNDS),
            Vector3::zeros()
        );
        // Centre of mass too far: onto the lateral surface, same direction of w.
        let p = project(&Vector3::new(2.0, 3.0, 0.0), &BOUNDS);
        assert!(inside(&p, &BOUNDS));
        assert!((p[1] / p[0] - 0.3).abs() < 1e-9 && p[2] == 0.0);
    }

    #[test]
    fn a_plausible_minimum_is_exact_and_an_implausible_one_is_feasible_and_no_better() {
        let h = Matrix3::new(4.0, 1.0, 0.0, 1.0, 3.0, 0.5, 0.0, 0.5, 2.0);
        for target in [
            Vector3::new(2.0, 0.1, 0.2),
            Vector3::new(10.0, 0.0, 0.0),
            Vector3::new(-3.0, 1.0, 0.0),
            Vector3::new(1.0, 2.0, -2.0),
        ] {
            let g = h * target;
            let x = minimise_in_cone(&h, &g, &Vector3::zeros(), &BOUNDS);
            assert!(inside(&x, &BOUNDS), "{x}");
            if inside(&target, &BOUNDS) {
                assert!((x - target).norm() < 1e-6);
            }
            // No feasible point on a grid does better (up to the grid's resolution).
            let value = objective(&h, &g, &x);
            let mut best_grid = f64::INFINITY;
            for i in 0..=40 {
                for j in -20..=20 {
                    for k in -20..=20 {
                        let m = 7.0 * f64::from(i) / 40.0;
                        let p = Vector3::new(
                            m,
                            0.3 * m * f64::from(j) / 20.0,
                            0.3 * m * f64::from(k) / 20.0,
                        );
                        if inside(&p, &BOUNDS) {
                            best_grid = best_grid.min(objective(&h, &g, &p));
                        }
                    }
                }
            }
            assert!(
                value <= best_grid + 0.05 * best_grid.abs().max(1.0),
                "{value} vs grid {best_grid}"
            );
        }
    }
}
