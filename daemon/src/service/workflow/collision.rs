//! `collision show|arm|disarm|configure`: the collision monitor's reaction and settings.
//!
//! `configure` range-checks every value it is given against the configured cycle and the
//! joints' limits (the error names the field and the range), replaces the loop's monitor, and
//! stores the settings with the payload applied now in the state directory, where the next start
//! finds them (`persistence::StoredMonitor`). New thresholds or gains replace a calibration's
//! schedule with static thresholds; a new reaction keeps it.

use fri_api::protocol::{ErrorCode, OperatorError, ReactionMode};
use fri_api::results::CollisionResult;

use super::status::applied;
use crate::persistence::StoredMonitor;
use crate::service::core::{ServiceCore, err, same_payload};
use crate::service::cycle::CycleRequest;

/// The changes `collision configure` asks for (absent: unchanged).
#[derive(Debug, Clone, Copy, Default)]
pub struct MonitorChange {
    /// Detection thresholds per joint, Nm.
    pub thresholds: Option<[f64; 7]>,
    /// Observer gains per joint, 1/s.
    pub gains: Option<[f64; 7]>,
    /// Reaction to a detected contact.
    pub reaction: Option<ReactionMode>,
    /// Pause of the `pause` reaction, s.
    pub pause_s: Option<f64>,
}

impl MonitorChange {
    fn is_empty(&self) -> bool {
        self.thresholds.is_none()
            && self.gains.is_none()
            && self.reaction.is_none()
            && self.pause_s.is_none()
    }
}

impl ServiceCore {
    /// `collision` arm/disarm/configure/show.
    pub fn collision(
        &self,
        action: fri_api::protocol::CollisionAction,
        change: MonitorChange,
    ) -> Result<CollisionResult, OperatorError> {
        use fri_api::protocol::CollisionAction as A;
        match action {
            A::Show => {}
            A::Arm | A::Disarm => {
                let on = action == A::Arm;
                self.send(CycleRequest::Arm(on))?;
                self.persistent(|s| s.armed = on);
            }
            A::Configure => self.configure_monitor(change)?,
        }
        Ok(self.monitor_settings())
    }

    fn configure_monitor(&self, change: MonitorChange) -> Result<(), OperatorError> {
        if change.is_empty() {
            return Err(err(
                ErrorCode::InvalidArguments,
                "configure needs `thresholds`, `gains`, `reaction` and/or `pause_s`",
            ));
        }
        let (mut t, mut g, mut reaction, mut pause_s, payload) =
            self.persistent(|s| (s.thresholds, s.gains, s.reaction, s.pause_s, s.payload));
        t = change.thresholds.unwrap_or(t);
        g = change.gains.unwrap_or(g);
        reaction = change.reaction.unwrap_or(reaction);
        pause_s = change.pause_s.unwrap_or(pause_s);
        // Named like the arguments; the gain bound follows the configured cycle (the request
        // parser checked the 1 ms bound, the loosest).
        let gain = fri_api::bounds::gain(self.config.fri.cycle_s);
        for j in 0..7 {
            fri_api::bounds::threshold(j)
                .check(&format!("thresholds[{j}]"), t[j])
                .and_then(|()| gain.check(&format!("gains[{j}]"), g[j]))
                .map_err(|e| {
                    let joint = format!(" (joint {})", j + 1);
                    let mut e = OperatorError::out_of_range(e);
                    e.message.push_str(&joint);
                    e
                })?;
        }
        fri_api::bounds::PAUSE_S
            .check("pause_s", pause_s)
            .map_err(OperatorError::out_of_range)?;
        // New thresholds or gains end a calibration: its schedule was fitted for the old
        // ones (the gains set the residual's noise). The reaction keeps it.
        let (schedule, calibration) = if change.thresholds.is_some() || change.gains.is_some() {
            (None, None)
        } else {
            self.persistent(|s| {
                s.stored_monitor.as_ref().map_or((None, None), |m| {
                    (m.schedule.clone(), m.calibration.clone())
                })
            })
        };
        self.install_monitor(StoredMonitor {
            thresholds: t,
            gains: g,
            reaction,
            pause_s,
            set_for_payload: payload,
            schedule,
            calibration,
        })
    }

    /// Puts `stored` in force (the loop's monitor is replaced, payload and arming carried over)
    /// and persists it; `configure` and `collision-calibrate` end here.
    pub(crate) fn install_monitor(&self, stored: StoredMonitor) -> Result<(), OperatorError> {
        let config = crate::service::with_stored_monitor(&self.config, &stored);
        config
            .validate()
            .map_err(|e| err(ErrorCode::InvalidArguments, e.to_string()))?;
        let monitor =
            crate::service::build_scheduled_monitor(&config, &self.arm, stored.schedule.as_ref())
                .map_err(|e| err(ErrorCode::InvalidArguments, e.to_string()))?;
        self.send(CycleRequest::ReplaceMonitor {
            monitor: Box::new(monitor),
            react: stored.reaction != ReactionMode::Report,
        })?;
        // In force from here on, whether or not the file can be written.
        let saved = self.store.save_monitor(Some(&stored));
        self.persistent(|s| {
            s.thresholds = stored.thresholds;
            s.gains = stored.gains;
            s.reaction = stored.reaction;
            s.pause_s = stored.pause_s;
            if saved.is_ok() {
                s.stored_monitor = Some(stored);
            }
        });
        saved.map_err(|e| {
            err(
                ErrorCode::Internal,
                format!("monitor settings in force but not persisted: {e}"),
            )
        })
    }

    /// The monitor's settings as `collision` and `status` report them.
    pub(crate) fn monitor_settings(&self) -> CollisionResult {
        self.persistent(|s| {
            let set_for = s.stored_monitor.as_ref().and_then(|m| m.set_for_payload);
            CollisionResult {
                armed: s.armed,
                thresholds: s.thresholds,
                gains: s.gains,
                reaction: s.reaction,
                pause_s: s.pause_s,
                persisted: s.stored_monitor.is_some(),
                set_for_payload: set_for.as_ref().map(applied),
                payload_changed: s.stored_monitor.is_some()
                    && !same_payload(set_for.as_ref(), s.payload.as_ref()),
                schedule: s.stored_monitor.as_ref().and_then(|m| m.schedule.clone()),
                calibration: s
                    .stored_monitor
                    .as_ref()
                    .and_then(|m| m.calibration.clone()),
            }
        })
    }

    /// What makes `settings` weaker than the configuration file's monitor (empty: nothing):
    /// a threshold above the configured one, a gain below it, a reaction that no longer holds
    /// the arm, a disarmed monitor. The audit trail and `status` name these.
    pub(crate) fn weaker_than_configuration(&self, settings: &CollisionResult) -> Vec<String> {
        weaker_than(&self.config, settings)
    }
}

/// What makes `settings` weaker than `config`'s monitor (see
/// [`ServiceCore::weaker_than_configuration`]).
pub(crate) fn weaker_than(
    config: &crate::config::Config,
    settings: &CollisionResult,
) -> Vec<String> {
    let mut weaker = Vec::new();
    let configured = &config.observer;
    if configured.armed && !settings.armed {
        weaker.push("disarmed (the configuration arms the monitor)".to_owned());
    }
    for j in 0..7 {
        if settings.thresholds[j] > configured.thresholds[j] {
            weaker.push(format!(
                "joint {} threshold {:.3} Nm above the configuration's {:.3} Nm",
                j + 1,
                settings.thresholds[j],
                configured.thresholds[j]
            ));
        }
        if settings.gains[j] < configured.gains[j] {
            weaker.push(format!(
                "joint {} gain {:.1} 1/s below the configuration's {:.1} 1/s",
                j + 1,
                settings.gains[j],
                configured.gains[j]
            ));
        }
    }
    if settings.reaction == ReactionMode::Report && config.reaction.policy != ReactionMode::Report {
        weaker.push(format!(
            "report-only reaction (the configuration's is `{}`)",
            config.reaction.policy.name()
        ));
    }
    weaker
}
