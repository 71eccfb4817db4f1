//! Plausibility of recorded values against the robot model, for data read from files.
//!
//! A finite but absurd value (q2 = 1e308 rad from a unit mix-up or a corrupted file) would
//! otherwise flow into the estimate and produce a confident-looking garbage result. Joint
//! positions must lie within the model's joint limits (plus a small margin for encoder noise
//! and calibration offsets at the stops); joint torques (measured τ_J and the controller's
//! gravity vector) within a multiple of the model's torque limits. Joints without a limit in
//! the model get a generous absolute bound instead.

use dynamics::JointLimits;
use nalgebra::SVector;

use crate::error::EstimatorError;
use crate::motion::Trajectory;
use crate::samples::StaticSample;

/// Margin beyond the model's position limits still accepted, rad (about 0.6°).
pub const POSITION_LIMIT_MARGIN: f64 = 0.01;
/// Bound on |q| for joints without a position limit in the model, rad.
pub const POSITION_BOUND_UNLIMITED: f64 = 1.0e3;
/// Accepted |τ| as a multiple of the model's torque limit: measured torques exceed the rated
/// limit briefly in contacts, never by more than this.
pub const TORQUE_LIMIT_FACTOR: f64 = 2.0;
/// Bound on |τ| for joints without a torque limit in the model, Nm.
pub const TORQUE_BOUND_UNLIMITED: f64 = 1.0e5;

/// The accepted ranges of one robot model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ranges<const N: usize> {
    /// Smallest accepted joint position, rad.
    pub q_min: SVector<f64, N>,
    /// Largest accepted joint position, rad.
    pub q_max: SVector<f64, N>,
    /// Largest accepted |joint torque|, Nm.
    pub tau_max: SVector<f64, N>,
}

impl<const N: usize> Ranges<N> {
    /// The ranges implied by the model's joint limits (see the module docs).
    pub fn from_limits(limits: &JointLimits<N>) -> Self {
        let bound = |v: f64, margin: f64, fallback: f64| {
            if v.is_finite() { v + margin } else { fallback }
        };
        Self {
            q_min: limits
                .position_min
                .map(|v| -bound(-v, POSITION_LIMIT_MARGIN, POSITION_BOUND_UNLIMITED)),
            q_max: limits
                .position_max
                .map(|v| bound(v, POSITION_LIMIT_MARGIN, POSITION_BOUND_UNLIMITED)),
            tau_max: limits
                .torque_max
                .map(|v| bound(TORQUE_LIMIT_FACTOR * v, 0.0, TORQUE_BOUND_UNLIMITED)),
        }
    }

    fn positions(&self, row: usize, q: &SVector<f64, N>) -> Result<(), EstimatorError> {
        for j in 0..N {
            if !(self.q_min[j]..=self.q_max[j]).contains(&q[j]) {
                return Err(EstimatorError::OutOfRange {
                    row,
                    column: format!("q{}", j + 1),
                    value: q[j],
                    min: self.q_min[j],
                    max: self.q_max[j],
                    unit: "rad",
                    source_of_range: "the robot model's joint limits",
                });
            }
        }
        Ok(())
    }

    fn torques(
        &self,
        row: usize,
        prefix: &str,
        tau: &SVector<f64, N>,
    ) -> Result<(), EstimatorError> {
        for j in 0..N {
            if tau[j].abs() > self.tau_max[j] {
                return Err(EstimatorError::OutOfRange {
                    row,
                    column: format!("{prefix}{}", j + 1),
                    value: tau[j],
                    min: -self.tau_max[j],
                    max: self.tau_max[j],
                    unit: "Nm",
                    source_of_range: "twice the robot model's torque limit",
                });
            }
        }
        Ok(())
    }

    /// Checks q, τ_J and g of every sample; Err names the first offending row and column.
    pub fn check_samples(&self, samples: &[StaticSample<N>]) -> Result<(), EstimatorError> {
        for (k, s) in samples.iter().enumerate() {
            self.positions(k + 1, &s.q)?;
            self.torques(k + 1, "tau", &s.tau)?;
            self.torques(k + 1, "g", &s.gravity)?;
        }
        Ok(())
    }

    /// Checks q and τ_J of every row of a trajectory; Err names the first offending row.
    pub fn check_trajectory(&self, trajectory: &Trajectory<N>) -> Result<(), EstimatorError> {
        for (k, (q, tau)) in trajectory.q.iter().zip(&trajectory.tau).enumerate() {
            self.positions(k + 1, q)?;
            self.torques(k + 1, "tau", tau)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(q1: f64, tau2: f64) -> StaticSample<2> {
        StaticSample::new(
            SVector::from([q1, 0.0]),
            SVector::from([0.0, tau2]),
            SVector::zeros(),
        )
    }

    #[test]
    fn planar_limits_give_margins_and_factor() {
        let r = Ranges::from_limits(dynamics::planar_2r().limits());
        let pi = std::f64::consts::PI;
        assert!(r.check_samples(&[sample(pi, 399.0)]).is_ok());
        let e = r.check_samples(&[sample(0.0, 0.0), sample(pi + 0.02, 0.0)]);
        let text = e.unwrap_err().to_string();
        assert!(
            text.contains("row 2") && text.contains("`q1`") && text.contains("rad"),
            "{text}"
        );
        let text = r
            .check_samples(&[sample(0.0, -401.0)])
            .unwrap_err()
            .to_string();
        assert!(
            text.contains("`tau2`") && text.contains("[-400, 400] Nm"),
            "{text}"
        );
    }

    #[test]
    fn unlimited_joints_still_have_a_bound() {
        let r = Ranges::<2>::from_limits(&JointLimits::unlimited());
        assert!(r.check_samples(&[sample(100.0, 1.0e4)]).is_ok());
        assert!(r.check_samples(&[sample(1e308, 0.0)]).is_err());
        assert!(r.check_samples(&[sample(0.0, -1e308)]).is_err());
    }
}
