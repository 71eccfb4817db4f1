//! Typed errors of the dynamics crate.

/// Everything that can go wrong when building a model, loading a robot file or solving dynamics.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DynamicsError {
    /// A number that must be finite is NaN or infinite.
    #[error("{what}[{index}] is not finite ({value})")]
    NonFinite {
        /// Which quantity (e.g. "q", "mass", "inertia_origin").
        what: &'static str,
        /// Component index inside that quantity (0-based).
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// A body has negative mass.
    #[error("mass {mass} kg is negative")]
    NegativeMass {
        /// The mass, kg.
        mass: f64,
    },
    /// A massless body has a non-zero first moment or inertia that no real body can have.
    #[error("body has zero mass but a non-zero first moment {first_moment:?} kg·m")]
    FirstMomentWithoutMass {
        /// The first moment m·c, kg·m.
        first_moment: [f64; 3],
    },
    /// The 3×3 inertia tensor is not symmetric.
    #[error("inertia tensor is not symmetric (largest asymmetry {asymmetry} kg·m²)")]
    InertiaNotSymmetric {
        /// Largest |J_ij − J_ji|, kg·m².
        asymmetry: f64,
    },
    /// The inertia tensor about the centre of mass has a negative principal moment.
    #[error(
        "inertia about the centre of mass is not positive (principal moments {principal_moments:?} kg·m²)"
    )]
    InertiaNotPositive {
        /// Principal moments about the CoM, ascending, kg·m².
        principal_moments: [f64; 3],
    },
    /// The principal moments about the CoM violate the triangle inequality I1 + I2 ≥ I3.
    #[error("principal moments {principal_moments:?} kg·m² violate the triangle inequality")]
    TriangleInequality {
        /// Principal moments about the CoM, ascending, kg·m².
        principal_moments: [f64; 3],
    },
    /// A link's parameters are invalid; `link` is 0-based.
    #[error("link {link}: {source}")]
    Link {
        /// Link index, 0-based.
        link: usize,
        /// What is wrong with it.
        source: Box<DynamicsError>,
    },
    /// A joint description is invalid; `joint` is 0-based.
    #[error("joint {joint}: {reason}")]
    InvalidJoint {
        /// Joint index, 0-based.
        joint: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// Joint limits are inconsistent (min ≥ max, non-positive velocity or torque limit).
    #[error("joint {joint} limits: {reason}")]
    InvalidLimits {
        /// Joint index, 0-based.
        joint: usize,
        /// What is wrong with them.
        reason: String,
    },
    /// A robot description has a different number of moving joints than the model type expects.
    #[error("{source_kind} describes {found} moving joints, the model needs {expected}")]
    JointCount {
        /// N of `Model<N>`.
        expected: usize,
        /// Number found in the description.
        found: usize,
        /// "TOML robot file", "URDF", ...
        source_kind: &'static str,
    },
    /// The mass matrix is not positive definite, so it cannot be inverted.
    #[error("mass matrix is not positive definite (Cholesky factorisation failed)")]
    SingularMassMatrix,
    /// A TOML robot file is malformed.
    #[error("TOML robot file: {0}")]
    Toml(String),
    /// A URDF file is malformed or describes something this crate cannot model.
    #[error("URDF: {0}")]
    Urdf(String),
    /// An identified-arm file does not fit the model, or a field is out of range.
    #[error("identified arm file, `{field}`: {reason}")]
    Identified {
        /// The field, e.g. `joint.offset[3]` (joints 1-based).
        field: String,
        /// What is wrong and the allowed range.
        reason: String,
    },
    /// A file could not be read.
    #[error("cannot read {path}: {message}")]
    Io {
        /// The path as given.
        path: String,
        /// The operating system's message.
        message: String,
    },
}

/// Checks that every component of `values` is finite; `what` names the quantity in the error.
pub fn check_finite<const N: usize>(
    what: &'static str,
    values: &nalgebra::SVector<f64, N>,
) -> Result<(), DynamicsError> {
    check_finite_slice(what, values.as_slice())
}

/// Checks that every value of a slice is finite; `what` names the quantity in the error.
pub(crate) fn check_finite_slice(what: &'static str, values: &[f64]) -> Result<(), DynamicsError> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(DynamicsError::NonFinite {
            what,
            index,
            value: values[index],
        }),
        None => Ok(()),
    }
}
