//! Detection metrics: detector replay for threshold sweeps, percentiles, per-campaign statistics.

use safety::DetectorConfig;

use crate::campaign::ContactRecord;
use crate::{OFF_AXIS_NM, THRESHOLD};

/// Replays the detector logic (uniform threshold, debounce, hysteresis) on the series
/// max_j |r_j| and returns the onset sample indices.
pub fn replay_onsets(series: &[f32], theta: f64, config: &DetectorConfig<7>) -> Vec<usize> {
    let mut onsets = Vec::new();
    let (mut over, mut below, mut contact) = (0u32, 0u32, false);
    for (k, &x) in series.iter().enumerate() {
        let x = f64::from(x);
        if contact {
            below = if x < config.release_ratio * theta {
                below + 1
            } else {
                0
            };
            if below >= config.release_samples {
                contact = false;
                below = 0;
                over = 0;
            }
        } else if x > theta {
            over += 1;
            if over >= config.debounce_samples {
                contact = true;
                onsets.push(k);
            }
        } else {
            over = 0;
        }
    }
    onsets
}

pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let idx = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[idx]
}

pub struct Stats {
    pub contacts: usize,
    pub missed: usize,
    pub median_ms: f64,
    pub p95_ms: f64,
    pub isolation_onset: f64,
    pub isolation_episode: f64,
    pub isolable: usize,
    pub isolation_episode_isolable: f64,
    pub off_axis: usize,
    pub isolation_onset_off_axis: f64,
    pub isolation_episode_off_axis: f64,
}

pub fn stats(records: &[&ContactRecord]) -> Stats {
    let mut delays: Vec<f64> = records
        .iter()
        .filter_map(|r| r.delay_s)
        .map(|d| d * 1e3)
        .collect();
    delays.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let detected: Vec<&&ContactRecord> = records.iter().filter(|r| r.delay_s.is_some()).collect();
    let frac = |n: usize, d: usize| {
        if d == 0 {
            f64::NAN
        } else {
            100.0 * n as f64 / d as f64
        }
    };
    let isolable: Vec<&&&ContactRecord> = detected
        .iter()
        .filter(|r| r.own_joint_torque >= THRESHOLD)
        .collect();
    let off_axis: Vec<&&&ContactRecord> = detected
        .iter()
        .filter(|r| r.own_joint_torque >= OFF_AXIS_NM)
        .collect();
    let share = |set: &[&&&ContactRecord], pick: fn(&ContactRecord) -> Option<usize>| {
        frac(
            set.iter().filter(|r| pick(r) == Some(r.link)).count(),
            set.len(),
        )
    };
    Stats {
        off_axis: off_axis.len(),
        isolation_onset_off_axis: share(&off_axis, |r| r.onset_link),
        isolation_episode_off_axis: share(&off_axis, |r| r.episode_link),
        contacts: records.len(),
        missed: records.len() - detected.len(),
        median_ms: percentile(&delays, 0.5),
        p95_ms: percentile(&delays, 0.95),
        isolation_onset: frac(
            detected
                .iter()
                .filter(|r| r.onset_link == Some(r.link))
                .count(),
            detected.len(),
        ),
        isolation_episode: frac(
            detected
                .iter()
                .filter(|r| r.episode_link == Some(r.link))
                .count(),
            detected.len(),
        ),
        isolable: isolable.len(),
        isolation_episode_isolable: frac(
            isolable
                .iter()
                .filter(|r| r.episode_link == Some(r.link))
                .count(),
            isolable.len(),
        ),
    }
}

pub fn stats_row(label: &str, s: &Stats) -> String {
    format!(
        "| {label} | {} | {} | {:.1} | {:.1} | {:.0} % | {:.0} % | {:.0} % / {:.0} % of {} | {:.0} % of {} |",
        s.contacts,
        s.missed,
        s.median_ms,
        s.p95_ms,
        s.isolation_onset,
        s.isolation_episode,
        s.isolation_onset_off_axis,
        s.isolation_episode_off_axis,
        s.off_axis,
        s.isolation_episode_isolable,
        s.isolable
    )
}

pub const STATS_HEADER: &str = "| | contacts | missed | delay median [ms] | delay p95 [ms] | isolation at onset | isolation over the contact | isolation at onset / over the contact, own-joint \\|τ_ext\\| ≥ 1 Nm (off-axis) | isolation over the contact, own-joint \\|τ_ext\\| ≥ 6 Nm |\n|---|---|---|---|---|---|---|---|---|";
