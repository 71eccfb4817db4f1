//! The check of `apply-payload` (issue 34, item 5): the declared payload's gravity torques at the
//! current pose against the static torques measured at rest beyond the unloaded arm
//! (`estimator::payload_check`, docs/collision-detection.md §4.1).
//!
//! One window of `[estimation] settle_window_s + average_s` of the loop's states, all taken
//! after the request arrived, is averaged: the arm must be at rest over all of it (every joint's
//! mean velocity below `settle_velocity`, its torque scatter below `settle_torque_std`). The
//! unloaded torque at that pose comes from, in this order:
//! 1. the stored tare's sample at this pose (within the tare tolerance, no controller restart
//!    since), moved to the exact pose with the arm model; σ: the two samples' standard errors and
//!    the drift `[estimation] drift_rate`·√(time since the tare);
//! 2. the identified arm's g(q) plus offsets (`robot.calibration`); σ: `untared_offset_std`, at
//!    least the arm's held-out residual RMS;
//! 3. the controller's gravity vector; σ: `untared_offset_std` (its stated model error).
//!
//! A joint whose difference exceeds k·σ ([`estimator::payload_check::SIGMAS`]) refuses the
//! payload with both figures.

use std::time::Duration;

use dynamics::Data;
use estimator::payload_check::{
    AtRest, Baseline, BaselineKind, Declared, RestLimits, SIGMAS, Verdict, check,
};
use fri_api::results::{PayloadBaseline, PayloadComparison, PayloadRefusal};
use nalgebra::SVector;
use tokio::sync::broadcast::error::RecvError;

use super::tare_epoch::restart_since;
use crate::persistence::{AppliedPayload, Tare};
use crate::service::core::ServiceCore;
use crate::service::settle::{AveragedSample, Averager};
use crate::service::stream::Update;

type V7 = SVector<f64, 7>;

impl ServiceCore {
    /// Measures the arm at rest now and compares `p` with it: `Ok` with both figures when every
    /// joint agrees within k·σ, else the refusal.
    pub(crate) async fn check_payload(
        &self,
        p: &AppliedPayload,
    ) -> Result<PayloadComparison, PayloadRefusal> {
        let sample = self.rest_window().await?;
        let s = &sample.sample;
        let Some(evidence) = s.evidence else {
            return Err(no_measurement("the window carries no statistics"));
        };
        let at_rest = AtRest {
            q: s.q,
            tau: s.tau,
            tau_sem: evidence.tau_sem,
            tau_std: evidence.tau_std,
            speed: s.qd.map_or(V7::repeat(f64::INFINITY), |v| v.abs()),
        };
        let e = &self.config.estimation;
        let limits = RestLimits {
            max_speed: e.settle_velocity,
            max_torque_std: e.settle_torque_std,
        };
        let baseline = self.payload_baseline(&sample);
        let declared = Declared {
            mass: p.mass,
            com: p.com,
        };
        let verdict = check(
            &self.model,
            &at_rest,
            &limits,
            baseline.as_ref().ok(),
            &declared,
            SIGMAS,
        );
        match verdict {
            Verdict::Agrees(c) => Ok(comparison(&c)),
            Verdict::Disagrees(c) => Err(PayloadRefusal::Disagrees {
                comparison: comparison(&c),
            }),
            Verdict::NotAtRest {
                joint,
                speed,
                max_speed,
                torque_std,
                max_torque_std,
            } => Err(PayloadRefusal::NotAtRest {
                joint: joint + 1,
                speed_rad_s: speed,
                limit_rad_s: max_speed,
                torque_std_nm: torque_std,
                limit_torque_std_nm: max_torque_std,
            }),
            Verdict::NoBaseline => Err(PayloadRefusal::NoBaseline {
                reason: baseline.err().unwrap_or_default(),
            }),
            Verdict::NotFinite(what) => Err(no_measurement(&format!("{what} is not finite"))),
        }
    }

    /// One averaged window of `settle_window_s + average_s` of states that all arrived after
    /// this call (a lag of this reader starts it over); bounded in wall time.
    async fn rest_window(&self) -> Result<AveragedSample, PayloadRefusal> {
        self.latest().map_err(|e| no_measurement(&e.message))?;
        let e = &self.config.estimation;
        let cycle_s = self.config.fri.cycle_s;
        let cycles = (((e.settle_window_s + e.average_s) / cycle_s).round() as usize).max(2);
        let limit = Duration::from_secs_f64(cycles as f64 * cycle_s)
            + self.connection_timeout()
            + Duration::from_secs(2);
        let mut updates = self.shared.subscribe();
        let collect = async {
            let mut avg = Averager::new(cycles);
            while avg.len() < cycles {
                match updates.recv().await {
                    Ok(Update::Snapshot(s)) => avg.push(&s.robot),
                    Ok(Update::Event(_)) => {}
                    Err(RecvError::Lagged(_)) => avg = Averager::new(cycles),
                    Err(RecvError::Closed) => {
                        return Err(no_measurement("the FRI loop has stopped"));
                    }
                }
            }
            avg.finish(cycle_s)
                .ok_or_else(|| no_measurement("an empty window"))
        };
        match tokio::time::timeout(limit, collect).await {
            Ok(r) => r,
            Err(_) => Err(no_measurement(&format!(
                "fewer than {cycles} states arrived within {:.1} s",
                limit.as_secs_f64()
            ))),
        }
    }

    /// The unloaded torque at the sample's pose with its σ (see the module documentation), or
    /// why there is none.
    fn payload_baseline(&self, sample: &AveragedSample) -> Result<Baseline<7>, String> {
        let s = &sample.sample;
        let e = &self.config.estimation;
        let tare = self.persistent(|st| st.tare.clone());
        let mut why_not_tare = "no stored tare".to_owned();
        if let Some(t) = &tare {
            match self.tare_baseline(t, s) {
                Ok(b) => return Ok(b),
                Err(why) => why_not_tare = why,
            }
        }
        if self.arm.identified_arm().is_some() {
            let mut data = Data::new(&self.model);
            let sigma = self.arm.model_offset_std(e.untared_offset_std);
            return Ok(Baseline {
                kind: BaselineKind::IdentifiedArm,
                tau: self.arm.torque_at_rest(&mut data, &s.q),
                sigma: V7::repeat(sigma),
            });
        }
        let gravity = s.gravity;
        if gravity.iter().all(|g| g.is_finite()) && gravity.iter().any(|g| *g != 0.0) {
            return Ok(Baseline {
                kind: BaselineKind::ControllerGravity,
                tau: gravity,
                sigma: V7::repeat(e.untared_offset_std),
            });
        }
        Err(format!(
            "{why_not_tare}, no identified arm (robot.calibration) and the controller sends no gravity vector: run `tare` at this pose"
        ))
    }

    /// The tare's sample at the pose of `s` moved to it exactly, or why it does not serve.
    fn tare_baseline(
        &self,
        tare: &Tare,
        s: &estimator::StaticSample<7>,
    ) -> Result<Baseline<7>, String> {
        let now = self.clocks();
        if let Some(restart) = restart_since(tare, now, self.session_mark()) {
            return Err(format!("the stored tare predates a restart ({restart})"));
        }
        let tolerance = estimator::correction::DEFAULT_TARE_TOLERANCE;
        let distance = |u: &estimator::StaticSample<7>| (u.q - s.q).abs().max();
        let Some(near) = tare
            .samples
            .iter()
            .filter(|u| u.evidence.is_some())
            .min_by(|a, b| distance(a).total_cmp(&distance(b)))
            .filter(|u| distance(u) < tolerance)
        else {
            return Err(format!(
                "the stored tare has no sample within {tolerance} rad of this pose"
            ));
        };
        let since_s = match (tare.clock, now) {
            (Some(then), Some(now)) if now.controller_s >= then.controller_s => {
                now.controller_s - then.controller_s
            }
            _ => match tare.taken_unix_s {
                Some(t) => std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(f64::INFINITY, |d| (d.as_secs_f64() - t).max(0.0)),
                None => return Err("the stored tare carries no time".to_owned()),
            },
        };
        let e = &self.config.estimation;
        let mut data = Data::new(&self.model);
        let moved =
            self.arm.torque_at_rest(&mut data, &s.q) - self.arm.torque_at_rest(&mut data, &near.q);
        let sem = near.evidence.map_or(V7::zeros(), |ev| ev.tau_sem);
        let drift = e.drift_rate.powi(2) * since_s;
        Ok(Baseline {
            kind: BaselineKind::Tare,
            tau: near.tau + moved,
            sigma: sem.map(|x| (x * x + drift).sqrt()),
        })
    }
}

fn no_measurement(reason: &str) -> PayloadRefusal {
    PayloadRefusal::NoMeasurement {
        reason: reason.to_owned(),
    }
}

fn comparison(c: &estimator::payload_check::Comparison<7>) -> PayloadComparison {
    let array = |v: &V7| std::array::from_fn(|j| v[j]);
    PayloadComparison {
        baseline: match c.baseline {
            BaselineKind::Tare => PayloadBaseline::Tare,
            BaselineKind::IdentifiedArm => PayloadBaseline::IdentifiedArm,
            BaselineKind::ControllerGravity => PayloadBaseline::ControllerGravity,
        },
        predicted_nm: array(&c.predicted),
        measured_nm: array(&c.measured),
        sigma_nm: array(&c.sigma),
        sigmas: c.sigmas,
        joint: c.worst_joint + 1,
        mass_implied_kg: c.mass_implied,
        mass_implied_std_kg: c.mass_implied_std,
    }
}
