//! What thresholds detect: the static minimum detectable force per link.

use dynamics::{Data, Model, point_jacobian};
use nalgebra::SVector;
use serde::{Deserialize, Serialize};

use super::bootstrap::quantile_sorted;
use super::rng::SplitMix64;
use crate::isolation::LinkSurface;

/// Minimum detectable force on one link at given thresholds \[N\].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LinkForce {
    /// Median over configurations, surface points and force directions.
    pub median_n: f64,
    /// 10th percentile.
    pub p10_n: f64,
    /// 90th percentile.
    pub p90_n: f64,
}

/// Static minimum detectable force per link at thresholds `thresholds` \[Nm\]: for `samples`
/// random configurations (within `fraction` of the joint ranges), points on the link's surface
/// and force directions, the smallest |F| whose J_vᵀF reaches θ on some joint,
/// F_min = min_j θ_j/|(J_vᵀn)_j|; median and percentiles per link (deterministic for `seed`).
pub fn minimum_detectable_force<const N: usize>(
    model: &Model<N>,
    surfaces: &[LinkSurface; N],
    thresholds: &SVector<f64, N>,
    samples: usize,
    fraction: f64,
    seed: u64,
) -> Vec<LinkForce> {
    let mut data = Data::new(model);
    let mut rng = SplitMix64(seed);
    let limits = model.limits();
    (0..N)
        .map(|link| {
            let mut values: Vec<f64> = (0..samples.max(1))
                .map(|_| {
                    let q = SVector::<f64, N>::from_fn(|j, _| {
                        let (lo, hi) = (limits.position_min[j], limits.position_max[j]);
                        let mid = 0.5 * (lo + hi);
                        mid + (rng.uniform() - 0.5) * (hi - lo) * fraction
                    });
                    let (point, _) =
                        surfaces[link].point(rng.uniform(), std::f64::consts::TAU * rng.uniform());
                    let jv = point_jacobian(model, &mut data, &q, link, &point)
                        .fixed_rows::<3>(0)
                        .into_owned();
                    let torque = jv.transpose() * rng.unit_vector();
                    (0..N)
                        .map(|j| thresholds[j] / torque[j].abs())
                        .fold(f64::INFINITY, f64::min)
                })
                .collect();
            values.sort_by(f64::total_cmp);
            LinkForce {
                median_n: quantile_sorted(&values, 0.5),
                p10_n: quantile_sorted(&values, 0.1),
                p90_n: quantile_sorted(&values, 0.9),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimum_detectable_force_scales_with_the_thresholds() {
        let model = dynamics::lwr4();
        let surfaces = crate::isolation::lwr4_link_surfaces();
        let six = minimum_detectable_force(&model, &surfaces, &SVector::repeat(6.0), 300, 0.8, 1);
        let three = minimum_detectable_force(&model, &surfaces, &SVector::repeat(3.0), 300, 0.8, 1);
        for link in 0..7 {
            assert!((six[link].median_n / three[link].median_n - 2.0).abs() < 1e-9);
            assert!(six[link].p10_n <= six[link].median_n && six[link].median_n <= six[link].p90_n);
        }
        // Distal links (short levers to many joints) need less force than the shoulder links.
        assert!(six[6].median_n < six[1].median_n);
    }
}
