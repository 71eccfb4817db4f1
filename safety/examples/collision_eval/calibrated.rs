//! Evaluation at calibrated settings (`--calibrated`): thresholds from `safety::calibration` for
//! a false-alarm budget, scheduled by the motion, the contact fitted through the links'
//! Jacobians; false alarms in randomised free motion that includes the paper's q_A/q_B/q_C sweeps
//! at full speed and the estimation pose pattern at full speed; delay, misses and isolation of
//! 50 N contacts on links 4–7; F_min per link; a budget sweep (ROC).

use std::cell::{Cell, RefCell};
use std::fmt::Write as _;

use dynamics::{LWR4_PICK_POSE_DEG, lwr4};
use mock_robot::SimulationConfig;
use mock_robot::motion::{MotionPlayer, MotionSegment};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use safety::calibration::{
    Calibration, EnvelopeRecorder, FitOptions, LinkForce, minimum_detectable_force,
};
use safety::{
    CollisionMonitor, Detection, FeatureTracker, MonitorConfig, MonitorOutput, ReactionPolicy,
    lwr4_link_surfaces,
};

use crate::T;
use crate::args::Args;
use crate::campaign::{ContactPlan, ForceSpec, plan_contacts};
use crate::metrics::percentile;
use crate::scenario::random_waypoints;
use crate::support::{Quintic, Trajectory, V7};
use crate::variant::observer_config;
use crate::world::{STATIC_POSES_DEG, World, deg};
use crate::{GAIN, OFF_AXIS_NM};

/// The paper's sweeps as mock-robot scripts (joint-1 chirp up to ≈ 100°/s and 150°/s²).
const SWEEPS: [(&str, &str); 3] = [
    (
        "q_A",
        include_str!("../../../mock-robot/scenarios/sweep-qa.toml"),
    ),
    (
        "q_B",
        include_str!("../../../mock-robot/scenarios/sweep-qb.toml"),
    ),
    (
        "q_C",
        include_str!("../../../mock-robot/scenarios/sweep-qc.toml"),
    ),
];
/// Full speed of the estimation pose pattern: the largest joint speed \[rad/s\] and acceleration
/// \[rad/s²\] of the paper's sweeps.
const PATTERN_SPEED: (f64, f64) = (1.75, 2.6);
/// Budgets of the ROC sweep, false alarms per hour (the default 0.1 among them).
const BUDGETS: [f64; 5] = [10.0, 1.0, 0.1, 0.01, 0.001];
/// The lower observer gain evaluated beside the default, 1/s.
const LOW_GAIN: f64 = 200.0;
/// Index of the default budget in [`BUDGETS`].
const DEFAULT_BUDGET: usize = 2;
/// A quarter of the LWR's joint torque limits: the service's largest threshold \[Nm\].
const CEILING_NM: [f64; 7] = [44.0, 44.0, 25.0, 25.0, 25.0, 9.5, 9.5];

fn sweep_script(i: usize) -> Vec<MotionSegment> {
    SimulationConfig::from_toml_str(SWEEPS[i].1)
        .expect("shipped sweep scenario")
        .motion
}

/// A mock-robot motion script as a trajectory (its player advanced to the sampled time).
struct Script {
    player: RefCell<MotionPlayer>,
    clock: Cell<f64>,
}

enum Piece {
    Script(Script),
    Path(Quintic),
}

/// Pieces of motion played one after the other (each starts where the previous ended).
struct Program {
    pieces: Vec<(f64, f64, Piece)>,
    end_q: V7,
}

impl Program {
    fn new(q0: V7) -> Self {
        Self {
            pieces: Vec::new(),
            end_q: q0,
        }
    }
    fn duration(&self) -> f64 {
        self.pieces.last().map_or(0.0, |p| p.1)
    }
    fn push_script(&mut self, segments: &[MotionSegment]) {
        let player = MotionPlayer::new(segments, self.end_q);
        let length = player.total_duration_s();
        let mut probe = player.clone();
        probe.advance(length + 1.0);
        self.end_q = probe.sample().q;
        let start = self.duration();
        self.pieces.push((
            start,
            start + length,
            Piece::Script(Script {
                player: RefCell::new(player),
                clock: Cell::new(0.0),
            }),
        ));
    }
    fn push_path(&mut self, waypoints: &[V7], v_max: f64, a_max: f64, dwell: f64) {
        let mut points = vec![self.end_q];
        points.extend_from_slice(waypoints);
        let path = Quintic::new(&points, v_max, a_max, dwell);
        self.end_q = *points.last().unwrap();
        let start = self.duration();
        self.pieces
            .push((start, start + path.duration(), Piece::Path(path)));
    }
    /// The estimation pose pattern around "pick" at full speed, and back to pick.
    fn push_pattern(&mut self) {
        let pick = deg(&LWR4_PICK_POSE_DEG);
        let mut poses = vec![pick];
        poses.extend(STATIC_POSES_DEG.iter().map(deg));
        poses.push(pick);
        self.push_path(&poses, PATTERN_SPEED.0, PATTERN_SPEED.1, 0.3);
    }
    /// The built-in excitation: the three sweeps, then the pose pattern.
    fn push_excitation(&mut self) {
        for i in 0..SWEEPS.len() {
            self.push_script(&sweep_script(i));
        }
        self.push_pattern();
    }
}

impl Trajectory for Program {
    fn sample(&self, t: f64) -> (V7, V7, V7) {
        for (start, end, piece) in &self.pieces {
            if t > *end {
                continue;
            }
            let local = (t - start).max(0.0);
            return match piece {
                Piece::Path(p) => p.sample(local),
                Piece::Script(s) => {
                    let step = local - s.clock.get();
                    if step > 0.0 {
                        s.player.borrow_mut().advance(step);
                        s.clock.set(local);
                    }
                    let sp = s.player.borrow().sample();
                    (sp.q, sp.qd, sp.qdd)
                }
            };
        }
        (self.end_q, V7::zeros(), V7::zeros())
    }
}

/// A free-motion segment of `seconds`: sweep `sweep` (if any), the pose pattern, then random
/// waypoints (v_max 0.3–1.0 rad/s, a_max 0.2–0.6 rad/s², as the uncalibrated campaign).
fn free_program(
    rng: &mut StdRng,
    seconds: f64,
    sweep: Option<usize>,
    all_sweeps: bool,
) -> (V7, Program) {
    let q0 = deg(&LWR4_PICK_POSE_DEG);
    let mut program = Program::new(q0);
    if all_sweeps {
        program.push_excitation();
    } else {
        if let Some(i) = sweep {
            program.push_script(&sweep_script(i));
        }
        program.push_pattern();
    }
    let v_max = rng.random_range(0.3..1.0);
    let a_max = rng.random_range(0.2..0.6);
    let dwell = rng.random_range(0.0..1.0);
    while program.duration() < seconds {
        program.push_path(&random_waypoints(rng, 10), v_max, a_max, dwell);
    }
    (q0, program)
}

/// The monitor at calibrated settings (gain `gain`, the run's velocity filter, controller gravity,
/// report-only reaction, contact fit with the LWR's link surfaces).
fn calibrated_monitor(c: &Calibration<7>, gain: f64) -> MonitorConfig<7> {
    let mut config = MonitorConfig::new(T, gain);
    config.observer = observer_config();
    config.observer.gains = V7::repeat(gain);
    config.detector.thresholds_nm = c.thresholds_nm;
    config.detector.velocity_coefficients = c.velocity_coefficients;
    config.detector.schedule = c.schedule;
    config.threshold_to_noise = c.scale;
    config.link_surfaces = Some(lwr4_link_surfaces());
    config.reaction = ReactionPolicy::Stop;
    config.warmup_s = 0.0;
    config
}

/// The paper's setting for comparison: θ = 6 Nm on every joint, no scheduling, same fit.
fn fixed_monitor() -> MonitorConfig<7> {
    let mut config = MonitorConfig::new(T, GAIN);
    config.observer = observer_config();
    config.link_surfaces = Some(lwr4_link_surfaces());
    config.warmup_s = 0.0;
    config
}

/// Monitor configurations evaluated with the estimate as a point mass in M, C and g (marked by
/// a `threshold_to_noise` of the calibrated scale and this flag beside it).
struct Evaluated {
    config: MonitorConfig<7>,
    point_mass: bool,
}

fn build(e: &Evaluated, world: &World) -> CollisionMonitor<7> {
    let mut m = CollisionMonitor::new(world.nominal.clone(), e.config.clone()).unwrap();
    let payload = if e.point_mass {
        world.payload_point_mass()
    } else {
        world.payload()
    };
    m.set_payload(payload).unwrap();
    m.set_armed(true);
    m
}

/// Records the calibration: `worlds` runs of `seconds`, each the built-in excitation followed by
/// random free motion, with the observer the monitor uses and the same feature tracker.
fn record_calibration(
    seed: u64,
    worlds: usize,
    seconds: f64,
    gain: f64,
    point_mass: bool,
) -> EnvelopeRecorder<7> {
    let mut rec = EnvelopeRecorder::<7>::new();
    // Diagnostics: COLLISION_EVAL_DUMP=FILE writes the first run's 10 ms windows (time, largest
    // |r_j|, smallest features) as CSV.
    let mut dump = std::env::var_os("COLLISION_EVAL_DUMP").map(|p| {
        let mut f = std::io::BufWriter::new(std::fs::File::create(p).unwrap());
        use std::io::Write as _;
        writeln!(
            f,
            "t,{}",
            (0..6)
                .flat_map(|k| (1..=7).map(move |j| format!(
                    "{}{j}",
                    ["r", "speed", "noise", "payload", "inertial", "gravity"][k]
                )))
                .collect::<Vec<_>>()
                .join(",")
        )
        .unwrap();
        (f, [0.0f64; 7], [[f64::INFINITY; 7]; 5])
    });
    for w in 0..worlds {
        let mut rng = StdRng::seed_from_u64(seed.wrapping_add(w as u64));
        let (q0, program) = free_program(&mut rng, seconds, None, true);
        let mut world = World::new(seed.wrapping_add(500 + w as u64), &q0, &[]);
        let mut config = observer_config();
        config.gains = V7::repeat(gain);
        let mut obs = safety::MomentumObserver::new(world.nominal.clone(), config).unwrap();
        let payload = if point_mass {
            world.payload_point_mass()
        } else {
            world.payload()
        };
        obs.set_payload(payload.clone()).unwrap();
        let mut tracker = FeatureTracker::new(&world.nominal, &payload);
        let ticks = (seconds / T) as usize;
        for k in 0..ticks {
            let (input, _) = world.measure();
            let out = obs.step(&input);
            let f = *tracker.step(&input.q, &out.velocity, T);
            // The monitor's warm-up (50 ms): start-up transients are not free motion.
            if k > 50 {
                rec.push(out.time_s, &out.residual, &f);
                if w == 0
                    && let Some((file, peak, low)) = &mut dump
                {
                    use std::io::Write as _;
                    for j in 0..7 {
                        peak[j] = peak[j].max(out.residual[j].abs());
                        for (i, v) in f.regressors(j)[1..].iter().enumerate() {
                            low[i][j] = low[i][j].min(*v);
                        }
                    }
                    if k % 10 == 0 {
                        let cells: Vec<String> = peak
                            .iter()
                            .chain(low.iter().flatten())
                            .map(|x| format!("{x:.4}"))
                            .collect();
                        writeln!(file, "{:.3},{}", k as f64 * T, cells.join(",")).unwrap();
                        *peak = [0.0; 7];
                        *low = [[f64::INFINITY; 7]; 5];
                    }
                }
            }
            world.advance(&program);
        }
        eprintln!("calibration recording {}/{worlds} done", w + 1);
    }
    rec
}

fn fit(rec: &EnvelopeRecorder<7>, budget: f64) -> Calibration<7> {
    let mut options = FitOptions::<7>::new(T);
    options.budget_per_hour = budget;
    options.ceiling_nm = V7::from(CEILING_NM);
    rec.fit(&options).expect("calibration fits")
}

/// False alarms of one monitor over the free-motion hour.
#[derive(Default, Clone)]
struct FreeResult {
    onsets: usize,
    /// Largest |r_j|/θ_j per joint over the hour.
    margin: [f64; 7],
    /// Where the largest ratio happened: (segment label, time s, joint).
    worst: (String, f64, usize),
    /// The effective thresholds every 100 ms \[Nm\].
    thresholds: Vec<V7>,
}

impl FreeResult {
    /// Median effective threshold per joint over the hour \[Nm\].
    fn median_thresholds(&self) -> V7 {
        V7::from_fn(|j, _| {
            let mut v: Vec<f64> = self.thresholds.iter().map(|t| t[j]).collect();
            v.sort_by(f64::total_cmp);
            percentile(&v, 0.5)
        })
    }
}

fn track(
    out: &MonitorOutput<7>,
    monitor: &CollisionMonitor<7>,
    result: &mut FreeResult,
    label: &str,
    t: f64,
) {
    if let Some(Detection::Onset(_)) = out.detection {
        result.onsets += 1;
    }
    let f = monitor
        .features()
        .copied()
        .unwrap_or_else(|| safety::MotionFeatures::from_speed(&out.observer.velocity));
    let theta = monitor.detector().config().thresholds_for(&f);
    if (t * 10.0).fract() < 0.5 * T * 10.0 {
        result.thresholds.push(theta);
    }
    for j in 0..7 {
        let ratio = out.observer.residual[j].abs() / theta[j];
        if ratio > result.margin[j] {
            result.margin[j] = ratio;
            if ratio >= result.margin.iter().cloned().fold(0.0, f64::max) {
                result.worst = (label.to_owned(), t, j);
            }
        }
    }
}

/// The free-motion hour: segments of 300 s, each its own mock-robot run (seed, payload
/// estimate), with sweep q_A/q_B/q_C in turn and the pose pattern at full speed first.
fn free_hour(seed: u64, hours: f64, configs: &[Evaluated]) -> (Vec<FreeResult>, f64) {
    let segment_s = 300.0_f64.min(hours * 3600.0);
    let segments = (hours * 3600.0 / segment_s).ceil() as usize;
    let mut results = vec![FreeResult::default(); configs.len()];
    let mut simulated = 0.0;
    for seg in 0..segments {
        let mut rng = StdRng::seed_from_u64(seed.wrapping_mul(37).wrapping_add(seg as u64));
        let sweep = seg % SWEEPS.len();
        let (q0, program) = free_program(&mut rng, segment_s, Some(sweep), false);
        let mut world = World::new(seed.wrapping_add(3000 + seg as u64), &q0, &[]);
        let mut monitors: Vec<CollisionMonitor<7>> =
            configs.iter().map(|c| build(c, &world)).collect();
        let label = format!("segment {} ({} sweep)", seg + 1, SWEEPS[sweep].0);
        let ticks = (segment_s / T) as usize;
        for k in 0..ticks {
            let t = k as f64 * T;
            let (input, _) = world.measure();
            for (m, r) in monitors.iter_mut().zip(results.iter_mut()) {
                let out = m.step(&input);
                if k > 50 {
                    track(&out, m, r, &label, t);
                }
            }
            world.advance(&program);
        }
        simulated += segment_s;
        eprintln!(
            "calibrated free motion segment {}/{segments} done (onsets: {:?})",
            seg + 1,
            results.iter().map(|r| r.onsets).collect::<Vec<_>>()
        );
    }
    (results, simulated / 3600.0)
}

/// One contact's outcome for one monitor.
#[derive(Clone, Default)]
struct Outcome {
    delay_s: Option<f64>,
    onset_link: Option<usize>,
    onset_confidence: f64,
    best_link: Option<usize>,
    best_confidence: f64,
}

struct ContactResult {
    outcomes: Vec<Outcome>,
    false_alarms: usize,
}

/// A contact campaign observed by every monitor.
fn contacts(plan: &ContactPlan, seed: u64, configs: &[Evaluated]) -> Vec<ContactResult> {
    let mut world = World::new(seed ^ 0xC0, &plan.q0, &plan.contacts);
    let mut monitors: Vec<CollisionMonitor<7>> = configs.iter().map(|c| build(c, &world)).collect();
    let mut results: Vec<ContactResult> = configs
        .iter()
        .map(|_| ContactResult {
            outcomes: vec![Outcome::default(); plan.records.len()],
            false_alarms: 0,
        })
        .collect();
    let mut active: Vec<Option<usize>> = vec![None; configs.len()];
    let ticks = (plan.total_s / T) as usize;
    for k in 0..ticks {
        let t = k as f64 * T;
        let (input, _) = world.measure();
        let window = plan
            .records
            .iter()
            .position(|r| k >= r.window.0 && k <= r.window.1);
        for ((m, res), act) in monitors
            .iter_mut()
            .zip(results.iter_mut())
            .zip(active.iter_mut())
        {
            let out = m.step(&input);
            if k <= 50 {
                continue;
            }
            match out.detection {
                Some(Detection::Onset(e)) => match window {
                    Some(i) if res.outcomes[i].delay_s.is_none() => {
                        let o = &mut res.outcomes[i];
                        o.delay_s = Some(t - plan.records[i].start);
                        o.onset_link = Some(e.isolated_link);
                        o.onset_confidence = e.contact.map_or(0.0, |c| c.confidence);
                        *act = Some(i);
                    }
                    Some(_) => {}
                    None => res.false_alarms += 1,
                },
                Some(Detection::Released { .. }) => {
                    if let Some(i) = act.take()
                        && let Some(c) = m.contact()
                    {
                        res.outcomes[i].best_link = Some(c.link);
                        res.outcomes[i].best_confidence = c.confidence;
                    }
                }
                _ => {}
            }
        }
        world.advance(&plan.trajectory);
    }
    results
}

/// Share in percent.
fn share(n: usize, of: usize) -> f64 {
    if of == 0 {
        f64::NAN
    } else {
        100.0 * n as f64 / of as f64
    }
}

fn fmt7(v: &V7, digits: usize) -> String {
    v.iter()
        .map(|x| format!("{x:.digits$}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn fmin_row(label: &str, f: &[LinkForce]) -> String {
    format!(
        "| {label} | {} |",
        f.iter()
            .map(|l| format!("{:.1}", l.median_n))
            .collect::<Vec<_>>()
            .join(" | ")
    )
}

/// Runs the whole calibrated evaluation and writes `calibrated.md` into `args.out`.
pub fn calibrated(args: &Args) {
    let started = std::time::Instant::now();
    let mut report = String::new();
    let calibration_s = 300.0;
    let rec = record_calibration(args.seed ^ 0xCA1B, 2, calibration_s, GAIN, false);
    let fits: Vec<Calibration<7>> = BUDGETS.iter().map(|&b| fit(&rec, b)).collect();
    let cal = &fits[DEFAULT_BUDGET];
    // The same at a lower observer gain: the velocity noise in r scales with K.
    let rec_low = record_calibration(args.seed ^ 0xCA1B, 2, calibration_s, LOW_GAIN, false);
    let cal_low = fit(&rec_low, BUDGETS[DEFAULT_BUDGET]);
    // And with the estimate as a point mass in M, C and g: a push's acceleration of the payload
    // no longer shows on the wrist joints as a residual.
    let rec_pm = record_calibration(args.seed ^ 0xCA1B, 2, calibration_s, LOW_GAIN, true);
    let cal_pm = fit(&rec_pm, BUDGETS[DEFAULT_BUDGET]);
    // The service's configuration: the point mass at the default gain.
    let rec_service = record_calibration(args.seed ^ 0xCA1B, 2, calibration_s, GAIN, true);
    let cal_service = fit(&rec_service, BUDGETS[DEFAULT_BUDGET]);
    eprintln!(
        "calibration fitted after {:.0} s",
        started.elapsed().as_secs_f64()
    );
    writeln!(
        report,
        "## collision_eval --calibrated (seed {}, K_I = {GAIN} 1/s; and K_I = {LOW_GAIN} 1/s)\n",
        args.seed
    )
    .unwrap();
    writeln!(report, "Calibration recording (per gain): 2 mock-robot runs × {calibration_s:.0} s (own seeds and payload estimates), each the built-in excitation (the paper's q_A, q_B, q_C sweeps, then the ten-pose estimation pattern at {} rad/s, {} rad/s²) followed by random free motion; {} blocks of {:.1} s. Budget {} false alarms/h (per joint {:.3}/h), scales at the {:.0} % bootstrap bound.\n",
        PATTERN_SPEED.0, PATTERN_SPEED.1, cal.blocks, cal.block_s, cal.budget_per_hour, cal.budget_per_hour / 7.0, cal.confidence * 100.0).unwrap();
    for (label, c) in [
        (format!("K_I = {GAIN} 1/s"), cal),
        (format!("K_I = {LOW_GAIN} 1/s"), &cal_low),
        (
            format!("K_I = {LOW_GAIN} 1/s, payload as a point mass in M, C, g"),
            &cal_pm,
        ),
        (
            format!("K_I = {GAIN} 1/s, payload as a point mass in M, C, g (the service)"),
            &cal_service,
        ),
    ] {
        writeln!(report, "{label}:\n").unwrap();
        calibration_table(&mut report, c);
    }

    // F_min at the calibrated thresholds.
    let model = lwr4();
    let surfaces = lwr4_link_surfaces();
    let fmin = |theta: &V7| {
        minimum_detectable_force(&model, &surfaces, theta, 2000, 0.8, args.seed ^ 0xF0)
    };
    writeln!(report, "### Minimum detectable force per link (median over 2000 configurations within 80 % of the ranges, surface points and directions; F_min = min_j θ_j/|(J_vᵀn)_j|) [N]\n").unwrap();
    writeln!(report, "| thresholds | link 1 | link 2 | link 3 | link 4 | link 5 | link 6 | link 7 |\n|---|---|---|---|---|---|---|---|").unwrap();
    writeln!(
        report,
        "{}",
        fmin_row("θ = 6 Nm (paper)", &fmin(&V7::repeat(6.0)))
    )
    .unwrap();
    writeln!(
        report,
        "{}",
        fmin_row("calibrated, at rest", &fmin(&cal.thresholds_nm))
    )
    .unwrap();
    writeln!(
        report,
        "{}",
        fmin_row(
            "calibrated, median over the recording",
            &fmin(&cal.median_thresholds_nm)
        )
    )
    .unwrap();
    writeln!(
        report,
        "{}",
        fmin_row(
            &format!("calibrated at K = {LOW_GAIN}, at rest"),
            &fmin(&cal_low.thresholds_nm)
        )
    )
    .unwrap();
    writeln!(
        report,
        "{}",
        fmin_row(
            &format!("calibrated at K = {LOW_GAIN}, median over the recording"),
            &fmin(&cal_low.median_thresholds_nm)
        )
    )
    .unwrap();
    for (gain, c) in [(LOW_GAIN, &cal_pm), (GAIN, &cal_service)] {
        for (label, theta) in [
            ("point mass, at rest", &c.thresholds_nm),
            (
                "point mass, median over the recording",
                &c.median_thresholds_nm,
            ),
        ] {
            writeln!(
                report,
                "{}",
                fmin_row(&format!("calibrated at K = {gain}, {label}"), &fmin(theta))
            )
            .unwrap();
        }
    }
    writeln!(report).unwrap();
    // Free-motion hour with the sweeps and patterns: every budget and the fixed 6 Nm.
    let plain = |config| Evaluated {
        config,
        point_mass: false,
    };
    let mut configs: Vec<Evaluated> = fits
        .iter()
        .map(|c| plain(calibrated_monitor(c, GAIN)))
        .collect();
    configs.push(plain(calibrated_monitor(&cal_low, LOW_GAIN)));
    configs.push(Evaluated {
        config: calibrated_monitor(&cal_pm, LOW_GAIN),
        point_mass: true,
    });
    configs.push(Evaluated {
        config: calibrated_monitor(&cal_service, GAIN),
        point_mass: true,
    });
    configs.push(plain(fixed_monitor()));
    let labels: Vec<String> = BUDGETS
        .iter()
        .map(|b| format!("calibrated, budget {b}/h"))
        .chain([
            format!(
                "calibrated at K = {LOW_GAIN} 1/s, budget {}/h",
                BUDGETS[DEFAULT_BUDGET]
            ),
            format!(
                "calibrated at K = {LOW_GAIN} 1/s, point-mass payload, budget {}/h",
                BUDGETS[DEFAULT_BUDGET]
            ),
            format!(
                "**the service**: calibrated at K = {GAIN} 1/s, point-mass payload, budget {}/h",
                BUDGETS[DEFAULT_BUDGET]
            ),
            "θ = 6 Nm, no scheduling".to_string(),
        ])
        .collect();
    assert_eq!(
        labels.len(),
        configs.len(),
        "one label per evaluated monitor"
    );
    let (free, hours) = free_hour(args.seed, args.hours, &configs);
    eprintln!(
        "free hour done after {:.0} s",
        started.elapsed().as_secs_f64()
    );
    writeln!(report, "F_min at the median effective thresholds of the free-motion hour below (v ≤ 1 rad/s between the sweeps and patterns):\n").unwrap();
    writeln!(report, "| thresholds | link 1 | link 2 | link 3 | link 4 | link 5 | link 6 | link 7 |\n|---|---|---|---|---|---|---|---|").unwrap();
    for (l, f) in labels.iter().zip(&free) {
        if l.contains("budget 0.1/h") {
            let m = f.median_thresholds();
            writeln!(
                report,
                "{}",
                fmin_row(&format!("{l}: ({}) Nm", fmt7(&m, 2)), &fmin(&m))
            )
            .unwrap();
        }
    }
    writeln!(report).unwrap();
    writeln!(report, "### False alarms in {hours:.2} h of free motion (segments of 300 s, each its own run and payload estimate: one of the q_A/q_B/q_C sweeps at full speed, the pose pattern at full speed, then random waypoints)\n").unwrap();
    writeln!(report, "| monitor | false alarms | per hour | largest \\|r_j\\|/θ_j per joint | where the largest ratio was |\n|---|---|---|---|---|").unwrap();
    for (l, r) in labels.iter().zip(&free) {
        writeln!(
            report,
            "| {l} | {} | {:.2} | {} | {}, t = {:.2} s, joint {} |",
            r.onsets,
            r.onsets as f64 / hours,
            r.margin
                .iter()
                .map(|x| format!("{x:.2}"))
                .collect::<Vec<_>>()
                .join(", "),
            r.worst.0,
            r.worst.1,
            r.worst.2 + 1
        )
        .unwrap();
    }
    writeln!(report).unwrap();

    // 50 N / 20 ms contacts on links 4–7.
    let plan = plan_contacts(
        args.seed + 20,
        args.contacts,
        &[3, 4, 5, 6],
        ForceSpec::Fixed(50.0),
        0.02,
        true,
    );
    let runs = contacts(&plan, args.seed + 20, &configs);
    eprintln!(
        "50 N campaign done after {:.0} s",
        started.elapsed().as_secs_f64()
    );
    writeln!(report, "### 50 N / 20 ms half-sine contacts on links 4–7 during motion ({} contacts; v ≤ 0.7 rad/s)\n", plan.records.len()).unwrap();
    writeln!(report, "Isolation: the contact fitted through each link's Jacobian (`ContactIsolator`) at the onset, and its best fit over the contact (refit whenever the residual grew by 20 %). Off-axis: the hit link's own joint sees ≥ {OFF_AXIS_NM} Nm of static τ_ext.\n").unwrap();
    writeln!(report, "| monitor | missed | delay median [ms] | p95 [ms] | isolation onset / best | off-axis onset / best | off-axis best, links 4 / 5 / 6 / 7 | median confidence (correct / wrong) | false alarms |\n|---|---|---|---|---|---|---|---|---|").unwrap();
    for (l, r) in labels.iter().zip(&runs) {
        contact_row(&mut report, l, r, &plan);
    }
    writeln!(report).unwrap();

    // ROC: detection of 15–80 N contacts on every link, per budget.
    let roc_plan = plan_contacts(
        args.seed + 77,
        args.contacts,
        &[0, 1, 2, 3, 4, 5, 6],
        ForceSpec::Uniform(15.0, 80.0),
        0.02,
        true,
    );
    let roc = contacts(&roc_plan, args.seed + 77, &configs);
    writeln!(
        report,
        "### ROC over the budget (15–80 N / 20 ms on links 1–7; false alarms from the hour above)\n"
    )
    .unwrap();
    writeln!(
        report,
        "| monitor | detected | false alarms / h | detected per link 1–7 |\n|---|---|---|---|"
    )
    .unwrap();
    let mut csv = String::from("monitor,budget_per_hour,detection_rate,false_alarms_per_hour\n");
    for ((l, r), f) in labels.iter().zip(&roc).zip(&free) {
        let detected = r.outcomes.iter().filter(|o| o.delay_s.is_some()).count();
        let per_link: Vec<String> = (0..7)
            .map(|link| {
                let idx: Vec<usize> = (0..roc_plan.records.len())
                    .filter(|&i| roc_plan.records[i].link == link)
                    .collect();
                let d = idx
                    .iter()
                    .filter(|&&i| r.outcomes[i].delay_s.is_some())
                    .count();
                format!("{d}/{}", idx.len())
            })
            .collect();
        writeln!(
            report,
            "| {l} | {:.1} % | {:.2} | {} |",
            share(detected, r.outcomes.len()),
            f.onsets as f64 / hours,
            per_link.join(", ")
        )
        .unwrap();
        let budget = l
            .split("budget ")
            .nth(1)
            .map_or(String::new(), |b| b.trim_end_matches("/h").to_string());
        writeln!(
            csv,
            "{l},{budget},{:.4},{:.3}",
            detected as f64 / r.outcomes.len() as f64,
            f.onsets as f64 / hours
        )
        .unwrap();
    }
    writeln!(report).unwrap();
    std::fs::write(args.out.join("roc_calibrated.csv"), csv).unwrap();
    writeln!(report, "Calibrated thresholds at rest (budget 0.1/h): ({}) Nm; median over the recording: ({}) Nm. Wall time {:.0} s.",
        fmt7(&cal.thresholds_nm, 2), fmt7(&cal.median_thresholds_nm, 2), started.elapsed().as_secs_f64()).unwrap();
    std::fs::write(args.out.join("calibrated.md"), &report).unwrap();
    std::fs::write(args.out.join("calibration.json"), serde_json_like(cal)).unwrap();
    print!("{report}");
}

fn calibration_table(report: &mut String, cal: &Calibration<7>) {
    writeln!(report, "| joint | θ at rest [Nm] | median θ [Nm] | max θ [Nm] | envelope floor / speed / noise / payload / inertial / gravity | tail | scale s (point, σ, 90 % interval) | peak \\|r\\| [Nm] | max \\|q̇\\| [rad/s] | max \\|q̈\\| [rad/s²] |\n|---|---|---|---|---|---|---|---|---|---|").unwrap();
    for (j, c) in cal.joints.iter().enumerate() {
        writeln!(
            report,
            "| {} | {:.2} | {:.2} | {:.2} | {:.3} / {:.3} / {:.3} / {:.3} / {:.3} / {:.4} | {} (ξ ∈ [{:.2}, {:.2}]) | {:.2} ({:.2}, {:.2}, [{:.2}, {:.2}]) | {:.2} | {:.2} | {:.2} |",
            j + 1,
            c.threshold_at_rest_nm,
            c.threshold_median_nm,
            c.threshold_max_nm,
            c.envelope[0], c.envelope[1], c.envelope[2], c.envelope[3], c.envelope[4], c.envelope[5],
            c.tail.name(),
            c.shape_interval[0], c.shape_interval[1],
            c.scale, c.scale_point, c.scale_std, c.scale_interval[0], c.scale_interval[1],
            c.peak_nm,
            c.max_speed,
            c.max_acceleration
        )
        .unwrap();
    }
    writeln!(report).unwrap();
}

/// The calibration as readable text (Debug; the example has no JSON dependency).
fn serde_json_like(c: &Calibration<7>) -> String {
    format!("{c:#?}\n")
}

fn contact_row(report: &mut String, label: &str, r: &ContactResult, plan: &ContactPlan) {
    let n = plan.records.len();
    let mut delays: Vec<f64> = r
        .outcomes
        .iter()
        .filter_map(|o| o.delay_s.map(|d| d * 1e3))
        .collect();
    delays.sort_by(f64::total_cmp);
    let missed = n - delays.len();
    let detected: Vec<usize> = (0..n)
        .filter(|&i| r.outcomes[i].delay_s.is_some())
        .collect();
    let off_axis: Vec<usize> = detected
        .iter()
        .copied()
        .filter(|&i| plan.records[i].own_joint_torque >= OFF_AXIS_NM)
        .collect();
    let right = |set: &[usize], best: bool| {
        set.iter()
            .filter(|&&i| {
                let o = &r.outcomes[i];
                let link = if best {
                    o.best_link.or(o.onset_link)
                } else {
                    o.onset_link
                };
                link == Some(plan.records[i].link)
            })
            .count()
    };
    let per_link: Vec<String> = (3..7)
        .map(|link| {
            let set: Vec<usize> = off_axis
                .iter()
                .copied()
                .filter(|&i| plan.records[i].link == link)
                .collect();
            format!("{:.0} %", share(right(&set, true), set.len()))
        })
        .collect();
    let mut conf_right: Vec<f64> = Vec::new();
    let mut conf_wrong: Vec<f64> = Vec::new();
    for &i in &detected {
        let o = &r.outcomes[i];
        if o.best_link.or(o.onset_link) == Some(plan.records[i].link) {
            conf_right.push(o.best_confidence.max(o.onset_confidence));
        } else {
            conf_wrong.push(o.best_confidence.max(o.onset_confidence));
        }
    }
    if std::env::var_os("COLLISION_EVAL_CONFUSION").is_some() {
        let mut confusion = [[0usize; 8]; 7];
        for &i in &off_axis {
            let o = &r.outcomes[i];
            confusion[plan.records[i].link][o.best_link.or(o.onset_link).map_or(7, |l| l)] += 1;
        }
        eprintln!(
            "{label}: off-axis true link (rows) → isolated (columns 1..7, none): {confusion:?}"
        );
    }
    conf_right.sort_by(f64::total_cmp);
    conf_wrong.sort_by(f64::total_cmp);
    writeln!(
        report,
        "| {label} | {missed}/{n} | {:.1} | {:.1} | {:.0} % / {:.0} % | {:.0} % / {:.0} % ({} contacts) | {} | {:.2} / {:.2} | {} |",
        percentile(&delays, 0.5),
        percentile(&delays, 0.95),
        share(right(&detected, false), detected.len()),
        share(right(&detected, true), detected.len()),
        share(right(&off_axis, false), off_axis.len()),
        share(right(&off_axis, true), off_axis.len()),
        off_axis.len(),
        per_link.join(" / "),
        percentile(&conf_right, 0.5),
        percentile(&conf_wrong, 0.5),
        r.false_alarms
    )
    .unwrap();
}
