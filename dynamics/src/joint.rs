//! Joints: every joint is "fixed placement, then a rotation about / translation along the local
//! z axis, then a fixed transform to the body (link) frame". That covers classical DH, modified
//! DH (Khalil) and URDF joints with any axis.

use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};

use crate::spatial::{Motion, Pose};

/// Kind of a one-degree-of-freedom joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JointKind {
    /// Rotation about the joint z axis; the joint variable is in rad.
    Revolute,
    /// Translation along the joint z axis; the joint variable is in m.
    Prismatic,
}

/// Classical (distal) Denavit-Hartenberg row: T = Rz(θ + q)·Tz(d)·Tx(a)·Rx(α) for a revolute
/// joint, T = Rz(θ)·Tz(d + q)·Tx(a)·Rx(α) for a prismatic one.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClassicalDh {
    /// Link length a, m.
    pub a: f64,
    /// Link twist α, rad.
    pub alpha: f64,
    /// Link offset d, m.
    pub d: f64,
    /// Joint angle offset θ, rad.
    pub theta: f64,
}

/// Modified (proximal, Khalil) Denavit-Hartenberg row: T = Rx(α)·Tx(d)·Rz(θ + q)·Tz(r) for a
/// revolute joint, T = Rx(α)·Tx(d)·Rz(θ)·Tz(r + q) for a prismatic one.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ModifiedDh {
    /// Twist α about the previous x axis, rad.
    pub alpha: f64,
    /// Distance d along the previous x axis, m.
    pub d: f64,
    /// Joint angle offset θ, rad.
    pub theta: f64,
    /// Offset r along the new z axis, m.
    pub r: f64,
}

/// One joint and the fixed transforms around it; the body it moves is the link after it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Joint {
    kind: JointKind,
    placement: Isometry3<f64>,
    body_in_joint: Isometry3<f64>,
    // Cached matrix forms of the two isometries.
    placement_pose: Pose,
    placement_is_identity: bool,
    body_pose: Pose,
    motion_subspace: Motion,
}

fn pose_of(iso: &Isometry3<f64>) -> Pose {
    Pose {
        rot: iso.rotation.to_rotation_matrix().into_inner(),
        trans: iso.translation.vector,
    }
}

fn rot_x(angle: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), angle),
    )
}

fn rot_z(angle: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), angle),
    )
}

fn trans(x: f64, y: f64, z: f64) -> Isometry3<f64> {
    Isometry3::translation(x, y, z)
}

impl Joint {
    /// A joint of `kind` whose frame (at q = 0) has pose `placement` in the parent link frame and
    /// whose link frame has pose `body_in_joint` in the moving joint frame; motion is about / along
    /// the joint frame's z axis.
    pub fn new(kind: JointKind, placement: Isometry3<f64>, body_in_joint: Isometry3<f64>) -> Self {
        let placement_pose = pose_of(&placement);
        let body_pose = pose_of(&body_in_joint);
        // Joint axis and a point on it, in the link frame: B⁻¹ applied to (e_z, 0).
        let axis = body_pose.rot.tr_mul(&Vector3::z());
        let point = -body_pose.rot.tr_mul(&body_pose.trans);
        let motion_subspace = match kind {
            JointKind::Revolute => Motion {
                ang: axis,
                lin: point.cross(&axis),
            },
            JointKind::Prismatic => Motion {
                ang: Vector3::zeros(),
                lin: axis,
            },
        };
        let placement_is_identity = placement_pose == Pose::IDENTITY;
        Self {
            kind,
            placement,
            body_in_joint,
            placement_pose,
            placement_is_identity,
            body_pose,
            motion_subspace,
        }
    }

    /// Joint from a classical DH row (see [`ClassicalDh`]).
    pub fn classical_dh(kind: JointKind, dh: &ClassicalDh) -> Self {
        let tail = trans(dh.a, 0.0, 0.0) * rot_x(dh.alpha);
        match kind {
            JointKind::Revolute => Self::new(kind, rot_z(dh.theta), trans(0.0, 0.0, dh.d) * tail),
            JointKind::Prismatic => Self::new(kind, rot_z(dh.theta) * trans(0.0, 0.0, dh.d), tail),
        }
    }

    /// Joint from a modified DH row (see [`ModifiedDh`]).
    pub fn modified_dh(kind: JointKind, dh: &ModifiedDh) -> Self {
        let head = rot_x(dh.alpha) * trans(dh.d, 0.0, 0.0) * rot_z(dh.theta);
        match kind {
            JointKind::Revolute => Self::new(kind, head, trans(0.0, 0.0, dh.r)),
            JointKind::Prismatic => {
                Self::new(kind, head * trans(0.0, 0.0, dh.r), Isometry3::identity())
            }
        }
    }

    /// Revolute or prismatic.
    pub fn kind(&self) -> JointKind {
        self.kind
    }

    /// Pose of the joint frame at q = 0 in the parent link frame.
    pub fn placement(&self) -> &Isometry3<f64> {
        &self.placement
    }

    /// Pose of the link frame in the moving joint frame.
    pub fn body_in_joint(&self) -> &Isometry3<f64> {
        &self.body_in_joint
    }

    /// Joint axis (unit vector) in the link frame.
    pub fn axis_in_link(&self) -> Vector3<f64> {
        match self.kind {
            JointKind::Revolute => self.motion_subspace.ang,
            JointKind::Prismatic => self.motion_subspace.lin,
        }
    }

    /// Pose of the link frame in the parent link frame at joint position `q` (rad or m).
    pub fn link_pose(&self, q: f64) -> Isometry3<f64> {
        let motion = match self.kind {
            JointKind::Revolute => rot_z(q),
            JointKind::Prismatic => trans(0.0, 0.0, q),
        };
        self.placement * motion * self.body_in_joint
    }

    /// Pose of the joint frame at q = 0 in the parent link frame (matrix form of `placement`).
    #[inline]
    pub(crate) fn placement_pose(&self) -> &Pose {
        &self.placement_pose
    }

    /// Pose of the link frame in the moving joint frame (matrix form of `body_in_joint`).
    #[inline]
    pub(crate) fn body_pose(&self) -> &Pose {
        &self.body_pose
    }

    /// Motion subspace S (unit joint velocity as a spatial motion vector) in the link frame.
    #[inline]
    pub(crate) fn motion_subspace(&self) -> &Motion {
        &self.motion_subspace
    }

    /// Pose of the link frame in the parent link frame at joint position `q`.
    #[inline]
    pub(crate) fn pose(&self, q: f64) -> Pose {
        let b = &self.body_pose;
        let (rot, tr) = match self.kind {
            JointKind::Revolute => {
                let (s, c) = q.sin_cos();
                let r = &b.rot;
                // Rz(q)·R_B touches only the first two rows.
                let rot = Matrix3::new(
                    c * r[(0, 0)] - s * r[(1, 0)],
                    c * r[(0, 1)] - s * r[(1, 1)],
                    c * r[(0, 2)] - s * r[(1, 2)],
                    s * r[(0, 0)] + c * r[(1, 0)],
                    s * r[(0, 1)] + c * r[(1, 1)],
                    s * r[(0, 2)] + c * r[(1, 2)],
                    r[(2, 0)],
                    r[(2, 1)],
                    r[(2, 2)],
                );
                let p = &b.trans;
                let tr = Vector3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z);
                (rot, tr)
            }
            JointKind::Prismatic => (b.rot, b.trans + Vector3::new(0.0, 0.0, q)),
        };
        if self.placement_is_identity {
            Pose { rot, trans: tr }
        } else {
            let a = &self.placement_pose;
            Pose {
                rot: a.rot * rot,
                trans: a.trans + a.rot * tr,
            }
        }
    }

    /// Checks that all transforms are finite.
    pub(crate) fn is_finite(&self) -> bool {
        let p = &self.placement;
        let b = &self.body_in_joint;
        p.translation.vector.iter().all(|v| v.is_finite())
            && p.rotation.coords.iter().all(|v| v.is_finite())
            && b.translation.vector.iter().all(|v| v.is_finite())
            && b.rotation.coords.iter().all(|v| v.is_finite())
    }
}
