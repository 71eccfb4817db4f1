//! The real KUKA LWR 4+ recordings in `data/real-lwr4` (the same excitation run twice;
//! provenance in its README): the arm identified on one run predicts the other, the payload
//! estimates of these unloaded runs stay within their σ of zero by every route, and the tare
//! route accepts a repeat of the trajectory. A missing recording is a failure, never a skip.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{Data, IdentifiedModel, InertialParameters, Model, lwr4, rnea};
use estimator::EstimatorError;
use estimator::coefficient_route::estimate_from_logs;
use estimator::consistency::NonPhysical;
use estimator::identify::{Identification, IdentifyOptions, identify};
use estimator::motion::{
    InertialEstimate, MotionOptions, RecordedLog, Unloaded, estimate_motion, read_recorded_csv,
};
use nalgebra::{Matrix3, SVector, Vector3};

type V7 = SVector<f64, 7>;

fn read(name: &str) -> RecordedLog<7> {
    // tests run in the crate's folder: the repository's `../shared` is two levels up
    let path = format!("../data/real-lwr4/{name}");
    let file = std::fs::File::open(&path).unwrap_or_else(|e| {
        panic!("{path}: {e} (the shared real-arm recordings must be beside the repository)")
    });
    read_recorded_csv(file).unwrap()
}

fn identified(log: &RecordedLog<7>, name: &str, options: &IdentifyOptions) -> Identification<7> {
    identify(&lwr4(), std::slice::from_ref(log), &[name.into()], options).unwrap()
}

/// RMS per joint of τ − prediction over `rows` of `log`, with the log's own q̇ and q̈.
fn rms(
    log: &RecordedLog<7>,
    rows: std::ops::Range<usize>,
    predict: impl Fn(&mut Data<7>, &V7, &V7, &V7) -> V7,
) -> V7 {
    let d = log.derivatives.as_ref().unwrap();
    let mut data = Data::new(&lwr4());
    let mut sum = V7::zeros();
    for k in rows.clone() {
        let r =
            log.trajectory.tau[k] - predict(&mut data, &log.trajectory.q[k], &d.qd[k], &d.qdd[k]);
        sum += r.component_mul(&r);
    }
    sum.map(|s| (s / rows.len() as f64).sqrt())
}

fn nominal(model: &Model<7>) -> impl Fn(&mut Data<7>, &V7, &V7, &V7) -> V7 + '_ {
    move |data, q, qd, qdd| rnea(model, data, q, qd, qdd)
}

fn identified_prediction(
    m: &IdentifiedModel<7>,
) -> impl Fn(&mut Data<7>, &V7, &V7, &V7) -> V7 + '_ {
    move |data, q, qd, qdd| m.predict(data, q, qd, qdd)
}

#[test]
fn the_nominal_model_leaves_the_residual_the_issue_reports() {
    // a check of the pipeline: issue 21's figures for run 1 (Gaz parameters)
    let run1 = read("flobaroid-run1.csv");
    let n = run1.trajectory.t.len();
    let model = lwr4();
    let r = rms(&run1, 0..n, nominal(&model));
    let expect = [1.32, 0.77, 0.56, 0.80, 1.31, 0.67, 0.27];
    for j in 0..7 {
        assert!(
            (r[j] - expect[j]).abs() < 0.006,
            "joint {}: {} Nm",
            j + 1,
            r[j]
        );
    }
}

/// Largest |τ − prediction| per joint over `log`, with the log's own q̇ and q̈.
fn peak(log: &RecordedLog<7>, predict: impl Fn(&mut Data<7>, &V7, &V7, &V7) -> V7) -> V7 {
    let d = log.derivatives.as_ref().unwrap();
    let mut data = Data::new(&lwr4());
    let mut peak = V7::zeros();
    for k in 0..log.trajectory.t.len() {
        let r =
            log.trajectory.tau[k] - predict(&mut data, &log.trajectory.q[k], &d.qd[k], &d.qdd[k]);
        peak = peak.zip_map(&r, |p, x| p.max(x.abs()));
    }
    peak
}

#[test]
fn the_identification_reports_the_residual_peaks_before_and_after() {
    let run1 = read("flobaroid-run1.csv");
    let model = lwr4();
    // the pipeline against issue 21's printed peaks of the nominal model on run 1
    let nominal_peak = peak(&run1, nominal(&model));
    let expect = [2.45, 1.90, 1.30, 1.90, 2.27, 1.18, 0.59];
    for j in 0..7 {
        assert!(
            (nominal_peak[j] - expect[j]).abs() < 0.006,
            "joint {}: {} Nm",
            j + 1,
            nominal_peak[j]
        );
    }
    let id = identified(&run1, "run1", &IdentifyOptions::default());
    let fit = &id.model.file().fit;
    println!(
        "run 1 peaks |r| [Nm]: nominal {:.3?}, identified in sample {:.3?}, held out {:.3?}",
        fit.residual_peak_nominal, fit.residual_peak, fit.heldout_peak
    );
    // what the report prints is the peak over the rows the fit used (all of run 1's)
    let in_sample = peak(&run1, identified_prediction(&id.model));
    for j in 0..7 {
        assert!(
            (fit.residual_peak_nominal[j] - nominal_peak[j]).abs() < 1e-6,
            "joint {}: nominal peak {} reported, {} over the log",
            j + 1,
            fit.residual_peak_nominal[j],
            nominal_peak[j]
        );
        assert!(
            (fit.residual_peak[j] - in_sample[j]).abs() < 1e-6,
            "joint {}: identified peak {} reported, {} over the log",
            j + 1,
            fit.residual_peak[j],
            in_sample[j]
        );
        assert!(fit.heldout_peak[j] >= fit.heldout_rms[j], "joint {}", j + 1);
        assert!(fit.residual_peak[j] < nominal_peak[j], "joint {}", j + 1);
    }
}

#[test]
fn identified_on_run_1_the_model_leaves_at_most_0_3_nm_rms_on_every_joint_of_run_2() {
    let (run1, run2) = (read("flobaroid-run1.csv"), read("flobaroid-run2.csv"));
    let id = identified(&run1, "run1", &IdentifyOptions::default());
    let r = rms(
        &run2,
        0..run2.trajectory.t.len(),
        identified_prediction(&id.model),
    );
    // the figure BENCHMARKS.md quotes (`-- --nocapture`)
    println!(
        "run 2, arm identified on run 1: residual RMS {:.3?} Nm",
        r.as_slice()
    );
    for j in 0..7 {
        assert!(
            r[j] <= 0.3,
            "joint {}: {:.3} Nm RMS on run 2 ({r:?})",
            j + 1,
            r[j]
        );
    }
    // the same from positions alone: q̇, q̈ derived on the log's own stamps (as for the
    // service's logs, which carry no q̈)
    let options = IdentifyOptions {
        recorded_derivatives: false,
        ..IdentifyOptions::default()
    };
    let from_q = identified(&run1, "run1", &options);
    assert_eq!(from_q.preparation.derived, 1);
    let r = rms(
        &run2,
        0..run2.trajectory.t.len(),
        identified_prediction(&from_q.model),
    );
    println!(
        "run 2, identified from run 1's q alone: residual RMS {:.3?} Nm",
        r.as_slice()
    );
    for j in 0..7 {
        assert!(
            r[j] <= 0.3,
            "from q alone, joint {}: {:.3} Nm RMS ({r:?})",
            j + 1,
            r[j]
        );
    }
}

/// Each log cut into 2.5 s segments: (rows, mean |q̇|₂ in rad/s).
fn segments(log: &RecordedLog<7>) -> Vec<(std::ops::Range<usize>, f64)> {
    let t = &log.trajectory.t;
    let d = log.derivatives.as_ref().unwrap();
    let mut out = Vec::new();
    let mut start = 0;
    for k in 1..=t.len() {
        if k == t.len() || t[k] - t[start] >= 2.5 {
            let speed = (start..k).map(|i| d.qd[i].norm()).sum::<f64>() / (k - start) as f64;
            out.push((start..k, speed));
            start = k;
        }
    }
    out
}

#[test]
fn faster_segments_are_predicted_from_slower_ones_better_than_by_the_nominal_model() {
    // the held-back trajectory is faster than the shared runs: fit on the slower half of both
    // runs' segments, predict the faster half (never seen, up to 1.6× the speed)
    let (run1, run2) = (read("flobaroid-run1.csv"), read("flobaroid-run2.csv"));
    let model = lwr4();
    let mut slow = Vec::new();
    let mut fast = Vec::new();
    for log in [&run1, &run2] {
        let mut cut = segments(log);
        cut.sort_by(|a, b| a.1.total_cmp(&b.1));
        let half = cut.len() / 2;
        for (i, (rows, _)) in cut.into_iter().enumerate() {
            if i < half {
                slow.push(log.slice(rows));
            } else {
                fast.push((log, rows));
            }
        }
    }
    let names: Vec<String> = (0..slow.len())
        .map(|i| format!("slow segment {i}"))
        .collect();
    for non_negative_friction in [false, true] {
        let options = IdentifyOptions {
            non_negative_friction,
            ..IdentifyOptions::default()
        };
        let id = identify(&model, &slow, &names, &options).unwrap();
        let (mut by_id, mut by_nominal, mut n) = (V7::zeros(), V7::zeros(), 0);
        for (log, rows) in &fast {
            let a = rms(log, rows.clone(), identified_prediction(&id.model));
            let b = rms(log, rows.clone(), nominal(&model));
            by_id += a.component_mul(&a) * rows.len() as f64;
            by_nominal += b.component_mul(&b) * rows.len() as f64;
            n += rows.len();
        }
        let (by_id, by_nominal) = (
            by_id.map(|s| (s / n as f64).sqrt()),
            by_nominal.map(|s| (s / n as f64).sqrt()),
        );
        // the figures BENCHMARKS.md quotes (`-- --nocapture`)
        println!(
            "faster half, fitted on the slower half (friction ≥ 0: {non_negative_friction}): RMS identified {:.3?}, nominal {:.3?} Nm",
            by_id.as_slice(),
            by_nominal.as_slice()
        );
        for j in 0..7 {
            assert!(
                by_id[j] < by_nominal[j],
                "friction ≥ 0: {non_negative_friction}, joint {}: {:.3} Nm identified, {:.3} nominal",
                j + 1,
                by_id[j],
                by_nominal[j]
            );
        }
        let f = &id.model.file().joint;
        if non_negative_friction {
            assert!(
                f.viscous.iter().chain(&f.coulomb).all(|v| *v >= 0.0),
                "{f:?}"
            );
        }
    }
}

#[test]
fn on_run_1_and_on_runs_1_and_2_the_held_out_residual_is_at_most_the_nominal_models() {
    let (run1, run2) = (read("flobaroid-run1.csv"), read("flobaroid-run2.csv"));
    let model = lwr4();
    for non_negative_friction in [false, true] {
        let o = IdentifyOptions {
            non_negative_friction,
            ..IdentifyOptions::default()
        };
        let one = identify(&model, std::slice::from_ref(&run1), &["run1".into()], &o).unwrap();
        let both = identify(
            &model,
            &[run1.clone(), run2.clone()],
            &["run1".into(), "run2".into()],
            &o,
        )
        .unwrap();
        for (what, id) in [("run 1", &one), ("runs 1 and 2", &both)] {
            let file = id.model.file();
            let fit = &file.fit;
            println!(
                "{what}, friction ≥ 0: {non_negative_friction}: λ = {}, held out (segments of other speeds) {:.3?}, nominal {:.3?} Nm; viscous {:.3?}",
                fit.ridge_weight, fit.heldout_rms, fit.residual_rms_nominal, file.joint.viscous
            );
            for j in 0..7 {
                assert!(
                    fit.heldout_rms[j] <= fit.residual_rms_nominal[j],
                    "{what}, joint {}: {:.3} Nm held out, nominal {:.3}",
                    j + 1,
                    fit.heldout_rms[j],
                    fit.residual_rms_nominal[j]
                );
            }
            let joint = &file.joint;
            if non_negative_friction {
                assert!(
                    joint
                        .viscous
                        .iter()
                        .chain(&joint.coulomb)
                        .all(|v| *v >= 0.0),
                    "{what}: negative friction {joint:?}"
                );
            }
            assert!(
                joint
                    .offset_std
                    .iter()
                    .chain(&file.base.delta_std)
                    .all(|s| s.is_finite() && *s > 0.0)
            );
        }
    }
}

#[test]
fn the_regularised_model_generalises_where_the_free_fit_does_not() {
    let run1 = read("flobaroid-run1.csv");
    let n = run1.trajectory.t.len();
    let first = run1.slice(0..n / 2);
    let id = identified(&first, "run1, first half", &IdentifyOptions::default());
    let model = lwr4();
    // on the half it never saw, the identified model beats the nominal one on every joint
    let other = rms(&run1, n / 2..n, identified_prediction(&id.model));
    let nominal = rms(&run1, n / 2..n, nominal(&model));
    for j in 0..7 {
        assert!(
            other[j] < nominal[j],
            "joint {}: {:.3} vs nominal {:.3}",
            j + 1,
            other[j],
            nominal[j]
        );
    }
    // on the cross-validation blocks of the whole run, the chosen weight is better than no
    // base correction, and the free fit (λ = 0) is worse than the nominal model on joint 2:
    // why the fit is regularised (issue 21)
    let whole = identified(&run1, "run1", &IdentifyOptions::default());
    let score = |w: Option<f64>| whole.cv.iter().find(|c| c.weight == w).unwrap().score;
    let chosen = whole.model.file().fit.ridge_weight;
    assert!(chosen > 0.0 && chosen.is_finite(), "λ = {chosen}");
    assert!(score(Some(chosen)) < score(None));
    assert!(score(Some(chosen)) < score(Some(0.0)));
    let fit = &whole.model.file().fit;
    assert!(
        fit.heldout_rms_free[1] > fit.residual_rms_nominal[1],
        "{fit:?}"
    );
    // and the report is complete: σ of every parameter, the condition number
    let file = whole.model.file();
    assert!(
        file.base
            .delta_std
            .iter()
            .chain(&file.joint.offset_std)
            .all(|s| s.is_finite() && *s > 0.0)
    );
    assert!(fit.condition_number.is_finite() && fit.condition_number > 1.0);
}

/// The estimate of an unloaded run must be refused as "no payload" with the mass within 2σ of
/// zero and at most 20 g.
fn assert_no_payload(result: Result<InertialEstimate, EstimatorError>, what: &str) -> (f64, f64) {
    match result {
        Err(EstimatorError::NonPhysical {
            cause: NonPhysical::MassNotPositive { mass, std, .. },
            ..
        }) => {
            assert!(
                mass.abs() <= 2.0 * std,
                "{what}: {mass:.4} ± {std:.4} kg is not within 2σ of 0"
            );
            assert!(mass.abs() <= 0.020, "{what}: |{mass:.4}| kg > 20 g");
            (mass, std)
        }
        other => panic!("{what}: expected `no payload`, got {other:?}"),
    }
}

#[test]
fn unloaded_runs_give_no_payload_by_the_motion_and_the_coefficient_routes() {
    let runs = [read("flobaroid-run1.csv"), read("flobaroid-run2.csv")];
    let models = [
        identified(&runs[0], "run1", &IdentifyOptions::default()).model,
        identified(&runs[1], "run2", &IdentifyOptions::default()).model,
    ];
    let model = lwr4();
    let options = MotionOptions::default();
    for (test, train) in [(1, 0), (0, 1)] {
        let log = std::slice::from_ref(&runs[test].trajectory);
        let what = format!(
            "run {} against the arm identified on run {}",
            test + 1,
            train + 1
        );
        let motion = estimate_motion(
            &model,
            log,
            Unloaded::Identified(&models[train]),
            &[],
            &options,
        );
        assert_no_payload(motion, &format!("motion route, {what}"));
        let route = estimate_from_logs(&models[train], log, &options).map(|c| c.estimate);
        assert_no_payload(route, &format!("coefficient route, {what}"));
    }
}

#[test]
fn the_nominal_models_bias_is_inside_its_honest_sigma() {
    // today's figures were −0.0276 ± 0.0090 kg (3σ) and −0.0459 ± 0.0085 kg (5σ): the σ of
    // independent rows; with the model-error term the same bias is inside 2σ
    let model = lwr4();
    for name in ["flobaroid-run1.csv", "flobaroid-run2.csv"] {
        let log = read(name).trajectory;
        match estimate_motion(
            &model,
            &[log],
            Unloaded::Model(&model),
            &[],
            &MotionOptions::default(),
        ) {
            Err(EstimatorError::NonPhysical {
                cause: NonPhysical::MassNotPositive { mass, std, .. },
                estimate,
            }) => {
                assert!(mass.abs() <= 2.0 * std, "{name}: {mass} ± {std}");
                assert!(estimate.parameters_std_white[0] < 0.5 * std, "{estimate:?}");
            }
            other => panic!("{name}: expected `no payload`, got {other:?}"),
        }
    }
}

#[test]
fn a_repeat_of_the_trajectory_is_accepted_as_tare() {
    let (run1, run2) = (read("flobaroid-run1.csv"), read("flobaroid-run2.csv"));
    let model = lwr4();
    // refused before: "tare pose mismatch: joint 1 differs by 0.00211 rad"
    for (loaded, tare) in [(&run2, &run1), (&run1, &run2)] {
        let result = estimate_motion(
            &model,
            std::slice::from_ref(&loaded.trajectory),
            Unloaded::Tare(std::slice::from_ref(&tare.trajectory)),
            &[],
            &MotionOptions::default(),
        );
        assert_no_payload(result, "tare route");
    }
    // the alignment: run 2 is run 1 about 7 ms later, and then matches to 0.2 mrad
    let options = MotionOptions::default();
    let p1 = estimator::motion::process(&run1.trajectory, &options).unwrap();
    let p2 = estimator::motion::process(&run2.trajectory, &options).unwrap();
    let (_, a) = estimator::align::align_tare(&p2, &p1, options.tare_tolerance).unwrap();
    assert!((a.shift_s + 0.007).abs() < 0.002, "{a:?}");
    assert!(a.max_difference < 2e-4, "{a:?}");
    // another path is still refused, naming the joint
    let mut other = run1.trajectory.clone();
    for q in &mut other.q {
        q[2] += 0.05;
    }
    let result = estimate_motion(
        &model,
        std::slice::from_ref(&run2.trajectory),
        Unloaded::Tare(&[other]),
        &[],
        &options,
    );
    match result {
        Err(EstimatorError::TarePoseMismatch { detail }) => {
            assert!(
                detail.contains("joint 3") && detail.contains("0.02 rad"),
                "{detail}"
            )
        }
        other => panic!("expected a tare path mismatch, got {other:?}"),
    }
}

/// The paper's payload (3.028 kg at (0, 0, 0.119) m in frame 7, the simulator's solid cylinder
/// of radius 0.04 m and length 0.08 m about its centre of mass).
fn paper_payload() -> InertialParameters {
    let (m, r, l) = (3.028, 0.04, 0.08);
    let transverse = m * (3.0 * r * r + l * l) / 12.0;
    InertialParameters::from_com(
        m,
        Vector3::new(0.0, 0.0, 0.119),
        Matrix3::from_diagonal(&Vector3::new(transverse, transverse, 0.5 * m * r * r)),
    )
}

/// `log` as if it had carried `payload`: its measured torques plus the payload's, computed by
/// RNEA on the recorded q, q̇, q̈ (the arm's model error and sensor noise stay real).
fn with_payload(log: &RecordedLog<7>, payload: &InertialParameters) -> RecordedLog<7> {
    let model = lwr4();
    let loaded_model = model.with_payload(payload);
    let (mut data, mut loaded_data) = (Data::new(&model), Data::new(&loaded_model));
    let d = log.derivatives.as_ref().unwrap();
    let mut out = log.clone();
    for k in 0..out.trajectory.t.len() {
        let (q, qd, qdd) = (&log.trajectory.q[k], &d.qd[k], &d.qdd[k]);
        out.trajectory.tau[k] +=
            rnea(&loaded_model, &mut loaded_data, q, qd, qdd) - rnea(&model, &mut data, q, qd, qdd);
    }
    out
}

/// The estimate of a loaded run, and the refusal's cause when the estimator refused it as no
/// rigid body (the estimate is then inside the error).
fn estimate_or_refusal(
    result: Result<InertialEstimate, EstimatorError>,
    what: &str,
) -> (InertialEstimate, Option<NonPhysical>) {
    match result {
        Ok(e) => (e, None),
        Err(EstimatorError::NonPhysical { cause, estimate }) => (*estimate, Some(cause)),
        Err(e) => panic!("{what}: {e}"),
    }
}

/// Issue 21 item 4: the paper's coefficient route end to end from logs (eqs. 25, 28, 45) and the
/// motion route on a known payload on a real run: run 2 with the paper's payload's torques
/// added, against the arm identified on run 1. The mass and the centre of mass lie within 2σ of
/// the truth (their σ carries the real arm's model error). This excitation was made to identify
/// the arm, not a payload: it cannot resolve the payload's inertia (its σ, about 0.2 kg·m², is
/// far above the truth's 0.0024–0.0028 kg·m² and covers every inertia a 3 kg flange load can
/// have), so both routes answer with the mass and the centre of mass and say the inertia is not
/// resolved — before, they refused the whole estimate as "no rigid body", its inertia 2.2σ
/// below zero.
#[test]
fn a_known_payload_on_a_real_run_gives_its_mass_and_centre_of_mass_within_2_sigma() {
    let run1 = read("flobaroid-run1.csv");
    let run2 = read("flobaroid-run2.csv");
    let arm = identified(&run1, "run1", &IdentifyOptions::default()).model;
    let payload = paper_payload();
    let loaded = with_payload(&run2, &payload);
    let options = MotionOptions::default();
    let log = std::slice::from_ref(&loaded.trajectory);
    let route = estimate_from_logs(&arm, log, &options).map(|c| c.estimate);
    let motion = estimate_motion(&lwr4(), log, Unloaded::Identified(&arm), &[], &options);
    for (what, result) in [("coefficient route", route), ("motion route", motion)] {
        let (e, refused) = estimate_or_refusal(result, what);
        let std = e.parameters_std[0];
        println!(
            "{what}: {:.4} ± {:.4} kg (truth 3.028), CoM [mm] {:.1?} ± {:.1?} (truth z 119); {}",
            e.mass,
            std,
            e.com.map(|c| c * 1e3),
            e.com_std.map(|c| c * 1e3),
            refused
                .as_ref()
                .map_or("accepted".to_owned(), |c| format!("refused: {c:?}"))
        );
        assert!(refused.is_none(), "{what}: refused for {refused:?}");
        assert!(!e.inertia_resolved, "{what}: {e:#?}");
        let warning = e.physical_warning.as_deref().unwrap_or_default();
        assert!(
            warning.contains("inertia not resolved"),
            "{what}: {warning}"
        );
        assert!(
            (e.mass - payload.mass).abs() <= 2.0 * std,
            "{what}: {:.4} ± {:.4} kg is not within 2σ of 3.028 kg",
            e.mass,
            std
        );
        assert!(
            (e.com[2] - 0.119).abs() <= 2.0 * e.com_std[2],
            "{what}: CoM z {:.4} ± {:.4} m is not within 2σ of 0.119 m",
            e.com[2],
            e.com_std[2]
        );
    }
}
