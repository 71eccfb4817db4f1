//! Randomly damaged robot files never panic the loaders: they load or return a typed error.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::Model;
use proptest::prelude::*;

const LWR_TOML: &str = include_str!("../robots/lwr4.toml");
const LWR_URDF: &str = include_str!("../robots/lwr4.urdf");

/// Applies `edits` (position fraction, replacement) to `text`: each replaces one character.
fn damage(text: &str, edits: &[(f64, char)], truncate: Option<f64>) -> String {
    let mut chars: Vec<char> = text.chars().collect();
    for (at, c) in edits {
        let index = ((chars.len() as f64) * at) as usize;
        if index < chars.len() {
            chars[index] = *c;
        }
    }
    if let Some(fraction) = truncate {
        chars.truncate((chars.len() as f64 * fraction) as usize);
    }
    chars.into_iter().collect()
}

fn edit_strategy() -> impl Strategy<Value = Vec<(f64, char)>> {
    proptest::collection::vec(
        (
            0.0f64..1.0,
            prop_oneof![
                Just('-'),
                Just('"'),
                Just('='),
                Just('['),
                Just('<'),
                Just('9'),
                Just('e'),
                Just(' '),
                any::<char>()
            ],
        ),
        1..6,
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn damaged_toml_never_panics(edits in edit_strategy(), truncate in proptest::option::of(0.0f64..1.0)) {
        let text = damage(LWR_TOML, &edits, truncate);
        let _ = Model::<7>::from_toml_str(&text);
        let _ = Model::<6>::from_toml_str(&text);
    }

    #[test]
    fn damaged_urdf_never_panics(edits in edit_strategy(), truncate in proptest::option::of(0.0f64..1.0)) {
        let text = damage(LWR_URDF, &edits, truncate);
        let _ = Model::<7>::from_urdf_str(&text);
    }
}
