//! The README's walkthrough with the simulator ("The same flow with the simulator"), as
//! written: the simulated controller starts unloaded and takes an operator's requests on its
//! control socket; `fri-ctl` tares, declares the payload unknown, the simulator is handed the
//! payload (the grasp), `estimate-payload --apply` estimates it with the monitor armed, and a
//! push on link 4 is detected and holds the arm until `resume`, while `fri-ctl watch` (its own
//! process from the start) shows every command, change and event. The service in-process, the
//! simulator in lockstep on its own thread (as the binary runs it, with its control socket),
//! the requests to the control socket the lines `mock-robot control` sends. What each command
//! printed is checked against the output the README shows for it (numbers masked: they are
//! the simulator's draws), so the README's transcript stays true.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use fri_service::testkit::{InProcess, local_config};
use mock_robot::server::{RunCounters, run_with};
use mock_robot::{ServerConfig, Simulation, SimulationConfig, TimingMode};
use serde_json::Value;

/// `fri-ctl ARGS… --socket SOCKET`: its stdout, or a panic with all of its output when it
/// failed.
async fn fri_ctl(args: &[&str], socket: &Path) -> String {
    let out = common::fri_ctl(socket, args).await;
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

/// The README's transcript of the walkthrough (its `text` block after "The same flow with the
/// simulator"): each `$ command` with the lines it shows (`…` stands for lines left out).
fn readme_transcript() -> Vec<(String, Vec<String>)> {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../README.md"))
            .unwrap();
    let section = &readme[readme.find("### The same flow with the simulator").unwrap()..];
    let start = section.find("```text\n").unwrap() + "```text\n".len();
    let block = &section[start..start + section[start..].find("```").unwrap()];
    let mut out: Vec<(String, Vec<String>)> = Vec::new();
    for line in block.lines() {
        match (line.strip_prefix("$ "), out.last_mut()) {
            (Some(cmd), _) => out.push((cmd.to_owned(), Vec::new())),
            (None, Some((_, lines))) if line.trim() != "…" => lines.push(line.to_owned()),
            _ => {}
        }
    }
    out
}

/// A line with its numbers masked and its spaces collapsed: what the README can promise.
fn masked(line: &str) -> String {
    let mut out = String::new();
    let mut in_number = false;
    for c in line
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .chars()
    {
        let digit = c.is_ascii_digit() || (in_number && c == '.');
        if digit && !in_number {
            // A sign belongs to the number.
            if out.ends_with(['+', '-']) {
                out.pop();
            }
            out.push('#');
        } else if !digit {
            out.push(c);
        }
        in_number = digit;
    }
    out
}

/// Checks `printed` (command, output) against the README's transcript.
fn check_readme(printed: &[(String, String)]) {
    let readme = readme_transcript();
    let commands: Vec<&str> = readme.iter().map(|(c, _)| c.as_str()).collect();
    let ran: Vec<&str> = printed.iter().map(|(c, _)| c.as_str()).collect();
    assert_eq!(commands, ran, "the README's transcript runs other commands");
    for ((cmd, shown), (_, output)) in readme.iter().zip(printed) {
        let got: Vec<String> = output.lines().map(masked).collect();
        for line in shown {
            assert!(
                got.contains(&masked(line)),
                "README, `{cmd}`: {line:?} is not what it printed:\n{output}"
            );
        }
    }
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

    // fri-ctl watch, in its own terminal from the start: the events as they happen.
    let mut watch = std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
        .arg("watch")
        .arg("--socket")
        .arg(&socket)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Commands start once `watch` says from which cycle on it misses nothing (its first line),
    // as an operator would see it; before, the tare could be accepted before it subscribed.
    let watch_stdout = watch.stdout.take().unwrap();
    let (line_tx, line_rx) = std::sync::mpsc::channel::<String>();
    let reader = std::thread::spawn(move || {
        use std::io::BufRead;
        for line in std::io::BufReader::new(watch_stdout).lines() {
            let Ok(line) = line else { break };
            if line_tx.send(line).is_err() {
                break;
            }
        }
    });
    let (first, line_rx) = tokio::task::spawn_blocking(move || {
        (line_rx.recv_timeout(Duration::from_secs(30)), line_rx)
    })
    .await
    .unwrap();
    let first = first.expect("fri-ctl watch printed nothing");
    assert!(first.starts_with("watching"), "{first}");
    let mut printed: Vec<(String, String)> = Vec::new();
    // fri-ctl tare: unloaded, stored.
    let tare = fri_ctl(&["tare"], &socket).await;
    printed.push(("fri-ctl tare".into(), tare.clone()));
    assert!(tare.contains("tare stored"), "{tare}");
    // fri-ctl expect-payload: the monitor stays armed.
    let declared = fri_ctl(&["expect-payload"], &socket).await;
    printed.push(("fri-ctl expect-payload".into(), declared.clone()));
    assert!(declared.contains("GRASP WINDOW"), "{declared}");
    // mock-robot control attach --mass-kg 3.028 --com-m 0,0,0.119: the grasp.
    let attached = control(
        &control_path,
        r#"{"cmd":"attach","mass_kg":3.028,"com_m":[0.0,0.0,0.119]}"#,
    )
    .await;
    assert!(attached.contains("payload attached"), "{attached}");
    printed.push((
        "mock-robot control attach --mass-kg 3.028 --com-m 0,0,0.119".into(),
        attached,
    ));
    // fri-ctl estimate-payload --apply: about 3.028 kg, armed throughout.
    let estimated = fri_ctl(&["estimate-payload", "--apply"], &socket).await;
    printed.push(("fri-ctl estimate-payload --apply".into(), estimated));
    let mass = status(&socket).await["payload"]["mass"].as_f64().unwrap();
    assert!((mass - 3.028).abs() < 0.03, "{mass}");
    let s = status(&socket).await;
    assert_eq!(s["monitor"]["armed"], true, "{s:#}");
    assert!(s["unknown_payload"].is_null(), "{s:#}");
    assert!((s["payload"]["mass"].as_f64().unwrap() - mass).abs() < 1e-9);
    // mock-robot control push --link 4 --force-n 80,0,0 --duration-s 0.2: the arm is held.
    let pushed = control(
        &control_path,
        r#"{"cmd":"push","link":4,"profile":{"kind":"half_sine","peak_force_n":[80.0,0.0,0.0],"duration_s":0.2}}"#,
    )
    .await;
    printed.push((
        "mock-robot control push --link 4 --force-n 80,0,0 --duration-s 0.2".into(),
        pushed,
    ));
    let mut held = Value::Null;
    for _ in 0..300 {
        held = status(&socket).await;
        if held["stopped"] == true {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    assert_eq!(held["stopped"], true, "{held:#}");
    printed.push(("fri-ctl status".into(), fri_ctl(&["status"], &socket).await));
    // fri-ctl resume: released once the contact is over.
    tokio::time::sleep(Duration::from_millis(300)).await;
    let resumed = fri_ctl(&["resume"], &socket).await;
    printed.push(("fri-ctl resume".into(), resumed.clone()));
    let s = status(&socket).await;
    assert_eq!(s["stopped"], false, "{s:#}");
    // What `watch` printed meanwhile (it runs until it is interrupted; every line is written
    // as it happens): read until it has printed the release after the resume, the README's last
    // line of it (30 s at most: a missing line fails below), then interrupt it. A fixed wait
    // before the interrupt lost that line on a loaded host.
    let watched = tokio::task::spawn_blocking(move || {
        let mut text = format!("{first}\n");
        let deadline = std::time::Instant::now() + Duration::from_secs(30);
        while let Some(left) = deadline.checked_duration_since(std::time::Instant::now()) {
            let Ok(line) = line_rx.recv_timeout(left) else {
                break;
            };
            text.push_str(&line);
            text.push('\n');
            if line.contains("arm released") && text.contains("`resume` accepted") {
                break;
            }
        }
        watch.kill().unwrap();
        watch.wait().unwrap();
        reader.join().unwrap();
        text.extend(line_rx.try_iter().map(|l| l + "\n"));
        text
    })
    .await
    .unwrap();
    assert!(watched.contains("collision"), "{watched}");
    assert!(watched.contains("resume"), "{watched}");
    printed.push(("fri-ctl watch".into(), watched));
    println!(
        "{}",
        printed
            .iter()
            .map(|(c, o)| format!("$ {c}\n{o}"))
            .collect::<String>()
    );
    check_readme(&printed);
    stop.store(true, Ordering::Relaxed);
    sim.join().unwrap();
    h.stop().await.unwrap();
}
