//! The thresholds file of `offline calibrate-thresholds` (JSON): the calibrated schedule in the
//! form the service stores it (`monitor.json`'s `schedule` and `calibration`, the same
//! `fri_api::results` types as `collision calibrate`), with the gains and the period it was
//! fitted at, the identified arm it assumes and what it detects. `offline monitor --thresholds
//! FILE` reads it back, checked against the service's bounds.

use std::path::Path;

use anyhow::{Context, bail};
use fri_api::bounds;
use fri_api::results::{CalibrationInfo, JointFit, LinkForce, ThresholdSchedule};
use serde::{Deserialize, Serialize};

/// Version of the thresholds file format.
pub const THRESHOLDS_FORMAT: u32 = 1;
/// What wrote the file.
pub const THRESHOLDS_KIND: &str = "fri-ctl offline calibrate-thresholds";

/// The thresholds file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThresholdsFile {
    /// Format version ([`THRESHOLDS_FORMAT`]).
    pub format: u32,
    /// [`THRESHOLDS_KIND`].
    pub kind: String,
    /// Robot model name.
    pub robot: String,
    /// Controller period the residual was computed at, s.
    pub period_s: f64,
    /// Observer gains K_I per joint, 1/s (the residual's noise scales with them).
    pub gains: [f64; 7],
    /// The identified arm the observer used (path as given; `null`: the nominal model). The
    /// thresholds assume the same model in the service.
    pub calibration: Option<String>,
    /// The identified arm's per-joint torque offsets, Nm (`null`: the nominal model): what
    /// `collision configure --from` compares with the service's `robot.calibration`.
    #[serde(default)]
    pub arm_offset: Option<[f64; 7]>,
    /// The logs fitted.
    pub logs: Vec<String>,
    /// The schedule: θ0 per joint and its motion coefficients (as `collision calibrate`).
    pub schedule: ThresholdSchedule,
    /// Budget, recording length, blocks, covered speeds and accelerations.
    pub recording: CalibrationInfo,
    /// Per-joint fit.
    pub joints: Vec<JointFit>,
    /// Minimum detectable force per link at θ0, N.
    pub min_force_at_rest: [LinkForce; 7],
    /// Minimum detectable force per link at the recording's median scheduled thresholds, N.
    pub min_force_median: [LinkForce; 7],
    /// The stated constant per joint, Nm (the cap where the logs support none that small;
    /// absent: a file from before caps).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fallback: Option<[f64; 7]>,
    /// Minimum detectable force per link at the stated constant, N: what the calibration is
    /// compared with (absent: a file from before caps).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_force_fallback: Option<[LinkForce; 7]>,
}

impl ThresholdsFile {
    /// Reads and checks a thresholds file: version, the service's threshold and gain ranges at
    /// the file's period, and finite, non-negative coefficients.
    pub fn read(path: &Path) -> anyhow::Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read thresholds file {}", path.display()))?;
        let f: ThresholdsFile = serde_json::from_str(&text)
            .with_context(|| format!("thresholds file {}", path.display()))?;
        f.check()
            .with_context(|| format!("thresholds file {}", path.display()))?;
        Ok(f)
    }

    fn check(&self) -> anyhow::Result<()> {
        if self.format != THRESHOLDS_FORMAT || self.kind != THRESHOLDS_KIND {
            bail!(
                "`format` {} / `kind` {:?}: not a version-{THRESHOLDS_FORMAT} file of `{THRESHOLDS_KIND}`",
                self.format,
                self.kind
            );
        }
        bounds::CYCLE_S.check("period_s", self.period_s)?;
        let gain = bounds::gain(self.period_s);
        for j in 0..7 {
            gain.check(&format!("gains[{j}]"), self.gains[j])?;
        }
        self.schedule.check()?;
        self.recording.check()?;
        if self.joints.len() != 7 {
            bail!(
                "`joints` has {} entries: one per joint, 7",
                self.joints.len()
            );
        }
        if self.calibration.is_some() != self.arm_offset.is_some() {
            bail!(
                "`calibration` and `arm_offset` go together (an identified arm has offsets, the nominal model none): write the file again with `offline calibrate-thresholds`"
            );
        }
        Ok(())
    }

    /// Writes the file (pretty JSON).
    pub fn write(&self, path: &Path) -> anyhow::Result<()> {
        let text = serde_json::to_string_pretty(self)?;
        std::fs::write(path, text + "\n")
            .with_context(|| format!("cannot write {}", path.display()))
    }
}
