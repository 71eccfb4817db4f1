//! The unknown-payload mode as the operator side keeps it between requests (the service's
//! state holds it; `expect-payload` and the estimates change it): the declaration, its static
//! samples and the hypothesis handed to the loop, and how clients see it.

use fri_api::origin::Origin;
use fri_api::results::{DeclaredBy, PinnedBy, PinnedPayload, UnknownPayload};
use safety::{FlangeLoadBounds, LoadSample, PayloadHypothesis, PinSource, ToleranceStatus};

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
    /// The mode for clients, with what the loop holds of this declaration (`looped`) and the
    /// newest controller time `now_s`.
    pub(crate) fn report(
        &self,
        looped: Option<&ToleranceStatus>,
        now_s: Option<f64>,
    ) -> UnknownPayload {
        let h = self.hypothesis.as_ref();
        let looped = looped.filter(|l| l.declaration == self.declaration);
        UnknownPayload {
            declared_by: self.declared_by,
            origin: Some(self.origin.clone()),
            max_mass: self.bounds.max_mass_kg,
            max_radius: self.bounds.radius_m,
            samples: self.samples.len(),
            mass: h.map(PayloadHypothesis::mass_kg),
            com: h.and_then(PayloadHypothesis::com).map(|c| [c.x, c.y, c.z]),
            consistent: h.is_none_or(|h| h.consistent),
            declared_at_s: looped.map(|l| l.declared_at_s),
            grasp_window_end_s: looped.map(|l| l.grasp_window_end_s),
            expires_at_s: looped.map(|l| l.expires_at_s),
            expires_in_s: looped
                .zip(now_s)
                .map(|(l, now)| (l.expires_at_s - now).max(0.0)),
            pinned: looped.and_then(|l| l.pinned).map(|p| PinnedPayload {
                mass: p.mass_kg,
                com: p.com.map(|c| [c.x, c.y, c.z]),
                mass_tolerance: p.mass_tolerance_kg,
                com_tolerance: p.com_tolerance_m,
                com_height_open: p.open_directions > 0,
                by: pinned_by(p.source),
                samples: match p.source {
                    PinSource::Samples(n) => Some(n),
                    _ => None,
                },
                at_s: p.at_s,
            }),
        }
    }
}

/// What clients see of a pin's source.
pub(crate) fn pinned_by(source: PinSource) -> PinnedBy {
    match source {
        PinSource::Settled => PinnedBy::Settled,
        PinSource::GraspWindow => PinnedBy::GraspWindow,
        PinSource::Move => PinnedBy::Move,
        PinSource::Samples(_) => PinnedBy::Samples,
    }
}
