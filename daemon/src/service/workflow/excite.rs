//! The service's excitations: a sequence of commanded moves driven (repeated) while a recorder
//! follows the loop's states. `collision-calibrate` drives the paper's sweeps
//! ([`super::calibrate::excitation_targets`]); `record` with `excite_deg` drives the
//! identification excitation of [`identification_targets`] for `fri-ctl identify`.

use fri_api::protocol::OperatorError;
use fri_api::results::{Event, Phase, Progress, Workflow};
use tokio::sync::watch;

use crate::operator::server::EventSink;
use crate::service::core::ServiceCore;

/// Waypoints of one pass of the identification excitation (the start pose is added at the
/// end). Twelve points let each of the seven joints follow its own cosine pattern (frequency
/// indices 1…7 of a 12-point DCT-II), so no two joints move in proportion and the friction
/// and inertia columns of the regressor stay apart.
pub const IDENTIFICATION_WAYPOINTS: usize = 12;

/// The identification excitation from `start` (rad) with offsets of up to `amplitude_rad`:
/// waypoint k sets joint j to `start[j] + amplitude·cos(π·(j+1)·(k+½)/12)` (each pattern scaled
/// to a peak of 1), clamped inside the joint limits less [`fri_api::bounds::AROUND_LIMIT_MARGIN_RAD`]; the last target is `start`.
/// The patterns of different joints are orthogonal over the waypoints, so the joints move
/// with different speeds and directions between any two of them.
pub fn identification_targets(
    model: &dynamics::Model<7>,
    start: &[f64; 7],
    amplitude_rad: f64,
) -> Vec<[f64; 7]> {
    let limits = model.limits();
    let margin = fri_api::bounds::AROUND_LIMIT_MARGIN_RAD;
    let k_total = IDENTIFICATION_WAYPOINTS as f64;
    let pattern = |j: usize, k: usize| {
        (std::f64::consts::PI * (j as f64 + 1.0) * (k as f64 + 0.5) / k_total).cos()
    };
    // Each pattern scaled to a peak of 1 (frequency 6 alone peaks at cos 45°): every joint
    // reaches the full amplitude, and scaling keeps the patterns orthogonal.
    let peak: [f64; 7] = std::array::from_fn(|j| {
        (0..IDENTIFICATION_WAYPOINTS)
            .map(|k| pattern(j, k).abs())
            .fold(0.0, f64::max)
    });
    let mut targets: Vec<[f64; 7]> = (0..IDENTIFICATION_WAYPOINTS)
        .map(|k| {
            std::array::from_fn(|j| {
                let q = start[j] + amplitude_rad * pattern(j, k) / peak[j];
                let low = limits.position_min[j] + margin;
                let high = limits.position_max[j] - margin;
                // A start pose already inside the margin stays where it is on that side.
                q.clamp(low.min(start[j]), high.max(start[j]))
            })
        })
        .collect();
    targets.push(*start);
    targets
}

impl ServiceCore {
    /// Drives `targets` in order, again from the first while less than `duration_s` of robot
    /// time has passed since the start (default: one pass), reporting each move as `progress`
    /// of `workflow`; then returns to monitor mode (also after an error) and sets `done`, so a
    /// recorder following the drive ends with it.
    pub(crate) async fn drive_passes(
        &self,
        targets: &[[f64; 7]],
        duration_s: Option<f64>,
        workflow: Workflow,
        events: &EventSink,
        done: watch::Sender<bool>,
    ) -> Result<(), OperatorError> {
        let started_at = self.latest().map(|s| s.robot.time_s);
        let outcome = async {
            let started_at = started_at?;
            let mut pass = 0;
            loop {
                for (k, target) in targets.iter().enumerate() {
                    events
                        .event(&Event::Progress(Progress {
                            phase: Phase::Moving,
                            step: Some(pass * targets.len() + k + 1),
                            of: Some(targets.len()),
                            workflow: Some(workflow),
                            pose: Some(*target),
                            settle_s: None,
                            max_speed: None,
                        }))
                        .await;
                    self.move_to(*target, None).await?;
                }
                pass += 1;
                let elapsed = self
                    .shared
                    .latest()
                    .map_or(0.0, |s| s.robot.time_s - started_at);
                if duration_s.is_none_or(|d| elapsed >= d) {
                    return Ok(());
                }
            }
        }
        .await;
        self.release();
        let _ = done.send(true);
        outcome
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_target_stays_inside_the_limits_less_the_margin_and_the_pass_ends_at_the_start() {
        let model = dynamics::lwr4();
        let limits = *model.limits();
        let margin = fri_api::bounds::AROUND_LIMIT_MARGIN_RAD;
        // One start near the upper limits, one at zero.
        let near: [f64; 7] = std::array::from_fn(|j| limits.position_max[j] - 0.1);
        for start in [[0.0; 7], near] {
            let targets = identification_targets(&model, &start, 45f64.to_radians());
            assert_eq!(targets.len(), IDENTIFICATION_WAYPOINTS + 1);
            assert_eq!(targets.last(), Some(&start));
            for t in &targets {
                for (j, q) in t.iter().enumerate() {
                    assert!(
                        *q >= limits.position_min[j] + margin - 1e-12
                            && *q <= limits.position_max[j] - margin + 1e-12,
                        "joint {} at {q} outside the limits less the margin",
                        j + 1,
                    );
                }
            }
        }
    }

    #[test]
    fn the_joints_follow_orthogonal_patterns_of_the_full_amplitude() {
        let model = dynamics::lwr4();
        let start = [0.0, 0.5, 0.0, -1.0, 0.0, 0.5, 0.0];
        let amplitude = 10f64.to_radians();
        let targets = identification_targets(&model, &start, amplitude);
        let offsets: Vec<[f64; 7]> = targets[..IDENTIFICATION_WAYPOINTS]
            .iter()
            .map(|t| std::array::from_fn(|j| t[j] - start[j]))
            .collect();
        for a in 0..7 {
            let peak = offsets.iter().map(|o| o[a].abs()).fold(0.0, f64::max);
            assert!((peak - amplitude).abs() < 1e-12, "joint {}: {peak}", a + 1);
            for b in (a + 1)..7 {
                let dot: f64 = offsets.iter().map(|o| o[a] * o[b]).sum();
                assert!(
                    dot.abs() < 1e-9,
                    "joints {} and {} not orthogonal",
                    a + 1,
                    b + 1
                );
            }
        }
    }
}
