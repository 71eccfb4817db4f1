//! Comma-separated number lists of the command line (`--around -0.1,0.5,…`): clap splits them
//! (`allow_hyphen_values` lets a list start with a minus), this counts them.

/// `values` as exactly `N` numbers, or the usage error naming `--name`.
pub(crate) fn exactly<const N: usize>(name: &str, values: &[f64]) -> Result<[f64; N], String> {
    <[f64; N]>::try_from(values).map_err(|_| {
        format!(
            "--{name} needs {N} comma-separated values, got {}",
            values.len()
        )
    })
}

/// [`exactly`] for an optional list.
pub(crate) fn optional<const N: usize>(
    name: &str,
    values: &Option<Vec<f64>>,
) -> Result<Option<[f64; N]>, String> {
    values.as_deref().map(|v| exactly(name, v)).transpose()
}

/// A per-joint list: one value (for every joint) or exactly `N`, or the usage error naming
/// `--name`.
pub(crate) fn per_joint<const N: usize>(name: &str, values: &[f64]) -> Result<[f64; N], String> {
    match values {
        [one] => Ok([*one; N]),
        _ => <[f64; N]>::try_from(values).map_err(|_| {
            format!(
                "--{name} needs one value for every joint or {N} comma-separated values, got {}",
                values.len()
            )
        }),
    }
}

/// [`per_joint`] for an optional list.
pub(crate) fn optional_per_joint<const N: usize>(
    name: &str,
    values: &Option<Vec<f64>>,
) -> Result<Option<[f64; N]>, String> {
    values.as_deref().map(|v| per_joint(name, v)).transpose()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_per_joint_list_takes_one_value_for_all_or_one_per_joint() {
        assert_eq!(per_joint::<7>("thresholds", &[4.0]), Ok([4.0; 7]));
        let seven = [9.0, 9.0, 6.0, 6.0, 4.0, 2.0, 2.0];
        assert_eq!(per_joint::<7>("thresholds", &seven), Ok(seven));
        let e = per_joint::<7>("thresholds", &[1.0, 2.0]).unwrap_err();
        assert_eq!(
            e,
            "--thresholds needs one value for every joint or 7 comma-separated values, got 2"
        );
        assert_eq!(optional_per_joint::<7>("gains", &None), Ok(None));
    }
}
