//! `fri-ctl collision configure --from FILE`: thresholds calibrated offline (`fri-ctl offline
//! calibrate-thresholds`) installed in the service (`collision-install`). The file is read and
//! checked here; the service checks it again against its own cycle, arm model and ceiling.

use std::path::Path;

use fri_api::protocol::{Command, InstallThresholds};

use super::collision::{CollisionArg, CollisionArgs};
use crate::offline::thresholds::ThresholdsFile;

impl CollisionArgs {
    /// The `collision-install` request of `collision configure --from FILE`.
    pub(super) fn install_request(&self, path: &Path) -> Result<Command, String> {
        if !matches!(self.action, CollisionArg::Configure) {
            return Err("--from goes with `configure`".to_owned());
        }
        if self.thresholds.is_some() || self.gains.is_some() {
            return Err(
                "--from installs the file's thresholds and gains: it does not go with --thresholds or --gains"
                    .to_owned(),
            );
        }
        if self.reaction.is_some()
            || self.pause_s.is_some()
            || self.source.is_some()
            || self.duration_s.is_some()
            || self.budget.is_some()
            || self.apply
        {
            return Err(
                "--from takes only --allow-weak (set the reaction with another `configure`)"
                    .to_owned(),
            );
        }
        let file = ThresholdsFile::read(path).map_err(|e| format!("{e:#}"))?;
        let median_thresholds: [f64; 7] = std::array::from_fn(|j| file.joints[j].threshold_median);
        let source = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        Ok(Command::CollisionInstall(Box::new(InstallThresholds {
            schedule: file.schedule,
            recording: file.recording,
            median_thresholds,
            period_s: file.period_s,
            gains: file.gains,
            arm_offset: file.arm_offset,
            source,
            allow_weaker: self.allow_weak.then_some(true),
        })))
    }
}
