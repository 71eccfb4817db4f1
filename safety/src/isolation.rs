//! Isolation and identification: which link was hit, where, and with what force.
//!
//! A contact on link i produces τ_ext = J_iᵀF, which has no component on joints distal to i
//! (they do not move link i). The simplest rule names the most distal joint whose residual
//! exceeds a level; it degenerates when the force line passes close to that joint's axis.
//!
//! [`ContactIsolator`] uses the residual's direction across all joints instead: for every link
//! it fits a pushing force at points of the link's surface ([`LinkSurface`], a capsule in the
//! link's DH frame) — a grid, then a local refinement of the best — weighted by the residual's
//! noise, and scores the link by its best fit's likelihood. The link with the highest score is
//! the isolated link; its share of the scores is the confidence, the best point and its force
//! the contact estimate. All joints' residuals rise together through
//! the same K/(s + K) when the gains are equal, so the direction is right well before the
//! residual has converged.
//!
//! Identification at an assumed point: F̂ = (J Jᵀ + λ²I)⁻¹ J r (damped least-squares inverse of
//! τ = JᵀF); meaningful on the last link (contact on the tool), where J has full row rank away
//! from singularities.

use dynamics::{Data, Model, forward_kinematics, point_jacobian};
use nalgebra::{Matrix2, Matrix3, Matrix6, SVector, Vector2, Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::detector::JointSet;

/// Candidate points along a link's capsule axis.
pub const POINTS_ALONG: usize = 5;
/// Candidate points around a link's capsule axis.
pub const POINTS_AROUND: usize = 8;
/// Candidate contact points per link.
pub const CANDIDATES: usize = POINTS_ALONG * POINTS_AROUND;
/// Relative model error added to the residual's noise in the fit (grid spacing of the candidate
/// points, model errors): σ_j² = noise_j² + (0.05·r_j)².
pub const RELATIVE_MODEL_ERROR: f64 = 0.05;

/// A link's surface approximated by a capsule around a segment, in the link's DH frame \[m\].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LinkSurface {
    /// Start of the segment \[m\].
    pub from: Vector3<f64>,
    /// End of the segment \[m\].
    pub to: Vector3<f64>,
    /// Radius of the surface around the segment \[m\].
    pub radius_m: f64,
}

impl LinkSurface {
    /// The point at fraction `along` ∈ \[0, 1\] of the segment, on the surface in the
    /// direction `angle` \[rad\] around the axis, and its outward normal (link frame).
    pub fn point(&self, along: f64, angle: f64) -> (Vector3<f64>, Vector3<f64>) {
        let axis = (self.to - self.from).normalize();
        // Any vector not parallel to the axis gives the first radial direction.
        let helper = if axis.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let u = axis.cross(&helper).normalize();
        let v = axis.cross(&u);
        let normal = u * angle.cos() + v * angle.sin();
        (
            self.from + (self.to - self.from) * along + normal * self.radius_m,
            normal,
        )
    }
}

/// The LWR 4+'s link surfaces (DH frames of `dynamics::lwr4`), links 1–7: the segments and radii
/// of the links' housings (link 7: the flange and a tool of 0.2 m).
pub fn lwr4_link_surfaces() -> [LinkSurface; 7] {
    let capsule = |from: [f64; 3], to: [f64; 3], radius_m: f64| LinkSurface {
        from: Vector3::from(from),
        to: Vector3::from(to),
        radius_m,
    };
    [
        capsule([0.0, 0.0, -0.15], [0.0, 0.0, -0.05], 0.07),
        capsule([0.0, 0.0, 0.05], [0.0, 0.0, 0.2], 0.07),
        capsule([0.0, 0.05, 0.0], [0.0, 0.18, 0.0], 0.07),
        capsule([0.0, 0.0, 0.08], [0.0, 0.0, 0.25], 0.065),
        capsule([0.0, -0.05, 0.0], [0.0, -0.18, 0.0], 0.06),
        capsule([0.0, 0.03, -0.05], [0.0, 0.08, -0.04], 0.05),
        capsule([0.0, 0.0, 0.08], [0.0, 0.0, 0.2], 0.05),
    ]
}

/// The contact fitted through the links' Jacobians.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ContactEstimate {
    /// Isolated link, 0-based (link i moves with joint i).
    pub link: usize,
    /// Posterior probability of that link given the residual (equal priors), 0…1.
    pub confidence: f64,
    /// Best-fitting contact point, base frame \[m\].
    pub point: Vector3<f64>,
    /// Contact force at that point, base frame \[N\] (pushing into the link).
    pub force: Vector3<f64>,
    /// Weighted squared fit error of the best point (χ², dimensionless).
    pub chi_squared: f64,
}

impl ContactEstimate {
    /// The contact as a wrench at the base origin (force \[N\]; moment p × F \[Nm\]), base frame
    /// (what a `geometry_msgs/WrenchStamped` in the base frame carries).
    pub fn wrench_at_base(&self) -> Vector6<f64> {
        let m = self.point.cross(&self.force);
        Vector6::new(self.force.x, self.force.y, self.force.z, m.x, m.y, m.z)
    }
}

/// Fits a pushing contact force through every link's Jacobian over its surface (see the module
/// documentation); `isolate` is allocation-free.
#[derive(Debug, Clone)]
pub struct ContactIsolator<const N: usize> {
    surfaces: [LinkSurface; N],
    data: Data<N>,
}

/// Rounds of the local refinement of a link's best grid point (each halves the step).
const REFINE_ROUNDS: usize = 6;

impl<const N: usize> ContactIsolator<N> {
    /// Isolator for `model` with one surface per link.
    pub fn new(model: &Model<N>, surfaces: &[LinkSurface; N]) -> Self {
        Self {
            surfaces: *surfaces,
            data: Data::new(model),
        }
    }

    /// The contact that best explains `residual` \[Nm\] at configuration `q` \[rad\], with the
    /// residual's noise `noise_nm` per joint \[Nm\] (e.g. the envelope; > 0). `None` when the
    /// inputs are not finite.
    ///
    /// Per link: the best of a grid of [`CANDIDATES`] surface points, refined by a pattern
    /// search along and around the capsule (a contact between grid points would otherwise
    /// misfit by |F|·Δp, several Nm on the proximal joints for 50 N and 3 cm); the link's score
    /// is its best fit's likelihood exp(−χ²/2) (profile likelihood) times the chance that its
    /// own joint carries as little as observed (a distal link fits a proximal contact only
    /// with its force line through its own joint's axis), the confidence its share.
    pub fn isolate(
        &mut self,
        model: &Model<N>,
        q: &SVector<f64, N>,
        residual: &SVector<f64, N>,
        noise_nm: &SVector<f64, N>,
    ) -> Option<ContactEstimate> {
        let finite = q
            .iter()
            .chain(residual.iter())
            .chain(noise_nm.iter())
            .all(|x| x.is_finite());
        if N == 0 || !finite {
            return None;
        }
        let weights = SVector::<f64, N>::from_fn(|j, _| {
            let sigma2 = noise_nm[j].powi(2) + (RELATIVE_MODEL_ERROR * residual[j]).powi(2);
            1.0 / sigma2.max(1e-12)
        });
        let frames = forward_kinematics(model, &mut self.data, q);
        let last = frames[N - 1].translation.vector;
        let twists = point_jacobian(model, &mut self.data, q, N - 1, &Vector3::zeros());
        let total: f64 = (0..N).map(|j| weights[j] * residual[j].powi(2)).sum();
        let mut best_per_link = [(f64::INFINITY, Vector3::zeros(), Vector3::zeros()); N];
        for (link, best) in best_per_link.iter_mut().enumerate() {
            let frame = &frames[link];
            let surface = &self.surfaces[link];
            let evaluate = |along: f64, angle: f64| {
                let (p, n) = surface.point(along.clamp(0.0, 1.0), angle);
                let point = (frame * nalgebra::Point3::from(p)).coords;
                let normal = frame.rotation * n;
                let (force, chi2) = fit_force(
                    &twists, &last, &point, &normal, link, residual, &weights, total,
                );
                (chi2, point, force)
            };
            let mut at = (0.0, 0.0);
            for k in 0..CANDIDATES {
                let (i, a) = (k / POINTS_AROUND, k % POINTS_AROUND);
                let along = i as f64 / (POINTS_ALONG - 1) as f64;
                let angle = std::f64::consts::TAU * a as f64 / POINTS_AROUND as f64;
                let fit = evaluate(along, angle);
                if fit.0 < best.0 {
                    *best = fit;
                    at = (along, angle);
                }
            }
            let mut step = (
                0.5 / (POINTS_ALONG - 1) as f64,
                0.5 * std::f64::consts::TAU / POINTS_AROUND as f64,
            );
            for _ in 0..REFINE_ROUNDS {
                let centre = at;
                for (da, dp) in [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)] {
                    let along = (centre.0 + da * step.0).clamp(0.0, 1.0);
                    let angle = centre.1 + dp * step.1;
                    let fit = evaluate(along, angle);
                    if fit.0 < best.0 {
                        *best = fit;
                        at = (along, angle);
                    }
                }
                step = (0.5 * step.0, 0.5 * step.1);
            }
        }
        // A contact on link i puts |F|·(its lever about joint i) on joint i, unless the force line
        // passes close to that axis — a coincidence a more proximal link explains without. The
        // score charges a hypothesis whose own joint carries much less than its force could
        // give: ln(min(1, (|r_i| + 2σ_i)/(|F|·lever_i))).
        let score = |link: usize| {
            let (chi2, point, force) = best_per_link[link];
            let lever = (twists.fixed_view::<3, 1>(0, link).into_owned()
                + twists.fixed_view::<3, 1>(3, link).cross(&(point - last)))
            .norm();
            let own = residual[link].abs() + 2.0 / weights[link].sqrt();
            let possible = force.norm() * lever;
            let coincidence = if possible > own {
                (own / possible).ln()
            } else {
                0.0
            };
            -0.5 * chi2 + coincidence
        };
        let scores: [f64; N] = std::array::from_fn(score);
        let (link, &top) = scores
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))?;
        let evidence: f64 = scores.iter().map(|s| (s - top).exp()).sum();
        let (chi2, point, force) = best_per_link[link];
        Some(ContactEstimate {
            link,
            confidence: 1.0 / evidence,
            point,
            force,
            chi_squared: chi2,
        })
    }
}

/// Weighted least-squares force at `point` (base frame) on `link` that explains `residual`,
/// pushing into the surface (F·n ≤ 0 for the outward normal `n`): returns (F, χ²).
#[allow(clippy::too_many_arguments)]
fn fit_force<const N: usize>(
    twists: &nalgebra::SMatrix<f64, 6, N>,
    last_origin: &Vector3<f64>,
    point: &Vector3<f64>,
    normal: &Vector3<f64>,
    link: usize,
    residual: &SVector<f64, N>,
    weights: &SVector<f64, N>,
    total: f64,
) -> (Vector3<f64>, f64) {
    // Column c of the point's linear Jacobian: v_c(p) = v_c(o) + ω_c × (p − o), o the last
    // link's origin where `twists` was taken; joints distal to the link do not move it.
    let offset = point - last_origin;
    let mut gram = Matrix3::zeros();
    let mut rhs = Vector3::zeros();
    for c in 0..=link {
        let v: Vector3<f64> = twists.fixed_view::<3, 1>(0, c).into_owned()
            + twists.fixed_view::<3, 1>(3, c).cross(&offset);
        gram += v * v.transpose() * weights[c];
        rhs += v * (weights[c] * residual[c]);
    }
    // A link moved by fewer than three joints leaves the force partly undetermined: a small
    // damping picks the least-norm force without changing the fit.
    let damping = 1e-9 * gram.trace().max(1e-12);
    let solve = |g: Matrix3<f64>| (g + Matrix3::identity() * damping).cholesky();
    let Some(chol) = solve(gram) else {
        return (Vector3::zeros(), total);
    };
    let force = chol.solve(&rhs);
    if force.dot(normal) <= 0.0 {
        return (force, (total - rhs.dot(&force)).max(0.0));
    }
    // Pulling: the best pushing force lies on the boundary, tangential to the surface.
    let helper = if normal.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let t1 = normal.cross(&helper).normalize();
    let t2 = normal.cross(&t1);
    let g2 = Matrix2::new(
        t1.dot(&(gram * t1)),
        t1.dot(&(gram * t2)),
        t2.dot(&(gram * t1)),
        t2.dot(&(gram * t2)),
    ) + Matrix2::identity() * damping;
    let h2 = Vector2::new(t1.dot(&rhs), t2.dot(&rhs));
    match g2.cholesky() {
        Some(c) => {
            let y = c.solve(&h2);
            (t1 * y.x + t2 * y.y, (total - h2.dot(&y)).max(0.0))
        }
        None => (Vector3::zeros(), total),
    }
}

/// The isolated link (0-based; link i is moved by joint i): most distal joint in `over`.
pub fn isolate_link(over: JointSet) -> Option<usize> {
    over.most_distal()
}

/// Damped least-squares estimate of the contact wrench (F \[N\]; moment about the point \[Nm\]),
/// base frame, from residual `residual` \[Nm\] for a contact at `point_in_link` \[m\] in the DH
/// frame of link `link` (0-based), damping `damping` λ (same units as J entries; 0 = plain
/// pseudo-inverse). `None` when the damped system is singular.
pub fn estimate_contact_wrench<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    residual: &SVector<f64, N>,
    link: usize,
    point_in_link: &Vector3<f64>,
    damping: f64,
) -> Option<Vector6<f64>> {
    let jacobian = point_jacobian(model, data, q, link, point_in_link);
    let normal: Matrix6<f64> =
        jacobian * jacobian.transpose() + Matrix6::identity() * (damping * damping);
    let rhs: Vector6<f64> = jacobian * residual;
    normal.cholesky().map(|c| c.solve(&rhs))
}

/// Damped least-squares estimate of a pure contact force F \[N\] (base frame) at `point_in_link`
/// \[m\] on link `link` (0-based) from residual `residual` \[Nm\]: F̂ = (J_v J_vᵀ + λ²I)⁻¹ J_v r.
pub fn estimate_contact_force<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    residual: &SVector<f64, N>,
    link: usize,
    point_in_link: &Vector3<f64>,
    damping: f64,
) -> Option<Vector3<f64>> {
    let jacobian = point_jacobian(model, data, q, link, point_in_link);
    let linear = jacobian.fixed_rows::<3>(0);
    let normal: Matrix3<f64> =
        linear * linear.transpose() + Matrix3::identity() * (damping * damping);
    let rhs: Vector3<f64> = linear * residual;
    normal.cholesky().map(|c| c.solve(&rhs))
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynamics::lwr4;

    type V7 = SVector<f64, 7>;

    #[test]
    fn the_fit_names_the_link_point_and_force_of_a_noise_free_contact() {
        let model = lwr4();
        let surfaces = lwr4_link_surfaces();
        let mut isolator = ContactIsolator::new(&model, &surfaces);
        let q = V7::from_column_slice(&[0.2, 0.7, -0.3, -1.3, 0.4, 0.9, 0.3]);
        let mut data = Data::new(&model);
        for link in 2..7 {
            // A candidate point, pushed along its inward normal with a tangential part.
            let (p, n) = surfaces[link].point(0.5, std::f64::consts::TAU / 8.0);
            let frames = forward_kinematics(&model, &mut data, &q);
            let normal = frames[link].rotation * n;
            let tangent = normal.cross(&Vector3::z()).normalize();
            let force = (-normal + tangent * 0.5).normalize() * 50.0;
            let j = point_jacobian(&model, &mut data, &q, link, &p);
            let residual: V7 = j.fixed_rows::<3>(0).transpose() * force;
            let e = isolator
                .isolate(&model, &q, &residual, &V7::repeat(0.1))
                .unwrap();
            assert_eq!(e.link, link, "{e:?}");
            if link < 3 {
                // Three joints, three force components: every point of link 3 fits exactly, so
                // the point is not identifiable and a distal link through the axes competes.
                assert!(e.confidence > 0.5, "{e:?}");
                continue;
            }
            assert!(e.confidence > 0.9, "{e:?}");
            let point = frames[link] * nalgebra::Point3::from(p);
            assert!((e.point - point.coords).norm() < 1e-6, "{e:?}");
            assert!((e.force - force).norm() < 1e-3 * 50.0, "{e:?}");
            let w = e.wrench_at_base();
            assert!((w.fixed_rows::<3>(3) - point.coords.cross(&force)).norm() < 0.1);
        }
    }

    #[test]
    fn a_weak_residual_gives_a_low_confidence() {
        let model = lwr4();
        let mut isolator = ContactIsolator::new(&model, &lwr4_link_surfaces());
        let q = V7::from_column_slice(&[0.2, 0.7, -0.3, -1.3, 0.4, 0.9, 0.3]);
        let residual = V7::from_column_slice(&[0.05, -0.03, 0.02, 0.01, 0.0, 0.01, 0.0]);
        let e = isolator
            .isolate(&model, &q, &residual, &V7::repeat(1.0))
            .unwrap();
        assert!(e.confidence < 0.5, "{e:?}");
        assert!(
            isolator
                .isolate(&model, &q, &V7::repeat(f64::NAN), &V7::repeat(1.0))
                .is_none()
        );
    }

    #[test]
    fn most_distal_joint_is_the_isolated_link() {
        let mut s = JointSet::default();
        assert_eq!(isolate_link(s), None);
        s.insert(1);
        s.insert(4);
        s.insert(2);
        assert_eq!(isolate_link(s), Some(4));
        assert_eq!(s.len(), 3);
    }
}
