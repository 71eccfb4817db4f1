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

/// Runs `$body` with `model: Model<N>` bound for the chosen robot (const-generic dispatch).
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
            $crate::offline::RobotChoice::File(path) => Err(anyhow::anyhow!(
                "robot file {}: robot description files are not supported by the offline tools yet; use --robot lwr4 or --robot planar-2r",
                path.display()
            )),
        }
    }};
}
pub(crate) use with_robot;
