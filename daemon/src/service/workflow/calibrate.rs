//! `collision-calibrate`: per-joint thresholds for a false-alarm budget, fitted on a motion
//! without contact (`docs/collision-detection.md` §7).
//!
//! The recording follows the loop's published states: each valid residual with the motion
//! features of the same q and q̇ (`safety::FeatureTracker`, the computation the monitor's
//! schedule runs each cycle). The source is the built-in excitation (the paper's q_A, q_B, q_C
//! joint-1 sweeps and the estimation pose pattern, driven at the `[motion]` limits), the
//! current task (recorded for `duration_s`, nothing moved by the service), or the last
//! recording again. `safety::calibration` fits the envelope and the extreme-value scale; the
//! result reports the fit, the covered motion and the minimum detectable force per link, and
//! `apply` installs and persists the thresholds with the payload they were calibrated for.
//! Any collision, stop or gap in the recording ends the workflow with its cause: a recording
//! with a contact in it would calibrate the contact away. The fit judges the recording itself
//! too, armed or not (`safety::calibration::screen`): a contact-like onset refuses it with
//! `Cause::ContactInRecording`. `apply` installs thresholds whose value at rest or median over
//! the recording lies above `[observer] calibration_ceiling_nm` only with `allow_weaker`, and
//! the audit trail records them as weaker than the configuration.

use fri_api::cause::Cause;
use fri_api::origin::Origin;
use fri_api::pattern::PatternKind;
use fri_api::protocol::{CalibrationSource, ErrorCode, OperatorError};
use fri_api::results::{CalibrateResult, Event, Phase, Progress, Workflow};
use safety::FeatureTracker;
use safety::calibration::{EnvelopeRecorder, FitOptions};
use tokio::sync::broadcast::error::RecvError;
use tokio::sync::watch;

use super::calibration_recording::CalibrationRecording;
use super::calibration_report::{above_ceiling, refused};
use super::motion::SilenceTimer;
use crate::operator::server::EventSink;
use crate::persistence::StoredMonitor;
use crate::service::core::{ServiceCore, compensation, err, same_payload};
use crate::service::output::CycleEvent;
use crate::service::stream::Update;

/// Default budget, false alarms per hour (one in 10 h).
pub const DEFAULT_BUDGET_PER_HOUR: f64 = 0.1;
/// Samples skipped after the recording starts or resumes after a gap: the feature tracker's
/// acceleration filters settle (two 25 Hz stages).
const TRACKER_SETTLE_SAMPLES: u32 = 100;
/// Amplitude of the joint-1 sweeps, rad (the paper's 66.7°).
const SWEEP_AMPLITUDE_RAD: f64 = 66.67 * std::f64::consts::PI / 180.0;
/// Centres of the paper's sweeps q_A, q_B, q_C, deg (mock-robot/scenarios/sweep-q*.toml).
const SWEEP_CENTRES_DEG: [[f64; 7]; 3] = [
    [0.0, 90.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 90.0, 0.0, 0.0, 0.0, -90.0, 0.0],
    [0.0, 90.0, 0.0, 0.0, -90.0, 0.0, 0.0],
];
/// The estimation pattern of the excitation: the paper's ten poses at ±7°.
const PATTERN_POSES: usize = 10;
/// Its increment, deg.
const PATTERN_STEP_DEG: f64 = 7.0;

/// The targets of the built-in excitation from `start` (rad): per sweep its centre, joint 1 at
/// ±66.7° (less where the joint limit minus 5° is closer) twice, the centre; then the
/// estimation pattern around `start` (when it fits inside the limits); then `start`.
pub fn excitation_targets(model: &dynamics::Model<7>, start: &[f64; 7]) -> Vec<[f64; 7]> {
    let limits = model.limits();
    let margin = fri_api::bounds::AROUND_LIMIT_MARGIN_RAD;
    let mut targets = Vec::new();
    for centre_deg in SWEEP_CENTRES_DEG {
        let centre = centre_deg.map(f64::to_radians);
        let reach = (limits.position_max[0] - margin - centre[0])
            .min(centre[0] - limits.position_min[0] - margin)
            .min(SWEEP_AMPLITUDE_RAD);
        let at = |offset: f64| {
            let mut q = centre;
            q[0] += offset;
            q
        };
        targets.extend([centre, at(reach), at(-reach), at(reach), at(-reach), centre]);
    }
    let fits = (0..7).all(|j| {
        let spread = PATTERN_STEP_DEG.to_radians() + margin;
        start[j] - spread >= limits.position_min[j] && start[j] + spread <= limits.position_max[j]
    });
    if fits
        && let Ok(poses) = crate::service::pattern::poses(
            PatternKind::Paper,
            model,
            start,
            PATTERN_POSES,
            PATTERN_STEP_DEG,
        )
    {
        targets.push(*start);
        targets.extend(poses);
    }
    targets.push(*start);
    targets
}

/// The arguments of `collision-calibrate` (protocol defaults applied).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrateRequest {
    /// What to fit on.
    pub source: CalibrationSource,
    /// Recording length, s.
    pub duration_s: Option<f64>,
    /// False alarms per hour, whole arm (default [`DEFAULT_BUDGET_PER_HOUR`]).
    pub budget_per_hour: Option<f64>,
    /// Install and persist the result.
    pub apply: bool,
    /// With `apply`: install thresholds above `[observer] calibration_ceiling_nm` too.
    pub allow_weaker: bool,
}

impl ServiceCore {
    /// `collision-calibrate` (see the module documentation).
    pub async fn collision_calibrate(
        &self,
        request: CalibrateRequest,
        origin: &Origin,
        events: &EventSink,
    ) -> Result<CalibrateResult, OperatorError> {
        let CalibrateRequest {
            source,
            duration_s,
            budget_per_hour,
            apply,
            allow_weaker,
        } = request;
        let _guard = self.busy()?;
        if allow_weaker && !apply {
            return Err(err(
                ErrorCode::InvalidArguments,
                "`allow_weaker` goes with `apply` (it lets apply install thresholds above [observer] calibration_ceiling_nm); nothing was done",
            ));
        }
        let budget = budget_per_hour.unwrap_or(DEFAULT_BUDGET_PER_HOUR);
        // The parser checked the ranges; a direct caller gets the same errors.
        fri_api::bounds::FALSE_ALARM_BUDGET
            .check("budget_per_hour", budget)
            .map_err(OperatorError::out_of_range)?;
        if let Some(d) = duration_s {
            fri_api::bounds::CALIBRATION_DURATION_S
                .check("duration_s", d)
                .map_err(OperatorError::out_of_range)?;
        }
        let recording = match source {
            CalibrationSource::LastRecording => {
                if duration_s.is_some() {
                    return Err(err(
                        ErrorCode::InvalidArguments,
                        "`duration_s` does not go with `source: last-recording` (nothing is recorded)",
                    ));
                }
                self.last_calibration_recording().ok_or_else(|| {
                    err(
                        ErrorCode::NotReady,
                        "no calibration recording yet: run `collision-calibrate` with `source: excitation` or `current-task` first",
                    )
                })?
            }
            CalibrationSource::CurrentTask => {
                let d = duration_s.ok_or_else(|| {
                    err(
                        ErrorCode::InvalidArguments,
                        "`duration_s` is required with `source: current-task` (20…3600 s)",
                    )
                })?;
                let (stop, _) = watch::channel(false);
                self.record_free_motion(Some(d), stop.subscribe(), events)
                    .await?
            }
            CalibrationSource::Excitation => self.excite_and_record(duration_s, events).await?,
        };
        self.keep_calibration_recording(recording.clone());
        events
            .event(&Event::Progress(Progress {
                phase: Phase::Fitting,
                step: None,
                of: None,
                workflow: Some(Workflow::Calibrate),
                pose: None,
                settle_s: None,
                max_speed: None,
            }))
            .await;
        let mut options = FitOptions::<7>::new(self.config.fri.cycle_s);
        options.budget_per_hour = budget;
        options.floor_nm = nalgebra::SVector::repeat(fri_api::bounds::MIN_THRESHOLD_NM);
        options.ceiling_nm = nalgebra::SVector::from_fn(|j, _| fri_api::bounds::threshold(j).max);
        // the configured constant thresholds are the stated constant: the cap wherever the
        // recording supports no smaller one (safety::calibration::cap)
        options.fallback_nm = nalgebra::SVector::from(self.config.observer.thresholds);
        let fit = recording.recorder.fit(&options).map_err(refused)?;
        let result = self.calibration_result(source, &fit, recording.payload)?;
        if !apply {
            return Ok(result);
        }
        if !result.above_ceiling.is_empty() && !allow_weaker {
            return Err(err(
                ErrorCode::Failed,
                format!(
                    "not installed: the calibrated thresholds weaken detection beyond [observer] calibration_ceiling_nm — {}. Was the arm touched during the recording, or does the budget ask for too few false alarms? Calibrate again, or install them anyway with `allow_weaker` (logged as weaker than the configuration)",
                    above_ceiling(&result.above_ceiling).join("; ")
                ),
            )
            .with_cause(Cause::CalibrationAboveCeiling {
                joints: result.above_ceiling.clone(),
            }));
        }
        let (gains, reaction, pause_s) = self.persistent(|s| (s.gains, s.reaction, s.pause_s));
        self.install_monitor(StoredMonitor {
            thresholds: result.schedule.thresholds,
            gains,
            reaction,
            pause_s,
            set_for_payload: recording.payload,
            schedule: Some(result.schedule.clone()),
            calibration: Some(result.recording.clone()),
        })?;
        self.audit.record(
            origin,
            fri_api::results::Change::CalibrationInstalled {
                thresholds: result.schedule.thresholds,
                budget_per_hour: budget,
                weaker_than_configuration: above_ceiling(&result.above_ceiling)
                    .into_iter()
                    .map(|w| format!("{w} (installed with allow_weaker)"))
                    .collect(),
            },
        );
        Ok(CalibrateResult {
            applied: true,
            settings: self.monitor_settings(),
            ..result
        })
    }

    fn last_calibration_recording(&self) -> Option<CalibrationRecording> {
        match self.calibration_recording.lock() {
            Ok(g) => g.clone(),
            Err(p) => p.into_inner().clone(),
        }
    }

    fn keep_calibration_recording(&self, r: CalibrationRecording) {
        match self.calibration_recording.lock() {
            Ok(mut g) => *g = Some(r),
            Err(p) => *p.into_inner() = Some(r),
        }
    }

    /// Drives the excitation (repeated until `duration_s` of robot time, default one pass) while
    /// recording; returns to monitor mode at the end, also after an error.
    async fn excite_and_record(
        &self,
        duration_s: Option<f64>,
        events: &EventSink,
    ) -> Result<CalibrationRecording, OperatorError> {
        let start = self.latest()?.robot.q;
        let targets = excitation_targets(&self.model, &start);
        let (stop, stopped) = watch::channel(false);
        let excite = self.drive_passes(&targets, duration_s, Workflow::Calibrate, events, stop);
        let (moved, recorded) =
            tokio::join!(excite, self.record_free_motion(None, stopped, events));
        moved?;
        recorded
    }

    /// Records residuals and motion features from the loop's states until `duration_s` of robot
    /// time is recorded (the filters' settling at the start and after a gap not counted), or
    /// until `stop` turns true. A collision, a stop, a lost state or a silent
    /// controller end it with an error; the payload must not change meanwhile.
    async fn record_free_motion(
        &self,
        duration_s: Option<f64>,
        mut stop: watch::Receiver<bool>,
        events: &EventSink,
    ) -> Result<CalibrationRecording, OperatorError> {
        let payload = self.persistent(|s| s.payload);
        let mut updates = self.shared.subscribe();
        let comp = payload.as_ref().map(compensation).unwrap_or_default();
        let mut tracker = FeatureTracker::new(&self.model, &comp);
        let mut recorder = EnvelopeRecorder::<7>::new();
        let silence = SilenceTimer::new(self);
        let cycle_s = self.config.fri.cycle_s;
        let mut previous: Option<f64> = None;
        let mut settle = TRACKER_SETTLE_SAMPLES;
        let mut reported = 0u64;
        let total = duration_s.map(|d| d.ceil() as usize);
        loop {
            tokio::select! {
                u = updates.recv() => match u {
                    Ok(Update::Snapshot(s)) => {
                        if let Some(e) = Self::held_error(&s.state) {
                            return Err(e);
                        }
                        let r = &s.robot;
                        if !s.residual_valid() {
                            previous = None;
                            continue;
                        }
                        let dt = previous.map_or(cycle_s, |p| r.time_s - p);
                        if previous.is_none() || dt > 3.5 * cycle_s || dt <= 0.0 {
                            // A gap the monitor did not bridge: the features start over.
                            tracker.reset();
                            settle = TRACKER_SETTLE_SAMPLES;
                        }
                        previous = Some(r.time_s);
                        let q = nalgebra::SVector::from(r.q);
                        let qd = nalgebra::SVector::from(r.qd);
                        let features = *tracker.step(&q, &qd, dt.max(cycle_s * 0.5));
                        if settle > 0 {
                            settle -= 1;
                        } else {
                            recorder.push(r.time_s, &nalgebra::SVector::from(r.residual), &features);
                        }
                        // Robot time recorded, s: the samples the fit gets, so `duration_s`
                        // of 20 s gives the fit its 20 blocks of 1 s (the filters' settling at
                        // the start and after a gap is not counted).
                        let recorded_s = recorder.samples() as f64 * cycle_s;
                        if recorded_s as u64 > reported {
                            reported = recorded_s as u64;
                            events
                                .event(&Event::Progress(Progress {
                                    phase: Phase::Recording,
                                    step: Some(reported as usize),
                                    of: total,
                                    workflow: Some(Workflow::Calibrate),
                                    pose: None,
                                    settle_s: None,
                                    max_speed: None,
                                }))
                                .await;
                        }
                        if duration_s.is_some_and(|d| recorded_s >= d) {
                            break;
                        }
                    }
                    Ok(Update::Event(CycleEvent::Collision(c))) => {
                        return Err(err(
                            ErrorCode::Aborted,
                            format!(
                                "collision detected during the calibration recording (link {}, {:.3} s): the recording is discarded. If nothing touched the arm, the thresholds in force are too low for this motion: raise them with `collision configure` (or disarm the monitor and watch the arm) and calibrate again",
                                c.link, c.time_s
                            ),
                        )
                        .with_cause(Cause::Collision {
                            link: c.link,
                            time_s: c.time_s,
                            residual: c.residual,
                        }));
                    }
                    Ok(Update::Event(CycleEvent::Stopped { reason, fri, .. })) => {
                        return Err(Self::stop_error(reason, fri));
                    }
                    Ok(Update::Event(_)) => {}
                    Err(RecvError::Lagged(n)) => {
                        tracing::warn!(lost = n, "calibration recording fell behind; the features start over");
                        previous = None;
                    }
                    Err(RecvError::Closed) => {
                        return Err(err(ErrorCode::NotReady, "the FRI loop has stopped"));
                    }
                },
                changed = stop.changed() => {
                    if changed.is_err() || *stop.borrow() {
                        break;
                    }
                }
                silent = silence.silence() => {
                    return Err(self.silent_error(silent));
                }
            }
        }
        let now = self.persistent(|s| s.payload);
        if !same_payload(payload.as_ref(), now.as_ref()) {
            return Err(err(
                ErrorCode::Failed,
                "the applied payload changed during the calibration recording: calibrate again with the payload the task carries",
            ));
        }
        Ok(CalibrationRecording { recorder, payload })
    }
}
