//! `expect-payload`: the payload is about to be grasped (or is held) and is unknown. The loop's
//! monitor stays armed and detects against what a plausible flange load explains during the
//! grasp, and against the pinned load once the load has settled or the grasp window has ended
//! (`safety::PayloadTolerance`); after every static sample of a workflow the load is refitted
//! here and the hypothesis handed to the loop, which pins its load again. `estimate-payload
//! --apply`, `apply-payload` and `clear-payload` end the mode (the loop ends it in the cycle
//! that installs the payload), and so does `expect-payload` with `end`; without an estimate the
//! loop ends it after `[unknown_payload] expire_s`, and [`ServiceCore::follow_unknown_payload`]
//! records that (and every pin) in the audit trail.
//!
//! `estimate-payload` enters the mode itself when the applied payload does not explain the
//! residual at its start ([`UNEXPLAINED_SHARE`]); the payload is held then, so its load is
//! pinned at once (no grasp window).

use std::time::Duration;

use dynamics::Data;
use fri_api::cause::Cause;
use fri_api::origin::Origin;
use fri_api::protocol::{ErrorCode, OperatorError};
use fri_api::results::{Change, DeclaredBy, ExpectPayloadResult, UnknownPayload};
use safety::{FlangeLoadBounds, GraspTiming, LoadSample, fit_hypothesis};
use tokio::sync::broadcast::error::RecvError;

use super::unknown_payload_state::{UnknownPayloadState, pinned_by};
use crate::persistence::StaticSample;
use crate::service::core::{ServiceCore, err};
use crate::service::cycle::CycleRequest;
use crate::service::output::{CycleEvent, UnknownPayloadView};
use crate::service::stream::Update;

/// Share of a joint's threshold the static residual may use at the start of `estimate-payload`
/// while the applied payload still counts as explaining it. With a correct payload the residual
/// at rest is the model error (≤ 0.5 Nm against 6 Nm on the simulated LWR). A flange load using
/// a third of θ changes by at most half of itself over a pattern of up to ±30° (sin 30°), and
/// the moves may take the other half of θ (the free-motion design rule, docs §2):
/// θ/3 · 1.5 + θ/2 = θ. Above it the estimate would trip on the payload itself.
pub const UNEXPLAINED_SHARE: f64 = 1.0 / 3.0;

/// Longest wait for a valid residual at the start of `estimate-payload` (the monitor's warm-up
/// is 50 ms).
const RESIDUAL_WAIT: Duration = Duration::from_millis(500);

/// Declarations of an unknown payload allowed with no payload applied since (a payload with
/// mass, by `apply-payload` or `estimate-payload --apply`). Each opens a grasp window in which a
/// downward flange force passes for a load; `--end` and a new declaration would otherwise
/// reopen it for ever (issue 34). A grasp, an estimate that is refused and one more try fit.
pub const MAX_DECLARATIONS_WITHOUT_PAYLOAD: u32 = 3;

/// Longest wait of `expect-payload` for the loop to take the declaration (it does in the next
/// cycle while a controller sends), so that the answer says until when the grasp may last.
const DECLARATION_WAIT: Duration = Duration::from_millis(500);

impl ServiceCore {
    /// `expect-payload`: declares the payload unknown with the given bounds (defaults from
    /// `[unknown_payload]`), or with `end` leaves the mode. Answers once the loop took the
    /// declaration (at most [`DECLARATION_WAIT`]), with its grasp window and expiry.
    pub async fn expect_payload(
        &self,
        max_mass: Option<f64>,
        max_radius: Option<f64>,
        end: bool,
        origin: &Origin,
    ) -> Result<ExpectPayloadResult, OperatorError> {
        if end {
            if max_mass.is_some() || max_radius.is_some() {
                return Err(err(
                    ErrorCode::InvalidArguments,
                    "`end` takes no other argument: it leaves the unknown-payload mode",
                ));
            }
            self.send(CycleRequest::EndExpectPayload)?;
            if self.persistent(|s| s.unknown_payload.take().is_some()) {
                self.audit.record(
                    origin,
                    Change::UnknownPayloadEnded {
                        reason: "ended".to_owned(),
                    },
                );
            }
            return Ok(ExpectPayloadResult {
                unknown_payload: None,
            });
        }
        let defaults = &self.config.unknown_payload;
        let bounds = FlangeLoadBounds {
            max_mass_kg: max_mass.unwrap_or(defaults.max_mass_kg),
            radius_m: max_radius.unwrap_or(defaults.max_radius_m),
        };
        fri_api::bounds::UNKNOWN_PAYLOAD_MASS
            .check("max_mass", bounds.max_mass_kg)
            .and_then(|()| {
                fri_api::bounds::UNKNOWN_PAYLOAD_RADIUS.check("max_radius", bounds.radius_m)
            })
            .map_err(OperatorError::out_of_range)?;
        let declaration =
            self.declare_unknown_payload(bounds, defaults.timing(), DeclaredBy::Operator, origin)?;
        let mut updates = self.shared.subscribe();
        let taken = |view: Option<UnknownPayloadView>| matches!(view, Some(UnknownPayloadView::Active(s)) if s.declaration == declaration);
        if !taken(self.shared.unknown_payload()) {
            let _ = tokio::time::timeout(DECLARATION_WAIT, async {
                loop {
                    match updates.recv().await {
                        Ok(Update::Event(CycleEvent::UnknownPayload { view, .. }))
                            if taken(Some(view)) =>
                        {
                            return;
                        }
                        Ok(_) | Err(RecvError::Lagged(_)) => {
                            if taken(self.shared.unknown_payload()) {
                                return;
                            }
                        }
                        Err(RecvError::Closed) => return,
                    }
                }
            })
            .await;
        }
        Ok(ExpectPayloadResult {
            unknown_payload: self.unknown_payload_status(),
        })
    }

    /// Starts the unknown-payload mode; returns the declaration's number. Refused while a
    /// declaration is active (it keeps its grasp window, pin and expiry: the loop refuses it
    /// too) and after [`MAX_DECLARATIONS_WITHOUT_PAYLOAD`] declarations with no payload applied
    /// since.
    fn declare_unknown_payload(
        &self,
        bounds: FlangeLoadBounds,
        timing: GraspTiming,
        declared_by: DeclaredBy,
        origin: &Origin,
    ) -> Result<u32, OperatorError> {
        // The loop's view first: a declaration it has ended (expired) no longer counts as active.
        let active = self.unknown_payload_status();
        let declaration = self.persistent(|s| {
            if let (Some(u), Some(status)) = (&s.unknown_payload, &active) {
                return Err(err(
                    ErrorCode::NotReady,
                    format!(
                        "the payload is declared unknown already (declaration {}): a new declaration would reopen the grasp window; estimate and apply the payload, or end the mode first",
                        u.declaration
                    ),
                )
                .with_cause(Cause::AlreadyDeclared {
                    declaration: u.declaration,
                    pinned: status.pinned.is_some(),
                }));
            }
            if s.declarations_without_payload >= MAX_DECLARATIONS_WITHOUT_PAYLOAD {
                return Err(err(
                    ErrorCode::NotReady,
                    format!(
                        "{} declarations of an unknown payload with no payload applied since (at most {MAX_DECLARATIONS_WITHOUT_PAYLOAD}): apply the payload before declaring again",
                        s.declarations_without_payload
                    ),
                )
                .with_cause(Cause::DeclarationsExhausted {
                    declarations: s.declarations_without_payload,
                    max: MAX_DECLARATIONS_WITHOUT_PAYLOAD,
                }));
            }
            s.declarations_without_payload += 1;
            s.declarations = s.declarations.wrapping_add(1);
            Ok(s.declarations)
        })?;
        self.send(CycleRequest::ExpectPayload {
            declaration,
            bounds,
            timing,
        })?;
        self.persistent(|s| {
            s.unknown_payload = Some(UnknownPayloadState {
                declaration,
                declared_by,
                origin: origin.clone(),
                bounds,
                samples: Vec::new(),
                hypothesis: None,
            });
        });
        self.audit.record(
            origin,
            Change::PayloadDeclaredUnknown {
                max_mass: bounds.max_mass_kg,
                max_radius: bounds.radius_m,
            },
        );
        Ok(declaration)
    }

    /// The unknown-payload mode for `status` (`None`: the applied payload is the payload; also
    /// once the loop ended this declaration, before [`Self::follow_unknown_payload`] has
    /// recorded it).
    pub(crate) fn unknown_payload_status(&self) -> Option<UnknownPayload> {
        let view = self.shared.unknown_payload();
        let now = self.shared.latest().map(|s| s.robot.time_s);
        self.persistent(|s| {
            let u = s.unknown_payload.as_ref()?;
            match view {
                Some(UnknownPayloadView::Ended { declaration, .. })
                    if declaration == u.declaration =>
                {
                    None
                }
                Some(UnknownPayloadView::Active(l)) => Some(u.report(Some(&l), now)),
                _ => Some(u.report(None, now)),
            }
        })
    }

    /// Follows the loop's unknown-payload mode until `shutdown`: records every pin in the audit
    /// trail, and an expiry (the loop ended the mode on its own) as the end of the mode, by the
    /// service. The operator side's state of an expired declaration is dropped.
    pub async fn follow_unknown_payload(&self, mut shutdown: tokio::sync::watch::Receiver<bool>) {
        let mut updates = self.shared.subscribe();
        // The last pin recorded: (declaration, controller time).
        let mut recorded: Option<(u32, f64)> = None;
        loop {
            let view = tokio::select! {
                u = updates.recv() => match u {
                    Ok(Update::Event(CycleEvent::UnknownPayload { view, .. })) => Some(view),
                    Ok(_) => None,
                    // Missed updates: the latest view says where the mode stands.
                    Err(RecvError::Lagged(_)) => self.shared.unknown_payload(),
                    Err(RecvError::Closed) => return,
                },
                changed = shutdown.changed() => {
                    if changed.is_err() || *shutdown.borrow() {
                        return;
                    }
                    None
                }
            };
            match view {
                Some(UnknownPayloadView::Active(status)) => {
                    let Some(pin) = status.pinned else { continue };
                    if recorded == Some((status.declaration, pin.at_s)) {
                        continue;
                    }
                    recorded = Some((status.declaration, pin.at_s));
                    tracing::info!(
                        declaration = status.declaration,
                        mass_kg = pin.mass_kg,
                        mass_tolerance_kg = pin.mass_tolerance_kg,
                        by = pinned_by(pin.source).name(),
                        "the unknown payload's load is pinned: a change of it is a contact"
                    );
                    self.audit.record(
                        &Origin::Service,
                        Change::PayloadPinned {
                            mass: pin.mass_kg,
                            com: pin.com.map(|c| [c.x, c.y, c.z]),
                            by: pinned_by(pin.source),
                        },
                    );
                }
                Some(UnknownPayloadView::Ended {
                    declaration,
                    reason: safety::ModeEnd::Expired,
                }) => {
                    let ended = self.persistent(|s| {
                        s.unknown_payload
                            .take_if(|u| u.declaration == declaration)
                            .is_some()
                    });
                    if ended {
                        tracing::warn!(
                            declaration,
                            expire_s = self.config.unknown_payload.expire_s,
                            "the unknown-payload mode expired without an estimate: the monitor detects against the applied payload again"
                        );
                        self.audit.record(
                            &Origin::Service,
                            Change::UnknownPayloadEnded {
                                reason: "expired".to_owned(),
                            },
                        );
                    }
                }
                _ => {}
            }
        }
    }

    /// The workflows' hook after each static sample: while the payload is unknown, refits the
    /// flange load to every sample since the declaration and hands the hypothesis to the loop.
    /// Data: the residual at rest without the compensation, z = τ_J − g(q) of the observer's
    /// own unloaded model (with an identified arm, its offsets too). Never fails the workflow:
    /// without the new hypothesis the loop keeps the previous one, which can only make it
    /// stricter.
    pub(crate) fn unknown_payload_sampled(&self, sample: &StaticSample) {
        let mut data = Data::new(&self.model);
        let load = LoadSample {
            q: sample.q,
            load_torque: sample.tau - self.arm.torque_at_rest(&mut data, &sample.q),
        };
        let thresholds = nalgebra::SVector::from(self.persistent(|s| s.thresholds));
        let hypothesis = self.persistent(|s| {
            let u = s.unknown_payload.as_mut()?;
            u.samples.push(load);
            let h = fit_hypothesis(
                &self.model,
                u.declaration,
                &u.samples,
                &thresholds,
                &u.bounds,
            )?;
            u.hypothesis = Some(h);
            Some(h)
        });
        let Some(h) = hypothesis else { return };
        if !h.consistent {
            tracing::warn!(
                samples = h.samples,
                misfit_nm = ?h.worst_misfit.as_slice(),
                "no flange load explains the static samples: a contact across the poses"
            );
        }
        if let Err(e) = self.send(CycleRequest::PayloadHypothesis(h)) {
            tracing::warn!(error = %e.message, "the refitted payload hypothesis did not reach the loop");
        }
    }

    /// `estimate-payload`'s entry into the mode: when the monitor is armed, the payload is not
    /// declared unknown yet and the residual at rest on some joint is more than
    /// [`UNEXPLAINED_SHARE`] of its threshold, the applied payload does not explain it; the
    /// estimate then runs in the unknown-payload mode with the configured bounds. Never while
    /// the arm is held or a contact is detected: what tripped the monitor is resolved by the
    /// operator (`expect-payload`, `resume`), not reclassified as a payload by a workflow.
    pub(crate) async fn expect_payload_when_unexplained(
        &self,
        origin: &Origin,
    ) -> Result<(), OperatorError> {
        let (armed, active, thresholds) =
            self.persistent(|s| (s.armed, s.unknown_payload.is_some(), s.thresholds));
        if !armed || active {
            return Ok(());
        }
        let started = tokio::time::Instant::now();
        let residual = loop {
            let latest = self.latest()?;
            if latest.state.is_held() || latest.collision() {
                return Ok(());
            }
            if latest.residual_valid() {
                break latest.robot.residual;
            }
            if started.elapsed() > RESIDUAL_WAIT {
                // No valid residual to judge (the monitor keeps restarting): unknown it is.
                break [f64::INFINITY; 7];
            }
            tokio::time::sleep(Duration::from_millis(10)).await;
        };
        let unexplained = (0..7).find(|&j| residual[j].abs() > UNEXPLAINED_SHARE * thresholds[j]);
        if let Some(j) = unexplained {
            tracing::warn!(
                joint = j + 1,
                residual_nm = residual[j],
                "the applied payload does not explain the residual: estimating in the unknown-payload mode"
            );
            let c = &self.config.unknown_payload;
            // The payload is held already: no grasp window, its load is pinned at once.
            let timing = GraspTiming {
                grasp_window_s: 0.0,
                ..c.timing()
            };
            self.declare_unknown_payload(
                FlangeLoadBounds {
                    max_mass_kg: c.max_mass_kg,
                    radius_m: c.max_radius_m,
                },
                timing,
                DeclaredBy::EstimatePayload,
                origin,
            )?;
        }
        Ok(())
    }
}
