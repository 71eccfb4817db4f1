//! Synthetic static data for tests, benchmarks and what-if studies: a "true" loaded robot, the
//! controller's (possibly wrong) model, and torque-sensor noise supplied by the caller.

use dynamics::{Data, InertialParameters, Model, compute_generalized_gravity};
use nalgebra::SVector;

use crate::samples::StaticSample;

/// The controller's model: `model` with δm_i (kg) and δ(m c)_i (kg·m, frame i) added per link,
/// rows `[δm, δ(mcx), δ(mcy), δ(mcz)]` (the perturbation of lwr4-model.md §4); inertia unchanged.
pub fn perturbed_model<const N: usize>(model: &Model<N>, dp: &[[f64; 4]; N]) -> Model<N> {
    let mut links = *model.links();
    for (link, d) in links.iter_mut().zip(dp) {
        link.mass += d[0];
        link.first_moment += nalgebra::Vector3::new(d[1], d[2], d[3]);
    }
    model.with_links(links)
}

/// Static samples at `poses`: τ_J = g_true+payload(q) + noise(k, j), g = g_ctrl(q).
pub fn static_samples<const N: usize>(
    truth: &Model<N>,
    payload: &InertialParameters,
    controller: &Model<N>,
    poses: &[SVector<f64, N>],
    mut noise: impl FnMut(usize, usize) -> f64,
) -> Vec<StaticSample<N>> {
    let loaded = truth.with_payload(payload);
    let mut dl = Data::new(&loaded);
    let mut dc = Data::new(controller);
    poses
        .iter()
        .enumerate()
        .map(|(k, q)| {
            let mut tau = compute_generalized_gravity(&loaded, &mut dl, q);
            for j in 0..N {
                tau[j] += noise(k, j);
            }
            StaticSample::new(*q, tau, compute_generalized_gravity(controller, &mut dc, q))
        })
        .collect()
}

/// The example draw of lwr4-model.md §4 (`controller_model_example.dp` of lwr4-golden.json):
/// per link [δm (kg), δ(mcx), δ(mcy), δ(mcz) (kg·m)].
pub const LWR4_EXAMPLE_PERTURBATION: [[f64; 4]; 7] = [
    [-0.01213, -0.00186, -0.00294, 0.00344],
    [-0.03103, 0.00096, -0.00492, -0.00297],
    [-0.02672, -0.00306, 0.00198, 0.00481],
    [-0.00606, -0.0006, 0.00048, 0.00061],
    [0.02036, 0.00019, -0.00506, 0.00266],
    [-0.04446, 0.00493, -0.0024, -0.00537],
    [0.01211, 0.00391, 0.00055, 0.00154],
];
