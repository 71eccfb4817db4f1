//! Minimal spatial-vector algebra (Featherstone), written with 3-vectors so that it stays
//! allocation-free and cheap. Motion and force vectors are expressed in a body frame, at its
//! origin; the angular part comes first.

use nalgebra::{Matrix3, Vector3};

/// Spatial motion vector: angular velocity ω (rad/s) and linear velocity of the frame origin (m/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Motion {
    /// Angular part.
    pub ang: Vector3<f64>,
    /// Linear part (velocity of the body point at the frame origin).
    pub lin: Vector3<f64>,
}

/// Spatial force vector: moment about the frame origin (Nm) and force (N).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Force {
    /// Moment about the frame origin.
    pub ang: Vector3<f64>,
    /// Force.
    pub lin: Vector3<f64>,
}

impl Motion {
    /// The zero motion.
    pub const ZERO: Motion = Motion {
        ang: Vector3::new(0.0, 0.0, 0.0),
        lin: Vector3::new(0.0, 0.0, 0.0),
    };

    /// Motion cross product self ×m other.
    #[inline]
    pub fn cross_motion(&self, other: &Motion) -> Motion {
        Motion {
            ang: self.ang.cross(&other.ang),
            lin: self.ang.cross(&other.lin) + self.lin.cross(&other.ang),
        }
    }

    /// Force cross product self ×* f.
    #[inline]
    pub fn cross_force(&self, f: &Force) -> Force {
        Force {
            ang: self.ang.cross(&f.ang) + self.lin.cross(&f.lin),
            lin: self.ang.cross(&f.lin),
        }
    }

    /// Power pairing motion · force.
    #[inline]
    pub fn dot(&self, f: &Force) -> f64 {
        self.ang.dot(&f.ang) + self.lin.dot(&f.lin)
    }

    /// self scaled by `s`.
    #[inline]
    pub fn scale(&self, s: f64) -> Motion {
        Motion {
            ang: self.ang * s,
            lin: self.lin * s,
        }
    }

    /// self + other.
    #[inline]
    pub fn add(&self, other: &Motion) -> Motion {
        Motion {
            ang: self.ang + other.ang,
            lin: self.lin + other.lin,
        }
    }
}

impl Force {
    /// The zero force.
    pub const ZERO: Force = Force {
        ang: Vector3::new(0.0, 0.0, 0.0),
        lin: Vector3::new(0.0, 0.0, 0.0),
    };

    /// self scaled by `s`.
    #[inline]
    pub fn scale(&self, s: f64) -> Force {
        Force {
            ang: self.ang * s,
            lin: self.lin * s,
        }
    }

    /// self − other.
    #[inline]
    pub fn sub(&self, other: &Force) -> Force {
        Force {
            ang: self.ang - other.ang,
            lin: self.lin - other.lin,
        }
    }

    /// self + other.
    #[inline]
    pub fn add(&self, other: &Force) -> Force {
        Force {
            ang: self.ang + other.ang,
            lin: self.lin + other.lin,
        }
    }
}

/// Pose of a child frame in its parent frame: x_parent = rot · x_child + trans.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Pose {
    /// Rotation child → parent.
    pub rot: Matrix3<f64>,
    /// Child origin in parent coordinates, m.
    pub trans: Vector3<f64>,
}

impl Pose {
    /// The identity pose.
    pub const IDENTITY: Pose = Pose {
        rot: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        trans: Vector3::new(0.0, 0.0, 0.0),
    };

    /// A motion vector of the parent frame expressed in the child frame.
    #[inline]
    pub fn motion_to_child(&self, m: &Motion) -> Motion {
        Motion {
            ang: self.rot.tr_mul(&m.ang),
            lin: self.rot.tr_mul(&(m.lin + m.ang.cross(&self.trans))),
        }
    }

    /// A motion vector of the child frame expressed in the parent frame.
    #[inline]
    pub fn motion_to_parent(&self, m: &Motion) -> Motion {
        let ang = self.rot * m.ang;
        Motion {
            ang,
            lin: self.rot * m.lin + self.trans.cross(&ang),
        }
    }

    /// A force vector of the child frame expressed in the parent frame.
    #[inline]
    pub fn force_to_parent(&self, f: &Force) -> Force {
        let lin = self.rot * f.lin;
        Force {
            ang: self.rot * f.ang + self.trans.cross(&lin),
            lin,
        }
    }

    /// Composition self ∘ child: the pose of a grandchild frame given its pose in the child.
    #[inline]
    pub fn compose(&self, child: &Pose) -> Pose {
        Pose {
            rot: self.rot * child.rot,
            trans: self.trans + self.rot * child.trans,
        }
    }
}
