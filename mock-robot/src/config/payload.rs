//! The payload on the flange: its inertial parameters (frame 7) and its attach/detach timeline.

use serde::{Deserialize, Serialize};

use crate::error::{SimError, ensure};

/// The rigid payload on the flange and when it is attached.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct PayloadSpec {
    /// Mass, kg (0 = no payload).
    pub mass_kg: f64,
    /// Centre of mass in DH frame 7 (wrist point), m.
    pub com_m: [f64; 3],
    /// Inertia about the CoM in frame-7 axes, kg·m², row-major 3×3; `None` = a solid cylinder of
    /// radius 0.04 m and length 0.08 m with the given mass, axis along z7.
    pub inertia_about_com: Option<[[f64; 3]; 3]>,
    /// Whether the payload is attached at t = 0 (default false: the simulator starts unloaded,
    /// and the payload is attached by an event or an operator's request).
    pub attached_at_start: bool,
    /// Attach/detach events.
    pub events: Vec<PayloadEvent>,
}

impl Default for PayloadSpec {
    fn default() -> Self {
        Self {
            mass_kg: 3.028,
            com_m: [0.0, 0.0, 0.119],
            inertia_about_com: None,
            attached_at_start: false,
            events: Vec::new(),
        }
    }
}

/// Radius of the default solid-cylinder payload, m.
pub const DEFAULT_PAYLOAD_RADIUS_M: f64 = 0.04;
/// Length of the default solid-cylinder payload along z7, m.
pub const DEFAULT_PAYLOAD_LENGTH_M: f64 = 0.08;

impl PayloadSpec {
    /// Inertia about the CoM, kg·m² (the given one or the default solid cylinder).
    pub fn inertia(&self) -> [[f64; 3]; 3] {
        self.inertia_about_com.unwrap_or_else(|| {
            let (r, l, m) = (
                DEFAULT_PAYLOAD_RADIUS_M,
                DEFAULT_PAYLOAD_LENGTH_M,
                self.mass_kg,
            );
            let transverse = m * (3.0 * r * r + l * l) / 12.0;
            let axial = 0.5 * m * r * r;
            [
                [transverse, 0.0, 0.0],
                [0.0, transverse, 0.0],
                [0.0, 0.0, axial],
            ]
        })
    }

    pub(super) fn validate(&self) -> Result<(), SimError> {
        ensure(self.mass_kg.is_finite() && self.mass_kg >= 0.0, || {
            format!("payload mass must be >= 0 kg, got {}", self.mass_kg)
        })?;
        ensure(
            self.com_m.iter().all(|c| c.is_finite() && c.abs() < 1.0),
            || "payload CoM must be finite and within 1 m of frame 7".into(),
        )?;
        let i = self.inertia();
        let symmetric = (0..3).all(|r| (0..3).all(|c| (i[r][c] - i[c][r]).abs() <= 1e-12));
        let (a, b, c) = (i[0][0], i[1][1], i[2][2]);
        let triangle = a + b >= c && b + c >= a && a + c >= b;
        ensure(
            symmetric && a >= 0.0 && b >= 0.0 && c >= 0.0 && triangle,
            || {
                "payload inertia must be symmetric with non-negative principal moments obeying the triangle inequality".into()
            },
        )?;
        ensure(
            self.events
                .iter()
                .all(|e| e.time_s.is_finite() && e.time_s >= 0.0),
            || "payload event times must be >= 0 s".into(),
        )
    }
}

/// One payload attach or detach event.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PayloadEvent {
    /// Simulation time of the event, s.
    pub time_s: f64,
    /// What happens.
    pub action: PayloadAction,
}

/// Payload attach or detach.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PayloadAction {
    /// The payload is rigidly attached to the flange.
    Attach,
    /// The payload is removed.
    Detach,
}
