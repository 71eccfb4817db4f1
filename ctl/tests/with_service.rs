//! `fri-ctl` against the whole daemon in-process (`fri_service::testkit`) and the mock robot in
//! lockstep over UDP loopback: what the operator types reaches the service, and what it prints.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::time::Duration;

use fri_api::client::Client;
use fri_api::protocol::{Command, OperatorError};
use fri_service::testkit::{InProcess, local_config};
use mock_robot::{MockRobotHandle, ServerConfig, SimulationConfig, TimingMode};
use serde_json::Value;

/// The simulated controller (its payload attached), in lockstep with the service.
fn controller(h: &InProcess) -> MockRobotHandle {
    controller_with(h, SimulationConfig::default())
}

/// The simulated controller without its payload (a tare that sees a load is refused).
fn unloaded_controller(h: &InProcess) -> MockRobotHandle {
    let mut sim = SimulationConfig::default();
    sim.payload.attached_at_start = false;
    controller_with(h, sim)
}

/// The simulated controller `sim`, in lockstep with the service.
fn controller_with(h: &InProcess, sim: SimulationConfig) -> MockRobotHandle {
    let mode = TimingMode::Lockstep {
        answer_timeout: Duration::from_millis(200),
    };
    mock_robot::spawn_new(sim, ServerConfig::loopback(h.fri, mode)).unwrap()
}

async fn call(c: &mut Client, cmd: Command) -> Result<Value, OperatorError> {
    c.call(cmd, |_, _| {}).await.unwrap()
}

/// Calls `cmd`, decodes the result into `T` and checks that `T` serialises back to the JSON
/// the daemon sent (the typed results of `fri_api::results` describe it exactly).
async fn typed<T: serde::de::DeserializeOwned + serde::Serialize>(
    c: &mut Client,
    cmd: Command,
) -> T {
    let raw = call(c, cmd.clone())
        .await
        .unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    let t: T = serde_json::from_value(raw.clone())
        .unwrap_or_else(|e| panic!("{cmd:?} → {}: {e}\n{raw:#}", std::any::type_name::<T>()));
    assert_eq!(serde_json::to_value(&t).unwrap(), raw, "{cmd:?}");
    t
}

/// Waits until the service reports the controller connected (polls `status`).
async fn wait_connected(c: &mut Client) {
    for _ in 0..500 {
        let s = call(c, Command::Status).await.unwrap();
        if s["connected"].as_bool() == Some(true) {
            return;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("service never saw the controller");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fri_ctl_talks_to_the_running_service() {
    let dir = tempfile::tempdir().unwrap();
    let h = InProcess::start(local_config(dir.path(), "ctl"))
        .await
        .unwrap();
    let driver = controller(&h);
    let mut c = h.client().await.unwrap();
    wait_connected(&mut c).await;
    let socket = h.socket.clone();
    let out = common::fri_ctl(&socket, &["status", "--json"]).await;
    assert!(out.status.success(), "{out:?}");
    let status: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(status["connected"], true);
    // Not what the simulated flange carries: refused with the per-joint figures (issue 34
    // item 5), applied with --force and the refusal it overrode in the result.
    let apply = ["apply-payload", "--mass", "1.5", "--com", "0,0.01,-0.02"];
    let out = common::fri_ctl(&socket, &apply).await;
    assert_eq!(out.status.code(), Some(64), "{out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("apply-payload refused") && stderr.contains("<- worst"),
        "{stderr}"
    );
    let mut forced = apply.to_vec();
    forced.extend(["--force", "--json"]);
    let out = common::fri_ctl(&socket, &forced).await;
    assert!(out.status.success(), "{out:?}");
    let result: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(result["forced_past"]["refusal"], "disagrees", "{result}");
    let out = common::fri_ctl(
        &socket,
        &["apply-payload", "--mass", "-1", "--com", "0,0,0"],
    )
    .await;
    assert_eq!(out.status.code(), Some(64), "{out:?}");
    let status = call(&mut c, Command::Status).await.unwrap();
    assert_eq!(status["payload"]["mass"], 1.5);
    assert_eq!(status["payload"]["com"][2], -0.02);
    let out = common::fri_ctl(&socket, &["stop"]).await;
    assert!(out.status.success());
    let out = common::fri_ctl(&socket, &["tare", "--poses", "2"]).await;
    assert_eq!(out.status.code(), Some(5), "tare while stopped: {out:?}");
    drop(driver.join());
    h.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fri_ctl_record_prints_the_full_path_in_the_configured_directory() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = local_config(dir.path(), "ctlrec");
    c.iceoryx2.enabled = false;
    c.state.record_dir = Some(dir.path().join("rec"));
    let h = InProcess::start(c).await.unwrap();
    let driver = controller(&h);
    // A recording needs a live controller: start it once the service has heard one.
    wait_connected(&mut h.client().await.unwrap()).await;
    let socket = h.socket.clone();
    let out = tokio::task::spawn_blocking(move || {
        std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
            .args(["record", "ctl.csv", "--kind", "log", "--duration", "0.05"])
            .arg("--socket")
            .arg(&socket)
            .output()
            .unwrap()
    })
    .await
    .unwrap();
    assert!(out.status.success(), "{out:?}");
    let full = dir
        .path()
        .join("rec")
        .canonicalize()
        .unwrap()
        .join("ctl.csv");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = format!("rows to {}", full.display());
    assert!(
        stdout.starts_with("recorded ") && stdout.contains(&line),
        "{stdout}"
    );
    assert!(full.exists());
    drop(driver.join());
    h.stop().await.unwrap();
}

/// The stored tare leaves the service as the static-sample CSV the offline tools read.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_stored_tare_is_recorded_as_a_samples_file_the_offline_tools_read() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = local_config(dir.path(), "ctltare");
    c.iceoryx2.enabled = false;
    c.observer.armed = false;
    c.state.record_dir = Some(dir.path().join("rec"));
    let h = InProcess::start(c).await.unwrap();
    let driver = unloaded_controller(&h);
    let mut client = h.client().await.unwrap();
    wait_connected(&mut client).await;
    let socket = h.socket.clone();
    let record = |name: &'static str| {
        let socket = socket.clone();
        tokio::task::spawn_blocking(move || {
            std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
                .args(["record", name, "--kind", "tare", "--socket"])
                .arg(&socket)
                .output()
                .unwrap()
        })
    };
    let none = record("none.csv").await.unwrap();
    assert_eq!(none.status.code(), Some(3), "{none:?}");
    assert!(
        String::from_utf8_lossy(&none.stderr).contains("no tare is stored"),
        "{none:?}"
    );
    // The residual must be valid before a workflow (the monitor warms up after connecting).
    while call(&mut client, Command::Status).await.unwrap()["residual_valid"] != true {
        tokio::task::yield_now().await;
    }
    call(
        &mut client,
        Command::Tare {
            around: None,
            poses: Some(2),
            step_deg: Some(7.0),
            pattern: None,
            replace_loaded: None,
        },
    )
    .await
    .unwrap();
    let out = record("tare.csv").await.unwrap();
    assert!(out.status.success(), "{out:?}");
    let file = dir.path().join("rec").join("tare.csv");
    let samples: Vec<estimator::samples::StaticSample<7>> =
        estimator::samples::read_csv(std::fs::File::open(&file).unwrap()).unwrap();
    assert_eq!(samples.len(), 3, "two poses and the revisit of the first");
    let offline = std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
        .args(["offline", "estimate", "--samples"])
        .arg(&file)
        .arg("--tare")
        .arg(&file)
        .arg("--json")
        .output()
        .unwrap();
    // Loaded = tare: the offline estimator reads and pairs both files and finds no payload — a
    // mass of zero within its σ, or refused as not positive when it rounds below zero (a verdict
    // on the data, not a reading error).
    let err = String::from_utf8_lossy(&offline.stderr);
    if offline.status.success() {
        let v: serde_json::Value = serde_json::from_slice(&offline.stdout).unwrap();
        let (m, s) = (v["mass"].as_f64().unwrap(), v["mass_std"].as_f64().unwrap());
        assert!(m.abs() < 3.0 * s && s < 0.01, "{v}");
    } else {
        assert!(err.contains("is not positive"), "{offline:?}");
    }
    drop(driver.join());
    h.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_daemons_results_decode_into_the_typed_results() {
    use fri_api::protocol::{CollisionAction, RecordKind};
    use fri_api::results::*;
    let dir = tempfile::tempdir().unwrap();
    let mut config = local_config(dir.path(), "ctltyped");
    config.iceoryx2.enabled = false;
    config.state.record_dir = Some(dir.path().join("rec"));
    // The mock carries a payload the monitor does not know of: armed, it would stop the arm
    // before the sample below.
    config.observer.armed = false;
    let h = InProcess::start(config).await.unwrap();
    let driver = controller(&h);
    let mut c = h.client().await.unwrap();
    wait_connected(&mut c).await;
    let s: StatusResult = typed(&mut c, Command::Status).await;
    assert!(s.connected && s.fri.is_some());
    let disarm = Command::Collision {
        action: CollisionAction::Disarm,
        thresholds: None,
        gains: None,
        reaction: None,
        pause_s: None,
    };
    typed::<CollisionResult>(&mut c, disarm).await;
    let s: SampleResult = typed(
        &mut c,
        Command::Sample {
            duration_s: Some(0.02),
        },
    )
    .await;
    assert!(s.cycles > 0);
    let p: PayloadResult = typed(
        &mut c,
        Command::ApplyPayload {
            mass: 1.5,
            com: [-0.0005, 0.0, 0.12],
            // Not the mock's payload: forced, so that the typed refusal it overrode decodes too.
            force: Some(true),
        },
    )
    .await;
    assert!(p.forced_past.is_some(), "{p:?}");
    assert_eq!(p.payload.unwrap().com[0], -0.0005);
    let p: PayloadResult = typed(&mut c, Command::ClearPayload).await;
    assert!(p.payload.is_none());
    let u: ExpectPayloadResult = typed(
        &mut c,
        Command::ExpectPayload {
            max_mass: Some(4.0),
            max_radius: None,
            end: None,
        },
    )
    .await;
    assert_eq!(u.unknown_payload.unwrap().max_mass, 4.0);
    let s: StatusResult = typed(&mut c, Command::Status).await;
    assert_eq!(s.unknown_payload.unwrap().declared_by, DeclaredBy::Operator);
    let u: ExpectPayloadResult = typed(
        &mut c,
        Command::ExpectPayload {
            max_mass: None,
            max_radius: None,
            end: Some(true),
        },
    )
    .await;
    assert!(u.unknown_payload.is_none());
    for action in [
        CollisionAction::Show,
        CollisionAction::Arm,
        CollisionAction::Disarm,
    ] {
        typed::<CollisionResult>(
            &mut c,
            Command::Collision {
                action,
                thresholds: None,
                gains: None,
                reaction: None,
                pause_s: None,
            },
        )
        .await;
    }
    let m: CollisionResult = typed(
        &mut c,
        Command::Collision {
            action: CollisionAction::Configure,
            thresholds: Some([8.0; 7]),
            gains: None,
            reaction: None,
            pause_s: None,
        },
    )
    .await;
    assert_eq!(m.thresholds, [8.0; 7]);
    let r: RecordResult = typed(
        &mut c,
        Command::Record {
            path: "typed.csv".into(),
            kind: RecordKind::Log,
            duration_s: Some(0.02),
            count: None,
            excite_deg: None,
        },
    )
    .await;
    assert!(r.lost.is_some());
    let st: StopResult = typed(&mut c, Command::Stop).await;
    assert_eq!(st.controller, ControllerLink::Connected);
    typed::<StatusResult>(&mut c, Command::Status).await;
    let r: ResumeResult = typed(&mut c, Command::Resume).await;
    assert!(!r.stopped, "{r:?}");
    // The typed call of the client decodes the same result.
    let s = c
        .call_typed::<StatusResult>(Command::Status, |_| {})
        .await
        .unwrap()
        .unwrap();
    assert!(s.connected);
    drop(driver.join());
    h.stop().await.unwrap();
}

/// `fri-ctl collision configure`: one value or seven, out-of-range values refused naming the
/// field and range (the service's check, printed by fri-ctl), settings kept across a restart.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fri_ctl_collision_configure_checks_ranges_and_the_service_keeps_the_settings() {
    let dir = tempfile::tempdir().unwrap();
    let config = || {
        let mut c = local_config(dir.path(), "ctlmon");
        c.iceoryx2.enabled = false;
        c
    };
    let h = InProcess::start(config()).await.unwrap();
    let socket = h.socket.clone();
    let out = common::fri_ctl(&socket, &["collision", "configure", "--gains", "1e5"]).await;
    assert!(!out.status.success(), "{out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("gains[0] = 100000 1/s is outside 1…500 1/s"),
        "{stderr}"
    );
    let out = common::fri_ctl(
        &socket,
        &["collision", "configure", "--thresholds", "6,6,6,6,6,6,30"],
    )
    .await;
    assert!(!out.status.success(), "{out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("thresholds[6] = 30 Nm is outside 0.1…9.5 Nm"),
        "{stderr}"
    );
    let out = common::fri_ctl(&socket, &["collision", "configure", "--thresholds", "1,2"]).await;
    assert!(!out.status.success(), "{out:?}");
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("one value for every joint or 7"),
        "{out:?}"
    );
    let out = common::fri_ctl(
        &socket,
        &[
            "collision",
            "configure",
            "--thresholds",
            "4",
            "--reaction",
            "pause",
            "--pause-s",
            "1.5",
            "--json",
        ],
    )
    .await;
    assert!(out.status.success(), "{out:?}");
    let m: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(m["thresholds"], serde_json::json!(([4.0; 7])));
    assert_eq!(m["reaction"], "pause");
    h.stop().await.unwrap();

    let h = InProcess::start(config()).await.unwrap();
    let socket = h.socket.clone();
    let out = tokio::task::spawn_blocking(move || {
        std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
            .args(["collision", "show"])
            .arg("--socket")
            .arg(&socket)
            .output()
            .unwrap()
    })
    .await
    .unwrap();
    assert!(out.status.success(), "{out:?}");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("resumes 1.5 s after the release"), "{text}");
    assert!(
        text.contains("set by `collision configure` without a payload"),
        "{text}"
    );
    let row = text
        .lines()
        .find(|l| l.starts_with("threshold"))
        .unwrap_or_else(|| panic!("{text}"));
    assert_eq!(row.matches("4.00").count(), 7, "{row}");
    h.stop().await.unwrap();
}

/// Issue 20 item 10: right after a controller restart the new controller is refused for
/// `fri.resync_after_s` (its sequence does not follow the old one); `status` says that it is
/// resynchronising and for how long, instead of only "NOT connected", and connects after it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn status_says_resynchronising_after_a_controller_restart() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = local_config(dir.path(), "ctlresync");
    config.iceoryx2.enabled = false;
    config.observer.armed = false;
    // A wide window so that a loaded machine still sees it (the rule is the same at 1 s).
    config.fri.resync_after_s = 3.0;
    let h = InProcess::start(config).await.unwrap();
    // Late enough that the new counter (from 0, one per ms) is still far behind the old one
    // when the window ends: it is refused as out of the window, then accepted as a restart.
    let sim = SimulationConfig {
        restarts_s: vec![4.0],
        ..SimulationConfig::default()
    };
    let driver =
        mock_robot::spawn_new(sim, ServerConfig::loopback(h.fri, TimingMode::RealTime)).unwrap();
    let mut c = h.client().await.unwrap();
    wait_connected(&mut c).await;
    let socket = h.socket.clone();
    let status = |json: bool| {
        let socket = socket.clone();
        tokio::task::spawn_blocking(move || {
            let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"));
            cmd.arg("status").arg("--socket").arg(&socket);
            if json {
                cmd.arg("--json");
            }
            cmd.output().unwrap()
        })
    };
    // Until the restart is refused: the text names the resync and the time left.
    let mut seen = None;
    for _ in 0..800 {
        let out = status(false).await.unwrap();
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        if text.contains("RESYNCHRONISING") {
            seen = Some(text);
            break;
        }
        tokio::time::sleep(Duration::from_millis(25)).await;
    }
    let text = seen.expect("status never said it was resynchronising");
    let line = text.lines().next().unwrap();
    assert!(
        line.contains("with a restarted controller")
            && line.contains("fri.resync_after_s = 3.00 s"),
        "{line}"
    );
    let left: f64 = line
        .split("accepted in ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!(left > 0.0 && left <= 3.0, "{line}");
    // The typed field, while it lasts.
    let out = status(true).await.unwrap();
    let json: Value = serde_json::from_slice(&out.stdout).unwrap();
    if json["connected"] == false {
        let r = &json["fri"]["resync"];
        assert_eq!(r["kind"], "restart", "{json}");
        assert!(r["refused"].as_u64().unwrap() > 0, "{json}");
        let left = r["remaining_s"].as_f64().unwrap();
        assert!(left > 0.0 && left <= 3.0, "{json}");
    }
    // After the window the restarted controller is accepted.
    wait_connected(&mut c).await;
    let s = call(&mut c, Command::Status).await.unwrap();
    assert!(s["fri"].get("resync").is_none(), "{s}");
    assert!(
        s["fri"]["statistics"]["sequence"]["restarted"]
            .as_u64()
            .unwrap()
            >= 1,
        "{s}"
    );
    drop(driver.join());
    h.stop().await.unwrap();
}
