//! The pose pattern shared by `tare` and `estimate-payload`: drive each pose (in the order of
//! least robot time: the pattern is a set), take one averaged static sample there, sample the
//! first pose again at the end (the pair measures the sensors' drift over the procedure; for the
//! centred pattern it is the centre, so the revisit is also the way home), return to the start
//! pose. An estimate that follows a tare visits the tare's poses in reverse, so that the two
//! procedures meet at the samples nearest in time. A stop or contact ends the run with its
//! cause and the arm held where it is; any other abort drives back to the start pose first
//! (or says why it could not).

use fri_api::cause::Cause;
use fri_api::results::{Event, Phase, ProcedureTiming, Progress, Workflow};

use nalgebra::SVector;

use super::acquire::Acquire;
use crate::operator::server::EventSink;
use crate::persistence::Clocks;
use crate::service::core::{ServiceCore, err};
use crate::service::cycle::ProcessorSettings;
use crate::service::pattern::{PatternKind, poses as pattern_poses};
use crate::service::settle::AveragedSample;
use fri_api::protocol::{ErrorCode, OperatorError};
use trajectory::JointMove;

/// A pose closer than this to the arm's measured one (every joint) is sampled without a move,
/// rad (≈ 35 encoder counts; the controller's g_ctrl takes up the difference in the fit).
const IN_PLACE_RAD: f64 = 1e-4;

/// What a workflow asked the pattern for.
#[derive(Debug, Clone, Copy)]
pub(super) struct PatternRequest {
    /// Centre, rad (default: the measured pose).
    pub around: Option<[f64; 7]>,
    /// Number of poses (default: `estimation.pattern_poses`).
    pub poses: Option<usize>,
    /// Increment, deg (default: `estimation.pattern_step_deg`, else the pattern's own).
    pub step_deg: Option<f64>,
    /// Which pattern.
    pub kind: PatternKind,
}

/// A completed pattern.
#[derive(Debug, Clone)]
pub(super) struct PatternRun {
    /// One sample per visit, in the order driven.
    pub samples: Vec<AveragedSample>,
    /// The commanded pose of every sample, rad.
    pub targets: Vec<[f64; 7]>,
    /// The centre, rad.
    pub around: [f64; 7],
    /// Poses of the pattern (without the revisit).
    pub poses: usize,
    /// Increment used, deg.
    pub step_deg: f64,
    /// Robot time by phase.
    pub timing: ProcedureTiming,
    /// The clocks when the run started and when its last sample was taken.
    pub clocks: (Option<Clocks>, Option<Clocks>),
}

fn deg(q: &[f64; 7]) -> String {
    let v: Vec<String> = q.iter().map(|x| format!("{:.2}", x.to_degrees())).collect();
    format!("[{}] deg", v.join(", "))
}

impl ServiceCore {
    /// Move time between two poses at the configured limits, s.
    fn move_time(&self, a: &[f64; 7], b: &[f64; 7]) -> f64 {
        let limits = ProcessorSettings::from_config(&self.config).limits;
        JointMove::new(SVector::from(*a), SVector::from(*b), limits)
            .map_or(f64::INFINITY, |m| m.end_time())
    }

    /// The visiting sequence of a pattern (one sample per entry): the poses in the order of
    /// least robot time at the configured motion limits, planned from the centre so that a
    /// tare and a later estimate visit them alike, with the revisit of the first last.
    fn visiting_sequence(
        &self,
        kind: PatternKind,
        around: &[f64; 7],
        pattern: Vec<[f64; 7]>,
        revisit: bool,
    ) -> Vec<[f64; 7]> {
        let time = |a: &[f64; 7], b: &[f64; 7]| self.move_time(a, b);
        let ordered = |targets: &[[f64; 7]], revisit_first| -> Vec<[f64; 7]> {
            trajectory::tour::order(around, targets, revisit_first, time)
                .into_iter()
                .map(|i| targets[i])
                .collect()
        };
        let mut seq = match kind {
            // the centre first, the tour of the others from it and back to it
            PatternKind::Centred if !pattern.is_empty() => {
                let mut seq = vec![pattern[0]];
                seq.extend(ordered(&pattern[1..], false));
                seq
            }
            _ => ordered(&pattern, revisit),
        };
        if revisit && let Some(first) = seq.first().copied() {
            seq.push(first);
        }
        seq
    }

    /// Drives the pattern (or, with `follow`, exactly those poses in that order), one averaged
    /// sample per visit, then returns to the start pose. On an abort the arm returns to the
    /// start pose when that is safe; the error says whether it did, or why not and what to do.
    pub(super) async fn run_pattern(
        &self,
        request: PatternRequest,
        follow: Option<Vec<[f64; 7]>>,
        workflow: Workflow,
        events: &EventSink,
    ) -> Result<PatternRun, OperatorError> {
        let latest = self.latest()?;
        if latest.state.is_held() {
            return Err(err(
                ErrorCode::NotReady,
                "the arm is stopped (operator stop or collision reaction); `resume` first",
            )
            .with_cause(Cause::Held));
        }
        // Where the arm rests: the controller's set-point when the arm holds it (a loaded arm
        // sags a little from it), else the measured pose.
        let start_q = self
            .commanded_q()
            .filter(|c| (0..7).all(|j| (c[j] - latest.robot.q[j]).abs() < 1e-3))
            .unwrap_or(latest.robot.q);
        let around = request.around.unwrap_or(start_q);
        let count = request
            .poses
            .unwrap_or(self.config.estimation.pattern_poses);
        let step = request
            .step_deg
            .or(self.config.estimation.pattern_step_deg)
            .unwrap_or(request.kind.default_step_deg());
        // The centre must keep the pattern inside the joint limits with a margin and lie near
        // the measured pose (the protocol layer only knows the limits, not the pose).
        let max_distance = self.config.motion.max_around_distance_rad;
        fri_api::bounds::POSES
            .check_count("poses", count as u64)
            .and_then(|()| fri_api::bounds::STEP_DEG.check("step_deg", step))
            .map_err(OperatorError::out_of_range)?;
        fri_api::bounds::check_around(&around, &start_q, step, max_distance)
            .map_err(|e| err(ErrorCode::InvalidArguments, e))?;
        let targets = match follow {
            Some(t) => t,
            None => {
                let pattern = pattern_poses(request.kind, &self.model, &around, count, step)
                    .map_err(|e| {
                        err(
                            ErrorCode::InvalidArguments,
                            format!("pose design failed: {e}"),
                        )
                    })?;
                let revisit = self.config.estimation.revisit_first_pose;
                self.visiting_sequence(request.kind, &around, pattern, revisit)
            }
        };
        let mut run = PatternRun {
            samples: Vec::with_capacity(targets.len()),
            targets,
            around,
            poses: count,
            step_deg: step,
            timing: ProcedureTiming::default(),
            clocks: (self.clocks(), None),
        };
        let mut baseline = Some(latest.robot.residual);
        let visited = self
            .visit(
                &mut run,
                &mut baseline,
                latest.robot.time_s,
                workflow,
                events,
            )
            .await;
        run.clocks.1 = self.clocks();
        let result = match visited {
            Ok(()) => {
                self.go_home(&mut run, start_q, baseline, workflow, events)
                    .await
            }
            Err(e) => Err(self.after_abort(e, start_q, baseline, workflow).await),
        };
        run.timing.total_s = self.now_or(latest.robot.time_s) - latest.robot.time_s;
        self.release();
        result.map(|()| run)
    }

    /// Whether the arm rests at `pose` already, measured or commanded (within
    /// [`IN_PLACE_RAD`]): a move to the set-point itself has length zero, and a loaded arm held
    /// by the controller may sag a little from it.
    fn at_pose(&self, pose: &[f64; 7]) -> bool {
        let off = |q: &[f64; 7]| (0..7).map(|j| (q[j] - pose[j]).abs()).fold(0.0, f64::max);
        let measured = self
            .shared
            .latest()
            .map_or(f64::INFINITY, |s| off(&s.robot.q));
        let commanded = self.commanded_q().map_or(f64::INFINITY, |c| off(&c));
        measured <= IN_PLACE_RAD || commanded <= IN_PLACE_RAD
    }

    /// The latest controller time, or `fallback`.
    fn now_or(&self, fallback: f64) -> f64 {
        self.shared.latest().map_or(fallback, |s| s.robot.time_s)
    }

    /// Visits `run.targets`, one sample each.
    async fn visit(
        &self,
        run: &mut PatternRun,
        baseline: &mut Option<[f64; 7]>,
        t0: f64,
        workflow: Workflow,
        events: &EventSink,
    ) -> Result<(), OperatorError> {
        let count = run.targets.len();
        for k in 0..count {
            let pose = run.targets[k];
            let progress = |phase| Progress {
                phase,
                step: Some(k + 1),
                of: Some(count),
                workflow: Some(workflow),
                pose: Some(pose),
                settle_s: None,
                max_speed: None,
            };
            // A pose sampled again right away (the design replicates informative poses) is
            // sampled in place: its set-point is already there, and a move of length zero is
            // never seen moving.
            // The same for a pose the arm already rests at, measured or commanded (a move to
            // the set-point itself has length zero: a loaded arm held by the controller may sag
            // a little from it).
            let again = k > 0 && run.targets[k - 1] == pose;
            if !again && !self.at_pose(&pose) {
                events
                    .event(&Event::Progress(progress(Phase::Moving)))
                    .await;
                let move_start = self.now_or(t0);
                let r = self.move_to(pose, *baseline).await;
                run.timing.moving_s += self.now_or(t0) - move_start;
                r?;
            }
            events
                .event(&Event::Progress(progress(Phase::Settling)))
                .await;
            let (sample, settle_s) = self
                .acquire(
                    Acquire::Workflow,
                    self.config.estimation.average_s,
                    *baseline,
                )
                .await?;
            *baseline = self.shared.latest().map(|s| s.robot.residual).or(*baseline);
            run.timing.settling_s += settle_s;
            run.timing.averaging_s += sample.sample.evidence.map_or(0.0, |e| e.window_s);
            let done = Progress {
                settle_s: Some(settle_s),
                max_speed: Some(sample.max_speed),
                ..progress(Phase::Sampled)
            };
            events.event(&Event::Progress(done)).await;
            self.unknown_payload_sampled(&sample.sample);
            run.samples.push(sample);
        }
        Ok(())
    }

    /// After the last sample: back to the start pose unless the arm is there already.
    async fn go_home(
        &self,
        run: &mut PatternRun,
        start_q: [f64; 7],
        baseline: Option<[f64; 7]>,
        workflow: Workflow,
        events: &EventSink,
    ) -> Result<(), OperatorError> {
        let count = run.targets.len();
        events
            .event(&Event::Progress(Progress {
                phase: Phase::Returning,
                step: Some(count),
                of: Some(count),
                workflow: Some(workflow),
                pose: Some(start_q),
                settle_s: None,
                max_speed: None,
            }))
            .await;
        if self.at_pose(&start_q) {
            return Ok(());
        }
        let t = self.now_or(0.0);
        let back = self.move_to(start_q, baseline).await;
        run.timing.moving_s += self.now_or(t) - t;
        back
    }

    /// The error of an aborted pattern, after driving back to the start pose when that is safe;
    /// the message says whether the arm returned, or why not and what to do.
    async fn after_abort(
        &self,
        mut e: OperatorError,
        start_q: [f64; 7],
        baseline: Option<[f64; 7]>,
        workflow: Workflow,
    ) -> OperatorError {
        let again = match workflow {
            Workflow::Tare => format!("`fri-ctl tare --around {}` (rad)", rad(&start_q)),
            _ => "`fri-ctl estimate-payload` (it drives to the tare's poses from wherever the arm is)".to_owned(),
        };
        let stay = |why: &str| {
            format!(
                "; the arm was not driven back to the start pose {}: {why}; after `fri-ctl resume` it stays where it is, and {again} runs the pattern again",
                deg(&start_q)
            )
        };
        let held_now = self.shared.latest().is_none_or(|s| s.state.is_held());
        let why_not = match e.cause.as_deref() {
            Some(
                Cause::Collision { .. }
                | Cause::ResidualChange { .. }
                | Cause::OperatorStop
                | Cause::Held
                | Cause::ObserverFault { .. },
            ) => Some(
                "after a stop, a contact or a suspected contact the arm is held where it stopped and never moves by itself",
            ),
            Some(Cause::ControllerSilent { .. }) => Some("the controller is silent"),
            _ if held_now => {
                Some("the arm is held (stop or collision reaction) and never moves by itself")
            }
            _ => None,
        };
        if let Some(why) = why_not {
            e.message.push_str(&stay(why));
            return e;
        }
        if self.at_pose(&start_q) {
            e.message.push_str("; the arm is at its start pose");
            return e;
        }
        match self.move_to(start_q, baseline).await {
            Ok(()) => e
                .message
                .push_str(&format!("; the arm returned to its start pose {}", deg(&start_q))),
            Err(r) => e.message.push_str(&format!(
                "; returning to the start pose {} failed too ({}); after `fri-ctl resume` (if held) {again} runs the pattern again",
                deg(&start_q),
                r.message
            )),
        }
        e
    }
}

fn rad(q: &[f64; 7]) -> String {
    let v: Vec<String> = q.iter().map(|x| format!("{x:.4}")).collect();
    v.join(",")
}
