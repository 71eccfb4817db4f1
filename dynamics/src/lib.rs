//! Rigid-body dynamics of serial robot arms, in the style of Pinocchio: an immutable [`Model`],
//! a preallocated [`Data`] workspace, and algorithms as free functions named after the textbook
//! algorithm ([`rnea`], [`crba`], [`compute_generalized_gravity`], ...).
//!
//! Conventions: SI units, angles in rad. Link frame i is the frame of the body moved by joint i
//! (for the built-in LWR: classical DH frame i). Link inertial parameters ([`InertialParameters`])
//! are expressed in their link frame, with the inertia tensor about the link-frame origin (the
//! paper's J). g(q) follows τ = M(q)q̈ + C(q,q̇)q̇ + g(q): it is the torque that holds the arm.
//! Spatial vectors used internally put the angular part first; Jacobians returned to callers put
//! the linear part first (rows v; ω).
//!
//! All algorithms for fixed N are allocation-free (proved by `tests/allocations.rs`).
//!
//! ```
//! use dynamics::{Data, compute_generalized_gravity, crba, lwr4, lwr4_heavy_payload, rnea};
//! use nalgebra::SVector;
//!
//! let model = lwr4().with_payload(&lwr4_heavy_payload());
//! let mut data = Data::new(&model);
//! let q = SVector::<f64, 7>::from([0.3, std::f64::consts::FRAC_PI_2, 0.0, 0.0, 0.0, 0.0, 0.0]);
//! let g = compute_generalized_gravity(&model, &mut data, &q);
//! assert!((g[1] - (-47.2782 - 27.0016)).abs() < 1e-3); // lwr4-model.md §3, configuration qA
//! let m = crba(&model, &mut data, &q);
//! let tau = rnea(&model, &mut data, &q, &SVector::zeros(), &SVector::repeat(1.0));
//! assert!((tau - (m * SVector::<f64, 7>::repeat(1.0) + g)).norm() < 1e-9);
//! ```

mod base_parameters;
mod coriolis;
mod crba;
mod data;
mod error;
mod forward_dynamics;
pub mod identified;
mod inertia;
mod joint;
mod joint_frames;
mod kinematics;
mod model;
mod regressor;
mod rnea;
mod robot_file;
mod robots;
mod spatial;
mod urdf;

pub use base_parameters::{
    BaseParameters, ColumnChoice, RegressorKind, base_parameters, base_parameters_of_columns,
    stacked_gravity_regressor,
};
pub use coriolis::{
    coriolis_matrix, coriolis_transpose_times_velocity, mass_matrix_partial_derivatives,
    mass_matrix_time_derivative,
};
pub use crba::crba;
pub use data::Data;
pub use error::{DynamicsError, check_finite};
pub use forward_dynamics::forward_dynamics;
pub use identified::{IdentifiedFile, IdentifiedModel};
pub use inertia::InertialParameters;
pub use joint::{ClassicalDh, Joint, JointKind, ModifiedDh};
pub use kinematics::{flange_jacobian, flange_pose, forward_kinematics, point_jacobian};
pub use model::{JointLimits, Model};
pub use regressor::{
    gravity_regressor, joint_torque_regressor, payload_gravity_regressor, payload_regressor,
};
pub use rnea::{
    compute_generalized_gravity, coriolis_centrifugal_torques, nonlinear_effects, rnea,
};
pub use robot_file::{JointSpec, LimitsSpec, LinkSpec, PoseSpec, RobotFile};
pub use robots::{
    LWR_BASE_TO_SHOULDER, LWR_FLANGE_OFFSET, LWR4_PICK_POSE_DEG, LWR4_PICK_POSE_RAD,
    LWR4_POSITION_LIMITS_DEG, LWR4_TORQUE_LIMITS_NM, LWR4_VELOCITY_LIMITS_DEG_S, STANDARD_GRAVITY,
    degrees_to_radians, inertia_tensor, lwr4, lwr4_heavy_payload, lwr4_light_payload, lwr4_limits,
    lwr4_links, lwr4_modified_dh, planar_2r, planar_2r_payload,
};
