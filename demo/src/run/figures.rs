//! The demo's figures in the style of the paper's Fig. 5 (measured vs computed torque with the
//! estimated payload) and Fig. 6 (the three residual signals with thresholds and detections).

use std::path::Path;

use dynamics::{Data, InertialParameters};
use nalgebra::{SVector, Vector3};

use super::log::LogRow;
use super::{CONTACTS_S, PayloadReport};
use crate::plots::{self, Marker, Panel, Series, Threshold};

type V7 = SVector<f64, 7>;

/// Every fifth point, without the ones that have no value (a replayed monitor's warm-up).
fn decimate(times: &[f64], values: impl Iterator<Item = f64>) -> Vec<(f64, f64)> {
    times
        .iter()
        .copied()
        .zip(values)
        .step_by(5)
        .filter(|(_, y)| y.is_finite())
        .collect()
}

/// Fig. 5: joints 2, 4 and 6, measured torque and the RNEA torque with the estimate.
pub(super) fn plot_fig5(
    path: &Path,
    model: &dynamics::Model<7>,
    rows: &[LogRow],
    times: &[f64],
    estimate: &PayloadReport,
    cycle_s: f64,
) -> anyhow::Result<()> {
    let loaded = model.with_payload(&InertialParameters::point_mass(
        estimate.mass,
        Vector3::from(estimate.com),
    ));
    let mut data = Data::new(&loaded);
    // q̈ from a central difference of the observer's filtered q̇ over ±10 cycles of the log's
    // own time. Across a gap in the log (a host stall) the difference is no acceleration, and
    // after one the observer's q̇ filter settles again (50 ms): no prediction there (NaN, the
    // line is cut).
    let h = 10usize;
    let gap = |k: usize| k > 0 && rows[k].time_s - rows[k - 1].time_s > 1.5 * cycle_s;
    let settle = (0.05 / cycle_s) as usize;
    let mut since_gap = usize::MAX;
    let mut fresh = vec![false; rows.len()];
    for (k, f) in fresh.iter_mut().enumerate() {
        since_gap = if gap(k) {
            0
        } else {
            since_gap.saturating_add(1)
        };
        *f = since_gap <= settle;
    }
    let computed: Vec<V7> = (0..rows.len())
        .map(|k| {
            let (a, b) = (k.saturating_sub(h), (k + h).min(rows.len() - 1));
            if (a + 1..=b).any(gap) || fresh[k] {
                return V7::repeat(f64::NAN);
            }
            let span = (rows[b].time_s - rows[a].time_s).max(cycle_s);
            let qdd = (V7::from(rows[b].qd) - V7::from(rows[a].qd)) / span;
            dynamics::rnea(
                &loaded,
                &mut data,
                &V7::from(rows[k].q),
                &V7::from(rows[k].qd),
                &qdd,
            )
        })
        .collect();
    // The observer's q̇ restarts with the free-motion run (new controller connection); its first
    // 50 ms are the velocity filter settling, not a torque prediction, so they are not plotted.
    let settled = ((0.05 / cycle_s) as usize).min(rows.len()).min(times.len());
    let (rows, times, computed) = (&rows[settled..], &times[settled..], &computed[settled..]);
    let markers = contact_markers();
    let panels: Vec<Panel> = [1usize, 3, 5]
        .iter()
        .map(|&j| Panel {
            title: format!(
                "Joint {}: measured joint torque and the torque computed with the estimated payload (RNEA)",
                j + 1
            ),
            y_label: "joint torque [Nm]".into(),
            // The computed torque first, the measured one (thinner) on top of it.
            series: vec![
                Series {
                    label: "computed (RNEA)".into(),
                    points: decimate(times, computed.iter().map(|c| c[j])),
                    color: 0,
                    width: 2,
                },
                Series {
                    label: "measured".into(),
                    points: decimate(times, rows.iter().map(|r| r.tau[j])),
                    color: 1,
                    width: 1,
                },
            ],
            thresholds: Vec::new(),
            markers: markers.clone(),
            marker_legend: Some(CONTACT_LEGEND.into()),
            detections: Vec::new(),
        })
        .collect();
    plots::draw(path, &panels).map(|_| ())
}

/// Legend entry of the contact markers.
const CONTACT_LEGEND: &str = "contact onset C1–C3";

/// The free-motion segment's contact onsets as labelled markers.
fn contact_markers() -> Vec<Marker> {
    CONTACTS_S
        .iter()
        .enumerate()
        .map(|(i, t)| Marker {
            t: *t,
            label: format!("C{}", i + 1),
        })
        .collect()
}

/// The joint number as a Unicode subscript (joints 1..9).
fn subscript(joint: usize) -> char {
    char::from_u32(0x2080 + (joint % 10) as u32).unwrap_or(' ')
}

/// The thresholds as the figure draws them: joints with the same value share one neutral
/// dashed pair ("θ = ±6 Nm", or "θ₆,₇ = ±2 Nm" when others differ), a joint alone on its value
/// gets a pair in its own colour.
fn threshold_lines(thresholds: &[f64; 7]) -> Vec<Threshold> {
    let mut groups: Vec<(f64, Vec<usize>)> = Vec::new();
    for (j, &t) in thresholds.iter().enumerate() {
        match groups.iter_mut().find(|(v, _)| (*v - t).abs() < 1e-9) {
            Some((_, joints)) => joints.push(j),
            None => groups.push((t, vec![j])),
        }
    }
    let every = groups.len() == 1;
    groups
        .into_iter()
        .map(|(value, joints)| {
            let who: String = if every {
                String::new()
            } else {
                joints
                    .iter()
                    .map(|j| subscript(j + 1).to_string())
                    .collect::<Vec<_>>()
                    .join(",")
            };
            Threshold {
                value,
                label: format!("θ{who} = ±{} Nm", fri_api::bounds::number(value)),
                color: (joints.len() == 1 && !every).then(|| joints[0]),
                curve: None,
            }
        })
        .collect()
}

/// Where each signal's monitor detected a contact (s since the run's start): the figure's
/// triangles.
pub(super) struct Onsets<'a> {
    /// The controller's estExtJntTrq at the fixed threshold.
    pub(super) fri: &'a [f64],
    /// The uncompensated residual at the fixed threshold.
    pub(super) uncompensated: &'a [f64],
    /// The compensated residual with the calibrated schedule.
    pub(super) compensated: &'a [f64],
}

/// Fig. 6: (a) the controller's estimate, (b) the uncompensated and (c) the compensated residual.
pub(super) fn plot_fig6(
    path: &Path,
    times: &[f64],
    thresholds: &[f64; 7],
    (fri, uncompensated, compensated): (&[V7], &[V7], &[V7]),
    scheduled: &[V7],
    onsets_of: &Onsets<'_>,
) -> anyhow::Result<()> {
    let markers = contact_markers();
    // Panel (c): each joint's calibrated threshold θ_j(t), dashed in the joint's colour, as its
    // largest value per 20 ms (the schedule follows the velocity noise sample by sample).
    let scheduled_lines: Vec<Threshold> = (0..7)
        .map(|j| {
            let points: Vec<(f64, f64)> = times
                .chunks(20)
                .zip(scheduled.chunks(20))
                .map(|(t, th)| (t[0], th.iter().map(|v| v[j]).fold(0.0, f64::max)))
                .collect();
            Threshold {
                value: points.last().map_or(0.0, |p| p.1),
                label: format!("θ{}(t)", subscript(j + 1)),
                color: Some(j),
                curve: Some(points),
            }
        })
        .collect();
    let panel = |title: &str, y_label: &str, sig: &[V7], detected: &[f64]| Panel {
        title: title.to_owned(),
        y_label: y_label.to_owned(),
        series: (0..7)
            .map(|j| Series {
                label: format!("joint {}", j + 1),
                points: decimate(times, sig.iter().map(|r| r[j])),
                color: j,
                width: 1,
            })
            .collect(),
        thresholds: threshold_lines(thresholds),
        markers: markers.clone(),
        marker_legend: Some(CONTACT_LEGEND.into()),
        detections: detected.to_vec(),
    };
    plots::draw(
        path,
        &[
            panel(
                "(a) Controller's external-torque estimate (FRI estExtJntTrq), payload not declared",
                "estExtJntTrq [Nm]",
                fri,
                onsets_of.fri,
            ),
            panel(
                "(b) Momentum-observer residual without payload compensation",
                "r [Nm]",
                uncompensated,
                onsets_of.uncompensated,
            ),
            Panel {
                thresholds: scheduled_lines,
                ..panel(
                    "(c) Compensated residual (eq. 48); θⱼ(t) for 1 false alarm/10 h (max per 20 ms)",
                    "r [Nm]",
                    compensated,
                    onsets_of.compensated,
                )
            },
        ],
    )
    .map(|_| ())
}
