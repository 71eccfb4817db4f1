//! Proof against an independent DDS implementation: Eclipse Cyclone DDS (Python `cyclonedds`,
//! no ROS anywhere) subscribes on loopback to the bridge's `rt/joint_states` with the ROS 2
//! type name `sensor_msgs::msg::dds_::JointState_` while the mock robot drives the service, and
//! to `rt/lwr/payload` (`geometry_msgs::msg::dds_::InertiaStamped_`) after an `apply-payload`.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};

use mock_robot::SimulationConfig;
use mock_robot::motion::MotionSegment;
use serde_json::Value;

const RATE_HZ: u32 = 250;
const SAMPLES: usize = 750;

/// The Cyclone subscriber on loopback, with its stdout lines.
struct Peer {
    child: Child,
    lines: std::sync::mpsc::Receiver<Value>,
}

impl Peer {
    fn start(domain: u16, topic: &str, ty: &str, count: usize, timeout_s: u32) -> Self {
        let script = common::workspace().join("ros2/tests/peers/cyclone_subscriber.py");
        let mut child = Command::new(common::peers_python())
            .arg(script)
            .args(["--topic", topic, "--type", ty])
            .args(["--domain", &domain.to_string()])
            .args(["--count", &count.to_string()])
            .args(["--timeout", &timeout_s.to_string()])
            .env(
                "CYCLONEDDS_URI",
                "<CycloneDDS><Domain id=\"any\"><General><Interfaces>\
                 <NetworkInterface name=\"lo\"/></Interfaces></General></Domain></CycloneDDS>",
            )
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap();
        let stdout = child.stdout.take().unwrap();
        let (tx, lines) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                match serde_json::from_str::<Value>(&line) {
                    Ok(v) => {
                        if tx.send(v).is_err() {
                            break;
                        }
                    }
                    Err(e) => eprintln!("peer printed a non-JSON line ({e}): {line}"),
                }
            }
        });
        let peer = Self { child, lines };
        let first = peer.next(60).expect("the peer never became ready");
        assert_eq!(first["ready"], true, "{first}");
        peer
    }

    /// The next line, waiting at most `timeout_s`.
    fn next(&self, timeout_s: u64) -> Option<Value> {
        self.lines
            .recv_timeout(std::time::Duration::from_secs(timeout_s))
            .ok()
    }
}

impl Drop for Peer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Truth rows of the mock by its cycle: joint positions, rad.
fn truth_positions(path: &std::path::Path) -> HashMap<i64, [f64; 7]> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let headers = r.headers().unwrap().clone();
    let col = |name: &str| headers.iter().position(|h| h == name).unwrap();
    let cycle = col("cycle");
    let q: Vec<usize> = (1..=7).map(|j| col(&format!("q{j}"))).collect();
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            let n: i64 = rec[cycle].parse().unwrap();
            (n, std::array::from_fn(|j| rec[q[j]].parse().unwrap()))
        })
        .collect()
}

fn stamp(v: &Value) -> f64 {
    v["sec"].as_f64().unwrap() + v["nanosec"].as_f64().unwrap() * 1e-9
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cyclone_peer_receives_joint_states_equal_to_the_truth_and_the_applied_payload() {
    common::loopback_multicast();
    let python_ready = common::peers_python();
    assert!(python_ready.exists());
    let dir = tempfile::tempdir().unwrap();
    let config = common::service_config(dir.path(), "ros2peer");
    let service = fri_service::testkit::InProcess::start(config.clone())
        .await
        .unwrap();
    // The KRL program moves every joint by 10° in 3 s (monitor mode: the controller moves,
    // the service only listens), so the positions change by far more than the encoder's step
    // every cycle and a wrong or shifted sample cannot match the truth.
    let mut target = dynamics::LWR4_PICK_POSE_DEG;
    for q in &mut target {
        *q += 10.0;
    }
    let sim = SimulationConfig {
        seed: 13,
        motion: vec![
            MotionSegment::Dwell { duration_s: 1.0 },
            MotionSegment::Ptp {
                q_deg: target,
                duration_s: Some(3.0),
                speed_fraction: None,
            },
        ],
        ..SimulationConfig::loaded()
    };
    let quantum = sim.sensors.encoder_quantum_rad;
    let truth_path = dir.path().join("truth.csv");
    let robot = common::robot(sim, service.fri, Some(truth_path.clone()));
    let mut client = common::wait_connected(&service).await;
    let domain = common::domain(0);
    let bridge = common::Bridge::start(config, domain, RATE_HZ);

    let peer = Peer::start(domain, "rt/joint_states", "joint_state", SAMPLES, 60);
    let samples: Vec<Value> = tokio::task::spawn_blocking(move || {
        let mut out = Vec::new();
        while let Some(v) = peer.next(60) {
            if v["done"] == true {
                break;
            }
            out.push(v);
        }
        out
    })
    .await
    .unwrap();
    assert_eq!(
        samples.len(),
        SAMPLES,
        "samples received by the Cyclone peer"
    );

    // Names and count.
    let names: Vec<String> = (1..=7).map(|i| format!("lwr_joint_{i}")).collect();
    for s in &samples {
        let got: Vec<String> = serde_json::from_value(s["name"].clone()).unwrap();
        assert_eq!(got, names);
        for field in ["position", "velocity", "effort"] {
            assert_eq!(s[field].as_array().unwrap().len(), 7, "{field}");
        }
    }
    // Stamps strictly increasing, at the configured rate in the controller's time.
    let stamps: Vec<f64> = samples.iter().map(stamp).collect();
    assert!(
        stamps.windows(2).all(|w| w[1] > w[0]),
        "stamps not increasing"
    );
    let rate = (stamps.len() - 1) as f64 / (stamps[stamps.len() - 1] - stamps[0]);
    assert!(
        (rate - f64::from(RATE_HZ)).abs() < 0.1 * f64::from(RATE_HZ),
        "rate {rate} Hz in controller time, configured {RATE_HZ}"
    );
    let recv: Vec<f64> = samples
        .iter()
        .map(|s| s["recv_s"].as_f64().unwrap())
        .collect();
    eprintln!(
        "Cyclone peer: {} samples, {rate:.1} Hz by stamps, {:.1} Hz by arrival",
        samples.len(),
        (recv.len() - 1) as f64 / (recv[recv.len() - 1] - recv[0])
    );

    // Stop the controller so the truth log is complete.
    robot.stop();
    let _ = robot.join();
    let truth = truth_positions(&truth_path);
    // The service counts its time from the first measurement it accepted; the mock counts its
    // own cycles: one constant offset maps one onto the other. Every sample must equal the
    // truth at that offset within the encoder's quantisation.
    let cycle_of = |t: f64| (t / 0.001).round() as i64;
    let matches = |s: &Value, offset: i64| -> bool {
        let Some(q) = truth.get(&(cycle_of(stamp(s)) + offset)) else {
            return false;
        };
        let p = s["position"].as_array().unwrap();
        (0..7).all(|j| (p[j].as_f64().unwrap() - q[j]).abs() <= quantum)
    };
    let (best, count) = (-50..=50)
        .map(|o| (o, samples.iter().filter(|s| matches(s, o)).count()))
        .max_by_key(|&(_, n)| n)
        .unwrap();
    assert_eq!(
        count,
        samples.len(),
        "samples equal to the truth at the best cycle offset {best}"
    );
    let moving = samples
        .windows(2)
        .filter(|w| {
            let a = w[0]["position"][0].as_f64().unwrap();
            let b = w[1]["position"][0].as_f64().unwrap();
            (a - b).abs() > 10.0 * quantum
        })
        .count();
    assert!(
        moving > 100,
        "the samples must cover the motion ({moving} moving)"
    );

    // The payload: applied over the operator socket, received on the transient-local topic.
    let reply = client
        .call(
            fri_api::protocol::Command::ApplyPayload {
                mass: 2.5,
                com: [0.0, 0.01, 0.1],
                // The value is what the peer must receive, not the flange's (not checked).
                force: Some(true),
            },
            |_, _| {},
        )
        .await
        .unwrap();
    assert!(reply.is_ok(), "{reply:?}");
    let payload = tokio::task::spawn_blocking(move || {
        let peer = Peer::start(domain, "rt/lwr/payload", "inertia_stamped", 0, 30);
        while let Some(v) = peer.next(30) {
            if v["done"] == true {
                break;
            }
            if v["m"].as_f64() == Some(2.5) {
                return Some(v);
            }
        }
        None
    })
    .await
    .unwrap()
    .expect("no InertiaStamped with the applied mass");
    assert_eq!(payload["frame_id"], "lwr_dh_frame_7");
    let com: Vec<f64> = serde_json::from_value(payload["com"].clone()).unwrap();
    assert_eq!(com, vec![0.0, 0.01, 0.1]);

    bridge.stop().await;
    service.stop().await.unwrap();
}
