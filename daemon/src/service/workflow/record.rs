//! `record`: static samples or a per-cycle log, as CSV in a new file of the recording directory.

use std::time::Duration;

use fri_api::results::{Event, Phase, Progress, RecordResult};
use tokio::sync::broadcast::error::RecvError;
use tokio::time::Instant;

use super::acquire::{Acquire, WATCH_WAIT_S};
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
            RecordKind::Log => {
                let d = duration_s.unwrap_or(1.0);
                if !(d.is_finite() && d > 0.0 && d <= 3600.0) {
                    return Err(err(
                        ErrorCode::InvalidArguments,
                        "duration_s must be in (0, 3600]",
                    ));
                }
                let mut updates = self.shared.subscribe();
                let (file, _) = dir.create(path).map_err(refuse)?;
                let mut w = std::io::BufWriter::new(file);
                use std::io::Write;
                let mut header = String::from("cycle,time_s,flags");
                for name in ["q", "qd", "tau", "g", "tau_ext", "r"] {
                    for j in 1..=7 {
                        header.push_str(&format!(",{name}{j}"));
                    }
                }
                writeln!(w, "{header}").map_err(io)?;
                let mut t0 = None;
                let mut rows = 0usize;
                let mut lost = 0u64;
                let wall = Instant::now() + Duration::from_secs_f64(d * 2.0 + 10.0);
                loop {
                    let u = tokio::select! {
                        u = updates.recv() => u,
                        _ = tokio::time::sleep_until(wall) => break,
                    };
                    let s = match u {
                        Ok(Update::Snapshot(s)) => s.robot,
                        Ok(Update::Event(_)) => continue,
                        Err(RecvError::Lagged(n)) => {
                            lost += n;
                            continue;
                        }
                        Err(RecvError::Closed) => break,
                    };
                    let start = *t0.get_or_insert(s.time_s);
                    if s.time_s - start > d {
                        break;
                    }
                    let mut line = format!("{},{:.6},{}", s.cycle, s.time_s, s.flags);
                    for a in [&s.q, &s.qd, &s.tau, &s.gravity, &s.tau_ext, &s.residual] {
                        for v in a {
                            line.push_str(&format!(",{v}"));
                        }
                    }
                    writeln!(w, "{line}").map_err(io)?;
                    rows += 1;
                }
                w.flush().map_err(io)?;
                Ok(RecordResult {
                    rows,
                    path: shown,
                    lost: Some(lost),
                })
            }
        }
    }
}
