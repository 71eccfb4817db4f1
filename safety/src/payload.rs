//! The payload term of eq. 48: which payload parameters the observer's model carries.

use dynamics::InertialParameters;
use nalgebra::{SVector, Vector3};
use serde::{Deserialize, Serialize};

use crate::fault::Fault;

/// Payload compensation used by the observer. Parameters are in the robot's last DH frame
/// (frame 7 of the LWR, at the wrist point), as estimated by the `estimator` crate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub enum PayloadCompensation {
    /// No payload in the model (the uncompensated residual).
    #[default]
    None,
    /// The paper's eq. 48: only g_L carries the payload, from its gravity parameters
    /// (eq. 40: m, m·c); M and Cᵀq̇ stay those of the unloaded robot.
    Gravity {
        /// Payload mass m \[kg\].
        mass_kg: f64,
        /// First moment of mass m·c \[kg·m\], last DH frame.
        first_moment: Vector3<f64>,
    },
    /// All ten inertial parameters: the payload enters g_L and also M and Cᵀq̇
    /// (the model becomes `Model::with_payload`).
    Full(InertialParameters),
}

impl PayloadCompensation {
    /// Gravity-only compensation from mass \[kg\] and CoM \[m\] in the last DH frame.
    pub fn gravity_from_com(mass_kg: f64, com: Vector3<f64>) -> Self {
        PayloadCompensation::Gravity {
            mass_kg,
            first_moment: com * mass_kg,
        }
    }

    /// The gravity parameters (m, m·cx, m·cy, m·cz) \[kg, kg·m\] multiplying the payload gravity
    /// regressor (paper eq. 40); zero for [`PayloadCompensation::None`].
    pub fn gravity_parameters(&self) -> SVector<f64, 4> {
        match self {
            PayloadCompensation::None => SVector::zeros(),
            PayloadCompensation::Gravity {
                mass_kg,
                first_moment,
            } => SVector::<f64, 4>::new(*mass_kg, first_moment.x, first_moment.y, first_moment.z),
            PayloadCompensation::Full(p) => {
                SVector::<f64, 4>::new(p.mass, p.first_moment.x, p.first_moment.y, p.first_moment.z)
            }
        }
    }

    /// Checks the estimate: finite parameters, mass ≥ 0, and for the full set a physical rigid
    /// body (`InertialParameters::check_physical`: PSD inertia about the CoM, triangle
    /// inequality).
    pub fn validate(&self) -> Result<(), Fault> {
        let mass = self.gravity_parameters()[0];
        let reject = Err(Fault::InvalidPayload { mass_kg: mass });
        if !self.gravity_parameters().iter().all(|x| x.is_finite()) || mass < 0.0 {
            return reject;
        }
        if let PayloadCompensation::Full(p) = self
            && p.check_physical().is_err()
        {
            return reject;
        }
        Ok(())
    }
}
