//! Number and table formatting of the human-readable output: units on every value, floats
//! rounded to the precision that matters near a moving arm, flags as words.

use std::io::{self, Write};

/// Width of one joint column.
const COL: usize = 9;

/// Header of a joint table: label column, then `j1 … j7`.
pub(crate) fn joint_header(out: &mut dyn Write) -> io::Result<()> {
    let mut line = format!("{:<16}", "");
    for j in 1..=7 {
        line.push_str(&format!("{:>COL$}", format!("j{j}")));
    }
    writeln!(out, "{}", line.trim_end())
}

/// One joint-table row: `label` with its `unit`, seven values with `digits` decimals
/// (`n/a` for NaN).
pub(crate) fn joint_row(
    out: &mut dyn Write,
    label: &str,
    unit: &str,
    values: &[f64; 7],
    digits: usize,
) -> io::Result<()> {
    let mut line = format!("{:<16}", format!("{label} [{unit}]"));
    for v in values {
        line.push_str(&format!("{:>COL$}", fixed(*v, digits)));
    }
    writeln!(out, "{line}")
}

/// A joint-table row of angles given in rad, shown in degrees.
pub(crate) fn joint_row_deg(
    out: &mut dyn Write,
    label: &str,
    rad: &[f64; 7],
    digits: usize,
) -> io::Result<()> {
    joint_row(out, label, "deg", &rad.map(f64::to_degrees), digits)
}

/// `v` with `digits` decimals and a sign; `n/a` for NaN, `∞` for infinities.
pub(crate) fn fixed(v: f64, digits: usize) -> String {
    if v.is_nan() {
        "n/a".to_owned()
    } else if v.is_infinite() {
        if v > 0.0 { "∞" } else { "-∞" }.to_owned()
    } else {
        // Avoid "-0.00": a value that rounds to zero has no sign.
        let s = format!("{v:.digits$}");
        if s.trim_start_matches('-')
            .chars()
            .all(|c| c == '0' || c == '.')
        {
            s.trim_start_matches('-').to_owned()
        } else {
            s
        }
    }
}

/// `n` and the noun, plural unless `n` is 1 (`count(2, "sample")` is `2 samples`).
pub(crate) fn count(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// A flag as a word.
pub(crate) fn yes_no(flag: bool) -> &'static str {
    if flag { "yes" } else { "no" }
}

/// A metre value in millimetres with `digits` decimals.
pub(crate) fn mm(m: f64, digits: usize) -> String {
    fixed(m * 1000.0, digits)
}

/// Three coordinates in mm: "x +1.00  y -2.00  z +119.00".
pub(crate) fn xyz_mm(v: &[f64; 3], digits: usize) -> String {
    let c = |x: f64| {
        let s = mm(x, digits);
        if x > 0.0 && !s.starts_with('n') {
            format!("+{s}")
        } else {
            s
        }
    };
    format!("x {}  y {}  z {}", c(v[0]), c(v[1]), c(v[2]))
}

/// Three standard deviations in mm, without a sign (a σ has none): "x 0.16  y 0.13  z 0.24".
pub(crate) fn xyz_mm_std(v: &[f64; 3], digits: usize) -> String {
    format!(
        "x {}  y {}  z {}",
        mm(v[0], digits),
        mm(v[1], digits),
        mm(v[2], digits)
    )
}

/// A ratio 0…1 as a percentage with one decimal.
pub(crate) fn percent(ratio: f64) -> String {
    format!("{} %", fixed(ratio * 100.0, 1))
}

/// A time in seconds shown in milliseconds with `digits` decimals.
pub(crate) fn ms(s: f64, digits: usize) -> String {
    format!("{} ms", fixed(s * 1000.0, digits))
}

/// A procedure's robot time by phase, one line: `robot time 14.2 s (moving 9.1, settling 0.9,
/// averaging 5.5)`.
pub(crate) fn timing_line(t: &fri_api::results::ProcedureTiming) -> String {
    format!(
        "robot time     {} s (moving {}, settling {}, averaging {})",
        fixed(t.total_s, 1),
        fixed(t.moving_s, 1),
        fixed(t.settling_s, 1),
        fixed(t.averaging_s, 1)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_keeps_signs_meaningful() {
        assert_eq!(fixed(-0.0001, 2), "0.00");
        assert_eq!(fixed(-1.236, 2), "-1.24");
        assert_eq!(fixed(f64::NAN, 2), "n/a");
        assert_eq!(
            xyz_mm(&[0.001, -0.002, 0.119], 2),
            "x +1.00  y -2.00  z +119.00"
        );
        // A σ has no sign.
        assert_eq!(
            xyz_mm_std(&[0.00016, 0.00013, 0.00024], 2),
            "x 0.16  y 0.13  z 0.24"
        );
    }
}
