//! The primitives a motion script compiles to: quintic PTP moves, holds and chirp sweeps, each
//! sampled as a set-point at a time since its start.

use trajectory::{QuinticSegment, quintic, rest_to_rest_duration};

use super::limits::VELOCITY_LIMITS_RAD_S;
use crate::joints::JOINTS;
use crate::joints::JointVector;

/// Set-point sample: position (rad), velocity (rad/s), acceleration (rad/s²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SetPoint {
    /// Joint angles, rad.
    pub q: JointVector,
    /// Joint velocities, rad/s.
    pub qd: JointVector,
    /// Joint accelerations, rad/s².
    pub qdd: JointVector,
}

impl SetPoint {
    /// At rest at `q`.
    pub fn rest(q: JointVector) -> Self {
        Self {
            q,
            qd: JointVector::zeros(),
            qdd: JointVector::zeros(),
        }
    }
}

/// Time of the last peak of sin φ(t) (φ = π/2 + kπ) in [0, duration] for a linear chirp from
/// `f0` to `f1` Hz over `duration` s; `duration` itself when there is no peak.
pub(super) fn last_peak_time(f0: f64, f1: f64, duration: f64) -> f64 {
    let cycles_at_end = duration * (f0 + f1) / 2.0; // φ(D) / 2π
    let k = ((2.0 * cycles_at_end - 0.5).floor()).max(-1.0);
    if k < 0.0 {
        return duration;
    }
    let target = (0.5 + k) / 2.0; // φ_e / 2π
    let a = (f1 - f0) / (2.0 * duration);
    let t = if a.abs() < 1e-12 {
        if f0 > 0.0 { target / f0 } else { duration }
    } else {
        (-f0 + (f0 * f0 + 4.0 * a * target).max(0.0).sqrt()) / (2.0 * a)
    };
    if t.is_finite() && t > 0.0 {
        t.min(duration)
    } else {
        duration
    }
}

/// Move time of a synchronous quintic PTP from `from` to `to` at `speed_fraction` of the limits
/// (peak acceleration limited to 2 s⁻¹ × velocity limit), s.
pub fn ptp_duration(from: &JointVector, to: &JointVector, speed_fraction: f64) -> f64 {
    let mut t: f64 = 0.2;
    for i in 0..JOINTS {
        let v = VELOCITY_LIMITS_RAD_S[i] * speed_fraction;
        t = t.max(rest_to_rest_duration((to[i] - from[i]).abs(), v, 2.0 * v));
    }
    t
}

/// One compiled piece of a motion script.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Primitive {
    /// Quintic rest-to-rest move.
    Move {
        from: JointVector,
        to: JointVector,
        duration: f64,
    },
    /// Rest at `q`.
    Hold { q: JointVector, duration: f64 },
    /// `duration` is the nominal sweep length (sets the frequency slope), `end` the time of the
    /// last peak of sin φ before it, where the primitive ends.
    Chirp {
        base: JointVector,
        joint: usize,
        amplitude: f64,
        f0: f64,
        f1: f64,
        duration: f64,
        ramp: f64,
        end: f64,
    },
}

impl Primitive {
    /// Length, s.
    pub(super) fn duration(&self) -> f64 {
        match self {
            Self::Move { duration, .. } | Self::Hold { duration, .. } => *duration,
            Self::Chirp { end, .. } => *end,
        }
    }

    /// The set-point `t` s after the start.
    pub(super) fn sample(&self, t: f64) -> SetPoint {
        match self {
            Self::Move { from, to, duration } => {
                let sp = QuinticSegment {
                    from: *from,
                    to: *to,
                    duration: *duration,
                }
                .sample(t);
                SetPoint {
                    q: sp.position,
                    qd: sp.velocity,
                    qdd: sp.acceleration,
                }
            }
            Self::Hold { q, .. } => SetPoint::rest(*q),
            Self::Chirp {
                base,
                joint,
                amplitude,
                f0,
                f1,
                duration,
                ramp,
                ..
            } => {
                let t = t.clamp(0.0, *duration);
                let two_pi = std::f64::consts::TAU;
                let phi = two_pi * (f0 * t + (f1 - f0) * t * t / (2.0 * duration));
                let dphi = two_pi * (f0 + (f1 - f0) * t / duration);
                let ddphi = two_pi * (f1 - f0) / duration;
                // Envelope only at the start (low frequency); the sweep ends at a peak of
                // sin φ, where the velocity is zero, so the next PTP starts smoothly.
                let (w, dw, ddw) = if *ramp > 0.0 && t < *ramp {
                    let (s, ds, dds) = quintic(t / ramp);
                    (s, ds / ramp, dds / (ramp * ramp))
                } else {
                    (1.0, 0.0, 0.0)
                };
                let (sin, cos) = phi.sin_cos();
                let mut sp = SetPoint::rest(*base);
                sp.q[*joint] += amplitude * w * sin;
                sp.qd[*joint] = amplitude * (dw * sin + w * cos * dphi);
                sp.qdd[*joint] = amplitude
                    * (ddw * sin + 2.0 * dw * cos * dphi - w * sin * dphi * dphi + w * cos * ddphi);
                sp
            }
        }
    }

    /// Where the primitive ends, rad.
    pub(super) fn end(&self) -> JointVector {
        self.sample(self.duration()).q
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ptp_respects_speed_fraction() {
        let from = JointVector::zeros();
        let to = JointVector::from_element(1.0);
        let t = ptp_duration(&from, &to, 0.3);
        let m = Primitive::Move {
            from,
            to,
            duration: t,
        };
        let mut peak: f64 = 0.0;
        for k in 0..=1000 {
            let sp = m.sample(t * k as f64 / 1000.0);
            for (i, v_max) in VELOCITY_LIMITS_RAD_S.iter().enumerate() {
                peak = peak.max(sp.qd[i].abs() / v_max);
            }
        }
        assert!(peak <= 0.3 + 1e-9 && peak > 0.2, "peak share {peak}");
    }

    #[test]
    fn chirp_derivatives_are_consistent() {
        let c = Primitive::Chirp {
            base: JointVector::zeros(),
            joint: 0,
            amplitude: 1.1636,
            f0: 0.05,
            f1: 0.2387,
            duration: 15.0,
            ramp: 2.0,
            end: last_peak_time(0.05, 0.2387, 15.0),
        };
        let end = c.duration();
        assert!(end > 12.5 && end <= 15.0);
        assert!(c.sample(end).qd[0].abs() < 1e-9);
        let h = 1e-5;
        let mut peak_v: f64 = 0.0;
        let mut peak_a: f64 = 0.0;
        for k in 1..1400 {
            let t = k as f64 * 0.01 + 0.005;
            let (a, b, m) = (c.sample(t - h), c.sample(t + h), c.sample(t));
            assert!(((b.q[0] - a.q[0]) / (2.0 * h) - m.qd[0]).abs() < 1e-6);
            let fd = (b.qd[0] - a.qd[0]) / (2.0 * h);
            assert!(
                (fd - m.qdd[0]).abs() < 1e-5,
                "t {t}: fd {fd} vs {}",
                m.qdd[0]
            );
            peak_v = peak_v.max(m.qd[0].abs());
            peak_a = peak_a.max(m.qdd[0].abs());
        }
        // The paper's q_A sweep: bounded by A·2πf1 ≈ 100 deg/s and A·(2πf1)² ≈ 150 deg/s².
        let (v, a) = (peak_v.to_degrees(), peak_a.to_degrees());
        assert!(v > 85.0 && v <= 100.5, "peak velocity {v} deg/s");
        assert!(a > 110.0 && a <= 152.0, "peak acceleration {a} deg/s²");
    }
}
