//! Damaged outside input (coefficient-set files, motion options from the command line) gives a
//! typed error that names the cause, never a panic, an abort or an absurd allocation.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use estimator::EstimatorError;
use estimator::coefficients::CoefficientSet;
use estimator::motion::{MotionOptions, Trajectory, process};
use nalgebra::SVector;

fn syntax_message(text: &str) -> (usize, String) {
    match CoefficientSet::parse(text) {
        Err(EstimatorError::CoefficientSyntax { line, message }) => (line, message),
        other => panic!("expected a syntax error, got {other:?}"),
    }
}

#[test]
fn absurd_link_count_is_a_syntax_error() {
    // a link count near usize::MAX used to overflow the allocation of the zero link vectors
    for n in [usize::MAX.to_string(), "100000000000".to_string()] {
        let (line, message) = syntax_message(&format!("links {n}\ncoef p1 = m1\n"));
        assert_eq!(line, 1);
        assert!(message.contains("links"), "{message}");
    }
}

#[test]
fn deeply_nested_expression_is_a_syntax_error_not_a_stack_overflow() {
    let depth = 200_000;
    for body in [
        format!("{}m1{}", "(".repeat(depth), ")".repeat(depth)),
        format!("{}m1", "-".repeat(depth)),
        format!("2{}m1", "^2".repeat(depth)),
    ] {
        let (line, message) = syntax_message(&format!("links 1\ncoef p1 = {body}\n"));
        assert_eq!(line, 2);
        assert!(message.contains("nested"), "{message}");
    }
}

#[test]
fn non_finite_numbers_are_syntax_errors() {
    let (line, message) = syntax_message("links 1\nconst a = 1e400\ncoef p1 = a*m1\n");
    assert_eq!(line, 2);
    assert!(message.contains("finite"), "{message}");
    let (line, message) = syntax_message("links 1\ncoef p1 = 1e200*1e200*m1\n");
    assert_eq!(line, 2);
    assert!(message.contains("finite"), "{message}");
}

fn ramp(rows: usize) -> Trajectory<2> {
    let t: Vec<f64> = (0..rows).map(|k| k as f64 * 0.01).collect();
    Trajectory {
        q: t.iter()
            .map(|t| SVector::from([t.sin(), t.cos()]))
            .collect(),
        tau: t.iter().map(|t| SVector::from([*t, -t])).collect(),
        t,
    }
}

#[test]
fn out_of_range_trim_is_an_invalid_setting() {
    let tr = ramp(2000);
    for trim in [f64::INFINITY, f64::NAN, -1.0] {
        let options = MotionOptions {
            trim_s: Some(trim),
            ..MotionOptions::default()
        };
        match process(&tr, &options) {
            Err(EstimatorError::InvalidSetting(m)) => assert!(m.contains("trim"), "{m}"),
            other => panic!("trim {trim}: expected InvalidSetting, got {other:?}"),
        }
    }
    // a trim longer than the log says so in seconds, with what to do (1e30 s used to overflow)
    for trim in [15.0, 1e30] {
        let options = MotionOptions {
            trim_s: Some(trim),
            ..MotionOptions::default()
        };
        match process(&tr, &options) {
            Err(e @ EstimatorError::LogTooShort { duration_s, .. }) => {
                assert!((duration_s - 19.99).abs() < 1e-9, "{e}");
                let text = e.to_string();
                assert!(
                    text.contains("--trim-s") && text.contains("19.990 s"),
                    "{text}"
                );
            }
            other => panic!("trim {trim}: expected LogTooShort, got {other:?}"),
        }
    }
    // and a sensible trim keeps rows - 2·trim/dt samples
    let options = MotionOptions {
        trim_s: Some(1.0),
        ..MotionOptions::default()
    };
    assert_eq!(process(&tr, &options).unwrap().len(), 2000 - 2 * 100);
}

#[test]
fn overflowing_trajectory_derivatives_are_named_as_such() {
    use estimator::motion::{Unloaded, estimate_motion};
    let model = dynamics::lwr4();
    let rows = 3000;
    let t: Vec<f64> = (0..rows).map(|k| k as f64 * 0.01).collect();
    let tr = Trajectory::<7> {
        q: t.iter()
            .map(|t| SVector::from_element(1e200 * (0.3 * t).sin()))
            .collect(),
        tau: t.iter().map(|_| SVector::from_element(1.0)).collect(),
        t,
    };
    let result = estimate_motion(
        &model,
        std::slice::from_ref(&tr),
        Unloaded::Model(&model),
        &[],
        &MotionOptions::default(),
    );
    // used to end in "poses too similar" (RankDeficient), which named the wrong cause
    match result {
        Err(EstimatorError::NotFinite { column, .. }) => {
            assert!(column.contains("overflow"), "{column}")
        }
        other => panic!("expected NotFinite, got {other:?}"),
    }
}
