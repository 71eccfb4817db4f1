//! The last `collision-calibrate` recording, kept by the service for `source: last-recording`.

use safety::calibration::EnvelopeRecorder;

use crate::persistence::AppliedPayload;

/// A recording kept for `last-recording`.
#[derive(Debug, Clone)]
pub struct CalibrationRecording {
    /// The residuals and motion features recorded.
    pub(crate) recorder: EnvelopeRecorder<7>,
    /// The payload applied during the recording (the thresholds are for it).
    pub(crate) payload: Option<AppliedPayload>,
}
