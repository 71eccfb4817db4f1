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
