//! Human-readable output of `fri-ctl` operator results (`--json` prints the raw result instead).

use std::io::{self, Write};

use serde_json::Value;

use fri_api::protocol::Command;

fn vec_str(v: &Value, digits: usize) -> String {
    match v.as_array() {
        Some(a) => a
            .iter()
            .map(|x| {
                x.as_f64()
                    .map_or("-".to_owned(), |f| format!("{f:+.digits$}"))
            })
            .collect::<Vec<_>>()
            .join(" "),
        None => "-".to_owned(),
    }
}

/// Writes the human-readable form of `command`'s result `r`.
pub(super) fn print(command: &Command, r: &Value, out: &mut dyn Write) -> io::Result<()> {
    match command {
        Command::Status => status(r, out),
        Command::EstimatePayload { .. } => estimate(r, out),
        Command::Record { .. } => {
            let path = r["path"].as_str().unwrap_or("?");
            writeln!(out, "recorded {} rows to {path}", r["rows"])?;
            if r["lost"].as_u64().is_some_and(|n| n > 0) {
                writeln!(out, "({} cycles lost: the recorder fell behind)", r["lost"])?;
            }
            Ok(())
        }
        _ => writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(r).unwrap_or_default()
        ),
    }
}

fn status(r: &Value, out: &mut dyn Write) -> io::Result<()> {
    writeln!(out, "connected      {}", r["connected"])?;
    // Index the Value, not the Map: a missing key must print `null`, not panic.
    let f = &r["fri"];
    if f.is_object() {
        writeln!(
            out,
            "fri            state {} quality {} krl {} (last drop: {})",
            f["state"], f["quality"], f["krl_status"], f["drop_reason"]
        )?;
        rejections(&f["statistics"]["rejections"], out)?;
    }
    writeln!(out, "cycle          {}  t = {} s", r["cycle"], r["time_s"])?;
    writeln!(out, "q        rad   {}", vec_str(&r["q"], 4))?;
    writeln!(out, "tau_J    Nm    {}", vec_str(&r["tau"], 3))?;
    writeln!(out, "gravity  Nm    {}", vec_str(&r["gravity"], 3))?;
    writeln!(out, "tau_ext  Nm    {}", vec_str(&r["tau_ext"], 3))?;
    writeln!(out, "residual Nm    {}", vec_str(&r["residual"], 3))?;
    writeln!(
        out,
        "flags          command_mode {} moving {} stopped {} collision {} observer_fault {}",
        r["command_mode"], r["moving"], r["stopped"], r["collision"], r["observer_fault"]
    )?;
    let p = &r["payload"];
    if p.is_object() {
        writeln!(
            out,
            "payload        {} kg at ({}) m, frame 7",
            p["mass"],
            vec_str(&p["com"], 4)
        )?;
    } else {
        writeln!(out, "payload        none")?;
    }
    writeln!(
        out,
        "monitor        armed {} thresholds [{}] Nm",
        r["monitor"]["armed"],
        vec_str(&r["monitor"]["thresholds"], 1)
    )
}

/// The session's rejected datagrams by reason (`fri::session::RejectionCounters`), non-zero
/// ones only, largest first.
fn rejections(counters: &Value, out: &mut dyn Write) -> io::Result<()> {
    let Some(map) = counters.as_object() else {
        return Ok(());
    };
    let mut nonzero: Vec<(&str, u64)> = map
        .iter()
        .filter_map(|(k, v)| v.as_u64().filter(|n| *n > 0).map(|n| (k.as_str(), n)))
        .collect();
    if nonzero.is_empty() {
        return writeln!(out, "rejected       none");
    }
    nonzero.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(b.0)));
    let total = nonzero.iter().fold(0u64, |t, (_, n)| t.saturating_add(*n));
    let list: Vec<String> = nonzero.iter().map(|(k, n)| format!("{k} {n}")).collect();
    writeln!(out, "rejected       {total} datagrams: {}", list.join(", "))
}

fn estimate(r: &Value, out: &mut dyn Write) -> io::Result<()> {
    let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
    let c = |k: &str, i: usize| r[k][i].as_f64().unwrap_or(f64::NAN);
    writeln!(
        out,
        "mass  {:.4} ± {:.4} kg   ({} samples, tare {}, condition {:.1})",
        f("mass"),
        f("mass_std"),
        r["samples"],
        r["tare_used"],
        f("condition_number")
    )?;
    writeln!(
        out,
        "com   ({:+.4} ± {:.4}, {:+.4} ± {:.4}, {:+.4} ± {:.4}) m in frame 7",
        c("com", 0),
        c("com_std", 0),
        c("com", 1),
        c("com_std", 1),
        c("com", 2),
        c("com_std", 2)
    )?;
    writeln!(
        out,
        "com   ({:+.4}, {:+.4}, {:+.4}) m in the flange frame",
        c("com_flange", 0),
        c("com_flange", 1),
        c("com_flange", 2)
    )?;
    let applied = if r["applied"] == true {
        "applied to the collision observer"
    } else {
        "not applied (use --apply or `fri-ctl apply-payload`)"
    };
    writeln!(out, "{applied}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn status_text(r: &Value) -> String {
        let mut out = Vec::new();
        print(&Command::Status, r, &mut out).unwrap();
        String::from_utf8(out).unwrap()
    }

    fn with_rejections(rejections: Value) -> Value {
        json!({
            "connected": true,
            "fri": {"state": "Monitor", "quality": "Perfect", "statistics": {"rejections": rejections}},
            "monitor": {"armed": true},
        })
    }

    #[test]
    fn status_shows_the_non_zero_rejection_counters() {
        let text = status_text(&with_rejections(json!({
            "empty": 0, "truncated": 2, "unexpected_source": 40, "duplicate": 0,
        })));
        let line = text
            .lines()
            .find(|l| l.starts_with("rejected"))
            .unwrap_or_else(|| panic!("no rejection line in\n{text}"));
        assert!(line.contains("42 datagrams"), "{line}");
        assert!(
            line.contains("unexpected_source 40") && line.contains("truncated 2"),
            "{line}"
        );
        assert!(
            !line.contains("duplicate") && !line.contains("empty"),
            "{line}"
        );
    }

    #[test]
    fn status_says_none_rejected() {
        let text = status_text(&with_rejections(json!({"truncated": 0})));
        assert!(text.contains("rejected       none"), "{text}");
    }
}
