//! Phase 3 of the demo: the free motion with three contacts (controller run 3, the KRL-side
//! motion in monitor mode), recorded by the service as a per-cycle log while a `watch` collects
//! the collisions the service reports online.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::Context as _;
use fri_api::client::Client;
use fri_api::protocol::{Command, RecordKind};
use fri_api::results::{Event, RecordResult, WatchResult};
use mock_robot::server::ServerConfig;

use super::clock::{service_clock, wait_fresh_state};
use super::scenario::free_motion;
use super::{DemoOptions, FREE_MOTION_S, say};

/// What the free-motion run left for the evaluation.
pub(super) struct FreeMotionRun {
    /// The log as the report names it (in the output directory).
    pub(super) log: PathBuf,
    /// The same file, absolute.
    pub(super) log_abs: PathBuf,
    /// The service's clock at the run's t = 0, s.
    pub(super) t0: f64,
    /// Collision onsets the service reported online, s on the service's clock.
    pub(super) online: Vec<f64>,
    /// Controller cycles of the run.
    pub(super) cycles: u64,
}

/// Runs the free motion against the service; the controller has ended when it returns.
pub(super) async fn run(
    opts: &DemoOptions,
    client: &mut Client,
    socket: &std::path::Path,
    fri: std::net::SocketAddr,
    cycle_s: f64,
) -> anyhow::Result<FreeMotionRun> {
    say(
        opts,
        "[3/4] free motion, contacts at 1, 8, 17 s; monitor armed with the estimate ...",
    );
    let log = opts.out_dir.join("free-motion.csv");
    let log_abs = if log.is_absolute() {
        log.clone()
    } else {
        std::env::current_dir()?.join(&log)
    };
    // The previous phase's controller has ended (joined). After the 0.2 s a rebind needs
    // (see `demo_config`), the service's clock at its last measurement fixes t = 0 of this
    // run: the new controller's first measurement is counted one cycle later. Recording and
    // watching start once the new controller is heard (a recording needs a live controller,
    // and one begun on the old controller's last breath fails when it falls silent); the few
    // cycles before that are missing from the log, never misplaced in time.
    tokio::time::sleep(Duration::from_millis(200)).await;
    let (before_cycle, before_time) = service_clock(client).await?;
    let t0 = before_time + cycle_s;
    let driver = mock_robot::spawn_new(
        free_motion(opts.seed, opts.arm),
        ServerConfig::loopback(fri, opts.pacing),
    )?;
    wait_fresh_state(client, Some(before_cycle), 0).await?;
    // The service writes only into its recording directory (in the demo's work directory); the
    // log is copied to the output directory afterwards.
    let mut recorder = Client::connect(socket).await?;
    let record = tokio::spawn(async move {
        recorder
            .call_typed::<RecordResult>(
                Command::Record {
                    path: "free-motion.csv".to_owned(),
                    kind: RecordKind::Log,
                    // Ends before the controller does (FREE_MOTION_S + 0.5 s after t = 0, the
                    // first row is a little later): a recording whose controller falls silent
                    // fails (issue 20 item 9).
                    duration_s: Some(FREE_MOTION_S),
                    count: None,
                    excite_deg: None,
                },
                |_| {},
            )
            .await
    });
    let mut watcher = Client::connect(socket).await?;
    let online = Arc::new(Mutex::new(Vec::<f64>::new()));
    let seen = online.clone();
    let watch_task = tokio::spawn(async move {
        let _ = watcher
            .call_typed::<WatchResult>(Command::Watch { state_every: None }, |e| {
                if let (Ok(Event::Collision(c)), Ok(mut v)) = (e, seen.lock()) {
                    v.push(c.time_s);
                }
            })
            .await;
    });
    let recorded = record
        .await
        .context("recording task")??
        .map_err(|e| anyhow::anyhow!("recording failed: {}", e.message))?;
    let cycles = driver.join().map_or(0, |(_, run)| run.cycles);
    watch_task.abort();
    std::fs::copy(&recorded.path, &log_abs)
        .with_context(|| format!("copying {} to {}", recorded.path, log_abs.display()))?;
    say(
        opts,
        format!(
            "      recorded {} cycles to {}",
            recorded.rows,
            log.display()
        ),
    );
    let online = online.lock().map(|v| v.clone()).unwrap_or_default();
    Ok(FreeMotionRun {
        log,
        log_abs,
        t0,
        online,
        cycles,
    })
}
