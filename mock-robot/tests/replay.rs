//! A real LWR 4+ recording replayed as the controller: the datagrams carry the log's angles and
//! torques interpolated to the FRI period and the nominal model's gravity at those angles, a start
//! of command mode is refused with its reason, and the log's end ends the controller.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::path::{Path, PathBuf};

use dynamics::Data;
use fri::handshake::{DropReason, KrlStatus, KrlStrategy, RequestKind};
use fri::wire::{InterfaceState, Measurement};
use mock_robot::replay::{Derivatives, Replay};
use mock_robot::testkit::{Client, in_monitor, status};
use mock_robot::{Controller, EventKind};

/// Run 2 of the real recordings (`../shared` beside the repository).
fn run2() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/real-lwr4/flobaroid-run2.csv")
}

/// The CSV as rows of 29 numbers (t, q1..7, qd1..7, qdd1..7, tau1..7), read independently.
fn rows(path: &Path) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).expect("the real recordings are in ../shared");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header[0], "t");
    assert_eq!(header[22], "tau1");
    lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

/// Cycle `k` (1 ms) of `rows` (run 2's layout) as the offline tools play them
/// (`estimator::replay::play`: the rows' clock, the positions' spline, torques linear).
fn played(rows: &[Vec<f64>], k: usize) -> estimator::replay::PlayedSample<7> {
    let v = |c: usize| -> Vec<nalgebra::SVector<f64, 7>> {
        rows.iter()
            .map(|r| nalgebra::SVector::<f64, 7>::from_fn(|i, _| r[c + i]))
            .collect()
    };
    let log = estimator::motion::RecordedLog {
        trajectory: estimator::motion::Trajectory {
            t: rows.iter().map(|r| r[0]).collect(),
            q: v(1),
            tau: v(22),
        },
        derivatives: None,
    };
    estimator::replay::play(&log, 0.001).unwrap()[0][k]
}

/// Equal up to the f32 rounding of the wire.
fn on_the_wire(wire: f64, expected: f64) -> bool {
    (wire - expected).abs() <= f64::from(f32::EPSILON) * expected.abs().max(1e-6)
}

/// What the remote receives: the measurement encoded and decoded.
fn datagram(m: &Measurement) -> Measurement {
    let mut bytes = [0u8; fri::wire::MSR_LEN];
    m.emit(&mut bytes).unwrap();
    Measurement::parse(&bytes).unwrap()
}

#[test]
fn run_2_replays_in_lockstep_with_the_logs_values_and_the_nominal_gravity() {
    let rows = rows(&run2());
    let mut replay = Replay::from_file(&run2(), 1).unwrap();
    assert_eq!(replay.log().rows(), rows.len());
    assert_eq!(replay.log().derivatives(), Derivatives::Recorded);
    let total = replay.total_cycles();
    // The offline tools' player on the same file: the rows' own clock, the positions' spline.
    let log =
        estimator::motion::read_recorded_csv::<7, _>(std::fs::File::open(run2()).unwrap()).unwrap();
    let played = estimator::replay::play(&log, 0.001).unwrap();
    assert_eq!(played.len(), 1);
    let played = &played[0];
    assert_eq!(total, played.len() as u64);
    // Cycles whose measurement is checked: the first (row 0 exactly), between rows, the last.
    let checked = [0u64, 1, 2, 7, 777, 5003, 12_345, 20_000, total - 1];
    let mut seen: Vec<(u64, Measurement)> = Vec::new();
    let mut client = Client::new();
    let mut m = *replay.measurement();
    for k in 0..total {
        if checked.contains(&k) {
            seen.push((k, datagram(&m)));
        }
        assert!(!replay.is_finished(), "ended early at cycle {k}");
        m = client.cycle(&mut replay);
    }
    // The log's end ends the controller, after every measurement it gives.
    assert!(replay.is_finished());
    assert_eq!(replay.receive_counters().missed_cycles, 0);
    let model = dynamics::lwr4();
    let mut data = Data::new(&model);
    for (k, m) in &seen {
        let t = *k as f64 * 0.001;
        assert!(
            on_the_wire(m.interface.timestamp, t),
            "{} vs {t}",
            m.interface.timestamp
        );
        assert_eq!(m.interface.state, InterfaceState::Monitor);
        // positions and torques as the offline player plays them
        let q = played[*k as usize].q;
        let g = dynamics::compute_generalized_gravity(&model, &mut data, &q);
        for j in 0..7 {
            let (q_wire, tau_wire) = (m.data.msr_jnt_pos[j], m.data.msr_jnt_trq[j]);
            assert!(
                on_the_wire(q_wire, q[j]),
                "cycle {k} q{}: {q_wire} vs {}",
                j + 1,
                q[j]
            );
            let tau = played[*k as usize].tau[j];
            assert!(
                on_the_wire(tau_wire, tau),
                "cycle {k} tau{}: {tau_wire} vs {tau}",
                j + 1
            );
            assert!(
                on_the_wire(m.data.gravity[j], g[j]),
                "cycle {k} g{}: {} vs {}",
                j + 1,
                m.data.gravity[j],
                g[j]
            );
            // Monitor mode: the controller holds where the arm is (no FRI offset).
            assert_eq!(m.data.cmd_jnt_pos[j], q_wire);
            assert_eq!(m.data.cmd_jnt_pos_fri_offset[j], 0.0);
        }
    }
    // Cycle 0 is row 0 itself.
    assert_eq!(seen[0].1.data.msr_jnt_trq[3], f64::from(rows[0][25] as f32));
}

#[test]
fn a_start_of_command_mode_is_refused_with_reason_7_and_said_why() {
    let mut replay = Replay::from_file(&run2(), 1).unwrap();
    let mut client = Client::new();
    let m = client.run(&mut replay, 150);
    assert_eq!(m.interface.quality, fri::wire::Quality::Perfect);
    let request = client.request(RequestKind::StartCommandMode, KrlStrategy::JointPosition);
    let m = client
        .run_until(&mut replay, 100, |m| status(m).has_acknowledged(request.id))
        .expect("the request is acknowledged");
    assert!(in_monitor(&m));
    assert_eq!(status(&m).status, KrlStatus::MonitorReady);
    assert_eq!(status(&m).drop_reason, DropReason::StrategyNotSupported);
    assert_eq!(replay.drop_reason_code(), 7);
    let event = replay.poll_event().expect("the refusal is an event");
    assert_eq!(
        event.kind,
        EventKind::StartRefused {
            reason: mock_robot::krl::DropReason::StrategyNotSupported,
            monitor_only: true
        }
    );
    let text = event.to_string();
    assert!(
        text.contains("command mode refused: reason 7 (strategy not supported)")
            && text.contains("monitor mode only"),
        "{text}"
    );
    // Still monitor mode a while later, and nothing else happened.
    let m = client.run(&mut replay, 500);
    assert!(in_monitor(&m));
    assert_eq!(replay.poll_event(), None);
}

/// Writes the first `n` rows of run 2 in the layout of the service's `record --kind log`
/// (stamps from 100 s, to the µs as the service writes them); returns the rows as written.
fn service_log(dir: &Path, n: usize) -> (PathBuf, Vec<Vec<f64>>) {
    let mut rows: Vec<Vec<f64>> = rows(&run2()).into_iter().take(n).collect();
    let mut text = String::from("cycle,time_s,flags");
    for name in ["q", "qd", "tau", "g", "tau_ext", "r"] {
        for j in 1..=7 {
            text.push_str(&format!(",{name}{j}"));
        }
    }
    text.push('\n');
    for (k, r) in rows.iter_mut().enumerate() {
        let stamp = format!("{:.6}", 100.0 + r[0]);
        r[0] = stamp.parse().unwrap();
        text.push_str(&format!("{k},{stamp},3"));
        for c in (1..15).chain(22..29) {
            text.push_str(&format!(",{}", r[c]));
        }
        text.push_str(&",0".repeat(21));
        text.push('\n');
    }
    let path = dir.join("service-log.csv");
    std::fs::write(&path, text).unwrap();
    (path, rows)
}

#[test]
fn the_services_log_layout_replays_by_column_name() {
    let dir = tempfile::tempdir().unwrap();
    let (path, rows) = service_log(dir.path(), 300);
    let mut replay = Replay::from_file(&path, 1).unwrap();
    assert_eq!(replay.log().derivatives(), Derivatives::VelocityRecorded);
    // The replay's time 0 is the log's first stamp.
    let m = datagram(&Client::new().run(&mut replay, 500));
    let q = played(&rows, 500).q[3];
    assert!(
        on_the_wire(m.data.msr_jnt_pos[3], q),
        "{} vs {q}",
        m.data.msr_jnt_pos[3]
    );
}

#[test]
fn an_mcap_recording_replays_its_joint_states() {
    use fri_ros_msgs::builtin_interfaces::Time;
    use fri_ros_msgs::sensor_msgs::JointState;
    use fri_ros_msgs::std_msgs::Header;
    let rows: Vec<Vec<f64>> = rows(&run2()).into_iter().take(200).collect();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let mut writer = mcap::Writer::new(std::io::BufWriter::new(
        std::fs::File::create(&path).unwrap(),
    ))
    .unwrap();
    let schema = writer
        .add_schema("sensor_msgs/msg/JointState", "ros2msg", b"")
        .unwrap();
    let channel = writer
        .add_channel(schema, "/joint_states", "cdr", &Default::default())
        .unwrap();
    for (k, r) in rows.iter().enumerate() {
        let js = JointState {
            header: Header {
                stamp: Time::from_seconds(10.0 + r[0]),
                frame_id: String::new(),
            },
            name: Vec::new(),
            position: r[1..8].to_vec(),
            velocity: r[8..15].to_vec(),
            effort: r[22..29].to_vec(),
        };
        let data = fri_ros_msgs::cdr::encode_cdr(&js).unwrap();
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: k as u32,
            log_time: k as u64,
            publish_time: k as u64,
        };
        writer.write_to_known_channel(&header, &data).unwrap();
    }
    writer.finish().unwrap();
    drop(writer);
    let mut replay = Replay::from_file(&path, 1).unwrap();
    assert_eq!(replay.log().rows(), 200);
    assert_eq!(replay.log().derivatives(), Derivatives::VelocityRecorded);
    let m = datagram(&Client::new().run(&mut replay, 300));
    // Stamps went through whole nanoseconds: play the rows as stamped.
    let stamped: Vec<Vec<f64>> = rows
        .iter()
        .map(|r| {
            let mut r = r.clone();
            r[0] = Time::from_seconds(10.0 + r[0]).as_seconds();
            r
        })
        .collect();
    let sample = played(&stamped, 300);
    let q = sample.q[1];
    assert!(
        (m.data.msr_jnt_pos[1] - q).abs() < 1e-6,
        "{} vs {q}",
        m.data.msr_jnt_pos[1]
    );
    let tau = sample.tau[5];
    assert!(
        on_the_wire(m.data.msr_jnt_trq[5], tau),
        "{} vs {tau}",
        m.data.msr_jnt_trq[5]
    );
}

#[test]
fn a_replay_runs_in_real_time_on_udp_and_ends_by_itself() {
    use fri::session::{DesiredCommand, Session, SessionConfig};
    use mock_robot::server::{ServerConfig, TimingMode};
    let dir = tempfile::tempdir().unwrap();
    // The first 60 rows of run 2 (about 0.3 s).
    let text = std::fs::read_to_string(run2()).unwrap();
    let short: String = text.lines().take(61).map(|l| format!("{l}\n")).collect();
    let path = dir.path().join("short.csv");
    std::fs::write(&path, short).unwrap();
    let replay = Replay::from_file(&path, 1).unwrap();
    let total = replay.total_cycles();
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    socket
        .set_read_timeout(Some(std::time::Duration::from_millis(100)))
        .unwrap();
    let config = ServerConfig::loopback(socket.local_addr().unwrap(), TimingMode::RealTime);
    let handle = mock_robot::spawn(replay, config).unwrap();
    let mut session = Session::new(SessionConfig::default());
    let (mut buf, mut out) = ([0u8; 2048], [0u8; fri::wire::CMD_LEN]);
    while !handle.is_finished() {
        if let Ok((n, from)) = socket.recv_from(&mut buf) {
            let now = std::time::Instant::now();
            if let Ok(info) =
                session.step(&buf[..n], from, now, &DesiredCommand::default(), &mut out)
            {
                socket.send_to(&out, info.destination).unwrap();
            }
        }
    }
    let (replay, summary) = handle.join().unwrap();
    assert_eq!(summary.cycles, total);
    assert!(replay.is_finished());
    assert!(replay.receive_counters().answers > 0);
}
