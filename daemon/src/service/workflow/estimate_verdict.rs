//! The verdict on an estimate before it is reported or applied (`estimator::verdict` against
//! `[estimation]` max_com_distance_m, max_mass_std_kg, max_com_std_m and the 3σ mass): a
//! meaningless estimate fails `estimate-payload` with `Cause::EstimateRejected` carrying its
//! numbers and every bound it breaks, and nothing applies it.

use estimator::error_model::Uncertainty;
use estimator::estimate::PayloadEstimate;
use estimator::verdict;
use fri_api::cause::{Cause, EstimateProblem};
use fri_api::protocol::{ErrorCode, OperatorError};
use fri_api::results::EstimateWarning;

use crate::config::EstimationConfig;
use crate::service::core::err;

/// The fit judged by `estimator::verdict` against the configured bounds: the estimate, or the
/// refusal naming every bound it breaks with its numbers (and the warnings, which often say
/// why), or the estimator's own error.
pub(super) fn judged(
    fitted: Result<(PayloadEstimate, Option<TaredUncertainty>), estimator::EstimatorError>,
    config: &EstimationConfig,
    tared: bool,
    warnings: &[EstimateWarning],
) -> Result<(PayloadEstimate, Option<TaredUncertainty>), OperatorError> {
    let bounds = config.verdict_bounds(tared);
    let (problems, mass, mass_std, com_flange) = match fitted {
        Ok((e, u)) => {
            let problems = verdict::judge(&e, &bounds);
            if problems.is_empty() {
                return Ok((e, u));
            }
            (problems, e.mass, e.mass_std, e.com_flange)
        }
        Err(e) => match verdict::problem_of_error(&e, &bounds) {
            Some(p) => {
                let (m, s) = match p {
                    verdict::Problem::MassNotSignificant {
                        mass_kg,
                        mass_std_kg,
                        ..
                    } => (mass_kg, mass_std_kg),
                    _ => (f64::NAN, f64::NAN),
                };
                (vec![p], m, s, [f64::NAN; 3])
            }
            None => {
                return Err(err(ErrorCode::Failed, format!("estimation failed: {e}")));
            }
        },
    };
    let words: Vec<String> = problems.iter().map(ToString::to_string).collect();
    let mut message = format!(
        "estimate refused, nothing applied: {}. The fit gave {mass:.4} ± {mass_std:.4} kg",
        words.join("; ")
    );
    if com_flange.iter().any(|c| c.is_finite()) {
        message.push_str(&format!(
            " at ({:.0}, {:.0}, {:.0}) mm in the flange frame",
            com_flange[0] * 1e3,
            com_flange[1] * 1e3,
            com_flange[2] * 1e3
        ));
    }
    for w in warnings {
        message.push_str(&format!(". {}", w.message()));
    }
    message.push_str(". Check that the tare was taken without payload (run `tare` again without it), that the payload is held by the flange, and `[estimation]` max_com_distance_m, max_mass_std_kg, max_com_std_m");
    Err(
        err(ErrorCode::Failed, message).with_cause(Cause::EstimateRejected {
            mass_kg: mass,
            mass_std_kg: mass_std,
            com_flange_m: com_flange,
            problems: problems.iter().map(|p| problem(*p)).collect(),
        }),
    )
}

/// The verdict's problem as the protocol carries it.
fn problem(p: verdict::Problem) -> EstimateProblem {
    match p {
        verdict::Problem::MassNotSignificant {
            mass_kg,
            mass_std_kg,
            sigmas,
        } => EstimateProblem::MassNotSignificant {
            mass_kg,
            mass_std_kg,
            sigmas,
        },
        verdict::Problem::ComBeyondReach { distance_m, max_m } => {
            EstimateProblem::ComBeyondReach { distance_m, max_m }
        }
        verdict::Problem::MassUncertain {
            mass_std_kg,
            max_kg,
        } => EstimateProblem::MassUncertain {
            mass_std_kg,
            max_kg,
        },
        verdict::Problem::ComUncertain { com_std_m, max_m } => {
            EstimateProblem::ComUncertain { com_std_m, max_m }
        }
    }
}

/// The error model's uncertainty of an estimate and the pause its tare's drift ran over.
pub struct TaredUncertainty {
    /// σ by source.
    pub uncertainty: Uncertainty,
    /// Time from the tare's last sample to the first loaded one, s, on the controller's clock
    /// (`None` without a tare).
    pub since_tare_s: Option<f64>,
}
