//! `record`: static samples or a per-cycle log, as CSV in a new file of the recording directory,
//! or the per-cycle state and the events as ROS 2 messages in an MCAP file. A log with
//! `excite_deg` drives the identification excitation ([`super::excite`]) while it records: the
//! unloaded arm's own data for `fri-ctl identify`.

use std::time::Duration;

use fri_api::results::{Event, Phase, Progress, RecordResult, Workflow};
use tokio::sync::broadcast::error::RecvError;
use tokio::sync::watch;
use tokio::time::Instant;

use super::acquire::{Acquire, WATCH_WAIT_S};
use super::excite::identification_targets;
use super::motion::SilenceTimer;
use crate::operator::server::EventSink;
use crate::service::core::{ServiceCore, err};
use crate::service::stream::Update;
use fri_api::protocol::{ErrorCode, OperatorError};

impl ServiceCore {
    /// `record`: static samples or a per-cycle log, as CSV in a new file `path` of the
    /// recording directory (`state.record_dir`, see [`crate::recordings`]).
    pub async fn record(
        &self,
        path: &str,
        kind: fri_api::protocol::RecordKind,
        duration_s: Option<f64>,
        count: Option<usize>,
        excite_deg: Option<f64>,
        events: &EventSink,
    ) -> Result<RecordResult, OperatorError> {
        use crate::recordings::{RecordDir, RecordError};
        use fri_api::protocol::RecordKind;
        let refuse = |e: RecordError| {
            let code = if e.is_request_error() {
                ErrorCode::InvalidArguments
            } else {
                ErrorCode::Failed
            };
            err(code, e.to_string())
        };
        let dir = RecordDir::open(&self.config.state.record_dir()).map_err(refuse)?;
        if excite_deg.is_some() && kind != RecordKind::Log {
            return Err(err(
                ErrorCode::InvalidArguments,
                "`excite_deg` goes with `kind: log` only (the excitation is logged per cycle); nothing was done",
            ));
        }
        let full = dir.check_free(path).map_err(refuse)?;
        let shown = full.to_string_lossy().into_owned();
        let io = |e: std::io::Error| err(ErrorCode::Failed, format!("cannot write {shown}: {e}"));
        match kind {
            RecordKind::Tare => {
                let tare = self.persistent(|s| s.tare.clone()).ok_or_else(|| {
                    err(
                        ErrorCode::Failed,
                        "no tare is stored: run `tare` first (it is kept in state.dir/tare.json)",
                    )
                })?;
                let mut text = Vec::new();
                estimator::samples::write_csv(&mut text, &tare.samples)
                    .map_err(|e| err(ErrorCode::Failed, e.to_string()))?;
                let (mut file, _) = dir.create(path).map_err(refuse)?;
                use std::io::Write;
                file.write_all(&text).map_err(io)?;
                Ok(RecordResult {
                    rows: tare.samples.len(),
                    path: shown,
                    lost: None,
                })
            }
            RecordKind::Samples => {
                let n = count.unwrap_or(1);
                if !(1..=1000).contains(&n) {
                    return Err(err(ErrorCode::InvalidArguments, "count must be 1..1000"));
                }
                let _guard = self.busy()?;
                let mut rows = Vec::with_capacity(n);
                for k in 0..n {
                    let (s, _) = self
                        .acquire(
                            Acquire::Watch {
                                wait_s: WATCH_WAIT_S,
                            },
                            self.config.estimation.average_s,
                            None,
                        )
                        .await?;
                    rows.push(s.sample);
                    events
                        .event(&Event::Progress(Progress {
                            phase: Phase::Sampled,
                            step: Some(k + 1),
                            of: Some(n),
                            workflow: None,
                            pose: None,
                            settle_s: None,
                            max_speed: None,
                        }))
                        .await;
                }
                let mut text = Vec::new();
                estimator::samples::write_csv(&mut text, &rows)
                    .map_err(|e| err(ErrorCode::Failed, e.to_string()))?;
                // Created only now, exclusively: the name may have been taken while sampling.
                let (mut file, _) = dir.create(path).map_err(refuse)?;
                use std::io::Write;
                file.write_all(&text).map_err(io)?;
                Ok(RecordResult {
                    rows: rows.len(),
                    path: shown,
                    lost: None,
                })
            }
            RecordKind::Mcap => {
                let d = log_duration(duration_s)?;
                let namespace = ros_namespace(&self.config)?;
                // Nothing to record without a controller: fail before creating the file.
                self.latest()?;
                let (file, _) = dir.create(path).map_err(refuse)?;
                let (rows, lost, silent) = self
                    .record_mcap(file, d, namespace)
                    .await
                    .map_err(|e| err(ErrorCode::Failed, format!("cannot write {shown}: {e}")))?;
                if let Some(silent_s) = silent {
                    return Err(self.went_silent(silent_s, rows, &shown));
                }
                Ok(RecordResult {
                    rows,
                    path: shown,
                    lost: Some(lost),
                })
            }
            RecordKind::Log => {
                let excitation = match excite_deg {
                    None => None,
                    Some(a) => {
                        fri_api::bounds::EXCITE_DEG
                            .check("excite_deg", a)
                            .map_err(OperatorError::out_of_range)?;
                        Some(a.to_radians())
                    }
                };
                // One pass by default with an excitation; 1 s without.
                let d = match (excitation, duration_s) {
                    (Some(_), None) => None,
                    (_, d) => Some(log_duration(d)?),
                };
                // The excitation moves the arm: no other workflow meanwhile.
                let _guard = excitation.map(|_| self.busy()).transpose()?;
                let mut updates = self.shared.subscribe();
                // Nothing to record without a controller: fail before creating the file.
                let start = self.latest()?.robot.q;
                let (file, _) = dir.create(path).map_err(refuse)?;
                let w = std::io::BufWriter::new(file);
                let (done, stopped) = watch::channel(false);
                let (logged, moved) = match excitation {
                    None => (self.write_log(w, &mut updates, d, None).await, Ok(())),
                    Some(amplitude) => {
                        let targets = identification_targets(&self.model, &start, amplitude);
                        let drive = self.drive_passes(&targets, d, Workflow::Record, events, done);
                        tokio::join!(self.write_log(w, &mut updates, None, Some(stopped)), drive)
                    }
                };
                let logged = logged.map_err(io)?;
                if let Err(mut e) = moved {
                    e.message = format!(
                        "{}; the excitation stopped after {} cycles ({shown} holds them)",
                        e.message, logged.rows
                    );
                    return Err(e);
                }
                if let Some(silent_s) = logged.silent_s {
                    return Err(self.went_silent(silent_s, logged.rows, &shown));
                }
                Ok(RecordResult {
                    rows: logged.rows,
                    path: shown,
                    lost: Some(logged.lost),
                })
            }
        }
    }
}

/// What [`ServiceCore::write_log`] wrote.
struct Logged {
    /// Rows written.
    rows: usize,
    /// Cycles the log fell behind on (gaps in the file).
    lost: u64,
    /// The controller's silence that ended the log early, s.
    silent_s: Option<f64>,
}

/// Wall-clock bound of an excited log, s: two hours, twice the longest `duration_s`, so a
/// drive that never ends cannot keep the file open forever.
const MAX_EXCITED_WALL_S: f64 = 2.0 * 3600.0 + 10.0;

impl ServiceCore {
    /// Writes the per-cycle CSV log to `w` from `updates`: `duration_s` of controller time, or
    /// until `stop` turns true, whichever ends first; the controller's silence ends it too.
    async fn write_log(
        &self,
        mut w: std::io::BufWriter<std::fs::File>,
        updates: &mut tokio::sync::broadcast::Receiver<Update>,
        duration_s: Option<f64>,
        mut stop: Option<watch::Receiver<bool>>,
    ) -> std::io::Result<Logged> {
        use std::io::Write;
        let mut header = String::from("cycle,time_s,flags");
        for name in ["q", "qd", "tau", "g", "tau_ext", "r"] {
            for j in 1..=7 {
                header.push_str(&format!(",{name}{j}"));
            }
        }
        writeln!(w, "{header}")?;
        let silence = SilenceTimer::new(self);
        let mut logged = Logged {
            rows: 0,
            lost: 0,
            silent_s: None,
        };
        let mut t0 = None;
        let wall_s = duration_s.map_or(MAX_EXCITED_WALL_S, |d| d * 2.0 + 10.0);
        let wall = Instant::now() + Duration::from_secs_f64(wall_s);
        let stopped = async |stop: &mut Option<watch::Receiver<bool>>| match stop {
            Some(rx) => {
                // A dropped sender ends the log as a stop does.
                let _ = rx.wait_for(|s| *s).await;
            }
            None => std::future::pending().await,
        };
        loop {
            let u = tokio::select! {
                u = updates.recv() => u,
                silent_s = silence.silence() => {
                    logged.silent_s = Some(silent_s);
                    break;
                }
                () = stopped(&mut stop) => break,
                _ = tokio::time::sleep_until(wall) => break,
            };
            let s = match u {
                Ok(Update::Snapshot(s)) => s.robot,
                Ok(Update::Event(_)) => continue,
                Err(RecvError::Lagged(n)) => {
                    logged.lost += n;
                    continue;
                }
                Err(RecvError::Closed) => break,
            };
            let start = *t0.get_or_insert(s.time_s);
            if duration_s.is_some_and(|d| s.time_s - start > d) {
                break;
            }
            let mut line = format!("{},{:.6},{}", s.cycle, s.time_s, s.flags);
            for a in [&s.q, &s.qd, &s.tau, &s.gravity, &s.tau_ext, &s.residual] {
                for v in a {
                    line.push_str(&format!(",{v}"));
                }
            }
            writeln!(w, "{line}")?;
            logged.rows += 1;
        }
        w.flush()?;
        Ok(logged)
    }

    /// The error of a recording the controller's silence ended: `controller-silent`, naming
    /// the partial file.
    fn went_silent(&self, silent_s: f64, rows: usize, shown: &str) -> OperatorError {
        let mut e = self.silent_error(silent_s);
        e.message = format!(
            "{}; the recording stopped after {rows} cycles ({shown} holds them)",
            e.message
        );
        e
    }
}

/// The length of a `log` or `mcap` recording, s (default 1).
fn log_duration(duration_s: Option<f64>) -> Result<f64, OperatorError> {
    let d = duration_s.unwrap_or(1.0);
    if d.is_finite() && d > 0.0 && d <= 3600.0 {
        Ok(d)
    } else {
        Err(err(
            ErrorCode::InvalidArguments,
            "duration_s must be in (0, 3600]",
        ))
    }
}

/// The namespace of the ROS 2 topics: `ros2.namespace` of the configuration file (the bridge's
/// table, checked by the same rule), else `/lwr`.
fn ros_namespace(config: &crate::config::Config) -> Result<String, OperatorError> {
    let refuse = |reason: String| {
        err(
            ErrorCode::Failed,
            format!("config key `ros2.namespace`: {reason}"),
        )
    };
    match config.ros2.as_ref().and_then(|t| t.get("namespace")) {
        None => Ok(crate::ros_messages::DEFAULT_NAMESPACE.to_owned()),
        Some(toml::Value::String(ns)) => fri_ros_msgs::names::check_namespace(ns)
            .map(|()| ns.clone())
            .map_err(refuse),
        Some(other) => Err(refuse(format!("{other} is not a string"))),
    }
}

/// Items queued between the stream and the MCAP writer thread (4 s at 1 kHz).
const MCAP_QUEUE: usize = 4096;

impl ServiceCore {
    /// Records `duration_s` s of controller time into `file` as MCAP: states, collision onsets,
    /// the applied payload at the start and on each change, contact wrenches. The writer (CDR encoding, zstd)
    /// runs on a blocking thread; a full queue or a lagging stream counts the cycles as lost.
    /// Returns the states written, the cycles lost, and the controller's silence, s, when it
    /// ended the recording early (the file is complete up to there).
    async fn record_mcap(
        &self,
        file: std::fs::File,
        duration_s: f64,
        namespace: String,
    ) -> Result<(usize, u64, Option<f64>), String> {
        use crate::mcap_recording::{Item, McapRecording, McapSettings};
        use crate::service::cycle::CycleEvent;
        use std::sync::mpsc::{TrySendError, sync_channel};

        let settings = McapSettings {
            namespace,
            cycle_s: self.config.fri.cycle_s,
        };
        let (tx, rx) = sync_channel::<Item>(MCAP_QUEUE);
        let writer = tokio::task::spawn_blocking(move || {
            let mut rec = McapRecording::create(std::io::BufWriter::new(file), settings)?;
            while let Ok(item) = rx.recv() {
                rec.item(&item)?;
            }
            let (written, out) = rec.finish()?;
            out.into_inner()
                .map_err(|e| mcap::McapError::Io(e.into_error()))?
                .sync_all()
                .map_err(mcap::McapError::Io)?;
            Ok::<_, crate::mcap_recording::McapRecordingError>(written)
        });
        let frame = crate::ros_messages::DH_FRAME_7;
        let mut updates = self.shared.subscribe();
        let mut t0 = None;
        let mut lost = 0u64;
        let mut payload: Option<Option<crate::persistence::AppliedPayload>> = None;
        let wall = Instant::now() + Duration::from_secs_f64(duration_s * 2.0 + 10.0);
        let silence = SilenceTimer::new(self);
        let mut silent = None;
        let send = |item: Item, lost: &mut u64| match tx.try_send(item) {
            Ok(()) => true,
            Err(TrySendError::Full(Item::State(_))) => {
                *lost += 1;
                true
            }
            // An event is never dropped for a full queue: wait for the writer.
            Err(TrySendError::Full(item)) => tx.send(item).is_ok(),
            Err(TrySendError::Disconnected(_)) => false,
        };
        loop {
            let u = tokio::select! {
                u = updates.recv() => u,
                silent_s = silence.silence() => {
                    silent = Some(silent_s);
                    break;
                }
                _ = tokio::time::sleep_until(wall) => break,
            };
            let item = match u {
                Ok(Update::Snapshot(s)) => {
                    let start = *t0.get_or_insert(s.robot.time_s);
                    if s.robot.time_s - start > duration_s {
                        break;
                    }
                    // The applied payload at the start and whenever it changed, stamped with
                    // the first cycle that shows it.
                    let now = self.persistent(|p| p.payload);
                    if payload != Some(now) {
                        payload = Some(now);
                        let applied = now.as_ref().map(super::status::applied);
                        let m = crate::ros_messages::status_payload(
                            applied.as_ref(),
                            s.robot.time_s,
                            frame,
                        );
                        if !send(Item::Payload(m), &mut lost) {
                            break;
                        }
                    }
                    Item::State(s.robot)
                }
                Ok(Update::Event(CycleEvent::Collision(c))) if t0.is_some() => {
                    if let Some(w) = crate::ros_messages::contact_wrench(&c)
                        && !send(Item::ContactWrench(w), &mut lost)
                    {
                        break;
                    }
                    Item::Collision(c)
                }
                Ok(Update::Event(_)) => continue,
                Err(RecvError::Lagged(n)) => {
                    lost += n;
                    continue;
                }
                Err(RecvError::Closed) => break,
            };
            if !send(item, &mut lost) {
                break;
            }
        }
        drop(tx);
        let written = writer
            .await
            .map_err(|e| format!("the MCAP writer thread failed: {e}"))?
            .map_err(|e| e.to_string())?;
        Ok((written.states, lost, silent))
    }
}
