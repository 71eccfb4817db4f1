//! The arm re-expressed in its moving joint frames (the frame right after the joint's rotation about
//! or translation along its z axis). There every joint's motion subspace S is a unit vector along
//! z, so I·S is a column of the inertia and Sᵀf is one component of f: what the CRBA and the
//! Coriolis recursion use instead of the link frames.

use nalgebra::{Matrix3, Vector3};

use crate::inertia::InertialParameters;
use crate::joint::{Joint, JointKind};
use crate::spatial::{Force, Motion, Pose};

/// The constant parts of the chain in joint frames, derived from the joints and link parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct JointFrames<const N: usize> {
    /// Pose of joint frame i at q_i = 0 in the moving joint frame i−1 (the base frame for i = 0).
    in_previous: [Pose; N],
    /// Parameters of link i in joint frame i.
    links: [InertialParameters; N],
    /// Kind of joint i.
    kinds: [JointKind; N],
}

impl<const N: usize> JointFrames<N> {
    /// The joint frames of `joints` carrying `links` (each given in its link frame).
    pub fn new(joints: &[Joint; N], links: &[InertialParameters; N]) -> Self {
        Self {
            in_previous: std::array::from_fn(|i| match i.checked_sub(1) {
                None => *joints[i].placement_pose(),
                Some(previous) => joints[previous]
                    .body_pose()
                    .compose(joints[i].placement_pose()),
            }),
            links: std::array::from_fn(|i| {
                let body = joints[i].body_pose();
                links[i].transformed(&body.rot, &body.trans)
            }),
            kinds: std::array::from_fn(|i| joints[i].kind()),
        }
    }

    /// Parameters of link i in joint frame i.
    #[inline]
    pub fn links(&self) -> &[InertialParameters; N] {
        &self.links
    }

    /// Kind of joint i.
    #[inline]
    pub fn kind(&self, i: usize) -> JointKind {
        self.kinds[i]
    }

    /// Pose of moving joint frame i in moving joint frame i−1 at joint position `q` (rad or m).
    #[inline]
    pub fn pose(&self, i: usize, q: f64) -> Pose {
        let k = &self.in_previous[i];
        match self.kinds[i] {
            JointKind::Revolute => {
                // K·Rz(q) mixes the first two columns of K only.
                let (s, c) = q.sin_cos();
                let (x, y) = (k.rot.column(0), k.rot.column(1));
                Pose {
                    rot: Matrix3::from_columns(&[
                        x * c + y * s,
                        y * c - x * s,
                        k.rot.column(2).into_owned(),
                    ]),
                    trans: k.trans,
                }
            }
            JointKind::Prismatic => Pose {
                rot: k.rot,
                trans: k.trans + k.rot.column(2) * q,
            },
        }
    }
}

/// Unit joint motion S of a joint of `kind` whose moving joint frame has pose `frame` in some
/// frame F, expressed in F: rotation about or translation along the joint frame's z axis.
#[inline]
pub(crate) fn unit_motion_in(kind: JointKind, frame: &Pose) -> Motion {
    let z = frame.rot.column(2).into_owned();
    match kind {
        JointKind::Revolute => Motion {
            lin: frame.trans.cross(&z),
            ang: z,
        },
        JointKind::Prismatic => Motion {
            ang: Vector3::zeros(),
            lin: z,
        },
    }
}

/// Sᵀf for the joint of `kind` with `f` in its joint frame: the z moment or the z force, Nm or N.
#[inline]
pub(crate) fn project(kind: JointKind, f: &Force) -> f64 {
    match kind {
        JointKind::Revolute => f.ang.z,
        JointKind::Prismatic => f.lin.z,
    }
}

/// Sᵀ(X f) for the joint of `kind` whose joint frame is the parent of `pose`, with `f` in the child
/// frame: the one component of `pose.force_to_parent(f)` that the projection reads, alone.
#[inline]
pub(crate) fn project_in_parent(kind: JointKind, pose: &Pose, f: &Force) -> f64 {
    let r = &pose.rot;
    let row = |i: usize, v: &Vector3<f64>| r[(i, 0)] * v.x + r[(i, 1)] * v.y + r[(i, 2)] * v.z;
    match kind {
        // (R n + p × R f)_z
        JointKind::Revolute => {
            row(2, &f.ang) + pose.trans.x * row(1, &f.lin) - pose.trans.y * row(0, &f.lin)
        }
        // (R f)_z
        JointKind::Prismatic => row(2, &f.lin),
    }
}

/// I·S for the joint of `kind` with `inertia` in its joint frame (I·S is a column of I).
#[inline]
pub(crate) fn inertia_times_unit_motion(kind: JointKind, inertia: &InertialParameters) -> Force {
    let h = &inertia.first_moment;
    match kind {
        // n = J e_z, f = −h × e_z
        JointKind::Revolute => Force {
            ang: inertia.inertia_origin.column(2).into_owned(),
            lin: Vector3::new(-h.y, h.x, 0.0),
        },
        // n = h × e_z, f = m e_z
        JointKind::Prismatic => Force {
            ang: Vector3::new(h.y, -h.x, 0.0),
            lin: Vector3::new(0.0, 0.0, inertia.mass),
        },
    }
}
