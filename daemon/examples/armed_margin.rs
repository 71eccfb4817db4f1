//! How close the payload-tolerant monitor comes to tripping on the payload itself, and what it
//! tolerates, during an armed grasp and 10-pose estimate (issue 12): the service's cycle
//! processor against the simulated controller in step (`mock_robot::testkit::EndpointClient`,
//! the endpoint's real loop body; robot time, independent of the machine's load).
//!
//! Per motion-limit set and payload: declare the payload unknown, pick it up at rest, drive the
//! paper's 10 poses ±7° plus the revisit and the return (a 0.5 s average at each pose, refitted
//! and handed to the loop as the service does), then apply the fit. Reports the largest share
//! of the threshold the detector saw (max_j (|e_j| − a_j)/θ_j) before the first sample and
//! after, the largest inertia allowance a_j in each phase, collisions, the residual after the
//! estimate is applied, and the per-cycle cost of the mode's call.
//!
//! `cargo run --release -p fri-service --example armed_margin`

use std::sync::mpsc::sync_channel;
use std::time::Instant;

use dynamics::{Data, compute_generalized_gravity};
use fri::session::SessionConfig;
use fri_service::config::Config;
use fri_service::service::build_monitor;
use fri_service::service::cycle::{CycleEvent, CycleProcessor, CycleRequest, ProcessorSettings};
use fri_service::service::pattern::{PatternKind, poses};
use mock_robot::config::{PayloadAction, PayloadEvent};
use mock_robot::testkit::EndpointClient;
use mock_robot::{Simulation, SimulationConfig};
use nalgebra::SVector;
use safety::{FlangeLoadBounds, LoadSample, PayloadCompensation, fit_hypothesis};

type V7 = SVector<f64, 7>;

struct Run {
    before_sample: f64,
    after_sample: f64,
    allowance_before: V7,
    allowance_one: V7,
    allowance_after: V7,
    collisions: usize,
    after_apply: f64,
    mass: f64,
}

fn run(limits: (f64, f64, f64), mass: f64, com: [f64; 3], seed: u64) -> anyhow::Result<Run> {
    let mut config = Config::default();
    config.motion.max_velocity = [limits.0; 7];
    config.motion.max_acceleration = [limits.1; 7];
    config.motion.max_jerk = [limits.2; 7];
    config.fri.max_joint_step = 1.0e-3;
    let thresholds = V7::from(config.observer.thresholds);
    let model = dynamics::lwr4();
    let monitor = build_monitor(&config, model.clone())?;
    let (requests, request_rx) = sync_channel(64);
    let (event_tx, events) = sync_channel(1 << 20);
    let processor = CycleProcessor::new(
        ProcessorSettings::from_config(&config),
        monitor,
        request_rx,
        event_tx,
    );
    let session = SessionConfig {
        max_joint_step: config.fri.max_joint_step,
        ..SessionConfig::default()
    };
    let mut client = EndpointClient::new(session, processor);
    let mut sim_config = SimulationConfig {
        seed,
        ..SimulationConfig::default()
    };
    sim_config.payload.mass_kg = mass;
    sim_config.payload.com_m = com;
    sim_config.payload.attached_at_start = false;
    sim_config.payload.events = vec![PayloadEvent {
        time_s: 1.0,
        action: PayloadAction::Attach,
    }];
    let mut sim = Simulation::new(sim_config)?;
    let bounds = FlangeLoadBounds {
        max_mass_kg: config.unknown_payload.max_mass_kg,
        radius_m: config.unknown_payload.max_radius_m,
    };
    let mut out = Run {
        before_sample: 0.0,
        after_sample: 0.0,
        allowance_before: V7::zeros(),
        allowance_one: V7::zeros(),
        allowance_after: V7::zeros(),
        collisions: 0,
        after_apply: 0.0,
        mass: f64::NAN,
    };
    client.run(&mut sim, 300);
    requests.send(CycleRequest::ExpectPayload {
        declaration: 1,
        bounds,
        timing: safety::GraspTiming::default(),
    })?;
    let mut samples: Vec<LoadSample<7>> = Vec::new();
    let mut data = Data::new(&model);
    let mut hypothesis = None;
    // One cycle, with the detector's view and the allowance tracked.
    let step = |client: &mut EndpointClient<CycleProcessor>,
                sim: &mut Simulation,
                out: &mut Run,
                sampled: bool,
                applied: bool| {
        client.cycle(sim);
        let p = client.hook();
        let tol = p.payload_tolerance();
        if tol.is_active() {
            let share = (0..7)
                .map(|j| (tol.unexplained()[j].abs() - tol.allowance()[j]).max(0.0) / thresholds[j])
                .fold(0.0, f64::max);
            if sampled {
                out.after_sample = out.after_sample.max(share);
                if tol.hypothesis().is_some_and(|h| h.samples >= 2) {
                    out.allowance_after = out.allowance_after.sup(tol.allowance());
                } else {
                    out.allowance_one = out.allowance_one.sup(tol.allowance());
                }
            } else {
                out.before_sample = out.before_sample.max(share);
                out.allowance_before = out.allowance_before.sup(tol.allowance());
            }
        }
        for e in events.try_iter() {
            match e {
                CycleEvent::Collision(_) => out.collisions += 1,
                CycleEvent::State(s) if applied && s.residual[0].is_finite() => {
                    let share = (0..7)
                        .map(|j| s.residual[j].abs() / thresholds[j])
                        .fold(0.0, f64::max);
                    out.after_apply = out.after_apply.max(share);
                }
                _ => {}
            }
        }
    };
    while sim.time_s() < 1.5 {
        step(&mut client, &mut sim, &mut out, false, false);
    }
    let start: [f64; 7] = sim.q().as_slice().try_into()?;
    let mut pattern = poses(PatternKind::Paper, &model, &start, 10, 7.0)?;
    pattern.push(pattern[0]);
    pattern.push(start);
    let last = pattern.len() - 1;
    for (k, pose) in pattern.iter().enumerate() {
        requests.send(CycleRequest::MoveTo(*pose))?;
        let sampled = !samples.is_empty();
        // Until the set-point stopped and the arm settled (0.3 s below 2 mrad/s).
        let mut quiet = 0;
        let mut moving_seen = 0;
        while quiet < 300 && moving_seen < 60_000 {
            step(&mut client, &mut sim, &mut out, sampled, false);
            moving_seen += 1;
            let at_rest = sim.qd().amax() < 0.002 && !client.hook().is_moving();
            quiet = if at_rest { quiet + 1 } else { 0 };
        }
        if k == last {
            break;
        }
        let (mut q, mut tau) = (V7::zeros(), V7::zeros());
        for _ in 0..500 {
            step(&mut client, &mut sim, &mut out, sampled, false);
            let m = sim.measurement();
            q += V7::from(m.data.msr_jnt_pos) / 500.0;
            tau += V7::from(m.data.msr_jnt_trq) / 500.0;
        }
        samples.push(LoadSample {
            q,
            load_torque: tau - compute_generalized_gravity(&model, &mut data, &q),
        });
        let h = fit_hypothesis(&model, 1, &samples, &thresholds, &bounds)
            .ok_or_else(|| anyhow::anyhow!("no fit"))?;
        requests.send(CycleRequest::PayloadHypothesis(h))?;
        hypothesis = Some(h);
    }
    if let Some(h) = hypothesis {
        out.mass = h.mass_kg();
        let p = h.parameters;
        requests.send(CycleRequest::SetPayload(Some(
            PayloadCompensation::Gravity {
                mass_kg: p[0],
                first_moment: nalgebra::Vector3::new(p[1], p[2], p[3]),
            },
        )))?;
        for _ in 0..1000 {
            step(&mut client, &mut sim, &mut out, true, true);
        }
    }
    Ok(out)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Median cost of one `PayloadTolerance::contact_residual` call, µs, in each phase.
fn cost() -> anyhow::Result<Vec<(&'static str, f64)>> {
    let model = dynamics::lwr4();
    let mut data = Data::new(&model);
    let bounds = FlangeLoadBounds {
        max_mass_kg: 7.0,
        radius_m: 0.3,
    };
    let q = V7::from(dynamics::LWR4_PICK_POSE_RAD);
    let theta = PayloadCompensation::gravity_from_com(3.0, nalgebra::Vector3::new(0.0, 0.0, 0.12))
        .gravity_parameters();
    let y = dynamics::payload_gravity_regressor(&model, &mut data, &q);
    let sample = LoadSample {
        q,
        load_torque: y * theta,
    };
    let h = fit_hypothesis(&model, 1, &[sample], &V7::repeat(6.0), &bounds)
        .ok_or_else(|| anyhow::anyhow!("no fit"))?;
    let residual = -(y * theta);
    let mut out = Vec::new();
    for (name, hypothesis, moving) in [
        ("during the grasp, at rest", None, false),
        ("after samples, at rest", Some(h), false),
        ("after samples, moving (inertia allowance)", Some(h), true),
    ] {
        let mut t = safety::PayloadTolerance::new(&model);
        t.declare(1, bounds, safety::GraspTiming::default(), 0.0)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        if let Some(h) = hypothesis {
            t.set_hypothesis(h);
        }
        t.set_motion(moving, &V7::repeat(0.5));
        let mut times = Vec::new();
        for k in 0..20_000 {
            let mut qk = q;
            qk[1] += 1e-6 * f64::from(k % 100);
            let t0 = Instant::now();
            let e = t.contact_residual(
                &qk,
                &V7::repeat(0.1),
                &residual,
                &nalgebra::Vector4::zeros(),
                &V7::repeat(6.0),
            );
            times.push(t0.elapsed().as_secs_f64() * 1e6);
            std::hint::black_box(e);
        }
        out.push((name, median(times)));
    }
    Ok(out)
}

fn main() -> anyhow::Result<()> {
    let limit_sets = [
        (
            "default [motion] (0.18 rad/s, 1 rad/s², 5 rad/s³)",
            (0.18, 1.0, 5.0),
        ),
        (
            "e2e tests' (0.9 rad/s, 5 rad/s², 100 rad/s³)",
            (0.9, 5.0, 100.0),
        ),
    ];
    let payloads = [
        ("3.028 kg at (0, 0, 0.119) m", 3.028, [0.0, 0.0, 0.119]),
        ("0.144 kg at (0, 0, 0.1146) m", 0.144, [0.0, 0.0, 0.1146]),
        ("6.5 kg at (0.1, 0, 0.25) m", 6.5, [0.1, 0.0, 0.25]),
    ];
    println!(
        "| motion limits | payload | detector/θ before the 1st sample | after | largest a_j [Nm] before the 1st sample (j = 1…7) | with 1 sample | with ≥ 2 samples | collisions | residual/θ after apply | fitted mass [kg] |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for (limits_name, limits) in limit_sets {
        for (payload_name, mass, com) in payloads {
            let r = run(limits, mass, com, 3)?;
            let list = |v: &V7| {
                let a: Vec<String> = v.iter().map(|x| format!("{x:.2}")).collect();
                a.join(", ")
            };
            println!(
                "| {limits_name} | {payload_name} | {:.2} | {:.2} | {} | {} | {} | {} | {:.2} | {:.4} |",
                r.before_sample,
                r.after_sample,
                list(&r.allowance_before),
                list(&r.allowance_one),
                list(&r.allowance_after),
                r.collisions,
                r.after_apply,
                r.mass,
            );
        }
    }
    println!();
    println!("| PayloadTolerance::contact_residual | median [µs] |");
    println!("|---|---|");
    for (name, us) in cost()? {
        println!("| {name} | {us:.2} |");
    }
    Ok(())
}
