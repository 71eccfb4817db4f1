//! CSV logs: a header line naming the columns, then one row per sample. Read by name, so both
//! layouts replay:
//!
//! - the real LWR 4+ recordings (`data/real-lwr4/`): `t, q1..q7, qd1..qd7, qdd1..qdd7,
//!   tau1..tau7`;
//! - the service's `record --kind log`: `cycle, time_s, flags, q1..q7, qd1..qd7, tau1..tau7,
//!   g1..g7, tau_ext1..tau_ext7, r1..r7` (the columns not named here are ignored).
//!
//! Required: one time column (`t` or `time_s`, s), `q1..q7` (rad), `tau1..tau7` (Nm, measured);
//! optional, all seven or none: `qd1..qd7` (rad/s), `qdd1..qdd7` (rad/s²).

use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use super::error::{Column, Location, ReplayError};
use super::log::{LogLimits, Quantity, RecordedLog, Row, check_value, joint_names};
use crate::joints::{JOINTS, JointVector};

/// Longest line read, bytes.
pub const MAX_LINE_BYTES: usize = 64 * 1024;
/// Most columns in a header.
pub const MAX_COLUMNS: usize = 1024;

/// Where each quantity sits in a row (0-based field indices).
struct Layout {
    fields: usize,
    time: usize,
    q: [usize; JOINTS],
    tau: [usize; JOINTS],
    qd: Option<[usize; JOINTS]>,
    qdd: Option<[usize; JOINTS]>,
    names: Vec<String>,
}

/// Reads a CSV log from `input` (at most `limits.max_bytes`, already checked by the caller).
pub(super) fn read(
    path: &Path,
    input: impl Read,
    limits: &LogLimits,
) -> Result<RecordedLog, ReplayError> {
    let mut reader = BufReader::new(input);
    let mut line = Vec::new();
    let mut number = 0;
    let header = match next_line(path, &mut reader, &mut line, &mut number)? {
        Some(text) => layout(path, text)?,
        None => {
            return Err(format_error(
                path,
                "the file is empty; a CSV log starts with a header line",
            ));
        }
    };
    let mut log = RecordedLog::empty();
    let time = column(&header, header.time);
    while let Some(text) = next_line(path, &mut reader, &mut line, &mut number)? {
        let at = Location::Line(number);
        let fields: Vec<&str> = text.split(',').map(str::trim).collect();
        if fields.len() != header.fields {
            return Err(ReplayError::Invalid {
                path: path.into(),
                at,
                column: None,
                problem: format!("{} fields, the header has {}", fields.len(), header.fields),
            });
        }
        let value = |index: usize, what: Quantity| -> Result<f64, ReplayError> {
            let invalid = |problem| ReplayError::Invalid {
                path: path.into(),
                at,
                column: Some(column(&header, index)),
                problem,
            };
            let raw = fields[index];
            let v: f64 = raw
                .parse()
                .map_err(|_| invalid(format!("`{}` is not a number", shorten(raw))))?;
            check_value(what, v).map_err(invalid)
        };
        let joints = |idx: &[usize; JOINTS], what: fn(usize) -> Quantity| {
            let mut v = JointVector::zeros();
            for (j, &i) in idx.iter().enumerate() {
                v[j] = value(i, what(j))?;
            }
            Ok::<_, ReplayError>(v)
        };
        let row = Row {
            t: value(header.time, Quantity::Time)?,
            q: joints(&header.q, Quantity::Position)?,
            tau: joints(&header.tau, Quantity::Torque)?,
            qd: header
                .qd
                .as_ref()
                .map(|idx| joints(idx, Quantity::Velocity))
                .transpose()?,
            qdd: header
                .qdd
                .as_ref()
                .map(|idx| joints(idx, Quantity::Acceleration))
                .transpose()?,
        };
        log.push(path, limits, at, &time, row)?;
    }
    log.finish(path)
}

/// The next line as text (without `\r\n`), numbering it; None at the end of the input.
fn next_line<'a>(
    path: &Path,
    reader: &mut impl BufRead,
    line: &'a mut Vec<u8>,
    number: &mut usize,
) -> Result<Option<&'a str>, ReplayError> {
    line.clear();
    let read = reader
        .by_ref()
        .take(MAX_LINE_BYTES as u64 + 1)
        .read_until(b'\n', line)
        .map_err(|source| ReplayError::Read {
            path: path.into(),
            source,
        })?;
    if read == 0 {
        return Ok(None);
    }
    *number += 1;
    let invalid = |problem: String| ReplayError::Invalid {
        path: path.into(),
        at: Location::Line(*number),
        column: None,
        problem,
    };
    if line.len() > MAX_LINE_BYTES {
        return Err(invalid(format!("longer than {MAX_LINE_BYTES} bytes")));
    }
    while line.last().is_some_and(|b| *b == b'\n' || *b == b'\r') {
        line.pop();
    }
    let text = std::str::from_utf8(line).map_err(|e| invalid(format!("not UTF-8 text: {e}")))?;
    if text.trim().is_empty() {
        return Err(invalid("empty line".into()));
    }
    Ok(Some(text))
}

/// Finds the columns of a header line.
fn layout(path: &Path, text: &str) -> Result<Layout, ReplayError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let names: Vec<String> = text.split(',').map(|n| n.trim().to_owned()).collect();
    let at_header = |column: Option<Column>, problem: String| ReplayError::Invalid {
        path: path.into(),
        at: Location::Line(1),
        column,
        problem,
    };
    if names.len() > MAX_COLUMNS {
        return Err(at_header(
            None,
            format!("{} columns, at most {MAX_COLUMNS}", names.len()),
        ));
    }
    for (i, name) in names.iter().enumerate() {
        if names[..i].contains(name) {
            let c = Column {
                number: i + 1,
                name: shorten(name),
            };
            return Err(at_header(Some(c), "the name appears twice".into()));
        }
    }
    let find = |name: &str| names.iter().position(|n| n == name);
    let needs = "a log needs a time column (`t` or `time_s`), q1..q7 and tau1..tau7 \
                 (qd1..qd7 and qdd1..qdd7 optional, all seven or none)";
    let time = match (find("t"), find("time_s")) {
        (Some(i), None) | (None, Some(i)) => i,
        (Some(_), Some(_)) => {
            return Err(at_header(None, format!("both `t` and `time_s`; {needs}")));
        }
        (None, None) => return Err(at_header(None, format!("no time column; {needs}"))),
    };
    let group = |prefix: &str, required: bool| -> Result<Option<[usize; JOINTS]>, ReplayError> {
        let wanted = joint_names(prefix);
        let found: Vec<Option<usize>> = wanted.iter().map(|n| find(n)).collect();
        if found.iter().all(Option::is_none) && !required {
            return Ok(None);
        }
        let mut idx = [0; JOINTS];
        for (j, f) in found.iter().enumerate() {
            idx[j] =
                f.ok_or_else(|| at_header(None, format!("no column `{}`; {needs}", wanted[j])))?;
        }
        Ok(Some(idx))
    };
    let (Some(q), Some(tau)) = (group("q", true)?, group("tau", true)?) else {
        return Err(at_header(None, needs.into()));
    };
    Ok(Layout {
        fields: names.len(),
        time,
        q,
        tau,
        qd: group("qd", false)?,
        qdd: group("qdd", false)?,
        names,
    })
}

fn column(layout: &Layout, index: usize) -> Column {
    Column {
        number: index + 1,
        name: shorten(&layout.names[index]),
    }
}

/// A value as an error quotes it: at most 40 characters.
fn shorten(raw: &str) -> String {
    match raw.char_indices().nth(40) {
        Some((cut, _)) => format!("{}…", &raw[..cut]),
        None => raw.to_owned(),
    }
}

fn format_error(path: &Path, problem: &str) -> ReplayError {
    ReplayError::Format {
        path: path.into(),
        problem: problem.into(),
    }
}
