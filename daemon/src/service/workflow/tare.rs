//! `tare`: the pose pattern without payload; the samples are stored and persisted so that a
//! later estimate subtracts them pose by pose (Δτ = τ_loaded − τ_unloaded).

use fri_api::results::{TareResult, Workflow};

use crate::operator::server::EventSink;
use crate::persistence::Tare;
use crate::service::core::{ServiceCore, err};
use crate::service::pattern::PatternKind;
use fri_api::protocol::{ErrorCode, OperatorError};

impl ServiceCore {
    /// `tare`: the pattern without payload, stored and persisted.
    pub async fn tare(
        &self,
        around: Option<[f64; 7]>,
        poses: Option<usize>,
        step_deg: Option<f64>,
        kind: PatternKind,
        events: &EventSink,
    ) -> Result<TareResult, OperatorError> {
        let _guard = self.busy()?;
        let (samples, around, timing) = self
            .run_pattern(around, poses, step_deg, kind, Workflow::Tare, events)
            .await?;
        let revisit = usize::from(self.config.estimation.revisit_first_pose);
        let tare = Tare {
            around,
            pattern_poses: Some(samples.len().saturating_sub(revisit)),
            samples: samples.iter().map(|s| s.sample).collect(),
            taken_unix_s: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .ok()
                .map(|d| d.as_secs_f64()),
        };
        self.store
            .save_tare(Some(&tare))
            .map_err(|e| err(ErrorCode::Internal, format!("tare not persisted: {e}")))?;
        let n = tare.pattern_len();
        self.persistent(|s| s.tare = Some(tare));
        Ok(TareResult {
            samples: n,
            around,
            timing: Some(timing),
        })
    }
}
