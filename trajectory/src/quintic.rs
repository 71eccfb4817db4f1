//! The quintic rest-to-rest profile s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ on τ ∈ [0, 1] (minimum jerk:
//! position, velocity and acceleration continuous; velocity and acceleration zero at both ends).
//!
//! Over a move of duration T and displacement Δ its peaks are |q̇| = (15/8)·Δ/T,
//! |q̈| = (10/√3)·Δ/T² (at τ = 1/2 ∓ √3/6) and |q⃛| = 60·Δ/T³ (at τ = 0 and 1).

use nalgebra::SVector;

/// Peak |ds/dτ| of the quintic profile (dimensionless).
pub const PEAK_VELOCITY: f64 = 15.0 / 8.0;
/// Peak |d²s/dτ²| of the quintic profile, 10/√3 (dimensionless).
pub const PEAK_ACCELERATION: f64 = 5.773_502_691_896_258;
/// Peak |d³s/dτ³| of the quintic profile (dimensionless).
pub const PEAK_JERK: f64 = 60.0;

/// (s, ds/dτ, d²s/dτ²) of the quintic at τ (dimensionless), τ clamped to [0, 1]; s(1) = 1 exactly.
pub fn quintic(tau: f64) -> (f64, f64, f64) {
    let t = tau.clamp(0.0, 1.0);
    let (t2, t3) = (t * t, t * t * t);
    (
        t3 * (10.0 - 15.0 * t + 6.0 * t2),
        30.0 * t2 * (1.0 - 2.0 * t + t2),
        60.0 * t * (1.0 - 3.0 * t + 2.0 * t2),
    )
}

/// Shortest duration, s, of a quintic over `distance` (rad, ≥ 0) that keeps its peak velocity
/// within `max_velocity` (rad/s) and its peak acceleration within `max_acceleration` (rad/s²).
pub fn rest_to_rest_duration(distance: f64, max_velocity: f64, max_acceleration: f64) -> f64 {
    (PEAK_VELOCITY * distance / max_velocity)
        .max((PEAK_ACCELERATION * distance / max_acceleration).sqrt())
}

/// The state of a joint-space set-point at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointSetpoint<const N: usize> {
    /// Position, rad.
    pub position: SVector<f64, N>,
    /// Velocity, rad/s.
    pub velocity: SVector<f64, N>,
    /// Acceleration, rad/s².
    pub acceleration: SVector<f64, N>,
}

impl<const N: usize> JointSetpoint<N> {
    /// At rest at `position` (rad).
    pub fn rest(position: SVector<f64, N>) -> Self {
        Self {
            position,
            velocity: SVector::zeros(),
            acceleration: SVector::zeros(),
        }
    }
}

/// A synchronous quintic move on a straight joint-space line, `from` → `to` (rad) over
/// `duration` (s), all joints starting and ending together at rest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuinticSegment<const N: usize> {
    /// Start position, rad.
    pub from: SVector<f64, N>,
    /// End position, rad.
    pub to: SVector<f64, N>,
    /// Move time, s (a non-positive duration is a jump to `to`).
    pub duration: f64,
}

impl<const N: usize> QuinticSegment<N> {
    /// Set-point at `t` (s since the segment started); at rest at the ends outside [0, duration].
    pub fn sample(&self, t: f64) -> JointSetpoint<N> {
        if self.duration <= 0.0 {
            return JointSetpoint::rest(self.to);
        }
        let (s, ds, dds) = quintic(t / self.duration);
        let delta = self.to - self.from;
        JointSetpoint {
            position: self.from + delta * s,
            velocity: delta * (ds / self.duration),
            acceleration: delta * (dds / (self.duration * self.duration)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ends_exactly_and_peaks_match_the_constants() {
        assert_eq!(quintic(0.0), (0.0, 0.0, 0.0));
        assert_eq!(quintic(1.0), (1.0, 0.0, 0.0));
        assert_eq!(quintic(2.0), (1.0, 0.0, 0.0));
        let (_, v, _) = quintic(0.5);
        assert!((v - PEAK_VELOCITY).abs() < 1e-15);
        let (_, _, a) = quintic(0.5 - 3f64.sqrt() / 6.0);
        assert!((a - PEAK_ACCELERATION).abs() < 1e-12);
        assert!((PEAK_ACCELERATION - 10.0 / 3f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn derivatives_are_consistent() {
        let h = 1e-6;
        for k in 1..100 {
            let tau = k as f64 / 100.0;
            let (a, b, m) = (quintic(tau - h), quintic(tau + h), quintic(tau));
            assert!(((b.0 - a.0) / (2.0 * h) - m.1).abs() < 1e-6);
            assert!(((b.1 - a.1) / (2.0 * h) - m.2).abs() < 1e-5);
        }
    }

    #[test]
    fn segment_respects_the_duration_limits() {
        let from = SVector::<f64, 2>::new(0.0, 1.0);
        let to = SVector::<f64, 2>::new(0.5, 0.2);
        let d = rest_to_rest_duration((to - from).amax(), 0.4, 1.0);
        let seg = QuinticSegment {
            from,
            to,
            duration: d,
        };
        let (mut v, mut a) = (0.0f64, 0.0f64);
        for k in 0..=2000 {
            let sp = seg.sample(d * k as f64 / 2000.0);
            v = v.max(sp.velocity.amax());
            a = a.max(sp.acceleration.amax());
        }
        assert!(v <= 0.4 + 1e-9 && a <= 1.0 + 1e-9, "{v} {a}");
        let end = seg.sample(d + 1.0);
        assert!((end.position - to).amax() < 1e-15);
        assert_eq!(end.velocity, SVector::<f64, 2>::zeros());
        assert_eq!(seg.sample(-1.0).position, from);
    }
}
