//! An arm model identified from the arm's own recordings (paper Sec. II, eqs. 11–15): the
//! nominal model's base dynamic coefficients corrected by δπ, plus per-joint torque offsets and
//! smooth Coulomb + viscous friction,
//!
//!   τ = Y(q, q̇, q̈)·(π_nom + δπ) + offset + viscous·q̇ + coulomb·tanh(q̇/v0).
//!
//! The correction δπ is carried by a model whose link parameters are the nominal ones plus δπ on
//! the base coefficients' independent columns ([`IdentifiedModel::corrected_model`]): since the
//! torque depends on the link parameters only through π = K·p, its RNEA, M(q), C and g(q) are
//! exactly those of π_nom + δπ, so every algorithm of this crate uses the correction unchanged.
//! Its link parameters need not be physical (a base coefficient is a combination), which is why
//! the model is built with `Model::with_links`.
//!
//! The file is written by `fri-ctl offline identify` and checked here against the model it names
//! ([`IdentifiedModel::new`]); format in docs/robot-model.md, "Identified arm models".

mod file;

pub use file::{
    BaseTerms, FitSummary, IDENTIFIED_FORMAT, IdentifiedFile, JointTerms, MAX_CORRELATION_TIME_S,
    MAX_COULOMB_VELOCITY, MIN_COULOMB_VELOCITY, ModelErrorTerms,
};

use nalgebra::{DMatrix, DVector, SVector};

use crate::base_parameters::{BaseParameters, RegressorKind, base_parameters};
use crate::data::Data;
use crate::error::DynamicsError;
use crate::inertia::InertialParameters;
use crate::model::Model;
use crate::regressor::joint_torque_regressor;
use crate::rnea::rnea;
use file::check_vector;

/// Random states of the base-parameter analysis the file's `base.columns` refer to.
pub const BASE_SAMPLES: usize = 100;
/// Seed of that analysis (deterministic: the same model always gives the same columns).
pub const BASE_SEED: u64 = 7;
/// Largest share of a joint's torque limit a correction may add (offset, friction at the speed
/// limit, δπ's torque over the checked states): beyond it the file is not a correction.
pub const MAX_CORRECTION_SHARE: f64 = 0.25;
/// Torque bound for joints without a torque limit, Nm.
const UNLIMITED_TORQUE_NM: f64 = 1e5;
/// Relative tolerance of the file's π_nom against the model's.
const NOMINAL_TOLERANCE: f64 = 1e-6;

/// The base coefficients of `model`'s full torque regressor as the identified-arm file uses them
/// (QR with column pivoting over [`BASE_SAMPLES`] states drawn with [`BASE_SEED`]).
pub fn identification_base<const N: usize>(model: &Model<N>) -> BaseParameters {
    base_parameters(model, RegressorKind::Full, BASE_SAMPLES, BASE_SEED)
}

/// The ten parameters of every link stacked (10·N, `to_vector` order per link).
pub fn link_parameter_vector<const N: usize>(model: &Model<N>) -> DVector<f64> {
    DVector::from_iterator(
        10 * N,
        model
            .links()
            .iter()
            .flat_map(|l| l.to_vector().iter().copied().collect::<Vec<_>>()),
    )
}

/// Y_base(q, q̇, q̈): the N × P torque regressor of the base coefficients `columns` (Nm per unit
/// of each coefficient), so that τ = Y_base·π.
pub fn base_regressor<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    columns: &[usize],
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
    qdd: &SVector<f64, N>,
) -> DMatrix<f64> {
    let blocks = joint_torque_regressor(model, data, q, qd, qdd);
    DMatrix::from_fn(N, columns.len(), |j, c| {
        let col = columns[c];
        blocks[col / 10][(j, col % 10)]
    })
}

/// A validated identified arm: ready to predict torques.
#[derive(Debug, Clone)]
pub struct IdentifiedModel<const N: usize> {
    file: IdentifiedFile,
    nominal: Model<N>,
    corrected: Model<N>,
    offset: SVector<f64, N>,
    viscous: SVector<f64, N>,
    coulomb: SVector<f64, N>,
    coulomb_velocity: f64,
}

impl<const N: usize> IdentifiedModel<N> {
    /// Checks `file` against `nominal` (robot name, joint count, base columns and π_nom, every
    /// value finite and bounded: see the constants) and builds the corrected model.
    pub fn new(nominal: &Model<N>, file: IdentifiedFile) -> Result<Self, DynamicsError> {
        file.check_own_fields(N)?;
        if file.robot != nominal.name() {
            return Err(DynamicsError::Identified {
                field: "robot".into(),
                reason: format!(
                    "the file was identified for `{}`, the model is `{}`",
                    file.robot,
                    nominal.name()
                ),
            });
        }
        let base = identification_base(nominal);
        if file.base.columns != base.independent {
            return Err(DynamicsError::Identified {
                field: "base.columns".into(),
                reason: format!(
                    "the model's base coefficients are the link parameters {:?}, the file's {:?}: \
                     another kinematic structure",
                    base.independent, file.base.columns
                ),
            });
        }
        let p = base.rank;
        let pi_nom = &base.map * link_parameter_vector(nominal);
        check_vector("base.nominal", &file.base.nominal, p, |_| f64::MAX, "")?;
        if let Some(k) = (0..p).find(|&k| {
            (file.base.nominal[k] - pi_nom[k]).abs() > NOMINAL_TOLERANCE * pi_nom[k].abs().max(1.0)
        }) {
            return Err(DynamicsError::Identified {
                field: format!("base.nominal[{}]", k + 1),
                reason: format!(
                    "{} differs from the model's {}: the file was identified against other link \
                     parameters",
                    file.base.nominal[k], pi_nom[k]
                ),
            });
        }
        let limit = |j: usize| {
            let t = nominal.limits().torque_max[j];
            if t.is_finite() {
                MAX_CORRECTION_SHARE * t
            } else {
                UNLIMITED_TORQUE_NM
            }
        };
        let speed = |j: usize| nominal.limits().velocity_max[j].min(10.0);
        let j = &file.joint;
        check_vector("joint.offset", &j.offset, N, limit, "Nm")?;
        check_vector("joint.coulomb", &j.coulomb, N, limit, "Nm")?;
        check_vector(
            "joint.viscous",
            &j.viscous,
            N,
            |k| limit(k) / speed(k),
            "Nm·s/rad",
        )?;
        check_vector("base.delta", &file.base.delta, p, |_| f64::MAX, "")?;
        check_vector("base.delta_std", &file.base.delta_std, p, |_| f64::MAX, "")?;
        let mut params = link_parameter_vector(nominal);
        for (k, &col) in base.independent.iter().enumerate() {
            params[col] += file.base.delta[k];
        }
        let links: [InertialParameters; N] = std::array::from_fn(|l| {
            InertialParameters::from_vector(&SVector::<f64, 10>::from_fn(|k, _| params[10 * l + k]))
        });
        let corrected = nominal.with_links(links);
        check_correction_torque(nominal, &corrected, &limit)?;
        Ok(Self {
            offset: SVector::from_column_slice(&j.offset),
            viscous: SVector::from_column_slice(&j.viscous),
            coulomb: SVector::from_column_slice(&j.coulomb),
            coulomb_velocity: j.coulomb_velocity,
            nominal: nominal.clone(),
            corrected,
            file,
        })
    }

    /// Parses the TOML text and checks it against `nominal` (see [`IdentifiedModel::new`]).
    pub fn from_toml_str(nominal: &Model<N>, text: &str) -> Result<Self, DynamicsError> {
        Self::new(nominal, IdentifiedFile::parse(text)?)
    }

    /// Reads and checks an identified-arm file.
    pub fn from_toml_file(
        nominal: &Model<N>,
        path: &std::path::Path,
    ) -> Result<Self, DynamicsError> {
        let text = std::fs::read_to_string(path).map_err(|e| DynamicsError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::from_toml_str(nominal, &text)
    }

    /// The file's contents.
    pub fn file(&self) -> &IdentifiedFile {
        &self.file
    }

    /// The nominal model the file was checked against.
    pub fn nominal_model(&self) -> &Model<N> {
        &self.nominal
    }

    /// The nominal model with δπ on its link parameters: its RNEA, M, C and g are those of the
    /// identified coefficients (link parameters not necessarily physical).
    pub fn corrected_model(&self) -> &Model<N> {
        &self.corrected
    }

    /// The links of [`IdentifiedModel::corrected_model`] that are no rigid body: (link index
    /// 0-based, smallest eigenvalue of its pseudo-inertia, kg·m²) where that eigenvalue is not
    /// positive. Empty for a physically consistent arm.
    pub fn non_realisable_links(&self) -> Vec<(usize, f64)> {
        self.corrected
            .links()
            .iter()
            .enumerate()
            .map(|(l, body)| (l, body.smallest_pseudo_eigenvalue()))
            .filter(|(_, e)| e.is_nan() || *e <= 0.0)
            .collect()
    }

    /// offset + viscous·q̇ + coulomb·tanh(q̇/v0) for joint velocities `qd` (rad/s), Nm: what the
    /// torque sensors read beyond the rigid-body torque (allocation-free).
    pub fn joint_torque(&self, qd: &SVector<f64, N>) -> SVector<f64, N> {
        SVector::from_fn(|j, _| {
            self.offset[j]
                + self.viscous[j] * qd[j]
                + self.coulomb[j] * (qd[j] / self.coulomb_velocity).tanh()
        })
    }

    /// The predicted measured torque τ = Y(q, q̇, q̈)(π_nom + δπ) + joint terms, Nm (positions rad,
    /// velocities rad/s, accelerations rad/s²; allocation-free).
    pub fn predict(
        &self,
        data: &mut Data<N>,
        q: &SVector<f64, N>,
        qd: &SVector<f64, N>,
        qdd: &SVector<f64, N>,
    ) -> SVector<f64, N> {
        rnea(&self.corrected, data, q, qd, qdd) + self.joint_torque(qd)
    }

    /// The held-out residual RMS (Nm) and correlation time (s) per joint.
    pub fn model_error(&self) -> (SVector<f64, N>, SVector<f64, N>) {
        let m = &self.file.model_error;
        (
            SVector::from_column_slice(&m.residual_rms),
            SVector::from_column_slice(&m.correlation_time_s),
        )
    }

    /// The file as TOML text.
    pub fn to_toml_string(&self) -> Result<String, DynamicsError> {
        self.file.to_toml_string()
    }
}

/// δπ's torque |Y·δπ| over deterministic states within the limits (positions in the range,
/// speeds up to the limit or 2 rad/s, accelerations up to 5 rad/s²) stays within `limit`.
fn check_correction_torque<const N: usize>(
    nominal: &Model<N>,
    corrected: &Model<N>,
    limit: &dyn Fn(usize) -> f64,
) -> Result<(), DynamicsError> {
    let mut data = Data::new(nominal);
    let lim = nominal.limits();
    for s in 0..32u32 {
        // a low-discrepancy walk through the box (golden-ratio sequence per joint)
        let u = |j: usize, k: u32| {
            let x =
                (f64::from(s) + 1.0) * (0.618_033_988_75 + 0.1 * j as f64 + 0.37 * f64::from(k));
            2.0 * (x - x.floor()) - 1.0
        };
        let q = SVector::<f64, N>::from_fn(|j, _| {
            let (lo, hi) = (
                lim.position_min[j].max(-std::f64::consts::PI),
                lim.position_max[j].min(std::f64::consts::PI),
            );
            0.5 * (lo + hi) + 0.5 * (hi - lo) * u(j, 0)
        });
        let qd = SVector::<f64, N>::from_fn(|j, _| lim.velocity_max[j].min(2.0) * u(j, 1));
        let qdd = SVector::<f64, N>::from_fn(|j, _| 5.0 * u(j, 2));
        let change =
            rnea(corrected, &mut data, &q, &qd, &qdd) - rnea(nominal, &mut data, &q, &qd, &qdd);
        if let Some(j) = (0..N).find(|&j| change[j].is_nan() || change[j].abs() > limit(j)) {
            return Err(DynamicsError::Identified {
                field: "base.delta".into(),
                reason: format!(
                    "the correction changes joint {}'s torque by {:.1} Nm at q = {:?} rad, more \
                     than {:.1} Nm ({} of its torque limit): not a correction of this model",
                    j + 1,
                    change[j],
                    q.as_slice(),
                    limit(j),
                    MAX_CORRECTION_SHARE
                ),
            });
        }
    }
    Ok(())
}
