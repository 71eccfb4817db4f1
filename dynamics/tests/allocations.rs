//! Every hot-path algorithm runs without touching the heap (N = 7, the LWR).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{
    Data, compute_generalized_gravity, coriolis_matrix, coriolis_transpose_times_velocity, crba,
    forward_dynamics, forward_kinematics, gravity_regressor, joint_torque_regressor, lwr4,
    nonlinear_effects, payload_gravity_regressor, payload_regressor, point_jacobian, rnea,
};
use nalgebra::{SVector, Vector3};

#[global_allocator]
static ALLOCATOR: alloc_counter::CountingAllocator = alloc_counter::CountingAllocator;

#[test]
fn hot_paths_do_not_allocate() {
    let model = lwr4();
    let mut data = Data::new(&model);
    let q = SVector::<f64, 7>::from([0.1, 0.5, -0.3, -1.2, 0.4, 0.9, -0.2]);
    let qd = SVector::<f64, 7>::from([0.3, -0.2, 0.5, 0.1, -0.4, 0.6, 0.2]);
    let qdd = SVector::<f64, 7>::from([1.0, -0.5, 0.2, 0.3, -0.1, 0.4, 0.7]);
    let tau = rnea(&model, &mut data, &q, &qd, &qdd);

    let mut sink = 0.0;
    let check = |name: &str, count: u64| assert_eq!(count, 0, "{name} allocated {count} times");
    check(
        "rnea",
        alloc_counter::count_allocations(|| sink += rnea(&model, &mut data, &q, &qd, &qdd)[0]),
    );
    check(
        "gravity",
        alloc_counter::count_allocations(|| {
            sink += compute_generalized_gravity(&model, &mut data, &q)[1]
        }),
    );
    check(
        "crba",
        alloc_counter::count_allocations(|| sink += crba(&model, &mut data, &q)[(1, 1)]),
    );
    check(
        "nonlinear_effects",
        alloc_counter::count_allocations(|| {
            sink += nonlinear_effects(&model, &mut data, &q, &qd)[1]
        }),
    );
    check(
        "coriolis_centrifugal_torques",
        alloc_counter::count_allocations(|| {
            sink += dynamics::coriolis_centrifugal_torques(&model, &mut data, &q, &qd)[1]
        }),
    );
    check(
        "coriolis_transpose_times_velocity",
        alloc_counter::count_allocations(|| {
            sink += coriolis_transpose_times_velocity(&model, &mut data, &q, &qd)[1]
        }),
    );
    check(
        "coriolis_matrix",
        alloc_counter::count_allocations(|| {
            sink += coriolis_matrix(&model, &mut data, &q, &qd)[(1, 2)]
        }),
    );
    check(
        "payload_gravity_regressor",
        alloc_counter::count_allocations(|| {
            sink += payload_gravity_regressor(&model, &mut data, &q)[(1, 0)]
        }),
    );
    check(
        "payload_regressor",
        alloc_counter::count_allocations(|| {
            sink += payload_regressor(&model, &mut data, &q, &qd, &qdd)[(1, 0)]
        }),
    );
    check(
        "joint_torque_regressor",
        alloc_counter::count_allocations(|| {
            sink += joint_torque_regressor(&model, &mut data, &q, &qd, &qdd)[6][(1, 0)]
        }),
    );
    check(
        "gravity_regressor",
        alloc_counter::count_allocations(|| {
            sink += gravity_regressor(&model, &mut data, &q)[6][(1, 0)]
        }),
    );
    check(
        "forward_dynamics",
        alloc_counter::count_allocations(|| {
            sink += forward_dynamics(&model, &mut data, &q, &qd, &tau).unwrap()[0]
        }),
    );
    check(
        "forward_kinematics",
        alloc_counter::count_allocations(|| {
            sink += forward_kinematics(&model, &mut data, &q)[6].translation.x
        }),
    );
    check(
        "point_jacobian",
        alloc_counter::count_allocations(|| {
            sink += point_jacobian(&model, &mut data, &q, 6, &Vector3::new(0.0, 0.0, 0.078))[(0, 0)]
        }),
    );
    assert!(sink.is_finite());
}
