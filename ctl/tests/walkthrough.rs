//! The README's walkthrough with the simulator ("The same flow with the simulator"), as
//! written: the simulated controller starts unloaded and takes an operator's requests on its
//! control socket; `fri-ctl` tares, declares the payload unknown, the simulator is handed the
//! payload (the grasp), `estimate-payload --apply` estimates it with the monitor armed, and a
//! push on link 4 is detected and holds the arm until `resume`. The service in-process, the
//! simulator in lockstep on its own thread (as the binary runs it, with its control socket),
//! the requests to the control socket the lines `mock-robot control` sends.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use fri_service::testkit::{InProcess, local_config};
use mock_robot::server::{RunCounters, run_with};
use mock_robot::{ServerConfig, Simulation, SimulationConfig, TimingMode};
use serde_json::Value;

/// `fri-ctl ARGS… --socket SOCKET`, off the async runtime: its stdout, or a panic with all of
/// its output when it failed.
async fn fri_ctl(args: &[&str], socket: &Path) -> String {
    let args: Vec<String> = args.iter().map(|s| (*s).to_owned()).collect();
    let socket = socket.to_owned();
    let out = tokio::task::spawn_blocking(move || {
        std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
            .args(&args)
            .arg("--socket")
            .arg(&socket)
            .output()
            .unwrap()
    })
    .await
    .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// `mock-robot control …` as the line it sends to the control socket; the reply's message.
async fn control(socket: &Path, line: &str) -> String {
    let socket = socket.to_owned();
    let sent = line.to_owned();
    let reply = tokio::task::spawn_blocking(move || mock_robot::control::send(&socket, &sent))
        .await
        .unwrap()
        .unwrap();
    assert!(reply.ok, "{line}: {}", reply.message);
    reply.message
}

/// The simulator as the binary runs it without a scenario (unloaded, at the pick pose), with
/// its control socket at `control_path`, in lockstep against `fri`.
fn simulator(
    fri: std::net::SocketAddr,
    control_path: PathBuf,
) -> (Arc<AtomicBool>, std::thread::JoinHandle<()>) {
    let (control_socket, port) = mock_robot::control::open(&control_path).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let thread_stop = Arc::clone(&stop);
    let thread = std::thread::spawn(move || {
        let _listening = control_socket;
        let mut sim = Simulation::new(SimulationConfig::default()).unwrap();
        let udp = UdpSocket::bind("127.0.0.1:0").unwrap();
        let mode = TimingMode::Lockstep {
            answer_timeout: Duration::from_millis(200),
        };
        let counters = RunCounters::default();
        let _ = run_with(
            &mut sim,
            &udp,
            &ServerConfig::loopback(fri, mode),
            &thread_stop,
            &counters,
            |sim| {
                port.serve(sim);
            },
        );
    });
    (stop, thread)
}

async fn status(socket: &Path) -> Value {
    serde_json::from_str(&fri_ctl(&["status", "--json"], socket).await).unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_readme_walkthrough_with_the_simulator() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = local_config(dir.path(), "walk");
    config.iceoryx2.enabled = false;
    let h = InProcess::start(config).await.unwrap();
    let control_dir = dir.path().join("mock");
    std::fs::create_dir(&control_dir).unwrap();
    std::fs::set_permissions(
        &control_dir,
        std::os::unix::fs::PermissionsExt::from_mode(0o700),
    )
    .unwrap();
    let control_path = control_dir.join("control.sock");
    let (stop, sim) = simulator(h.fri, control_path.clone());
    let socket = h.socket.clone();
    let mut connected = false;
    for _ in 0..500 {
        let s = status(&socket).await;
        if s["connected"] == true && s["residual_valid"] == true {
            connected = true;
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    assert!(connected, "the service never saw the simulator");

    // fri-ctl tare: unloaded, stored.
    let tare = fri_ctl(&["tare"], &socket).await;
    assert!(tare.contains("tare stored"), "{tare}");
    // fri-ctl expect-payload: the monitor stays armed.
    let declared = fri_ctl(&["expect-payload"], &socket).await;
    assert!(declared.contains("GRASP WINDOW"), "{declared}");
    // mock-robot control attach --mass-kg 3.028 --com-m 0,0,0.119: the grasp.
    let attached = control(
        &control_path,
        r#"{"cmd":"attach","mass_kg":3.028,"com_m":[0.0,0.0,0.119]}"#,
    )
    .await;
    assert!(attached.contains("payload attached"), "{attached}");
    // fri-ctl estimate-payload --apply: about 3.028 kg, armed throughout.
    let estimate: Value = serde_json::from_str(
        fri_ctl(&["estimate-payload", "--apply", "--json"], &socket)
            .await
            .lines()
            .last()
            .unwrap(),
    )
    .unwrap();
    let mass = estimate["mass"].as_f64().unwrap();
    assert!((mass - 3.028).abs() < 0.03, "{estimate:#}");
    let s = status(&socket).await;
    assert_eq!(s["monitor"]["armed"], true, "{s:#}");
    assert!(s["unknown_payload"].is_null(), "{s:#}");
    assert!((s["payload"]["mass"].as_f64().unwrap() - mass).abs() < 1e-9);
    // mock-robot control push --link 4 --force-n 0,80,0 --duration-s 0.2: the arm is held.
    control(
        &control_path,
        r#"{"cmd":"push","link":4,"profile":{"kind":"half_sine","peak_force_n":[0.0,80.0,0.0],"duration_s":0.2}}"#,
    )
    .await;
    let mut held = Value::Null;
    for _ in 0..300 {
        held = status(&socket).await;
        if held["stopped"] == true {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    assert_eq!(held["stopped"], true, "{held:#}");
    // fri-ctl resume: released once the contact is over.
    tokio::time::sleep(Duration::from_millis(300)).await;
    fri_ctl(&["resume"], &socket).await;
    let s = status(&socket).await;
    assert_eq!(s["stopped"], false, "{s:#}");
    stop.store(true, Ordering::Relaxed);
    sim.join().unwrap();
    h.stop().await.unwrap();
}
