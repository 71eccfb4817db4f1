//! Pose design for the static estimator: the paper's small pattern around a pick pose (Sec. VI-A)
//! and an optimised pattern (greedy + exchange, D- or A-optimal) with the predicted standard
//! deviations of the estimate before the robot moves.
//!
//! Prediction model: independent torque noise of σ (Nm) on every used joint equation and no model
//! error (use tare or calibration to make that true); cov(p̂) = σ² (Σ_k Y_kᵀ Y_k)⁻¹ with Y_k the
//! payload gravity regressor (eq. 40).

use dynamics::{Data, Model, payload_gravity_regressor};
use nalgebra::{Matrix3, Matrix3x4, Matrix4, SMatrix, SVector, Vector3};
use serde::{Deserialize, Serialize};

use crate::basis::{clamp_limits, nth_prime};
use crate::error::EstimatorError;

/// Optimality criterion of the pose optimiser.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Criterion {
    /// Maximise det(Σ YᵀY): smallest confidence-ellipsoid volume.
    #[default]
    D,
    /// Minimise the summed predicted variances of mass (kg²) and CoM (m², weighted ×(m̄)²).
    A,
}

/// Predicted uncertainty of a pose set, for noise σ on each joint torque.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Prediction {
    /// Predicted 1σ of the mass, kg.
    pub mass_std: f64,
    /// Predicted 1σ of the CoM in the last DH frame, m (at the nominal payload); NaN for an axis
    /// no pose can determine (along the joint axes of a planar robot).
    pub com_std: [f64; 3],
    /// 2-norm condition number of the stacked payload regressor.
    pub condition_number: f64,
}

/// Nominal payload used to predict the CoM uncertainty (c = h/m depends on m and h).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Nominal {
    /// Mass guess, kg.
    pub mass: f64,
    /// CoM guess in the last DH frame, m.
    pub com: [f64; 3],
}

impl Default for Nominal {
    fn default() -> Self {
        // the paper's 3 kg payload, 4 cm beyond the LWR flange
        Nominal {
            mass: 3.0,
            com: [0.0, 0.0, 0.12],
        }
    }
}

fn u(k: usize, j: usize) -> f64 {
    2.0 * (k as f64 * (nth_prime(j) as f64).sqrt()).fract() - 1.0
}

/// The paper's pattern: `count` poses q_k = center + spread·u_k with u_kj = 2·frac(k·√p_j) − 1
/// ∈ (−1, 1) (k = 1..count; the golden Q10 set of lwr4-model.md §4 for spread = 7°), each joint
/// clamped inside the position limits.
pub fn paper_pattern<const N: usize>(
    model: &Model<N>,
    center: &SVector<f64, N>,
    spread: f64,
    count: usize,
) -> Vec<SVector<f64, N>> {
    let lim = model.limits();
    let (lo, hi) = clamp_limits(&lim.position_min, &lim.position_max);
    (1..=count)
        .map(|k| SVector::from_fn(|j, _| (center[j] + spread * u(k, j)).clamp(lo[j], hi[j])))
        .collect()
}

fn information<const N: usize>(y: &SMatrix<f64, N, 4>) -> Matrix4<f64> {
    y.transpose() * y
}

/// Predicted uncertainty of `poses` for torque noise `sigma` (Nm) and a nominal payload.
pub fn predict<const N: usize>(
    model: &Model<N>,
    poses: &[SVector<f64, N>],
    sigma: f64,
    nominal: &Nominal,
) -> Result<Prediction, EstimatorError> {
    let mut data = Data::new(model);
    let info: Matrix4<f64> = poses
        .iter()
        .map(|q| information(&payload_gravity_regressor(model, &mut data, q)))
        .sum();
    prediction_from_information(&info, sigma, nominal)
}

fn prediction_from_information(
    info: &Matrix4<f64>,
    sigma: f64,
    nominal: &Nominal,
) -> Result<Prediction, EstimatorError> {
    // parameters no pose can excite (m·cz of a planar robot: zero row and column) are left out
    let dmax = info.diagonal().max();
    let known: Vec<usize> = (0..4).filter(|&i| info[(i, i)] > 1e-12 * dmax).collect();
    if !known.contains(&0) {
        return Err(EstimatorError::RankDeficient {
            condition: f64::INFINITY,
            limit: 1e6,
        });
    }
    let reduced = info.select_rows(known.iter()).select_columns(known.iter());
    let eig = reduced.clone().symmetric_eigen();
    let (lmax, lmin) = (eig.eigenvalues.max(), eig.eigenvalues.min());
    let condition_number = if lmin > 0.0 {
        (lmax / lmin).sqrt()
    } else {
        f64::INFINITY
    };
    if !condition_number.is_finite() || condition_number > 1e6 {
        return Err(EstimatorError::RankDeficient {
            condition: condition_number,
            limit: 1e6,
        });
    }
    let Some(inv_r) = reduced.try_inverse() else {
        return Err(EstimatorError::RankDeficient {
            condition: f64::INFINITY,
            limit: 1e6,
        });
    };
    let mut cov = Matrix4::zeros();
    for (a, &i) in known.iter().enumerate() {
        for (b, &k) in known.iter().enumerate() {
            cov[(i, k)] = inv_r[(a, b)] * sigma * sigma;
        }
    }
    let m = nominal.mass;
    let h = Vector3::from(nominal.com) * m;
    let mut jc = Matrix3x4::zeros();
    jc.set_column(0, &(-h / (m * m)));
    jc.fixed_view_mut::<3, 3>(0, 1)
        .copy_from(&(Matrix3::identity() / m));
    let cc = jc * cov * jc.transpose();
    Ok(Prediction {
        mass_std: cov[(0, 0)].max(0.0).sqrt(),
        // NaN (null in JSON) for a CoM axis the poses cannot determine
        com_std: std::array::from_fn(|i| {
            if known.contains(&(i + 1)) {
                cc[(i, i)].max(0.0).sqrt()
            } else {
                f64::NAN
            }
        }),
        condition_number,
    })
}

fn score(info: &Matrix4<f64>, criterion: Criterion, nominal: &Nominal) -> f64 {
    // lower is better
    let reg = info + Matrix4::identity() * 1e-9;
    match criterion {
        Criterion::D => -reg.determinant().max(1e-300).ln(),
        Criterion::A => match prediction_from_information(&reg, 1.0, nominal) {
            Ok(p) => {
                let m2 = nominal.mass * nominal.mass;
                p.mass_std.powi(2) + m2 * p.com_std.iter().map(|s| s * s).sum::<f64>()
            }
            Err(_) => f64::INFINITY,
        },
    }
}

/// Refuses a design of fewer than two poses.
fn design_size(count: usize) -> Result<(), EstimatorError> {
    if count < 2 {
        return Err(EstimatorError::TooFewSamples {
            got: count,
            need: 2,
            what: "poses in a design",
        });
    }
    Ok(())
}

/// Chooses `count` poses inside the box center ± spread (rad, clipped to the joint limits) that
/// optimise `criterion`: greedy selection from `candidates` low-discrepancy candidates plus the box
/// corners of the gravity-relevant joints, then exchange passes until no swap improves.
pub fn optimize<const N: usize>(
    model: &Model<N>,
    center: &SVector<f64, N>,
    spread: f64,
    count: usize,
    criterion: Criterion,
    candidates: usize,
    nominal: &Nominal,
) -> Result<Vec<SVector<f64, N>>, EstimatorError> {
    design_size(count)?;
    select(
        model,
        center,
        spread,
        count,
        criterion,
        candidates,
        nominal,
        &[true; N],
        &Matrix4::zeros(),
    )
}

/// The centred design: `count` poses whose first is `center` itself, the other `count − 1`
/// chosen as by [`optimize`] given the centre's information, moving only the joints that change
/// the payload's gravity torques (never joint 1 of the LWR, whose axis is vertical: moving it
/// costs time and tells nothing). A procedure samples the centre first and again last, so the
/// revisit that measures the drift is also the way home, and it is the sample nearest in time
/// to the other phase (tare and estimate meet at the centre).
pub fn centred<const N: usize>(
    model: &Model<N>,
    center: &SVector<f64, N>,
    spread: f64,
    count: usize,
    candidates: usize,
    nominal: &Nominal,
) -> Result<Vec<SVector<f64, N>>, EstimatorError> {
    design_size(count)?;
    let mut data = Data::new(model);
    let y0 = payload_gravity_regressor(model, &mut data, center);
    // a joint matters when a small move of it changes the regressor
    let h = 1e-4;
    let movable: [bool; N] = std::array::from_fn(|j| {
        let mut q = *center;
        q[j] += h;
        let d = payload_gravity_regressor(model, &mut data, &q) - y0;
        d.amax() > 1e-9 * y0.amax().max(f64::MIN_POSITIVE)
    });
    // The D-optimal set of the box on its own (the greedy start conditioned on the centre's
    // information chose worse sets in the drift-aware prediction: docs/estimation.md), with
    // the joints that tell nothing kept at the centre.
    let mut poses = vec![*center];
    poses.extend(
        select(
            model,
            center,
            spread,
            count - 1,
            Criterion::D,
            candidates,
            nominal,
            &[true; N],
            &Matrix4::zeros(),
        )?
        .into_iter()
        .map(|q| SVector::from_fn(|j, _| if movable[j] { q[j] } else { center[j] })),
    );
    Ok(poses)
}

/// Greedy + exchange selection of `count` candidates in the box (only `movable` joints leave
/// the centre), given the information `base` of poses already chosen.
#[allow(clippy::too_many_arguments)]
fn select<const N: usize>(
    model: &Model<N>,
    center: &SVector<f64, N>,
    spread: f64,
    count: usize,
    criterion: Criterion,
    candidates: usize,
    nominal: &Nominal,
    movable: &[bool; N],
    base: &Matrix4<f64>,
) -> Result<Vec<SVector<f64, N>>, EstimatorError> {
    let lim = model.limits();
    let (lo, hi) = clamp_limits(&lim.position_min, &lim.position_max);
    let clip = |q: SVector<f64, N>| {
        SVector::<f64, N>::from_fn(|j, _| {
            if movable[j] {
                q[j].clamp(lo[j], hi[j])
            } else {
                center[j]
            }
        })
    };
    let mut cands: Vec<SVector<f64, N>> = (1..=candidates)
        .map(|k| clip(center + SVector::from_fn(|j, _| spread * u(k, j))))
        .collect();
    // corners of the box (all 2^N sign patterns when N ≤ 8): extreme poses carry the most information
    if N <= 8 {
        for mask in 0..(1usize << N) {
            if (0..N).any(|j| !movable[j] && mask >> j & 1 == 1) {
                continue;
            }
            cands.push(clip(
                center + SVector::from_fn(|j, _| if mask >> j & 1 == 1 { spread } else { -spread }),
            ));
        }
    }
    let mut data = Data::new(model);
    let infos: Vec<Matrix4<f64>> = cands
        .iter()
        .map(|q| information(&payload_gravity_regressor(model, &mut data, q)))
        .collect();
    let mut chosen: Vec<usize> = Vec::with_capacity(count);
    let mut total = *base;
    for _ in 0..count {
        let best = (0..cands.len())
            .map(|c| (c, score(&(total + infos[c]), criterion, nominal)))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((c, _)) = best {
            chosen.push(c);
            total += infos[c];
        }
    }
    for _pass in 0..4 {
        let mut improved = false;
        for slot in 0..chosen.len() {
            let without = total - infos[chosen[slot]];
            let current = score(&total, criterion, nominal);
            let best = (0..cands.len())
                .map(|c| (c, score(&(without + infos[c]), criterion, nominal)))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((c, s)) = best
                && s < current - 1e-12 * current.abs().max(1.0)
            {
                chosen[slot] = c;
                total = without + infos[c];
                improved = true;
            }
        }
        if !improved {
            break;
        }
    }
    Ok(chosen.into_iter().map(|c| cands[c]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pick() -> SVector<f64, 7> {
        SVector::from(dynamics::LWR4_PICK_POSE_RAD)
    }

    #[test]
    fn paper_pattern_stays_in_the_box_and_limits() {
        let model = dynamics::lwr4();
        let p = paper_pattern(&model, &pick(), 7f64.to_radians(), 10);
        assert_eq!(p.len(), 10);
        for q in &p {
            assert!((q - pick()).amax() <= 7f64.to_radians() + 1e-12);
        }
        let edge = SVector::<f64, 7>::from_element(2.09); // ~119.7°: joint 2/4/6 limits are 120°
        for q in paper_pattern(&model, &edge, 7f64.to_radians(), 10) {
            assert!(model.limits().contains_position(&q));
        }
    }

    #[test]
    fn optimised_design_beats_the_paper_pattern() {
        let model = dynamics::lwr4();
        let nominal = Nominal {
            mass: 3.028,
            com: [0.0, 0.0, 0.119],
        };
        let norm = |c: [f64; 3]| c.iter().map(|v| v * v).sum::<f64>().sqrt();
        let paper = predict(
            &model,
            &paper_pattern(&model, &pick(), 7f64.to_radians(), 10),
            0.05,
            &nominal,
        )
        .unwrap();
        // same 10 poses, box ±3° instead of ±7°: same mass σ (it is set by the number of
        // equations, within 1 %) and a smaller CoM σ
        let small = optimize(
            &model,
            &pick(),
            3f64.to_radians(),
            10,
            Criterion::D,
            200,
            &nominal,
        )
        .unwrap();
        let s = predict(&model, &small, 0.05, &nominal).unwrap();
        assert!(
            s.mass_std <= 1.01 * paper.mass_std,
            "{} vs {}",
            s.mass_std,
            paper.mass_std
        );
        assert!(
            norm(s.com_std) <= norm(paper.com_std),
            "{:?} vs {:?}",
            s.com_std,
            paper.com_std
        );
        for q in &small {
            assert!((q - pick()).amax() <= 3f64.to_radians() + 1e-12);
        }
        // half the poses in the same box: CoM σ still below the paper pattern's
        let few = optimize(
            &model,
            &pick(),
            7f64.to_radians(),
            5,
            Criterion::A,
            200,
            &nominal,
        )
        .unwrap();
        let f = predict(&model, &few, 0.05, &nominal).unwrap();
        assert!(
            norm(f.com_std) <= norm(paper.com_std),
            "{:?} vs {:?}",
            f.com_std,
            paper.com_std
        );
    }

    #[test]
    fn centred_design_starts_at_the_centre_and_never_moves_joint_1() {
        let model = dynamics::lwr4();
        let nominal = Nominal {
            mass: 3.028,
            com: [0.0, 0.0, 0.119],
        };
        let spread = 5f64.to_radians();
        let d = centred(&model, &pick(), spread, 10, 256, &nominal).unwrap();
        assert_eq!(d.len(), 10);
        assert_eq!(d[0], pick());
        for q in &d {
            assert_eq!(q[0], pick()[0], "joint 1 moved");
            assert!((q - pick()).amax() <= spread + 1e-12);
        }
        // in a ±5° box it determines the CoM better than the paper's ±7° pattern
        let norm = |c: [f64; 3]| c.iter().map(|v| v * v).sum::<f64>().sqrt();
        let paper = predict(
            &model,
            &paper_pattern(&model, &pick(), 7f64.to_radians(), 10),
            0.05,
            &nominal,
        )
        .unwrap();
        let c = predict(&model, &d, 0.05, &nominal).unwrap();
        assert!(
            norm(c.com_std) < norm(paper.com_std),
            "{:?} vs {:?}",
            c.com_std,
            paper.com_std
        );
        assert!(centred(&model, &pick(), spread, 1, 16, &nominal).is_err());
    }

    #[test]
    fn planar_robot_design_leaves_out_the_unobservable_axis() {
        let model = dynamics::planar_2r();
        let center = SVector::<f64, 2>::from([0.3, -0.5]);
        let p = paper_pattern(&model, &center, 20f64.to_radians(), 8);
        let nominal = Nominal {
            mass: 1.5,
            com: [0.3, 0.1, 0.0],
        };
        let pred = predict(&model, &p, 0.05, &nominal).unwrap();
        assert!(
            pred.mass_std.is_finite() && pred.com_std[0].is_finite() && pred.com_std[2].is_nan()
        );
        let opt = optimize(
            &model,
            &center,
            20f64.to_radians(),
            4,
            Criterion::D,
            100,
            &nominal,
        )
        .unwrap();
        let po = predict(&model, &opt, 0.05, &nominal).unwrap();
        assert!(
            po.mass_std <= pred.mass_std * 1.5,
            "{} vs {}",
            po.mass_std,
            pred.mass_std
        );
    }

    #[test]
    fn single_pose_design_is_rank_deficient() {
        let model = dynamics::lwr4();
        assert!(predict(&model, &[pick()], 0.05, &Nominal::default()).is_err());
    }
}
