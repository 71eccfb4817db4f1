//! The estimation pose pattern: the paper's "N samples with increments of ±7° per joint around
//! the pick configuration" (Sec. VI-A).
//!
//! The paper does not list its poses; we use a two-level design: pose k offsets every joint j by
//! ±step with the sign of row (k mod 8) of the 8 × 8 Walsh–Hadamard matrix, column j + 1
//! (−1 to the power popcount(k & (j+1))). Columns are orthogonal, so the orientation of the last
//! link varies in independent directions and the 4 payload gravity parameters are well
//! conditioned with as few as 5 poses. Poses 8..15 use half the step, 16.. a quarter, so no pose
//! repeats. Every pose is clamped into the joint limits minus a margin.

use dynamics::JointLimits;

/// Margin kept from the joint position limits, rad (5°).
pub const LIMIT_MARGIN: f64 = 0.087_266_462_599_716_48;

/// `count` poses around `around` (rad) with increments `step_deg` (degrees).
pub fn paper_pattern(
    around: &[f64; 7],
    count: usize,
    step_deg: f64,
    limits: &JointLimits<7>,
) -> Vec<[f64; 7]> {
    let step = step_deg.to_radians();
    (0..count)
        .map(|k| {
            let row = (k % 8) as u32;
            let scale = 0.5f64.powi((k / 8) as i32);
            std::array::from_fn(|j| {
                let sign = if (row & (j as u32 + 1)).count_ones().is_multiple_of(2) {
                    1.0
                } else {
                    -1.0
                };
                let lo = limits.position_min[j] + LIMIT_MARGIN;
                let hi = limits.position_max[j] - LIMIT_MARGIN;
                (around[j] + sign * step * scale).clamp(lo.min(hi), hi.max(lo))
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ten_distinct_poses_at_plus_minus_seven_degrees() {
        let around = [0.0, 0.5, 0.0, -1.2, 0.0, 0.8, 0.0];
        let poses = paper_pattern(&around, 10, 7.0, dynamics::lwr4().limits());
        assert_eq!(poses.len(), 10);
        let step = 7f64.to_radians();
        for (k, p) in poses.iter().enumerate() {
            for j in 0..7 {
                let d = (p[j] - around[j]).abs();
                let expect = if k < 8 { step } else { step / 2.0 };
                assert!((d - expect).abs() < 1e-12, "pose {k} joint {j}: {d}");
            }
            for other in &poses[..k] {
                assert_ne!(p, other, "pose {k} repeats");
            }
        }
        // Pose 0 is all +7°, pose 1 alternates starting with −7° on joint 1.
        assert!(poses[0].iter().zip(&around).all(|(p, a)| p > a));
        assert!(poses[1][0] < around[0] && poses[1][1] > around[1]);
    }

    #[test]
    fn poses_stay_inside_the_limits() {
        let limits = *dynamics::lwr4().limits();
        let mut around = [0.0; 7];
        around[1] = limits.position_max[1]; // at the limit
        for p in paper_pattern(&around, 10, 7.0, &limits) {
            assert!(p[1] <= limits.position_max[1] - LIMIT_MARGIN + 1e-12);
        }
    }
}
