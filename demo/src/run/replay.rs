//! The service's collision monitor replayed on the recorded log, and the onsets it and plain
//! threshold detectors find: the evaluation's detections and false alarms.

use anyhow::Context as _;
use fri_service::config::Config;
use nalgebra::SVector;
use safety::{CollisionDetector, CollisionMonitor, Detection, ObserverInput, PayloadCompensation};

use super::log::LogRow;
use super::{CONTACTS_S, MATCH_WINDOW_S};

type V7 = SVector<f64, 7>;

/// The residual of the service's monitor (nominal thresholds) replayed on `rows` with `payload`.
pub(super) fn residuals(
    model: &dynamics::Model<7>,
    config: &Config,
    rows: &[LogRow],
    payload: PayloadCompensation,
    cycle_s: f64,
) -> anyhow::Result<Vec<V7>> {
    let mut monitor: CollisionMonitor<7> =
        fri_service::service::build_monitor(config, model.clone())
            .context("observer configuration")?;
    monitor
        .set_payload(payload)
        .map_err(|e| anyhow::anyhow!("payload rejected by the observer: {e}"))?;
    let mut last_t: Option<f64> = None;
    Ok(rows
        .iter()
        .map(|r| {
            replay_step(&mut monitor, r, &mut last_t, cycle_s)
                .observer
                .residual
        })
        .collect())
}

/// One logged cycle through a replayed monitor, as the service ran it: the gap since the
/// previous row integrated with its true length, or — longer than the service bridges
/// (`MAX_BRIDGED_CYCLES`, e.g. a host stall in real time) — a restart and a new warm-up, as the
/// service resynchronised there (integrating across it would turn the gap into a residual step
/// and a false alarm the service never raised). During a warm-up the residual is NaN, as in
/// the service's log: it is not trusted, and the detector was not updated.
fn replay_step(
    monitor: &mut CollisionMonitor<7>,
    r: &LogRow,
    last_t: &mut Option<f64>,
    cycle_s: f64,
) -> safety::MonitorOutput<7> {
    let dt = last_t.map_or(cycle_s, |t| (r.time_s - t).max(cycle_s));
    *last_t = Some(r.time_s);
    let cycles = (dt / cycle_s).round();
    if cycles > f64::from(fri_service::service::cycle::MAX_BRIDGED_CYCLES) {
        monitor.restart();
    }
    let mut out = monitor.step(&ObserverInput::new(V7::from(r.q), V7::from(r.tau), dt));
    if !out.live {
        out.observer.residual = V7::repeat(f64::NAN);
    }
    out
}

/// The residual, the scheduled thresholds and the onset times (s since `t0`) of the service's
/// calibrated monitor replayed on the log.
pub(super) fn scheduled_residuals(
    model: &dynamics::Model<7>,
    config: &Config,
    rows: &[LogRow],
    payload: PayloadCompensation,
    cycle_s: f64,
    schedule: &fri_api::results::ThresholdSchedule,
    t0: f64,
) -> anyhow::Result<(Vec<V7>, Vec<V7>, Vec<f64>)> {
    let mut monitor: CollisionMonitor<7> = fri_service::service::build_scheduled_monitor(
        config,
        &fri_service::service::arm::ArmModel::nominal(model.clone()),
        Some(schedule),
    )
    .context("observer configuration")?;
    monitor
        .set_payload(payload)
        .map_err(|e| anyhow::anyhow!("payload rejected by the observer: {e}"))?;
    let mut last_t: Option<f64> = None;
    let (mut residual, mut thresholds, mut onsets) = (Vec::new(), Vec::new(), Vec::new());
    for r in rows {
        let out = replay_step(&mut monitor, r, &mut last_t, cycle_s);
        let features = monitor
            .features()
            .copied()
            .unwrap_or_else(|| safety::MotionFeatures::from_speed(&out.observer.velocity));
        residual.push(out.observer.residual);
        thresholds.push(monitor.detector().config().thresholds_for(&features));
        if let Some(Detection::Onset(_)) = out.detection {
            onsets.push(r.time_s - t0);
        }
    }
    Ok((residual, thresholds, onsets))
}

/// Onset times of a plain detector at `thresholds` on `signal` (the FRI estimate, the
/// uncompensated residual).
pub(super) fn onsets(
    signal: &[V7],
    velocities: &[V7],
    times: &[f64],
    thresholds: &[f64; 7],
) -> anyhow::Result<Vec<f64>> {
    let mut detector = CollisionDetector::<7>::new(safety::DetectorConfig {
        thresholds_nm: V7::from(*thresholds),
        ..Default::default()
    })
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut out = Vec::new();
    for (k, ((r, v), t)) in signal.iter().zip(velocities).zip(times).enumerate() {
        if let Detection::Onset(_) = detector.update(r, v, k as u64, *t) {
            out.push(*t);
        }
    }
    Ok(out)
}

/// Splits onsets into detections (first onset within the window after each contact) and false
/// alarms (all other onsets).
pub(super) fn classify(onsets: &[f64]) -> (Vec<f64>, usize) {
    let mut detections = Vec::new();
    let mut used = vec![false; onsets.len()];
    for c in CONTACTS_S {
        if let Some((i, t)) = onsets
            .iter()
            .enumerate()
            .find(|(i, t)| !used[*i] && **t >= c && **t <= c + MATCH_WINDOW_S)
        {
            used[i] = true;
            detections.push(*t);
        }
    }
    let false_alarms = used.iter().filter(|u| !**u).count();
    (detections, false_alarms)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynamics::Data;

    /// A moving arm logged at 1 ms with a 10 ms hole (a host stall in real time): the replay
    /// restarts there as the service does, its warm-up is NaN, and what it trusts stays at the
    /// model's residual (≈ 0 for torques from the same model) instead of a step.
    #[test]
    fn a_replay_restarts_after_a_gap_the_service_does_not_bridge() {
        let model = dynamics::lwr4();
        let mut data = Data::new(&model);
        let mut row = |t: f64| {
            let w = std::f64::consts::TAU * 0.5;
            let q = V7::from_fn(|j, _| 0.4 * (w * t).sin() + 0.3 * j as f64 - 0.6);
            let qd = V7::repeat(0.4 * w * (w * t).cos());
            let qdd = V7::repeat(-0.4 * w * w * (w * t).sin());
            let tau = dynamics::rnea(&model, &mut data, &q, &qd, &qdd);
            LogRow {
                time_s: t,
                q: q.into(),
                qd: qd.into(),
                tau: tau.into(),
                tau_ext: [0.0; 7],
            }
        };
        let rows: Vec<LogRow> = (0..3000)
            .filter(|k| !(1500..1510).contains(k))
            .map(|k| row(f64::from(k) * 1e-3))
            .collect();
        let replayed = residuals(
            &model,
            &Config::default(),
            &rows,
            PayloadCompensation::None,
            1e-3,
        )
        .unwrap();
        let after_gap = rows.iter().position(|r| r.time_s > 1.5).unwrap();
        assert!(replayed[after_gap].iter().all(|x| x.is_nan()));
        let trusted: Vec<&V7> = replayed.iter().filter(|r| r[0].is_finite()).collect();
        assert!(trusted.len() > 2000);
        let peak = trusted.iter().map(|r| r.amax()).fold(0.0, f64::max);
        assert!(peak < 0.5, "largest trusted residual {peak} Nm");
    }
}
