//! Damaged outside input (coefficient-set files) gives a
//! typed error that names the cause, never a panic, an abort or an absurd allocation.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use estimator::EstimatorError;
use estimator::coefficients::CoefficientSet;

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
