//! The pose pattern shared by `tare` and `estimate-payload`: drive each pose, take one averaged
//! static sample there, return to the start pose; any stop or contact ends it with its cause.

use fri_api::results::{Event, Phase, Progress, Workflow};

use crate::operator::server::EventSink;
use crate::service::core::{ServiceCore, err};
use crate::service::pattern::{PatternKind, poses as pattern_poses};
use crate::service::settle::AveragedSample;
use fri_api::protocol::{ErrorCode, OperatorError};

impl ServiceCore {
    /// Drives the pattern, one averaged sample per pose, then returns to the start pose.
    pub(super) async fn run_pattern(
        &self,
        around: Option<[f64; 7]>,
        poses: Option<usize>,
        step_deg: Option<f64>,
        kind: PatternKind,
        workflow: Workflow,
        events: &EventSink,
    ) -> Result<(Vec<AveragedSample>, [f64; 7]), OperatorError> {
        let latest = self.latest()?;
        let start_q = latest.robot.q;
        let around = around.unwrap_or(start_q);
        let count = poses.unwrap_or(self.config.estimation.pattern_poses);
        let step = step_deg.unwrap_or(self.config.estimation.pattern_step_deg);
        // The centre must keep the pattern inside the joint limits with a margin and lie near
        // the measured pose (the protocol layer only knows the limits, not the pose).
        let max_distance = self.config.motion.max_around_distance_rad;
        fri_api::bounds::POSES
            .check_count("poses", count as u64)
            .and_then(|()| fri_api::bounds::STEP_DEG.check("step_deg", step))
            .map_err(OperatorError::out_of_range)?;
        fri_api::bounds::check_around(&around, &start_q, step, max_distance)
            .map_err(|e| err(ErrorCode::InvalidArguments, e))?;
        let pattern = pattern_poses(kind, &self.model, &around, count, step).map_err(|e| {
            err(
                ErrorCode::InvalidArguments,
                format!("pose design failed: {e}"),
            )
        })?;
        let mut baseline = Some(latest.robot.residual);
        let mut samples = Vec::with_capacity(count);
        for (k, pose) in pattern.iter().enumerate() {
            let progress = |phase| Progress {
                phase,
                step: Some(k + 1),
                of: Some(count),
                workflow: Some(workflow),
                pose: Some(*pose),
                settle_s: None,
                max_speed: None,
            };
            events
                .event(&Event::Progress(progress(Phase::Moving)))
                .await;
            let r = self.move_to(*pose, baseline).await;
            if let Err(e) = r {
                self.release().await;
                return Err(e);
            }
            events
                .event(&Event::Progress(progress(Phase::Settling)))
                .await;
            let acquired = self
                .acquire(true, self.config.estimation.average_s, baseline)
                .await;
            let (sample, settle_s) = match acquired {
                Ok(x) => {
                    baseline = self.shared.latest().map(|s| s.robot.residual).or(baseline);
                    x
                }
                Err(e) => {
                    self.release().await;
                    return Err(e);
                }
            };
            let done = Progress {
                settle_s: Some(settle_s),
                max_speed: Some(sample.max_speed),
                ..progress(Phase::Sampled)
            };
            events.event(&Event::Progress(done)).await;
            samples.push(sample);
        }
        events
            .event(&Event::Progress(Progress {
                phase: Phase::Returning,
                step: Some(count),
                of: Some(count),
                workflow: Some(workflow),
                pose: None,
                settle_s: None,
                max_speed: None,
            }))
            .await;
        let back = self.move_to(start_q, baseline).await;
        self.release().await;
        back?;
        Ok((samples, around))
    }
}
