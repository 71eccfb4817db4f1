//! What the loop tells the monitor's unknown-payload view each cycle: whether the arm is being
//! moved and the move's peak acceleration (the inertia allowance is derived from it), and which
//! residual a detected contact is reported with.

use super::*;
use trajectory::quintic::PEAK_ACCELERATION;

/// Peak acceleration vector of a move, rad/s²: its line Δ times the largest |s̈| its path can
/// take. A planned quintic of duration T peaks at 10/√3 / T²; a brake (operator stop, reaction)
/// stays within the motion limits along the line, min_j a_max_j / |Δ_j|.
pub(super) fn peak_acceleration(
    start: &V7,
    target: &V7,
    duration_s: f64,
    braking: bool,
    limits: &trajectory::MotionLimits<7>,
) -> V7 {
    let delta = target - start;
    let along = (0..7)
        .filter(|&j| delta[j] != 0.0)
        .map(|j| limits.acceleration[j] / delta[j].abs())
        .fold(f64::INFINITY, f64::min);
    if !along.is_finite() {
        return V7::zeros();
    }
    let planned = if duration_s > 0.0 {
        PEAK_ACCELERATION / (duration_s * duration_s)
    } else {
        along
    };
    delta * if braking { along } else { planned.min(along) }
}

impl CycleProcessor {
    /// Hands the monitor's unknown-payload view this cycle's motion: a running move's peak
    /// acceleration, kept after the move until the arm is at rest (it lags its set-point and
    /// rings): [`REST_CYCLES`] live cycles in a row under [`REST_SPEED`]. The velocity of a
    /// monitor that has just restarted (a host gap) starts from zero whatever the arm does, so
    /// it never ends the allowance.
    pub(super) fn follow_motion_for_tolerance(&mut self) {
        if let Some((m, _, target)) = &self.motion {
            let start = m.sample(0.0).position;
            let duration = if m.is_braking() { 0.0 } else { m.end_time() };
            self.move_peak = peak_acceleration(
                &start,
                target,
                duration,
                m.is_braking(),
                &self.settings.limits,
            );
            self.settling_after_move = true;
        } else if self.settling_after_move && self.quiet_cycles >= REST_CYCLES {
            self.settling_after_move = false;
            self.move_peak = V7::zeros();
        }
        self.tolerance
            .set_motion(self.settling_after_move, &self.move_peak);
    }

    /// Hands a change of the unknown-payload mode (declared, pinned, ended, expired) to the
    /// non-real-time side, once per cycle with the mode as it stands after the cycle.
    pub(super) fn report_unknown_payload(&mut self) {
        if !self.tolerance.take_changed() {
            return;
        }
        let view = match (self.tolerance.status(), self.tolerance.last_end()) {
            (Some(status), _) => UnknownPayloadView::Active(status),
            (None, Some((declaration, reason))) => UnknownPayloadView::Ended {
                declaration,
                reason,
            },
            (None, None) => return,
        };
        self.emit(CycleEvent::UnknownPayload {
            cycle: self.cycle,
            view,
        });
    }

    /// The residual a detected contact is reported with, Nm: while the payload is unknown the
    /// part the load does not explain (the detector saw it less the inertia allowance),
    /// otherwise the detector's own.
    pub(super) fn reported_residual(&self, detected: &V7) -> V7 {
        if self.tolerance.is_active() {
            *self.tolerance.unexplained()
        } else {
            *detected
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use trajectory::MotionLimits;

    #[test]
    fn a_planned_move_peaks_at_its_quintic_and_a_brake_at_the_limits_along_its_line() {
        let limits = MotionLimits {
            velocity: V7::repeat(0.18),
            acceleration: V7::repeat(1.0),
            jerk: V7::repeat(5.0),
        };
        let start = V7::zeros();
        let mut target = V7::zeros();
        target[1] = 0.24;
        target[3] = -0.12;
        let m = JointMove::new(start, target, limits).unwrap();
        let planned = peak_acceleration(&start, &target, m.end_time(), false, &limits);
        // The largest acceleration the set-point takes over the move.
        let sampled = (0..=1000)
            .map(|i| m.sample(m.end_time() * f64::from(i) / 1000.0).acceleration[1].abs())
            .fold(0.0, f64::max);
        assert!(
            (planned[1] - sampled).abs() < 1e-3 * sampled,
            "{planned} vs {sampled}"
        );
        assert!((planned[3] + 0.5 * planned[1]).abs() < 1e-12);
        let brake = peak_acceleration(&start, &target, 0.0, true, &limits);
        assert!((brake[1] - 1.0).abs() < 1e-12 && (brake[3] + 0.5).abs() < 1e-12);
        assert_eq!(
            peak_acceleration(&start, &start, 1.0, false, &limits),
            V7::zeros()
        );
    }
}
