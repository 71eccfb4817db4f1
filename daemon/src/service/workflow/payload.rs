//! `apply-payload` / `clear-payload`: install a payload in the observer (paper eq. 48),
//! persist it and publish it. `apply-payload` checks the declared payload against the static
//! torques measured at rest first ([`super::payload_check`]).

use fri_api::cause::Cause;
use fri_api::origin::Origin;
use fri_api::results::{Change, PayloadRefusal, PayloadResult};

use super::status::applied;

use crate::ipc::PayloadEstimate as IpcPayload;
use crate::persistence::AppliedPayload;
use crate::service::core::{ServiceCore, compensation, err};
use crate::service::cycle::CycleRequest;
use fri_api::protocol::{ErrorCode, OperatorError};

impl ServiceCore {
    /// A payload's centre of mass must lie within `[estimation] max_com_distance_m` of the
    /// flange point, as an estimate's must (`estimator::verdict`): a payload the flange holds
    /// cannot have it farther. The mass is the operator's statement and keeps its own range.
    fn check_reach(&self, p: &AppliedPayload) -> Result<(), OperatorError> {
        if p.mass <= 0.0 {
            return Ok(());
        }
        let com7 = nalgebra::Point3::from(nalgebra::Vector3::from(p.com));
        let c = self.model.flange().inverse_transform_point(&com7).coords;
        let distance = estimator::verdict::com_distance_from_flange(&[c.x, c.y, c.z]);
        let reach =
            fri_api::bounds::Range::new(0.0, self.config.estimation.max_com_distance_m, "m");
        reach
            .check("com (distance from the flange point)", distance)
            .map_err(|e| {
                let mut e = OperatorError::out_of_range(e);
                e.message = format!(
                    "{} ([estimation] max_com_distance_m): a payload held by the flange has its centre of mass within reach; com is in frame 7, whose origin lies {:.0} mm behind the flange point",
                    e.message,
                    self.model.flange().translation.vector.norm() * 1e3
                );
                e
            })
    }

    /// The range and reach checks of a payload to install (any origin).
    fn validate(&self, p: &AppliedPayload) -> Result<(), OperatorError> {
        let ok = p.mass.is_finite()
            && p.mass >= 0.0
            && p.mass <= 20.0
            && p.com.iter().all(|c| c.is_finite() && c.abs() <= 1.0);
        if !ok {
            return Err(err(
                ErrorCode::InvalidArguments,
                "mass must be in [0, 20] kg and each com coordinate in [-1, 1] m",
            ));
        }
        self.check_reach(p)
    }

    /// `apply-payload`: the declared payload is checked against the static torques measured at
    /// rest ([`ServiceCore::check_payload`]); refused with both figures unless `force`, which
    /// applies it and audits the refusal it overrode as a weakening. Then to the observer and
    /// persisted.
    pub async fn apply_payload(
        &self,
        p: AppliedPayload,
        force: bool,
        origin: &Origin,
    ) -> Result<PayloadResult, OperatorError> {
        self.validate(&p)?;
        let (check, forced_past) = match self.check_payload(&p).await {
            Ok(c) => (Some(c), None),
            Err(refusal) if force => {
                tracing::warn!(%origin, %refusal, mass = p.mass, "apply-payload FORCED past its check");
                let check = match &refusal {
                    PayloadRefusal::Disagrees { comparison } => Some(*comparison),
                    _ => None,
                };
                (check, Some(refusal))
            }
            Err(refusal) => return Err(refused(&p, refusal)),
        };
        let mut result = self.install_payload(Some(p), forced_past.clone(), origin)?;
        result.check = check;
        result.forced_past = forced_past;
        Ok(result)
    }

    /// `clear-payload`: nothing is compensated any more (not checked: a load still carried
    /// then shows as a residual, which the monitor reacts to).
    pub fn clear_payload(&self, origin: &Origin) -> Result<PayloadResult, OperatorError> {
        self.install_payload(None, None, origin)
    }

    /// Installs `p` in the observer and persists it, unchecked against the measured torques (an
    /// estimate's `apply` comes from them); `forced_past` is the check's refusal a `force`
    /// overrode, for the audit trail.
    pub(crate) fn install_payload(
        &self,
        p: Option<AppliedPayload>,
        forced_past: Option<PayloadRefusal>,
        origin: &Origin,
    ) -> Result<PayloadResult, OperatorError> {
        if let Some(p) = &p {
            self.validate(p)?;
        }
        self.send(CycleRequest::SetPayload(p.as_ref().map(compensation)))?;
        self.store.save_payload(p.as_ref()).map_err(|e| {
            err(
                ErrorCode::Internal,
                format!("payload applied but not persisted: {e}"),
            )
        })?;
        // The loop ended the unknown-payload mode with this payload (same request).
        let was_unknown = self.persistent(|s| {
            if p.is_some_and(|p| p.mass > 0.0) {
                // A payload with mass is known: the next grasp may be declared again.
                s.declarations_without_payload = 0;
            }
            s.payload = p;
            s.payload_origin = p.map(|_| origin.clone());
            s.unknown_payload.take().is_some()
        });
        self.audit.record(
            origin,
            match &p {
                Some(p) => Change::PayloadApplied {
                    mass: p.mass,
                    com: p.com,
                    forced_past,
                },
                None => Change::PayloadCleared,
            },
        );
        if was_unknown {
            self.audit.record(
                origin,
                Change::UnknownPayloadEnded {
                    reason: if p.is_some() { "applied" } else { "cleared" }.to_owned(),
                },
            );
        }
        if let Some(ipc) = &self.ipc {
            let latest = self.shared.latest();
            ipc.payload(&IpcPayload {
                time_s: latest.map_or(0.0, |s| s.robot.time_s),
                mass: p.map_or(0.0, |p| p.mass),
                com: p.map_or([0.0; 3], |p| p.com),
                applied: u32::from(p.is_some()),
                ..IpcPayload::default()
            });
        }
        Ok(PayloadResult {
            payload: p.as_ref().map(applied),
            check: None,
            forced_past: None,
        })
    }
}

/// The refusal of `p`: `invalid-arguments` when its torques disagree (the declaration is
/// wrong), `not-ready` when nothing could be compared; the message names the fields and the
/// figures, the cause carries them.
fn refused(p: &AppliedPayload, refusal: PayloadRefusal) -> OperatorError {
    let code = match refusal {
        PayloadRefusal::Disagrees { .. } => ErrorCode::InvalidArguments,
        _ => ErrorCode::NotReady,
    };
    let (what, todo) = match refusal {
        PayloadRefusal::Disagrees { .. } => (
            "does not agree with",
            "Check the payload's data or measure it (`estimate-payload`)",
        ),
        _ => (
            "cannot be checked against",
            "Let the arm rest (or `tare` at this pose) and send it again",
        ),
    };
    err(
        code,
        format!(
            "apply-payload refused, nothing applied: mass = {} kg with com = ({}, {}, {}) m in frame 7 {what} the static torques measured at rest: {refusal}. {todo}; `force` (fri-ctl apply-payload --force) applies it anyway and the audit trail records it as weakening",
            p.mass, p.com[0], p.com[1], p.com[2]
        ),
    )
    .with_cause(Cause::PayloadImplausible { refusal })
}
