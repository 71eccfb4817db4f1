//! Numerical base parameters of a robot's gravity model: which combinations of the link
//! parameters (m_i, m_i c_i) the gravity torques depend on (the paper's π_g, eq. 38, up to a
//! change of basis), found by column selection on a regressor stacked over many poses.

use dynamics::{
    ColumnChoice, Data, Model, base_parameters_of_columns, gravity_regressor,
    stacked_gravity_regressor,
};
use nalgebra::{DMatrix, DVector, SVector};

/// Deterministic low-discrepancy poses over the joint ranges: q_kj = mid_j + half_j·u_kj with
/// u_kj = 2·frac(k·√p_j) − 1 and p the primes (the formula of lwr4-model.md §4), k = 1..=count.
pub fn spread_poses<const N: usize>(
    lo: &SVector<f64, N>,
    hi: &SVector<f64, N>,
    count: usize,
) -> Vec<SVector<f64, N>> {
    (1..=count)
        .map(|k| {
            SVector::<f64, N>::from_fn(|j, _| {
                let u = 2.0 * (k as f64 * (nth_prime(j) as f64).sqrt()).fract() - 1.0;
                0.5 * (lo[j] + hi[j]) + 0.5 * (hi[j] - lo[j]) * u
            })
        })
        .collect()
}

/// The j-th prime (0-based: 2, 3, 5, 7, 11, 13, 17, …).
pub fn nth_prime(j: usize) -> u64 {
    let mut count = 0;
    let mut n = 1u64;
    loop {
        n += 1;
        if (2..n)
            .take_while(|d| d * d <= n)
            .all(|d| !n.is_multiple_of(d))
        {
            if count == j {
                return n;
            }
            count += 1;
        }
    }
}

/// Gravity base parameters: π_b = K p with p the 4N standard gravity parameters
/// (m, mcx, mcy, mcz of links 1..N in their own frames, kg and kg·m).
#[derive(Debug, Clone, PartialEq)]
pub struct GravityBasis {
    /// Number of joints N.
    pub joints: usize,
    /// Indices (into the 4N standard parameters) of the independent columns, ascending.
    pub independent: Vec<usize>,
    /// K (nb × 4N): identity on the independent columns, regrouping coefficients elsewhere.
    pub map: DMatrix<f64>,
}

impl GravityBasis {
    /// Number of base parameters nb.
    pub fn len(&self) -> usize {
        self.independent.len()
    }

    /// True when the gravity model has no identifiable parameter (no gravity at all).
    pub fn is_empty(&self) -> bool {
        self.independent.is_empty()
    }

    /// The basis of `model` (as [`GravityBasis::compute`]), remembered for the last few robot
    /// structures: the basis depends only on joints, gravity and joint limits, and recomputing it
    /// (a 224 × 28 column selection for the LWR) dominated every calibrated estimate.
    pub fn of_model<const N: usize>(model: &Model<N>) -> Self {
        memo::basis_of(model)
    }

    /// Computes the basis of `model` from 8·4N spread poses within the joint limits (no memo).
    pub fn compute<const N: usize>(model: &Model<N>) -> Self {
        let lim = model.limits();
        let (lo, hi) = clamp_limits(&lim.position_min, &lim.position_max);
        let poses = spread_poses(&lo, &hi, 8 * 4 * N);
        Self::of_columns(&stacked_gravity_regressor(model, &poses), N)
    }

    /// Column selection in column order ([`ColumnChoice::InOrder`] of
    /// [`dynamics::base_parameters_of_columns`]); a column is dependent when less than 1e-8 of
    /// its norm (relative to the largest column) remains after projection.
    pub fn of_columns(w: &DMatrix<f64>, joints: usize) -> Self {
        let base = base_parameters_of_columns(w, 1e-8, ColumnChoice::InOrder);
        GravityBasis {
            joints,
            independent: base.independent,
            map: base.map,
        }
    }

    /// Base regressor Y_b(q) = Y(q)[:, independent] (N × nb, Nm per base-parameter unit).
    pub fn regressor<const N: usize>(
        &self,
        model: &Model<N>,
        data: &mut Data<N>,
        q: &SVector<f64, N>,
    ) -> DMatrix<f64> {
        let blocks = gravity_regressor(model, data, q);
        DMatrix::from_fn(N, self.independent.len(), |r, c| {
            let col = self.independent[c];
            blocks[col / 4][(r, col % 4)]
        })
    }

    /// Base parameters π_b = K p of standard gravity parameters p (4N).
    pub fn project(&self, p: &DVector<f64>) -> DVector<f64> {
        &self.map * p
    }
}

/// Memo of [`GravityBasis::compute`] keyed on the model without its link parameters (the
/// gravity regressor, hence the basis, does not depend on them, so models that differ only by
/// a payload share one entry).
mod memo {
    use std::any::Any;
    use std::sync::{Mutex, PoisonError};

    use dynamics::{InertialParameters, Model};

    use super::GravityBasis;

    /// Distinct robot structures remembered; the oldest is dropped beyond this.
    const CAPACITY: usize = 8;

    type Entry = (Box<dyn Any + Send>, GravityBasis);

    static ENTRIES: Mutex<Vec<Entry>> = Mutex::new(Vec::new());

    pub(super) fn basis_of<const N: usize>(model: &Model<N>) -> GravityBasis {
        let key = model.with_links([InertialParameters::zero(); N]);
        let found = |entries: &[Entry]| {
            entries
                .iter()
                .find(|(k, _)| k.downcast_ref::<Model<N>>() == Some(&key))
                .map(|(_, b)| b.clone())
        };
        // a panic elsewhere while the lock was held cannot leave a half-written entry behind
        if let Some(b) = found(&ENTRIES.lock().unwrap_or_else(PoisonError::into_inner)) {
            return b;
        }
        // computed outside the lock so that threads with other robots do not wait
        let basis = GravityBasis::compute(model);
        let mut entries = ENTRIES.lock().unwrap_or_else(PoisonError::into_inner);
        if found(&entries).is_none() {
            if entries.len() >= CAPACITY {
                entries.remove(0);
            }
            entries.push((Box::new(key), basis.clone()));
        }
        basis
    }
}

/// Replaces infinite limits by ±π so that spread poses stay finite.
pub fn clamp_limits<const N: usize>(
    lo: &SVector<f64, N>,
    hi: &SVector<f64, N>,
) -> (SVector<f64, N>, SVector<f64, N>) {
    let pi = std::f64::consts::PI;
    (
        lo.map(|v| if v.is_finite() { v } else { -pi }),
        hi.map(|v| if v.is_finite() { v } else { pi }),
    )
}

/// The 4N standard gravity parameters (m, m·c per link, link frames) of a model.
pub fn standard_gravity_parameters<const N: usize>(model: &Model<N>) -> DVector<f64> {
    let mut p = DVector::zeros(4 * N);
    for (i, link) in model.links().iter().enumerate() {
        p[4 * i] = link.mass;
        p.fixed_rows_mut::<3>(4 * i + 1)
            .copy_from(&link.first_moment);
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primes() {
        let p: Vec<u64> = (0..7).map(nth_prime).collect();
        assert_eq!(p, vec![2, 3, 5, 7, 11, 13, 17]);
    }

    #[test]
    fn lwr4_has_twelve_gravity_base_parameters_like_eq38() {
        let model = dynamics::lwr4();
        let basis = GravityBasis::of_model(&model);
        assert_eq!(
            basis.len(),
            12,
            "independent columns {:?}",
            basis.independent
        );
        // the base regressor reproduces g(q) with π_b = K p at poses not used to build it
        let p = standard_gravity_parameters(&model);
        let pib = basis.project(&p);
        let mut data = Data::new(&model);
        for q in spread_poses(
            &SVector::<f64, 7>::from_element(-2.0),
            &SVector::<f64, 7>::from_element(2.5),
            5,
        ) {
            let g = dynamics::compute_generalized_gravity(&model, &mut data, &q);
            let yb = basis.regressor(&model, &mut data, &q);
            let g2 = yb * &pib;
            for j in 0..7 {
                assert!(
                    (g[j] - g2[j]).abs() < 1e-9,
                    "joint {j}: {} vs {}",
                    g[j],
                    g2[j]
                );
            }
        }
    }

    #[test]
    fn memo_returns_what_compute_computes_for_each_structure() {
        let lwr = dynamics::lwr4();
        let loaded = lwr.with_payload(&dynamics::InertialParameters::point_mass(
            2.0,
            nalgebra::Vector3::new(0.0, 0.0, 0.1),
        ));
        let planar = dynamics::planar_2r();
        for _ in 0..2 {
            assert_eq!(GravityBasis::of_model(&lwr), GravityBasis::compute(&lwr));
            assert_eq!(
                GravityBasis::of_model(&loaded),
                GravityBasis::compute(&loaded)
            );
            assert_eq!(
                GravityBasis::of_model(&planar),
                GravityBasis::compute(&planar)
            );
        }
    }

    #[test]
    fn planar_2r_has_four_gravity_base_parameters() {
        // eq. (29): π2, π3, π5, π6 enter g
        let basis = GravityBasis::of_model(&dynamics::planar_2r());
        assert_eq!(basis.len(), 4);
    }
}
