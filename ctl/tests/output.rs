//! `fri-ctl`'s binary against a fake service that records what it receives and answers with
//! the daemon's JSON: list arguments with negative numbers reach the service, the socket comes
//! from `--socket` (before or after the subcommand) or `FRI_SERVICE_SOCKET`, every command
//! prints text with units, `--json` prints the result as sent, errors show their cause.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::process::{Command, Output};
use std::sync::{Arc, Mutex};

use fri_api::cause::Cause;
use fri_api::protocol::{Command as Request, ErrorCode, OperatorError};
use fri_service::operator::server::{self, AccessPolicy, EventSink, Handler, ServerLimits};
use serde_json::{Value, json};

const Q: [f64; 7] = [0.1, 0.5, -0.2, -1.2, 0.0, 0.5, 0.3];

/// Records every request; answers as the daemon would.
#[derive(Default)]
struct FakeService {
    seen: Mutex<Vec<Request>>,
}

fn status() -> Value {
    json!({
        "connected": true, "residual_valid": true, "fri": null, "cycle": 10, "time_s": 0.01,
        "q": Q, "qd": Q, "tau": Q, "gravity": Q, "tau_ext": Q, "residual": Q,
        "command_mode": true, "stopped": false, "collision": false, "observer_fault": false,
        "moving": false, "payload": {"mass": 1.5, "com": [0.0, 0.01, -0.02], "frame": "7"},
        "tare_samples": null,
        "monitor": {"armed": true, "thresholds": Q, "gains": Q},
    })
}

fn estimate() -> Value {
    json!({
        "method": "direct", "correction": "tare", "mass": 3.02814, "mass_std": 0.00042,
        "com": [0.0001, -0.0002, 0.11904], "com_std": [0.0003, 0.0003, 0.0003],
        "com_flange": [0.0, 0.0, 0.04], "com_flange_std": [0.0003, 0.0003, 0.0003],
        "first_moment": [0.0, 0.0, 0.36], "first_moment_std": [0.0, 0.0, 0.0],
        "covariance": [[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]],
        "residual_rms": Q, "residual_std": 0.012, "condition_number": 12.5, "samples": 2,
        "joints_used": [1, 2, 3, 4, 5, 6, 7], "tare_used": true, "frame": "7", "around": Q,
        "applied": true,
    })
}

fn calibration(monitor: &Value) -> Value {
    let joint = json!({"threshold_at_rest": 0.5, "threshold_median": 1.25, "threshold_max": 9.0,
        "envelope": [0.1, 0.0, 0.2, 0.9, 0.1, 0.001], "model": "gumbel", "shape_interval": [-0.2, 0.05],
        "scale": 5.2, "scale_point": 5.0, "scale_std": 0.1, "scale_interval": [4.9, 5.3],
        "peak": 1.1, "exceedances": 0});
    let force = json!({"median": 8.5, "p10": 4.0, "p90": 20.0});
    json!({
        "source": "last-recording", "budget_per_hour": 0.01, "confidence": 0.9,
        "recording": {"budget_per_hour": 0.01, "duration_s": 61.2, "blocks": 61, "block_s": 1.0,
                      "max_speed": Q, "max_acceleration": Q},
        "joints": vec![joint; 7],
        "schedule": {"thresholds": Q, "speed": Q, "velocity_noise": Q, "payload_dynamics": Q,
                     "inertial": Q, "gravity": Q, "scale": Q},
        "min_force_at_rest": vec![force.clone(); 7], "min_force_median": vec![force; 7],
        "calibrated_for_payload": null, "applied": false, "settings": monitor,
    })
}

impl Handler for FakeService {
    async fn handle(
        &self,
        command: Request,
        _origin: fri_api::origin::Origin,
        events: EventSink,
    ) -> Result<Value, OperatorError> {
        self.seen.lock().unwrap().push(command.clone());
        let monitor = json!({"armed": true, "thresholds": Q, "gains": Q});
        match command {
            Request::Status => Ok(status()),
            Request::Sample { .. } => Err(OperatorError::new(
                ErrorCode::Aborted,
                "collision detected (link 4) at 12.345 s",
            )
            .with_cause(Cause::Collision {
                link: 4,
                time_s: 12.345,
                residual: [0.0, 0.0, 0.0, 7.25, 0.0, 0.0, 0.0],
            })),
            Request::Tare { .. } => {
                for step in 1..=2 {
                    let e = json!({"phase": "sampled", "step": step, "of": 2, "workflow": "tare",
                                   "pose": Q, "settle_s": 0.3, "max_speed": 0.0001});
                    events.send("progress", e).await;
                }
                Ok(json!({"samples": 2, "around": Q}))
            }
            Request::EstimatePayload { .. } => Ok(estimate()),
            Request::ApplyPayload { mass, com, .. } => {
                Ok(json!({"payload": {"mass": mass, "com": com, "frame": "7"}}))
            }
            Request::ClearPayload => Ok(json!({"payload": null})),
            Request::ExpectPayload {
                end: Some(true), ..
            } => Ok(json!({"unknown_payload": null})),
            Request::ExpectPayload { max_mass, .. } => Ok(json!({"unknown_payload": {
                "declared_by": "operator", "max_mass": max_mass.unwrap_or(7.0), "max_radius": 0.3,
                "samples": 2, "mass": 3.031, "com": [0.0, 0.0, 0.119], "consistent": true,
            }})),
            Request::Collision { .. } => Ok(monitor),
            Request::CollisionCalibrate { .. } => {
                events
                    .send(
                        "progress",
                        json!({"phase": "fitting", "workflow": "calibrate"}),
                    )
                    .await;
                Ok(calibration(&monitor))
            }
            Request::CollisionInstall(r) => Ok(json!({
                "armed": true, "thresholds": Q, "gains": Q, "persisted": true,
                "calibration": {"budget_per_hour": 0.1, "duration_s": 25.0, "blocks": 24,
                                "block_s": 1.0, "max_speed": Q, "max_acceleration": Q,
                                "installed_from": r.source},
            })),
            Request::Stop => Ok(json!({"stopped": true, "controller": "connected"})),
            Request::Resume => Ok(json!({"stopped": false})),
            Request::Record { .. } => Ok(json!({"rows": 5, "path": "/rec/x.csv", "lost": 2})),
            Request::Watch { .. } => {
                events.send("resumed", json!({"cycle": 3})).await;
                Ok(json!({"watch": "ended"}))
            }
        }
    }
}

/// Serves a fresh [`FakeService`] on a socket in a fresh directory.
async fn fake_service() -> (tempfile::TempDir, String, Arc<FakeService>) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("op.sock");
    let listener = server::bind(&path).await.unwrap();
    let (tx, rx) = tokio::sync::watch::channel(false);
    // The sender lives as long as the test process: the server never shuts down.
    std::mem::forget(tx);
    let fake = Arc::new(FakeService::default());
    tokio::spawn(server::serve(
        listener,
        fake.clone(),
        AccessPolicy::default(),
        ServerLimits::default(),
        rx,
    ));
    (dir, path.to_str().unwrap().to_owned(), fake)
}

/// Runs `fri-ctl` with `args` (blocking, off the runtime's threads).
async fn fri_ctl(args: Vec<String>, env_socket: Option<String>) -> Output {
    tokio::task::spawn_blocking(move || {
        let mut c = Command::new(env!("CARGO_BIN_EXE_fri-ctl"));
        c.args(&args).env_remove("FRI_SERVICE_SOCKET");
        if let Some(s) = env_socket {
            c.env("FRI_SERVICE_SOCKET", s);
        }
        c.output().unwrap()
    })
    .await
    .unwrap()
}

fn strings(args: &[&str]) -> Vec<String> {
    args.iter().map(|s| (*s).to_owned()).collect()
}

fn stdout(out: &Output) -> String {
    assert!(out.status.success(), "{out:?}");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn negative_numbers_in_list_arguments_reach_the_service() {
    let (_dir, socket, fake) = fake_service().await;
    let around = "-0.1,0.5,0,-1.2,0,0.5,0";
    for args in [
        vec!["tare", "--around", around],
        vec!["estimate-payload", "--around", around, "--apply"],
        vec!["apply-payload", "--mass", "1", "--com", "-0.0005,0,0.12"],
    ] {
        let mut args = strings(&args);
        args.extend(strings(&["--socket", &socket]));
        stdout(&fri_ctl(args, None).await);
    }
    // Thresholds and gains cannot be negative: the list is parsed (not taken for a flag) and the
    // service's range check names the value.
    for (list, message) in [
        ("--thresholds", "thresholds[0] = -1 Nm is outside"),
        ("--gains", "gains[0] = -400 1/s is outside"),
    ] {
        let values = if list == "--gains" {
            "-400,1,1,1,1,1,1"
        } else {
            "-1,6,6,6,6,6,6"
        };
        let args = strings(&["collision", "configure", list, values, "--socket", &socket]);
        let out = fri_ctl(args, None).await;
        assert_eq!(out.status.code(), Some(64), "{out:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(message), "{err}");
    }
    let seen = fake.seen.lock().unwrap().clone();
    assert!(
        matches!(seen[0], Request::Tare { around: Some(a), .. } if a[0] == -0.1 && a[3] == -1.2)
    );
    assert!(
        matches!(seen[1], Request::EstimatePayload { around: Some(a), apply: Some(true), .. } if a[0] == -0.1)
    );
    assert!(matches!(seen[2], Request::ApplyPayload { com, .. } if com == [-0.0005, 0.0, 0.12]));
    assert_eq!(
        seen.len(),
        3,
        "out-of-range lists are refused before the handler"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_socket_comes_from_either_side_of_the_subcommand_or_the_environment() {
    let (_dir, socket, fake) = fake_service().await;
    stdout(&fri_ctl(strings(&["--socket", &socket, "stop"]), None).await);
    stdout(&fri_ctl(strings(&["stop", "--socket", &socket]), None).await);
    stdout(&fri_ctl(strings(&["resume"]), Some(socket.clone())).await);
    // The command line wins over the environment.
    stdout(
        &fri_ctl(
            strings(&["resume", "--socket", &socket]),
            Some("/nonexistent".into()),
        )
        .await,
    );
    assert_eq!(fake.seen.lock().unwrap().len(), 4);
    let out = fri_ctl(strings(&["status"]), Some("/nonexistent/fri.sock".into())).await;
    assert_eq!(out.status.code(), Some(69), "{out:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_command_prints_text_with_units() {
    let (_dir, socket, _fake) = fake_service().await;
    let cases: [(&[&str], &[&str]); 14] = [
        (
            &["status"],
            &[
                "controller     connected",
                "q [deg]",
                "residual [Nm]",
                "payload        1.5000 kg",
                "ARMED",
            ],
        ),
        (&["tare"], &["tare stored    2 poses", "around [deg]"]),
        (
            &["estimate-payload"],
            &[
                "mass           3.0281 kg ± 0.0004 kg (1σ)",
                "z +119.04",
                "applied to the collision observer",
            ],
        ),
        (
            &["apply-payload", "--mass", "1.5", "--com", "0,0.01,-0.02"],
            &["payload applied  1.5000 kg", "y +10.00  z -20.00"],
        ),
        (&["clear-payload"], &["payload cleared"]),
        (
            &["expect-payload", "--max-mass", "4"],
            &[
                "payload UNKNOWN",
                "at most 4.00 kg within 0.300 m",
                "2 static samples: 3.0310 kg",
            ],
        ),
        (&["expect-payload", "--end"], &["payload known"]),
        (
            &["collision", "show"],
            &["monitor        ARMED", "threshold [Nm]", "gain [1/s]"],
        ),
        (
            &[
                "collision",
                "calibrate",
                "--source",
                "last-recording",
                "--budget",
                "0.01",
            ],
            &[
                "61.2 s of robot time (last-recording), 61 blocks",
                "θ at rest [Nm]",
                "θ median [Nm]",
                "median θ [N]",
                "preview only",
            ],
        ),
        (&["stop"], &["stop latched"]),
        (&["resume"], &["resumed"]),
        (
            &["record", "x.csv"],
            &["recorded 5 rows to /rec/x.csv", "2 cycles lost"],
        ),
        (&["watch"], &["resumed    cycle 3", "watch ended"]),
        (&["status", "--json"], &["\"connected\":true"]),
    ];
    for (args, expected) in cases {
        let mut a = strings(args);
        a.extend(strings(&["--socket", &socket]));
        let text = stdout(&fri_ctl(a, None).await);
        for e in expected {
            assert!(text.contains(e), "{args:?}: no `{e}` in\n{text}");
        }
        assert!(
            !text.contains('{') || args.contains(&"--json"),
            "{args:?}: raw JSON in\n{text}"
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn json_output_is_the_result_as_sent() {
    let (_dir, socket, _fake) = fake_service().await;
    let text = stdout(
        &fri_ctl(
            strings(&["estimate-payload", "--json", "--socket", &socket]),
            None,
        )
        .await,
    );
    let printed: Value = serde_json::from_str(text.trim()).unwrap();
    assert_eq!(printed, estimate());
    let text = stdout(&fri_ctl(strings(&["tare", "--json", "--socket", &socket]), None).await);
    let lines: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines[0]["event"], "progress");
    assert_eq!(lines[0]["data"]["step"], 1);
    assert_eq!(lines[2], json!({"samples": 2, "around": Q}));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_error_shows_its_cause() {
    let (_dir, socket, _fake) = fake_service().await;
    let out = fri_ctl(strings(&["sample", "--socket", &socket]), None).await;
    assert_eq!(out.status.code(), Some(4), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.starts_with("error (aborted): collision detected"),
        "{err}"
    );
    assert!(
        err.contains("contact detected on link 4 at t = 12.345 s"),
        "{err}"
    );
    assert!(err.contains("7.25"), "{err}");
    let out = fri_ctl(strings(&["sample", "--json", "--socket", &socket]), None).await;
    let printed: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(printed["error"]["cause"]["kind"], "collision");
}
