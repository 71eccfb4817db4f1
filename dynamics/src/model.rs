//! The immutable robot model: joints, link inertial parameters, gravity, flange, limits.

use nalgebra::{Isometry3, SVector, Vector3};

use crate::error::{DynamicsError, check_finite_slice};
use crate::inertia::InertialParameters;
use crate::joint::Joint;
use crate::joint_frames::JointFrames;

/// Joint limits of an N-joint arm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointLimits<const N: usize> {
    /// Lower position limit per joint, rad (m for prismatic joints).
    pub position_min: SVector<f64, N>,
    /// Upper position limit per joint, rad (m for prismatic joints).
    pub position_max: SVector<f64, N>,
    /// Speed limit per joint (|q̇| ≤ limit), rad/s (m/s for prismatic joints).
    pub velocity_max: SVector<f64, N>,
    /// Torque limit per joint (|τ| ≤ limit), Nm (N for prismatic joints).
    pub torque_max: SVector<f64, N>,
}

impl<const N: usize> JointLimits<N> {
    /// Limits with no bound at all (infinite everywhere).
    pub fn unlimited() -> Self {
        Self {
            position_min: SVector::repeat(f64::NEG_INFINITY),
            position_max: SVector::repeat(f64::INFINITY),
            velocity_max: SVector::repeat(f64::INFINITY),
            torque_max: SVector::repeat(f64::INFINITY),
        }
    }

    /// Symmetric limits ±`position` (rad), `velocity` (rad/s) and `torque` (Nm) per joint.
    pub fn symmetric(
        position: SVector<f64, N>,
        velocity: SVector<f64, N>,
        torque: SVector<f64, N>,
    ) -> Self {
        Self {
            position_min: -position,
            position_max: position,
            velocity_max: velocity,
            torque_max: torque,
        }
    }

    /// Checks min < max, no NaN, and positive velocity and torque limits.
    pub fn validate(&self) -> Result<(), DynamicsError> {
        for joint in 0..N {
            let (lo, hi) = (self.position_min[joint], self.position_max[joint]);
            if lo.is_nan() || hi.is_nan() || lo >= hi {
                return Err(DynamicsError::InvalidLimits {
                    joint,
                    reason: format!("position range [{lo}, {hi}] is empty or NaN"),
                });
            }
            let v = self.velocity_max[joint];
            if v.is_nan() || v <= 0.0 {
                return Err(DynamicsError::InvalidLimits {
                    joint,
                    reason: format!("velocity limit {v} is not positive"),
                });
            }
            let t = self.torque_max[joint];
            if t.is_nan() || t <= 0.0 {
                return Err(DynamicsError::InvalidLimits {
                    joint,
                    reason: format!("torque limit {t} is not positive"),
                });
            }
        }
        Ok(())
    }

    /// True when every joint position lies inside [position_min, position_max].
    pub fn contains_position(&self, q: &SVector<f64, N>) -> bool {
        (0..N).all(|i| q[i] >= self.position_min[i] && q[i] <= self.position_max[i])
    }
}

/// Immutable model of a serial N-joint arm (Pinocchio style: algorithms take it with a [`crate::Data`]).
///
/// Frame conventions: frame 0 is the base; link frame i (1-based in the paper, index i−1 here) is
/// the frame of the body moved by joint i, e.g. the classical DH frame i.
#[derive(Debug, Clone, PartialEq)]
pub struct Model<const N: usize> {
    name: String,
    joints: [Joint; N],
    links: [InertialParameters; N],
    gravity: Vector3<f64>,
    flange: Isometry3<f64>,
    limits: JointLimits<N>,
    // Derived from `joints` and `links`; every constructor that sets either rebuilds it.
    joint_frames: JointFrames<N>,
}

impl<const N: usize> Model<N> {
    /// Builds and validates a model: `gravity` in m/s² in the base frame, `flange` = flange pose in
    /// the last link frame. Fails on non-finite numbers, non-physical links or inconsistent limits.
    pub fn new(
        name: impl Into<String>,
        joints: [Joint; N],
        links: [InertialParameters; N],
        gravity: Vector3<f64>,
        flange: Isometry3<f64>,
        limits: JointLimits<N>,
    ) -> Result<Self, DynamicsError> {
        for (joint, j) in joints.iter().enumerate() {
            if !j.is_finite() {
                return Err(DynamicsError::InvalidJoint {
                    joint,
                    reason: "transform contains NaN or infinity".into(),
                });
            }
        }
        for (link, p) in links.iter().enumerate() {
            p.check_physical().map_err(|e| DynamicsError::Link {
                link,
                source: Box::new(e),
            })?;
        }
        check_finite_slice("gravity", gravity.as_slice())?;
        check_finite_slice("flange translation", flange.translation.vector.as_slice())?;
        check_finite_slice("flange rotation", flange.rotation.coords.as_slice())?;
        limits.validate()?;
        let joint_frames = JointFrames::new(&joints, &links);
        Ok(Self {
            name: name.into(),
            joints,
            links,
            gravity,
            flange,
            limits,
            joint_frames,
        })
    }

    /// Name of the robot.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The joints, base to tip.
    pub fn joints(&self) -> &[Joint; N] {
        &self.joints
    }

    /// Link inertial parameters, each in its own link frame.
    pub fn links(&self) -> &[InertialParameters; N] {
        &self.links
    }

    /// Gravity acceleration, m/s², in the base frame, e.g. (0, 0, −9.81).
    pub fn gravity(&self) -> Vector3<f64> {
        self.gravity
    }

    /// Flange (tool plate) pose in the last link frame.
    pub fn flange(&self) -> Isometry3<f64> {
        self.flange
    }

    /// Joint limits: position rad (min, max), velocity rad/s, torque Nm.
    pub fn limits(&self) -> &JointLimits<N> {
        &self.limits
    }

    /// The same robot carrying `payload` (parameters in the last link frame) rigidly on its last
    /// link: the last link's parameters become the sum (eqs. 16-19 and 17).
    pub fn with_payload(&self, payload: &InertialParameters) -> Model<N> {
        let mut model = self.clone();
        model.load_payload(self, payload);
        model
    }

    /// Makes this model `unloaded`'s links with `payload` added to the last one, in place and
    /// without allocating (the real-time loop switches payloads this way); the joints, gravity,
    /// flange and limits must be `unloaded`'s, which holds for a model made by
    /// [`Model::with_payload`] or cloned from `unloaded`.
    pub fn load_payload(&mut self, unloaded: &Model<N>, payload: &InertialParameters) {
        self.links = unloaded.links;
        if let Some(last) = self.links.last_mut() {
            *last = last.plus(payload);
        }
        self.joint_frames = JointFrames::new(&self.joints, &self.links);
    }

    /// The same kinematics with other link parameters (not checked for physical consistency, so
    /// that identified or perturbed sets can be used; see [`Model::try_with_links`]).
    pub fn with_links(&self, links: [InertialParameters; N]) -> Model<N> {
        let mut model = self.clone();
        model.links = links;
        model.joint_frames = JointFrames::new(&model.joints, &model.links);
        model
    }

    /// Like [`Model::with_links`] but rejects non-physical or non-finite parameters.
    pub fn try_with_links(
        &self,
        links: [InertialParameters; N],
    ) -> Result<Model<N>, DynamicsError> {
        for (link, p) in links.iter().enumerate() {
            p.check_physical().map_err(|e| DynamicsError::Link {
                link,
                source: Box::new(e),
            })?;
        }
        Ok(self.with_links(links))
    }

    /// The same robot with another gravity vector (m/s², base frame).
    pub fn with_gravity(&self, gravity: Vector3<f64>) -> Model<N> {
        let mut model = self.clone();
        model.gravity = gravity;
        model
    }

    /// The same robot with another flange pose (in the last link frame).
    pub fn with_flange(&self, flange: Isometry3<f64>) -> Model<N> {
        let mut model = self.clone();
        model.flange = flange;
        model
    }

    /// The same robot with other joint limits.
    pub fn with_limits(&self, limits: JointLimits<N>) -> Model<N> {
        let mut model = self.clone();
        model.limits = limits;
        model
    }

    /// The chain in its moving joint frames (every joint axis along z there).
    pub(crate) fn joint_frames(&self) -> &JointFrames<N> {
        &self.joint_frames
    }

    /// Total mass of all links, kg.
    pub fn total_mass(&self) -> f64 {
        self.links.iter().map(|l| l.mass).sum()
    }
}
