//! `stop` and `resume`: the operator's hold of the arm and its release.

use fri_api::results::{ControllerLink, ResumeResult, StopResult};

use crate::service::core::ServiceCore;
use crate::service::cycle::CycleRequest;
use fri_api::protocol::OperatorError;

impl ServiceCore {
    /// `stop`.
    ///
    /// The stop is latched in the loop at once. When the controller is silent nothing is being
    /// commanded (the controller stops the arm itself when our answers are missing) and the
    /// reply says so: the latched stop holds the arm when the controller returns.
    pub fn stop(&self) -> Result<StopResult, OperatorError> {
        self.send(CycleRequest::Stop)?;
        Ok(match self.latest() {
            Ok(_) => StopResult {
                stopped: true,
                controller: ControllerLink::Connected,
                note: None,
            },
            Err(e) => StopResult {
                stopped: true,
                controller: ControllerLink::Silent,
                note: Some(format!(
                    "{}; nothing is commanded while the controller is silent, and the stop holds the arm when it returns",
                    e.message
                )),
            },
        })
    }

    /// `resume`.
    pub fn resume(&self) -> Result<ResumeResult, OperatorError> {
        self.send(CycleRequest::Resume)?;
        Ok(ResumeResult { stopped: false })
    }
}
