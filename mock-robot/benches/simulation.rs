//! Speed of the simulated controller: one in-process cycle with full dynamics (5 kHz physics,
//! controller model, sensors), one lockstep cycle over loopback UDP with an `fri::session`
//! client, and (printed once) real-time pacing figures.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group};
use fri::session::{DesiredCommand, Session, SessionConfig};
use fri::wire::{CMD_LEN, MSR_LEN};
use mock_robot::server::{ServerConfig, TimingMode};
use mock_robot::{Simulation, SimulationConfig};

fn sweep_config() -> SimulationConfig {
    // The paper's q_A sweep: joint 1 moving, payload attached, default sensors and model error.
    SimulationConfig::from_toml_str(include_str!("../scenarios/sweep-qa.toml")).unwrap()
}

fn in_process(c: &mut Criterion) {
    let mut sim = Simulation::new(sweep_config()).unwrap();
    let mut session = Session::new(SessionConfig::default());
    let desired = DesiredCommand::default();
    let from: SocketAddr = "127.0.0.1:1".parse().unwrap();
    let start = Instant::now();
    let mut msr = [0u8; MSR_LEN];
    let mut out = [0u8; CMD_LEN];
    c.bench_function("mock_robot/in_process_cycle_1ms_sweep", |b| {
        b.iter(|| {
            sim.measurement().emit(&mut msr).unwrap();
            let now = start + Duration::from_secs_f64(sim.time_s());
            session.step(&msr, from, now, &desired, &mut out).unwrap();
            sim.submit_datagram(&out, 0.0);
            sim.advance();
            if sim.is_finished() {
                sim = Simulation::new(sweep_config()).unwrap();
                session = Session::new(SessionConfig::default());
            }
        })
    });
}

/// A client socket answering every measurement through an fri session.
struct UdpClient {
    socket: UdpSocket,
    session: Session,
    start: Instant,
}

impl UdpClient {
    fn answer_one(&mut self) {
        let mut buf = [0u8; 2048];
        let mut out = [0u8; CMD_LEN];
        let (n, from) = self.socket.recv_from(&mut buf).unwrap();
        let now = Instant::now();
        if let Ok(info) =
            self.session
                .step(&buf[..n], from, now, &DesiredCommand::default(), &mut out)
        {
            self.socket.send_to(&out, info.destination).unwrap();
        }
        let _ = self.start;
    }
}

fn spawn_pair(
    mode: TimingMode,
    duration_s: Option<f64>,
) -> (mock_robot::MockRobotHandle, UdpClient) {
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    socket
        .set_read_timeout(Some(Duration::from_secs(2)))
        .unwrap();
    let mut config = sweep_config();
    config.duration_s = duration_s.or(Some(1e9));
    let server = ServerConfig {
        bind: "127.0.0.1:0".parse().unwrap(),
        client: socket.local_addr().unwrap(),
        mode,
        max_cycles: None,
        truth_log: None,
    };
    let handle = mock_robot::spawn(Simulation::new(config).unwrap(), server).unwrap();
    (
        handle,
        UdpClient {
            socket,
            session: Session::new(SessionConfig::default()),
            start: Instant::now(),
        },
    )
}

fn lockstep_udp(c: &mut Criterion) {
    let (handle, mut client) = spawn_pair(
        TimingMode::Lockstep {
            answer_timeout: Duration::from_millis(200),
        },
        None,
    );
    c.bench_function("mock_robot/lockstep_udp_cycle_1ms_sweep", |b| {
        b.iter(|| client.answer_one())
    });
    handle.stop();
    // Unblock the server if it waits for an answer.
    for _ in 0..3 {
        let _ = client
            .socket
            .set_read_timeout(Some(Duration::from_millis(300)));
        let mut buf = [0u8; 2048];
        if client.socket.recv_from(&mut buf).is_err() {
            break;
        }
    }
    let _ = handle.join();
}

/// Real-time pacing figures: 5 s at 1 ms with a client answering at once; printed once.
fn realtime_figures() {
    let (handle, mut client) = spawn_pair(TimingMode::RealTime, Some(5.0));
    client
        .socket
        .set_read_timeout(Some(Duration::from_millis(500)))
        .unwrap();
    let mut buf = [0u8; 2048];
    let mut out = [0u8; CMD_LEN];
    let mut arrivals = Vec::with_capacity(6000);
    while !handle.is_finished() {
        match client.socket.recv_from(&mut buf) {
            Ok((n, from)) => {
                let now = Instant::now();
                arrivals.push(now);
                if let Ok(info) =
                    client
                        .session
                        .step(&buf[..n], from, now, &DesiredCommand::default(), &mut out)
                {
                    client.socket.send_to(&out, info.destination).unwrap();
                }
            }
            Err(_) => break,
        }
    }
    let (sim, summary) = handle.join().unwrap();
    let periods: Vec<f64> = arrivals
        .windows(2)
        .map(|w| (w[1] - w[0]).as_secs_f64())
        .collect();
    let mean = periods.iter().sum::<f64>() / periods.len().max(1) as f64;
    let mut dev: Vec<f64> = periods.iter().map(|p| (p - 0.001).abs()).collect();
    dev.sort_by(f64::total_cmp);
    let pct = |p: f64| {
        dev.get(((dev.len() as f64 - 1.0) * p) as usize)
            .copied()
            .unwrap_or(0.0)
    };
    let stats = sim.statistics();
    println!(
        "realtime 1 ms, 5 s: cycles {} wall {:.3} s, mean period {:.4} ms, |period-1ms| p50 {:.1} us p99 {:.1} us max {:.1} us; send lateness mean {:.1} us max {:.1} us, late cycles {}; controller answer rate {:.3}, mean latency {:.1} us, jitter {:.1} us, misses {}",
        summary.cycles,
        summary.wall_time_s,
        mean * 1e3,
        pct(0.5) * 1e6,
        pct(0.99) * 1e6,
        dev.last().copied().unwrap_or(0.0) * 1e6,
        summary.mean_send_jitter_s * 1e6,
        summary.max_lateness_s * 1e6,
        summary.late_cycles,
        stats.answer_rate,
        stats.latency_s * 1e6,
        stats.jitter_s * 1e6,
        stats.miss_counter,
    );
}

criterion_group!(benches, in_process, lockstep_udp);

fn main() {
    if std::env::args().all(|a| a != "--list") {
        realtime_figures();
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
