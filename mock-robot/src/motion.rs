//! KRL-side motion script: what the KRL program moves in monitor mode (PTP moves to static poses
//! with dwell times, joint sinusoid/chirp sweeps such as the paper's q_A, q_B, q_C).
//!
//! The script runs on its own clock, which pauses while the remote commands the arm (CMD); on the
//! return to MON the KRL moves PTP from where the remote left the arm back to the paused script
//! point before the script continues, so the set-point never jumps.

use serde::{Deserialize, Serialize};

use trajectory::{QuinticSegment, quintic, rest_to_rest_duration};

use crate::config::JOINTS;
use crate::error::{SimError, ensure};
use crate::sensors::JointVector;

/// Joint velocity limits of the LWR 4+, rad/s (from `dynamics`' lwr4-model.md §1.2 table).
pub const VELOCITY_LIMITS_RAD_S: [f64; JOINTS] =
    dynamics::degrees_to_radians(dynamics::LWR4_VELOCITY_LIMITS_DEG_S);

/// Joint position limits of the LWR 4+, ± rad (from `dynamics`' lwr4-model.md §1.2 table).
pub const POSITION_LIMITS_RAD: [f64; JOINTS] =
    dynamics::degrees_to_radians(dynamics::LWR4_POSITION_LIMITS_DEG);

/// Default PTP speed as a fraction of the joint velocity limits.
pub const DEFAULT_SPEED_FRACTION: f64 = 0.3;

/// One segment of a KRL motion script (TOML: `[[motion]]` with `kind = ...`; angles in deg).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum MotionSegment {
    /// Point-to-point move (quintic, synchronous joints) to `q_deg`.
    Ptp {
        /// Target joint angles, deg.
        q_deg: [f64; JOINTS],
        /// Move time, s; `None` = from `speed_fraction` of the velocity limits.
        duration_s: Option<f64>,
        /// Share of the joint velocity limits (0..=1]; default 0.3.
        speed_fraction: Option<f64>,
    },
    /// Hold the current pose, s.
    Dwell {
        /// Hold time, s.
        duration_s: f64,
    },
    /// A list of static poses, each reached PTP and held for `dwell_s`.
    Poses {
        /// Joint angles of each pose, deg.
        poses_deg: Vec<[f64; JOINTS]>,
        /// Hold time at each pose, s.
        dwell_s: f64,
        /// Share of the joint velocity limits; default 0.3.
        speed_fraction: Option<f64>,
    },
    /// Chirp on one joint around `center_deg`: q_j = c_j + A·w(t)·sin φ(t), φ' = 2π f(t) with f
    /// linear from `f_start_hz` to `f_end_hz`; w ramps in over `ramp_s`.
    Sweep {
        /// Swept joint, 1..=7.
        joint: usize,
        /// Centre pose, deg (reached PTP first).
        center_deg: [f64; JOINTS],
        /// Amplitude A, deg.
        amplitude_deg: f64,
        /// Start frequency, Hz.
        f_start_hz: f64,
        /// End frequency, Hz.
        f_end_hz: f64,
        /// Sweep length, s.
        duration_s: f64,
        /// Envelope ramp length at the start, s (default 2); the sweep ends at the last peak of
        /// sin φ before `duration_s`, with zero velocity.
        ramp_s: Option<f64>,
    },
}

fn deg(v: &[f64; JOINTS]) -> JointVector {
    JointVector::from_fn(|i, _| v[i].to_radians())
}

impl MotionSegment {
    pub(crate) fn validate(&self) -> Result<(), SimError> {
        let in_limits = |q: &[f64; JOINTS]| {
            q.iter()
                .enumerate()
                .all(|(i, d)| d.is_finite() && d.to_radians().abs() <= POSITION_LIMITS_RAD[i])
        };
        let speed_ok = |s: &Option<f64>| s.is_none_or(|s| s.is_finite() && s > 0.0 && s <= 1.0);
        let ok = match self {
            Self::Ptp {
                q_deg,
                duration_s,
                speed_fraction,
            } => {
                in_limits(q_deg)
                    && duration_s.is_none_or(|d| d.is_finite() && d > 0.0)
                    && speed_ok(speed_fraction)
            }
            Self::Dwell { duration_s } => duration_s.is_finite() && *duration_s >= 0.0,
            Self::Poses {
                poses_deg,
                dwell_s,
                speed_fraction,
            } => {
                poses_deg.iter().all(in_limits)
                    && dwell_s.is_finite()
                    && *dwell_s >= 0.0
                    && speed_ok(speed_fraction)
            }
            Self::Sweep {
                joint,
                center_deg,
                amplitude_deg,
                f_start_hz,
                f_end_hz,
                duration_s,
                ramp_s,
            } => {
                let j = joint.wrapping_sub(1);
                (1..=JOINTS).contains(joint)
                    && in_limits(center_deg)
                    && amplitude_deg.is_finite()
                    && (center_deg[j].abs() + amplitude_deg.abs()).to_radians()
                        <= POSITION_LIMITS_RAD[j]
                    && f_start_hz.is_finite()
                    && f_end_hz.is_finite()
                    && *f_start_hz >= 0.0
                    && *f_end_hz >= 0.0
                    && duration_s.is_finite()
                    && *duration_s > 0.0
                    && ramp_s.is_none_or(|r| r.is_finite() && r >= 0.0 && 2.0 * r <= *duration_s)
            }
        };
        ensure(ok, || {
            format!(
                "motion segment out of range (joint limits ±170/120 deg, positive times): {self:?}"
            )
        })
    }
}

/// Default length of the sweep's start envelope, s.
pub const DEFAULT_SWEEP_RAMP_S: f64 = 2.0;

/// Time of the last peak of sin φ(t) (φ = π/2 + kπ) in [0, duration] for a linear chirp from
/// `f0` to `f1` Hz over `duration` s; `duration` itself when there is no peak.
fn last_peak_time(f0: f64, f1: f64, duration: f64) -> f64 {
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

#[derive(Debug, Clone, PartialEq)]
enum Primitive {
    Move {
        from: JointVector,
        to: JointVector,
        duration: f64,
    },
    Hold {
        q: JointVector,
        duration: f64,
    },
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
    fn duration(&self) -> f64 {
        match self {
            Self::Move { duration, .. } | Self::Hold { duration, .. } => *duration,
            Self::Chirp { end, .. } => *end,
        }
    }

    fn sample(&self, t: f64) -> SetPoint {
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

    fn end(&self) -> JointVector {
        self.sample(self.duration()).q
    }
}

/// Plays a motion script; the set-point source of the KRL program in monitor mode.
#[derive(Debug, Clone)]
pub struct MotionPlayer {
    primitives: Vec<Primitive>,
    index: usize,
    local_t: f64,
    paused: bool,
    blend: Option<(Primitive, f64)>,
    rest: JointVector,
}

impl MotionPlayer {
    /// Compiles `segments` starting at rest at `initial_q` (rad).
    pub fn new(segments: &[MotionSegment], initial_q: JointVector) -> Self {
        let mut primitives = Vec::new();
        let mut at = initial_q;
        let ptp = |primitives: &mut Vec<Primitive>,
                   at: &mut JointVector,
                   to: JointVector,
                   duration: Option<f64>,
                   speed: Option<f64>| {
            let duration = duration
                .unwrap_or_else(|| ptp_duration(at, &to, speed.unwrap_or(DEFAULT_SPEED_FRACTION)));
            primitives.push(Primitive::Move {
                from: *at,
                to,
                duration,
            });
            *at = to;
        };
        for segment in segments {
            match segment {
                MotionSegment::Ptp {
                    q_deg,
                    duration_s,
                    speed_fraction,
                } => {
                    ptp(
                        &mut primitives,
                        &mut at,
                        deg(q_deg),
                        *duration_s,
                        *speed_fraction,
                    );
                }
                MotionSegment::Dwell { duration_s } => primitives.push(Primitive::Hold {
                    q: at,
                    duration: *duration_s,
                }),
                MotionSegment::Poses {
                    poses_deg,
                    dwell_s,
                    speed_fraction,
                } => {
                    for pose in poses_deg {
                        ptp(&mut primitives, &mut at, deg(pose), None, *speed_fraction);
                        primitives.push(Primitive::Hold {
                            q: at,
                            duration: *dwell_s,
                        });
                    }
                }
                MotionSegment::Sweep {
                    joint,
                    center_deg,
                    amplitude_deg,
                    f_start_hz,
                    f_end_hz,
                    duration_s,
                    ramp_s,
                } => {
                    ptp(&mut primitives, &mut at, deg(center_deg), None, None);
                    let chirp = Primitive::Chirp {
                        base: at,
                        joint: joint.saturating_sub(1).min(JOINTS - 1),
                        amplitude: amplitude_deg.to_radians(),
                        f0: *f_start_hz,
                        f1: *f_end_hz,
                        duration: *duration_s,
                        ramp: ramp_s.unwrap_or(DEFAULT_SWEEP_RAMP_S).min(0.5 * duration_s),
                        end: last_peak_time(*f_start_hz, *f_end_hz, *duration_s),
                    };
                    at = chirp.end();
                    primitives.push(chirp);
                }
            }
        }
        Self {
            primitives,
            index: 0,
            local_t: 0.0,
            paused: false,
            blend: None,
            rest: at,
        }
    }

    /// Total script time without pauses, s.
    pub fn total_duration_s(&self) -> f64 {
        self.primitives.iter().map(Primitive::duration).sum()
    }

    /// Whether the script has no segments.
    pub fn is_empty(&self) -> bool {
        self.primitives.is_empty()
    }

    /// Whether every segment has been played.
    pub fn is_finished(&self) -> bool {
        self.index >= self.primitives.len() && self.blend.is_none()
    }

    /// Current set-point.
    pub fn sample(&self) -> SetPoint {
        if let Some((blend, t)) = &self.blend {
            return blend.sample(*t);
        }
        match self.primitives.get(self.index) {
            Some(p) => p.sample(self.local_t),
            None => SetPoint::rest(self.rest),
        }
    }

    /// Advances the script clock by `dt` seconds (no effect while paused).
    pub fn advance(&mut self, dt: f64) {
        if self.paused {
            return;
        }
        if let Some((blend, t)) = &mut self.blend {
            *t += dt;
            if *t >= blend.duration() {
                self.blend = None;
            }
            return;
        }
        self.local_t += dt;
        while let Some(p) = self.primitives.get(self.index) {
            if self.local_t < p.duration() {
                break;
            }
            self.local_t -= p.duration();
            self.index += 1;
        }
        if self.index >= self.primitives.len() {
            self.local_t = 0.0;
        }
    }

    /// Pauses the script (the remote takes over).
    pub fn pause(&mut self) {
        self.paused = true;
    }

    /// Resumes after a pause with the arm's set-point at `q_now` (rad): PTP back to the paused
    /// script point, then continue.
    pub fn resume_from(&mut self, q_now: JointVector) {
        if !self.paused {
            return;
        }
        self.paused = false;
        let target = self.sample().q;
        if (target - q_now).amax() < 1e-9 {
            return;
        }
        if self.is_finished() {
            // Nothing left to play: the KRL program holds where the remote left the arm.
            self.rest = q_now;
            return;
        }
        let duration = ptp_duration(&q_now, &target, DEFAULT_SPEED_FRACTION);
        self.blend = Some((
            Primitive::Move {
                from: q_now,
                to: target,
                duration,
            },
            0.0,
        ));
    }

    /// Whether the script is paused.
    pub fn is_paused(&self) -> bool {
        self.paused
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(v: [f64; JOINTS]) -> [f64; JOINTS] {
        v
    }

    #[test]
    fn poses_are_reached_and_held() {
        let segs = vec![MotionSegment::Poses {
            poses_deg: vec![
                pose([10.0, 20.0, 0.0, -30.0, 0.0, 40.0, 0.0]),
                pose([0.0; JOINTS]),
            ],
            dwell_s: 1.0,
            speed_fraction: None,
        }];
        let mut p = MotionPlayer::new(&segs, JointVector::zeros());
        let first = p.primitives[0].duration();
        p.advance(first + 0.5);
        let sp = p.sample();
        assert!((sp.q[1] - 20f64.to_radians()).abs() < 1e-12);
        assert_eq!(sp.qd, JointVector::zeros());
        p.advance(100.0);
        assert!(p.is_finished());
        assert!(p.sample().q.amax() < 1e-12);
    }

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

    #[test]
    fn pause_and_resume_blends_back_without_jump() {
        let segs = vec![MotionSegment::Ptp {
            q_deg: [30.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            duration_s: Some(2.0),
            speed_fraction: None,
        }];
        let mut p = MotionPlayer::new(&segs, JointVector::zeros());
        p.advance(1.0);
        let paused_at = p.sample().q;
        p.pause();
        p.advance(5.0);
        assert_eq!(p.sample().q, paused_at);
        let q_now = paused_at + JointVector::from_element(0.05);
        p.resume_from(q_now);
        assert!((p.sample().q - q_now).amax() < 1e-12);
        p.advance(10.0);
        p.advance(10.0);
        assert!(p.is_finished());
        assert!((p.sample().q[0] - 30f64.to_radians()).abs() < 1e-12);
    }
}
