//! Fitting a real arm's unexplained torque to its recordings, and driving the simulated arm
//! along a recording to compare the two.
//!
//! Two runs of the same trajectory split the identified arm's residual in two: what repeats
//! (the same at the same point of the path: a function of the state the model misses) and what
//! does not. Run 2 is aligned to run 1 in time (the shift that best matches the angles), and
//! d = r₁(t) − r₂(t + shift) of the two residuals holds only the non-repeating part, twice:
//! σ_n = std(d)/√2, τ_n its correlation time. The identified file's held-out residual (σ, τ)
//! holds both, so σ_r² = σ² − σ_n² (the level on paths the fit has not seen). Integrated
//! correlation times of independent parts add weighted by variance, so run 2's residual
//! (σ₂, τ₂: over the whole run, where the held-out blocks of 5 s cut the correlation short)
//! gives τ_r = (σ₂²τ₂ − σ_n²τ_n)/(σ₂² − σ_n²). Along a path of RMS joint speed v the
//! repeatable function's correlation time is ℓ·√(π/2)/v, which sets its length scale ℓ.

use dynamics::{Data, rnea};
use estimator::model_error::correlation_time;

use super::{RealArm, SensedArmTerms, UnexplainedSpec};
use crate::config::SensorSpec;
use crate::joints::{JOINTS, JointVector};
use crate::replay::RecordedLog;
use crate::sensors::TorqueSensors;

/// The alignment's search range, ± s, its coarse step and its fine step, s.
const SHIFT_RANGE_S: f64 = 0.2;
const SHIFT_COARSE_S: f64 = 0.005;
const SHIFT_FINE_S: f64 = 0.0005;
/// Time left out at both ends of run 1 when comparing (the shift must stay inside run 2), s.
const EDGE_S: f64 = 0.5;

/// The shift (s) that best aligns `run2` to `run1`: the smallest sum over joints of the RMS
/// angle difference q₁(t) − q₂(t + shift), searched on a coarse grid, then finely around its
/// best point.
pub fn align(run1: &RecordedLog, run2: &RecordedLog) -> f64 {
    let times = interior(run1);
    let cost = |shift: f64| {
        let (mut c1, mut c2) = (0, 0);
        let mut sq = JointVector::zeros();
        for &t in times.iter().step_by(4) {
            let d = run1.sample(t, &mut c1).q - run2.sample(t + shift, &mut c2).q;
            sq += d.component_mul(&d);
        }
        sq.iter().map(|s| s.sqrt()).sum::<f64>()
    };
    let best_of = |centre: f64, range: f64, step: f64| {
        let steps = (range / step).round() as i64;
        (-steps..=steps)
            .map(|k| centre + k as f64 * step)
            .map(|shift| (cost(shift), shift))
            .fold(
                (f64::INFINITY, centre),
                |a, b| if b.0 < a.0 { b } else { a },
            )
            .1
    };
    let coarse = best_of(0.0, SHIFT_RANGE_S, SHIFT_COARSE_S);
    best_of(coarse, SHIFT_COARSE_S, SHIFT_FINE_S)
}

/// Run 1's stamps (s after its first) at least [`EDGE_S`] from both ends.
fn interior(log: &RecordedLog) -> Vec<f64> {
    let t0 = log.start_s();
    let end = log.duration_s() - EDGE_S;
    log.stamps()
        .iter()
        .map(|t| t - t0)
        .filter(|t| *t >= EDGE_S && *t <= end)
        .collect()
}

/// The unexplained torque of `arm` from two runs of the same trajectory (see the module doc).
pub fn fit_unexplained(arm: &RealArm, run1: &RecordedLog, run2: &RecordedLog) -> UnexplainedSpec {
    let id = &arm.identified;
    let mut data = Data::new(id.corrected_model());
    let shift = align(run1, run2);
    let times = interior(run1);
    let (mut c1, mut c2) = (0, 0);
    let mut diff: Vec<JointVector> = Vec::with_capacity(times.len());
    let mut second: Vec<JointVector> = Vec::with_capacity(times.len());
    let mut speed_sq = 0.0;
    for &t in &times {
        let a = run1.sample(t, &mut c1);
        let b = run2.sample(t + shift, &mut c2);
        let ra = a.tau - id.predict(&mut data, &a.q, &a.qd, &a.qdd);
        let rb = b.tau - id.predict(&mut data, &b.q, &b.qd, &b.qdd);
        diff.push(ra - rb);
        second.push(rb);
        speed_sq += a.qd.norm_squared();
    }
    let n = diff.len().max(1) as f64;
    let speed = (speed_sq / n).sqrt();
    let (sigma, _) = id.model_error();
    let mut spec = UnexplainedSpec {
        repeatable_sigma_nm: [0.0; JOINTS],
        repeatable_length_rad: [0.0; JOINTS],
        random_sigma_nm: [0.0; JOINTS],
        random_correlation_s: [0.0; JOINTS],
    };
    for j in 0..JOINTS {
        let d: Vec<f64> = diff.iter().map(|v| v[j]).collect();
        let mean = d.iter().sum::<f64>() / n;
        let centred: Vec<f64> = d.iter().map(|x| x - mean).collect();
        let var_d = centred.iter().map(|x| x * x).sum::<f64>() / n;
        let sigma_n = (var_d / 2.0).sqrt().min(sigma[j]);
        let tau_n = correlation_time(&times, &centred, &[0]);
        let var_r = (sigma[j].powi(2) - sigma_n.powi(2)).max(0.0);
        let r2: Vec<f64> = second.iter().map(|v| v[j]).collect();
        let mean2 = r2.iter().sum::<f64>() / n;
        let r2: Vec<f64> = r2.iter().map(|x| x - mean2).collect();
        let var_2 = r2.iter().map(|x| x * x).sum::<f64>() / n;
        let tau_2 = correlation_time(&times, &r2, &[0]);
        let tau_r = if var_2 > sigma_n.powi(2) {
            ((var_2 * tau_2 - sigma_n.powi(2) * tau_n) / (var_2 - sigma_n.powi(2))).max(0.01)
        } else {
            tau_2
        };
        spec.random_sigma_nm[j] = sigma_n;
        spec.random_correlation_s[j] = tau_n;
        spec.repeatable_sigma_nm[j] = var_r.sqrt();
        spec.repeatable_length_rad[j] =
            (tau_r * speed / (std::f64::consts::PI / 2.0).sqrt()).clamp(1e-3, 10.0);
    }
    spec
}

/// The torques the simulated arm's sensors read when it follows `log`'s trajectory (its own
/// angles, velocities and accelerations, at the rows' stamps, s after the first), the noise
/// advanced at `period_s`: τ_J of the true (identified) model, the arm's sensed terms, and the
/// `[sensors]` model on top.
pub fn drive_along(
    arm: &RealArm,
    sensors: &SensorSpec,
    log: &RecordedLog,
    period_s: f64,
    seed: u64,
) -> Vec<(f64, JointVector)> {
    let model = arm.model();
    let mut data = Data::new(&model);
    let mut terms = SensedArmTerms::new(arm, seed);
    let mut sensor = TorqueSensors::new(sensors, seed ^ 0x5e75);
    let t0 = log.start_s();
    let (mut cursor, mut clock) = (0, 0.0);
    let mut out = Vec::with_capacity(log.rows());
    for &stamp in log.stamps() {
        let t = stamp - t0;
        while clock + period_s <= t {
            terms.advance(period_s);
            sensor.advance(period_s);
            clock += period_s;
        }
        let s = log.sample(t, &mut cursor);
        let tau_j = rnea(&model, &mut data, &s.q, &s.qd, &s.qdd);
        out.push((t, sensor.read(&(tau_j + terms.torque(&s.q, &s.qd)))));
    }
    out
}
