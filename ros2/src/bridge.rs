//! The running bridge: the input thread publishing what the service sends, and the tasks
//! serving ROS 2 calls, the `apply_payload` subscription and the diagnostics.

use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use fri_ros_msgs::geometry_msgs::{Inertia, InertiaStamped};
use fri_ros_msgs::std_msgs;

use crate::access::{Access, Authentication};
use crate::commands::{Call, Commands};
use crate::config::{BridgeConfig, JOINTS};
use crate::dds::{DdsError, Publishers, Ros};
use crate::diagnostics::{CommandAccess, Stats};
use crate::ipc::{Decimator, Input};
use crate::operator::Operator;
use crate::srv::{SetBoolRequest, TriggerRequest};

/// Errors that end the bridge.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// DDS setup failed.
    #[error(transparent)]
    Dds(#[from] DdsError),
    /// The input thread could not be started.
    #[error("starting the iceoryx2 input thread: {0}")]
    Thread(std::io::Error),
}

/// The newest applied payload the bridge published: mass (kg) and centre of mass (m).
type LastPayload = Arc<Mutex<Option<(f64, [f64; 3])>>>;

/// Publishes `p` on `<ns>/payload` unless it is the one published last.
fn publish_payload(publishers: &Publishers, last: &LastPayload, p: InertiaStamped) {
    let key = (
        p.inertia.m,
        [p.inertia.com.x, p.inertia.com.y, p.inertia.com.z],
    );
    let mut guard = last.lock().unwrap_or_else(|e| e.into_inner());
    if *guard != Some(key) {
        *guard = Some(key);
        drop(guard);
        publishers.payload.publish(p);
    }
}

/// What the input thread does with each message of the service.
struct Sink {
    publishers: Arc<Publishers>,
    names: [String; JOINTS],
    decimator: Decimator,
    stats: Arc<Stats>,
    payload_frame: String,
    last_payload: LastPayload,
}

impl Sink {
    fn handle(&mut self, input: Input) {
        match input {
            Input::State(s) => {
                self.stats.states.fetch_add(1, Ordering::Relaxed);
                self.stats.last_cycle.store(s.cycle, Ordering::Relaxed);
                if self.decimator.take(s.time_s) {
                    let m = fri_service::ros_messages::joint_states(&s, &self.names);
                    self.publishers.joint_states.publish(m.measured);
                    self.publishers.external_torque.publish(m.external_torque);
                    self.publishers
                        .controller_gravity
                        .publish(m.controller_gravity);
                    self.stats.joint_states.fetch_add(1, Ordering::Relaxed);
                }
            }
            Input::Collision(c) => {
                self.stats.collisions.fetch_add(1, Ordering::Relaxed);
                self.publishers
                    .collision
                    .publish(fri_service::ros_messages::collision(&c, &self.names));
                if let Some(w) = fri_service::ros_messages::contact_wrench(&c) {
                    self.publishers.contact_wrench.publish(w);
                }
            }
            Input::Payload(p) => {
                match fri_service::ros_messages::applied_payload(&p, &self.payload_frame) {
                    Some(applied) => publish_payload(&self.publishers, &self.last_payload, applied),
                    None => self.publishers.payload_estimate.publish(
                        fri_service::ros_messages::payload(
                            p.time_s,
                            p.mass,
                            p.com,
                            &self.payload_frame,
                        ),
                    ),
                }
            }
            Input::Opened => {
                self.stats.opened.fetch_add(1, Ordering::Relaxed);
                // A restarted service counts time from zero again.
                self.decimator.reset();
            }
        }
    }
}

/// Why an `apply_payload` message is refused before it reaches the service.
pub fn check_apply_payload(m: &Inertia) -> Result<(f64, [f64; 3]), String> {
    let com = [m.com.x, m.com.y, m.com.z];
    if !m.m.is_finite() || m.m < 0.0 {
        return Err(format!(
            "mass {} kg is not a finite non-negative number",
            m.m
        ));
    }
    if com.iter().any(|c| !c.is_finite()) {
        return Err(format!("centre of mass {com:?} m is not finite"));
    }
    Ok((m.m, com))
}

/// Logs who may command: nobody (INFO), authenticated participants (INFO), or anyone (WARN).
fn log_access(access: &Access) {
    let names: Vec<&str> = access.commands.iter().map(|c| c.as_str()).collect();
    match &access.authentication {
        Authentication::ReadOnly => {
            tracing::info!("read-only: no command enabled (ros2.commands)");
        }
        Authentication::Enclave(dir) => tracing::info!(
            commands = ?names,
            enclave = %dir.display(),
            allow_disarm = access.allow_disarm,
            "commands for participants authenticated by DDS Security"
        ),
        Authentication::Unauthenticated => tracing::warn!(
            commands = ?names,
            allow_disarm = access.allow_disarm,
            "UNAUTHENTICATED commands: ANY DDS participant on the domain may call them \
             (ros2.allow_unauthenticated_commands = true)"
        ),
    }
}

/// Runs the bridge until `shutdown` completes.
pub async fn run(
    config: BridgeConfig,
    shutdown: impl std::future::Future<Output = ()>,
) -> Result<(), BridgeError> {
    // Requests issued before this instant are never executed (a transient-local request
    // written while the bridge was down, a replay).
    let started_ns = crate::replay::now_ns();
    log_access(&config.access);
    let Ros {
        mut node,
        publishers,
        servers,
        context,
        sockets_bound_to,
    } = Ros::new(&config)?;
    let publishers = Arc::new(publishers);
    publishers.robot_description.publish(std_msgs::String {
        data: config.description.urdf.clone(),
    });
    let stats = Arc::new(Stats::default());
    let last_payload: LastPayload = Arc::new(Mutex::new(None));
    let mut sink = Sink {
        publishers: publishers.clone(),
        names: config.joint_names.clone(),
        decimator: Decimator::new(config.joint_states_every, config.service.fri.cycle_s),
        stats: stats.clone(),
        payload_frame: config.ros2.payload_frame.clone(),
        last_payload: last_payload.clone(),
    };
    let (stop, input) = crate::ipc::spawn(config.ipc_names(), move |i| sink.handle(i))
        .map_err(BridgeError::Thread)?;
    let operator = Operator::new(
        config.service.operator.socket.clone(),
        config.service.operator.stop_socket_path(),
    );
    let mut tasks = tokio::task::JoinSet::new();
    match node.spinner() {
        Ok(spinner) => {
            tasks.spawn(async move {
                if let Err(e) = spinner.spin().await {
                    tracing::warn!("ROS 2 node spinner: {e:?}");
                }
            });
        }
        Err(e) => tracing::warn!("ROS 2 node spinner: {e:?}"),
    }
    let commands = Commands::new(
        operator.clone(),
        config.access.clone(),
        stats.clone(),
        publishers.clone(),
        started_ns,
    );
    for (trigger, service) in servers.triggers {
        tasks.spawn(commands.clone().serve(
            trigger.service_name(),
            service,
            move |_: &TriggerRequest| Call::Trigger(trigger),
        ));
    }
    if let Some(service) = servers.collision_arm {
        tasks.spawn(
            commands
                .clone()
                .serve("collision_arm", service, |r: &SetBoolRequest| {
                    Call::Arm(r.data)
                }),
        );
    }
    if let Some(subscription) = servers.apply_payload {
        tasks.spawn(commands.clone().apply_payload(subscription));
    }
    let access = CommandAccess {
        commands: config
            .access
            .commands
            .iter()
            .map(|c| c.as_str().to_owned())
            .collect(),
        unauthenticated: config.access.unauthenticated(),
        secured: matches!(config.access.authentication, Authentication::Enclave(_)),
        sockets_bound_to,
    };
    {
        let operator = operator.clone();
        let publishers = publishers.clone();
        let period = Duration::from_secs_f64(1.0 / config.ros2.diagnostics_hz);
        let prefix = config.ros2.namespace.trim_start_matches('/').to_owned();
        let frame = config.ros2.payload_frame.clone();
        tasks.spawn(async move {
            let mut tick = tokio::time::interval(period);
            tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
            loop {
                tick.tick().await;
                let status = operator.status().await;
                if let Ok(s) = &status {
                    // The service's applied payload: right after the bridge or the service
                    // (re)started, and whenever it changed without an iceoryx2 message.
                    let p = fri_service::ros_messages::status_payload(
                        s.payload.as_ref(),
                        s.time_s.unwrap_or(0.0),
                        &frame,
                    );
                    publish_payload(&publishers, &last_payload, p);
                }
                let report = crate::diagnostics::report(&prefix, &status, &stats, &access);
                publishers.diagnostics_ns.publish(report.clone());
                publishers.diagnostics.publish(report);
            }
        });
    }
    shutdown.await;
    tasks.shutdown().await;
    stop.store(true, Ordering::Relaxed);
    if input.join().is_err() {
        tracing::warn!("the iceoryx2 input thread panicked");
    }
    drop(publishers);
    drop(node);
    drop(context);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use fri_ros_msgs::geometry_msgs::Vector3;

    #[test]
    fn nan_or_negative_masses_and_non_finite_centres_are_refused() {
        let ok = Inertia {
            m: 1.5,
            com: Vector3::from_array([0.0, 0.0, 0.1]),
            ..Inertia::default()
        };
        assert_eq!(check_apply_payload(&ok).unwrap(), (1.5, [0.0, 0.0, 0.1]));
        for m in [f64::NAN, -0.1, f64::INFINITY] {
            let e = check_apply_payload(&Inertia { m, ..ok }).unwrap_err();
            assert!(e.contains("mass"), "{e}");
        }
        let bad = Inertia {
            com: Vector3::from_array([0.0, f64::NAN, 0.0]),
            ..ok
        };
        assert!(check_apply_payload(&bad).unwrap_err().contains("centre"));
    }
}
