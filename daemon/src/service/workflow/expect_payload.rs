//! `expect-payload`: the payload is about to be grasped (or is held) and is unknown. The loop's
//! monitor stays armed and detects against what a plausible flange load explains
//! (`safety::PayloadTolerance`); after every static sample of a workflow the load is refitted
//! here and the hypothesis handed to the loop. `estimate-payload --apply`, `apply-payload` and
//! `clear-payload` end the mode (the loop ends it in the cycle that installs the payload), and
//! so does `expect-payload` with `end`.
//!
//! `estimate-payload` enters the mode itself when the applied payload does not explain the
//! residual at its start ([`UNEXPLAINED_SHARE`]).

use std::time::Duration;

use dynamics::{Data, compute_generalized_gravity};
use fri_api::origin::Origin;
use fri_api::protocol::{ErrorCode, OperatorError};
use fri_api::results::{Change, DeclaredBy, ExpectPayloadResult, UnknownPayload};
use safety::{FlangeLoadBounds, LoadSample, PayloadHypothesis, fit_hypothesis};

use crate::persistence::StaticSample;
use crate::service::core::{ServiceCore, err};
use crate::service::cycle::CycleRequest;

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

/// The unknown-payload mode as the operator side keeps it.
#[derive(Debug, Clone)]
pub(crate) struct UnknownPayloadState {
    /// Number of the declaration (the loop refuses hypotheses of other ones).
    pub(crate) declaration: u32,
    /// Who declared it.
    pub(crate) declared_by: DeclaredBy,
    /// Whose request declared it.
    pub(crate) origin: Origin,
    /// What the payload may be.
    pub(crate) bounds: FlangeLoadBounds,
    /// Static samples since the declaration.
    pub(crate) samples: Vec<LoadSample<7>>,
    /// The last hypothesis handed to the loop.
    pub(crate) hypothesis: Option<PayloadHypothesis<7>>,
}

impl UnknownPayloadState {
    fn report(&self) -> UnknownPayload {
        let h = self.hypothesis.as_ref();
        UnknownPayload {
            declared_by: self.declared_by,
            origin: Some(self.origin.clone()),
            max_mass: self.bounds.max_mass_kg,
            max_radius: self.bounds.radius_m,
            samples: self.samples.len(),
            mass: h.map(PayloadHypothesis::mass_kg),
            com: h.and_then(PayloadHypothesis::com).map(|c| [c.x, c.y, c.z]),
            consistent: h.is_none_or(|h| h.consistent),
        }
    }
}

impl ServiceCore {
    /// `expect-payload`: declares the payload unknown with the given bounds (defaults from
    /// `[unknown_payload]`), or with `end` leaves the mode.
    pub fn expect_payload(
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
        self.declare_unknown_payload(bounds, DeclaredBy::Operator, origin)?;
        Ok(ExpectPayloadResult {
            unknown_payload: self.unknown_payload_status(),
        })
    }

    /// Starts (or restarts, forgetting earlier samples) the unknown-payload mode.
    fn declare_unknown_payload(
        &self,
        bounds: FlangeLoadBounds,
        declared_by: DeclaredBy,
        origin: &Origin,
    ) -> Result<(), OperatorError> {
        let declaration = self.persistent(|s| {
            s.declarations = s.declarations.wrapping_add(1);
            s.declarations
        });
        self.send(CycleRequest::ExpectPayload {
            declaration,
            bounds,
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
        Ok(())
    }

    /// The unknown-payload mode for `status` (`None`: the applied payload is the payload).
    pub(crate) fn unknown_payload_status(&self) -> Option<UnknownPayload> {
        self.persistent(|s| s.unknown_payload.as_ref().map(UnknownPayloadState::report))
    }

    /// The workflows' hook after each static sample: while the payload is unknown, refits the
    /// flange load to every sample since the declaration and hands the hypothesis to the loop.
    /// Data: the residual at rest without the compensation, z = τ_J − g(q) of the observer's
    /// own unloaded model. Never fails the workflow: without the new hypothesis the loop keeps
    /// the previous one, which can only make it stricter.
    pub(crate) fn unknown_payload_sampled(&self, sample: &StaticSample) {
        let mut data = Data::new(&self.model);
        let load = LoadSample {
            q: sample.q,
            load_torque: sample.tau
                - compute_generalized_gravity(&self.model, &mut data, &sample.q),
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
            self.declare_unknown_payload(
                FlangeLoadBounds {
                    max_mass_kg: c.max_mass_kg,
                    radius_m: c.max_radius_m,
                },
                DeclaredBy::EstimatePayload,
                origin,
            )?;
        }
        Ok(())
    }
}
