//! Proof against an independent MCAP reader: the service records `record --kind mcap` while the
//! mock robot moves, a payload is applied and a contact hits the flange; Foxglove's Python `mcap`
//! reader with `mcap-ros2-support` (which decodes every message from the `ros2msg` schema in the
//! file, no ROS installation) reads it, and the decoded messages are checked against a CSV log
//! (`record --kind log`) recorded from the same run at the same time.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::collections::HashMap;
use std::process::Command as Process;

use fri_api::protocol::{CollisionAction, Command, RecordKind};
use fri_api::results::RecordResult;
use mock_robot::SimulationConfig;
use mock_robot::contact::{ContactProfile, ContactSpec};
use mock_robot::motion::MotionSegment;
use serde_json::Value;

const RECORD_S: f64 = 3.5;
const CONTACT_AT_S: f64 = 3.0;
/// The push, N: along the y axis of DH frame 7 at the end of the move.
const CONTACT_FORCE_N: f64 = 90.0;
/// Where the push hits, m in DH frame 7: on the flange's plane, 10 cm off the joint-7 axis (a
/// tool's edge), so joint 7 feels it and the contact isolates on link 7.
const CONTACT_POINT_M: [f64; 3] = [0.1, 0.0, dynamics::LWR_FLANGE_OFFSET];

/// A CSV log row: positions, torques and residuals by column.
struct CsvRow {
    q: [f64; 7],
    tau: [f64; 7],
    r: [f64; 7],
}

/// The CSV log keyed by its time in µs (the column has 6 decimals).
fn read_csv_log(path: &std::path::Path) -> HashMap<i64, CsvRow> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let h = r.headers().unwrap().clone();
    let col = |n: String| h.iter().position(|x| x == n).unwrap();
    let t = col("time_s".into());
    let cols = |p: &str| -> Vec<usize> { (1..=7).map(|j| col(format!("{p}{j}"))).collect() };
    let (q, tau, res) = (cols("q"), cols("tau"), cols("r"));
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            let get = |c: &[usize]| std::array::from_fn(|j| rec[c[j]].parse::<f64>().unwrap());
            let us = (rec[t].parse::<f64>().unwrap() * 1e6).round() as i64;
            (
                us,
                CsvRow {
                    q: get(&q),
                    tau: get(&tau),
                    r: get(&res),
                },
            )
        })
        .collect()
}

/// The service's newest controller time, s.
async fn controller_time(client: &mut fri_api::client::Client) -> f64 {
    let s = client
        .call_typed::<fri_api::results::StatusResult>(Command::Status, |_| {})
        .await
        .unwrap()
        .unwrap();
    s.time_s.unwrap()
}

/// Waits until the service's controller time passes `t` s.
async fn wait_until(client: &mut fri_api::client::Client, t: f64) {
    while controller_time(client).await < t {
        tokio::time::sleep(std::time::Duration::from_millis(10)).await;
    }
}

fn stamp_ns(m: &Value) -> u64 {
    m["header"]["sec"].as_u64().unwrap() * 1_000_000_000 + m["header"]["nanosec"].as_u64().unwrap()
}

fn floats(v: &Value) -> Vec<Option<f64>> {
    v.as_array().unwrap().iter().map(Value::as_f64).collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn python_mcap_reader_decodes_the_recording_as_the_csv_log_of_the_same_run() {
    let t = std::time::Instant::now();
    let python = common::peers_python();
    eprintln!("venv checked after {:.1} s", t.elapsed().as_secs_f64());
    let dir = tempfile::tempdir().unwrap();
    let mut config = common::service_config(dir.path(), "ros2mcap");
    // Armed only once the payload the mock carries is applied (an undeclared payload is a
    // contact for the monitor); a detection is reported, the arm is not stopped.
    config.observer.armed = false;
    config.reaction.policy = fri_service::config::ReactionMode::Report;
    let record_dir = config.state.record_dir();
    let service = fri_service::testkit::InProcess::start(config.clone())
        .await
        .unwrap();
    let mut target = dynamics::LWR4_PICK_POSE_DEG;
    for q in &mut target {
        *q += 10.0;
    }
    let model = dynamics::lwr4();
    let frame_7 = |q: &[f64]| {
        dynamics::flange_pose(
            &model,
            &mut dynamics::Data::new(&model),
            &nalgebra::SVector::<f64, 7>::from_column_slice(q),
        )
    };
    let push = frame_7(&target.map(f64::to_radians)).rotation * nalgebra::Vector3::y();
    let push_n: [f64; 3] = (push * CONTACT_FORCE_N).into();
    let sim = SimulationConfig {
        seed: 29,
        // Beyond the recording (without it, the controller stops 1 s after its motion script).
        duration_s: Some(60.0),
        motion: vec![
            MotionSegment::Dwell { duration_s: 0.5 },
            MotionSegment::Ptp {
                q_deg: target,
                duration_s: Some(1.5),
                speed_fraction: None,
            },
        ],
        contacts: vec![ContactSpec {
            link: 7,
            point_m: CONTACT_POINT_M,
            onset_s: CONTACT_AT_S,
            profile: ContactProfile::HalfSine {
                peak_force_n: push_n,
                duration_s: 0.3,
            },
        }],
        ..SimulationConfig::loaded()
    };
    let payload = (sim.payload.mass_kg, sim.payload.com_m);
    let robot = common::robot(sim, service.fri, None);
    let mut client = common::wait_connected(&service).await;

    let record = |mut c: fri_api::client::Client, path: &'static str, kind| async move {
        c.call_typed::<RecordResult>(
            Command::Record {
                path: path.into(),
                kind,
                duration_s: Some(RECORD_S),
                count: None,
                excite_deg: None,
            },
            |_| {},
        )
        .await
        .unwrap()
        .unwrap()
    };
    let start = controller_time(&mut client).await;
    let mcap = tokio::spawn(record(
        service.client().await.unwrap(),
        "run.mcap",
        RecordKind::Mcap,
    ));
    let log = tokio::spawn(record(
        service.client().await.unwrap(),
        "run.csv",
        RecordKind::Log,
    ));
    // The steps follow the controller's time, whatever the machine's load does to its pace.
    wait_until(&mut client, start + 0.3).await;
    let reply = client
        .call(
            Command::ApplyPayload {
                mass: payload.0,
                com: payload.1,
                // The true payload, sent as the motion script starts: the check's window
                // (0.35 s) sees the move and refuses `not-at-rest` (issue 34 item 5). Forced:
                // the recording of the change at this time is under test, not the check.
                force: Some(true),
            },
            |_, _| {},
        )
        .await
        .unwrap();
    assert!(reply.is_ok(), "{reply:?}");
    // Armed after the move (the contact comes later): a moving arm's model error stays out.
    wait_until(&mut client, 2.2).await;
    let reply = client
        .call(
            Command::Collision {
                action: CollisionAction::Arm,
                thresholds: None,
                gains: None,
                reaction: None,
                pause_s: None,
            },
            |_, _| {},
        )
        .await
        .unwrap();
    assert!(reply.is_ok(), "{reply:?}");
    let mcap = mcap.await.unwrap();
    let log = log.await.unwrap();
    eprintln!("recordings done after {:.1} s", t.elapsed().as_secs_f64());

    robot.stop();
    let (_, run) = robot.join().unwrap();
    eprintln!(
        "the simulated controller ran at {:.2} × real time",
        run.speed_factor()
    );
    assert_eq!(mcap.path, record_dir.join("run.mcap").to_string_lossy());
    let mcap_lost = mcap.lost.unwrap();
    let csv_lost = log.lost.unwrap();

    // The independent reader.
    let started = std::time::Instant::now();
    let out = Process::new(&python)
        .arg(common::workspace().join("ros2/tests/peers/mcap_reader.py"))
        .arg(&mcap.path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "mcap_reader.py: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!("mcap_reader.py: {:.1} s", started.elapsed().as_secs_f64());
    let lines: Vec<Value> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let header = &lines[0]["header"];
    assert_eq!(header["profile"], "ros2");
    let summary = &lines[1]["summary"];
    let messages: Vec<&Value> = lines.iter().filter(|l| l.get("topic").is_some()).collect();
    let on = |topic: &str| -> Vec<&Value> {
        messages
            .iter()
            .copied()
            .filter(|m| m["topic"] == topic)
            .collect()
    };
    assert_eq!(summary["message_count"], messages.len());
    assert_eq!(summary["compressions"], serde_json::json!(["zstd"]));
    assert!(summary["chunk_count"].as_u64().unwrap() >= 1);
    assert_eq!(summary["indexed_chunks"], summary["chunk_count"]);
    assert_eq!(summary["encodings"], serde_json::json!(["cdr"]));
    for (name, encoding) in summary["schemas"].as_object().unwrap() {
        assert_eq!(encoding, "ros2msg", "{name}");
    }
    let metadata = lines
        .iter()
        .find(|l| l["metadata"]["name"] == "fri_service")
        .expect("the fri_service metadata record");
    assert!(
        metadata["metadata"]["data"]["time_base"]
            .as_str()
            .unwrap()
            .contains("controller")
    );

    // Joint states: one per recorded cycle on each of the three topics, names, stamps.
    let js = on("/joint_states");
    let ext = on("/lwr/external_torque");
    let grav = on("/lwr/controller_gravity");
    assert_eq!(js.len(), mcap.rows);
    assert_eq!(summary["counts"]["/joint_states"], mcap.rows);
    assert_eq!(ext.len(), mcap.rows);
    assert_eq!(grav.len(), mcap.rows);
    let names: Vec<String> = (1..=7).map(|i| format!("lwr_joint_{i}")).collect();
    for (k, m) in js.iter().enumerate() {
        let got: Vec<String> = serde_json::from_value(m["name"].clone()).unwrap();
        assert_eq!(got, names);
        assert_eq!(m["log_time"].as_u64(), Some(stamp_ns(m)));
        assert_eq!(m["publish_time"], m["log_time"]);
        assert_eq!(stamp_ns(ext[k]), stamp_ns(m));
        assert_eq!(stamp_ns(grav[k]), stamp_ns(m));
    }
    let stamps: Vec<u64> = js.iter().map(|m| stamp_ns(m)).collect();
    assert!(stamps.windows(2).all(|w| w[1] > w[0]), "stamps increase");
    // Cycles missing from the stamps: lost by the recorder (reported) or never received by the
    // service (a loaded machine delays the simulated controller; the CSV log misses those too).
    let missing: u64 = stamps
        .windows(2)
        .map(|w| (w[1] - w[0]) / 1_000_000 - 1)
        .sum();
    // The recording spans its duration in controller time (lost or missing cycles included).
    let span_cycles = (stamps[stamps.len() - 1] - stamps[0]) / 1_000_000 + 1;
    assert_eq!(span_cycles, mcap.rows as u64 + missing);
    assert!(mcap.rows > 1000, "{} cycles recorded", mcap.rows);

    // The same cycles in the CSV log carry the same numbers (both recorders read one stream).
    let csv = read_csv_log(&record_dir.join("run.csv"));
    let mut compared = 0;
    for (k, m) in js.iter().enumerate() {
        let Some(row) = csv.get(&((stamp_ns(m) as f64 / 1e3).round() as i64)) else {
            continue;
        };
        compared += 1;
        let q = floats(&m["position"]);
        let tau = floats(&m["effort"]);
        let r = floats(&ext[k]["effort"]);
        // Python prints the shortest round-trip text; serde_json may read it one ulp off.
        let same = |a: Option<f64>, b: f64| match a {
            Some(a) => (a - b).abs() <= 1e-14 * b.abs().max(1e-3),
            // NaN (the residual before the monitor is valid) is null in JSON.
            None => b.is_nan(),
        };
        for j in 0..7 {
            let at = stamp_ns(m);
            assert!(
                same(q[j], row.q[j]),
                "q{} at {at}: {:?} {}",
                j + 1,
                q[j],
                row.q[j]
            );
            assert!(
                same(tau[j], row.tau[j]),
                "tau{} at {at}: {:?} {}",
                j + 1,
                tau[j],
                row.tau[j]
            );
            assert!(
                same(r[j], row.r[j]),
                "r{} at {at}: {:?} {}",
                j + 1,
                r[j],
                row.r[j]
            );
        }
    }
    // Over the time both recordings cover, a cycle in only one of them is one its recorder
    // reported lost: the recorders lose nothing unaccounted for.
    let us = |ns: u64| (ns as f64 / 1e3).round() as i64;
    let in_mcap: std::collections::HashSet<i64> = stamps.iter().map(|&ns| us(ns)).collect();
    let from = us(stamps[0]).max(*csv.keys().min().unwrap());
    let to = us(stamps[stamps.len() - 1]).min(*csv.keys().max().unwrap());
    let only_csv = csv
        .keys()
        .filter(|t| (from..=to).contains(*t) && !in_mcap.contains(*t))
        .count() as u64;
    let only_mcap = in_mcap
        .iter()
        .filter(|t| (from..=to).contains(*t) && !csv.contains_key(*t))
        .count() as u64;
    assert!(
        only_csv <= mcap_lost,
        "{only_csv} cycles missing from the MCAP file, {mcap_lost} reported lost"
    );
    assert!(
        only_mcap <= csv_lost,
        "{only_mcap} cycles missing from the CSV log, {csv_lost} reported lost"
    );
    assert!(compared > 1000, "{compared} cycles in both recordings");
    // The motion is in the recording: positions change by far more than the encoder's step.
    let first = floats(&js[0]["position"])[0].unwrap();
    let last = floats(&js[js.len() - 1]["position"])[0].unwrap();
    assert!((last - first).abs() > 5f64.to_radians(), "{first} → {last}");

    // The payload: none at the start, then the applied one, in DH frame 7.
    let p = on("/lwr/payload");
    assert_eq!(p.len(), 2, "{p:?}");
    assert_eq!(p[0]["m"], 0.0);
    assert_eq!(stamp_ns(p[0]), stamps[0]);
    assert_eq!(p[1]["m"].as_f64(), Some(payload.0));
    assert_eq!(
        floats(&p[1]["com"]),
        payload.1.iter().map(|c| Some(*c)).collect::<Vec<_>>()
    );
    assert_eq!(p[1]["header"]["frame_id"], "lwr_dh_frame_7");
    assert!(stamp_ns(p[1]) > stamps[0]);

    // The contact: a collision isolated on the wrist (the push is on the flange's plane) and
    // the contact fit's wrench, force in the base axes, pointing along the pushing force.
    let c = on("/lwr/collision");
    assert!(!c.is_empty(), "no collision recorded");
    let onset = c
        .iter()
        .find(|c| c["link"].as_u64().is_some_and(|l| l >= 6))
        .unwrap_or_else(|| {
            let links: Vec<&Value> = c.iter().map(|c| &c["link"]).collect();
            panic!("no collision on links 6–7, links {links:?}")
        });
    assert_eq!(onset["joint_names"], serde_json::json!(names));
    assert_eq!(onset["header"]["frame_id"], "base_link");
    let w = on("/lwr/contact_wrench");
    let w = w
        .iter()
        .find(|w| stamp_ns(w) == stamp_ns(onset))
        .unwrap_or_else(|| panic!("no contact wrench at the onset ({} wrenches)", w.len()));
    assert_eq!(w["header"]["frame_id"], "lwr_dh_frame_0");
    let f: Vec<f64> = floats(&w["force"]).into_iter().flatten().collect();
    let f = nalgebra::Vector3::new(f[0], f[1], f[2]);
    eprintln!(
        "contact wrench at the onset: force {:?} N in the base frame (push along {push:?})",
        f.as_slice()
    );
    assert!(
        f.normalize().dot(&push) > 0.8,
        "estimated force {f:?} against the push {push:?}"
    );

    // The description, once.
    let d = on("/robot_description");
    assert_eq!(d.len(), 1);
    assert!(d[0]["data"].as_str().unwrap().contains("lwr_dh_frame_7"));
    eprintln!(
        "MCAP: {} messages, {} cycles, {} lost by the recorder, {missing} missing in the stamps; \
         {} cycles compared with the CSV log",
        messages.len(),
        mcap.rows,
        mcap_lost,
        compared
    );
    service.stop().await.unwrap();
}
