//! The service's own collision monitor over a recorded log: `safety::CollisionMonitor` built by
//! the function the service builds it with (`fri_api::monitor::build_monitor`: the configured
//! gains, model gravity, the LWR's link surfaces, the calibrated schedule with the service's
//! ceiling, the arm model's joint terms),
//! fed at the FRI period with the log played by `estimator::replay` (positions by a natural
//! cubic spline through the log's q, torques linear between its samples): the observer, its
//! velocity filter, warm-up and every threshold are those of the 1 ms loop, which a 200 Hz
//! recording's own step would not exercise (docs/collision-detection.md, "Real recordings").
//! With an identified arm, the observer runs on its corrected model and subtracts the arm's
//! offset and friction at its own filtered velocity, as the service does with
//! `robot.calibration` (`fri_service::service::arm`).

use std::path::PathBuf;

use anyhow::{Context, bail};
use dynamics::{IdentifiedModel, Model};
use estimator::replay::{PlayedSample, play};
use fri_api::bounds;
use fri_api::results::LinkForce;
use nalgebra::SVector;
use safety::calibration::{EnvelopeRecorder, minimum_detectable_force};
use safety::{
    CollisionMonitor, Detection, FeatureTracker, JointFriction, MotionFeatures, ObserverInput,
    PayloadCompensation, ReactionPolicy,
};

use super::logs::{read_identified, read_recorded};

type V7 = SVector<f64, 7>;

/// Configurations sampled per link for the minimum detectable force (as the service).
const FORCE_SAMPLES: usize = 1000;

/// Minimum detectable force per link at thresholds `theta` (the service's computation).
pub(crate) fn forces(model: &Model<7>, theta: &V7) -> [LinkForce; 7] {
    let f = minimum_detectable_force(
        model,
        &safety::lwr4_link_surfaces(),
        theta,
        FORCE_SAMPLES,
        0.8,
        2017,
    );
    std::array::from_fn(|l| LinkForce {
        median: f[l].median_n,
        p10: f[l].p10_n,
        p90: f[l].p90_n,
    })
}

/// One value for every joint or seven, each within `range(joint)`.
pub(crate) fn per_joint(
    name: &str,
    v: &[f64],
    range: impl Fn(usize) -> bounds::Range,
) -> anyhow::Result<V7> {
    let out = match v.len() {
        1 => V7::repeat(v[0]),
        7 => V7::from_column_slice(v),
        n => bail!("--{name}: {n} values; give one for every joint or 7"),
    };
    for j in 0..7 {
        range(j).check(&format!("{name}[{}]", j + 1), out[j])?;
    }
    Ok(out)
}

/// Longest edge `--edge-s` drops at each end of a log, s.
pub(crate) const EDGE_S: bounds::Range = bounds::Range::new(0.0, 10.0, "s");

/// Time from the first played sample to the last, s (`None`: nothing was played).
fn span_s(pieces: &[Vec<PlayedSample<7>>]) -> Option<f64> {
    let first = pieces.first()?.first()?.t;
    let last = pieces.last()?.last()?.t;
    Some(last - first)
}

/// The pieces less `edge_s` at each end of the whole log (the pieces between its gaps are
/// kept whole; a piece left empty is dropped).
fn without_edges(pieces: Vec<Vec<PlayedSample<7>>>, edge_s: f64) -> Vec<Vec<PlayedSample<7>>> {
    let (Some(first), Some(last)) = (
        pieces.first().and_then(|p| p.first()).map(|s| s.t),
        pieces.last().and_then(|p| p.last()).map(|s| s.t),
    ) else {
        return pieces;
    };
    let inside = |s: &PlayedSample<7>| s.t >= first + edge_s && s.t <= last - edge_s;
    pieces
        .into_iter()
        .map(|piece| piece.into_iter().filter(inside).collect::<Vec<_>>())
        .filter(|piece| !piece.is_empty())
        .collect()
}

/// The logs played at the period, each with its name, less `edge_s` at each end of every log
/// (a zero-phase filter's transient in a recording; the pieces between its gaps are kept whole).
pub(crate) fn played(
    paths: &[PathBuf],
    model: &Model<7>,
    period_s: f64,
    edge_s: f64,
) -> anyhow::Result<Vec<(String, Vec<Vec<PlayedSample<7>>>)>> {
    EDGE_S.check("--edge-s", edge_s)?;
    paths
        .iter()
        .map(|p| {
            let log = read_recorded::<7>(p, model)?;
            let pieces =
                play(&log, period_s).with_context(|| format!("playing {}", p.display()))?;
            let Some(span_s) = span_s(&pieces) else {
                bail!("{}: no piece long enough to play", p.display());
            };
            let pieces = without_edges(pieces, edge_s);
            if pieces.is_empty() {
                bail!(
                    "{}: nothing is left to play after dropping --edge-s {edge_s} s at each end of its {span_s:.3} s",
                    p.display()
                );
            }
            Ok((p.display().to_string(), pieces))
        })
        .collect()
}

/// The identified arm of `--calibration`, checked against `model`.
pub(crate) fn identified(
    path: &Option<PathBuf>,
    model: &Model<7>,
) -> anyhow::Result<Option<IdentifiedModel<7>>> {
    path.as_ref().map(|p| read_identified(p, model)).transpose()
}

/// The arm model the observer runs on, as the service's with `robot.calibration`: the identified
/// arm's corrected model and its offset and friction, or the nominal model alone.
pub(crate) fn arm_model(nominal: &Model<7>, arm: Option<&IdentifiedModel<7>>) -> ArmModel {
    ArmModel {
        model: arm.map_or_else(|| nominal.clone(), |m| m.corrected_model().clone()),
        joint_terms: arm.map(<JointFriction<7> as From<&IdentifiedModel<7>>>::from),
    }
}

/// The observer's model and the joint terms it subtracts at its own velocity.
#[derive(Debug, Clone)]
pub(crate) struct ArmModel {
    /// The model the observer runs on.
    pub model: Model<7>,
    /// Offset and friction subtracted from the measured torque (`None`: the nominal model).
    pub joint_terms: Option<JointFriction<7>>,
}

/// Samples skipped after a (re)start before the calibration records: the feature tracker's
/// acceleration filters settle (the service's `TRACKER_SETTLE_SAMPLES`).
pub(crate) const TRACKER_SETTLE_SAMPLES: u32 = 100;

/// The monitor's settings.
#[derive(Debug, Clone)]
pub(crate) struct Setup {
    /// Controller period, s.
    pub period_s: f64,
    /// Observer gains, 1/s.
    pub gains: V7,
    /// Static thresholds θ0, Nm.
    pub thresholds: V7,
    /// The calibrated schedule, if any.
    pub schedule: Option<fri_api::results::ThresholdSchedule>,
}

/// The monitor the service would run with `setup` on `arm`: the service's own builder.
pub(crate) fn build(arm: &ArmModel, setup: &Setup) -> anyhow::Result<CollisionMonitor<7>> {
    let monitor_setup = fri_api::monitor::MonitorSetup {
        period_s: setup.period_s,
        gains: setup.gains.into(),
        thresholds: setup.thresholds.into(),
        schedule: setup.schedule.as_ref(),
        reaction: ReactionPolicy::Stop,
    };
    fri_api::monitor::build_monitor(arm.model.clone(), arm.joint_terms, &monitor_setup)
        .map_err(|e| anyhow::anyhow!("collision monitor settings: {e}"))
}

/// A threshold crossing: the detector's onset.
#[derive(Debug, Clone, serde::Serialize)]
pub(crate) struct Crossing {
    /// Log time of the onset, s.
    pub time_s: f64,
    /// Joints over their threshold (1-based), with |r| and θ, Nm.
    pub joints: Vec<(usize, f64, f64)>,
}

/// What a run saw.
#[derive(Debug, Default)]
pub(crate) struct Run {
    /// |r_j| of every live sample, per joint, Nm.
    pub residual: [Vec<f32>; 7],
    /// θ_j of every live sample, per joint, Nm.
    pub thresholds: [Vec<f32>; 7],
    /// Live samples over θ, per joint.
    pub over: [usize; 7],
    /// The detector's onsets.
    pub crossings: Vec<Crossing>,
    /// Samples the observer rejected, with the last fault.
    pub rejected: usize,
    /// The last fault, if any.
    pub fault: Option<String>,
    /// Samples played.
    pub samples: usize,
}

/// Plays `pieces` through `monitor` (restarted at each piece, as the service does after a gap);
/// with `record`, also the service's calibration recording (its feature tracker, fed with the
/// observer's velocity, settled for [`TRACKER_SETTLE_SAMPLES`] after each start).
pub(crate) fn run(
    monitor: &mut CollisionMonitor<7>,
    pieces: &[Vec<PlayedSample<7>>],
    period_s: f64,
    mut record: Option<&mut EnvelopeRecorder<7>>,
) -> Run {
    let mut out = Run::default();
    let mut tracker = FeatureTracker::new(monitor.observer().model(), &PayloadCompensation::None);
    for piece in pieces {
        monitor.restart();
        tracker.reset();
        let mut settle = TRACKER_SETTLE_SAMPLES;
        for s in piece {
            out.samples += 1;
            let o = monitor.step(&ObserverInput::new(s.q, s.tau, period_s));
            if let Some(f) = o.observer.status.fault() {
                if !o.observer.status.residual_updated() {
                    out.rejected += 1;
                }
                out.fault = Some(format!("{f:?}"));
            }
            if !(o.live && o.observer.status.residual_updated()) {
                continue;
            }
            let r = o.observer.residual;
            let features = monitor
                .features()
                .copied()
                .unwrap_or_else(|| MotionFeatures::from_speed(&o.observer.velocity));
            let theta = monitor.detector().config().thresholds_for(&features);
            for j in 0..7 {
                out.residual[j].push(r[j].abs() as f32);
                out.thresholds[j].push(theta[j] as f32);
                if r[j].abs() > theta[j] {
                    out.over[j] += 1;
                }
            }
            if let Some(Detection::Onset(e)) = o.detection {
                out.crossings.push(Crossing {
                    time_s: s.t,
                    joints: (0..7)
                        .filter(|&j| e.joints_over.contains(j))
                        .map(|j| (j + 1, e.residual[j], e.thresholds[j]))
                        .collect(),
                });
                // report only, as `reaction = "report"`: the next contact is reported again
                monitor.pass_reaction();
            }
            if let Some(recorder) = record.as_deref_mut() {
                let f = *tracker.step(&s.q, &o.observer.velocity, period_s);
                if settle > 0 {
                    settle -= 1;
                } else {
                    recorder.push(s.t, &r, &f);
                }
            }
        }
    }
    out
}

/// RMS, 99th percentile and peak of `v`.
pub(crate) fn summary(v: &[f32]) -> (f64, f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let rms = (v.iter().map(|x| f64::from(*x).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
    let mut sorted: Vec<f32> = v.to_vec();
    sorted.sort_by(f32::total_cmp);
    let p99 = f64::from(sorted[((sorted.len() - 1) as f64 * 0.99).round() as usize]);
    let peak = f64::from(sorted[sorted.len() - 1]);
    (rms, p99, peak)
}

/// Median of `v`.
pub(crate) fn median(v: &[f32]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut sorted: Vec<f32> = v.to_vec();
    sorted.sort_by(f32::total_cmp);
    f64::from(sorted[sorted.len() / 2])
}
