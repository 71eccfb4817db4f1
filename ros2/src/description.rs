//! The URDF on `/robot_description`: the project's LWR 4+ model, with the paper's frame 7 (the
//! payload's frame) added as a fixed child of the last link, or a file of the user's.

use std::path::Path;

pub use fri_service::ros_messages::DH_FRAME_7;
/// Largest URDF file accepted, bytes.
pub const MAX_URDF_BYTES: u64 = 4 << 20;

/// Errors reading a robot description.
#[derive(Debug, thiserror::Error)]
pub enum DescriptionError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: std::path::PathBuf,
        /// Underlying I/O error.
        source: std::io::Error,
    },
    /// The file is larger than [`MAX_URDF_BYTES`].
    #[error("{path}: {bytes} bytes, at most {MAX_URDF_BYTES}")]
    TooLarge {
        /// The file.
        path: std::path::PathBuf,
        /// Its size, bytes.
        bytes: u64,
    },
    /// Not a URDF robot.
    #[error("not a URDF robot: {0}")]
    Parse(String),
}

/// A URDF text and the names of its moving joints.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotDescription {
    /// The URDF XML.
    pub urdf: String,
    /// Revolute and continuous joints in file order.
    joints: Vec<String>,
}

impl RobotDescription {
    /// The built-in LWR 4+ with [`DH_FRAME_7`].
    pub fn builtin() -> Result<Self, DescriptionError> {
        Self::from_urdf(fri_service::ros_messages::robot_description())
    }

    /// A URDF file (at most [`MAX_URDF_BYTES`]).
    pub fn from_file(path: &Path) -> Result<Self, DescriptionError> {
        let read = |source| DescriptionError::Read {
            path: path.to_owned(),
            source,
        };
        let bytes = std::fs::metadata(path).map_err(read)?.len();
        if bytes > MAX_URDF_BYTES {
            return Err(DescriptionError::TooLarge {
                path: path.to_owned(),
                bytes,
            });
        }
        Self::from_urdf(std::fs::read_to_string(path).map_err(read)?)
    }

    /// Parses `urdf` (checks it is a robot and collects its joints).
    pub fn from_urdf(urdf: String) -> Result<Self, DescriptionError> {
        let robot =
            urdf_rs::read_from_string(&urdf).map_err(|e| DescriptionError::Parse(e.to_string()))?;
        let joints = robot
            .joints
            .iter()
            .filter(|j| {
                matches!(
                    j.joint_type,
                    urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous
                )
            })
            .map(|j| j.name.clone())
            .collect();
        Ok(Self { urdf, joints })
    }

    /// Revolute and continuous joints in file order.
    pub fn revolute_joints(&self) -> Vec<String> {
        self.joints.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_model_has_the_seven_lwr_joints_and_frame_7() {
        let d = RobotDescription::builtin().unwrap();
        let expected: Vec<String> = (1..=7).map(|i| format!("lwr_joint_{i}")).collect();
        assert_eq!(d.revolute_joints(), expected);
        assert_eq!(expected, fri_service::ros_messages::JOINT_NAMES);
        let robot = urdf_rs::read_from_string(&d.urdf).unwrap();
        let j = robot
            .joints
            .iter()
            .find(|j| j.child.link == DH_FRAME_7)
            .unwrap();
        assert_eq!(j.parent.link, "lwr_link_7");
        assert_eq!(j.origin.xyz.0, [0.0, 0.0, -0.078]);
    }

    #[test]
    fn a_file_that_is_no_urdf_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.urdf");
        std::fs::write(&p, "robot: not xml").unwrap();
        assert!(matches!(
            RobotDescription::from_file(&p),
            Err(DescriptionError::Parse(_))
        ));
        assert!(matches!(
            RobotDescription::from_file(&dir.path().join("missing")),
            Err(DescriptionError::Read { .. })
        ));
    }
}
