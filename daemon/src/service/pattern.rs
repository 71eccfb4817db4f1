//! The estimation pose patterns, from the estimator's pose design (`estimator::poses`):
//!
//! - `paper`: the paper's "N samples with increments of ±7° per joint around the pick
//!   configuration" (Sec. VI-A), as the project defines it (lwr4-model.md §4, the golden Q10 set
//!   for 7°): q_k = around + step·u_k with u_kj = 2·frac(k·√p_j) − 1, k = 1..N;
//! - `optimized`: N poses inside the same ±step box chosen D-optimally (greedy + exchange) for
//!   the payload gravity parameters, which reaches the paper pattern's accuracy with fewer poses;
//! - `centred` (the default): the centre itself first, then N − 1 D-optimal poses of the ±step
//!   box with joint 1 kept at the centre (`estimator::poses::centred`). A procedure samples the
//!   centre first and again last: the drift revisit is the way home, and the tare and a later
//!   estimate meet at the centre, their samples nearest in time (docs/estimation.md, "Pose
//!   pattern, order and timing").
//!
//! Both are deterministic for the same inputs, so a tare and a later estimate visit the same
//! poses. Every pose is clamped inside the joint limits.

use dynamics::Model;
use estimator::poses::{Criterion, Nominal, centred, optimize, paper_pattern};
pub use fri_api::pattern::PatternKind;
use nalgebra::SVector;

/// Candidates screened by the optimiser.
const CANDIDATES: usize = 256;

/// `count` poses around `around` (rad) within ±`step_deg` degrees.
pub fn poses(
    kind: PatternKind,
    model: &Model<7>,
    around: &[f64; 7],
    count: usize,
    step_deg: f64,
) -> Result<Vec<[f64; 7]>, estimator::EstimatorError> {
    let center = SVector::<f64, 7>::from(*around);
    let spread = step_deg.to_radians();
    let qs = match kind {
        PatternKind::Paper => paper_pattern(model, &center, spread, count),
        PatternKind::Optimized => optimize(
            model,
            &center,
            spread,
            count,
            Criterion::D,
            CANDIDATES,
            &Nominal::default(),
        )?,
        PatternKind::Centred => centred(
            model,
            &center,
            spread,
            count,
            CANDIDATES,
            &Nominal::default(),
        )?,
    };
    Ok(qs
        .iter()
        .map(|q| {
            let mut a = [0.0; 7];
            a.copy_from_slice(q.as_slice());
            a
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_pattern_stays_within_the_step_and_is_deterministic() {
        let model = dynamics::lwr4();
        let around = [0.0, 0.5, 0.0, -1.2, 0.0, 0.8, 0.0];
        let a = poses(PatternKind::Paper, &model, &around, 10, 7.0).unwrap();
        let b = poses(PatternKind::Paper, &model, &around, 10, 7.0).unwrap();
        assert_eq!(a, b);
        assert_eq!(a.len(), 10);
        let step = 7f64.to_radians();
        for p in &a {
            for j in 0..7 {
                assert!((p[j] - around[j]).abs() < step + 1e-12);
            }
        }
        for (k, p) in a.iter().enumerate() {
            for other in &a[..k] {
                assert_ne!(p, other);
            }
        }
    }

    #[test]
    fn centred_pattern_starts_at_the_centre() {
        let model = dynamics::lwr4();
        let around = [0.0, 0.5, 0.0, -1.2, 0.0, 0.8, 0.0];
        let a = poses(PatternKind::Centred, &model, &around, 10, 5.0).unwrap();
        assert_eq!(a.len(), 10);
        assert_eq!(a[0], around);
        assert!(a.iter().all(|p| p[0] == around[0]));
        assert_eq!(
            a,
            poses(PatternKind::Centred, &model, &around, 10, 5.0).unwrap()
        );
    }

    #[test]
    fn optimized_pattern_has_more_information_than_the_paper_pattern() {
        // D-optimality: det(Σ YᵀY) of the payload gravity regressor (eq. 40) is larger.
        let model = dynamics::lwr4();
        let mut data = dynamics::Data::new(&model);
        let around = [0.0, 0.5, 0.0, -1.2, 0.0, 0.8, 0.0];
        let mut det = |kind| {
            let info: nalgebra::Matrix4<f64> = poses(kind, &model, &around, 6, 7.0)
                .unwrap()
                .iter()
                .map(|q| {
                    let y =
                        dynamics::payload_gravity_regressor(&model, &mut data, &SVector::from(*q));
                    y.transpose() * y
                })
                .sum();
            info.determinant()
        };
        let (opt, paper) = (det(PatternKind::Optimized), det(PatternKind::Paper));
        assert!(opt > paper, "optimized {opt} vs paper {paper}");
    }
}
