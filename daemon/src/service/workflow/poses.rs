//! The pose pattern shared by `tare` and `estimate-payload`: drive each pose (in the order of
//! least robot time: the pattern is a set), take one averaged
//! static sample there, revisit the first pose (the pair measures the sensors' drift over the
//! procedure), return to the start pose; any stop or contact ends it with its cause.

use fri_api::results::{Event, Phase, ProcedureTiming, Progress, Workflow};

use nalgebra::SVector;

use crate::motion::JointMove;
use crate::operator::server::EventSink;
use crate::service::core::{ServiceCore, err};
use crate::service::cycle::ProcessorSettings;
use crate::service::pattern::{PatternKind, poses as pattern_poses};
use crate::service::settle::AveragedSample;
use fri_api::protocol::{ErrorCode, OperatorError};

impl ServiceCore {
    /// The pattern's poses in the order of least robot time at the configured motion limits,
    /// planned from the centre so that a tare and a later estimate visit them alike.
    fn travel_order(
        &self,
        around: &[f64; 7],
        poses: Vec<[f64; 7]>,
        revisit: bool,
    ) -> Vec<[f64; 7]> {
        let limits = ProcessorSettings::from_config(&self.config).limits;
        let time = |a: &[f64; 7], b: &[f64; 7]| {
            JointMove::new(SVector::from(*a), SVector::from(*b), limits)
                .map_or(f64::INFINITY, |m| m.end_time())
        };
        trajectory::tour::order(around, &poses, revisit, time)
            .into_iter()
            .map(|i| poses[i])
            .collect()
    }

    /// Drives the pattern, one averaged sample per pose (plus the revisit of the first when
    /// `estimation.revisit_first_pose`), then returns to the start pose.
    pub(super) async fn run_pattern(
        &self,
        around: Option<[f64; 7]>,
        poses: Option<usize>,
        step_deg: Option<f64>,
        kind: PatternKind,
        workflow: Workflow,
        events: &EventSink,
    ) -> Result<(Vec<AveragedSample>, [f64; 7], ProcedureTiming), OperatorError> {
        let latest = self.latest()?;
        let now = || {
            self.shared
                .latest()
                .map_or(latest.robot.time_s, |s| s.robot.time_s)
        };
        let mut timing = ProcedureTiming::default();
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
        let revisit = self.config.estimation.revisit_first_pose;
        let mut pattern = self.travel_order(&around, pattern, revisit);
        if revisit && let Some(first) = pattern.first().copied() {
            pattern.push(first);
        }
        let count = pattern.len();
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
            let move_start = now();
            let r = self.move_to(*pose, baseline).await;
            timing.moving_s += now() - move_start;
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
            timing.settling_s += settle_s;
            timing.averaging_s += sample.sample.evidence.map_or(0.0, |e| e.window_s);
            let done = Progress {
                settle_s: Some(settle_s),
                max_speed: Some(sample.max_speed),
                ..progress(Phase::Sampled)
            };
            events.event(&Event::Progress(done)).await;
            self.unknown_payload_sampled(&sample.sample);
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
        let move_start = now();
        let back = self.move_to(start_q, baseline).await;
        timing.moving_s += now() - move_start;
        timing.total_s = now() - latest.robot.time_s;
        self.release().await;
        back?;
        Ok((samples, around, timing))
    }
}
