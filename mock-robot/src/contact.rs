//! External contacts: a force at a point of a link with a time profile.
//!
//! The force acts on the link at `point_m` (DH frame of the link) and enters the dynamics as
//! τ_ext = J_p(q)ᵀ F with the point's translational Jacobian; forces are in the base frame (the
//! DH frame 0 of the shoulder, z up).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::error::{SimError, ensure};

/// One contact event of a scenario.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// Link hit, 1..=7 (joint numbering).
    pub link: usize,
    /// Contact point in the link's DH frame, m.
    pub point_m: [f64; 3],
    /// Time at which the profile starts, s.
    pub onset_s: f64,
    /// Force time profile.
    pub profile: ContactProfile,
}

/// Time profile of a contact force.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ContactProfile {
    /// Impulse F(t) = F_peak·sin(π t / T) for 0 ≤ t ≤ T.
    HalfSine {
        /// Peak force, N, base frame.
        peak_force_n: [f64; 3],
        /// Pulse length T, s.
        duration_s: f64,
    },
    /// Force growing at `rate_n_per_s` along `direction`, held at `max_force_n`, released after
    /// `duration_s`.
    Ramp {
        /// Direction of the force (normalised internally), base frame.
        direction: [f64; 3],
        /// Growth rate, N/s.
        rate_n_per_s: f64,
        /// Saturation, N.
        max_force_n: f64,
        /// Time until release, s.
        duration_s: f64,
    },
    /// A stiff wall (half-space) against which the point is clamped: F = k·max(0, d)·n, with d
    /// the penetration depth along the outward normal n.
    Wall {
        /// Outward wall normal (normalised internally), base frame.
        normal: [f64; 3],
        /// A point of the wall plane, base frame, m; `None` = the contact point's position at
        /// onset (the wall touches the link at onset).
        plane_point_m: Option<[f64; 3]>,
        /// Wall stiffness, N/m (ISO range 1e4..1.5e5).
        stiffness_n_per_m: f64,
        /// Time until the wall is removed, s.
        duration_s: f64,
    },
}

fn unit(v: &[f64; 3]) -> Option<Vector3<f64>> {
    let v = Vector3::from(*v);
    let n = v.norm();
    (n.is_finite() && n > 1e-12).then(|| v / n)
}

impl ContactSpec {
    /// 0-based link index.
    pub fn link_index(&self) -> usize {
        self.link.saturating_sub(1)
    }

    /// Contact point in the link frame, m.
    pub fn point(&self) -> Vector3<f64> {
        Vector3::from(self.point_m)
    }

    /// Length of the profile, s.
    pub fn duration_s(&self) -> f64 {
        match self.profile {
            ContactProfile::HalfSine { duration_s, .. }
            | ContactProfile::Ramp { duration_s, .. }
            | ContactProfile::Wall { duration_s, .. } => duration_s,
        }
    }

    /// Whether the profile is running at time `t_s`.
    pub fn is_active(&self, t_s: f64) -> bool {
        t_s >= self.onset_s && t_s <= self.onset_s + self.duration_s()
    }

    /// Force on the link, N, base frame, at time `t_s` with the contact point at `point_base`
    /// (m, base frame); `wall_anchor` is the wall plane point fixed at onset when none is given.
    pub fn force(
        &self,
        t_s: f64,
        point_base: &Vector3<f64>,
        wall_anchor: &Vector3<f64>,
    ) -> Vector3<f64> {
        if !self.is_active(t_s) {
            return Vector3::zeros();
        }
        let tau = t_s - self.onset_s;
        match &self.profile {
            ContactProfile::HalfSine {
                peak_force_n,
                duration_s,
            } => Vector3::from(*peak_force_n) * (std::f64::consts::PI * tau / duration_s).sin(),
            ContactProfile::Ramp {
                direction,
                rate_n_per_s,
                max_force_n,
                ..
            } => {
                let dir = unit(direction).unwrap_or_else(Vector3::zeros);
                dir * (rate_n_per_s * tau).min(*max_force_n)
            }
            ContactProfile::Wall {
                normal,
                plane_point_m,
                stiffness_n_per_m,
                ..
            } => {
                let n = unit(normal).unwrap_or_else(Vector3::zeros);
                let p0 = plane_point_m.map(Vector3::from).unwrap_or(*wall_anchor);
                let depth = (p0 - point_base).dot(&n);
                if depth > 0.0 {
                    n * (stiffness_n_per_m * depth)
                } else {
                    Vector3::zeros()
                }
            }
        }
    }

    pub(crate) fn validate(&self) -> Result<(), SimError> {
        ensure((1..=7).contains(&self.link), || {
            format!("contact link must be 1..=7, got {}", self.link)
        })?;
        ensure(
            self.point_m.iter().all(|c| c.is_finite() && c.abs() < 1.0),
            || "contact point must be finite and within 1 m of the link frame".into(),
        )?;
        ensure(self.onset_s.is_finite() && self.onset_s >= 0.0, || {
            "contact onset must be >= 0 s".into()
        })?;
        let d = self.duration_s();
        ensure(d.is_finite() && d > 0.0, || {
            "contact duration must be > 0 s".into()
        })?;
        let ok = match &self.profile {
            ContactProfile::HalfSine { peak_force_n, .. } => peak_force_n
                .iter()
                .all(|f| f.is_finite() && f.abs() <= 5000.0),
            ContactProfile::Ramp {
                direction,
                rate_n_per_s,
                max_force_n,
                ..
            } => {
                unit(direction).is_some()
                    && rate_n_per_s.is_finite()
                    && *rate_n_per_s > 0.0
                    && max_force_n.is_finite()
                    && (0.0..=5000.0).contains(max_force_n)
            }
            ContactProfile::Wall {
                normal,
                plane_point_m,
                stiffness_n_per_m,
                ..
            } => {
                unit(normal).is_some()
                    && plane_point_m.is_none_or(|p| p.iter().all(|c| c.is_finite()))
                    && stiffness_n_per_m.is_finite()
                    && (0.0..=1e7).contains(stiffness_n_per_m)
            }
        };
        ensure(ok, || {
            format!(
                "contact profile parameters out of range: {:?}",
                self.profile
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(profile: ContactProfile) -> ContactSpec {
        ContactSpec {
            link: 4,
            point_m: [0.0, 0.0, 0.1],
            onset_s: 1.0,
            profile,
        }
    }

    #[test]
    fn half_sine_peaks_mid_pulse() {
        let c = spec(ContactProfile::HalfSine {
            peak_force_n: [0.0, 50.0, 0.0],
            duration_s: 0.02,
        });
        let z = Vector3::zeros();
        assert_eq!(c.force(0.99, &z, &z), Vector3::zeros());
        assert!((c.force(1.01, &z, &z).y - 50.0).abs() < 1e-9);
        assert_eq!(c.force(1.03, &z, &z), Vector3::zeros());
    }

    #[test]
    fn ramp_grows_then_saturates() {
        let c = spec(ContactProfile::Ramp {
            direction: [2.0, 0.0, 0.0],
            rate_n_per_s: 100.0,
            max_force_n: 30.0,
            duration_s: 2.0,
        });
        let z = Vector3::zeros();
        assert!((c.force(1.1, &z, &z).x - 10.0).abs() < 1e-9);
        assert!((c.force(1.9, &z, &z).x - 30.0).abs() < 1e-9);
        assert_eq!(c.force(3.5, &z, &z), Vector3::zeros());
    }

    #[test]
    fn wall_pushes_only_when_penetrated() {
        let c = spec(ContactProfile::Wall {
            normal: [0.0, 0.0, 1.0],
            plane_point_m: Some([0.0, 0.0, 0.5]),
            stiffness_n_per_m: 50_000.0,
            duration_s: 10.0,
        });
        let z = Vector3::zeros();
        assert_eq!(
            c.force(2.0, &Vector3::new(0.0, 0.0, 0.6), &z),
            Vector3::zeros()
        );
        let f = c.force(2.0, &Vector3::new(0.3, 0.0, 0.498), &z);
        assert!((f.z - 100.0).abs() < 1e-6);
    }

    #[test]
    fn invalid_link_rejected() {
        let mut c = spec(ContactProfile::HalfSine {
            peak_force_n: [1.0, 0.0, 0.0],
            duration_s: 0.01,
        });
        c.link = 8;
        assert!(c.validate().is_err());
    }
}
