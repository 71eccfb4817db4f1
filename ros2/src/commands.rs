//! Serving the enabled commands: every request is judged by the replay guard, answered `busy`
//! when the commands in flight toward the service reach `ros2.max_requests_in_flight` (`stop`
//! has a budget of its own, so a flood of other calls never holds a stop back), logged with the
//! calling participant, and forwarded to the service on that participant's behalf
//! (`Ros2Caller`), so the service's audit trail names it. What is neither answered nor executed
//! is counted (`dropped requests` in the diagnostics), never lost silently.

use std::sync::Arc;
use std::sync::atomic::{AtomicI64, Ordering};

use fri_api::protocol::Ros2Caller;
use fri_api::results::Event;
use fri_ros_msgs::geometry_msgs::Inertia;
use fri_ros_msgs::std_msgs;
use ros2_client::Subscription;
use serde::de::DeserializeOwned;
use tokio::sync::Semaphore;

use crate::access::{Access, Authentication};
use crate::dds::Publishers;
use crate::diagnostics::Stats;
use crate::operator::{Operator, Trigger};
use crate::replay::{ReplayGuard, now_ns};
use crate::rpc::{Request, Service, participant_guid};
use crate::srv::TriggerResponse;

/// What a request asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Call {
    /// A `std_srvs/Trigger` service.
    Trigger(Trigger),
    /// `collision_arm` with its `data`.
    Arm(bool),
}

impl Call {
    fn name(self) -> &'static str {
        match self {
            Self::Trigger(t) => t.service_name(),
            Self::Arm(_) => "collision_arm",
        }
    }
}

/// Logs at most one line a second per kind (a flood of ignored requests must not flood the
/// log); the counters in the diagnostics count every one.
#[derive(Debug, Default)]
pub struct LogLimit {
    last_s: AtomicI64,
}

impl LogLimit {
    /// Whether a line may be logged now.
    pub fn allow(&self) -> bool {
        let now = now_ns() / 1_000_000_000;
        self.last_s.swap(now, Ordering::Relaxed) != now
    }
}

/// The command side of the bridge.
pub struct Commands {
    operator: Operator,
    access: Access,
    stats: Arc<Stats>,
    publishers: Arc<Publishers>,
    general: Arc<Semaphore>,
    stop: Arc<Semaphore>,
    started_ns: i64,
    ignored_log: LogLimit,
    busy_log: LogLimit,
}

impl Commands {
    /// Commands for a bridge that started at `started_ns` (ns since the Unix epoch).
    pub fn new(
        operator: Operator,
        access: Access,
        stats: Arc<Stats>,
        publishers: Arc<Publishers>,
        started_ns: i64,
    ) -> Arc<Self> {
        let n = access.max_in_flight;
        Arc::new(Self {
            operator,
            access,
            stats,
            publishers,
            general: Arc::new(Semaphore::new(n)),
            stop: Arc::new(Semaphore::new(n)),
            started_ns,
            ignored_log: LogLimit::default(),
            busy_log: LogLimit::default(),
        })
    }

    fn authenticated(&self) -> bool {
        matches!(self.access.authentication, Authentication::Enclave(_))
    }

    fn guard(&self) -> ReplayGuard {
        ReplayGuard::new(self.started_ns, self.access.max_age_s)
    }

    /// Judges a request sample; false: ignored (counted and, rate-limited, logged).
    fn admit(
        &self,
        guard: &mut ReplayGuard,
        name: &str,
        writer: &[u8; 16],
        seq: i64,
        source: Option<i64>,
    ) -> bool {
        let s = &self.stats;
        s.requests.fetch_add(1, Ordering::Relaxed);
        match guard.admit(*writer, seq, source, now_ns()) {
            Ok(a) => {
                s.dropped.fetch_add(a.skipped, Ordering::Relaxed);
                true
            }
            Err(why) => {
                s.ignored.fetch_add(1, Ordering::Relaxed);
                s.dropped.fetch_add(1, Ordering::Relaxed);
                if self.ignored_log.allow() {
                    tracing::warn!(
                        service = name,
                        participant = %participant_guid(writer),
                        sequence = seq,
                        "ROS 2 request ignored: {why} (further ones this second are only counted)"
                    );
                }
                false
            }
        }
    }

    /// Serves `service`, whose requests decode to a [`Call`] with `call`.
    pub async fn serve<Q: DeserializeOwned + Send + Sync + 'static>(
        self: Arc<Self>,
        name: &'static str,
        service: Service<Q, TriggerResponse>,
        call: impl Fn(&Q) -> Call,
    ) {
        let service = Arc::new(service);
        let mut guard = self.guard();
        loop {
            let request: Request<Q> = match service.requests.next().await {
                Ok(r) => r,
                Err(e) => {
                    self.stats.requests.fetch_add(1, Ordering::Relaxed);
                    self.stats.dropped.fetch_add(1, Ordering::Relaxed);
                    if self.ignored_log.allow() {
                        tracing::warn!(service = name, "undecodable ROS 2 request: {e}");
                    }
                    continue;
                }
            };
            if !self.admit(
                &mut guard,
                name,
                &request.writer,
                request.sequence_number,
                request.source_ns,
            ) {
                continue;
            }
            let c = call(&request.body);
            let permits = if c == Call::Trigger(Trigger::Stop) {
                &self.stop
            } else {
                &self.general
            };
            let Ok(permit) = permits.clone().try_acquire_owned() else {
                self.stats.busy.fetch_add(1, Ordering::Relaxed);
                if self.busy_log.allow() {
                    tracing::warn!(
                        service = name,
                        participant = %request.participant(),
                        "ROS 2 request answered busy: {} commands in flight toward the service \
                         (ros2.max_requests_in_flight; further ones this second are only counted)",
                        self.access.max_in_flight
                    );
                }
                let busy = TriggerResponse {
                    success: false,
                    message: format!(
                        "busy: the bridge has {} `{}`-class commands in flight toward the \
                         service (ros2.max_requests_in_flight); try again",
                        self.access.max_in_flight,
                        if c == Call::Trigger(Trigger::Stop) {
                            "stop"
                        } else {
                            "non-stop"
                        }
                    ),
                };
                self.reply(&service, name, request.id, busy).await;
                continue;
            };
            let this = self.clone();
            let service = service.clone();
            tokio::spawn(async move {
                let _permit = permit;
                let caller = request.caller(this.authenticated());
                let response = this.execute(c, caller).await;
                this.reply(&service, name, request.id, response).await;
            });
        }
    }

    async fn reply<Q: 'static>(
        &self,
        service: &Service<Q, TriggerResponse>,
        name: &str,
        id: ros2_client::RmwRequestId,
        response: TriggerResponse,
    ) {
        match service.replies.send(id, response).await {
            Ok(()) => {
                self.stats.answered.fetch_add(1, Ordering::Relaxed);
            }
            Err(e) => {
                self.stats.dropped.fetch_add(1, Ordering::Relaxed);
                if self.busy_log.allow() {
                    tracing::warn!(service = name, "ROS 2 reply not sent: {e}");
                }
            }
        }
    }

    /// Runs `call` for `caller` (logged with the participant) and makes its response.
    pub async fn execute(&self, call: Call, caller: Ros2Caller) -> TriggerResponse {
        let participant = caller.participant.clone();
        let authenticated = caller.authenticated;
        if call == Call::Arm(false) && !self.access.allow_disarm {
            self.stats.refused.fetch_add(1, Ordering::Relaxed);
            tracing::warn!(
                service = "collision_arm",
                %participant,
                authenticated,
                "ROS 2 command refused: disarming is not enabled (ros2.allow_disarm)"
            );
            return TriggerResponse {
                success: false,
                message: "refused: disarming the collision monitor through ROS 2 is not enabled \
                          (ros2.allow_disarm)"
                    .into(),
            };
        }
        tracing::info!(
            service = call.name(),
            %participant,
            authenticated,
            arm = matches!(call, Call::Arm(true)),
            "ROS 2 command"
        );
        self.stats.executed.fetch_add(1, Ordering::Relaxed);
        let response = match call {
            Call::Trigger(t) => {
                let publishers = self.publishers.clone();
                self.operator
                    .trigger(t, caller, |e: &Event| {
                        if let Ok(data) = serde_json::to_string(e) {
                            publishers.progress.publish(std_msgs::String { data });
                        }
                    })
                    .await
            }
            Call::Arm(arm) => self.operator.collision_arm(arm, caller).await,
        };
        if !response.success {
            tracing::warn!(service = call.name(), %participant, "ROS 2 command failed: {}", response.message);
        }
        response
    }

    /// Serves the `apply_payload` subscription, one message at a time.
    pub async fn apply_payload(self: Arc<Self>, subscription: Subscription<Inertia>) {
        let mut guard = self.guard();
        loop {
            let (m, info) = match subscription.async_take().await {
                Ok(r) => r,
                Err(e) => {
                    self.stats.requests.fetch_add(1, Ordering::Relaxed);
                    self.stats.dropped.fetch_add(1, Ordering::Relaxed);
                    if self.ignored_log.allow() {
                        tracing::warn!("undecodable apply_payload: {e:?}");
                    }
                    continue;
                }
            };
            let writer = info.publisher_gid().to_bytes16();
            let source = info.source_timestamp().map(|t| t.to_nanos());
            if !self.admit(
                &mut guard,
                "apply_payload",
                &writer,
                info.sequence_number(),
                source,
            ) {
                continue;
            }
            let participant = participant_guid(&writer);
            let caller = Ros2Caller {
                participant: participant.clone(),
                authenticated: self.authenticated(),
            };
            match crate::bridge::check_apply_payload(&m) {
                Err(reason) => {
                    self.stats.refused.fetch_add(1, Ordering::Relaxed);
                    tracing::warn!(%participant, "apply_payload refused: {reason}");
                }
                Ok((mass, com)) => {
                    tracing::info!(
                        service = "apply_payload",
                        %participant,
                        authenticated = caller.authenticated,
                        mass,
                        ?com,
                        "ROS 2 command"
                    );
                    self.stats.executed.fetch_add(1, Ordering::Relaxed);
                    match self.operator.apply_payload(mass, com, caller).await {
                        Ok(_) => tracing::info!(%participant, mass, ?com, "apply_payload: applied"),
                        Err(e) => {
                            tracing::warn!(%participant, "apply_payload refused by the service: {e}")
                        }
                    }
                }
            }
        }
    }
}
