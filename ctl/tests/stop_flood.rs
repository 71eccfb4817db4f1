//! Issue 20 item 6, the attack: every connection slot of the operator socket held by idle
//! clients, threads cycling its reserved over-limit slots, and (beyond the reported attack) a
//! flood of idle connections on the stop socket too. Every `fri-ctl stop` (the real binary)
//! must still latch a stop. Whole daemon in-process, mock robot in lockstep over UDP loopback.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;

use fri_api::protocol::{CollisionAction, Command, ErrorCode};
use fri_service::testkit::{InProcess, local_config};
use mock_robot::{ServerConfig, SimulationConfig, TimingMode};
use serde_json::Value;

/// The operator socket's connection limit (operator.max_clients, default).
const CLIENTS: usize = 64;
/// Threads cycling the operator socket's 4 over-limit slots (the reported attack used 6).
const CYCLERS: usize = 6;
/// Threads holding idle connections on the stop socket (its 32 reading slots, and more).
const STOP_FLOODERS: usize = 48;
/// `fri-ctl stop` runs under the attack (the reported attack: 8 of 8 failed).
const STOPS: usize = 8;

/// What the attacking threads share.
#[derive(Default)]
struct Attack {
    done: AtomicBool,
    /// Operator connections holding a client slot (status answered).
    holding: AtomicUsize,
    /// Connections refused with `busy` on the operator socket.
    busy: AtomicUsize,
    /// Connections opened on the stop socket.
    stop_socket_opened: AtomicUsize,
}

/// Reads from `c` until the server closes it or the attack ends; whether a `busy` line came.
fn hold(c: UnixStream, attack: &Attack) -> bool {
    c.set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    let mut r = BufReader::new(c);
    let mut line = String::new();
    let mut busy = false;
    loop {
        match r.read_line(&mut line) {
            Ok(0) => return busy,
            Ok(_) => {
                busy |= line.contains("\"busy\"");
                line.clear();
            }
            Err(_) if attack.done.load(Ordering::SeqCst) => return busy,
            Err(_) => {}
        }
    }
}

/// An idle client on the operator socket: takes a client slot (one `status`), then sends
/// nothing; reconnects whenever it is closed.
fn holder(path: PathBuf, attack: Arc<Attack>) {
    while !attack.done.load(Ordering::SeqCst) {
        let Ok(mut c) = UnixStream::connect(&path) else {
            continue;
        };
        let _ = c.write_all(b"{\"id\":1,\"cmd\":\"status\"}\n");
        c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        let mut r = BufReader::new(c.try_clone().unwrap());
        let mut reply = String::new();
        let took_slot = r.read_line(&mut reply).is_ok() && reply.contains("\"ok\":true");
        if took_slot {
            attack.holding.fetch_add(1, Ordering::SeqCst);
        }
        hold(c, &attack);
        if took_slot {
            attack.holding.fetch_sub(1, Ordering::SeqCst);
        }
    }
}

/// Connects to `path` and holds the connection silently until closed, again and again.
fn cycler(path: PathBuf, attack: Arc<Attack>, stop_socket: bool) {
    while !attack.done.load(Ordering::SeqCst) {
        let Ok(c) = UnixStream::connect(&path) else {
            continue;
        };
        if stop_socket {
            attack.stop_socket_opened.fetch_add(1, Ordering::SeqCst);
        }
        if hold(c, &attack) {
            attack.busy.fetch_add(1, Ordering::SeqCst);
        }
    }
}

/// Runs the real `fri-ctl stop` against the operator socket `socket` (the stop socket is found
/// beside it).
fn fri_ctl_stop(socket: &Path) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
        .arg("--socket")
        .arg(socket)
        .arg("stop")
        .env_remove("FRI_SERVICE_STOP_SOCKET")
        .output()
        .unwrap()
}

async fn wait_for(what: &str, mut cond: impl FnMut() -> bool) {
    for _ in 0..3000 {
        if cond() {
            return;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("never: {what}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_fri_ctl_stop_gets_through_a_flood_of_both_sockets() {
    let dir = tempfile::tempdir().unwrap();
    let h = InProcess::start(local_config(dir.path(), "flood"))
        .await
        .unwrap();
    let mode = TimingMode::Lockstep {
        answer_timeout: Duration::from_millis(200),
    };
    let driver = mock_robot::spawn_new(
        SimulationConfig::default(),
        ServerConfig::loopback(h.fri, mode),
    )
    .unwrap();
    // The test's own client holds one of the 64 slots: it checks and resumes.
    let mut c = h.client().await.unwrap();
    let connected = |v: Value| v["connected"].as_bool() == Some(true);
    for _ in 0..500 {
        if connected(c.call(Command::Status, |_, _| {}).await.unwrap().unwrap()) {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    // The stop path is under test, not the detector: disarmed, only the operator's stop holds
    // the arm, and each `resume` shows that the next `stop` latched a new one.
    let disarm = Command::Collision {
        action: CollisionAction::Disarm,
        thresholds: None,
        gains: None,
        reaction: None,
        pause_s: None,
    };
    c.call(disarm, |_, _| {}).await.unwrap().unwrap();

    let attack = Arc::new(Attack::default());
    let stop_socket = fri_api::stop_socket_beside(&h.socket);
    let mut threads = Vec::new();
    for _ in 0..CLIENTS - 1 {
        let (p, a) = (h.socket.clone(), attack.clone());
        threads.push(std::thread::spawn(move || holder(p, a)));
    }
    wait_for("63 idle clients hold the operator socket", || {
        attack.holding.load(Ordering::SeqCst) == CLIENTS - 1
    })
    .await;
    for _ in 0..CYCLERS {
        let (p, a) = (h.socket.clone(), attack.clone());
        threads.push(std::thread::spawn(move || cycler(p, a, false)));
    }
    for _ in 0..STOP_FLOODERS {
        let (p, a) = (stop_socket.clone(), attack.clone());
        threads.push(std::thread::spawn(move || cycler(p, a, true)));
    }
    wait_for(
        "the over-limit slots are taken and the stop socket flooded",
        || {
            attack.busy.load(Ordering::SeqCst) >= 20
                && attack.stop_socket_opened.load(Ordering::SeqCst) >= 200
        },
    )
    .await;
    // The attack is in force: a new operator client is refused (`busy`, or the connection is
    // closed with the refusal before its request is written: "Broken pipe").
    let mut newcomer = fri_api::client::Client::connect(&h.socket).await.unwrap();
    match newcomer.call(Command::Status, |_, _| {}).await {
        Ok(Ok(v)) => panic!("the operator socket is not flooded: {v}"),
        Ok(Err(e)) => assert_eq!(e.code, ErrorCode::Busy, "{e:?}"),
        Err(_) => {}
    }

    let mut latched = 0;
    for k in 0..STOPS {
        let socket = h.socket.clone();
        let out = tokio::task::spawn_blocking(move || fri_ctl_stop(&socket))
            .await
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "stop {k}: {out:?}");
        assert!(text.contains("stop latched"), "stop {k}: {text}");
        let s = c.call(Command::Status, |_, _| {}).await.unwrap().unwrap();
        assert_eq!(s["stopped"], true, "stop {k} did not hold the arm");
        latched += 1;
        let r = c.call(Command::Resume, |_, _| {}).await.unwrap().unwrap();
        assert_eq!(r["stopped"], false, "resume after stop {k}: {r}");
    }
    attack.done.store(true, Ordering::SeqCst);
    for t in threads {
        t.join().unwrap();
    }
    eprintln!(
        "{latched} of {STOPS} `fri-ctl stop` latched a stop; meanwhile {} operator connections \
         were refused busy and {} stop-socket connections opened",
        attack.busy.load(Ordering::SeqCst),
        attack.stop_socket_opened.load(Ordering::SeqCst)
    );
    drop(driver.join());
    h.stop().await.unwrap();
}

/// Where `fri-ctl stop` sends: `--stop-socket` when given; without one, the stop socket beside
/// `--socket`; when nothing is there (a service older than the stop socket, or one configured
/// with another operator.stop_socket), the operator socket, with a warning on stderr.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fri_ctl_stop_uses_the_stop_socket_and_falls_back_to_the_operator_socket() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = local_config(dir.path(), "fallback");
    let elsewhere = dir.path().join("elsewhere.sock");
    config.operator.stop_socket = Some(elsewhere.clone());
    let h = InProcess::start(config).await.unwrap();
    let mode = TimingMode::Lockstep {
        answer_timeout: Duration::from_millis(200),
    };
    let driver = mock_robot::spawn_new(
        SimulationConfig::default(),
        ServerConfig::loopback(h.fri, mode),
    )
    .unwrap();
    let socket = h.socket.clone();
    let run = move |stop_socket: Option<PathBuf>| {
        let socket = socket.clone();
        tokio::task::spawn_blocking(move || {
            let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"));
            cmd.arg("--socket").arg(&socket);
            if let Some(p) = stop_socket {
                cmd.arg("--stop-socket").arg(p);
            }
            cmd.arg("stop")
                .env_remove("FRI_SERVICE_STOP_SOCKET")
                .output()
                .unwrap()
        })
    };
    let out = run(Some(elsewhere)).await.unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{out:?}");
    assert!(!err.contains("warning"), "{err}");
    let out = run(None).await.unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{out:?}");
    assert!(
        err.contains("warning: no stop socket at") && err.contains("op.stop.sock"),
        "{err}"
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("stop latched"));
    drop(driver.join());
    h.stop().await.unwrap();
}
