//! `tare`: the pose pattern without payload; the samples are stored and persisted so that a
//! later estimate subtracts them pose by pose (Δτ = τ_loaded − τ_unloaded).

use fri_api::results::{TareResult, Workflow};

use super::poses::PatternRequest;
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
        let request = PatternRequest {
            around,
            poses,
            step_deg,
            kind,
        };
        let run = self
            .run_pattern(request, None, Workflow::Tare, events)
            .await?;
        let timing = run.timing;
        let around = run.around;
        let tare = Tare {
            around,
            pattern_poses: Some(run.poses),
            samples: run.samples.iter().map(|s| s.sample).collect(),
            taken_unix_s: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .ok()
                .map(|d| d.as_secs_f64()),
            targets: Some(run.targets),
            pattern: Some(kind),
            step_deg: Some(run.step_deg),
            clock: run.clocks.1,
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
