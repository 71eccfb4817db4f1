//! Whole-number arguments (`--poses`, `--count`, `--state-every`), checked at parse time against
//! the service's own bounds: a negative or out-of-range count gets the message that names the
//! field and the range, not a parser complaint about a stray `-`.

use fri_api::bounds::{POSES, RECORD_COUNT, Range, STATE_EVERY};

/// `s` as a count inside `range`, or the message "`name` = value is outside min…max".
fn within(range: &Range, name: &str, s: &str) -> Result<u64, String> {
    let value: i64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{name} = {s:?} is not a whole number (allowed: {range})"))?;
    // Every bound here is far below 2^53: the conversion to f64 is exact inside the range.
    range.check(name, value as f64).map_err(String::from)?;
    u64::try_from(value).map_err(|_| format!("{name} = {value} is outside {range}"))
}

/// `--poses`: 2…100.
pub(crate) fn poses(s: &str) -> Result<usize, String> {
    within(&POSES, "poses", s).and_then(|n| usize::try_from(n).map_err(|e| e.to_string()))
}

/// `--count` of `record`: 1…1000.
pub(crate) fn record_count(s: &str) -> Result<usize, String> {
    within(&RECORD_COUNT, "count", s).and_then(|n| usize::try_from(n).map_err(|e| e.to_string()))
}

/// `--state-every` of `watch`: 1…100000 cycles.
pub(crate) fn state_every(s: &str) -> Result<u32, String> {
    within(&STATE_EVERY, "state_every", s).and_then(|n| u32::try_from(n).map_err(|e| e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_and_out_of_range_counts_name_the_field_and_the_range() {
        assert_eq!(poses("-3"), Err("poses = -3 is outside 2…100".to_owned()));
        assert_eq!(poses("101"), Err("poses = 101 is outside 2…100".to_owned()));
        assert_eq!(poses("11"), Ok(11));
        assert_eq!(
            record_count("0"),
            Err("count = 0 is outside 1…1000".to_owned())
        );
        assert!(state_every("x").unwrap_err().contains("not a whole number"));
    }
}
