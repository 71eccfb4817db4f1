//! The TOML robot file format (documented in docs/robot-model.md).

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{DynamicsError, check_finite_slice};
use crate::inertia::InertialParameters;
use crate::joint::{ClassicalDh, Joint, JointKind, ModifiedDh};
use crate::model::{JointLimits, Model};
use crate::robots::inertia_tensor;

/// A pose as translation (m) and roll-pitch-yaw angles (rad, URDF convention
/// R = Rz(yaw)·Ry(pitch)·Rx(roll)).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PoseSpec {
    /// Translation, m.
    pub translation: [f64; 3],
    /// Roll, pitch, yaw, rad.
    pub rpy: [f64; 3],
}

impl PoseSpec {
    fn to_isometry(self) -> Isometry3<f64> {
        let [r, p, y] = self.rpy;
        Isometry3::from_parts(
            Translation3::from(Vector3::from(self.translation)),
            UnitQuaternion::from_euler_angles(r, p, y),
        )
    }

    fn from_isometry(iso: &Isometry3<f64>) -> Self {
        let (r, p, y) = iso.rotation.euler_angles();
        Self {
            translation: iso.translation.vector.into(),
            rpy: [r, p, y],
        }
    }
}

/// Joint limits of one joint in a robot file; missing entries mean "no limit".
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LimitsSpec {
    /// [min, max] position, rad (m for prismatic joints).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub position: Option<[f64; 2]>,
    /// Speed limit, rad/s (m/s).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub velocity: Option<f64>,
    /// Torque limit, Nm (N).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub torque: Option<f64>,
}

/// Inertial parameters of one link in a robot file, in the link frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkSpec {
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass, m, link frame.
    #[serde(default)]
    pub com: [f64; 3],
    /// Inertia about the CoM (axes of the link frame) as [xx, yy, zz, xy, xz, yz], kg·m².
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inertia_com: Option<[f64; 6]>,
    /// Inertia about the link-frame origin as [xx, yy, zz, xy, xz, yz], kg·m² (alternative to
    /// `inertia_com`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inertia_origin: Option<[f64; 6]>,
}

/// One joint of a robot file: exactly one of `dh`, `modified_dh` or `placement` (+ `body`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointSpec {
    /// Joint name (for messages).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// "revolute" or "prismatic".
    #[serde(rename = "type")]
    pub kind: Option<JointKind>,
    /// Classical DH row.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dh: Option<ClassicalDh>,
    /// Modified (Khalil) DH row.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub modified_dh: Option<ModifiedDh>,
    /// General form: joint frame pose (q = 0) in the parent link frame; motion about its z axis.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub placement: Option<PoseSpec>,
    /// General form: link frame pose in the moving joint frame (default identity).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub body: Option<PoseSpec>,
    /// Joint limits.
    #[serde(default)]
    pub limits: LimitsSpec,
    /// Link parameters.
    pub link: Option<LinkSpec>,
}

/// A whole robot file.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotFile {
    /// Robot name.
    pub name: String,
    /// Gravity acceleration in the base frame, m/s² (default (0, 0, −9.81)).
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 3],
    /// Flange pose in the last link frame (default identity).
    #[serde(default)]
    pub flange: PoseSpec,
    /// Joints base to tip.
    #[serde(rename = "joint", default)]
    pub joints: Vec<JointSpec>,
}

fn default_gravity() -> [f64; 3] {
    [0.0, 0.0, -crate::robots::STANDARD_GRAVITY]
}

fn joint_error(joint: usize, spec: &JointSpec, reason: impl std::fmt::Display) -> DynamicsError {
    let name = spec.name.as_deref().unwrap_or("unnamed");
    DynamicsError::InvalidJoint {
        joint,
        reason: format!("({name}) {reason}"),
    }
}

fn build_joint(index: usize, spec: &JointSpec) -> Result<Joint, DynamicsError> {
    let kind = spec
        .kind
        .ok_or_else(|| joint_error(index, spec, "missing `type` (revolute or prismatic)"))?;
    let given = [
        spec.dh.is_some(),
        spec.modified_dh.is_some(),
        spec.placement.is_some(),
    ]
    .iter()
    .filter(|g| **g)
    .count();
    if given != 1 {
        return Err(joint_error(
            index,
            spec,
            "give exactly one of `dh`, `modified_dh` or `placement`",
        ));
    }
    if spec.body.is_some() && spec.placement.is_none() {
        return Err(joint_error(
            index,
            spec,
            "`body` is only allowed with `placement`",
        ));
    }
    let joint = if let Some(dh) = &spec.dh {
        check_finite_slice("dh", &[dh.a, dh.alpha, dh.d, dh.theta])?;
        Joint::classical_dh(kind, dh)
    } else if let Some(mdh) = &spec.modified_dh {
        check_finite_slice("modified_dh", &[mdh.alpha, mdh.d, mdh.theta, mdh.r])?;
        Joint::modified_dh(kind, mdh)
    } else {
        let placement = spec.placement.unwrap_or_default();
        let body = spec.body.unwrap_or_default();
        check_finite_slice("placement.translation", &placement.translation)?;
        check_finite_slice("placement.rpy", &placement.rpy)?;
        check_finite_slice("body.translation", &body.translation)?;
        check_finite_slice("body.rpy", &body.rpy)?;
        Joint::new(kind, placement.to_isometry(), body.to_isometry())
    };
    Ok(joint)
}

fn build_link(index: usize, spec: &JointSpec) -> Result<InertialParameters, DynamicsError> {
    let link = spec
        .link
        .ok_or_else(|| joint_error(index, spec, "missing [joint.link] table"))?;
    let wrap = |e: DynamicsError| DynamicsError::Link {
        link: index,
        source: Box::new(e),
    };
    check_finite_slice("mass", &[link.mass]).map_err(wrap)?;
    check_finite_slice("com", &link.com).map_err(wrap)?;
    let com = Vector3::from(link.com);
    let params = match (link.inertia_com, link.inertia_origin) {
        (Some(i), None) => {
            check_finite_slice("inertia_com", &i).map_err(wrap)?;
            InertialParameters::from_com(link.mass, com, inertia_tensor(&i))
        }
        (None, Some(i)) => {
            check_finite_slice("inertia_origin", &i).map_err(wrap)?;
            InertialParameters {
                mass: link.mass,
                first_moment: com * link.mass,
                inertia_origin: inertia_tensor(&i),
            }
        }
        (None, None) => InertialParameters::point_mass(link.mass, com),
        (Some(_), Some(_)) => {
            return Err(joint_error(
                index,
                spec,
                "give either `inertia_com` or `inertia_origin`, not both",
            ));
        }
    };
    params.check_physical().map_err(wrap)?;
    Ok(params)
}

impl RobotFile {
    /// Parses TOML text; syntax errors name the line and column.
    pub fn parse(text: &str) -> Result<Self, DynamicsError> {
        toml::from_str(text).map_err(|e| DynamicsError::Toml(e.to_string()))
    }

    /// Builds a validated `Model<N>`; fails with [`DynamicsError::JointCount`] when the file has
    /// another number of joints than N.
    pub fn to_model<const N: usize>(&self) -> Result<Model<N>, DynamicsError> {
        if self.joints.len() != N {
            return Err(DynamicsError::JointCount {
                expected: N,
                found: self.joints.len(),
                source_kind: "TOML robot file",
            });
        }
        check_finite_slice("gravity", &self.gravity)?;
        check_finite_slice("flange.translation", &self.flange.translation)?;
        check_finite_slice("flange.rpy", &self.flange.rpy)?;
        let mut joints = [Joint::new(
            JointKind::Revolute,
            Isometry3::identity(),
            Isometry3::identity(),
        ); N];
        let mut links = [InertialParameters::zero(); N];
        let mut limits = JointLimits::<N>::unlimited();
        for (i, spec) in self.joints.iter().enumerate() {
            joints[i] = build_joint(i, spec)?;
            links[i] = build_link(i, spec)?;
            if let Some([lo, hi]) = spec.limits.position {
                limits.position_min[i] = lo;
                limits.position_max[i] = hi;
            }
            if let Some(v) = spec.limits.velocity {
                limits.velocity_max[i] = v;
            }
            if let Some(t) = spec.limits.torque {
                limits.torque_max[i] = t;
            }
        }
        Model::new(
            self.name.clone(),
            joints,
            links,
            Vector3::from(self.gravity),
            self.flange.to_isometry(),
            limits,
        )
    }

    /// Describes `model` in the general form (placement/body poses, inertia about the origin).
    pub fn from_model<const N: usize>(model: &Model<N>) -> Self {
        let limits = model.limits();
        let finite = |v: f64| if v.is_finite() { Some(v) } else { None };
        let joints = (0..N)
            .map(|i| {
                let joint = &model.joints()[i];
                let link = &model.links()[i];
                let j = &link.inertia_origin;
                let (lo, hi) = (limits.position_min[i], limits.position_max[i]);
                JointSpec {
                    name: None,
                    kind: Some(joint.kind()),
                    dh: None,
                    modified_dh: None,
                    placement: Some(PoseSpec::from_isometry(joint.placement())),
                    body: Some(PoseSpec::from_isometry(joint.body_in_joint())),
                    limits: LimitsSpec {
                        position: (lo.is_finite() && hi.is_finite()).then_some([lo, hi]),
                        velocity: finite(limits.velocity_max[i]),
                        torque: finite(limits.torque_max[i]),
                    },
                    link: Some(LinkSpec {
                        mass: link.mass,
                        com: link.com().unwrap_or_else(Vector3::zeros).into(),
                        inertia_com: None,
                        inertia_origin: Some([
                            j[(0, 0)],
                            j[(1, 1)],
                            j[(2, 2)],
                            j[(0, 1)],
                            j[(0, 2)],
                            j[(1, 2)],
                        ]),
                    }),
                }
            })
            .collect();
        Self {
            name: model.name().to_string(),
            gravity: model.gravity().into(),
            flange: PoseSpec::from_isometry(&model.flange()),
            joints,
        }
    }

    /// TOML text of this file.
    pub fn to_toml_string(&self) -> Result<String, DynamicsError> {
        toml::to_string(self).map_err(|e| DynamicsError::Toml(e.to_string()))
    }
}

impl<const N: usize> Model<N> {
    /// Model from TOML robot-file text (format in docs/robot-model.md).
    pub fn from_toml_str(text: &str) -> Result<Self, DynamicsError> {
        RobotFile::parse(text)?.to_model()
    }

    /// Model from a TOML robot file on disk.
    pub fn from_toml_file(path: impl AsRef<std::path::Path>) -> Result<Self, DynamicsError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| DynamicsError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::from_toml_str(&text)
    }

    /// TOML robot-file text describing this model (general joint form).
    pub fn to_toml_string(&self) -> Result<String, DynamicsError> {
        RobotFile::from_model(self).to_toml_string()
    }
}
