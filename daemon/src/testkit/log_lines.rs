//! Reading a binary's `tracing` output as the tests of its log filter need it: the lines without
//! terminal colours, and each line's level and target.

/// The log's non-empty lines with the terminal colour sequences (CSI) removed.
pub fn log_lines(text: &str) -> Vec<String> {
    let mut out = String::with_capacity(text.len());
    let mut chars = text.chars();
    while let Some(c) = chars.next() {
        if c == '\u{1b}' {
            // CSI: ESC [ parameters final-letter
            for d in chars.by_ref() {
                if d.is_ascii_alphabetic() {
                    break;
                }
            }
        } else {
            out.push(c);
        }
    }
    out.lines()
        .filter(|l| !l.trim().is_empty())
        .map(str::to_owned)
        .collect()
}

/// A `tracing` line's level and target (`2026-… INFO fri_service::x: …`); `None` for a line
/// that does not start with a time stamp (not from the logger).
pub fn level_and_target(line: &str) -> Option<(String, String)> {
    let mut words = line.split_whitespace();
    let stamp = words.next()?;
    if !stamp.starts_with(|c: char| c.is_ascii_digit()) {
        return None;
    }
    let level = words.next()?.to_owned();
    let target = words.next()?.trim_end_matches(':').to_owned();
    Some((level, target))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_are_removed_and_level_and_target_read() {
        let lines = log_lines(
            "\u{1b}[2m2026-12-06T20:00:00Z\u{1b}[0m \u{1b}[32m INFO\u{1b}[0m \u{1b}[2mrustdds::x\u{1b}[0m\u{1b}[2m:\u{1b}[0m hello\n\nplain text\n",
        );
        assert_eq!(lines.len(), 2);
        assert_eq!(
            level_and_target(&lines[0]),
            Some(("INFO".to_owned(), "rustdds::x".to_owned()))
        );
        assert_eq!(level_and_target(&lines[1]), None);
    }
}
