//! Allowed ranges of the numbers that come from outside the process (operator arguments and
//! configuration values) and the messages that name a value outside them.
//!
//! The ranges are physical, not merely "positive and finite": a threshold of 1e300 Nm or a gain
//! of 1e308 1/s passes a positivity check but switches collision detection off while the monitor
//! still reads `armed`, and a pattern centre of 1e300 rad clamps every pose onto the joint limits.
//! Every range is documented in `docs/operator-protocol.md` and
//! `daemon/config/fri-service.example.toml`; keep them in step with the constants here.

use std::fmt;

use dynamics::{LWR4_POSITION_LIMITS_DEG, LWR4_TORQUE_LIMITS_NM, LWR4_VELOCITY_LIMITS_DEG_S};

pub use crate::JOINTS;

/// A closed interval `min…max` of a value in `unit`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// Smallest allowed value, in `unit`.
    pub min: f64,
    /// Largest allowed value, in `unit`.
    pub max: f64,
    /// Unit shown in messages (empty for counts).
    pub unit: &'static str,
}

impl Range {
    /// The interval `min…max` in `unit`.
    pub const fn new(min: f64, max: f64, unit: &'static str) -> Self {
        Self { min, max, unit }
    }

    /// True for a finite value inside the interval (NaN and infinities never are).
    pub fn contains(&self, value: f64) -> bool {
        value.is_finite() && value >= self.min && value <= self.max
    }

    /// `Ok` inside the interval, otherwise the field, its value and this range as data (its text
    /// reads "`name` = value unit is outside min…max unit").
    pub fn check(&self, name: &str, value: f64) -> Result<(), OutOfRange> {
        if self.contains(value) {
            Ok(())
        } else {
            Err(OutOfRange {
                field: name.to_owned(),
                value,
                range: *self,
            })
        }
    }

    /// The same check for an integer (counts, sizes).
    pub fn check_count(&self, name: &str, value: u64) -> Result<(), OutOfRange> {
        // Every count we bound is far below 2^53, so the conversion is exact inside the range.
        self.check(name, value as f64)
    }
}

/// A value outside its allowed range, as data: the field (dotted or indexed name), the value and
/// the range with its unit.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field} = {} is outside {range}", with_unit(*.value, range.unit))]
pub struct OutOfRange {
    /// The field, e.g. `thresholds[6]` or `step_deg`.
    pub field: String,
    /// The rejected value, in the range's unit (NaN and infinities included).
    pub value: f64,
    /// The allowed range.
    pub range: Range,
}

impl From<OutOfRange> for String {
    fn from(e: OutOfRange) -> Self {
        e.to_string()
    }
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let unit = if self.unit.is_empty() {
            String::new()
        } else {
            format!(" {}", self.unit)
        };
        write!(f, "{}…{}{unit}", rounded(self.min), rounded(self.max))
    }
}

/// A range bound with at most 6 significant digits (bounds derived from degrees or products
/// such as 170° in rad or 1.5 rad/s × cycle need no more to be read).
fn rounded(value: f64) -> String {
    if !value.is_finite() || value.fract() == 0.0 {
        return number(value);
    }
    let digits = 5 - value.abs().log10().floor() as i32;
    let scale = 10f64.powi(digits);
    number((value * scale).round() / scale)
}

/// A number as people read it: plain for ordinary magnitudes, exponent form for huge or tiny
/// ones (so 1e300 does not print as 301 digits), NaN and infinities by name.
pub fn number(value: f64) -> String {
    let a = value.abs();
    if !value.is_finite() || a == 0.0 || (1e-4..1e9).contains(&a) {
        // Shortest representation that round-trips, trailing zeros trimmed by Display.
        format!("{value}")
    } else {
        format!("{value:e}")
    }
}

fn with_unit(value: f64, unit: &str) -> String {
    if unit.is_empty() {
        number(value)
    } else {
        format!("{} {unit}", number(value))
    }
}

/// Shortest controller cycle FRI allows, s (`friOpen(1)`).
pub const MIN_CYCLE_S: f64 = 0.001;

/// `fri.cycle_s`: FRI runs at 1 to 100 ms (`friOpen(T)`, shared docs §2.2).
pub const CYCLE_S: Range = Range::new(MIN_CYCLE_S, 0.1, "s");

/// Joint `j`'s position range, rad (the LWR 4+ limits of the dynamics crate).
pub fn joint_position(j: usize) -> Range {
    let limit = LWR4_POSITION_LIMITS_DEG[j.min(JOINTS - 1)].to_radians();
    Range::new(-limit, limit, "rad")
}

/// Smallest detection threshold, Nm: a few times the joint torque sensors' noise (σ 0.02 to
/// 0.05 Nm, lwr4-model.md); below it the monitor trips on noise alone.
pub const MIN_THRESHOLD_NM: f64 = 0.1;

/// Largest detection threshold as a share of the joint's torque limit: above a quarter of its
/// rated torque (44 Nm on joints 1–2, 25 Nm on 3–5, 9.5 Nm on the wrist) a "detected" contact
/// already loads the joint heavily, so a larger value means detection is effectively off.
pub const MAX_THRESHOLD_SHARE: f64 = 0.25;

/// Joint `j`'s detection threshold range, Nm.
pub fn threshold(j: usize) -> Range {
    Range::new(
        MIN_THRESHOLD_NM,
        MAX_THRESHOLD_SHARE * LWR4_TORQUE_LIMITS_NM[j.min(JOINTS - 1)],
        "Nm",
    )
}

/// Joint `j`'s torque range, Nm (± the LWR 4+ torque limit): e.g. an identified arm's offset.
pub fn joint_torque(j: usize) -> Range {
    let limit = LWR4_TORQUE_LIMITS_NM[j.min(JOINTS - 1)];
    Range::new(-limit, limit, "Nm")
}

/// Smallest observer gain K_I, 1/s: a 1 s time constant; slower residuals cannot follow a
/// contact of tens of milliseconds at all.
pub const MIN_GAIN: f64 = 1.0;

/// Largest observer gain × controller cycle, K_I·T (dimensionless). Derivation, per joint the
/// residual update is r_k = a·r_{k−1} + b·u_k (`safety::Discretisation`):
/// - the observer bridges up to two lost packets (`max_dt_factor` 3), so a step can be 3T; the
///   paper's Euler form a = 1 − K·dt is stable only for K·dt < 2, i.e. K·T < 2/3, and at K·T = ½
///   its pole at 3T is −½ (stable, decaying) and at T is +½ (no overshoot);
/// - the exact form's pole e^{−KT} is 0.61 at K·T = ½: the residual still averages a few samples
///   (at K·T = 2 it would be 0.14 and r the raw torque difference of one sample), and its corner
///   K = 500 rad/s at 1 ms stays below a sixth of the Nyquist rate π/T, so the sampled
///   observer behaves like the continuous K/(s + K) (the velocity filter shapes only the
///   momentum input, outside this loop);
/// - Euler and exact forms then differ by (K·T)²/2 ≈ 0.13 of a step, not by half of it (K·T = 1).
///
/// The default 400 1/s (K·T = 0.4 at 1 ms) lies inside; faster detection comes from lower
/// thresholds, not from gains beyond it.
pub const MAX_GAIN_PERIOD_PRODUCT: f64 = 0.5;

/// Observer gain range at controller cycle `cycle_s`, 1/s: [`MIN_GAIN`] to
/// [`MAX_GAIN_PERIOD_PRODUCT`]/T (500 1/s at 1 ms).
pub fn gain(cycle_s: f64) -> Range {
    Range::new(
        MIN_GAIN,
        MAX_GAIN_PERIOD_PRODUCT / cycle_s.max(MIN_CYCLE_S),
        "1/s",
    )
}

/// Pause of the `pause` reaction before the automatic resume, s (the paper: 2 s; a minute is
/// longer than anyone waits beside a stopped arm).
pub const PAUSE_S: Range = Range::new(0.0, 60.0, "s");

/// Applied or estimated payload mass, kg (the LWR 4+ is rated for 7 kg; 20 kg leaves room for
/// short-term overload and a wrong but finite estimate to be applied deliberately).
pub const MASS: Range = Range::new(0.0, 20.0, "kg");

/// Each payload centre-of-mass coordinate in frame 7, m.
pub const COM: Range = Range::new(-1.0, 1.0, "m");

/// Largest mass of a payload declared unknown (`expect-payload`'s `max_mass`,
/// `unknown_payload.max_mass_kg`), kg: up to the LWR 4+'s rated 7 kg. Every gram above the real
/// payload's mass is a downward push on the flange the monitor tolerates before the first
/// static sample, so the bound is the rating, not [`MASS`]'s room for overload.
pub const UNKNOWN_PAYLOAD_MASS: Range = Range::new(0.01, 7.0, "kg");

/// Radius around the flange point that holds a payload declared unknown (`max_radius`,
/// `unknown_payload.max_radius_m`), m: from a part in the gripper's fingers to a metre-long tool.
pub const UNKNOWN_PAYLOAD_RADIUS: Range = Range::new(0.01, 1.0, "m");

/// Grasp window of a payload declared unknown (`unknown_payload.grasp_window_s`), s: the load
/// may change for this long after the declaration, and a flange contact that a plausible load
/// explains goes unseen for as long, so it is bounded: at least long enough for a gripper to
/// close and lift (0.5 s), at most two minutes.
pub const GRASP_WINDOW_S: Range = Range::new(0.5, 120.0, "s");

/// Time a changed load must stay settled to be pinned before the grasp window ends
/// (`unknown_payload.settle_s`), s: longer than the residual's transient (a few ms) and a
/// gripper's ringing, shorter than the window's useful range.
pub const SETTLE_S: Range = Range::new(0.05, 5.0, "s");

/// Time without an estimate after which the unknown-payload mode ends (`unknown_payload.expire_s`),
/// s: long enough for a slow ten-pose estimate between refits, at most an hour.
pub const EXPIRE_S: Range = Range::new(5.0, 3600.0, "s");

/// Pattern increment, degrees: below 1° neighbouring poses are too alike for a well-conditioned
/// estimate; above 30° the pattern leaves the "around the pick pose" regime of the paper.
pub const STEP_DEG: Range = Range::new(1.0, 30.0, "deg");

/// Number of poses of a pattern (2 is the minimum for a solvable estimate; 100 takes minutes).
pub const POSES: Range = Range::new(2.0, 100.0, "");

/// Margin kept between every pose of a pattern and the joint limits, rad (5°).
pub const AROUND_LIMIT_MARGIN_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;

/// `motion.max_around_distance_rad`: how far a pattern centre may lie from the measured pose.
pub const MAX_AROUND_DISTANCE_RAD: Range = Range::new(0.01, 1.0, "rad");

/// Averaging window of `sample`, s.
pub const SAMPLE_DURATION_S: Range = Range::new(MIN_CYCLE_S, 60.0, "s");

/// Length of a `record` log, s.
pub const LOG_DURATION_S: Range = Range::new(MIN_CYCLE_S, 3600.0, "s");

/// Amplitude of the identification excitation of a `record` log (`excite_deg`), deg: below 1°
/// friction and inertia are not excited above the torque noise; above 45° the waypoints of
/// typical working poses run into the joint limits (each target is clamped 5° inside them).
pub const EXCITE_DEG: Range = Range::new(1.0, 45.0, "deg");

/// Number of static samples of a `record`.
pub const RECORD_COUNT: Range = Range::new(1.0, 1000.0, "");

/// `watch` state period, cycles (100000 is 100 s at 1 ms).
pub const STATE_EVERY: Range = Range::new(1.0, 100_000.0, "cycles");

/// `duration_s` of `collision-calibrate`, s: at least 20 blocks of 1 s for the extreme-value
/// fit; an hour of recording keeps the service's memory for it under 100 MB.
pub const CALIBRATION_DURATION_S: Range = Range::new(20.0, 3600.0, "s");

/// `budget_per_hour` of `collision-calibrate`, false alarms per hour: from one in 10 000 h (the
/// fit's extrapolation is already far beyond any recording) to 10 per hour.
pub const FALSE_ALARM_BUDGET: Range = Range::new(1e-4, 10.0, "1/h");

/// Length of the recording behind installed thresholds (`collision-install`), s of robot time:
/// an offline fit may use logs shorter or longer than `collision-calibrate` records.
pub const FITTED_DURATION_S: Range = Range::new(1.0, 360_000.0, "s");

/// Block length of an extreme-value fit, s.
pub const FIT_BLOCK_S: Range = Range::new(MIN_CYCLE_S, 3600.0, "s");

/// A coefficient of a threshold schedule or a covered speed or acceleration (units per field):
/// non-negative and finite; the upper end only excludes nonsense, the thresholds' own range
/// caps every scheduled threshold.
pub const SCHEDULE_COEFFICIENT: Range = Range::new(0.0, 1e6, "");

/// Extreme-value scale of a threshold schedule (threshold over the residual's envelope).
pub const SCHEDULE_SCALE: Range = Range::new(1e-6, 1e6, "");

/// Joint `j`'s rated speed, rad/s (the upper bound of `motion.max_velocity` before the
/// set-point step limit).
pub fn rated_speed(j: usize) -> f64 {
    LWR4_VELOCITY_LIMITS_DEG_S[j.min(JOINTS - 1)].to_radians()
}

/// Checks a pattern centre against the joint limits and the measured pose: every joint at
/// least `step_deg` (the pattern's half-range) plus [`AROUND_LIMIT_MARGIN_RAD`] inside its
/// limits, and at most `max_distance` rad from the measured position. The error names the joint.
pub fn check_around(
    around: &[f64; JOINTS],
    measured: &[f64; JOINTS],
    step_deg: f64,
    max_distance: f64,
) -> Result<(), String> {
    let half_range = step_deg.to_radians() + AROUND_LIMIT_MARGIN_RAD;
    for j in 0..JOINTS {
        let limits = joint_position(j);
        let inner = Range::new(limits.min + half_range, limits.max - half_range, "rad");
        inner
            .check(&format!("around[{j}]"), around[j])
            .map_err(|e| {
                format!(
                    "{e} (joint {}: its limits {limits} less the pattern's ±{} and a {} margin)",
                    j + 1,
                    with_unit(step_deg, "deg"),
                    with_unit(AROUND_LIMIT_MARGIN_RAD.to_degrees(), "deg"),
                )
            })?;
        let distance = (around[j] - measured[j]).abs();
        if distance.is_nan() || distance > max_distance {
            return Err(format!(
                "around[{j}] = {} is {} from the measured position {} of joint {}; at most \
                 motion.max_around_distance_rad = {} is allowed",
                with_unit(around[j], "rad"),
                with_unit(distance, "rad"),
                with_unit(measured[j], "rad"),
                j + 1,
                with_unit(max_distance, "rad"),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_value_the_unit_and_the_range() {
        assert_eq!(
            threshold(3)
                .check("thresholds[3]", 1e300)
                .map_err(String::from),
            Err("thresholds[3] = 1e300 Nm is outside 0.1…25 Nm".to_owned())
        );
        assert_eq!(
            gain(0.001).check("gains[0]", 1e308).map_err(String::from),
            Err("gains[0] = 1e308 1/s is outside 1…500 1/s".to_owned())
        );
        assert_eq!(
            POSES.check_count("poses", 1).map_err(String::from),
            Err("poses = 1 is outside 2…100".to_owned())
        );
        assert!(
            MASS.check("mass", f64::NAN)
                .unwrap_err()
                .to_string()
                .contains("NaN")
        );
        // The error carries its data, not only its text.
        let e = threshold(6).check("thresholds[6]", 30.0).unwrap_err();
        assert_eq!(
            (e.field.as_str(), e.value, e.range),
            ("thresholds[6]", 30.0, threshold(6))
        );
        assert!(threshold(6).check("t", 9.5).is_ok());
        assert!(threshold(6).check("t", 9.51).is_err());
        assert_eq!(gain(0.01).max, 50.0);
        // The default gain is inside the 1 kHz range, 1e5 1/s (the value) is not.
        assert!(gain(0.001).check("gains[0]", 400.0).is_ok());
        assert!(gain(0.001).check("gains[0]", 1e5).is_err());
        assert_eq!(joint_position(1).to_string(), "-2.0944…2.0944 rad");
        assert_eq!(
            Range::new(0.01, 0.2000000002, "rad/s").to_string(),
            "0.01…0.2 rad/s"
        );
    }

    #[test]
    fn pattern_centres_keep_the_margin_and_stay_near_the_measured_pose() {
        let q = [0.0, 0.5, 0.0, -1.0, 0.0, 1.0, 0.0];
        assert!(check_around(&q, &q, 7.0, 0.5).is_ok());
        let e = check_around(&[1e300; 7], &q, 7.0, 0.5).unwrap_err();
        assert!(e.starts_with("around[0] = 1e300 rad is outside"), "{e}");
        // Joint 2's limit is 120°: the centre must stay 7° + 5° inside it.
        let mut near_limit = q;
        near_limit[1] = 109f64.to_radians();
        let e = check_around(&near_limit, &near_limit, 7.0, 0.5).unwrap_err();
        assert!(e.contains("around[1]") && e.contains("joint 2"), "{e}");
        near_limit[1] = 107.9f64.to_radians();
        assert!(check_around(&near_limit, &near_limit, 7.0, 0.5).is_ok());
        // Within the limits but 0.6 rad from where the arm is.
        let mut far = q;
        far[3] += 0.6;
        let e = check_around(&far, &q, 7.0, 0.5).unwrap_err();
        assert!(e.contains("around[3]") && e.contains("0.5 rad"), "{e}");
    }
}
