//! Operator errors as text: the code, the message, and the typed cause with the controller's
//! view at the time (`fri_api::cause::Cause`).

use fri_api::cause::Cause;
use fri_api::fri_context::FriContext;
use fri_api::protocol::{ErrorCode, OperatorError};

use super::format::{fixed, ms, percent};

/// The stable name of an error code (as in the JSON).
pub(crate) fn code_name(code: ErrorCode) -> String {
    serde_json::to_value(code)
        .ok()
        .and_then(|v| v.as_str().map(str::to_owned))
        .unwrap_or_else(|| format!("{code:?}"))
}

/// The lines of an error report: `error (<code>): <message>`, then the cause and the
/// controller's view, indented.
pub(crate) fn lines(e: &OperatorError) -> Vec<String> {
    let mut lines = vec![format!("error ({}): {}", code_name(e.code), e.message)];
    if let Some(cause) = &e.cause {
        lines.extend(cause_lines(cause).into_iter().map(|l| format!("  {l}")));
    }
    lines
}

/// The cause in words, with its values and units.
fn cause_lines(cause: &Cause) -> Vec<String> {
    let residual = |r: &[f64; 7]| {
        let v: Vec<String> = r.iter().map(|x| fixed(*x, 2)).collect();
        format!("residual at the onset [Nm], j1..j7: {}", v.join(" "))
    };
    match cause {
        Cause::Collision {
            link,
            time_s,
            residual: r,
        } => vec![
            format!(
                "cause: contact detected on link {link} at t = {} s (arm held; `fri-ctl resume` to continue)",
                fixed(*time_s, 3)
            ),
            residual(r),
        ],
        Cause::ResidualChange {
            joint,
            change_nm,
            limit_nm,
        } => vec![format!(
            "cause: the residual of joint {joint} changed by {} Nm, more than the workflow limit of ±{} Nm (contact or an unexpected payload?)",
            fixed(*change_nm, 2),
            fixed(*limit_nm, 2)
        )],
        Cause::OutOfRange {
            field,
            value,
            min,
            max,
            unit,
        } => vec![format!(
            "cause: `{field}` = {value} {unit} is outside the allowed range {min}…{max} {unit}; nothing was done"
        )],
        Cause::OperatorStop => {
            vec!["cause: stopped by the operator (`fri-ctl resume` releases the arm)".to_owned()]
        }
        Cause::Held => vec![
            "cause: the arm is held by a stop or a collision reaction; `fri-ctl resume` first"
                .to_owned(),
        ],
        Cause::ObserverFault { fault, fri } => vec![
            format!("cause: the collision monitor faulted: {fault}"),
            controller(fri),
        ],
        Cause::CommandModeLost { retries, fri } => vec![
            format!(
                "cause: the controller left command mode and stayed out after {retries} retries"
            ),
            controller(fri),
        ],
        Cause::ControllerRestarted { fri } => {
            vec![
                "cause: the controller restarted".to_owned(),
                controller(fri),
            ]
        }
        Cause::ControllerSilent { silent_s, fri } => {
            let silence = if silent_s.is_finite() {
                format!("no measurement for {} s", fixed(*silent_s, 3))
            } else {
                "no measurement has arrived yet (is the KRL program running and FRI open?)"
                    .to_owned()
            };
            let mut v = vec![format!("cause: the controller is silent: {silence}")];
            v.extend(fri.as_ref().map(|f| format!("last {}", controller(f))));
            v
        }
        Cause::NotSettled {
            speed_rad_s,
            limit_rad_s,
            waited_s,
        } => vec![format!(
            "cause: the arm did not come to rest within {} s (joint velocity {:.2e} rad/s over the settle window, limit {:.2e} rad/s): vibration, a slow controller or too tight `estimation.settle_*` limits",
            fixed(*waited_s, 2),
            speed_rad_s,
            limit_rad_s
        )],
        Cause::ContactInRecording {
            joint,
            onset_s,
            peak_s,
            residual_nm,
            envelope_nm,
            score,
            limit,
        } => vec![format!(
            "cause: contact-like onset in the calibration recording on joint {joint} at t = {} s (peak at {} s): the residual held {} Nm where it reaches {} Nm without contact (score {}, limit {}); nothing was installed: record again without touching the arm",
            fixed(*onset_s, 3),
            fixed(*peak_s, 3),
            fixed(*residual_nm, 2),
            fixed(*envelope_nm, 2),
            fixed(*score, 1),
            fixed(*limit, 1)
        )],
        Cause::CalibrationAboveCeiling { joints } => joints
            .iter()
            .map(|a| {
                format!(
                    "cause: joint {}: calibrated threshold {} Nm at rest, {} Nm median over the recording, up to {} Nm in motion, above the ceiling {} Nm ([observer] calibration_ceiling_nm); `--allow-weak` installs it anyway",
                    a.joint,
                    fixed(a.threshold_at_rest_nm, 2),
                    fixed(a.threshold_median_nm, 2),
                    fixed(a.threshold_max_nm, 2),
                    fixed(a.ceiling_nm, 2)
                )
            })
            .collect(),
        Cause::AlreadyDeclared {
            declaration,
            pinned,
        } => vec![format!(
            "cause: the payload is declared unknown already (declaration {declaration}, {}): a new declaration would reopen the grasp window; estimate and apply the payload, or end the mode first (`fri-ctl expect-payload --end`)",
            if *pinned {
                "its load pinned"
            } else {
                "in its grasp window"
            }
        )],
        Cause::DeclarationsExhausted { declarations, max } => vec![format!(
            "cause: {declarations} declarations of an unknown payload with no payload applied since (at most {max}: each opens a grasp window in which a flange force passes for a load); apply the payload (`fri-ctl estimate --apply` or `fri-ctl apply-payload`) before declaring again"
        )],
        Cause::ThresholdsForAnotherSetup {
            field,
            thresholds,
            service,
        } => vec![format!(
            "cause: the thresholds were fitted with {field} = {thresholds}, this service runs with {service}: fit them again on logs of this setup (`fri-ctl offline calibrate-thresholds`)"
        )],
        Cause::EstimateRejected {
            mass_kg,
            mass_std_kg,
            com_flange_m,
            problems,
        } => {
            let mut v = vec![format!(
                "cause: the estimate means nothing and was not applied: {} ± {} kg, centre of mass [mm] in the flange frame {}",
                fixed(*mass_kg, 4),
                fixed(*mass_std_kg, 4),
                com_flange_m
                    .iter()
                    .map(|c| fixed(c * 1e3, 0))
                    .collect::<Vec<_>>()
                    .join(" ")
            )];
            v.extend(problems.iter().map(|p| format!("  {p}")));
            v
        }
        Cause::LoadedTare {
            mass_kg,
            mass_std_kg,
            sigmas,
            against,
        } => vec![format!(
            "cause: the tare's samples see a load of {} ± {} kg against {} (above {}σ); the stored tare was kept: remove the payload and run `tare` again, or `--replace-loaded` if the load belongs to the arm",
            fixed(*mass_kg, 4),
            fixed(*mass_std_kg, 4),
            against.describe(),
            sigmas
        )],
        Cause::PayloadImplausible { refusal } => {
            let mut v = vec![format!("cause: {refusal}")];
            if let fri_api::results::PayloadRefusal::Disagrees { comparison: c } = refusal {
                v.extend(super::apply_payload::comparison_lines(c));
            }
            v.push(
                "nothing was applied; `--force` applies it anyway (audited as weakening)".to_owned(),
            );
            v
        }
        Cause::CommandModeNotEntered { fri } => {
            let mut v = vec![
                "cause: the controller did not enter command mode in time (check the KRL program, quality and drives)".to_owned(),
            ];
            v.extend(fri.as_ref().map(controller));
            v
        }
    }
}

/// The controller's view in one line.
pub(crate) fn controller(f: &FriContext) -> String {
    format!(
        "controller: state {:?}, quality {:?}, answer rate {}, latency {}, {} missed answers in total; KRL status {:?}, last drop to monitor mode: {:?}",
        f.state,
        f.quality,
        percent(f.statistics.answer_rate),
        ms(f.statistics.latency, 2),
        f.statistics.miss_counter,
        f.krl.status,
        f.krl.drop_reason
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_collision_error_names_link_time_and_residual() {
        let e = OperatorError::new(
            ErrorCode::Aborted,
            "collision detected (link 4) at 12.345 s",
        )
        .with_cause(Cause::Collision {
            link: 4,
            time_s: 12.3456,
            residual: [0.0, 0.0, 1.0, 7.25, 0.0, 0.0, 0.0],
        });
        let text = lines(&e).join("\n");
        assert!(
            text.starts_with("error (aborted): collision detected"),
            "{text}"
        );
        assert!(text.contains("link 4 at t = 12.346 s"), "{text}");
        assert!(text.contains("7.25"), "{text}");
    }

    #[test]
    fn a_refused_calibration_names_joint_time_and_what_was_held() {
        let e = OperatorError::new(ErrorCode::Failed, "calibration refused").with_cause(
            Cause::ContactInRecording {
                joint: 1,
                onset_s: 8.131,
                peak_s: 10.49,
                residual_nm: -15.8,
                envelope_nm: 0.92,
                score: 85.0,
                limit: 10.1,
            },
        );
        let text = lines(&e).join("\n");
        assert!(text.contains("joint 1 at t = 8.131 s"), "{text}");
        assert!(
            text.contains("-15.80 Nm") && text.contains("0.92 Nm"),
            "{text}"
        );
        let e = OperatorError::new(ErrorCode::Failed, "not installed").with_cause(
            Cause::CalibrationAboveCeiling {
                joints: vec![fri_api::cause::ThresholdAboveCeiling {
                    joint: 1,
                    threshold_at_rest_nm: 2.11,
                    threshold_median_nm: 40.27,
                    threshold_max_nm: 44.0,
                    ceiling_nm: 22.0,
                }],
            },
        );
        let text = lines(&e).join("\n");
        assert!(
            text.contains("joint 1") && text.contains("40.27") && text.contains("--allow-weak"),
            "{text}"
        );
    }

    #[test]
    fn a_silent_controller_since_the_start() {
        let e = OperatorError::new(ErrorCode::NotReady, "no measurement").with_cause(
            Cause::ControllerSilent {
                silent_s: f64::INFINITY,
                fri: None,
            },
        );
        assert!(lines(&e)[1].contains("no measurement has arrived yet"));
    }
}
