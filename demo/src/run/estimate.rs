//! Phases 1 and 2 of the demo: the tare without payload, then — the payload declared unknown,
//! attached while the arm is parked — the estimate, applied, with the monitor armed throughout.

use anyhow::Context as _;
use fri_api::client::Client;
use fri_api::protocol::Command;
use fri_api::results::{
    EstimateResult, Event, ExpectPayloadResult, Phase, Progress, RawEvent, TareResult,
};
use mock_robot::server::ServerConfig;

use super::clock::{current_cycle, status, wait_fresh_state};
use super::scenario::sim;
use super::{DemoOptions, PAPER_COM, PAPER_MASS, PAYLOAD_MASS, PayloadReport, say};

/// The progress line of a sampled pose: the pattern's poses count to their number, the last
/// sample is the first pose again (the drift over the procedure).
fn sampled_line(p: &Progress) -> Option<String> {
    if p.phase != Phase::Sampled {
        return None;
    }
    Some(match (p.step, p.of) {
        (Some(k), Some(n)) if k == n && n > 1 => {
            "      pose 1 sampled again (the drift over the procedure)".to_owned()
        }
        (Some(k), Some(n)) => format!("      pose {k}/{} sampled", n.saturating_sub(1).max(1)),
        _ => "      pose sampled".to_owned(),
    })
}

/// Prints each sampled pose of a pattern workflow.
fn progress(opts: &DemoOptions) -> impl FnMut(Result<Event, RawEvent>) + '_ {
    move |e| {
        if let Ok(Event::Progress(p)) = e
            && let Some(line) = sampled_line(&p)
        {
            say(opts, line);
        }
    }
}

/// The estimate and the truth it is compared with (frame 7).
pub(super) struct Estimated {
    /// The service's estimate, applied to the observer.
    pub(super) estimate: PayloadReport,
    /// The simulation's payload.
    pub(super) truth: PayloadReport,
    /// Controller cycles of the two runs (tare, estimate).
    pub(super) cycles: u64,
}

/// Tare (controller run 1, no payload), then the estimate (run 2, the same simulated arm with
/// the payload attached), applied. The arm is left parked, the controller ended.
pub(super) async fn tare_and_estimate(
    opts: &DemoOptions,
    client: &mut Client,
    fri: std::net::SocketAddr,
) -> anyhow::Result<Estimated> {
    say(
        opts,
        "[1/4] tare: 10 poses (centred pattern, ±7°), no payload ...",
    );
    let driver = mock_robot::spawn_new(
        sim(opts.seed, opts.arm, false),
        ServerConfig::loopback(fri, opts.pacing),
    )?;
    wait_fresh_state(client, None, 50).await?;
    let tare = client
        .call_typed::<TareResult>(
            Command::Tare {
                around: None,
                poses: Some(10),
                step_deg: Some(7.0),
                pattern: None,
                replace_loaded: None,
            },
            progress(opts),
        )
        .await?
        .map_err(|e| anyhow::anyhow!("tare failed: {}", e.message))?;
    say(
        opts,
        format!(
            "      tare stored: {} poses and the first again, {} samples",
            tare.samples,
            tare.samples + 1
        ),
    );

    say(
        opts,
        format!("[2/4] payload attached ({PAYLOAD_MASS} kg at (0, 0, 0.119) m); estimating ..."),
    );
    let before = current_cycle(client).await?;
    // Declared unknown before the grasp: the monitor stays armed and tolerates only what a
    // plausible flange load explains (docs/collision-detection.md §8).
    let declared = client
        .call_typed::<ExpectPayloadResult>(
            Command::ExpectPayload {
                max_mass: None,
                max_radius: None,
                end: None,
            },
            |_| {},
        )
        .await?
        .map_err(|e| anyhow::anyhow!("expect-payload failed: {}", e.message))?;
    // The same robot carries on: the tare's noise, drift and estimate are independent draws.
    let (mut robot, tare_run) = driver
        .join()
        .context("the simulated controller of the tare phase failed")?;
    robot.set_payload_attached(true);
    let driver = mock_robot::spawn(robot, ServerConfig::loopback(fri, opts.pacing))?;
    wait_fresh_state(client, before, 50).await?;
    let est = client
        .call_typed::<EstimateResult>(
            Command::EstimatePayload {
                around: None,
                poses: Some(10),
                step_deg: Some(7.0),
                pattern: None,
                use_tare: None,
                apply: Some(true),
            },
            progress(opts),
        )
        .await?
        .map_err(|e| anyhow::anyhow!("estimation failed: {}", e.message))?;
    // A collision would have aborted the estimate; the monitor was armed from the declaration
    // on, and the applied estimate ended the unknown-payload mode.
    let after = status(client).await?;
    let armed = declared.unknown_payload.is_some()
        && after.monitor.armed
        && after.unknown_payload.is_none();
    say(
        opts,
        if armed {
            "      estimated with the monitor ARMED throughout (payload declared unknown, no collision; estimate applied)"
        } else {
            "      WARNING: the monitor was not armed throughout the estimate"
        },
    );
    let (robot, estimate_run) = driver
        .join()
        .context("the simulated controller of the estimate phase failed")?;
    let truth = robot
        .true_payload()
        .copied()
        .context("the simulation ended without its truth")?;
    let estimated = Estimated {
        estimate: PayloadReport {
            mass: est.mass,
            com: est.com,
            mass_std: Some(est.mass_std),
            com_std: Some(est.com_std),
        },
        truth: PayloadReport {
            mass: truth.mass,
            com: truth.com().map_or([f64::NAN; 3], |c| [c.x, c.y, c.z]),
            mass_std: None,
            com_std: None,
        },
        cycles: tare_run.cycles + estimate_run.cycles,
    };
    report(opts, &estimated, &est);
    Ok(estimated)
}

/// Prints the estimate next to the truth and the paper's, its σ by source and its robot time.
fn report(opts: &DemoOptions, e: &Estimated, est: &EstimateResult) {
    let (truth, estimate) = (&e.truth, &e.estimate);
    say(
        opts,
        "      payload (frame 7)         mass [kg]            com [m]",
    );
    say(
        opts,
        format!(
            "      truth                     {:.4}               ({:+.4}, {:+.4}, {:+.4})",
            truth.mass, truth.com[0], truth.com[1], truth.com[2]
        ),
    );
    let sd = estimate.com_std.unwrap_or([f64::NAN; 3]);
    say(
        opts,
        format!(
            "      service (tare, 10 poses)  {:.4} ± {:.4}     ({:+.4} ± {:.4}, {:+.4} ± {:.4}, {:+.4} ± {:.4})",
            estimate.mass,
            estimate.mass_std.unwrap_or(f64::NAN),
            estimate.com[0],
            sd[0],
            estimate.com[1],
            sd[1],
            estimate.com[2],
            sd[2]
        ),
    );
    say(
        opts,
        format!(
            "      paper eq. 47 (10 poses)   {PAPER_MASS:.4}               ({:+.4}, {:+.4}, {:+.4})",
            PAPER_COM[0], PAPER_COM[1], PAPER_COM[2]
        ),
    );
    // What the service's σ is made of, and where the procedure's robot time went.
    if let Some(u) = &est.uncertainty {
        let parts: Vec<String> = u
            .sources
            .iter()
            .map(|p| format!("{} {:.2} g", p.source.label(), p.mass_std * 1e3))
            .collect();
        say(
            opts,
            format!("      mass 1σ by source: {}", parts.join(", ")),
        );
    }
    if let Some(t) = &est.timing {
        say(
            opts,
            format!(
                "      estimate robot time {:.1} s: moving {:.1}, settling {:.1}, averaging {:.1}",
                t.total_s, t.moving_s, t.settling_s, t.averaging_s
            ),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sampled(step: usize, of: usize) -> Progress {
        Progress {
            phase: Phase::Sampled,
            step: Some(step),
            of: Some(of),
            workflow: None,
            pose: None,
            settle_s: None,
            max_speed: None,
        }
    }

    #[test]
    fn the_pattern_counts_its_poses_and_names_the_revisit() {
        assert_eq!(
            sampled_line(&sampled(3, 11)).as_deref(),
            Some("      pose 3/10 sampled")
        );
        assert_eq!(
            sampled_line(&sampled(11, 11)).as_deref(),
            Some("      pose 1 sampled again (the drift over the procedure)")
        );
        let moving = Progress {
            phase: Phase::Moving,
            ..sampled(1, 11)
        };
        assert_eq!(sampled_line(&moving), None);
    }
}
