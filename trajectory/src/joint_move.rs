//! Jerk-limited straight-line joint moves with a stop (the moves the service commands itself).
//!
//! A move is a straight line in joint space, q(t) = q₀ + s(t)·Δ, with the path parameter s
//! following a quintic rest-to-rest profile s(τ) = 10τ³ − 15τ⁴ + 6τ⁵, τ = t/T. Its peaks are
//! |ṡ| ≤ 15/(8T), |s̈| ≤ 10/(√3 T²), |s⃛| ≤ 60/T³, so the duration T is the smallest one that keeps
//! every joint within its velocity, acceleration and jerk limits. Position, velocity and
//! acceleration are continuous, velocity and acceleration are zero at both ends, and s(T) = 1
//! exactly, so the move lands exactly on the target.
//!
//! A stop during a move replaces the remaining profile by a quartic brake on s from the current
//! (s, ṡ, s̈) to rest, whose duration is the shortest (found by bisection) that keeps the same
//! limits; the arm then holds where the brake ends, still on the line.
//!
//! Everything here is allocation-free and evaluated once per cycle on the real-time thread.

use nalgebra::SVector;

use crate::quintic::{JointSetpoint, PEAK_ACCELERATION, PEAK_JERK, PEAK_VELOCITY, quintic};

/// Per-joint motion limits (all strictly positive).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionLimits<const N: usize> {
    /// Maximum |q̇|, rad/s.
    pub velocity: SVector<f64, N>,
    /// Maximum |q̈|, rad/s².
    pub acceleration: SVector<f64, N>,
    /// Maximum |q⃛|, rad/s³.
    pub jerk: SVector<f64, N>,
}

/// Errors creating a move.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MotionError {
    /// A start, target or limit value is NaN or infinite.
    #[error("non-finite value in {0}")]
    NonFinite(&'static str),
    /// A limit is zero or negative.
    #[error("limit {0} must be positive")]
    NonPositiveLimit(&'static str),
}

/// Scalar profile of the path parameter s(t).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Profile {
    /// Quintic rest-to-rest from s = 0 to s = 1 over `duration`.
    Quintic { duration: f64 },
    /// Brake from (s0, v0, a0) at `t0`: first `kill_s` of constant jerk `kill_jerk` that takes
    /// a positive acceleration to zero, then a quartic to rest over `duration`.
    Brake {
        t0: f64,
        s0: f64,
        v0: f64,
        a0: f64,
        kill_jerk: f64,
        kill_s: f64,
        c3: f64,
        c4: f64,
        duration: f64,
    },
}

/// A jerk-limited straight-line joint move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointMove<const N: usize> {
    start: SVector<f64, N>,
    delta: SVector<f64, N>,
    limits: MotionLimits<N>,
    profile: Profile,
}

fn all_finite<const N: usize>(v: &SVector<f64, N>) -> bool {
    v.iter().all(|x| x.is_finite())
}

impl<const N: usize> MotionLimits<N> {
    fn validate(&self) -> Result<(), MotionError> {
        for (name, v) in [
            ("velocity", &self.velocity),
            ("acceleration", &self.acceleration),
            ("jerk", &self.jerk),
        ] {
            if !all_finite(v) {
                return Err(MotionError::NonFinite(name));
            }
            if v.iter().any(|x| *x <= 0.0) {
                return Err(MotionError::NonPositiveLimit(name));
            }
        }
        Ok(())
    }

    /// Limits on the path parameter s for a line with joint displacement `delta`:
    /// (ṡ_max, s̈_max, s⃛_max); infinite when no joint moves.
    fn along(&self, delta: &SVector<f64, N>) -> (f64, f64, f64) {
        let mut lim = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
        for i in 0..N {
            let d = delta[i].abs();
            if d > 0.0 {
                lim.0 = lim.0.min(self.velocity[i] / d);
                lim.1 = lim.1.min(self.acceleration[i] / d);
                lim.2 = lim.2.min(self.jerk[i] / d);
            }
        }
        lim
    }
}

impl<const N: usize> JointMove<N> {
    /// Plans the fastest quintic move from `start` to `target` (both at rest) within `limits`.
    pub fn new(
        start: SVector<f64, N>,
        target: SVector<f64, N>,
        limits: MotionLimits<N>,
    ) -> Result<Self, MotionError> {
        if !all_finite(&start) {
            return Err(MotionError::NonFinite("start"));
        }
        if !all_finite(&target) {
            return Err(MotionError::NonFinite("target"));
        }
        limits.validate()?;
        let delta = target - start;
        let (vs, as_, js) = limits.along(&delta);
        let duration = (PEAK_VELOCITY / vs)
            .max((PEAK_ACCELERATION / as_).sqrt())
            .max((PEAK_JERK / js).cbrt());
        Ok(Self {
            start,
            delta,
            limits,
            profile: Profile::Quintic { duration },
        })
    }

    /// Time at which the set-point comes to rest (end of the move or of the brake), s.
    pub fn end_time(&self) -> f64 {
        match self.profile {
            Profile::Quintic { duration } => duration,
            Profile::Brake {
                t0,
                kill_s,
                duration,
                ..
            } => t0 + kill_s + duration,
        }
    }

    /// Whether the set-point is at rest for good at time `t` (s since the move started).
    pub fn is_finished(&self, t: f64) -> bool {
        t >= self.end_time()
    }

    /// Whether a stop was requested.
    pub fn is_braking(&self) -> bool {
        matches!(self.profile, Profile::Brake { .. })
    }

    /// Final resting position (the target, or where the brake ends), rad.
    pub fn final_position(&self) -> SVector<f64, N> {
        self.sample(self.end_time()).position
    }

    /// (s, ṡ, s̈) at time t.
    fn path(&self, t: f64) -> (f64, f64, f64) {
        match self.profile {
            Profile::Quintic { duration } => {
                if duration <= 0.0 || t >= duration {
                    return (1.0, 0.0, 0.0);
                }
                if t <= 0.0 {
                    return (0.0, 0.0, 0.0);
                }
                let (s, ds, dds) = quintic(t / duration);
                (s, ds / duration, dds / (duration * duration))
            }
            Profile::Brake {
                t0,
                s0,
                v0,
                a0,
                kill_jerk,
                kill_s,
                c3,
                c4,
                duration,
            } => {
                let kill = |u: f64| {
                    (
                        s0 + v0 * u + 0.5 * a0 * u * u + kill_jerk * u.powi(3) / 6.0,
                        v0 + a0 * u + 0.5 * kill_jerk * u * u,
                        a0 + kill_jerk * u,
                    )
                };
                if t - t0 < kill_s {
                    return kill((t - t0).max(0.0));
                }
                let (s1, v1, a1) = kill(kill_s);
                let u = (t - t0 - kill_s).clamp(0.0, duration);
                let s = s1 + v1 * u + 0.5 * a1 * u * u + c3 * u.powi(3) + c4 * u.powi(4);
                if t - t0 - kill_s >= duration {
                    return (s, 0.0, 0.0);
                }
                let v = v1 + a1 * u + 3.0 * c3 * u * u + 4.0 * c4 * u.powi(3);
                let a = a1 + 6.0 * c3 * u + 12.0 * c4 * u * u;
                (s, v, a)
            }
        }
    }

    /// Set-point at time `t` (s since the move started); clamps to the ends outside the move.
    pub fn sample(&self, t: f64) -> JointSetpoint<N> {
        let (s, ds, dds) = self.path(t);
        JointSetpoint {
            position: self.start + self.delta * s,
            velocity: self.delta * ds,
            acceleration: self.delta * dds,
        }
    }

    /// Replaces the rest of the move by the gentlest-fitting quartic brake to rest starting at
    /// time `t`. Calling it again, or after the end, changes nothing.
    pub fn stop_at(&mut self, t: f64) {
        if self.is_braking() || self.is_finished(t) {
            return;
        }
        let (s0, v0, a0) = self.path(t);
        let t0 = t.max(0.0);
        let (vs, as_, js) = self.limits.along(&self.delta);
        // Still accelerating: take the acceleration to zero at the jerk limit first (the speed
        // gains a0²/2j, no more than the planned profile would have). A quartic from (v0, a0 > 0)
        // gains far more, and near the speed limit no duration fits at all.
        let (kill_jerk, kill_s) = if a0 > 0.0 && js.is_finite() && js > 0.0 {
            (-js, a0 / js)
        } else {
            (0.0, 0.0)
        };
        let v1 = v0 + a0 * kill_s + 0.5 * kill_jerk * kill_s * kill_s;
        let a1 = a0 + kill_jerk * kill_s;
        let brake = |c3: f64, c4: f64, duration: f64| Profile::Brake {
            t0,
            s0,
            v0,
            a0,
            kill_jerk,
            kill_s,
            c3,
            c4,
            duration,
        };
        if v1 == 0.0 && a1 == 0.0 {
            self.profile = brake(0.0, 0.0, 0.0);
            return;
        }
        // Feasibility is monotone in the duration (longer = gentler) once the acceleration is
        // not positive: bisect on it.
        let fits = |d: f64| {
            let (c3, c4) = brake_coefficients(v1, a1, d);
            brake_within(
                v1,
                a1,
                c3,
                c4,
                d,
                vs * (1.0 + 1e-9),
                as_ * (1.0 + 1e-9),
                js * (1.0 + 1e-9),
            )
        };
        let mut hi = 1e-3;
        while !fits(hi) && hi < 1e4 {
            hi *= 2.0;
        }
        let mut lo = hi / 2.0;
        if hi <= 1e-3 {
            lo = 0.0;
        }
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if fits(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let (c3, c4) = brake_coefficients(v1, a1, hi);
        self.profile = brake(c3, c4, hi);
    }
}

/// Coefficients of s(u) = s0 + v0 u + a0 u²/2 + c3 u³ + c4 u⁴ with ṡ(T) = s̈(T) = 0.
fn brake_coefficients(v0: f64, a0: f64, duration: f64) -> (f64, f64) {
    let t = duration;
    let c3 = -(v0 + 2.0 * a0 * t / 3.0) / (t * t);
    let c4 = -(a0 + 6.0 * c3 * t) / (12.0 * t * t);
    (c3, c4)
}

/// Whether the brake keeps |ṡ|, |s̈|, |s⃛| within the path limits over [0, T].
#[allow(clippy::too_many_arguments)]
fn brake_within(v0: f64, a0: f64, c3: f64, c4: f64, t: f64, vs: f64, as_: f64, js: f64) -> bool {
    if t.is_nan() || t <= 0.0 {
        return false;
    }
    // Jerk is linear in u: extremes at the ends.
    let j0 = 6.0 * c3;
    let j1 = 6.0 * c3 + 24.0 * c4 * t;
    if j0.abs() > js || j1.abs() > js {
        return false;
    }
    // Acceleration is quadratic: ends and vertex.
    let acc = |u: f64| a0 + 6.0 * c3 * u + 12.0 * c4 * u * u;
    let vel = |u: f64| v0 + a0 * u + 3.0 * c3 * u * u + 4.0 * c4 * u * u * u;
    let mut acc_pts = [0.0, t, -1.0];
    if c4 != 0.0 {
        acc_pts[2] = -6.0 * c3 / (24.0 * c4);
    }
    for u in acc_pts {
        if (0.0..=t).contains(&u) && acc(u).abs() > as_ {
            return false;
        }
    }
    // Velocity extremes: ends and roots of the acceleration.
    // The brake starts inside the limits (the quintic respects them); it must never speed up
    // beyond max(|v0|, limit).
    let mut vel_ok = true;
    let v_cap = vs.max(v0.abs());
    let (qa, qb, qc) = (12.0 * c4, 6.0 * c3, a0);
    let mut roots = [-1.0; 2];
    if qa.abs() > 0.0 {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc >= 0.0 {
            let r = disc.sqrt();
            roots = [(-qb - r) / (2.0 * qa), (-qb + r) / (2.0 * qa)];
        }
    } else if qb.abs() > 0.0 {
        roots[0] = -qc / qb;
    }
    for u in roots {
        if (0.0..=t).contains(&u) && vel(u).abs() > v_cap {
            vel_ok = false;
        }
    }
    vel_ok
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    type V7 = SVector<f64, 7>;

    fn limits() -> MotionLimits<7> {
        MotionLimits {
            velocity: V7::repeat(0.5),
            acceleration: V7::repeat(1.0),
            jerk: V7::repeat(5.0),
        }
    }

    /// Samples the move at 1 kHz and checks finite-difference velocity, acceleration and jerk
    /// against the limits (with the discretisation slack of a 1 ms grid) and continuity.
    fn check_trajectory(m: &JointMove<7>, lim: &MotionLimits<7>) {
        let dt = 1e-3;
        let n = (m.end_time() / dt).ceil() as usize + 3;
        let mut prev = m.sample(0.0);
        for k in 1..=n {
            let t = k as f64 * dt;
            let sp = m.sample(t);
            for i in 0..7 {
                // Analytic velocity/acceleration within limits (tiny rounding slack).
                assert!(
                    sp.velocity[i].abs() <= lim.velocity[i] * (1.0 + 1e-9) + 1e-12,
                    "velocity {} > {} at t={t} joint {}",
                    sp.velocity[i],
                    lim.velocity[i],
                    i + 1
                );
                assert!(
                    sp.acceleration[i].abs() <= lim.acceleration[i] * (1.0 + 1e-9) + 1e-12,
                    "acc {} at t={t}",
                    sp.acceleration[i]
                );
                // Never a jump: position step bounded by the velocity limit, velocity step by
                // the acceleration limit, acceleration step by the jerk limit.
                let dq = (sp.position[i] - prev.position[i]).abs();
                assert!(
                    dq <= lim.velocity[i] * dt * (1.0 + 1e-6) + 1e-12,
                    "jump {dq} at {t}"
                );
                let dv = (sp.velocity[i] - prev.velocity[i]).abs();
                assert!(
                    dv <= lim.acceleration[i] * dt * (1.0 + 1e-6) + 1e-12,
                    "dv {dv} at {t}"
                );
                let da = (sp.acceleration[i] - prev.acceleration[i]).abs();
                assert!(
                    da <= lim.jerk[i] * dt * (1.0 + 1e-6) + 1e-12,
                    "da {da} at {t}"
                );
            }
            prev = sp;
        }
    }

    #[test]
    fn lands_exactly_on_target_and_rests() {
        let start = V7::from_column_slice(&[0.0, 0.5, 0.0, -1.2, 0.0, 0.8, 0.1]);
        let target = V7::from_column_slice(&[0.12, 0.38, 0.05, -1.0, -0.1, 0.9, 0.2]);
        let m = JointMove::new(start, target, limits()).unwrap();
        let end = m.sample(m.end_time());
        assert_eq!(end.position, start + (target - start));
        assert!((end.position - target).amax() < 1e-15);
        assert_eq!(end.velocity, V7::zeros());
        assert_eq!(m.sample(m.end_time() + 5.0).position, end.position);
        assert_eq!(m.sample(0.0).position, start);
        check_trajectory(&m, &limits());
    }

    #[test]
    fn duration_is_set_by_the_binding_limit() {
        // 7° on one joint: jerk-bound (cbrt(60·0.122/5) = 1.135 s) vs acc (0.84 s) vs vel (0.46 s).
        let d = 7f64.to_radians();
        let mut target = V7::zeros();
        target[3] = d;
        let m = JointMove::new(V7::zeros(), target, limits()).unwrap();
        assert!((m.end_time() - (60.0 * d / 5.0).cbrt()).abs() < 1e-12);
        // Large move: velocity-bound.
        target[3] = 3.0;
        let m = JointMove::new(V7::zeros(), target, limits()).unwrap();
        assert!((m.end_time() - 15.0 / 8.0 * 3.0 / 0.5).abs() < 1e-12);
        // Some joint reaches its velocity limit exactly.
        let peak = m.sample(m.end_time() / 2.0).velocity[3];
        assert!((peak - 0.5).abs() < 1e-12);
    }

    #[test]
    fn zero_move_is_immediate_and_stays_put() {
        let q = V7::repeat(0.3);
        let m = JointMove::new(q, q, limits()).unwrap();
        assert_eq!(m.end_time(), 0.0);
        assert_eq!(m.sample(0.5).position, q);
    }

    #[test]
    fn rejects_bad_input() {
        let mut l = limits();
        l.jerk[2] = 0.0;
        assert_eq!(
            JointMove::new(V7::zeros(), V7::zeros(), l),
            Err(MotionError::NonPositiveLimit("jerk"))
        );
        let mut t = V7::zeros();
        t[0] = f64::NAN;
        assert_eq!(
            JointMove::new(V7::zeros(), t, limits()),
            Err(MotionError::NonFinite("target"))
        );
    }

    #[test]
    fn stop_brakes_smoothly_and_holds() {
        let target = V7::from_column_slice(&[1.0, -0.5, 0.3, 0.8, 0.0, 0.2, -1.0]);
        let mut m = JointMove::new(V7::zeros(), target, limits()).unwrap();
        let t_stop = m.end_time() * 0.4;
        let before = m.sample(t_stop);
        m.stop_at(t_stop);
        assert!(m.is_braking());
        let after = m.sample(t_stop);
        assert!((after.position - before.position).amax() < 1e-12);
        assert!((after.velocity - before.velocity).amax() < 1e-12);
        assert!(m.end_time() < t_stop + 10.0);
        let rest = m.final_position();
        assert_eq!(m.sample(m.end_time() + 1.0).velocity, V7::zeros());
        // It stops short of the target, on the line.
        assert!((rest - target).norm() > 1e-3);
        check_trajectory(&m, &limits());
    }

    /// A stop while still accelerating close to the speed limit (found by the property test
    /// below): the quartic alone found no feasible duration and planned a 4.7-hour "brake" that
    /// sped up to 640 times the limit. The arm must instead stop within limits, promptly.
    #[test]
    fn a_stop_while_accelerating_near_the_speed_limit_stops_promptly() {
        let lim = MotionLimits {
            velocity: V7::from([1.2885, 0.05, 0.2907, 0.05, 0.05, 0.05, 0.05]),
            acceleration: V7::from([0.4899, 0.2, 4.6196, 0.2, 0.2, 0.2, 0.2]),
            jerk: V7::from([36.82, 1.0, 7.498, 1.0, 1.0, 1.0, 1.0]),
        };
        let target = V7::from([-0.4853, 0.0, -0.4256, 0.0, 0.0, 0.0, 0.0]);
        let mut m = JointMove::new(V7::zeros(), target, lim).unwrap();
        let t_stop = m.end_time() * 0.4555;
        let before = m.end_time();
        m.stop_at(t_stop);
        assert!(
            m.end_time() - t_stop < before,
            "brake {} s",
            m.end_time() - t_stop
        );
        check_trajectory(&m, &lim);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn limits_respected_and_target_reached(
            start in proptest::array::uniform7(-2.0f64..2.0),
            delta in proptest::array::uniform7(-0.6f64..0.6),
            vel in proptest::array::uniform7(0.05f64..1.5),
            acc in proptest::array::uniform7(0.2f64..5.0),
            jerk in proptest::array::uniform7(1.0f64..50.0),
            stop_frac in proptest::option::of(0.0f64..1.0),
        ) {
            let lim = MotionLimits {
                velocity: V7::from(vel),
                acceleration: V7::from(acc),
                jerk: V7::from(jerk),
            };
            let s = V7::from(start);
            let t = s + V7::from(delta);
            let mut m = JointMove::new(s, t, lim).unwrap();
            if let Some(f) = stop_frac {
                m.stop_at(m.end_time() * f);
            } else {
                prop_assert!((m.final_position() - t).amax() < 1e-12);
            }
            check_trajectory(&m, &lim);
        }
    }
}
