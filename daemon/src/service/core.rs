//! The service object the workflows share: configuration, the channel to the loop, the loop's
//! ordered output, persistent state, and the errors every workflow reports the same way. The
//! workflows themselves are in [`super::workflow`], one file per operator command.

use std::sync::mpsc::{SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use dynamics::Model;
use nalgebra::Vector3;
use safety::PayloadCompensation;

use super::cycle::CycleRequest;
use super::output::{FriContext, StopReason};
use super::state::{LoopState, Snapshot};
use super::stream::Shared;
use super::stream::Update;
use crate::config::Config;
use crate::ipc::IpcSender;
use crate::persistence::{AppliedPayload, StateStore, StoredMonitor, Tare};
use fri_api::cause::Cause;
use fri_api::protocol::{ErrorCode, OperatorError};
use tokio::sync::broadcast::error::RecvError;

/// Longest wait for the controller to enter command mode and start a move, s.
pub(crate) const MOVE_START_TIMEOUT_S: f64 = 10.0;
/// Moves re-driven after a loss of command mode before giving up.
pub(crate) const MOVE_RETRIES: u32 = 3;
/// Longest accepted move, s.
pub(crate) const MOVE_TIMEOUT_S: f64 = 120.0;
/// Largest distance of the measured position from the target after a move, rad.
pub(crate) const ARRIVAL_TOLERANCE: f64 = 0.005;
/// During workflows with the monitor disarmed, a contact is a change of the residual since the
/// previous static sample larger than this multiple of the threshold: an unknown payload's own
/// gravity torque changes by a few Nm between neighbouring ±7° poses. Armed, the monitor watches
/// instead (`workflow::motion::residual_change`).
pub(crate) const WORKFLOW_THRESHOLD_FACTOR: f64 = 2.0;
/// Longest wait for the arm to reach the target after the set-point did, s (controller time).
pub(crate) const ARRIVAL_TIMEOUT_S: f64 = 2.0;

/// Where the service reads FRI statistics for `status` (the endpoint's snapshot).
pub type FriStateSource = Arc<dyn Fn() -> fri::state::EndpointState + Send + Sync>;

/// Persistent, operator-visible state.
#[derive(Debug)]
pub(crate) struct Persistent {
    pub(crate) payload: Option<AppliedPayload>,
    pub(crate) tare: Option<Tare>,
    pub(crate) armed: bool,
    pub(crate) thresholds: [f64; 7],
    pub(crate) gains: [f64; 7],
    pub(crate) reaction: fri_api::protocol::ReactionMode,
    pub(crate) pause_s: f64,
    /// The settings stored by `collision configure` (`None`: the configuration file's).
    pub(crate) stored_monitor: Option<StoredMonitor>,
    /// The payload is declared unknown (`expect-payload`; not persisted: a restarted service
    /// detects against the applied payload, the safe direction).
    pub(crate) unknown_payload: Option<super::workflow::unknown_payload_state::UnknownPayloadState>,
    /// Declarations of an unknown payload so far (numbers them).
    pub(crate) declarations: u32,
    /// Declarations since a payload with mass was last applied (bounded by
    /// `MAX_DECLARATIONS_WITHOUT_PAYLOAD`; not persisted, as the mode itself is not).
    pub(crate) declarations_without_payload: u32,
    /// Who applied the payload in force (`None`: no payload).
    pub(crate) payload_origin: Option<fri_api::origin::Origin>,
}

/// The service (see the module documentation).
pub struct ServiceCore {
    pub(crate) config: Config,
    /// The model the observer runs on (the identified arm's corrected one when configured).
    pub(crate) model: Model<7>,
    /// The arm model in force (`robot.calibration`).
    pub(crate) arm: super::arm::ArmModel,
    pub(crate) shared: Arc<Shared>,
    pub(crate) rt: SyncSender<CycleRequest>,
    /// The operator's stops, outside `rt` (no queued request delays them).
    pub(crate) stop_latch: super::cycle::StopLatch,
    /// The loop's count of the events it dropped (shown in `status`).
    pub(crate) dropped_events: super::cycle::DroppedEvents,
    pub(crate) store: StateStore,
    pub(crate) state: Mutex<Persistent>,
    pub(crate) workflow: tokio::sync::Mutex<()>,
    pub(crate) ipc: Option<IpcSender>,
    pub(crate) fri_state: Option<FriStateSource>,
    /// The last `collision-calibrate` recording (for `source: last-recording`).
    pub(crate) calibration_recording:
        Mutex<Option<super::workflow::calibration_recording::CalibrationRecording>>,
    /// The audit trail (`crate::audit`).
    pub(crate) audit: Arc<crate::audit::Audit>,
    /// This service instance (its start on the host clock in ns, xor the process id): a stored
    /// tare's controller-restart count is comparable only within one instance.
    pub(crate) instance: u64,
}

impl std::fmt::Debug for ServiceCore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ServiceCore").finish_non_exhaustive()
    }
}

pub(crate) fn err(code: ErrorCode, msg: impl Into<String>) -> OperatorError {
    OperatorError::new(code, msg)
}

/// Mass difference under which two payloads count as the same for the monitor's thresholds, as
/// a share of the mass (2 %: about the estimate's own spread on the LWR, BENCHMARKS.md).
const SAME_PAYLOAD_MASS_SHARE: f64 = 0.02;
/// Smallest mass difference that counts, kg (an empty gripper's estimate scatters by grams).
const SAME_PAYLOAD_MASS_FLOOR_KG: f64 = 0.01;
/// Centre-of-mass difference under which two payloads count as the same, m.
const SAME_PAYLOAD_COM_M: f64 = 0.005;

/// Whether the monitor settings configured with payload `set_for` still fit the payload
/// `applied` (none and none, or masses within 2 % and centres within 5 mm): a re-estimate of the
/// same load does not ask for new thresholds, another load does.
pub(crate) fn same_payload(
    set_for: Option<&AppliedPayload>,
    applied: Option<&AppliedPayload>,
) -> bool {
    match (set_for, applied) {
        (None, None) => true,
        (Some(a), Some(b)) => {
            let mass_tolerance =
                (SAME_PAYLOAD_MASS_SHARE * a.mass.max(b.mass)).max(SAME_PAYLOAD_MASS_FLOOR_KG);
            let com_distance = Vector3::from(a.com) - Vector3::from(b.com);
            (a.mass - b.mass).abs() <= mass_tolerance && com_distance.norm() <= SAME_PAYLOAD_COM_M
        }
        _ => false,
    }
}

/// Converts an applied payload into the observer's compensation: the paper's eq. 48 puts it in
/// g_L only, which leaves the load's inertia in the residual (a 3 kg load one metre from joint 1
/// accelerated at 2.5 rad/s² alone makes 7.5 Nm); we carry it as a point mass at the estimated
/// centre of mass in M, Cᵀq̇ and g_L. Its own inertia about the centre of mass is unknown (the
/// estimate gives m and m·c) and small for compact loads.
pub fn compensation(p: &AppliedPayload) -> PayloadCompensation {
    if p.mass > 0.0 {
        PayloadCompensation::Full(dynamics::InertialParameters::point_mass(
            p.mass,
            Vector3::from(p.com),
        ))
    } else {
        PayloadCompensation::None
    }
}

impl ServiceCore {
    /// Assembles the service; `payload`/`tare`/`monitor` are what was reloaded from the state
    /// directory. `config` is the configuration file's: the stored monitor settings are put in
    /// force over it ([`crate::service::with_stored_monitor`]), and it stays what
    /// [`Self::weaker_than_configuration`] compares them with; `audit` is the trail the stream
    /// thread writes the loop's own changes to; `stop_latch` and `dropped_events` are the loop's
    /// ([`super::cycle::StopLatch`], [`super::cycle::DroppedEvents`]).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        config: Config,
        arm: super::arm::ArmModel,
        shared: Arc<Shared>,
        rt: SyncSender<CycleRequest>,
        store: StateStore,
        payload: Option<AppliedPayload>,
        tare: Option<Tare>,
        monitor: Option<StoredMonitor>,
        ipc: Option<IpcSender>,
        fri_state: Option<FriStateSource>,
        audit: Arc<crate::audit::Audit>,
        stop_latch: super::cycle::StopLatch,
        dropped_events: super::cycle::DroppedEvents,
    ) -> Self {
        let payload_origin = payload.map(|_| fri_api::origin::Origin::Restored);
        let in_force = monitor
            .as_ref()
            .map(|m| crate::service::with_stored_monitor(&config, m));
        let effective = in_force.as_ref().unwrap_or(&config);
        let state = Persistent {
            payload_origin,
            payload,
            tare,
            armed: effective.observer.armed,
            thresholds: effective.observer.thresholds,
            gains: effective.observer.gains,
            reaction: effective.reaction.policy,
            pause_s: effective.reaction.pause_s,
            stored_monitor: monitor,
            unknown_payload: None,
            declarations: 0,
            declarations_without_payload: 0,
        };
        Self {
            config,
            model: arm.observer_model().clone(),
            arm,
            shared,
            rt,
            stop_latch,
            dropped_events,
            store,
            state: Mutex::new(state),
            workflow: tokio::sync::Mutex::new(()),
            ipc,
            fri_state,
            calibration_recording: Mutex::new(None),
            audit,
            instance: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos() as u64)
                ^ u64::from(std::process::id()),
        }
    }

    /// The audit trail.
    pub fn audit(&self) -> &Arc<crate::audit::Audit> {
        &self.audit
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The loop's shared output.
    pub fn shared(&self) -> &Arc<Shared> {
        &self.shared
    }

    pub(crate) fn persistent<R>(&self, f: impl FnOnce(&mut Persistent) -> R) -> R {
        match self.state.lock() {
            Ok(mut g) => f(&mut g),
            Err(p) => f(&mut p.into_inner()),
        }
    }

    /// Sends a request to the loop without blocking.
    pub fn send(&self, r: CycleRequest) -> Result<(), OperatorError> {
        self.rt.try_send(r).map_err(|e| match e {
            TrySendError::Full(_) => err(ErrorCode::Busy, "the loop's request queue is full"),
            TrySendError::Disconnected(_) => err(ErrorCode::NotReady, "the FRI loop has stopped"),
        })
    }

    /// [`connection_timeout`] at this service's FRI cycle.
    pub fn connection_timeout(&self) -> Duration {
        connection_timeout(self.config.fri.cycle_s)
    }

    /// The newest state, if the controller is connected (a measurement within
    /// [`Self::connection_timeout`]). A state older than that is still the newest when the
    /// endpoint thread heard the controller meanwhile: this side lagged (a host stall), the
    /// controller did not fall silent.
    pub(crate) fn latest(&self) -> Result<Snapshot, OperatorError> {
        self.connected(self.shared.latest_with_age())
    }

    /// [`Self::latest`] of one read of the newest state and its age.
    pub(crate) fn connected(
        &self,
        newest: Option<(Snapshot, Duration)>,
    ) -> Result<Snapshot, OperatorError> {
        let timeout = self.connection_timeout();
        match newest {
            Some((s, age)) if age <= timeout => Ok(s),
            Some((s, age)) => match endpoint_heard(self.fri_state.as_ref(), timeout) {
                Heard::Recently => Ok(s),
                Heard::SilentFor(silent_s) => Err(self.silent_error(silent_s)),
                Heard::Unknown => Err(self.silent_error(age.as_secs_f64())),
            },
            None => Err(err(
                ErrorCode::NotReady,
                "no measurement from the controller yet (is the KRL program running and FRI open?)",
            )
            .with_cause(Cause::ControllerSilent {
                silent_s: f64::INFINITY,
                fri: None,
            })),
        }
    }

    /// The controller's view in its newest measurement (endpoint snapshot), if any.
    /// The controller's commanded joint positions (`cmdJntPos + cmdJntPosFriOffset`, where the
    /// next move starts from), rad.
    pub(crate) fn commanded_q(&self) -> Option<[f64; 7]> {
        let s = self.fri_state.as_ref().map(|f| f())?;
        let d = &s.measurement.data;
        s.valid
            .then(|| std::array::from_fn(|j| d.cmd_jnt_pos[j] + d.cmd_jnt_pos_fri_offset[j]))
    }

    /// The service's and the controller's clocks now (the latest state and measurement).
    pub(crate) fn clocks(&self) -> Option<crate::persistence::Clocks> {
        let s = self.fri_state.as_ref().map(|f| f())?;
        let latest = self.shared.latest()?;
        (s.valid && s.measurement.interface.timestamp.is_finite()).then_some(
            crate::persistence::Clocks {
                service_s: latest.robot.time_s,
                controller_s: s.measurement.interface.timestamp,
            },
        )
    }

    pub(crate) fn fri_context(&self) -> Option<FriContext> {
        let s = self.fri_state.as_ref().map(|f| f())?;
        s.valid.then(|| FriContext::of(&s.measurement))
    }

    /// The error for a controller silent for `silent_s` seconds.
    pub(crate) fn silent_error(&self, silent_s: f64) -> OperatorError {
        let fri = self.fri_context();
        let last = fri.map_or(String::new(), |f| {
            format!("; last measurement: {}", f.describe())
        });
        err(
            ErrorCode::NotReady,
            format!(
                "the controller is silent: no measurement for {silent_s:.3} s (connection timeout {:.3} s){last}",
                self.connection_timeout().as_secs_f64()
            ),
        )
        .with_cause(Cause::ControllerSilent { silent_s, fri })
    }

    /// The error for a stop by the loop.
    pub(crate) fn stop_error(reason: StopReason, fri: FriContext) -> OperatorError {
        let cause = match reason {
            StopReason::Operator => Cause::OperatorStop,
            StopReason::Collision {
                link,
                time_s,
                residual,
            } => Cause::Collision {
                link,
                time_s,
                residual,
            },
            StopReason::ObserverFault { fault } => Cause::ObserverFault {
                fault: fault.to_string(),
                fri,
            },
        };
        err(ErrorCode::Aborted, reason.describe()).with_cause(cause)
    }

    /// The error for a workflow step that finds the arm held in `state`.
    pub(crate) fn held_error(state: &LoopState) -> Option<OperatorError> {
        if *state == LoopState::Held {
            return Some(
                err(
                    ErrorCode::Aborted,
                    "the arm is held; why was not seen (the loop's output queue overflowed): check `status` and `resume`",
                )
                .with_cause(Cause::Held),
            );
        }
        let (reason, fri) = state.stop()?;
        Some(Self::stop_error(reason, fri))
    }

    /// Waits until the controller is out of command mode (after [`CycleRequest::Shutdown`] or
    /// [`CycleRequest::ReleaseCommandMode`]), the controller goes silent, or `timeout` passes;
    /// says which in the log.
    pub async fn leave_command_mode(&self, timeout: Duration) {
        let mut updates = self.shared.subscribe();
        let commanding = |s: &Snapshot| s.command_mode() || s.state == LoopState::EnteringCommand;
        if !self.latest().is_ok_and(|s| commanding(&s)) {
            return;
        }
        let _ = self.send(CycleRequest::ReleaseCommandMode);
        let waited = tokio::time::timeout(timeout, async {
            loop {
                match updates.recv().await {
                    Ok(Update::Snapshot(s)) if !commanding(&s) => return true,
                    Ok(_) | Err(RecvError::Lagged(_)) => {}
                    Err(RecvError::Closed) => return false,
                }
            }
        })
        .await;
        match waited {
            Ok(true) => tracing::info!("the controller left command mode"),
            Ok(false) => tracing::warn!("the loop ended before the controller left command mode"),
            Err(_) => tracing::warn!(
                timeout_s = timeout.as_secs_f64(),
                "the controller did not leave command mode in time; it brakes the arm itself when our answers stop"
            ),
        }
    }

    /// Leaves command mode (best effort).
    pub(crate) fn release(&self) {
        let _ = self.send(CycleRequest::ReleaseCommandMode);
    }

    pub(crate) fn busy(&self) -> Result<tokio::sync::MutexGuard<'_, ()>, OperatorError> {
        self.workflow
            .try_lock()
            .map_err(|_| err(ErrorCode::Busy, "another workflow is running"))
    }
}

/// Longest silence of a controller cycling every `cycle_s` seconds that still counts as
/// connected: 100 ms, or ten cycles when `friOpen` runs slower than 10 ms.
pub(crate) fn connection_timeout(cycle_s: f64) -> Duration {
    Duration::from_secs_f64((10.0 * cycle_s).max(0.1))
}

/// What the FRI endpoint thread says of the controller: only that thread can tell a silent
/// controller from a stall of this side that delayed the delivered states.
pub(crate) enum Heard {
    /// An accepted measurement within the connection timeout.
    Recently,
    /// No accepted measurement for this long, s (longer than the connection timeout).
    SilentFor(f64),
    /// The endpoint thread publishes no valid state (not running, or no session yet).
    Unknown,
}

/// [`Heard`] from the endpoint's published state, judged against `timeout`.
pub(crate) fn endpoint_heard(source: Option<&FriStateSource>, timeout: Duration) -> Heard {
    match source.map(|state| state()) {
        Some(e) if e.valid && e.silence_s <= timeout.as_secs_f64() => Heard::Recently,
        Some(e) if e.valid => Heard::SilentFor(e.silence_s),
        _ => Heard::Unknown,
    }
}
