//! `collision show|arm|disarm|configure`: the collision monitor's reaction and settings.

use fri_api::results::CollisionResult;

use crate::service::core::{ServiceCore, err};
use crate::service::cycle::CycleRequest;
use fri_api::protocol::{ErrorCode, OperatorError};

impl ServiceCore {
    /// `collision` arm/disarm/configure/show.
    pub fn collision(
        &self,
        action: fri_api::protocol::CollisionAction,
        thresholds: Option<[f64; 7]>,
        gains: Option<[f64; 7]>,
    ) -> Result<CollisionResult, OperatorError> {
        use fri_api::protocol::CollisionAction as A;
        match action {
            A::Show => {}
            A::Arm | A::Disarm => {
                let on = action == A::Arm;
                self.send(CycleRequest::Arm(on))?;
                self.persistent(|s| s.armed = on);
            }
            A::Configure => {
                if thresholds.is_none() && gains.is_none() {
                    return Err(err(
                        ErrorCode::InvalidArguments,
                        "configure needs `thresholds` and/or `gains`",
                    ));
                }
                let (mut t, mut g) = self.persistent(|s| (s.thresholds, s.gains));
                if let Some(x) = thresholds {
                    t = x;
                }
                if let Some(x) = gains {
                    g = x;
                }
                // Named like the arguments; the gain bound follows the configured cycle.
                let gain = fri_api::bounds::gain(self.config.fri.cycle_s);
                for j in 0..7 {
                    fri_api::bounds::threshold(j)
                        .check(&format!("thresholds[{j}]"), t[j])
                        .and_then(|()| gain.check(&format!("gains[{j}]"), g[j]))
                        .map_err(OperatorError::out_of_range)?;
                }
                let mut config = self.config.clone();
                config.observer.thresholds = t;
                config.observer.gains = g;
                config
                    .validate()
                    .map_err(|e| err(ErrorCode::InvalidArguments, e.to_string()))?;
                let monitor = crate::service::build_monitor(&config, self.model.clone())
                    .map_err(|e| err(ErrorCode::InvalidArguments, e.to_string()))?;
                self.send(CycleRequest::ReplaceMonitor(Box::new(monitor)))?;
                self.persistent(|s| {
                    s.thresholds = t;
                    s.gains = g;
                });
            }
        }
        let (armed, t, g) = self.persistent(|s| (s.armed, s.thresholds, s.gains));
        Ok(CollisionResult {
            armed,
            thresholds: t,
            gains: g,
        })
    }
}
