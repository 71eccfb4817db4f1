//! The audit trail as log lines (issue 20 item 9): every safety-relevant change is one line of
//! target `fri_service::audit` naming its origin — the configuration at start, the service for
//! what the loop does on its own (collisions, holds and releases by the reaction), the operator's
//! uid for requests — and a flood of requests writes at most BURST + RATE × t of its requests'
//! lines, with the suppressed count reported, and never drops a change among them.
//!
//! The log is captured by this test binary's global tracing subscriber; the tests take turns
//! (one service at a time) so that each sees only its own lines.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::sync::{Arc, Mutex, MutexGuard, OnceLock};
use std::time::{Duration, Instant};

use common::*;
use fri_api::protocol::{CollisionAction, Command, ErrorCode, Reply};
use fri_service::audit::{BURST, RATE_PER_S};
use fri_service::config::ReactionMode;
use mock_robot::ServerConfig;

/// The audit lines written so far (this process).
fn log() -> &'static Arc<Mutex<Vec<u8>>> {
    static LOG: OnceLock<Arc<Mutex<Vec<u8>>>> = OnceLock::new();
    LOG.get_or_init(|| {
        let log = Arc::new(Mutex::new(Vec::new()));
        let sink = log.clone();
        let subscriber = tracing_subscriber::fmt()
            .with_env_filter(tracing_subscriber::EnvFilter::new(
                "fri_service::audit=info",
            ))
            .with_ansi(false)
            .with_writer(move || Capture(sink.clone()))
            .finish();
        tracing::subscriber::set_global_default(subscriber).unwrap();
        log
    })
}

struct Capture(Arc<Mutex<Vec<u8>>>);

impl std::io::Write for Capture {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// One test at a time, with the log emptied.
fn exclusive() -> MutexGuard<'static, ()> {
    static TURN: Mutex<()> = Mutex::new(());
    let turn = TURN.lock().unwrap_or_else(|p| p.into_inner());
    log().lock().unwrap().clear();
    turn
}

fn lines() -> Vec<String> {
    String::from_utf8_lossy(&log().lock().unwrap())
        .lines()
        .map(str::to_owned)
        .collect()
}

/// The audit lines of change `what` (the JSON `"what"` tag).
fn of(lines: &[String], what: &str) -> Vec<String> {
    let tag = format!("\"what\":\"{what}\"");
    lines.iter().filter(|l| l.contains(&tag)).cloned().collect()
}

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap()
}

/// Five contacts, each reacted to by the `pause` reaction: five collision lines, five holds and
/// five releases by the service, each with origin `service`; the configuration's own settings at
/// start with origin `configuration`.
#[test]
fn five_collisions_are_five_lines_naming_the_service() {
    let _turn = exclusive();
    runtime().block_on(async {
        let dir = tempfile::tempdir().unwrap();
        let mut config = armed_to_stop(test_config(dir.path()));
        config.iceoryx2.enabled = false;
        config.reaction.policy = ReactionMode::Pause;
        config.reaction.pause_s = 0.5;
        let h = Harness::start(config, dir).await;
        let mut sim_config = sim(false, 31);
        sim_config.contacts = [1.0, 2.5, 4.0, 5.5, 7.0]
            .into_iter()
            .map(push_on_link_4)
            .collect();
        sim_config.duration_s = Some(9.0);
        let driver =
            mock_robot::spawn_new(sim_config, ServerConfig::loopback(h.fri, lockstep())).unwrap();
        let mut c = h.client().await;
        wait_connected(&mut c).await;
        let events = collect_watch(h.client().await, None).await;
        // The whole scenario (lockstep: as fast as the service answers).
        while !driver.is_finished() {
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        drop(driver.join());
        // The watch and the log are written by other threads than this one: wait for the
        // fifth release (bounded, a missing line fails).
        let deadline = Instant::now() + Duration::from_secs(20);
        while of(&lines(), "released-by-service").len() < 5 && Instant::now() < deadline {
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        let lines = lines();
        let watched = collision_times(&events).len();
        let collisions = of(&lines, "collision");
        assert_eq!(watched, 5, "{:?}", events.lock().unwrap());
        assert_eq!(collisions.len(), 5, "{lines:#?}");
        for what in ["collision", "held-by-service", "released-by-service"] {
            let found = of(&lines, what);
            assert_eq!(found.len(), 5, "{what}: {lines:#?}");
            assert!(
                found.iter().all(|l| l.contains("origin=service")),
                "{found:#?}"
            );
        }
        assert!(
            of(&lines, "held-by-service")
                .iter()
                .all(|l| l.contains("\"kind\":\"collision\"")),
            "{lines:#?}"
        );
        // The configuration's settings at start, once each, before anything else.
        for what in ["monitor-configured", "armed"] {
            let found = of(&lines, what);
            assert_eq!(found.len(), 1, "{what}: {lines:#?}");
            assert!(found[0].contains("origin=configuration"), "{found:?}");
        }
        h.stop().await;
    });
}

/// Issue 34 item 2: 10 000 refused requests (`apply-payload` with a centre of mass beyond the
/// flange's reach) as fast as the socket takes them, with one `collision disarm` in their
/// middle. Every request is a `command` record; at most BURST + RATE × t of those lines are
/// written, and the count of the others is reported by a line of its own once the flood ends;
/// the disarm's change is written however empty the requests' budget is (before, one bucket for
/// every record turned it into a count): written + reported = recorded.
#[test]
fn a_flood_of_refused_requests_never_hides_the_disarm_among_them() {
    let _turn = exclusive();
    runtime().block_on(async {
        let dir = tempfile::tempdir().unwrap();
        let mut config = test_config(dir.path());
        config.iceoryx2.enabled = false;
        let h = Harness::start(config, dir).await;
        let driver = mock_robot::spawn_new(sim(false, 37), ServerConfig::loopback(h.fri, lockstep()))
            .unwrap();
        let mut c = h.client().await;
        wait_connected(&mut c).await;
        let audit = h.service.service().unwrap().core.audit().clone();
        let before = lines().len();
        let recorded_before = audit.recorded();
        const N: u64 = 10_000;
        let started = Instant::now();
        // Pipelined on one connection, at most 16 in flight (the per-connection limit).
        let (mut ok, mut sent, mut answered) = (0u64, 0u64, 0u64);
        while answered < N {
            while sent < N && sent - answered < 16 {
                let line = if sent == N / 2 {
                    format!("{{\"id\":{sent},\"cmd\":\"collision\",\"action\":\"disarm\"}}\n")
                } else {
                    format!("{{\"id\":{sent},\"cmd\":\"apply-payload\",\"mass\":1.0,\"com\":[0.0,0.0,0.9]}}\n")
                };
                c.send_raw(line.as_bytes()).await.unwrap();
                sent += 1;
            }
            match c.next_reply().await.unwrap() {
                Reply::Ok { .. } => ok += 1,
                Reply::Err { error, .. } => assert!(
                    matches!(error.code, ErrorCode::Busy | ErrorCode::InvalidArguments),
                    "{error:?}"
                ),
                Reply::Event { .. } => continue,
            }
            answered += 1;
        }
        let flood_s = started.elapsed().as_secs_f64();
        // The disarm was accepted (not `busy`): its line is written, at WARN.
        assert_eq!(ok, 1, "the disarm");
        let disarmed = of(&lines()[before..], "disarmed");
        assert_eq!(disarmed.len(), 1, "the disarm's line");
        assert!(disarmed[0].contains("WARN"), "{disarmed:?}");
        let commands = of(&lines()[before..], "command").len();
        let bound = BURST + RATE_PER_S * flood_s;
        assert!(
            (commands as f64) <= bound + 1.0,
            "{commands} request lines in {flood_s:.2} s (bound {bound:.0})"
        );
        let recorded = audit.recorded() - recorded_before;
        // Once the flood ends, the suppressed count is reported by itself (within a second or
        // two; bounded wait, a missing report fails).
        let deadline = Instant::now() + Duration::from_secs(10);
        let report = loop {
            let l = lines();
            if let Some(r) = l[before..]
                .iter()
                .find(|l| l.contains("suppressed by the volume bound"))
            {
                break r.clone();
            }
            assert!(Instant::now() < deadline, "no suppression report");
            tokio::time::sleep(Duration::from_millis(50)).await;
        };
        let written = lines()[before..]
            .iter()
            .filter(|l| l.contains("audit origin="))
            .count() as u64;
        let suppressed: u64 = lines()[before..]
            .iter()
            .filter_map(|l| l.split("suppressed=").nth(1))
            .filter_map(|s| s.split_whitespace().next())
            .filter_map(|n| n.parse::<u64>().ok())
            .sum();
        eprintln!(
            "{N} requests ({ok} accepted) in {flood_s:.2} s: {recorded} records, {written} lines written ({commands} of requests), {suppressed} suppressed; report: {report}"
        );
        assert!(suppressed > 0, "{report}");
        assert_eq!(written + suppressed, recorded, "{report}");
        drop(driver.join());
        h.stop().await;
    });
}

/// The operator's own changes name the operator's uid (`collision disarm` over the socket).
#[test]
fn an_operator_change_names_the_uid() {
    let _turn = exclusive();
    runtime().block_on(async {
        let dir = tempfile::tempdir().unwrap();
        let mut config = test_config(dir.path());
        config.iceoryx2.enabled = false;
        let h = Harness::start(config, dir).await;
        let mut c = h.client().await;
        let disarm = Command::Collision {
            action: CollisionAction::Disarm,
            thresholds: None,
            gains: None,
            reaction: None,
            pause_s: None,
        };
        // No controller: the loop's queue still takes it.
        call(&mut c, disarm).await.unwrap();
        // SAFETY: no preconditions.
        let uid = unsafe { libc::geteuid() };
        let who = format!("origin=operator uid {uid} (pid {})", std::process::id());
        let l = lines();
        let disarmed = of(&l, "disarmed");
        assert_eq!(disarmed.len(), 1, "{l:#?}");
        assert!(
            disarmed[0].contains(&who) && disarmed[0].contains("WARN"),
            "{disarmed:?}"
        );
        h.stop().await;
    });
}

/// A `stop` on the stop socket (issue 20 item 6) is audited like one on the operator socket:
/// `command` then `stopped`, naming the operator's uid and pid.
#[test]
fn a_stop_on_the_stop_socket_names_the_uid() {
    let _turn = exclusive();
    runtime().block_on(async {
        let dir = tempfile::tempdir().unwrap();
        let mut config = test_config(dir.path());
        config.iceoryx2.enabled = false;
        let stop_socket = config.operator.stop_socket_path();
        let h = Harness::start(config, dir).await;
        // No controller: the stop is latched and answered as `silent`.
        let mut c = fri_api::client::Client::connect(&stop_socket)
            .await
            .unwrap();
        let reply = call(&mut c, Command::Stop).await.unwrap();
        assert_eq!(reply["stopped"], true, "{reply}");
        // SAFETY: no preconditions.
        let uid = unsafe { libc::geteuid() };
        let who = format!("origin=operator uid {uid} (pid {})", std::process::id());
        let l = lines();
        let stopped = of(&l, "stopped");
        assert_eq!(stopped.len(), 1, "{l:#?}");
        assert!(stopped[0].contains(&who), "{stopped:?}");
        assert!(
            of(&l, "command")
                .iter()
                .any(|c| c.contains("stop") && c.contains(&who)),
            "{l:#?}"
        );
        h.stop().await;
    });
}
