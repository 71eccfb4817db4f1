//! The true arm: the LWR 4+ of the shared model with its payload, reflected rotor inertia and
//! motor-side friction, pushed by contacts; one semi-implicit Euler substep at a time.
//!
//! (M(q) + B) q̈ = τ_m − τ_f + τ_ext − n(q, q̇); the link-side sensors see τ_J = M q̈ + n − τ_ext
//! (neither friction nor rotor inertia, lwr4-model.md §5).

use dynamics::{Data, InertialParameters, Model};
use nalgebra::{SMatrix, Vector3};

use crate::config::{FrictionSpec, SimulationConfig};
use crate::contact::{ContactProfile, ContactSpec};
use crate::error::SimError;
use crate::friction::{friction_torque, rotor_inertia};
use crate::joints::JOINTS;
use crate::joints::JointVector;
use crate::models::payload_parameters;

/// Contacts an operator may add while the simulation runs (pushes), on top of the scenario's:
/// room for them is reserved up front, so a push never allocates in the controller loop.
pub const MAX_PUSHES: usize = 256;

/// Ground truth of one contact in the current cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactState {
    /// Index of the contact in the scenario's `contacts` list.
    pub index: usize,
    /// Link hit, 1..=7.
    pub link: usize,
    /// Contact point in the link's DH frame, m.
    pub point_link_m: Vector3<f64>,
    /// Contact point in the base frame, m.
    pub point_base_m: Vector3<f64>,
    /// Force on the link, N, base frame (zero when inactive).
    pub force_n: Vector3<f64>,
    /// Time at which the force first became non-zero, s.
    pub onset_s: Option<f64>,
    /// Whether the force is non-zero in this cycle.
    pub active: bool,
}

/// The arm's models, state and contacts.
#[derive(Debug, Clone)]
pub(crate) struct Arm {
    bare: Model<7>,
    loaded: Model<7>,
    payload: InertialParameters,
    payload_attached: bool,
    data: Data<7>,
    rotor: JointVector,
    friction: FrictionSpec,
    contact_specs: Vec<ContactSpec>,
    contacts: Vec<ContactState>,
    wall_anchor: Vec<Vector3<f64>>,
    wall_anchor_set: Vec<bool>,
    /// Joint angles, rad.
    pub(crate) q: JointVector,
    /// Joint velocities, rad/s.
    pub(crate) qd: JointVector,
    /// Joint accelerations of the last substep, rad/s².
    pub(crate) qdd: JointVector,
    /// Link-side joint torques τ_J, Nm.
    pub(crate) tau_j: JointVector,
    /// External joint torques Σ J_pᵀ F, Nm.
    pub(crate) tau_ext: JointVector,
    /// Motor torques the joint controller applies, Nm.
    pub(crate) tau_motor: JointVector,
}

impl Arm {
    /// The arm of `config` with the rigid-body model `bare`, at rest at `q` (rad), holding
    /// gravity; the payload is checked to be physical.
    pub(crate) fn new(
        config: &SimulationConfig,
        bare: Model<7>,
        q: JointVector,
    ) -> Result<Self, SimError> {
        let payload = payload_parameters(&config.payload);
        payload
            .check_physical()
            .map_err(|e| SimError::InvalidConfig(format!("payload is not physical: {e}")))?;
        let loaded = bare.with_payload(&payload);
        let contacts = config
            .contacts
            .iter()
            .enumerate()
            .map(|(index, c)| ContactState {
                index,
                link: c.link,
                point_link_m: c.point(),
                point_base_m: Vector3::zeros(),
                force_n: Vector3::zeros(),
                onset_s: None,
                active: false,
            })
            .collect::<Vec<_>>();
        let capacity = contacts.len() + MAX_PUSHES;
        let mut contact_specs = Vec::with_capacity(capacity);
        contact_specs.extend_from_slice(&config.contacts);
        let mut contacts_reserved = Vec::with_capacity(capacity);
        contacts_reserved.extend_from_slice(&contacts);
        let mut wall_anchor = Vec::with_capacity(capacity);
        wall_anchor.resize(contacts.len(), Vector3::zeros());
        let mut wall_anchor_set = Vec::with_capacity(capacity);
        wall_anchor_set.resize(contacts.len(), false);
        let mut arm = Self {
            data: Data::new(&bare),
            bare,
            loaded,
            payload,
            payload_attached: config.payload.attached_at_start && config.payload.mass_kg > 0.0,
            rotor: rotor_inertia(&config.friction),
            friction: config.friction.clone(),
            contact_specs,
            wall_anchor,
            wall_anchor_set,
            contacts: contacts_reserved,
            q,
            qd: JointVector::zeros(),
            qdd: JointVector::zeros(),
            tau_j: JointVector::zeros(),
            tau_ext: JointVector::zeros(),
            tau_motor: JointVector::zeros(),
        };
        // The arm starts at rest: link-side torques hold gravity.
        arm.tau_j = arm.gravity();
        arm.tau_motor = arm.tau_j;
        Ok(arm)
    }

    /// The true arm model (with the payload when attached).
    pub(crate) fn model(&self) -> &Model<7> {
        if self.payload_attached {
            &self.loaded
        } else {
            &self.bare
        }
    }

    /// Gravity torques of the true arm at its current angles, Nm.
    fn gravity(&mut self) -> JointVector {
        let model = if self.payload_attached {
            &self.loaded
        } else {
            &self.bare
        };
        dynamics::compute_generalized_gravity(model, &mut self.data, &self.q)
    }

    /// Reflected rotor inertia per joint, kg·m².
    pub(crate) fn rotor(&self) -> &JointVector {
        &self.rotor
    }

    /// Attaches (or detaches) the configured payload; returns whether one is now attached
    /// (never, when its mass is zero).
    pub(crate) fn set_payload_attached(&mut self, attached: bool) -> bool {
        self.payload_attached = attached && self.payload.mass > 0.0;
        self.payload_attached
    }

    /// Attaches `payload` (frame 7, checked physical by the caller) in place of any other;
    /// allocation-free.
    pub(crate) fn attach_payload(&mut self, payload: &InertialParameters) {
        self.payload = *payload;
        self.loaded.load_payload(&self.bare, payload);
        self.payload_attached = payload.mass > 0.0;
    }

    /// Adds a contact (validated by the caller) to the scenario's; returns its index, or None
    /// when [`MAX_PUSHES`] have been added already.
    pub(crate) fn add_contact(&mut self, spec: &ContactSpec) -> Option<usize> {
        if self.contact_specs.len() == self.contact_specs.capacity() {
            return None;
        }
        let index = self.contact_specs.len();
        self.contacts.push(ContactState {
            index,
            link: spec.link,
            point_link_m: spec.point(),
            point_base_m: Vector3::zeros(),
            force_n: Vector3::zeros(),
            onset_s: None,
            active: false,
        });
        self.contact_specs.push(spec.clone());
        self.wall_anchor.push(Vector3::zeros());
        self.wall_anchor_set.push(false);
        Some(index)
    }

    /// The payload (frame 7) when attached.
    pub(crate) fn payload(&self) -> Option<&InertialParameters> {
        self.payload_attached.then_some(&self.payload)
    }

    /// Ground truth of every contact.
    pub(crate) fn contacts(&self) -> &[ContactState] {
        &self.contacts
    }

    /// Sum of contact torques at the current state and time `t` (s); updates the contact truth.
    fn contact_torques(&mut self, t: f64) -> JointVector {
        let mut tau = JointVector::zeros();
        for (idx, spec) in self.contact_specs.iter().enumerate() {
            if !spec.is_active(t) {
                let state = &mut self.contacts[idx];
                state.active = false;
                state.force_n = Vector3::zeros();
                continue;
            }
            let link = spec.link_index();
            // Kinematics are the same with or without payload: use the bare arm.
            let frames = dynamics::forward_kinematics(&self.bare, &mut self.data, &self.q);
            let point_base = (frames[link] * nalgebra::Point3::from(spec.point())).coords;
            let auto_wall = matches!(
                spec.profile,
                ContactProfile::Wall {
                    plane_point_m: None,
                    ..
                }
            );
            if auto_wall && !self.wall_anchor_set[idx] {
                self.wall_anchor[idx] = point_base;
                self.wall_anchor_set[idx] = true;
            }
            let force = spec.force(t, &point_base, &self.wall_anchor[idx]);
            let state = &mut self.contacts[idx];
            state.point_base_m = point_base;
            state.force_n = force;
            state.active = force.norm() > 0.0;
            if state.active && state.onset_s.is_none() {
                state.onset_s = Some(t);
            }
            if state.active {
                let jac = dynamics::point_jacobian(
                    &self.bare,
                    &mut self.data,
                    &self.q,
                    link,
                    &spec.point(),
                );
                tau += jac.fixed_rows::<3>(0).transpose() * force;
            }
        }
        tau
    }

    /// One semi-implicit Euler step of length `dt` (s) ending at time `t` (s), driven by
    /// `self.tau_motor`.
    pub(crate) fn substep(&mut self, t: f64, dt: f64) {
        let tau_ext = if self.contact_specs.is_empty() {
            JointVector::zeros()
        } else {
            self.contact_torques(t)
        };
        let model = if self.payload_attached {
            &self.loaded
        } else {
            &self.bare
        };
        let m = dynamics::crba(model, &mut self.data, &self.q);
        let n = dynamics::nonlinear_effects(model, &mut self.data, &self.q, &self.qd);
        let friction = friction_torque(&self.friction, &self.qd);
        let mut m_total: SMatrix<f64, 7, 7> = m;
        for i in 0..JOINTS {
            m_total[(i, i)] += self.rotor[i];
        }
        let rhs = self.tau_motor - friction + tau_ext - n;
        let qdd = match m_total.cholesky() {
            Some(ch) => ch.solve(&rhs),
            None => JointVector::zeros(),
        };
        self.qd += qdd * dt;
        self.q += self.qd * dt;
        self.qdd = qdd;
        self.tau_ext = tau_ext;
        // Link side: what the torque sensors between gear and link transmit.
        self.tau_j = m * qdd + n - tau_ext;
    }
}
