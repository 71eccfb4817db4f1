//! Input from the service: its iceoryx2 publications (state, collision, payload), read on a
//! thread of their own (iceoryx2 ports are not `Send`) and handed on as [`Input`]s.
//!
//! The bridge opens the services exactly as the service does (`open_service`, same history and
//! buffer sizes), so either may start first. When no state arrives for [`REOPEN_AFTER`] (the
//! service stopped, restarted or crashed), the subscriptions are dropped and opened again.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use fri_api::ipc::{CollisionMessage, PayloadEstimate, RobotState};
use fri_service::ipc::publisher::open_service;
use fri_service::ipc::{IpcError, IpcNames};
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;

/// Silence of the state publication after which the subscriptions are opened again.
pub const REOPEN_AFTER: Duration = Duration::from_secs(2);
/// Pause between polls of the subscriptions (the service publishes every 1 ms cycle; the
/// state subscriber buffers 16 samples).
pub const POLL: Duration = Duration::from_micros(500);
/// Pause after a failed open.
const RETRY: Duration = Duration::from_millis(200);

/// One message from the service.
// Passed by value to the sink once per message: boxing the state would allocate every cycle.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Input {
    /// A robot state (every cycle).
    State(RobotState),
    /// The onset of a collision detection.
    Collision(CollisionMessage),
    /// A payload estimate, applied or cleared payload.
    Payload(PayloadEstimate),
    /// The subscriptions were (re)opened (at start and after a silence).
    Opened,
}

/// The three subscriptions on one node. Not `Send`.
pub struct Subscriptions {
    // Field order = drop order: ports before the services before the node.
    state: Subscriber<ipc::Service, RobotState, ()>,
    collision: Subscriber<ipc::Service, CollisionMessage, ()>,
    payload: Subscriber<ipc::Service, PayloadEstimate, ()>,
    _services: (
        fri_service::ipc::publisher::PubSubService<RobotState>,
        fri_service::ipc::publisher::PubSubService<CollisionMessage>,
        fri_service::ipc::publisher::PubSubService<PayloadEstimate>,
    ),
    _node: Node<ipc::Service>,
}

impl std::fmt::Debug for Subscriptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Subscriptions").finish_non_exhaustive()
    }
}

fn setup(what: &'static str) -> impl Fn(String) -> IpcError {
    move |message| IpcError::Setup { what, message }
}

impl Subscriptions {
    /// Opens (or creates) the service's three publications with the service's own settings.
    pub fn open(names: &IpcNames) -> Result<Self, IpcError> {
        let node = names.node()?;
        let state_service = open_service::<RobotState>(&node, &names.state(), 1)?;
        let collision_service = open_service::<CollisionMessage>(&node, &names.collision(), 16)?;
        let payload_service = open_service::<PayloadEstimate>(&node, &names.payload(), 4)?;
        let state = state_service
            .subscriber_builder()
            .create()
            .map_err(|e| setup("state subscriber")(format!("{e:?}")))?;
        let collision = collision_service
            .subscriber_builder()
            .create()
            .map_err(|e| setup("collision subscriber")(format!("{e:?}")))?;
        let payload = payload_service
            .subscriber_builder()
            .create()
            .map_err(|e| setup("payload subscriber")(format!("{e:?}")))?;
        Ok(Self {
            state,
            collision,
            payload,
            _services: (state_service, collision_service, payload_service),
            _node: node,
        })
    }

    /// Hands every waiting message to `sink` (events first, then states, each in order);
    /// returns the number of states.
    pub fn drain(&self, sink: &mut impl FnMut(Input)) -> Result<usize, IpcError> {
        let recv = |what: &'static str| {
            move |e: iceoryx2::port::ReceiveError| IpcError::Setup {
                what,
                message: format!("receive: {e:?}"),
            }
        };
        while let Some(s) = self.collision.receive().map_err(recv("collision"))? {
            sink(Input::Collision(*s.payload()));
        }
        while let Some(s) = self.payload.receive().map_err(recv("payload"))? {
            sink(Input::Payload(*s.payload()));
        }
        let mut states = 0;
        while let Some(s) = self.state.receive().map_err(recv("state"))? {
            sink(Input::State(*s.payload()));
            states += 1;
        }
        Ok(states)
    }
}

/// Reads the service's publications until `stop` is set, reopening them after a silence of
/// [`REOPEN_AFTER`]; runs on the calling thread.
pub fn run(names: &IpcNames, stop: &AtomicBool, mut sink: impl FnMut(Input)) {
    let mut subs: Option<Subscriptions> = None;
    let mut last_state = Instant::now();
    let mut reported_failure = false;
    while !stop.load(Ordering::Relaxed) {
        let Some(s) = &subs else {
            match Subscriptions::open(names) {
                Ok(s) => {
                    tracing::info!(prefix = %names.service_prefix, "iceoryx2 subscriptions open");
                    subs = Some(s);
                    last_state = Instant::now();
                    reported_failure = false;
                    sink(Input::Opened);
                }
                Err(e) => {
                    if !reported_failure {
                        tracing::warn!("iceoryx2: {e}; retrying");
                        reported_failure = true;
                    }
                    std::thread::sleep(RETRY);
                }
            }
            continue;
        };
        match s.drain(&mut sink) {
            Ok(0) if last_state.elapsed() > REOPEN_AFTER => {
                tracing::info!(
                    "no state from the service for {} s: re-opening the subscriptions",
                    REOPEN_AFTER.as_secs()
                );
                subs = None;
            }
            Ok(0) => {}
            Ok(_) => last_state = Instant::now(),
            Err(e) => {
                tracing::warn!("iceoryx2: {e}; re-opening");
                subs = None;
            }
        }
        std::thread::sleep(POLL);
    }
}

/// The input thread: [`run`] on a new thread, stopped by the returned flag.
pub fn spawn(
    names: IpcNames,
    sink: impl FnMut(Input) + Send + 'static,
) -> std::io::Result<(Arc<AtomicBool>, std::thread::JoinHandle<()>)> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    let handle = std::thread::Builder::new()
        .name("fri-ros2-ipc".into())
        .spawn(move || run(&names, &flag, sink))?;
    Ok((stop, handle))
}

/// Picks the states to publish at a rate below the controller's: the first state of each slot
/// of `every` controller cycles (by the state's controller time, so a lost cycle does not shift
/// the rate; a time that goes back, a service restart, starts over).
#[derive(Debug, Clone)]
pub struct Decimator {
    every: u64,
    cycle_s: f64,
    last_slot: Option<u64>,
}

impl Decimator {
    /// One state per `every` cycles of `cycle_s` s.
    pub fn new(every: u32, cycle_s: f64) -> Self {
        Self {
            every: u64::from(every.max(1)),
            cycle_s,
            last_slot: None,
        }
    }

    /// Forgets the last slot (the next state is taken).
    pub fn reset(&mut self) {
        self.last_slot = None;
    }

    /// Whether the state at controller time `time_s` is published.
    pub fn take(&mut self, time_s: f64) -> bool {
        if !time_s.is_finite() || time_s < 0.0 {
            return false;
        }
        let slot = (time_s / self.cycle_s).round() as u64 / self.every;
        match self.last_slot {
            Some(last) if slot == last => false,
            _ => {
                self.last_slot = Some(slot);
                true
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimator_keeps_one_state_per_slot_despite_lost_cycles_and_restarts() {
        let mut d = Decimator::new(4, 0.001);
        let taken: Vec<u32> = (1..=16)
            .filter(|&k| k != 8) // a lost cycle at a slot's start
            .filter(|&k| d.take(f64::from(k) * 0.001))
            .collect();
        assert_eq!(taken, vec![1, 4, 9, 12, 16]);
        // Time goes back (the service restarted): the first state is taken.
        assert!(d.take(0.001));
        assert!(!d.take(0.002));
        assert!(!d.take(f64::NAN));
        let mut every = Decimator::new(1, 0.001);
        assert!((1..=10).all(|k| every.take(f64::from(k) * 0.001)));
    }
}
