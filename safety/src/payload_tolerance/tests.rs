//! The grasp, the pin and the expiry of [`PayloadTolerance`], cycle by cycle at rest.

use super::*;
use dynamics::payload_gravity_regressor;
use plausible::TEST_BOUNDS;

type V7 = SVector<f64, 7>;
const T: f64 = 1e-3;

/// A tolerance at the pick pose, at rest, with nothing applied to the observer.
struct Bench {
    tolerance: PayloadTolerance<7>,
    y: nalgebra::SMatrix<f64, 7, 4>,
    q: V7,
    now: f64,
}

impl Bench {
    fn new() -> Self {
        let model = dynamics::lwr4();
        let mut data = Data::new(&model);
        let q = V7::from(dynamics::LWR4_PICK_POSE_RAD);
        Self {
            y: payload_gravity_regressor(&model, &mut data, &q),
            tolerance: PayloadTolerance::new(&model),
            q,
            now: 0.0,
        }
    }

    /// One cycle with the load `theta` on the flange plus the external torque `contact`:
    /// what the detector sees, and whether the mode expired.
    fn cycle(&mut self, theta: &Vector4<f64>, contact: &V7) -> (V7, Option<u32>) {
        self.now += T;
        let expired = self.tolerance.advance(self.now);
        // The residual at rest: τ_ext = −(load torque) + contact, nothing compensated.
        let residual = -(self.y * theta) + contact;
        let seen = self.tolerance.contact_residual(
            &self.q,
            &V7::zeros(),
            &residual,
            &Vector4::zeros(),
            &V7::repeat(6.0),
        );
        (seen, expired)
    }

    fn run(&mut self, seconds: f64, theta: &Vector4<f64>, contact: &V7) -> f64 {
        let mut peak: f64 = 0.0;
        for _ in 0..(seconds / T).round() as usize {
            peak = peak.max(self.cycle(theta, contact).0.amax());
        }
        peak
    }
}

fn payload(m: f64) -> Vector4<f64> {
    Vector4::new(m, 0.0, 0.0, m * 0.12)
}

/// A push of `newtons` down on the flange point, as a load: a point mass there.
fn push_down(newtons: f64) -> Vector4<f64> {
    let m = newtons / 9.81;
    Vector4::new(m, 0.0, 0.0, m * 0.078)
}

#[test]
fn a_grasp_is_pinned_once_settled_and_a_later_push_down_is_seen_whole() {
    let mut b = Bench::new();
    b.tolerance
        .declare(1, TEST_BOUNDS, GraspTiming::default(), 0.0)
        .unwrap();
    assert!(b.run(0.5, &Vector4::zeros(), &V7::zeros()) < 1e-9);
    // Grasped over 0.3 s, then static: tolerated throughout, pinned 0.5 s after.
    for k in 0..300 {
        let (seen, _) = b.cycle(&payload(3.0 * f64::from(k) / 300.0), &V7::zeros());
        assert!(seen.amax() < 1e-6, "{seen}");
    }
    assert!(b.tolerance.pinned().is_none());
    // Pinned to the settled load: what is left of the grasp's tail is far below the noise.
    assert!(b.run(0.6, &payload(3.0), &V7::zeros()) < 1e-3);
    let pin = *b.tolerance.pinned().expect("pinned once settled");
    assert_eq!(pin.source, PinSource::Settled);
    assert!((pin.mass_kg() - 3.0).abs() < 1e-4, "{pin:?}");
    // 15 N down on the flange: before the pin a heavier payload, now the whole push (the
    // detector sees e = Y θ_pin − z: a load added to z with the opposite sign).
    let push = b.y * push_down(15.0);
    let (seen, _) = b.cycle(&(payload(3.0) + push_down(15.0)), &V7::zeros());
    assert!((seen + push).amax() < 1e-3, "{seen} vs {push}");
    assert!(seen.amax() > 6.0, "{seen}");
}

#[test]
fn without_a_grasp_the_window_end_pins_the_load_held_since_the_declaration() {
    let mut b = Bench::new();
    let timing = GraspTiming {
        grasp_window_s: 2.0,
        ..GraspTiming::default()
    };
    b.tolerance.declare(4, TEST_BOUNDS, timing, 0.0).unwrap();
    // 35 N down within the window looks like a heavier payload (tolerated)...
    assert!(b.run(1.0, &payload(3.028), &V7::zeros()) < 1e-6);
    assert!(b.run(0.2, &(payload(3.028) + push_down(35.0)), &V7::zeros()) < 1e-6);
    assert!(b.run(0.9, &payload(3.028), &V7::zeros()) < 1e-6);
    let pin = *b.tolerance.pinned().expect("pinned at the window's end");
    assert_eq!(pin.source, PinSource::GraspWindow);
    assert!((pin.at_s - 2.0).abs() < 2.0 * T, "{pin:?}");
    assert!((pin.mass_kg() - 3.028).abs() < 1e-6, "{pin:?}");
    // ...after it, 15 N and 35 N down and a 20 N lift are seen whole.
    for newtons in [15.0, 35.0, -20.0] {
        let (seen, _) = b.cycle(&(payload(3.028) + push_down(newtons)), &V7::zeros());
        let push = b.y * push_down(newtons);
        assert!(
            (seen + push).amax() < 1e-6,
            "{newtons} N: {seen:?} vs {push:?}"
        );
        assert!(seen.amax() > 6.0, "{newtons} N: {seen:?}");
    }
}

#[test]
fn samples_repin_the_load_and_restart_the_expiry_and_the_mode_expires() {
    let mut b = Bench::new();
    let timing = GraspTiming {
        grasp_window_s: 0.0,
        settle_s: 0.5,
        expire_s: 3.0,
    };
    b.tolerance.declare(7, TEST_BOUNDS, timing, 0.0).unwrap();
    b.run(0.01, &payload(2.0), &V7::zeros());
    assert_eq!(
        b.tolerance.pinned().map(|p| p.source),
        Some(PinSource::GraspWindow),
        "a zero window pins at once"
    );
    let sample = LoadSample {
        q: b.q,
        load_torque: b.y * payload(2.0),
    };
    let model = dynamics::lwr4();
    let h = fit_hypothesis(&model, 7, &[sample], &V7::repeat(6.0), &TEST_BOUNDS).unwrap();
    b.run(2.0, &payload(2.0), &V7::zeros());
    assert!(b.tolerance.set_hypothesis(h));
    assert_eq!(
        b.tolerance.pinned().map(|p| p.source),
        Some(PinSource::Samples(1))
    );
    let expires = b.tolerance.status().unwrap().expires_at_s;
    assert!((expires - (b.now + 3.0)).abs() < 1e-9, "{expires}");
    // A hypothesis of another declaration changes nothing.
    let mut stale = h;
    stale.declaration = 6;
    assert!(!b.tolerance.set_hypothesis(stale));
    // Expiry: the mode ends and the detector sees the residual itself.
    let mut expired = None;
    let mut seen = V7::zeros();
    for _ in 0..3100 {
        let (s, e) = b.cycle(&payload(2.0), &V7::zeros());
        seen = s;
        expired = expired.or(e);
    }
    assert_eq!(expired, Some(7));
    assert!(!b.tolerance.is_active());
    assert_eq!(b.tolerance.last_end(), Some((7, ModeEnd::Expired)));
    assert!((seen + b.y * payload(2.0)).amax() < 1e-9, "{seen}");
}

/// Issue 34 item 1: `expect-payload` repeated every 6.5 s hid a 30 N push for ever (each
/// declaration reopened the grasp window and dropped the pin). A declaration while one is
/// active is refused: the pin, the window's end and the expiry stay, and the push is seen.
#[test]
fn a_declaration_while_one_is_active_keeps_the_pin_and_the_expiry() {
    let mut b = Bench::new();
    let timing = GraspTiming {
        grasp_window_s: 2.0,
        settle_s: 0.5,
        expire_s: 30.0,
    };
    b.tolerance.declare(1, TEST_BOUNDS, timing, 0.0).unwrap();
    b.run(2.1, &payload(3.0), &V7::zeros());
    let pinned = *b.tolerance.pinned().expect("pinned at the window's end");
    let status = b.tolerance.status().unwrap();
    for (k, id) in (2..6).enumerate() {
        b.run(1.5, &payload(3.0), &V7::zeros());
        assert_eq!(
            b.tolerance.declare(id, TEST_BOUNDS, timing, b.now),
            Err(ConfigError::AlreadyDeclared { active: 1 }),
            "renewal {k}"
        );
        assert_eq!(b.tolerance.pinned(), Some(&pinned));
        assert_eq!(b.tolerance.status(), Some(status));
        // 30 N down on the flange is seen whole right after every attempt.
        let (seen, _) = b.cycle(&(payload(3.0) + push_down(30.0)), &V7::zeros());
        assert!(seen.amax() > 6.0, "renewal {k}: {seen}");
    }
    // Ended, a new declaration is taken (the service bounds how often: docs §8).
    b.tolerance.end(ModeEnd::Ended);
    b.tolerance.declare(9, TEST_BOUNDS, timing, b.now).unwrap();
    assert_eq!(b.tolerance.declaration().map(|d| d.0), Some(9));
}
