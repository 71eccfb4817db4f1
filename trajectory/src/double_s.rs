//! The time-optimal jerk-limited rest-to-rest profile of a path parameter s from 0 to 1 (the
//! "double S": jerk ±j, acceleration up to ±a, velocity up to v; Biagiotti & Melchiorri,
//! *Trajectory Planning for Automatic Machines and Robots*, 2008, Sec. 3.4).
//!
//! The acceleration phase lasts `ta`: jerk +j for `tj`, constant acceleration a_lim = j·tj,
//! jerk −j for `tj`, reaching v_lim = a_lim·(ta − tj). Then `tv` at v_lim, and the deceleration
//! phase mirrors the acceleration phase, so s(2·ta + tv) = 1 exactly. Position, velocity and
//! acceleration are continuous and within the limits; among profiles with these limits none
//! arrives sooner. A quintic with the same limits takes 1.2–1.9 × as long (its peaks are
//! 15/8 and 10/√3 times the averages, where the double S runs at its limits).

/// A planned double-S profile on s ∈ [0, 1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoubleS {
    /// Duration of each jerk segment, s.
    tj: f64,
    /// Duration of the acceleration (and of the deceleration) phase, s.
    ta: f64,
    /// Duration of the constant-velocity phase, s.
    tv: f64,
    /// Jerk during the jerk segments, 1/s³.
    jerk: f64,
}

impl DoubleS {
    /// The fastest profile from rest at s = 0 to rest at s = 1 with |ṡ| ≤ `v`, |s̈| ≤ `a`,
    /// |s⃛| ≤ `j` (1/s, 1/s², 1/s³; positive, possibly infinite — an infinite limit does not
    /// bind, and all three infinite is an immediate step).
    pub fn plan(v: f64, a: f64, j: f64) -> Self {
        let rest = DoubleS {
            tj: 0.0,
            ta: 0.0,
            tv: 0.0,
            jerk: 0.0,
        };
        // JointMove's limits are validated finite and positive; only a line on which no joint
        // moves has infinite limits, and it arrives at once.
        if !(v > 0.0 && a > 0.0 && j > 0.0 && v.is_finite() && a.is_finite() && j.is_finite()) {
            return rest;
        }
        // Reaching v: with the acceleration limit (v·j ≥ a²) or with jerk segments only.
        let (tj, ta) = if v * j >= a * a {
            (a / j, a / j + v / a)
        } else {
            let tj = (v / j).sqrt();
            (tj, 2.0 * tj)
        };
        let tv = 1.0 / v - ta;
        if tv >= 0.0 && tv.is_finite() {
            return DoubleS {
                tj,
                ta,
                tv,
                jerk: j,
            };
        }
        // No cruise: the peak velocity stays below v. With the acceleration limit reached
        // (s = a(ta − tj)·ta with tj = a/j) or, for short moves, jerk segments only
        // (s = 2 j tj³).
        let tj = a / j;
        let ta = 0.5 * (tj + (tj * tj + 4.0 / a).sqrt());
        if ta >= 2.0 * tj && ta.is_finite() {
            return DoubleS {
                tj,
                ta,
                tv: 0.0,
                jerk: j,
            };
        }
        let tj = (0.5 / j).cbrt();
        DoubleS {
            tj,
            ta: 2.0 * tj,
            tv: 0.0,
            jerk: j,
        }
    }

    /// Total duration, s.
    pub fn duration(&self) -> f64 {
        2.0 * self.ta + self.tv
    }

    /// Peak velocity reached, 1/s.
    fn v_lim(&self) -> f64 {
        self.jerk * self.tj * (self.ta - self.tj)
    }

    /// (s, ṡ, s̈) of the acceleration phase at τ ∈ [0, ta].
    fn accelerating(&self, tau: f64) -> (f64, f64, f64) {
        let (j, tj, ta) = (self.jerk, self.tj, self.ta);
        let a_lim = j * tj;
        let v_lim = self.v_lim();
        if tau < tj {
            (j * tau.powi(3) / 6.0, 0.5 * j * tau * tau, j * tau)
        } else if tau < ta - tj {
            let u = tau - tj;
            let (s1, v1) = (j * tj.powi(3) / 6.0, 0.5 * j * tj * tj);
            (s1 + v1 * u + 0.5 * a_lim * u * u, v1 + a_lim * u, a_lim)
        } else {
            // mirrored about the phase's middle: w is the time left in the phase
            let w = (ta - tau).max(0.0);
            (
                0.5 * v_lim * ta - v_lim * w + j * w.powi(3) / 6.0,
                v_lim - 0.5 * j * w * w,
                j * w,
            )
        }
    }

    /// (s, ṡ, s̈) at time `t` (s), clamped to rest at both ends.
    pub fn at(&self, t: f64) -> (f64, f64, f64) {
        let total = self.duration();
        if t >= total || total <= 0.0 {
            return (1.0, 0.0, 0.0);
        }
        if t <= 0.0 {
            return (0.0, 0.0, 0.0);
        }
        if t < self.ta {
            return self.accelerating(t);
        }
        if t < self.ta + self.tv {
            let v = self.v_lim();
            return (0.5 * v * self.ta + v * (t - self.ta), v, 0.0);
        }
        let (s, v, a) = self.accelerating(total - t);
        (1.0 - s, v, -a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(p: &DoubleS, v: f64, a: f64, j: f64) {
        let n = 20_000;
        let dt = p.duration() / n as f64;
        let mut prev = p.at(0.0);
        for k in 1..=n {
            let (s, sd, sdd) = p.at(k as f64 * dt);
            assert!(sd <= v * (1.0 + 1e-9) && sd >= -1e-12, "v {sd} > {v}");
            assert!(sdd.abs() <= a * (1.0 + 1e-9), "a {sdd} > {a}");
            assert!((s - prev.0).abs() <= v * dt * (1.0 + 1e-6) + 1e-12);
            assert!((sd - prev.1).abs() <= a * dt * (1.0 + 1e-6) + 1e-12);
            assert!((sdd - prev.2).abs() <= j * dt * (1.0 + 1e-6) + 1e-9);
            prev = (s, sd, sdd);
        }
        assert_eq!(p.at(p.duration()), (1.0, 0.0, 0.0));
        let end = p.at(p.duration() * (1.0 - 1e-12));
        assert!((end.0 - 1.0).abs() < 1e-9, "{end:?}");
    }

    #[test]
    fn every_case_stays_within_the_limits_and_ends_at_one() {
        // cruise with the acceleration limit, cruise on jerk only, no cruise with the
        // acceleration limit, jerk segments only
        for (v, a, j) in [
            (0.5, 1.0, 5.0),
            (0.5, 10.0, 5.0),
            (50.0, 1.0, 5.0),
            (50.0, 50.0, 5.0),
        ] {
            let p = DoubleS::plan(v, a, j);
            check(&p, v, a, j);
        }
    }

    #[test]
    fn it_is_faster_than_the_quintic_at_the_same_limits() {
        // the service's defaults on a 0.24 rad move: s-limits v/d, a/d, j/d
        let d = 0.244;
        let (v, a, j) = (0.18 / d, 1.0 / d, 5.0 / d);
        let p = DoubleS::plan(v, a, j);
        let quintic = (crate::quintic::PEAK_VELOCITY / v)
            .max((crate::quintic::PEAK_ACCELERATION / a).sqrt())
            .max((crate::quintic::PEAK_JERK / j).cbrt());
        // v-limited: cruise 0.98 s plus 2 × 0.38 s of acceleration (a never reaches 1)
        assert!((p.duration() - 1.737).abs() < 2e-3, "{}", p.duration());
        assert!(
            quintic > 1.4 * p.duration(),
            "{quintic} vs {}",
            p.duration()
        );
    }

    #[test]
    fn degenerate_limits() {
        let p = DoubleS::plan(f64::INFINITY, f64::INFINITY, f64::INFINITY);
        assert_eq!(p.duration(), 0.0);
        assert_eq!(p.at(0.0), (1.0, 0.0, 0.0));
    }
}
