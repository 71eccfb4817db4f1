//! Speed of the static estimator: 10 paper-pattern poses and 500 random poses (LWR 4+), both
//! formulations, and the pose optimiser.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use criterion::{Criterion, criterion_group, criterion_main};
use dynamics::{InertialParameters, lwr4};
use estimator::basis::{GravityBasis, spread_poses};
use estimator::estimate::{EstimateOptions, estimate_coefficients, estimate_direct};
use estimator::poses::{self, Nominal};
use estimator::sim::{LWR4_EXAMPLE_PERTURBATION, perturbed_model, static_samples};
use nalgebra::{SVector, Vector3};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let model = lwr4();
    let ctrl = perturbed_model(&model, &LWR4_EXAMPLE_PERTURBATION);
    let payload = InertialParameters::point_mass(3.028, Vector3::new(0.0, 0.0, 0.119));
    let pick = SVector::<f64, 7>::from(dynamics::LWR4_PICK_POSE_RAD);
    let q10 = poses::paper_pattern(&model, &pick, 7f64.to_radians(), 10);
    let lim = model.limits();
    let q500 = spread_poses(&lim.position_min, &lim.position_max, 500);
    let mut k = 0u64;
    let mut noise = move |_: usize, _: usize| {
        k = k
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        0.05 * ((k >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 3.46
    };
    let s10 = static_samples(&model, &payload, &ctrl, &q10, &mut noise);
    let s500 = static_samples(&model, &payload, &ctrl, &q500, &mut noise);
    let opts = EstimateOptions::default();
    c.bench_function("estimate_direct/10_poses", |b| {
        b.iter(|| estimate_direct(&model, black_box(&s10), &opts).unwrap())
    });
    c.bench_function("estimate_direct/500_poses", |b| {
        b.iter(|| estimate_direct(&model, black_box(&s500), &opts).unwrap())
    });
    let basis = GravityBasis::of_model(&model);
    c.bench_function("estimate_coefficients/10_poses", |b| {
        b.iter(|| estimate_coefficients(&model, &basis, black_box(&s10), &opts).unwrap())
    });
    c.bench_function("estimate_coefficients/500_poses", |b| {
        b.iter(|| estimate_coefficients(&model, &basis, black_box(&s500), &opts).unwrap())
    });
    c.bench_function("gravity_basis/lwr4", |b| {
        b.iter(|| GravityBasis::compute(black_box(&model)))
    });
    let nominal = Nominal::default();
    c.bench_function("poses_optimize/10_of_300_candidates", |b| {
        b.iter(|| {
            poses::optimize(
                &model,
                black_box(&pick),
                7f64.to_radians(),
                10,
                poses::Criterion::D,
                300,
                &nominal,
            )
            .unwrap()
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
