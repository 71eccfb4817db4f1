//! KRL-side motion script: what the KRL program moves in monitor mode (PTP moves to static poses
//! with dwell times, joint sinusoid/chirp sweeps such as the paper's q_A, q_B, q_C).
//!
//! The script runs on its own clock, which pauses while the remote commands the arm (CMD); on the
//! return to MON the KRL moves PTP from where the remote left the arm back to the paused script
//! point before the script continues, so the set-point never jumps.

mod limits;
mod primitive;
mod segment;

pub use limits::{POSITION_LIMITS_RAD, VELOCITY_LIMITS_RAD_S};
pub use primitive::{SetPoint, ptp_duration};
pub use segment::{DEFAULT_SWEEP_RAMP_S, MotionSegment};

use crate::joints::JOINTS;
use crate::joints::JointVector;
use primitive::{Primitive, last_peak_time};

fn deg(v: &[f64; JOINTS]) -> JointVector {
    JointVector::from_fn(|i, _| v[i].to_radians())
}

/// Default PTP speed as a fraction of the joint velocity limits.
pub const DEFAULT_SPEED_FRACTION: f64 = 0.3;

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
