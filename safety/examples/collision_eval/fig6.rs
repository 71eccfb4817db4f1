//! Fig. 6 reproduction: the paper's experiment (three 50 N contacts during a 20 s motion) with
//! the controller-style signal and the residuals, with the paper's reaction executed, and per
//! tuning candidate.

use std::fmt::Write as _;

use dynamics::lwr4;
use rand::SeedableRng;
use rand::rngs::StdRng;
use safety::{
    CollisionDetector, Detection, DetectorConfig, GravitySource, MomentumObserver,
    PayloadCompensation,
};

use crate::scenario::{random_contact_geometry, random_waypoints, to_base};
use crate::support::{Contact, Profile, Quintic, Trajectory, V7};
use crate::variant::{LowPass, Variant, observer};
use crate::world::{SetPoint, World};
use crate::{GAIN, T, THRESHOLD};

/// Start pose of the Fig. 6 motion, rad.
const Q0: [f64; 7] = [0.0, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0];
/// The Fig. 6 contacts: (start [s], link (0-based)), each 50 N, 200 ms half-sine.
const FIG6_CONTACTS: [(f64, usize); 3] = [(1.0, 3), (8.0, 5), (17.0, 6)];

/// The Fig. 6 world: a random 8-waypoint motion from `Q0` with the three contacts, their
/// geometry drawn from the seed, every force direction converted to base at the contact time.
struct Fig6Scenario {
    trajectory: Quintic,
    world: World,
}

impl Fig6Scenario {
    fn new(seed: u64) -> Self {
        let mut rng = StdRng::seed_from_u64(seed ^ 0xF16);
        let q0 = V7::from_column_slice(&Q0);
        let mut waypoints = vec![q0];
        waypoints.extend(random_waypoints(&mut rng, 8));
        let trajectory = Quintic::new(&waypoints, 0.8, 0.5, 0.3);
        let nominal = lwr4();
        let mut contacts = Vec::new();
        for &(t0, link) in &FIG6_CONTACTS {
            // Geometry in the link frame; force direction converted to base at the contact time.
            let (point, direction) = random_contact_geometry(&mut rng, link);
            let (q_at, _, _) = trajectory.sample(t0);
            let force = to_base(&nominal, &q_at, link, &direction) * 50.0;
            contacts.push(Contact {
                link,
                point,
                force,
                profile: Profile::HalfSine {
                    start: t0,
                    duration: 0.2,
                },
            });
        }
        let world = World::new(seed, &q0, &contacts);
        Self { trajectory, world }
    }
}

/// Free motion: outside [t0, t0 + 1.2 s] of every contact, after the first 50 ms.
fn is_free_motion(t: f64) -> bool {
    FIG6_CONTACTS
        .iter()
        .all(|&(t0, _)| t < t0 || t > t0 + 0.2 + 1.0)
        && t > 0.05
}

/// Whether an onset at `t` detects some contact (within 0.3 s of its start).
fn in_detection_window(t: f64) -> bool {
    FIG6_CONTACTS
        .iter()
        .any(|&(t0, _)| t >= t0 && t <= t0 + 0.3)
}

/// Onsets of one signal against the Fig. 6 contacts.
struct OnsetScore {
    /// Contacts with an onset within 0.3 s of their start.
    detected: usize,
    /// Onsets in (t0 + 0.3 s, t0 + 1.2 s] of some contact (the arm rebounding).
    retriggers: usize,
    /// Onsets outside [t0, t0 + 1.2 s] of every contact.
    false_alarms: usize,
}

fn score_onsets(onsets: &[f64]) -> OnsetScore {
    OnsetScore {
        detected: FIG6_CONTACTS
            .iter()
            .filter(|&&(t0, _)| onsets.iter().any(|&t| t >= t0 && t <= t0 + 0.3))
            .count(),
        retriggers: onsets
            .iter()
            .filter(|&&t| {
                FIG6_CONTACTS
                    .iter()
                    .any(|&(t0, _)| t > t0 + 0.3 && t <= t0 + 1.2)
            })
            .count(),
        false_alarms: onsets
            .iter()
            .filter(|&&t| FIG6_CONTACTS.iter().all(|&(t0, _)| t < t0 || t > t0 + 1.2))
            .count(),
    }
}

/// Signals of the Fig. 6 run, for the plot and the CSV.
pub struct Fig6 {
    /// time, then per signal (ctrl, uncompensated, compensated) 7 joints.
    pub rows: Vec<(f64, [V7; 3])>,
    pub contacts: Vec<(f64, usize)>,
}

pub fn fig6(seed: u64, report: &mut String) -> Fig6 {
    let Fig6Scenario {
        trajectory,
        mut world,
    } = Fig6Scenario::new(seed);
    let nominal = lwr4();
    let duration = 20.0_f64.min(trajectory.duration());
    let mut obs_unc = observer(&nominal, PayloadCompensation::None);
    let mut obs_comp = observer(&nominal, world.payload());
    let mut ctrl_filter = LowPass::new(GAIN);
    let det_cfg = DetectorConfig::<7>::default();
    let mut obs_full = observer(&nominal, world.payload_full());
    let mut detectors: Vec<CollisionDetector<7>> = (0..4)
        .map(|_| CollisionDetector::new(det_cfg).unwrap())
        .collect();
    let mut onsets: [Vec<f64>; 4] = Default::default();
    let mut rows = Vec::new();
    let mut peak_free = [0.0_f64; 4];
    let mut over_free = [0usize; 4];
    let mut free_samples = 0usize;
    let mut peak_speed = 0.0_f64;
    let ticks = (duration / T) as usize;
    for k in 0..ticks {
        let t = k as f64 * T;
        let (input, ctrl_raw) = world.measure();
        let ctrl = ctrl_filter.update(&ctrl_raw);
        let r_unc = obs_unc.step(&input);
        let r_comp = obs_comp.step(&input);
        let r_full = obs_full.step(&input);
        let signals = [ctrl, r_unc.residual, r_comp.residual, r_full.residual];
        let free = is_free_motion(t);
        if free {
            free_samples += 1;
            peak_speed = peak_speed.max(world.true_state().1.amax());
        }
        for (i, s) in signals.iter().enumerate() {
            if free {
                peak_free[i] = peak_free[i].max(s.amax());
                if s.amax() > THRESHOLD {
                    over_free[i] += 1;
                }
            }
            if k > 0
                && let Detection::Onset(_) = detectors[i].update(s, &r_comp.velocity, k as u64, t)
            {
                onsets[i].push(t);
            }
        }
        rows.push((t, [signals[0], signals[1], signals[2]]));
        world.advance(&trajectory);
    }
    let names = [
        "(i) controller-style estimate, no payload",
        "(ii) residual, no payload",
        "(iii) residual, estimated payload (eq. 48)",
        "(iv) residual, estimated payload incl. inertia (not in the paper)",
    ];
    writeln!(report, "### Fig. 6 reproduction (seed {seed}, {duration:.0} s, contacts 50 N / 200 ms half-sine at 1 s link 4, 8 s link 6, 17 s link 7)\n").unwrap();
    let e = world.estimate();
    writeln!(report, "Payload estimate of this run (10 static poses around pick, estimator::estimate_direct, Δτ = msrJntTrq − controller gravity): m = {:.3} kg (true 3.028), CoM = ({:.1}, {:.1}, {:.1}) mm (true (0, 0, 119)), condition number {:.0}.\n", e.mass, e.com[0] * 1e3, e.com[1] * 1e3, e.com[2] * 1e3, e.condition_number).unwrap();
    writeln!(report, "Peak joint speed in free motion: {peak_speed:.2} rad/s. Threshold 6 Nm, default detector (debounce {}), release at 80 % for 20 samples. Free motion = outside [t0, t0 + 1.2 s] of each contact; a re-trigger is an onset in (t0 + 0.3 s, t0 + 1.2 s], i.e. while the arm rebounds from the push (no reaction is executed in this simulation).\n", det_cfg.debounce_samples).unwrap();
    writeln!(report, "| signal | peak \\|s\\| free motion [Nm] | free-motion time > 6 Nm | contacts detected (onset within 0.3 s) | re-triggers after a contact | false alarms in free motion |").unwrap();
    writeln!(report, "|---|---|---|---|---|---|").unwrap();
    for i in 0..4 {
        let OnsetScore {
            detected,
            retriggers,
            false_alarms,
        } = score_onsets(&onsets[i]);
        writeln!(
            report,
            "| {} | {:.2} | {:.1} % | {}/3 | {} | {} |",
            names[i],
            peak_free[i],
            100.0 * over_free[i] as f64 / free_samples.max(1) as f64,
            detected,
            retriggers,
            false_alarms
        )
        .unwrap();
    }
    writeln!(report).unwrap();
    Fig6 {
        rows,
        contacts: FIG6_CONTACTS.iter().map(|&(t, l)| (t, l)).collect(),
    }
}

/// Fig. 6 experiment with the paper's reaction executed: at every detected collision the robot
/// stops (trajectory time-scaled to zero over 0.5 s), waits until the contact has been released
/// for 2 s, then resumes (time scale back to one over 0.5 s). The monitor runs the compensated
/// residual (gravity-only, eq. 48, or with the payload inertia).
pub fn fig6_with_reaction(seed: u64, with_inertia: bool, label: &str, report: &mut String) {
    let Fig6Scenario {
        trajectory,
        mut world,
    } = Fig6Scenario::new(seed);
    let nominal = lwr4();
    let mut monitor_config = safety::MonitorConfig::new(T, GAIN);
    monitor_config.observer.gravity_source = GravitySource::Controller;
    let mut monitor = safety::CollisionMonitor::new(nominal, monitor_config).unwrap();
    let payload = if with_inertia {
        world.payload_full()
    } else {
        world.payload()
    };
    monitor.set_payload(payload).unwrap();
    let ramp_s = 0.5;
    let (mut clock, mut scale, mut running) = (0.0_f64, 1.0_f64, true);
    let mut pauses: Vec<(f64, bool)> = Vec::new(); // (time, caused within a contact window)
    let mut resumes = 0usize;
    let mut paused_ticks = 0usize;
    let ticks = (24.0 / T) as usize;
    for k in 0..ticks {
        let t = k as f64 * T;
        let (q, v, a) = trajectory.sample(clock);
        let setpoint = SetPoint(q, v * scale, a * scale * scale);
        let (input, _) = world.measure();
        let out = monitor.step(&input);
        match out.reaction {
            Some(safety::ReactionRequest::Pause { .. }) => {
                running = false;
                pauses.push((t, in_detection_window(t)));
            }
            Some(safety::ReactionRequest::Resume) => {
                running = true;
                resumes += 1;
            }
            _ => {}
        }
        if !running {
            paused_ticks += 1;
        }
        let target = if running { 1.0 } else { 0.0 };
        scale += (target - scale).clamp(-T / ramp_s, T / ramp_s);
        clock += scale * T;
        world.advance(&setpoint);
    }
    let pause_times: Vec<f64> = pauses.iter().map(|p| p.0).collect();
    let detected = score_onsets(&pause_times).detected;
    let spurious = pauses.iter().filter(|p| !p.1).count();
    writeln!(
        report,
        "| {label} | {detected}/3 | {} | {spurious} | {resumes} | {:.1} s |",
        pauses.len(),
        paused_ticks as f64 * T
    )
    .unwrap();
}

/// Fig. 6 experiment (same world, trajectory and contacts as [`fig6`]) with every variant's
/// compensated observer and detector: contacts detected (onset within 0.3 s), re-triggers and
/// false alarms in free motion, peak free-motion |r|.
pub fn fig6_detection(seed: u64, variants: &[Variant], report: &mut String) {
    let Fig6Scenario {
        trajectory,
        mut world,
    } = Fig6Scenario::new(seed);
    let duration = 20.0_f64.min(trajectory.duration());
    let mut observers: Vec<MomentumObserver<7>> =
        variants.iter().map(|v| v.observer(&world)).collect();
    let mut detectors: Vec<CollisionDetector<7>> = variants.iter().map(Variant::detector).collect();
    let mut onsets: Vec<Vec<f64>> = vec![Vec::new(); variants.len()];
    let mut peak_free = vec![0.0_f64; variants.len()];
    for k in 0..(duration / T) as usize {
        let t = k as f64 * T;
        let (input, _) = world.measure();
        let free = is_free_motion(t);
        for (i, (obs, det)) in observers.iter_mut().zip(detectors.iter_mut()).enumerate() {
            let out = obs.step(&input);
            if free {
                peak_free[i] = peak_free[i].max(out.residual.amax());
            }
            if k > 0
                && let Detection::Onset(_) = det.update(&out.residual, &out.velocity, k as u64, t)
            {
                onsets[i].push(t);
            }
        }
        world.advance(&trajectory);
    }
    writeln!(
        report,
        "#### Fig. 6 detection per candidate (seed {seed}, estimated payload, eq. 48)\n"
    )
    .unwrap();
    writeln!(report, "| variant | peak \\|r\\| free motion [Nm] | contacts detected | re-triggers | false alarms |\n|---|---|---|---|---|").unwrap();
    for (i, v) in variants.iter().enumerate() {
        let OnsetScore {
            detected,
            retriggers,
            false_alarms,
        } = score_onsets(&onsets[i]);
        writeln!(
            report,
            "| {} | {:.2} | {detected}/3 | {retriggers} | {false_alarms} |",
            v.label, peak_free[i]
        )
        .unwrap();
    }
    writeln!(report).unwrap();
}
