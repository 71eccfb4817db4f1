//! Payload estimation for serial robots from joint torques (Gaz & De Luca, IROS 2017), with
//! uncertainty, tare and calibration against the controller's model error, pose design and
//! full inertial estimation from motion.
//!
//! Conventions: SI units (kg, m, kg·m², rad, Nm, s). Payload parameters live in the last DH
//! frame n of the robot model (frame 7 of the LWR 4+, at the wrist point) unless a field says
//! `flange`. Joints are 0-based in code and 1-based in messages.
//!
//! Modules:
//! - [`estimate`]: the static one-shot estimator (eq. 26), direct or via the paper's coefficients;
//! - [`correction`]: tare and controller model-error calibration;
//! - [`error_model`]: the estimate under an explicit error model (averaging noise, tare, drift,
//!   offset) with its uncertainty by source;
//! - [`coefficients`] and [`expr`]: the coefficient-set workflow (eqs. 21–28) and its file format;
//! - [`motion`]: full inertial estimation from trajectories (eq. 45), with [`align`] (a tare run
//!   of the same trajectory aligned in time) and [`consistency`] (a result that is no payload is
//!   an error with its cause);
//! - [`identify`]: the arm identified from its own unloaded recordings (paper Sec. II,
//!   eqs. 11–14), regularised toward the nominal model; [`model_error`]: the correlated
//!   model-error term of trajectory fits; [`coefficient_route`]: the paper's payload from the
//!   difference of identified coefficients (eqs. 22–28) on logs;
//! - [`poses`]: pose design with predicted uncertainty; [`replay`]: a recorded log played at a
//!   controller's period;
//! - [`samples`]: static-sample CSV and validation; [`plausible`]: recorded values against the
//!   robot model's limits; [`lsq`]: least squares with covariance;
//! - [`payload_check`]: whether a declared payload explains the static torques measured at
//!   rest (before `apply-payload` installs it);
//! - [`verdict`]: whether an estimate means anything (significant mass, centre of mass within
//!   reach of the flange, bounded uncertainty) and whether a tare sees a load;
//! - [`basis`]: numerical gravity base parameters; [`filter`]: zero-phase Butterworth and
//!   differentiation; [`sim`]: synthetic data for tests and studies.
//!
//! Methods, frames, file formats and how to read the uncertainties: `docs/estimation.md`.

pub mod align;
pub mod basis;
pub mod coefficient_route;
pub mod coefficients;
pub mod consistency;
pub mod correction;
mod equations;
pub mod error;
pub mod error_model;
pub mod estimate;
pub mod expr;
pub mod filter;
pub mod identify;
pub mod lsq;
pub mod model_error;
pub mod motion;
pub mod payload_check;
pub mod plausible;
pub mod poses;
pub mod replay;
pub mod samples;
pub mod sim;
pub mod verdict;

pub use coefficients::{CoefficientEstimate, CoefficientSet};
pub use correction::{Calibration, estimate_with_calibration, estimate_with_tare};
pub use error::EstimatorError;
pub use estimate::{Correction, EstimateOptions, Method, PayloadEstimate, estimate};
pub use motion::{InertialEstimate, MotionOptions, Trajectory, Unloaded, estimate_motion};
pub use samples::{SampleEvidence, StaticCheck, StaticSample};
