//! Preallocated workspace for the algorithms (Pinocchio's `Data`).

use crate::inertia::InertialParameters;
use crate::model::Model;
use crate::spatial::{Force, Motion, Pose};

/// Scratch space for the algorithms of one model; create once with [`Data::new`] and reuse, so
/// that no algorithm allocates. Its contents after a call are an implementation detail.
#[derive(Debug, Clone)]
pub struct Data<const N: usize> {
    /// Pose of link i in link i−1 (link 0 in the base).
    pub(crate) link_in_parent: [Pose; N],
    /// Pose of link i in the base.
    pub(crate) link_in_base: [Pose; N],
    /// Pose of moving joint frame i in moving joint frame i−1 (joint frame 0 in the base).
    pub(crate) joint_in_previous: [Pose; N],
    /// Pose of moving joint frame i in the base.
    pub(crate) joint_in_base: [Pose; N],
    /// Spatial velocity of link i in its own frame.
    pub(crate) velocity: [Motion; N],
    /// Spatial acceleration (gravity included) of link i in its own frame.
    pub(crate) acceleration: [Motion; N],
    /// Spatial force or momentum accumulator of link i in its own frame.
    pub(crate) force: [Force; N],
    /// Joint motion subspaces S_j re-expressed in the frame of the link being processed.
    pub(crate) axes: [Motion; N],
    /// Composite inertia of the subtree rooted at link i, in joint frame i.
    pub(crate) composite: [InertialParameters; N],
    /// Joint motion subspace S_i in the base frame.
    pub(crate) axes_in_base: [Motion; N],
    /// Its rate Ṡ_i = v_i ×m S_i in the base frame.
    pub(crate) axes_rate_in_base: [Motion; N],
    /// Composite inertia of the subtree rooted at link i, in the base frame.
    pub(crate) composite_in_base: [InertialParameters; N],
    /// Composite rate of that inertia, Σ_{b ≥ i} İ_b (mass rate zero), in the base frame.
    pub(crate) composite_rate_in_base: [InertialParameters; N],
    /// Composite momentum Σ_{b ≥ i} I_b v_b in the base frame.
    pub(crate) composite_momentum_in_base: [Force; N],
}

impl<const N: usize> Data<N> {
    /// Workspace sized for `model`.
    pub fn new(model: &Model<N>) -> Self {
        let _ = model;
        Self {
            link_in_parent: [Pose::IDENTITY; N],
            link_in_base: [Pose::IDENTITY; N],
            joint_in_previous: [Pose::IDENTITY; N],
            joint_in_base: [Pose::IDENTITY; N],
            velocity: [Motion::ZERO; N],
            acceleration: [Motion::ZERO; N],
            force: [Force::ZERO; N],
            axes: [Motion::ZERO; N],
            composite: [InertialParameters::zero(); N],
            axes_in_base: [Motion::ZERO; N],
            axes_rate_in_base: [Motion::ZERO; N],
            composite_in_base: [InertialParameters::zero(); N],
            composite_rate_in_base: [InertialParameters::zero(); N],
            composite_momentum_in_base: [Force::ZERO; N],
        }
    }
}
