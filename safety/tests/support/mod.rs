//! Simulated LWR 4+ for the safety tests and the evaluation example: forward dynamics of the
//! "true" arm (payload, perturbed links), a joint-impedance controller on its own (perturbed,
//! unloaded) model, held torques per controller period, sensor noise and contact forces.
//!
//! Timing convention: at controller tick k (t_k = k·T) the controller measures q_k and the torque
//! that acted over [t_{k−1}, t_k], then applies τ_k for [t_k, t_{k+1}) (zero-order hold).

#![allow(dead_code, clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{Data, InertialParameters, Model, crba, forward_dynamics, point_jacobian, rnea};
use nalgebra::{Matrix3, SVector, Vector3};
use rand::Rng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal};
use trajectory::{QuinticSegment, rest_to_rest_duration};

pub type V7 = SVector<f64, 7>;

/// A Gaussian draw of the §4 perturbation (σ 0.02 kg, 0.005 kg·m) plus a relative scaling of
/// each link's inertia tensor about its CoM by N(1, `inertia_sigma`²).
pub fn random_links(
    links: &[InertialParameters; 7],
    rng: &mut StdRng,
    inertia_sigma: f64,
) -> [InertialParameters; 7] {
    let dm = Normal::new(0.0, 0.02).unwrap();
    let dh = Normal::new(0.0, 0.005).unwrap();
    let di = Normal::new(1.0, inertia_sigma).unwrap();
    let mut out = *links;
    for l in out.iter_mut() {
        let com = l.com().unwrap_or_else(Vector3::zeros);
        let icom = l.inertia_about_com() * di.sample(rng).max(0.5);
        let mass = l.mass + dm.sample(rng);
        let h = l.mass * com + Vector3::new(dh.sample(rng), dh.sample(rng), dh.sample(rng));
        *l = InertialParameters::from_com(mass, h / mass, icom);
    }
    out
}

/// The paper's heavy payload with a plausible inertia: 3.028 kg, CoM (0, 0, 0.119) m in frame 7,
/// inertia about the CoM of a solid cylinder r = 0.05 m, h = 0.10 m along z7.
pub fn heavy_payload_with_inertia() -> InertialParameters {
    let m = 3.028;
    let (r, h) = (0.05_f64, 0.10_f64);
    let ixx = m * (3.0 * r * r + h * h) / 12.0;
    let izz = m * r * r / 2.0;
    InertialParameters::from_com(
        m,
        Vector3::new(0.0, 0.0, 0.119),
        Matrix3::from_diagonal(&Vector3::new(ixx, ixx, izz)),
    )
}

/// Paper eq. 47: payload estimate from 10 samples (mass kg, CoM m in frame 7).
pub const PAPER_ESTIMATE_MASS: f64 = 3.059;
pub const PAPER_ESTIMATE_COM: [f64; 3] = [-2.8e-3, 1.1e-2, 0.1283];

/// Time law of a contact force.
#[derive(Debug, Clone, Copy)]
pub enum Profile {
    /// F(t) = peak·sin(π(t − start)/duration) on [start, start + duration].
    HalfSine { start: f64, duration: f64 },
    /// Constant from `start` to `end`.
    Box { start: f64, end: f64 },
    /// Linear ramp from zero at `start` with slope 1 (scaled by the force) until `end`.
    Ramp { start: f64, end: f64 },
}

impl Profile {
    pub fn value(&self, t: f64) -> f64 {
        match *self {
            Profile::HalfSine { start, duration } => {
                if t >= start && t <= start + duration {
                    (std::f64::consts::PI * (t - start) / duration).sin()
                } else {
                    0.0
                }
            }
            Profile::Box { start, end } => {
                if t >= start && t < end {
                    1.0
                } else {
                    0.0
                }
            }
            Profile::Ramp { start, end } => {
                if t >= start && t < end {
                    t - start
                } else {
                    0.0
                }
            }
        }
    }
    pub fn start(&self) -> f64 {
        match *self {
            Profile::HalfSine { start, .. }
            | Profile::Box { start, .. }
            | Profile::Ramp { start, .. } => start,
        }
    }
}

/// A contact force on a link (0-based) at a point in its DH frame; `force` in the base frame [N].
#[derive(Debug, Clone, Copy)]
pub struct Contact {
    pub link: usize,
    pub point: Vector3<f64>,
    pub force: Vector3<f64>,
    pub profile: Profile,
}

/// A trajectory: desired (q, q̇, q̈) at time t.
pub trait Trajectory {
    fn sample(&self, t: f64) -> (V7, V7, V7);
}

/// Holds a fixed configuration.
pub struct Hold(pub V7);
impl Trajectory for Hold {
    fn sample(&self, _t: f64) -> (V7, V7, V7) {
        (self.0, V7::zeros(), V7::zeros())
    }
}

/// Rest-to-rest quintic segments through waypoints, with optional dwell at each waypoint.
pub struct Quintic {
    /// (start time s, segment)
    segments: Vec<(f64, QuinticSegment<7>)>,
    end: f64,
    last: V7,
}

impl Quintic {
    /// Segments between consecutive `waypoints`; each move's duration is the smallest that keeps
    /// |q̇| ≤ v_max and |q̈| ≤ a_max on every joint; `dwell` s of rest after each move.
    pub fn new(waypoints: &[V7], v_max: f64, a_max: f64, dwell: f64) -> Self {
        let mut segments = Vec::new();
        let mut t = dwell;
        for w in waypoints.windows(2) {
            let delta = (w[1] - w[0]).abs().max();
            let duration = rest_to_rest_duration(delta, v_max, a_max).max(0.05);
            segments.push((
                t,
                QuinticSegment {
                    from: w[0],
                    to: w[1],
                    duration,
                },
            ));
            t += duration + dwell;
        }
        let last = *waypoints.last().unwrap();
        Self {
            segments,
            end: t,
            last,
        }
    }
    pub fn duration(&self) -> f64 {
        self.end
    }
}

impl Trajectory for Quintic {
    fn sample(&self, t: f64) -> (V7, V7, V7) {
        let first = self.segments.first().map(|s| s.1.from).unwrap_or(self.last);
        let mut hold = first;
        for (start, segment) in &self.segments {
            if t < *start {
                return (hold, V7::zeros(), V7::zeros());
            }
            if t <= start + segment.duration {
                let sp = segment.sample(t - start);
                return (sp.position, sp.velocity, sp.acceleration);
            }
            hold = segment.to;
        }
        (self.last, V7::zeros(), V7::zeros())
    }
}

/// Joint-impedance controller: τ = RNEA_ctrl(q, q̇, q̈_d) + K(q_d − q) + D(q̇_d − q̇), on the
/// controller's own (unloaded, perturbed) model.
pub struct Impedance {
    pub model: Model<7>,
    pub data: Data<7>,
    pub stiffness: V7,
    pub damping: V7,
}

impl Impedance {
    /// Stiffness [Nm/rad] per joint; damping for ratio `zeta` against the effective joint
    /// inertias 1/(M⁻¹)_jj of the plant at `q0` (the diagonal of M overestimates them for coupled
    /// joints and would make the damping too stiff for the sampled loop).
    pub fn new(model: Model<7>, stiffness: V7, plant: &Model<7>, q0: &V7, zeta: f64) -> Self {
        let mut data = Data::new(plant);
        let inverse = crba(plant, &mut data, q0)
            .try_inverse()
            .expect("invertible mass matrix");
        let inertia_diag = inverse.diagonal().map(|x| 1.0 / x);
        let damping = V7::from_fn(|j, _| 2.0 * zeta * (stiffness[j] * inertia_diag[j]).sqrt());
        Self {
            model,
            data,
            stiffness,
            damping,
        }
    }
    pub fn torque(&mut self, q: &V7, qd: &V7, desired: &(V7, V7, V7)) -> V7 {
        let (qd_des, vd_des, ad_des) = desired;
        // Feed-forward with the measured velocity (computed-torque style) plus impedance.
        let ff = rnea(&self.model, &mut self.data, q, qd, ad_des);
        ff + self.stiffness.component_mul(&(qd_des - q))
            + self.damping.component_mul(&(vd_des - qd))
    }
}

/// Default LWR joint stiffness [Nm/rad] used by the harness (joint impedance mode).
pub fn default_stiffness() -> V7 {
    V7::from_column_slice(&[1500.0, 1500.0, 800.0, 800.0, 150.0, 60.0, 10.0])
}

/// Integration scheme of the plant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Integrator {
    /// Classical RK4 (4 forward-dynamics calls per substep).
    Rk4,
    /// Semi-implicit (symplectic) Euler (1 call per substep).
    SemiImplicitEuler,
}

/// The "true" arm.
pub struct Plant {
    pub model: Model<7>,
    pub data: Data<7>,
    pub q: V7,
    pub qd: V7,
    pub qdd: V7,
    pub t: f64,
    pub integrator: Integrator,
}

impl Plant {
    pub fn new(model: Model<7>, q0: V7, integrator: Integrator) -> Self {
        let data = Data::new(&model);
        Self {
            model,
            data,
            q: q0,
            qd: V7::zeros(),
            qdd: V7::zeros(),
            t: 0.0,
            integrator,
        }
    }

    /// External joint torque τ_ext = Σ J_vᵀ F of the active contacts at (t, q), plus `extra`.
    pub fn external_torque(&mut self, t: f64, q: &V7, contacts: &[Contact], extra: &V7) -> V7 {
        let mut tau = *extra;
        for c in contacts {
            let s = c.profile.value(t);
            if s != 0.0 {
                let j = point_jacobian(&self.model, &mut self.data, q, c.link, &c.point);
                tau += j.fixed_rows::<3>(0).transpose() * (c.force * s);
            }
        }
        tau
    }

    fn acceleration(
        &mut self,
        t: f64,
        q: &V7,
        qd: &V7,
        tau: &V7,
        contacts: &[Contact],
        extra: &V7,
    ) -> V7 {
        let ext = self.external_torque(t, q, contacts, extra);
        forward_dynamics(&self.model, &mut self.data, q, qd, &(tau + ext))
            .expect("forward dynamics")
    }

    /// Lets the arm settle for `seconds` under the controller holding `q_hold` (an undeclared
    /// payload makes it sag first), then restarts the clock at zero with zero velocity.
    pub fn settle(&mut self, controller: &mut Impedance, q_hold: &V7, seconds: f64) {
        let hold = Hold(*q_hold);
        let ticks = (seconds / 1e-3) as usize;
        for _ in 0..ticks {
            self.advance_controlled(controller, &hold, 1e-3, 5, &[], &V7::zeros());
        }
        self.t = 0.0;
        self.qd = V7::zeros();
    }

    /// Advances by `period` in `substeps` steps with the controller closing the loop at every
    /// substep (the LWR's joint controller runs faster than FRI); returns nothing: the caller
    /// samples the torque at the next tick.
    pub fn advance_controlled(
        &mut self,
        controller: &mut Impedance,
        trajectory: &dyn Trajectory,
        period: f64,
        substeps: usize,
        contacts: &[Contact],
        extra: &V7,
    ) {
        let h = period / substeps as f64;
        for _ in 0..substeps {
            let desired = trajectory.sample(self.t);
            let (q, v) = (self.q, self.qd);
            let tau = controller.torque(&q, &v, &desired);
            let a = self.acceleration(self.t, &q, &v, &tau, contacts, extra);
            self.qd += a * h;
            self.q += self.qd * h;
            self.qdd = a;
            self.t += h;
        }
    }

    /// Advances by `period` with torque `tau` held, in `substeps` integration steps.
    pub fn advance(
        &mut self,
        tau: &V7,
        period: f64,
        substeps: usize,
        contacts: &[Contact],
        extra: &V7,
    ) {
        let h = period / substeps as f64;
        for _ in 0..substeps {
            let t = self.t;
            match self.integrator {
                Integrator::SemiImplicitEuler => {
                    let a = self.acceleration(
                        t,
                        &self.q.clone(),
                        &self.qd.clone(),
                        tau,
                        contacts,
                        extra,
                    );
                    self.qd += a * h;
                    self.q += self.qd * h;
                    self.qdd = a;
                }
                Integrator::Rk4 => {
                    let (q, v) = (self.q, self.qd);
                    let a1 = self.acceleration(t, &q, &v, tau, contacts, extra);
                    let (q2, v2) = (q + v * (h / 2.0), v + a1 * (h / 2.0));
                    let a2 = self.acceleration(t + h / 2.0, &q2, &v2, tau, contacts, extra);
                    let (q3, v3) = (q + v2 * (h / 2.0), v + a2 * (h / 2.0));
                    let a3 = self.acceleration(t + h / 2.0, &q3, &v3, tau, contacts, extra);
                    let (q4, v4) = (q + v3 * h, v + a3 * h);
                    let a4 = self.acceleration(t + h, &q4, &v4, tau, contacts, extra);
                    self.q = q + (v + (v2 + v3) * 2.0 + v4) * (h / 6.0);
                    self.qd = v + (a1 + (a2 + a3) * 2.0 + a4) * (h / 6.0);
                    self.qdd = a1;
                }
            }
            self.t += h;
        }
    }
}

/// Gaussian torque noise σ [Nm] (0 = none) and f32 rounding of positions (as on the FRI wire).
pub struct Sensors {
    pub torque_noise: Option<Normal<f64>>,
    pub round_positions_to_f32: bool,
}

impl Sensors {
    pub fn new(torque_sigma: f64, round_positions_to_f32: bool) -> Self {
        let torque_noise = (torque_sigma > 0.0).then(|| Normal::new(0.0, torque_sigma).unwrap());
        Self {
            torque_noise,
            round_positions_to_f32,
        }
    }
    pub fn measure(&self, rng: &mut StdRng, q: &V7, tau: &V7) -> (V7, V7) {
        let q_m = if self.round_positions_to_f32 {
            q.map(|x| x as f32 as f64)
        } else {
            *q
        };
        let tau_m = match &self.torque_noise {
            Some(n) => tau.map(|x| x + n.sample(rng)),
            None => *tau,
        };
        (q_m, tau_m)
    }
}

/// Uniform random configuration within `fraction` of the LWR joint limits.
pub fn random_configuration(rng: &mut StdRng, fraction: f64) -> V7 {
    let limits_deg = [170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 170.0];
    V7::from_fn(|j, _| rng.random_range(-1.0..1.0) * fraction * f64::to_radians(limits_deg[j]))
}
