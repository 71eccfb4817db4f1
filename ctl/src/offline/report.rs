//! Human-readable reports: units, frames and 1σ uncertainties on every number.

use std::fmt::Write as _;

use estimator::estimate::{Correction, Method, PayloadEstimate};
use estimator::poses::Prediction;
use fri_api::results::LinkForce;

/// Millimetres with sign; "n/a" for a component the data cannot determine (NaN).
fn mm(v: f64) -> String {
    if v.is_nan() {
        format!("{:>8}", "n/a")
    } else {
        format!("{:+8.2}", v * 1000.0)
    }
}

fn mm_std(v: f64) -> String {
    if v.is_nan() {
        format!("{:>8}", "n/a")
    } else {
        format!("{:8.2}", v * 1000.0)
    }
}

/// Two report lines: a CoM in mm after `label` (which carries its own column padding) and its
/// 1σ below; NaN components (not identifiable) show as n/a.
fn com_rows(s: &mut String, label: &str, com: &[f64; 3], std: &[f64; 3]) {
    let _ = writeln!(
        s,
        "  {label} [mm]  x {}  y {}  z {}",
        mm(com[0]),
        mm(com[1]),
        mm(com[2])
    );
    let _ = writeln!(
        s,
        "                             ± 1σ [mm]    {}    {}    {}",
        mm_std(std[0]),
        mm_std(std[1]),
        mm_std(std[2])
    );
}

/// Report of a static estimate.
pub fn payload(e: &PayloadEstimate, last_frame: usize) -> String {
    let mut s = String::new();
    let method = match e.method {
        Method::Direct => "direct least squares on the payload gravity regressor",
        Method::Coefficients => "paper's coefficient route (eqs. 26-28)",
    };
    let correction = match e.correction {
        Correction::None => "none (one-shot tau_J - g_ctrl; includes the controller's model error)",
        Correction::Tare => "tare (unloaded samples at the same poses subtracted)",
        Correction::Calibration => "calibration (stored controller model error removed)",
    };
    let _ = writeln!(s, "Payload estimate");
    let _ = writeln!(s, "  method       {method}");
    let _ = writeln!(s, "  correction   {correction}");
    let _ = writeln!(
        s,
        "  mass         {:.4} kg  ± {:.4} kg (1σ, {:.2} %)",
        e.mass,
        e.mass_std,
        100.0 * e.mass_std / e.mass
    );
    com_rows(
        &mut s,
        &format!("CoM, frame {last_frame} (last DH frame)  "),
        &e.com,
        &e.com_std,
    );
    com_rows(
        &mut s,
        "CoM, flange frame          ",
        &e.com_flange,
        &e.com_flange_std,
    );
    let _ = writeln!(
        s,
        "  first moment m·c, frame {last_frame} [kg·m]  {:+.5} {:+.5} {:+.5}  (± {:.5} {:.5} {:.5})",
        e.first_moment[0],
        e.first_moment[1],
        e.first_moment[2],
        e.first_moment_std[0],
        e.first_moment_std[1],
        e.first_moment_std[2]
    );
    let joints: Vec<String> = e.joints_used.iter().map(|j| j.to_string()).collect();
    let _ = writeln!(
        s,
        "  fit          {} samples, joints {} used, condition number {:.1}, residual σ {:.4} Nm",
        e.samples,
        joints.join(","),
        e.condition_number,
        e.residual_std
    );
    let rms: Vec<String> = e
        .residual_rms
        .iter()
        .enumerate()
        .map(|(j, r)| format!("J{} {:.3}", j + 1, r))
        .collect();
    let _ = writeln!(s, "  residual RMS per joint [Nm]  {}", rms.join("  "));
    let _ = writeln!(
        s,
        "  (1σ from the residual variance: sensor noise and any model error the residuals show;"
    );
    let _ = writeln!(
        s,
        "   a model error aliased with the payload is invisible here — use --tare or --calibration)"
    );
    s
}

/// Report of a pose-design prediction.
pub fn prediction(p: &Prediction, sigma: f64) -> String {
    let c: Vec<String> = p
        .com_std
        .iter()
        .zip(["x", "y", "z"])
        .map(|(v, ax)| {
            if v.is_nan() {
                format!("{ax} n/a")
            } else {
                format!("{ax} {:.2}", v * 1000.0)
            }
        })
        .collect();
    format!(
        "Predicted 1σ (torque noise {sigma} Nm per joint, no model error): mass {:.4} kg, CoM [mm] {}, condition number {:.1}\n",
        p.mass_std,
        c.join(" "),
        p.condition_number
    )
}

/// The uncertainty by source (mass in g, CoM in mm) and the drift figures, as text.
pub fn uncertainty(u: &estimator::error_model::Uncertainty) -> String {
    use std::fmt::Write as _;
    let mut s = String::from("1σ by source (each alone; variances add):\n");
    for part in &u.sources {
        let _ = writeln!(
            s,
            "  {:<16} mass {:>8.3} g   com [mm] {:>7.3} {:>7.3} {:>7.3}",
            format!("{:?}", part.source).to_lowercase(),
            part.mass_std * 1e3,
            part.com_std[0] * 1e3,
            part.com_std[1] * 1e3,
            part.com_std[2] * 1e3
        );
    }
    let measured = u.drift_rate_measured.map_or_else(
        || "none measured".to_owned(),
        |m| format!("{:.2} mNm/√s measured", m * 1e3),
    );
    let _ = writeln!(
        s,
        "drift {:.2} mNm/√s used ({measured}, {} increments); scatter ratio {:.2} over {} dof",
        u.drift_rate * 1e3,
        u.drift_increments,
        u.scatter_ratio,
        u.dof
    );
    s
}

/// One row of a per-joint (or per-link) table: label, unit, values.
pub(crate) fn table_row(
    s: &mut String,
    label: &str,
    unit: &str,
    v: impl Iterator<Item = f64>,
    digits: usize,
) {
    let cells: Vec<String> = v.map(|x| format!("{x:>8.digits$}")).collect();
    let _ = writeln!(s, "  {label:<22} {unit:<5}{}", cells.join(""));
}

/// One row of minimum detectable forces per link, N (medians).
pub(crate) fn force_rows(s: &mut String, label: &str, f: &[LinkForce; 7]) {
    table_row(s, label, "N", f.iter().map(|l| l.median), 1);
}
