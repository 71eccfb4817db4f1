//! Typed results of the operator commands and typed payloads of the events streamed before
//! them: exactly the JSON the daemon sends (`{"id":…,"ok":true,"result":{…}}` and
//! `{"id":…,"event":"…","data":{…}}`), one file per command.
//!
//! Every type is `Serialize + Deserialize` and round-trips the daemon's JSON unchanged (see
//! `api/tests/results.rs`). Decoding is lenient towards new fields (they are ignored) and
//! towards `null` where the daemon writes a non-finite float (serde_json writes NaN and ±∞ as
//! `null`): such fields read back as NaN or +∞ as documented on the field.

mod audit;
mod calibrate;
mod collision;
mod estimate;
mod event;
mod expect_payload;
pub(crate) mod lenient;
mod payload;
mod progress;
mod record;
mod resume;
mod sample;
mod state;
mod status;
mod stop;
mod tare;
mod watch;

/// The FRI types inside [`FriStatus`], re-exported so clients need not depend on `fri`.
pub use fri::session::{PendingResync, RejectionCounters, ResyncKind, SessionStatistics};
/// The controller's statistics inside [`FriStatus`] and [`crate::fri_context::FriContext`].
pub use fri::wire::InterfaceStatistics;

pub use audit::{AuditRecord, Change, ReleaseReason};
pub use calibrate::{CalibrateResult, JointFit, LinkForce};
pub use collision::{CalibrationInfo, CollisionResult, MonitorSettings, ThresholdSchedule};
pub use estimate::{
    Correction, EstimateMethod, EstimateResult, EstimateWarning, SourceShare, UncertaintyReport,
    UncertaintySource,
};
pub use event::{Event, RawEvent};
pub use expect_payload::{
    DeclaredBy, ExpectPayloadResult, PinnedBy, PinnedPayload, UnknownPayload,
};
pub use payload::{
    AppliedPayload, PayloadBaseline, PayloadComparison, PayloadRefusal, PayloadResult,
};
pub use progress::{Phase, Progress, Workflow};
pub use record::RecordResult;
pub use resume::ResumeResult;
pub use sample::SampleResult;
pub use state::ServiceState;
pub use status::{ArmCalibration, DroppedCounts, FriStatus, RobotModelStatus, StatusResult};
pub use stop::{ControllerLink, StopResult};
pub use tare::{ProcedureTiming, TareLoad, TareResult};
pub use watch::{
    AbortReason, CollisionDetected, MonitorRestarted, MoveAborted, Resumed, ResyncReason,
    StateLine, StopCause, StopKind, Stopped, WatchResult, Watching,
};
