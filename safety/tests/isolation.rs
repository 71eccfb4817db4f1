//! Detection, isolation and identification of contacts on a simulated LWR 4+ at rest.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod support;

use dynamics::{Data, lwr4, point_jacobian};
use nalgebra::Vector3;
use safety::{
    CollisionMonitor, Detection, MonitorConfig, ObserverInput, ReactionRequest, StopCause,
    isolation::estimate_contact_force,
};
use support::*;

const T: f64 = 1e-3;

fn pose() -> V7 {
    V7::from_column_slice(&[0.2, 0.7, -0.3, -1.3, 0.4, 0.9, 0.3])
}

/// Direction of the force at `point` on `link` that produces the largest torque on joint `link`.
fn tangential_direction(link: usize, point: &Vector3<f64>) -> Vector3<f64> {
    let model = lwr4();
    let mut data = Data::new(&model);
    let j = point_jacobian(&model, &mut data, &pose(), link, point);
    j.fixed_view::<3, 1>(0, link).normalize()
}

struct Outcome {
    onset: Option<safety::CollisionEvent<7>>,
    /// Refined isolation reported when the contact ended.
    episode_link: Option<usize>,
    /// Residual 0.3 s (30/K) after the contact started.
    converged: V7,
    first_request: Option<ReactionRequest<7>>,
    /// Monitor's last-link wrench estimate at the same time (contact point = true point).
    wrench: Option<nalgebra::Vector6<f64>>,
}

/// Runs a box contact of `force_n` N from 0.1 s to 0.45 s and records what the monitor reports.
fn run(link: usize, point: Vector3<f64>, force_n: f64) -> Outcome {
    let model = lwr4();
    let q0 = pose();
    let mut plant = Plant::new(model.clone(), q0, Integrator::SemiImplicitEuler);
    let mut controller = Impedance::new(model.clone(), default_stiffness(), &model, &q0, 0.7);
    let hold = Hold(q0);
    let mut config = MonitorConfig::new(T, 100.0);
    config.observer.stale_limit = None;
    config.contact_point = Some(point);
    let mut monitor = CollisionMonitor::new(model, config).unwrap();
    let contact = Contact {
        link,
        point,
        force: tangential_direction(link, &point) * force_n,
        profile: Profile::Box {
            start: 0.1,
            end: 0.45,
        },
    };
    let mut first = None;
    let mut first_request = None;
    let mut episode_link = None;
    let mut converged = V7::zeros();
    let mut wrench = None;
    for k in 0..700 {
        let t = k as f64 * T;
        let tau = controller.torque(&plant.q, &plant.qd, &hold.sample(t));
        let out = monitor.step(&ObserverInput::new(plant.q, tau, T));
        if let Some(Detection::Onset(e)) = out.detection
            && first.is_none()
        {
            first = Some(e);
        }
        if let Some(Detection::Released {
            episode_link: l, ..
        }) = out.detection
        {
            episode_link = Some(l);
        }
        if first_request.is_none() {
            first_request = out.reaction;
        }
        if k == 400 {
            converged = out.observer.residual;
            wrench = monitor.last_link_wrench(&plant.q);
        }
        plant.advance_controlled(&mut controller, &hold, T, 5, &[contact], &V7::zeros());
    }
    Outcome {
        onset: first,
        episode_link,
        converged,
        first_request,
        wrench,
    }
}

#[test]
fn contacts_are_isolated_on_the_link_that_was_hit() {
    let cases = [
        (1usize, Vector3::new(0.0, 0.0, 0.15)),
        (3, Vector3::new(0.0, -0.06, 0.2)),
        (4, Vector3::new(0.0, -0.12, 0.05)),
        (6, Vector3::new(0.0, 0.06, 0.15)),
    ];
    for (link, point) in cases {
        let outcome = run(link, point, 80.0);
        let request = outcome.first_request;
        let event = outcome
            .onset
            .unwrap_or_else(|| panic!("contact on link {link} not detected"));
        // At the onset the residual has risen only part of the way: isolation may still name a
        // more proximal link, never a more distal one; the episode isolation must be exact.
        assert!(
            event.isolated_link <= link,
            "link {link}: onset isolated {}",
            event.isolated_link
        );
        assert_eq!(
            outcome.episode_link,
            Some(link),
            "link {link}: onset r = {:?}",
            event.residual
        );
        assert!(
            event.time_s >= 0.1 && event.time_s < 0.12,
            "late onset {}",
            event.time_s
        );
        assert!(
            matches!(request, Some(ReactionRequest::Pause { cause: StopCause::Collision(_), pause_s }) if pause_s == 2.0)
        );
        assert_eq!(event.contact_wrench.is_some(), event.isolated_link == 6);
    }
}

#[test]
fn converged_last_link_force_is_identified_within_ten_percent_and_ten_degrees() {
    let point = Vector3::new(0.0, 0.06, 0.15);
    let outcome = run(6, point, 80.0);
    let residual = outcome.converged;
    let truth = tangential_direction(6, &point) * 80.0;
    let model = lwr4();
    let mut data = Data::new(&model);
    let estimate =
        estimate_contact_force(&model, &mut data, &pose(), &residual, 6, &point, 1e-3).unwrap();
    let magnitude_error = (estimate.norm() - 80.0).abs() / 80.0;
    let angle = estimate.angle(&truth).to_degrees();
    assert!(magnitude_error < 0.10, "estimate {estimate:?} vs {truth:?}");
    assert!(angle < 10.0, "direction error {angle} deg");
    // The monitor's 6-D wrench at the true contact point: same force, negligible moment.
    let wrench = outcome.wrench.unwrap();
    let force = wrench.fixed_rows::<3>(0).into_owned();
    assert!((force.norm() - 80.0).abs() < 8.0, "wrench force {force:?}");
    assert!(
        force.angle(&truth).to_degrees() < 10.0,
        "wrench force {force:?} vs {truth:?}"
    );
    assert!(
        wrench.fixed_rows::<3>(3).norm() < 1.0,
        "moment {:?}",
        wrench.fixed_rows::<3>(3)
    );
}
