//! Phase 4 of the demo: the recorded free motion evaluated with the service's own monitor
//! (compensated with the applied estimate and the calibrated schedule; uncompensated at the
//! fixed threshold) and with the controller's estimate, then Fig. 5 and Fig. 6.

use std::path::PathBuf;

use fri_api::results::ThresholdSchedule;
use fri_service::config::Config;
use nalgebra::SVector;
use safety::PayloadCompensation;

use super::figures::{Onsets, plot_fig5, plot_fig6};
use super::free_motion::FreeMotionRun;
use super::log::read_log;
use super::replay::{classify, onsets, residuals, scheduled_residuals};
use super::{CONTACTS_S, DemoOptions, PayloadReport, fmt_times, say};

type V7 = SVector<f64, 7>;

/// Detections and false alarms of one signal.
pub(super) struct Detections {
    /// The first onset after each contact, s since t = 0.
    pub(super) detected: Vec<f64>,
    /// Onsets no contact explains.
    pub(super) false_alarms: usize,
    /// Peak |signal| away from the contacts, Nm.
    pub(super) free_motion_peak_nm: f64,
}

/// The evaluation of the three signals and the figures drawn.
pub(super) struct Evaluation {
    /// The service's monitor with the estimate compensated and the calibrated schedule.
    pub(super) compensated: Detections,
    /// The service's monitor without payload compensation, fixed threshold.
    pub(super) uncompensated: Detections,
    /// The controller's estExtJntTrq, fixed threshold.
    pub(super) fri: Detections,
    /// The figures: PNGs first, then the SVGs.
    pub(super) plots: Vec<PathBuf>,
}

/// Evaluates `run` (see the module documentation).
pub(super) fn evaluate(
    opts: &DemoOptions,
    config: &Config,
    estimate: &PayloadReport,
    schedule: &ThresholdSchedule,
    run: &FreeMotionRun,
) -> anyhow::Result<Evaluation> {
    say(opts, "[4/4] evaluating residuals and plotting ...");
    let cycle_s = config.fri.cycle_s;
    let rows = read_log(&run.log_abs)?;
    let model = dynamics::lwr4();
    // Panel (c) and the compensated detections: the service's calibrated monitor (scheduled
    // thresholds, the applied estimate as the service compensates it) on the recorded log.
    let applied = fri_service::persistence::AppliedPayload {
        mass: estimate.mass,
        com: estimate.com,
    };
    let (compensated, scheduled, on_c) = scheduled_residuals(
        &model,
        config,
        &rows,
        fri_service::service::core::compensation(&applied),
        cycle_s,
        schedule,
        run.t0,
    )?;
    let uncompensated = residuals(&model, config, &rows, PayloadCompensation::None, cycle_s)?;
    let fri_signal: Vec<V7> = rows.iter().map(|r| V7::from(r.tau_ext)).collect();
    let times: Vec<f64> = rows.iter().map(|r| r.time_s - run.t0).collect();
    let velocities: Vec<V7> = rows.iter().map(|r| V7::from(r.qd)).collect();
    // The service's thresholds, so the figure's dashed lines are the ones the evaluation used.
    let thresholds = &config.observer.thresholds;
    let on_u = onsets(&uncompensated, &velocities, &times, thresholds)?;
    let on_f = onsets(&fri_signal, &velocities, &times, thresholds)?;
    let judge = |on: &[f64], signal: &[V7]| {
        let (detected, false_alarms) = classify(on);
        let free_motion_peak_nm = signal
            .iter()
            .zip(&times)
            .filter(|(_, t)| CONTACTS_S.iter().all(|c| **t < *c - 0.05 || **t > *c + 1.0))
            .map(|(r, _)| r.amax())
            .fold(0.0, f64::max);
        Detections {
            detected,
            false_alarms,
            free_motion_peak_nm,
        }
    };
    let (c, u, f) = (
        judge(&on_c, &compensated),
        judge(&on_u, &uncompensated),
        judge(&on_f, &fri_signal),
    );
    for (name, d) in [
        ("compensated residual (with estimate)", &c),
        ("uncompensated residual (no payload)", &u),
        ("controller estExtJntTrq (FRI)", &f),
    ] {
        say(
            opts,
            format!(
                "      {name:38} detections {}, {}, free-motion peak {:.1} Nm",
                fmt_times(&d.detected),
                super::fmt_false_alarms(d.false_alarms),
                d.free_motion_peak_nm
            ),
        );
    }

    let fig5 = opts.out_dir.join("fig5-torque-validation.svg");
    let fig6 = opts.out_dir.join("fig6-residuals.svg");
    plot_fig5(&fig5, &model, &rows, &times, estimate, cycle_s)?;
    plot_fig6(
        &fig6,
        &times,
        thresholds,
        (&fri_signal, &uncompensated, &compensated),
        &scheduled,
        &Onsets {
            fri: &on_f,
            uncompensated: &on_u,
            compensated: &on_c,
        },
    )?;
    say(
        opts,
        format!(
            "      plots: {} and {} (each also as .png)",
            fig5.display(),
            fig6.display()
        ),
    );
    Ok(Evaluation {
        compensated: c,
        uncompensated: u,
        fri: f,
        plots: vec![
            fig5.with_extension("png"),
            fig6.with_extension("png"),
            fig5,
            fig6,
        ],
    })
}
