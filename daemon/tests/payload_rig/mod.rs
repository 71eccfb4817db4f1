//! The rig of the collision-reaction and unknown-payload tests: the cycle processor cycle by
//! cycle without sockets or sleeps, against a synthetic controller in command mode that follows
//! every set-point exactly and measures τ_J = M(q)q̈ + C(q, q̇)q̇ + g(q) + g_payload(q) − τ_ext (the
//! arm's own dynamics at the last step's velocity and acceleration), so residual = τ_ext −
//! (payload error). The payload can be carried at once or attached over a ramp (a real grasp),
//! forces act on any link (the flange included), and the service's refit of static samples is
//! done as the service does it.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    missing_docs,
    dead_code,
    unused_imports
)]

pub use std::sync::mpsc::{Receiver, SyncSender, sync_channel};

pub use dynamics::{
    Data, Model, compute_generalized_gravity, payload_gravity_regressor, point_jacobian, rnea,
};
pub use fri::handshake::{HandshakeRequest, HandshakeStatus};
pub use fri::session::{Arrival, Verdict};
pub use fri::wire::{InterfaceState, Measurement, Quality};
pub use fri_service::config::{Config, ReactionMode};
pub use fri_service::service::build_monitor;
pub use fri_service::service::cycle::{
    CycleEvent, CycleProcessor, CycleRequest, ProcessorSettings,
};
pub use fri_service::service::output::{AbortReason, ResyncReason, StopReason};
pub use nalgebra::{SVector, Vector3};
pub use safety::{
    FlangeLoadBounds, GraspTiming, LoadSample, PayloadCompensation, PayloadHypothesis,
    fit_hypothesis,
};
pub use trajectory::MotionLimits;

pub type V7 = SVector<f64, 7>;

/// The paper's pick pose, rad.
pub const PICK: [f64; 7] = dynamics::LWR4_PICK_POSE_RAD;

/// A real payload at the flange: 3 kg, 0.12 m along z of frame 7.
pub const PAYLOAD_KG: f64 = 3.0;
pub const PAYLOAD_COM: [f64; 3] = [0.0, 0.0, 0.12];

/// The service's default bounds of an unknown payload (`[unknown_payload]`).
pub const BOUNDS: FlangeLoadBounds = FlangeLoadBounds {
    max_mass_kg: 7.0,
    radius_m: 0.3,
};

/// A force on a link: link 1..7, point in the link's DH frame (m), force in the base frame (N).
#[derive(Debug, Clone, Copy)]
pub struct LinkForce {
    pub link: usize,
    pub point: [f64; 3],
    pub force: [f64; 3],
}

pub struct Rig {
    pub processor: CycleProcessor,
    pub requests: SyncSender<CycleRequest>,
    pub events: Receiver<CycleEvent>,
    pub model: Model<7>,
    pub data: Data<7>,
    pub q: V7,
    pub seq: u16,
    /// Sequence number of the previous measurement.
    pub previous_seq: Option<u16>,
    /// Payload really carried by the arm.
    pub carried: bool,
    /// Share of the payload's weight the arm carries (1 once grasped; a grasp over a ramp
    /// raises it by `ramp` per cycle).
    pub share: f64,
    /// Rise of `share` per cycle while a grasp lasts (0: none).
    pub ramp: f64,
    /// Timing of the declarations (`[unknown_payload]`'s defaults unless a test shortens it).
    pub timing: GraspTiming,
    /// The carried payload (m, m·c) in frame 7.
    pub payload: nalgebra::Vector4<f64>,
    /// External torque applied to the arm, Nm.
    pub external: V7,
    /// A force on a link, applied on top of `external`.
    pub link_force: Option<LinkForce>,
    /// Number of the current unknown-payload declaration.
    pub declaration: u32,
    /// Static samples since that declaration.
    pub samples: Vec<LoadSample<7>>,
    /// The last hypothesis fitted to them.
    pub hypothesis: Option<PayloadHypothesis<7>>,
    /// The controller dropped to monitor mode and brakes at this rate, rad/s².
    pub braking: Option<f64>,
    pub velocity: V7,
    /// The velocity of the step before, rad/s (the acceleration the torques carry).
    pub previous_velocity: V7,
}

impl Rig {
    pub fn new(policy: ReactionMode, armed: bool) -> Self {
        let mut config = Config::default();
        config.reaction.policy = policy;
        config.reaction.pause_s = 0.2;
        let model = dynamics::lwr4();
        let monitor = build_monitor(&config, model.clone()).unwrap();
        let (requests, request_rx) = sync_channel(64);
        let (event_tx, events) = sync_channel(1 << 16);
        let m = &config.motion;
        let processor = CycleProcessor::new(
            ProcessorSettings {
                cycle_s: 0.001,
                limits: MotionLimits {
                    velocity: m.max_velocity.into(),
                    acceleration: m.max_acceleration.into(),
                    jerk: m.max_jerk.into(),
                },
                react: policy != ReactionMode::Report,
                armed,
            },
            monitor,
            request_rx,
            event_tx,
        );
        Self {
            processor,
            requests,
            events,
            data: Data::new(&model),
            model,
            q: V7::from(PICK),
            seq: 100,
            previous_seq: None,
            carried: false,
            share: 1.0,
            ramp: 0.0,
            timing: GraspTiming::default(),
            payload: PayloadCompensation::gravity_from_com(PAYLOAD_KG, Vector3::from(PAYLOAD_COM))
                .gravity_parameters(),
            external: V7::zeros(),
            link_force: None,
            declaration: 0,
            samples: Vec::new(),
            hypothesis: None,
            braking: None,
            velocity: V7::zeros(),
            previous_velocity: V7::zeros(),
        }
    }

    pub fn send(&self, r: CycleRequest) {
        self.requests.try_send(r).unwrap();
    }

    /// The external joint torque now, Nm: `external` plus the link force through J_pᵀ.
    pub fn contact_torque(&mut self) -> V7 {
        let mut t = self.external;
        if let Some(f) = self.link_force {
            let j = point_jacobian(
                &self.model,
                &mut self.data,
                &self.q,
                f.link - 1,
                &Vector3::from(f.point),
            );
            t += j.fixed_rows::<3>(0).transpose() * Vector3::from(f.force);
        }
        t
    }

    /// The carried payload's gravity torque at the current pose, Nm.
    pub fn payload_torque(&mut self) -> V7 {
        if self.carried {
            payload_gravity_regressor(&self.model, &mut self.data, &self.q)
                * self.payload
                * self.share
        } else {
            V7::zeros()
        }
    }

    pub fn measurement(&mut self) -> Measurement {
        self.seq = self.seq.wrapping_add(1);
        let g = compute_generalized_gravity(&self.model, &mut self.data, &self.q);
        let acceleration = (self.velocity - self.previous_velocity) / 0.001;
        let arm = rnea(
            &self.model,
            &mut self.data,
            &self.q,
            &self.velocity,
            &acceleration,
        );
        let mut tau = arm - self.contact_torque() + self.payload_torque();
        // Sensor noise of a few mNm: the observer rejects bit-identical (stale) samples.
        tau[0] += 1e-3 * f64::from(self.seq % 7);
        let mut m = Measurement::default();
        m.header.send_seq_count = self.seq;
        m.interface.state = if self.braking.is_some() {
            InterfaceState::Monitor
        } else {
            InterfaceState::Command
        };
        m.interface.quality = Quality::Perfect;
        m.robot.power = 0x7f;
        m.data.msr_jnt_pos = self.q.into();
        m.data.cmd_jnt_pos = self.q.into();
        m.data.msr_jnt_trq = tau.into();
        m.data.gravity = g.into();
        m
    }

    /// One cycle; the arm follows the set-point exactly. Returns the cycle's events.
    pub fn cycle(&mut self) -> Vec<CycleEvent> {
        if self.ramp > 0.0 {
            self.share = (self.share + self.ramp).min(1.0);
        }
        let m = self.measurement();
        // How a session places it: a jump back or beyond the window is a restart.
        let arrival = match self.previous_seq.replace(self.seq) {
            None => Arrival::First,
            Some(p) => match self.seq.wrapping_sub(p) {
                d @ 1..=1000 => Arrival::Continued {
                    cycles: u32::from(d),
                },
                _ => Arrival::Restart,
            },
        };
        let (desired, _) = self.processor.on_measurement(
            &m,
            Verdict::new(&m, arrival),
            HandshakeStatus::NOT_REPORTED,
            HandshakeRequest::NONE,
        );
        self.previous_velocity = self.velocity;
        match (self.braking, desired.joint_position) {
            (Some(decel), _) => {
                // The controller's own brake: constant deceleration to rest.
                let v = self
                    .velocity
                    .map(|v| v.signum() * (v.abs() - decel * 0.001).max(0.0));
                self.q += v * 0.001;
                self.velocity = v;
            }
            (None, Some(p)) => {
                let p = V7::from(p);
                self.velocity = (p - self.q) / 0.001;
                self.q = p;
            }
            (None, None) => self.velocity = V7::zeros(),
        }
        self.events
            .try_iter()
            .filter(|e| !matches!(e, CycleEvent::State(_)))
            .collect()
    }

    /// Runs `n` cycles and checks the rule on each: an armed onset leaves the arm held.
    pub fn run(&mut self, n: usize) -> Vec<CycleEvent> {
        let mut all = Vec::new();
        for _ in 0..n {
            let events = self.cycle();
            // Requests are applied at the start of a cycle, before the monitor steps.
            let armed = self.processor.is_armed();
            let onset = events.iter().any(|e| matches!(e, CycleEvent::Collision(_)));
            if armed && onset {
                assert!(
                    self.processor.is_holding(),
                    "armed onset without reaction: {events:?}"
                );
                assert!(!self.processor.is_moving());
            }
            assert!(
                armed || !onset,
                "a collision was reported while disarmed: {events:?}"
            );
            // The mode's own reports (declared, pinned, expired) are no safety events; the
            // tests read the mode from the processor.
            all.extend(
                events
                    .into_iter()
                    .filter(|e| !matches!(e, CycleEvent::UnknownPayload { .. })),
            );
        }
        all
    }
}

pub fn stopped_by_collision(events: &[CycleEvent]) -> bool {
    events.iter().any(|e| {
        matches!(
            e,
            CycleEvent::Stopped {
                reason: StopReason::Collision { .. },
                ..
            }
        )
    })
}

impl Rig {
    /// Armed (reaction: stop), the payload declared unknown and then picked up, at rest.
    pub fn declared_and_grasped() -> Self {
        let mut rig = Rig::new(ReactionMode::Stop, true);
        rig.run(100);
        rig.declare();
        rig.carried = true;
        rig.run(200);
        rig
    }

    /// Declares the payload unknown, as `expect-payload` does (which refuses while the loop's
    /// mode is active: the loop would refuse it too, and the rig's numbers stay the loop's).
    pub fn declare(&mut self) {
        if !self.processor.payload_unknown() {
            self.send_declaration();
        }
    }

    /// Ends the declaration and declares again, in one cycle (`expect-payload --end`, then
    /// `expect-payload`: the service allows it a bounded number of times).
    pub fn end_and_declare(&mut self) {
        self.send(CycleRequest::EndExpectPayload);
        self.send_declaration();
    }

    /// A new declaration's number and request; its samples start empty.
    fn send_declaration(&mut self) {
        self.declaration += 1;
        self.samples.clear();
        self.hypothesis = None;
        self.send(CycleRequest::ExpectPayload {
            declaration: self.declaration,
            bounds: BOUNDS,
            timing: self.timing,
        });
    }

    /// The gripper takes the payload: its weight comes onto the flange linearly over
    /// `seconds` (0: at once).
    pub fn grasp_over(&mut self, seconds: f64) {
        self.carried = true;
        if seconds > 0.0 {
            self.share = 0.0;
            self.ramp = 0.001 / seconds;
        } else {
            self.share = 1.0;
        }
    }

    /// A static sample at the current pose (the arm at rest) and the refit the service does
    /// after it, handed to the loop.
    pub fn sample(&mut self) {
        let load_torque = self.payload_torque() - self.contact_torque();
        self.samples.push(LoadSample {
            q: self.q,
            load_torque,
        });
        let h = self.refit();
        self.send(CycleRequest::PayloadHypothesis(h));
    }

    /// The hypothesis of the samples so far, as the service fits it.
    pub fn refit(&mut self) -> PayloadHypothesis<7> {
        let h = fit_hypothesis(
            &self.model,
            self.declaration,
            &self.samples,
            &V7::repeat(safety::DEFAULT_THRESHOLD_NM),
            &BOUNDS,
        )
        .unwrap();
        self.hypothesis = Some(h);
        h
    }

    /// Applies the hypothesis' load as the payload (`estimate-payload --apply`).
    pub fn apply_estimate(&mut self) {
        let Some(h) = self.hypothesis else { return };
        let p = h.parameters;
        self.send(CycleRequest::SetPayload(Some(
            PayloadCompensation::Gravity {
                mass_kg: p[0],
                first_moment: Vector3::new(p[1], p[2], p[3]),
            },
        )));
    }
}

/// The part of `torque` (Nm) no flange gravity load explains at `q`, whatever its mass and
/// centre of mass: the component orthogonal to the span of the payload gravity regressor in
/// the metric of the thresholds θ, as a norm in units of θ. Above 2·√7 some joint's residual
/// exceeds 2θ whatever the monitor's fit (the fit changes only the component in the span), so
/// any armed monitor must detect it (see `an_armed_onset_is_always_reacted_to`).
pub fn unexplainable(model: &Model<7>, q: &V7, torque: &V7) -> f64 {
    let mut data = Data::new(model);
    let theta = safety::DEFAULT_THRESHOLD_NM;
    let y = payload_gravity_regressor(model, &mut data, q) / theta;
    let t = torque / theta;
    let svd = y.svd(true, false);
    let u = svd.u.unwrap();
    let mut projected = V7::zeros();
    for k in 0..4 {
        if svd.singular_values[k] > 1e-9 * svd.singular_values.max() {
            let column = u.column(k);
            projected += column * column.dot(&t);
        }
    }
    (t - projected).norm()
}

pub fn apply_carried_payload(rig: &Rig) {
    rig.send(CycleRequest::SetPayload(Some(
        PayloadCompensation::gravity_from_com(PAYLOAD_KG, Vector3::from(PAYLOAD_COM)),
    )));
}
