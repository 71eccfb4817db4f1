//! The arm identified from its own unloaded recordings (paper Sec. II, eqs. 11–14): per-joint
//! torque offsets, viscous and smooth Coulomb friction, and corrections δπ of the nominal
//! model's base dynamic coefficients, regularised toward the nominal model.
//!
//! Per sample and joint j: τ_j − τ_nom,j(q, q̇, q̈) = Y_base,j·δπ + o_j + v_j·q̇_j +
//! c_j·tanh(q̇_j/v0), with Y_base the regressor of the base coefficients
//! (`dynamics::identified::identification_base`) and τ_nom the nominal model's inverse dynamics.
//! Weighted least squares (each joint weighted by 1/σ_j², σ_j the residual RMS of the fit
//! without δπ) with a ridge on the deviation from the nominal model,
//!
//!   min (1/n)·Σ w_j r² + λ·Σ_k D_k²·δπ_k²,   D_k² = (1/n)·Σ w_j·Y_base,jk²,
//!
//! i.e. a Gaussian prior δπ ~ N(0, ·) centred on the nominal coefficients whose weight counts
//! every coefficient by the torque it makes on these data; with
//! [`IdentifyOptions::non_negative_friction`], v_j, c_j ≥ 0 (friction takes energy out of the
//! arm: a negative coefficient is model error fitted as physics, and it grows with speed beyond
//! the data; not yet the default: docs/estimation.md says what it costs on the real runs).
//! λ is chosen on held-out segments of other speeds
//! ([`folds`]): from 0 (free fit) through 10⁻⁸…10² to ∞ (offsets and friction only), the
//! best held-out score among the weights no worse than the nominal model on any joint
//! ([`select`]). The report gives the held-out residual of each.

mod folds;
mod normal;
mod rows;
mod samples;
mod select;

pub use samples::{Piece, Preparation, piece_of, prepare};

use dynamics::identified::{
    BaseTerms, FitSummary, IDENTIFIED_FORMAT, IdentifiedFile, JointTerms, ModelErrorTerms,
    identification_base, link_parameter_vector,
};
use dynamics::{IdentifiedModel, Model};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::EstimatorError;
use crate::model_error::{Ar1Gram, correlation_time};
use crate::motion::RecordedLog;
use normal::{Normal, condition_number, inverse, solve_non_negative};
use rows::{JOINT_TERMS, for_each_row};
use select::{JOINT_TERM_RIDGE, Ridge, choose};

/// Default v0 of the Coulomb term tanh(q̇/v0), rad/s: the sign is smooth over ±0.02 rad/s, where
/// a zero-phase-filtered velocity is still dominated by its filter, not by the joint's stiction.
pub const DEFAULT_COULOMB_VELOCITY: f64 = 0.02;
/// Default folds of the cross-validation.
pub const DEFAULT_FOLDS: usize = 5;
/// Default cutoff of the filter that derives q̇ and q̈ when a log lacks them, Hz: above the
/// content of excitation trajectories (≤ 2 Hz) and below the torque sensors' noise.
pub const DEFAULT_DERIVATIVE_CUTOFF_HZ: f64 = 5.0;
/// Default largest sample rate fitted, Hz (faster logs are thinned: the filtered signals carry
/// nothing above a few Hz).
pub const DEFAULT_MAX_RATE_HZ: f64 = 200.0;

/// Options of [`identify`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IdentifyOptions {
    /// v0 of the Coulomb term, rad/s.
    pub coulomb_velocity: f64,
    /// Keep the viscous and Coulomb coefficients ≥ 0.
    #[serde(default)]
    pub non_negative_friction: bool,
    /// Cross-validation folds (segments grouped by speed, [`folds`]), 2…20.
    pub folds: usize,
    /// Use a log's own q̇ and q̈ when it has both columns (otherwise derive them).
    pub recorded_derivatives: bool,
    /// Butterworth order of the derivation filter.
    pub order: usize,
    /// Cutoff of the derivation filter, Hz.
    pub cutoff_hz: f64,
    /// Edge trim of the derivation filter, s (`None`: 3/cutoff).
    pub trim_s: Option<f64>,
    /// Largest sample rate fitted, Hz.
    pub max_rate_hz: f64,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        Self {
            coulomb_velocity: DEFAULT_COULOMB_VELOCITY,
            non_negative_friction: false,
            folds: DEFAULT_FOLDS,
            recorded_derivatives: true,
            order: 4,
            cutoff_hz: DEFAULT_DERIVATIVE_CUTOFF_HZ,
            trim_s: None,
            max_rate_hz: DEFAULT_MAX_RATE_HZ,
        }
    }
}

/// One ridge weight of the cross-validation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CvPoint {
    /// λ (0: free fit; `None`: ∞, offsets and friction only).
    pub weight: Option<f64>,
    /// Held-out residual RMS per joint, Nm (NaN when the fit was singular).
    pub heldout_rms: Vec<f64>,
    /// Weighted held-out score (the criterion).
    pub score: f64,
}

/// An identification and how it went.
#[derive(Debug, Clone)]
pub struct Identification<const N: usize> {
    /// The identified model (its file carries the parameters, σ and the fit summary).
    pub model: IdentifiedModel<N>,
    /// The cross-validation curve, λ ascending (∞ last).
    pub cv: Vec<CvPoint>,
    /// How the samples were obtained.
    pub preparation: Preparation,
    /// Joint weights used, 1/Nm².
    pub weights: Vec<f64>,
    /// The options it ran with.
    pub options: IdentifyOptions,
}

/// The regularised normal equations were singular (a regressor with no motion in it).
fn singular() -> EstimatorError {
    EstimatorError::RankDeficient {
        condition: f64::INFINITY,
        limit: 1e12,
    }
}

fn check_options(o: &IdentifyOptions) -> Result<(), EstimatorError> {
    let bad = |what: String| Err(EstimatorError::InvalidSetting(what));
    if !(2..=20).contains(&o.folds) {
        return bad(format!("folds {} must be 2 to 20", o.folds));
    }
    let v0 = o.coulomb_velocity;
    if !(v0.is_finite()
        && (dynamics::identified::MIN_COULOMB_VELOCITY
            ..=dynamics::identified::MAX_COULOMB_VELOCITY)
            .contains(&v0))
    {
        return bad(format!(
            "Coulomb velocity {v0} rad/s must be 1e-4 to 1 rad/s"
        ));
    }
    if !(o.max_rate_hz.is_finite() && o.max_rate_hz >= 1.0) {
        return bad(format!(
            "largest rate {} Hz must be at least 1 Hz",
            o.max_rate_hz
        ));
    }
    Ok(())
}

/// Identifies `model`'s arm from unloaded `logs` (named `names` in the file), see the module
/// docs; Err when the logs are too short or carry no motion.
pub fn identify<const N: usize>(
    model: &Model<N>,
    logs: &[RecordedLog<N>],
    names: &[String],
    options: &IdentifyOptions,
) -> Result<Identification<N>, EstimatorError> {
    check_options(options)?;
    let (pieces, preparation) = prepare(logs, options)?;
    let total: usize = pieces.iter().map(Piece::len).sum();
    let folds = options.folds;
    let need = 20 * folds;
    if total < need {
        return Err(EstimatorError::TooFewSamples {
            got: total,
            need,
            what: "samples for the identification's cross-validation",
        });
    }
    let base = identification_base(model);
    let columns = base.independent.clone();
    let p = columns.len();
    let k = p + JOINT_TERMS * N;
    let v0 = options.coulomb_velocity;
    let fold_of = folds::speed_folds(&pieces, folds::DEFAULT_SEGMENT_S, folds);
    let mut sums = Normal::new(k, folds, N);
    let mut finite = true;
    for_each_row(model, &columns, v0, &pieces, |s, _, _, j, a, y| {
        finite &= y.is_finite() && a.iter().all(|v| v.is_finite());
        sums.add(fold_of[s], j, a, y);
    });
    if !finite {
        return Err(EstimatorError::NotFinite {
            sample: 0,
            column: "regressor or torque of the identification (are the positions in rad?)".into(),
        });
    }
    let joint_terms: Vec<usize> = (p..k).collect();
    // viscous and Coulomb friction never negative, when asked
    let friction: Vec<usize> = if options.non_negative_friction {
        (p + N..k).collect()
    } else {
        Vec::new()
    };
    // joint weights from the fit without δπ (unweighted)
    let ones = vec![1.0; N];
    let (g1, h1) = sums.weighted(&ones, None);
    let tiny = DVector::from_fn(k, |c, _| JOINT_TERM_RIDGE * g1[(c, c)].max(1e-12));
    let (x0, _) =
        solve_non_negative(&g1, &h1, &tiny, &joint_terms, &friction).ok_or_else(singular)?;
    let weights: Vec<f64> = (0..N)
        .map(|j| {
            let var = sums.sse(None, j, &x0) / total as f64;
            1.0 / var.max(1e-6)
        })
        .collect();
    let (g, h) = sums.weighted(&weights, None);
    let ridge = Ridge {
        sums: &sums,
        weights: &weights,
        p,
        friction,
        scale: (0..k).map(|c| g[(c, c)] / total as f64).collect(),
    };
    let cv = ridge.curve();
    let zero = DVector::zeros(k);
    let in_sample = |x: &DVector<f64>| -> Vec<f64> {
        (0..N)
            .map(|j| (sums.sse(None, j, x) / total as f64).sqrt())
            .collect()
    };
    let nominal_rms = in_sample(&zero);
    let chosen = choose(&cv, &nominal_rms).ok_or_else(singular)?;
    let pen = ridge.penalty(chosen, total);
    let (x, active) = ridge.fit(&g, &h, chosen, total).ok_or_else(singular)?;
    // the held-out residual series at the chosen λ: its RMS and correlation time are the
    // model error later estimates carry
    let fold_fits = ridge.fold_fits(chosen).ok_or_else(singular)?;
    let mut times = Vec::with_capacity(total);
    let mut starts = Vec::new();
    let mut heldout: Vec<Vec<f64>> = vec![Vec::with_capacity(total); N];
    // largest |residual| per joint: the nominal model's (y itself) and the identified one's
    let mut peak_nominal = vec![0.0_f64; N];
    let mut peak = vec![0.0_f64; N];
    let mut last_piece = usize::MAX;
    for_each_row(model, &columns, v0, &pieces, |s, i, t, j, a, y| {
        if j == 0 {
            if i != last_piece {
                starts.push(s);
                last_piece = i;
            }
            times.push(t);
        }
        let xf = &fold_fits[fold_of[s]];
        let fit: f64 = a.iter().zip(xf.iter()).map(|(u, v)| u * v).sum();
        heldout[j].push(y - fit);
        let fit_all: f64 = a.iter().zip(x.iter()).map(|(u, v)| u * v).sum();
        peak_nominal[j] = peak_nominal[j].max(y.abs());
        peak[j] = peak[j].max((y - fit_all).abs());
    });
    let heldout_peak: Vec<f64> = heldout
        .iter()
        .map(|r| r.iter().fold(0.0_f64, |m, v| m.max(v.abs())))
        .collect();
    let rms = |r: &[f64]| (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).sqrt();
    let heldout_rms: Vec<f64> = heldout.iter().map(|r| rms(r)).collect();
    let taus: Vec<f64> = heldout
        .iter()
        .map(|r| correlation_time(&times, r, &starts))
        .collect();
    // covariance: sandwich of the weighted ridge fit with each joint's correlated model error
    // a friction coefficient held at zero is a bound, not an estimate: no variance
    let bread = inverse(&g, &pen, &active).ok_or_else(singular)?;
    let mut grams: Vec<Ar1Gram> = (0..N).map(|j| Ar1Gram::new(k, taus[j])).collect();
    let mut last_piece = usize::MAX;
    let mut new_piece = false;
    for_each_row(model, &columns, v0, &pieces, |_, i, t, j, a, _| {
        if j == 0 {
            new_piece = i != last_piece;
            last_piece = i;
        }
        grams[j].push(t, a, new_piece);
    });
    let mut meat = DMatrix::<f64>::zeros(k, k);
    for j in 0..N {
        let s2 = heldout_rms[j] * heldout_rms[j];
        meat += grams[j].finish() * (weights[j] * weights[j] * s2);
    }
    let cov = &bread * meat * &bread;
    let sd: Vec<f64> = (0..k).map(|c| cov[(c, c)].max(0.0).sqrt()).collect();
    let pi_nom = &base.map * link_parameter_vector(model);
    let duration_s: f64 = pieces
        .iter()
        .map(|p| p.t.last().copied().unwrap_or(0.0) - p.t.first().copied().unwrap_or(0.0))
        .sum();
    let rms_at = |w: Option<f64>| {
        cv.iter()
            .find(|c| c.weight == w)
            .map_or(vec![f64::NAN; N], |c| c.heldout_rms.clone())
    };
    let slice = |from: usize, v: &[f64]| v[from..from + N].to_vec();
    let xs: Vec<f64> = x.iter().copied().collect();
    let file = IdentifiedFile {
        format: IDENTIFIED_FORMAT,
        robot: model.name().to_owned(),
        joints: N,
        joint: JointTerms {
            coulomb_velocity: v0,
            offset: slice(p, &xs),
            offset_std: slice(p, &sd),
            viscous: slice(p + N, &xs),
            viscous_std: slice(p + N, &sd),
            coulomb: slice(p + 2 * N, &xs),
            coulomb_std: slice(p + 2 * N, &sd),
        },
        base: BaseTerms {
            columns: columns.clone(),
            nominal: pi_nom.iter().copied().collect(),
            delta: xs[..p].to_vec(),
            delta_std: sd[..p].to_vec(),
        },
        model_error: ModelErrorTerms {
            residual_rms: heldout_rms.clone(),
            correlation_time_s: taus,
        },
        fit: FitSummary {
            logs: names.to_vec(),
            samples: total,
            duration_s,
            ridge_weight: chosen.unwrap_or(f64::INFINITY),
            folds,
            condition_number: condition_number(&g),
            residual_rms_nominal: nominal_rms,
            residual_rms: in_sample(&x),
            heldout_rms,
            heldout_rms_joint_terms: rms_at(None),
            heldout_rms_free: rms_at(Some(0.0)),
            residual_peak_nominal: peak_nominal,
            residual_peak: peak,
            heldout_peak,
        },
    };
    let model = IdentifiedModel::new(model, file)?;
    Ok(Identification {
        model,
        cv,
        preparation,
        weights,
        options: *options,
    })
}
