//! Linear least squares with uncertainty: solution, covariance from the residual variance,
//! per-row residuals and the condition number of the stacked matrix.

use nalgebra::{DMatrix, DVector};

use crate::error::EstimatorError;

/// Default largest accepted 2-norm condition number of a stacked regressor.
pub const DEFAULT_CONDITION_LIMIT: f64 = 1.0e5;

/// Result of an ordinary least-squares fit `A x ≈ b` (units those of `x`).
#[derive(Debug, Clone)]
pub struct LeastSquares {
    /// Estimate x̂ = A^# b.
    pub x: DVector<f64>,
    /// Covariance of x̂: s² (AᵀA)⁻¹ with s² the residual variance (units of x²).
    pub covariance: DMatrix<f64>,
    /// Unscaled (AᵀA)⁻¹, i.e. the covariance for unit noise variance (units of x² per b²).
    pub information_inverse: DMatrix<f64>,
    /// Residual variance s² = ‖b − A x̂‖² / (rows − cols), units of b².
    pub residual_variance: f64,
    /// Residuals b − A x̂, one per row (units of b).
    pub residuals: DVector<f64>,
    /// 2-norm condition number σ_max/σ_min of A (dimensionless).
    pub condition_number: f64,
}

/// Solves `A x ≈ b` in the least-squares sense with an SVD.
///
/// Fails with [`EstimatorError::TooFewSamples`] when A has no more rows than columns (no residual
/// variance could be formed) and with [`EstimatorError::RankDeficient`] when the condition number
/// exceeds `condition_limit`.
pub fn solve(
    a: &DMatrix<f64>,
    b: &DVector<f64>,
    condition_limit: f64,
) -> Result<LeastSquares, EstimatorError> {
    let (rows, cols) = a.shape();
    if cols == 0 || rows <= cols {
        return Err(EstimatorError::TooFewSamples {
            got: rows,
            need: cols + 1,
            what: "equations for a least-squares fit with a residual variance",
        });
    }
    let svd = a.clone().svd(true, true);
    let s = &svd.singular_values;
    let s_max = s.max();
    let s_min = s.min();
    let condition_number = if s_min > 0.0 {
        s_max / s_min
    } else {
        f64::INFINITY
    };
    if !condition_number.is_finite() || condition_number > condition_limit {
        return Err(EstimatorError::RankDeficient {
            condition: condition_number,
            limit: condition_limit,
        });
    }
    let (Some(u), Some(v_t)) = (svd.u.as_ref(), svd.v_t.as_ref()) else {
        return Err(EstimatorError::RankDeficient {
            condition: f64::INFINITY,
            limit: condition_limit,
        });
    };
    // x = V Σ⁻¹ Uᵀ b ; (AᵀA)⁻¹ = V Σ⁻² Vᵀ
    let mut utb = u.transpose() * b;
    let mut v_scaled = v_t.transpose();
    for k in 0..cols {
        utb[k] /= s[k];
        let inv = 1.0 / s[k];
        v_scaled.column_mut(k).scale_mut(inv);
    }
    let x = v_t.transpose() * utb;
    let information_inverse = &v_scaled * v_scaled.transpose();
    let residuals = b - a * &x;
    let residual_variance = residuals.norm_squared() / (rows - cols) as f64;
    let covariance = &information_inverse * residual_variance;
    Ok(LeastSquares {
        x,
        covariance,
        information_inverse,
        residual_variance,
        residuals,
        condition_number,
    })
}

/// Moore–Penrose pseudo-inverse of a full-column-rank matrix, (JᵀJ)⁻¹Jᵀ via SVD.
///
/// Fails with [`EstimatorError::RankDeficient`] when J is rank deficient (condition > limit).
pub fn pseudo_inverse(
    j: &DMatrix<f64>,
    condition_limit: f64,
) -> Result<DMatrix<f64>, EstimatorError> {
    let cols = j.ncols();
    if cols == 0 || j.nrows() < cols {
        return Err(EstimatorError::RankDeficient {
            condition: f64::INFINITY,
            limit: condition_limit,
        });
    }
    let svd = j.clone().svd(true, true);
    let s = &svd.singular_values;
    let condition = if s.min() > 0.0 {
        s.max() / s.min()
    } else {
        f64::INFINITY
    };
    if !condition.is_finite() || condition > condition_limit {
        return Err(EstimatorError::RankDeficient {
            condition,
            limit: condition_limit,
        });
    }
    let (Some(u), Some(v_t)) = (svd.u.as_ref(), svd.v_t.as_ref()) else {
        return Err(EstimatorError::RankDeficient {
            condition,
            limit: condition_limit,
        });
    };
    let mut v = v_t.transpose();
    for k in 0..cols {
        v.column_mut(k).scale_mut(1.0 / s[k]);
    }
    Ok(v * u.transpose())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_fit_matches_closed_form() {
        // y = 2 + 3 t with residuals (+0.1, -0.1, -0.1, +0.1)
        let t = [0.0, 1.0, 2.0, 3.0];
        let e = [0.1, -0.1, -0.1, 0.1];
        let a = DMatrix::from_fn(4, 2, |r, c| if c == 0 { 1.0 } else { t[r] });
        let b = DVector::from_fn(4, |r, _| 2.0 + 3.0 * t[r] + e[r]);
        let ls = solve(&a, &b, 1e6).unwrap();
        // residuals orthogonal to [1, t] → exact fit of the line, residuals returned unchanged
        assert!((ls.x[0] - 2.0).abs() < 1e-12);
        assert!((ls.x[1] - 3.0).abs() < 1e-12);
        assert!((ls.residual_variance - 0.04 / 2.0).abs() < 1e-12);
        // (AᵀA)⁻¹ = [[4, 6],[6, 14]]⁻¹ = [[14, -6],[-6, 4]]/20
        assert!((ls.information_inverse[(0, 0)] - 0.7).abs() < 1e-12);
        assert!((ls.information_inverse[(1, 1)] - 0.2).abs() < 1e-12);
        assert!((ls.information_inverse[(0, 1)] + 0.3).abs() < 1e-12);
    }

    #[test]
    fn rank_deficient_is_an_error() {
        let a = DMatrix::from_fn(5, 2, |r, _| r as f64);
        let b = DVector::from_element(5, 1.0);
        assert!(matches!(
            solve(&a, &b, 1e6),
            Err(EstimatorError::RankDeficient { .. })
        ));
    }

    #[test]
    fn square_system_has_no_residual_variance() {
        let a = DMatrix::<f64>::identity(3, 3);
        let b = DVector::from_element(3, 1.0);
        assert!(matches!(
            solve(&a, &b, 1e6),
            Err(EstimatorError::TooFewSamples { .. })
        ));
    }

    #[test]
    fn pseudo_inverse_of_tall_matrix() {
        let j = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 2.0, 0.0, 0.0]);
        let p = pseudo_inverse(&j, 1e6).unwrap();
        assert!((p[(0, 0)] - 1.0).abs() < 1e-12);
        assert!((p[(1, 1)] - 0.5).abs() < 1e-12);
        assert!(p[(0, 2)].abs() < 1e-12);
    }
}
