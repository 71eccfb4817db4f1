//! The demo's scenario: the simulated arm of each phase (the paper's payload, the free motion
//! with its three contacts) and the service's configuration for it.

use std::path::Path;

use fri_service::config::{Config, ReactionMode};
use mock_robot::SimulationConfig;
use mock_robot::config::ArmProfile;
use mock_robot::contact::{ContactProfile, ContactSpec};
use mock_robot::motion::MotionSegment;

use super::{CONTACTS_S, FREE_MOTION_S, PAYLOAD_COM, PAYLOAD_MASS, THRESHOLD_NM};

/// The simulated arm `arm` with seed `seed`, the paper's payload attached or not.
pub(super) fn sim(seed: u64, arm: ArmProfile, payload: bool) -> SimulationConfig {
    let mut c = SimulationConfig {
        name: "demo".into(),
        seed,
        ..SimulationConfig::default()
    };
    c.arm.profile = arm;
    c.payload.mass_kg = PAYLOAD_MASS;
    c.payload.com_m = PAYLOAD_COM;
    c.payload.attached_at_start = payload;
    c
}

/// The free-motion segment: five point-to-point moves and the way back to the start, contacts
/// on links 4, 6 and 7 at [`CONTACTS_S`], payload attached.
pub(super) fn free_motion(seed: u64, arm: ArmProfile) -> SimulationConfig {
    let mut c = sim(seed, arm, true);
    let p0 = mock_robot::config::DEFAULT_INITIAL_Q_DEG;
    let ptp = |q: [f64; 7], d: f64| MotionSegment::Ptp {
        q_deg: q,
        duration_s: Some(d),
        speed_fraction: None,
    };
    c.motion = vec![
        ptp([30.0, 45.0, 15.0, -45.0, 20.0, 70.0, 15.0], 3.0),
        ptp([-30.0, 20.0, -15.0, -80.0, -20.0, 45.0, -15.0], 3.5),
        ptp([20.0, 55.0, 25.0, -35.0, 30.0, 80.0, 25.0], 3.5),
        ptp([-25.0, 30.0, -20.0, -70.0, -25.0, 50.0, -20.0], 3.5),
        ptp([25.0, 40.0, 10.0, -50.0, 15.0, 65.0, 10.0], 3.0),
        ptp(p0, 3.0),
        MotionSegment::Dwell { duration_s: 1.0 },
    ];
    let contact = |link: usize, onset_s: f64, force: [f64; 3]| ContactSpec {
        link,
        point_m: [0.0, 0.0, 0.0],
        onset_s,
        profile: ContactProfile::HalfSine {
            peak_force_n: force,
            duration_s: 0.3,
        },
    };
    c.contacts = vec![
        contact(4, CONTACTS_S[0], [0.0, 60.0, 0.0]),
        contact(6, CONTACTS_S[1], [60.0, 0.0, 0.0]),
        contact(7, CONTACTS_S[2], [0.0, -50.0, 30.0]),
    ];
    c.duration_s = Some(FREE_MOTION_S + 0.5);
    c
}

/// The service's configuration for the demo, its files in `dir`.
pub(super) fn demo_config(dir: &Path) -> Config {
    let mut c = Config::default();
    c.fri.bind = "127.0.0.1:0".parse().unwrap_or(c.fri.bind);
    c.operator.socket = dir.join("operator.sock");
    c.state.dir = dir.join("state");
    c.iceoryx2.enabled = false;
    // Faster than the conservative defaults (still far below the LWR's limits) so the demo
    // finishes in about a minute.
    c.fri.max_joint_step = 1.0e-3;
    c.motion.max_velocity = [0.9; 7];
    // 2.5 rad/s²: faster, an undeclared 3 kg payload's inertial torque on the centred pattern's
    // moves reaches the workflow's residual check
    c.motion.max_acceleration = [2.5; 7];
    c.motion.max_jerk = [50.0; 7];
    c.estimation.settle_window_s = 0.1;
    c.estimation.average_s = 0.3;
    // the faster moves leave the arm ringing longer before it counts as settled
    c.estimation.settle_timeout_s = 2.0;
    // Each phase brings its simulated controller up on a new socket, at least 0.2 s after the
    // previous one stopped: a 0.1 s resync binds the new one at its first datagram (with the
    // default 1 s its first 0.8 s would go unanswered and the log would start late).
    c.fri.resync_after_s = 0.1;
    // Armed throughout (the default); the payload is declared unknown before it is attached.
    // Report only: the free motion is the controller's own program, which the service does not
    // hold, and every contact is to be counted.
    c.observer.thresholds = [THRESHOLD_NM; 7];
    c.reaction.policy = ReactionMode::Report;
    c
}
