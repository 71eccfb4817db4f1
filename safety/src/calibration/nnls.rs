//! Non-negative least squares for the envelope (Lawson–Hanson active set).

use nalgebra::{SMatrix, SVector};

use super::ENVELOPE_TERMS;

/// Non-negative least squares min ‖Ax − b‖², x ≥ 0, from the normal equations G = AᵀA,
/// h = Aᵀb (Lawson–Hanson active set; columns with zero scale stay at zero).
const K: usize = ENVELOPE_TERMS;

pub(super) fn nnls(g: &SMatrix<f64, K, K>, h: &SVector<f64, K>) -> SVector<f64, K> {
    let mut x = SVector::<f64, K>::zeros();
    let mut passive = [false; K];
    let usable: [bool; K] = std::array::from_fn(|k| g[(k, k)] > 0.0);
    for _ in 0..(3 * K + 10) {
        let gradient = h - g * x;
        let candidate = (0..K)
            .filter(|&k| usable[k] && !passive[k] && gradient[k] > 1e-12)
            .max_by(|&a, &b| gradient[a].total_cmp(&gradient[b]));
        let Some(k) = candidate else {
            break;
        };
        passive[k] = true;
        loop {
            let z = solve_passive(g, h, &passive);
            if (0..K).all(|i| !passive[i] || z[i] > 0.0) {
                x = z;
                break;
            }
            // Step back to the boundary and drop the variables that hit zero.
            let mut alpha = 1.0_f64;
            for i in 0..K {
                if passive[i] && z[i] <= 0.0 {
                    alpha = alpha.min(x[i] / (x[i] - z[i]));
                }
            }
            x += (z - x) * alpha;
            for i in 0..K {
                if passive[i] && x[i] <= 1e-15 {
                    passive[i] = false;
                    x[i] = 0.0;
                }
            }
        }
    }
    x
}

/// The unconstrained solution on the passive set (others zero).
fn solve_passive(
    g: &SMatrix<f64, K, K>,
    h: &SVector<f64, K>,
    passive: &[bool; K],
) -> SVector<f64, K> {
    let mut reduced = SMatrix::<f64, K, K>::identity();
    let mut rhs = SVector::<f64, K>::zeros();
    for a in 0..K {
        if !passive[a] {
            continue;
        }
        rhs[a] = h[a];
        for b in 0..K {
            reduced[(a, b)] = if passive[b] { g[(a, b)] } else { 0.0 };
        }
        reduced[(a, a)] += 1e-12;
    }
    reduced.lu().solve(&rhs).unwrap_or_else(SVector::zeros)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::rng::SplitMix64;

    #[test]
    fn nnls_keeps_coefficients_non_negative() {
        // y = 1 + 2 x1 − 3 x2 would need a negative coefficient: NNLS sets it to zero.
        // (The two last columns are unused: zero scale, kept at zero.)
        let mut g = SMatrix::<f64, K, K>::zeros();
        let mut h = SVector::<f64, K>::zeros();
        let mut rng = SplitMix64(1);
        for _ in 0..500 {
            let x = SVector::<f64, K>::new(1.0, rng.uniform(), rng.uniform(), 0.0, 0.0, 0.0);
            let y = 1.0 + 2.0 * x[1] - 3.0 * x[2];
            g += x * x.transpose();
            h += x * y;
        }
        let c = nnls(&g, &h);
        assert!(c.iter().all(|v| *v >= 0.0), "{c}");
        assert_eq!(c[2], 0.0);
        // Without the constraint binding, the exact solution comes back.
        let mut h = SVector::<f64, K>::zeros();
        let mut g = SMatrix::<f64, K, K>::zeros();
        for _ in 0..500 {
            let x = SVector::<f64, K>::new(1.0, rng.uniform(), rng.uniform(), 0.0, 0.0, 0.0);
            g += x * x.transpose();
            h += x * (0.5 + 2.0 * x[1] + 3.0 * x[2]);
        }
        let c = nnls(&g, &h);
        assert!(
            (c - SVector::<f64, K>::new(0.5, 2.0, 3.0, 0.0, 0.0, 0.0)).norm() < 1e-8,
            "{c}"
        );
    }
}
