//! Human-readable output of `fri-ctl` operator results (`--json` prints the raw result instead).

use std::io::{self, Write};

use serde_json::Value;

use crate::operator::protocol::Command;

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
    if let Some(f) = r["fri"].as_object() {
        writeln!(
            out,
            "fri            state {} quality {} krl {} (last drop: {})",
            f["state"], f["quality"], f["krl_status"], f["drop_reason"]
        )?;
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
    match r["payload"].as_object() {
        Some(p) => writeln!(
            out,
            "payload        {} kg at ({}) m, frame 7",
            p["mass"],
            vec_str(&p["com"], 4)
        )?,
        None => writeln!(out, "payload        none")?,
    }
    writeln!(
        out,
        "monitor        armed {} thresholds [{}] Nm",
        r["monitor"]["armed"],
        vec_str(&r["monitor"]["thresholds"], 1)
    )
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
