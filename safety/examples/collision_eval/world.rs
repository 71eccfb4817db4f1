//! The simulated plant and the driver: mock-robot's controller and arm, driven in command mode
//! through `fri::session`, with the static payload estimate every run starts with.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use dynamics::{InertialParameters, LWR4_PICK_POSE_DEG, Model, lwr4};
use estimator::estimate::PayloadEstimate;
use estimator::samples::StaticSample;
use fri::handshake::{HandshakeStatus, KrlStatus, KrlStrategy, RequestKind};
use fri::session::{DesiredCommand, Session, SessionConfig};
use fri::wire::{CMD_LEN, InterfaceState, MSR_LEN, Measurement};
use mock_robot::contact::{ContactProfile, ContactSpec};
use mock_robot::{Simulation, SimulationConfig};
use nalgebra::Vector3;
use safety::{ObserverInput, PayloadCompensation};

use crate::T;
use crate::support::{Contact, Profile, Quintic, Trajectory, V7, heavy_payload_with_inertia};

/// Ten static poses around "pick" (pick + 7° · u_k, lwr4-model.md §4; the same as
/// mock-robot/scenarios/static-poses.toml), deg.
pub const STATIC_POSES_DEG: [[f64; 7]; 10] = [
    [-1.201, 33.2487, -3.695, -57.9595, -2.5673, 61.4777, -5.2765],
    [4.598, 29.4974, -0.3901, -62.919, 1.8655, 55.9554, -3.553],
    [-3.603, 25.7461, 2.9149, -53.8784, 6.2982, 64.4332, -1.8296],
    [2.196, 35.9948, 6.2198, -58.8379, -3.269, 58.9109, -0.1061],
    [-6.0051, 32.2436, -4.4752, -63.7974, 1.1637, 53.3886, 1.6174],
    [-0.2061, 28.4923, -1.1703, -54.7569, 5.5965, 61.8663, 3.3409],
    [5.5929, 24.741, 2.1347, -59.7164, -3.9708, 56.344, 5.0644],
    [-2.6081, 34.9897, 5.4396, -64.6759, 0.462, 64.8217, 6.7878],
    [3.1909, 31.2384, -5.2554, -55.6353, 4.8947, 59.2995, -5.4887],
    [
        -5.0101, 27.4871, -1.9505, -60.5948, -4.6725, 53.7772, -3.7652,
    ],
];

/// Time given to the FRI handshake (quality up to PERFECT, MON → CMD) before the
/// pick-estimate-and-move sequence starts, s.
pub const HANDSHAKE_S: f64 = 1.0;
/// Dwell at each static pose, s; τ_J, q and the controller's g(q) are averaged over its second
/// half.
pub const DWELL_S: f64 = 2.0;
/// Largest set-point step per cycle the FRI session may send, rad: the paper's sweeps reach
/// 1.75 rad/s on joint 1; the controller's jump rule is its velocity limit × cycle (≥ 1.92 mrad).
pub const MAX_JOINT_STEP_RAD: f64 = 1.9e-3;

pub fn deg(q: &[f64; 7]) -> V7 {
    V7::from_fn(|j, _| q[j].to_radians())
}

/// The simulated world of one run: mock-robot's controller and arm (payload 3.028 kg at
/// (0, 0, 0.119) m, perturbed controller model without it, torque sensors with noise, offset,
/// drift and quantisation, friction, contacts from the scenario), driven in command mode
/// (joint position strategy) through `fri::session` and the KRL handshake. Every run first
/// picks: it visits the ten static poses, estimates the payload from them with `estimator`
/// (eq. 26, Δτ = τ_J − g_ctrl), then moves to the run's start pose; experiment time 0 is
/// `t_start` of the simulation clock.
pub struct World {
    pub nominal: Model<7>,
    pub sim: Simulation,
    pub session: Session,
    pub desired: DesiredCommand,
    pub epoch: Instant,
    pub msr: Measurement,
    /// Simulation time of experiment time 0, s (a whole number of cycles).
    pub t_start: f64,
    /// Static payload estimate of this run (set by `new`).
    pub estimate: Option<PayloadEstimate>,
}

/// A contact of the experiment (experiment time) as a mock-robot scenario contact.
pub fn contact_spec(c: &Contact, t_start: f64) -> ContactSpec {
    let (onset, duration) = match c.profile {
        Profile::HalfSine { start, duration } => (start, duration),
        Profile::Box { .. } | Profile::Ramp { .. } => {
            panic!("the mock-robot harness only uses half-sine contacts")
        }
    };
    ContactSpec {
        link: c.link + 1,
        point_m: c.point.into(),
        onset_s: onset + t_start,
        profile: ContactProfile::HalfSine {
            peak_force_n: c.force.into(),
            duration_s: duration,
        },
    }
}

impl World {
    /// A run with robot seed `seed` (controller-model perturbation, sensor offsets and noise)
    /// that ends its pick-estimate sequence at rest at `q0`; `contacts` in experiment time.
    pub fn new(seed: u64, q0: &V7, contacts: &[Contact]) -> Self {
        let pick = deg(&LWR4_PICK_POSE_DEG);
        let mut waypoints = vec![pick];
        waypoints.extend(STATIC_POSES_DEG.iter().map(deg));
        waypoints.push(*q0);
        let prep = Quintic::new(&waypoints, 0.5, 0.5, DWELL_S);
        let t_start = ((HANDSHAKE_S + prep.duration()) / T).ceil() * T;
        let config = SimulationConfig {
            name: "collision_eval".into(),
            seed,
            initial_q_deg: LWR4_PICK_POSE_DEG,
            contacts: contacts.iter().map(|c| contact_spec(c, t_start)).collect(),
            ..SimulationConfig::loaded()
        };
        let sim = Simulation::new(config).expect("valid mock-robot configuration");
        let msr = *sim.measurement();
        let mut world = Self {
            nominal: lwr4(),
            sim,
            // The session's default step limit (0.2 mrad per cycle = 0.2 rad/s) would clip the
            // trajectories (up to 1.75 rad/s in the paper's sweeps); 1.9 mrad stays below the
            // controller's jump rule (velocity limit × cycle ≥ 1.92 mrad).
            session: Session::new(SessionConfig {
                max_joint_step: MAX_JOINT_STEP_RAD,
                ..SessionConfig::default()
            }),
            desired: DesiredCommand::default(),
            epoch: Instant::now(),
            msr,
            t_start,
            estimate: None,
        };
        world.enter_command_mode();
        world.estimate = Some(world.pick_and_estimate(&prep));
        world
    }

    /// One controller cycle: `fri::session` answers the current measurement with the desired
    /// command, the simulation advances.
    pub fn cycle(&mut self) {
        let mut msr_bytes = [0u8; MSR_LEN];
        self.msr.emit(&mut msr_bytes).expect("measurement encodes");
        let now = self.epoch + Duration::from_secs_f64(self.sim.time_s());
        let mut out = [0u8; CMD_LEN];
        let controller: SocketAddr = "127.0.0.1:49939".parse().expect("address");
        self.session
            .step(&msr_bytes, controller, now, &self.desired, &mut out)
            .expect("session answers the controller");
        self.sim.submit_datagram(&out, 0.0);
        self.msr = *self.sim.advance();
    }

    pub fn in_command(&self) -> bool {
        self.msr.interface.state == InterfaceState::Command
            && HandshakeStatus::read_from_measurement(&self.msr).status == KrlStatus::CommandActive
    }

    /// Waits for quality, requests joint-position command mode, holds until `HANDSHAKE_S`.
    pub fn enter_command_mode(&mut self) {
        while self.sim.time_s() < 0.2 {
            self.cycle();
        }
        self.session
            .request(RequestKind::StartCommandMode, KrlStrategy::JointPosition);
        while self.sim.time_s() < HANDSHAKE_S - 0.5 * T {
            self.cycle();
        }
        assert!(
            self.in_command(),
            "command mode not reached: {:?}",
            HandshakeStatus::read_from_measurement(&self.msr)
        );
    }

    /// Runs the pick sequence `prep` (experiment time −(t_start − HANDSHAKE_S) … 0): averages
    /// q, τ_J and the controller's g(q) over the second half of every dwell and estimates the
    /// payload from these static samples.
    pub fn pick_and_estimate(&mut self, prep: &Quintic) -> PayloadEstimate {
        let mut samples = Vec::new();
        let (mut still_since, mut last_q) = (0.0_f64, V7::repeat(f64::NAN));
        let mut sums = (V7::zeros(), V7::zeros(), V7::zeros(), 0usize);
        let flush = |sums: &mut (V7, V7, V7, usize), samples: &mut Vec<StaticSample<7>>| {
            if sums.3 > 100 {
                let n = sums.3 as f64;
                samples.push(StaticSample::new(sums.0 / n, sums.1 / n, sums.2 / n));
            }
            *sums = (V7::zeros(), V7::zeros(), V7::zeros(), 0);
        };
        while self.sim.time_s() < self.t_start - 0.5 * T {
            let t_prep = self.sim.time_s() - HANDSHAKE_S;
            let (q_d, qd_d, _) = prep.sample(t_prep + T);
            if qd_d.amax() > 0.0 || q_d != last_q {
                flush(&mut sums, &mut samples);
                still_since = t_prep;
                last_q = q_d;
            } else if t_prep - still_since >= 0.5 * DWELL_S {
                let d = &self.msr.data;
                sums.0 += V7::from(d.msr_jnt_pos);
                sums.1 += V7::from(d.msr_jnt_trq);
                sums.2 += V7::from(d.gravity);
                sums.3 += 1;
            }
            self.desired.joint_position = Some(q_d.into());
            self.cycle();
        }
        // The final dwell at q0 is cut at t_start: it is the settling time, not a sample.
        estimator::estimate::estimate_direct(
            &self.nominal,
            &samples,
            &estimator::estimate::EstimateOptions::default(),
        )
        .expect("static payload estimate")
    }

    /// This run's static payload estimate.
    pub fn estimate(&self) -> &PayloadEstimate {
        self.estimate.as_ref().expect("estimated in World::new")
    }

    /// Gravity-only payload compensation from this run's estimate (eq. 48).
    pub fn payload(&self) -> PayloadCompensation {
        let e = self.estimate();
        PayloadCompensation::gravity_from_com(e.mass, Vector3::from(e.com))
    }

    /// The estimate as a point mass in the full dynamics (`PayloadEstimate::to_point_mass`).
    pub fn payload_point_mass(&self) -> PayloadCompensation {
        PayloadCompensation::Full(self.estimate().to_point_mass())
    }

    /// The estimate with an assumed inertia (cylinder r = 5 cm, h = 10 cm about the CoM).
    pub fn payload_full(&self) -> PayloadCompensation {
        let e = self.estimate();
        PayloadCompensation::Full(InertialParameters::from_com(
            e.mass,
            Vector3::from(e.com),
            heavy_payload_with_inertia().inertia_about_com(),
        ))
    }

    /// Experiment time of the current measurement, s.
    pub fn time(&self) -> f64 {
        self.sim.time_s() - self.t_start
    }

    /// The current measurement as the observer sees it (msrJntPos, msrJntTrq, the controller's
    /// gravity vector) and the controller's own external-torque estimate estExtJntTrq.
    pub fn measure(&self) -> (ObserverInput<7>, V7) {
        let d = &self.msr.data;
        let mut input = ObserverInput::new(V7::from(d.msr_jnt_pos), V7::from(d.msr_jnt_trq), T);
        input.controller_gravity = Some(V7::from(d.gravity));
        (input, V7::from(d.est_ext_jnt_trq))
    }

    /// Commands the set-point of `trajectory` at the next cycle and runs one cycle.
    pub fn advance(&mut self, trajectory: &dyn Trajectory) {
        let (q_d, _, _) = trajectory.sample(self.time() + T);
        self.desired.joint_position = Some(q_d.into());
        self.cycle();
        debug_assert!(self.in_command());
    }

    /// True joint angles (rad) and velocities (rad/s).
    pub fn true_state(&self) -> (V7, V7) {
        (*self.sim.q(), *self.sim.qd())
    }
}

/// A set-point held for one controller tick (substeps see the same desired state, as over FRI).
pub struct SetPoint(pub V7, pub V7, pub V7);
impl Trajectory for SetPoint {
    fn sample(&self, _t: f64) -> (V7, V7, V7) {
        (self.0, self.1, self.2)
    }
}
