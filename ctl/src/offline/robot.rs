//! Robot model selection for the offline commands: built-in names or a robot TOML file.

use std::path::PathBuf;
use std::str::FromStr;

/// Which robot model a command uses.
#[derive(Debug, Clone, PartialEq)]
pub enum RobotChoice {
    /// The built-in KUKA LWR 4+ (7 joints, classical DH of the paper).
    Lwr4,
    /// The paper's planar 2R robot (Sec. IV).
    Planar2r,
    /// A robot description file.
    File(PathBuf),
}

impl FromStr for RobotChoice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "lwr4" => Ok(RobotChoice::Lwr4),
            "planar-2r" => Ok(RobotChoice::Planar2r),
            "" => Err("empty robot name; use lwr4, planar-2r or a robot file".into()),
            path => Ok(RobotChoice::File(PathBuf::from(path))),
        }
    }
}

/// A robot file loaded with its joint count known (TOML robot file or URDF).
pub(crate) enum LoadedRobot {
    /// TOML robot file (dynamics' format, docs/robot-model.md).
    Toml(dynamics::RobotFile),
    /// URDF text.
    Urdf(String),
}

impl LoadedRobot {
    /// Reads `path`: `.urdf` as URDF, anything else as a TOML robot file.
    pub(crate) fn load(path: &std::path::Path) -> anyhow::Result<Self> {
        use anyhow::Context;
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read robot file {}", path.display()))?;
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("urdf"))
        {
            Ok(LoadedRobot::Urdf(text))
        } else {
            Ok(LoadedRobot::Toml(
                dynamics::RobotFile::parse(&text)
                    .with_context(|| format!("robot file {}", path.display()))?,
            ))
        }
    }

    /// Builds the model with N joints; Err when the file has another number of moving joints.
    pub(crate) fn model<const N: usize>(
        &self,
    ) -> Result<dynamics::Model<N>, dynamics::DynamicsError> {
        match self {
            LoadedRobot::Toml(rf) => rf.to_model::<N>(),
            LoadedRobot::Urdf(xml) => dynamics::Model::<N>::from_urdf_str(xml),
        }
    }
}

/// Runs `$body` with `model: Model<N>` bound for the chosen robot (const-generic dispatch; robot
/// files with 2 to 7 joints).
macro_rules! with_robot {
    ($choice:expr, |$model:ident| $body:expr) => {{
        match $choice {
            $crate::offline::RobotChoice::Lwr4 => {
                let $model = dynamics::lwr4();
                $body
            }
            $crate::offline::RobotChoice::Planar2r => {
                let $model = dynamics::planar_2r();
                $body
            }
            $crate::offline::RobotChoice::File(path) => {
                let robot = $crate::offline::robot::LoadedRobot::load(path)?;
                if let Ok($model) = robot.model::<7>() {
                    $body
                } else if let Ok($model) = robot.model::<6>() {
                    $body
                } else if let Ok($model) = robot.model::<5>() {
                    $body
                } else if let Ok($model) = robot.model::<4>() {
                    $body
                } else if let Ok($model) = robot.model::<3>() {
                    $body
                } else if let Ok($model) = robot.model::<2>() {
                    $body
                } else {
                    let err = robot
                        .model::<7>()
                        .err()
                        .map(|e| e.to_string())
                        .unwrap_or_default();
                    Err(anyhow::anyhow!(
                        "robot file {}: no valid model with 2 to 7 joints ({err})",
                        path.display()
                    ))
                }
            }
        }
    }};
}
pub(crate) use with_robot;
