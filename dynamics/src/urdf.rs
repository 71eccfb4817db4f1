//! Import of serial chains from URDF (via urdf-rs): revolute, continuous, prismatic and fixed
//! joints. Link frames of the model are the URDF link frames of the moving links; fixed joints
//! are folded into the next joint's placement (or, after a moving joint, their links' inertia is
//! merged into the moving link).

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use crate::error::DynamicsError;
use crate::inertia::InertialParameters;
use crate::joint::{Joint, JointKind};
use crate::model::{JointLimits, Model};
use crate::robots::{STANDARD_GRAVITY, inertia_tensor};

fn urdf_error(message: impl Into<String>) -> DynamicsError {
    DynamicsError::Urdf(message.into())
}

fn finite(what: &str, values: &[f64]) -> Result<(), DynamicsError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(urdf_error(format!(
            "{what} contains NaN or infinity: {values:?}"
        )))
    }
}

fn pose(what: &str, p: &urdf_rs::Pose) -> Result<Isometry3<f64>, DynamicsError> {
    finite(&format!("{what} origin xyz"), &p.xyz.0)?;
    finite(&format!("{what} origin rpy"), &p.rpy.0)?;
    let [x, y, z] = p.xyz.0;
    let [r, pi, ya] = p.rpy.0;
    Ok(Isometry3::from_parts(
        Translation3::new(x, y, z),
        UnitQuaternion::from_euler_angles(r, pi, ya),
    ))
}

/// Inertial parameters of a URDF link in its link frame.
fn link_inertial(link: &urdf_rs::Link) -> Result<InertialParameters, DynamicsError> {
    let inertial = &link.inertial;
    let frame = pose(&format!("link {} inertial", link.name), &inertial.origin)?;
    let i = &inertial.inertia;
    let values = [i.ixx, i.iyy, i.izz, i.ixy, i.ixz, i.iyz];
    finite(&format!("link {} inertia", link.name), &values)?;
    finite(&format!("link {} mass", link.name), &[inertial.mass.value])?;
    let about_com = InertialParameters::from_com(
        inertial.mass.value,
        Vector3::zeros(),
        inertia_tensor(&values),
    );
    let rotation = frame.rotation.to_rotation_matrix().into_inner();
    Ok(about_com.transformed(&rotation, &frame.translation.vector))
}

/// Rotation taking the z axis onto the unit vector `axis`.
fn z_onto(axis: &Vector3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::rotation_between(&Vector3::z(), axis).unwrap_or_else(|| {
        // axis = −z: any half turn about a horizontal axis.
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    })
}

impl<const N: usize> Model<N> {
    /// Model from URDF text: the serial chain from the root link to the leaf, with N moving
    /// (revolute, continuous or prismatic) joints. Gravity is (0, 0, −9.81) m/s² in the root link
    /// frame; the flange is the leaf link's frame. Missing or zero velocity/effort limits mean
    /// "unlimited".
    pub fn from_urdf_str(xml: &str) -> Result<Self, DynamicsError> {
        let robot = urdf_rs::read_from_string(xml).map_err(|e| urdf_error(e.to_string()))?;
        Self::from_urdf_robot(&robot)
    }

    /// Model from a URDF file on disk (see [`Model::from_urdf_str`]).
    pub fn from_urdf_file(path: impl AsRef<std::path::Path>) -> Result<Self, DynamicsError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| DynamicsError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::from_urdf_str(&text)
    }

    /// Model from a parsed urdf-rs robot (see [`Model::from_urdf_str`]).
    pub fn from_urdf_robot(robot: &urdf_rs::Robot) -> Result<Self, DynamicsError> {
        let children = |link: &str| -> Vec<&urdf_rs::Joint> {
            robot
                .joints
                .iter()
                .filter(|j| j.parent.link == link)
                .collect()
        };
        let roots: Vec<&urdf_rs::Link> = robot
            .links
            .iter()
            .filter(|l| !robot.joints.iter().any(|j| j.child.link == l.name))
            .collect();
        let root = match roots.as_slice() {
            [root] => *root,
            [] => return Err(urdf_error("no root link (every link is a joint child)")),
            many => {
                let names: Vec<&str> = many.iter().map(|l| l.name.as_str()).collect();
                return Err(urdf_error(format!("several root links: {names:?}")));
            }
        };
        let find_link = |name: &str| -> Result<&urdf_rs::Link, DynamicsError> {
            robot
                .links
                .iter()
                .find(|l| l.name == name)
                .ok_or_else(|| urdf_error(format!("joint refers to unknown link `{name}`")))
        };

        let mut joints: Vec<Joint> = Vec::with_capacity(N);
        let mut links: Vec<InertialParameters> = Vec::with_capacity(N);
        let mut limits = JointLimits::<N>::unlimited();
        // Pose of the current link in the last moving link's frame (or the root frame).
        let mut pending = Isometry3::identity();
        let mut current = root.name.as_str();
        let mut visited = 0usize;
        loop {
            let next = children(current);
            let joint = match next.as_slice() {
                [] => break,
                [joint] => *joint,
                many => {
                    let names: Vec<&str> = many.iter().map(|j| j.name.as_str()).collect();
                    return Err(urdf_error(format!(
                        "link `{current}` has several child joints {names:?}; only serial chains are supported"
                    )));
                }
            };
            visited += 1;
            if visited > robot.joints.len() {
                return Err(urdf_error("the joint graph has a cycle"));
            }
            let origin = pose(&format!("joint {}", joint.name), &joint.origin)?;
            let child = find_link(&joint.child.link)?;
            let child_inertial = link_inertial(child)?;
            let kind = match joint.joint_type {
                urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => {
                    Some(JointKind::Revolute)
                }
                urdf_rs::JointType::Prismatic => Some(JointKind::Prismatic),
                urdf_rs::JointType::Fixed => None,
                ref other => {
                    return Err(urdf_error(format!(
                        "joint `{}` has unsupported type {other:?}",
                        joint.name
                    )));
                }
            };
            match kind {
                None => {
                    pending *= origin;
                    // A link rigidly attached to a moving link adds to its inertia.
                    if let Some(last) = links.last_mut() {
                        let rotation = pending.rotation.to_rotation_matrix().into_inner();
                        *last = last.plus(
                            &child_inertial.transformed(&rotation, &pending.translation.vector),
                        );
                    }
                }
                Some(kind) => {
                    let index = joints.len();
                    if index >= N {
                        return Err(DynamicsError::JointCount {
                            expected: N,
                            found: count_moving(robot),
                            source_kind: "URDF",
                        });
                    }
                    finite(&format!("joint {} axis", joint.name), &joint.axis.xyz.0)?;
                    let axis = Vector3::from(joint.axis.xyz.0);
                    let norm = axis.norm();
                    // an overflowing norm would normalise the axis to zero just as silently
                    if !(1e-12..=f64::MAX).contains(&norm) {
                        return Err(urdf_error(format!(
                            "joint `{}` has a zero axis or one whose length overflows",
                            joint.name
                        )));
                    }
                    let align = z_onto(&(axis / norm));
                    let align_iso = Isometry3::from_parts(Translation3::identity(), align);
                    joints.push(Joint::new(
                        kind,
                        pending * origin * align_iso,
                        align_iso.inverse(),
                    ));
                    links.push(child_inertial);
                    pending = Isometry3::identity();
                    let limit = &joint.limit;
                    finite(
                        &format!("joint {} limit", joint.name),
                        &[limit.lower, limit.upper, limit.velocity, limit.effort],
                    )?;
                    if !matches!(joint.joint_type, urdf_rs::JointType::Continuous)
                        && limit.lower < limit.upper
                    {
                        limits.position_min[index] = limit.lower;
                        limits.position_max[index] = limit.upper;
                    }
                    if limit.velocity > 0.0 {
                        limits.velocity_max[index] = limit.velocity;
                    }
                    if limit.effort > 0.0 {
                        limits.torque_max[index] = limit.effort;
                    }
                }
            }
            current = joint.child.link.as_str();
        }
        if joints.len() != N {
            return Err(DynamicsError::JointCount {
                expected: N,
                found: joints.len(),
                source_kind: "URDF",
            });
        }
        let joints: [Joint; N] = joints
            .try_into()
            .map_err(|_| urdf_error("internal: joint count changed"))?;
        let links: [InertialParameters; N] = links
            .try_into()
            .map_err(|_| urdf_error("internal: link count changed"))?;
        Model::new(
            robot.name.clone(),
            joints,
            links,
            Vector3::new(0.0, 0.0, -STANDARD_GRAVITY),
            pending,
            limits,
        )
    }
}

fn count_moving(robot: &urdf_rs::Robot) -> usize {
    robot
        .joints
        .iter()
        .filter(|j| {
            matches!(
                j.joint_type,
                urdf_rs::JointType::Revolute
                    | urdf_rs::JointType::Continuous
                    | urdf_rs::JointType::Prismatic
            )
        })
        .count()
}
