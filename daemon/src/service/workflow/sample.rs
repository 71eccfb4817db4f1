//! `sample`: one averaged static sample at the current pose.

use fri_api::results::SampleResult;

use super::acquire::{Acquire, WATCH_WAIT_S};
use crate::service::core::{ServiceCore, err};
use crate::service::settle::AveragedSample;
use fri_api::protocol::{ErrorCode, OperatorError};

impl ServiceCore {
    /// `sample`: one averaged static sample at the current pose.
    pub async fn sample(&self, duration_s: Option<f64>) -> Result<SampleResult, OperatorError> {
        let _guard = self.busy()?;
        let d = duration_s.unwrap_or(self.config.estimation.average_s);
        if !(d.is_finite() && d > 0.0 && d <= 60.0) {
            return Err(err(
                ErrorCode::InvalidArguments,
                "duration_s must be in (0, 60]",
            ));
        }
        let wait = Acquire::Watch {
            wait_s: WATCH_WAIT_S,
        };
        let (s, settle_s) = self.acquire(wait, d, None).await?;
        Ok(sample_result(&s, settle_s))
    }
}

fn sample_result(s: &AveragedSample, settle_s: f64) -> SampleResult {
    let array = |v: &nalgebra::SVector<f64, 7>| {
        let mut a = [0.0; 7];
        a.copy_from_slice(v.as_slice());
        a
    };
    SampleResult {
        q: array(&s.sample.q),
        tau: array(&s.sample.tau),
        gravity: array(&s.sample.gravity),
        velocity_max: s.max_speed,
        torque_std: s.torque_std,
        drift: s.drift,
        cycles: s.cycles,
        settle_s,
    }
}
