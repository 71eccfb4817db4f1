//! The arm model the service predicts torque with: the nominal `lwr4`, or the arm identified from
//! its own recordings (`robot.calibration`, written by `fri-ctl offline identify`).
//!
//! An identified arm changes two things, everywhere the service predicts a torque: the observer
//! runs on the corrected model (its M, C and g are those of the identified base coefficients,
//! `dynamics::IdentifiedModel::corrected_model`), and the arm's per-joint offset and friction
//! are subtracted from the measured torque at the observer's velocity (`safety::JointFriction`).
//! The detector, the thresholds' calibration, the unknown-payload view and the estimate against
//! a model (no tare) then see what the rigid body does, not the arm's sensor offsets. The file is
//! read once at start, through a checked directory without following links, and checked against
//! the built-in model (robot name, joint count, base coefficients, every value bounded): a file
//! that does not describe this arm stops the start, naming the field.

use std::path::{Path, PathBuf};

use dynamics::{Data, IdentifiedModel, Model, compute_generalized_gravity};
use estimator::samples::StaticSample;
use fri_api::results::{ArmCalibration, RobotModelStatus};
use nalgebra::SVector;
use safety::JointFriction;

use crate::config::RobotConfig;
use crate::persistence::dir::{CheckedDir, DirError, Rule};

/// Largest identified-arm file read, bytes (a 7-joint file is about 5 kB).
pub const MAX_CALIBRATION_BYTES: u64 = 1 << 20;

/// Why the identified arm of `robot.calibration` cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ArmError {
    /// The file's directory is not one the service trusts, or the file is a link, not a
    /// regular file, or writable by others.
    #[error(transparent)]
    Untrusted(#[from] DirError),
    /// There is no such file.
    #[error(
        "robot.calibration {path}: no such file (write one with `fri-ctl offline identify --log \
         FILE… --out {path}`, or remove the key to run the nominal model)"
    )]
    Missing {
        /// The configured path.
        path: PathBuf,
    },
    /// The file is not UTF-8 text.
    #[error("robot.calibration {path}: not a TOML text file")]
    NotText {
        /// The configured path.
        path: PathBuf,
    },
    /// The file does not describe this arm (a field out of range, another robot, another
    /// structure).
    #[error("robot.calibration {path}: {source}")]
    Invalid {
        /// The configured path.
        path: PathBuf,
        /// The field and what is wrong with it.
        source: dynamics::DynamicsError,
    },
}

/// The arm model in force (see the module documentation).
#[derive(Debug, Clone)]
pub struct ArmModel {
    /// The model the observer runs on: the identified arm's corrected model, or the nominal one.
    model: Model<7>,
    /// The identified arm and its configured path (`None`: the nominal model).
    identified: Option<(PathBuf, IdentifiedModel<7>)>,
}

impl ArmModel {
    /// The nominal model, uncorrected.
    pub fn nominal(model: Model<7>) -> Self {
        Self {
            model,
            identified: None,
        }
    }

    /// The arm `arm` identified, read from `path` (the model the file was checked against is its
    /// nominal model).
    pub fn identified(path: PathBuf, arm: IdentifiedModel<7>) -> Self {
        Self {
            model: arm.corrected_model().clone(),
            identified: Some((path, arm)),
        }
    }

    /// The configured model: `nominal`, corrected by `robot.calibration` when it is set.
    pub fn load(robot: &RobotConfig, nominal: Model<7>) -> Result<Self, ArmError> {
        let Some(path) = &robot.calibration else {
            return Ok(Self::nominal(nominal));
        };
        let text = read_calibration(path)?;
        let arm = IdentifiedModel::from_toml_str(&nominal, &text).map_err(|source| {
            ArmError::Invalid {
                path: path.clone(),
                source,
            }
        })?;
        Ok(Self::identified(path.clone(), arm))
    }

    /// The model the observer runs on (the corrected one with an identified arm).
    pub fn observer_model(&self) -> &Model<7> {
        &self.model
    }

    /// The identified arm in force, if any.
    pub fn identified_arm(&self) -> Option<&IdentifiedModel<7>> {
        self.identified.as_ref().map(|(_, a)| a)
    }

    /// The per-joint offset and friction the observer subtracts (`None`: the nominal model).
    pub fn joint_terms(&self) -> Option<JointFriction<7>> {
        self.identified_arm()
            .map(<JointFriction<7> as From<&IdentifiedModel<7>>>::from)
    }

    /// What the torque sensors read at rest at `q` (rad) with no load: g(q) of the observer's
    /// model plus the identified offsets, Nm (allocation-free).
    pub fn torque_at_rest(&self, data: &mut Data<7>, q: &SVector<f64, 7>) -> SVector<f64, 7> {
        let g = compute_generalized_gravity(&self.model, data, q);
        match self.identified_arm() {
            Some(a) => g + a.joint_torque(&SVector::zeros()),
            None => g,
        }
    }

    /// The samples a fit against a model uses (no tare): with an identified arm each sample's
    /// reference torque (`gravity`, the controller's g otherwise) becomes the corrected model's
    /// g(q) plus the offsets; `None` with the nominal model (the controller's own gravity stays).
    pub fn model_reference(&self, samples: &[StaticSample<7>]) -> Option<Vec<StaticSample<7>>> {
        self.identified_arm()?;
        let mut data = Data::new(&self.model);
        Some(
            samples
                .iter()
                .map(|s| StaticSample {
                    gravity: self.torque_at_rest(&mut data, &s.q),
                    ..*s
                })
                .collect(),
        )
    }

    /// σ of the per-joint constant error of a fit against the model, Nm: the configured
    /// `configured` (the controller's model error), or with an identified arm at least the
    /// largest residual RMS it leaves on held-out data.
    pub fn model_offset_std(&self, configured: f64) -> f64 {
        self.identified_arm().map_or(configured, |a| {
            a.model_error().0.iter().fold(configured, |m, &r| m.max(r))
        })
    }

    /// The model as `status` reports it.
    pub fn status(&self) -> RobotModelStatus {
        RobotModelStatus {
            model: self.model.name().to_owned(),
            calibration: self.identified.as_ref().map(|(path, a)| {
                let f = a.file();
                ArmCalibration {
                    path: path.display().to_string(),
                    logs: f.fit.logs.clone(),
                    duration_s: f.fit.duration_s,
                    residual_rms_nominal: f.fit.residual_rms_nominal.clone(),
                    heldout_rms: f.fit.heldout_rms.clone(),
                    offset: f.joint.offset.clone(),
                }
            }),
        }
    }
}

/// Reads the file at `path` through its checked directory (parents owned by root or the
/// service's user, not writable by others; the file a regular file, not a link).
fn read_calibration(path: &Path) -> Result<String, ArmError> {
    let missing = || ArmError::Missing {
        path: path.to_owned(),
    };
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .ok_or_else(missing)?;
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    // The checked directory creates what is missing; a calibration's directory must exist.
    if !parent.is_dir() {
        return Err(missing());
    }
    let dir = CheckedDir::open(parent, "robot.calibration", Rule::Trusted)?;
    let bytes = dir.read(name, MAX_CALIBRATION_BYTES)?.ok_or_else(missing)?;
    String::from_utf8(bytes).map_err(|_| ArmError::NotText {
        path: path.to_owned(),
    })
}
