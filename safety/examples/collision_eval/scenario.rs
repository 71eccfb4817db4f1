//! Random motions and contact geometry shared by the campaigns.

use dynamics::{Data, Model};
use nalgebra::Vector3;
use rand::Rng;
use rand::rngs::StdRng;

use crate::support::{V7, random_configuration};

/// Random waypoints within 60 % of the joint ranges, joint 2 kept away from the stretched
/// singularity, and the elbow bent.
pub fn random_waypoints(rng: &mut StdRng, n: usize) -> Vec<V7> {
    (0..n)
        .map(|_| {
            let mut q = random_configuration(rng, 0.6);
            q[1] = q[1].signum() * q[1].abs().max(0.3);
            q[3] = -(q[3].abs().max(0.4));
            q
        })
        .collect()
}

/// A random contact point on link `link` (0-based) in its DH frame and a force direction
/// pushing mostly into the surface.
pub fn random_contact_geometry(rng: &mut StdRng, link: usize) -> (Vector3<f64>, Vector3<f64>) {
    // Bone segment (from, to) and surface radius per link, in the link's DH frame.
    let (from, to, radius) = match link {
        0 => (
            Vector3::new(0.0, 0.0, -0.15),
            Vector3::new(0.0, 0.0, -0.05),
            0.07,
        ),
        1 => (
            Vector3::new(0.0, 0.0, 0.05),
            Vector3::new(0.0, 0.0, 0.2),
            0.07,
        ),
        2 => (
            Vector3::new(0.0, 0.05, 0.0),
            Vector3::new(0.0, 0.18, 0.0),
            0.07,
        ),
        3 => (
            Vector3::new(0.0, 0.0, 0.08),
            Vector3::new(0.0, 0.0, 0.25),
            0.065,
        ),
        4 => (
            Vector3::new(0.0, -0.05, 0.0),
            Vector3::new(0.0, -0.18, 0.0),
            0.06,
        ),
        5 => (
            Vector3::new(0.0, 0.03, -0.05),
            Vector3::new(0.0, 0.08, -0.04),
            0.05,
        ),
        _ => (
            Vector3::new(0.0, 0.0, 0.08),
            Vector3::new(0.0, 0.0, 0.2),
            0.05,
        ),
    };
    let axis = (to - from).normalize();
    let s: f64 = rng.random_range(0.0..1.0);
    let radial = loop {
        let v = random_unit(rng);
        let perp = v - axis * axis.dot(&v);
        if perp.norm() > 0.2 {
            break perp.normalize();
        }
    };
    let point = from + (to - from) * s + radial * radius;
    let direction = (-radial + random_unit(rng) * 0.7).normalize();
    (point, direction)
}

/// Contact force direction from the link frame into the base frame at configuration q.
pub fn to_base(model: &Model<7>, q: &V7, link: usize, v: &Vector3<f64>) -> Vector3<f64> {
    let mut data = Data::new(model);
    let frames = dynamics::forward_kinematics(model, &mut data, q);
    frames[link].rotation * v
}

/// A random unit vector (rejection sampling in the unit ball, norms in (0.1, 1]).
pub fn random_unit(rng: &mut StdRng) -> Vector3<f64> {
    loop {
        let v = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if v.norm() > 0.1 && v.norm() <= 1.0 {
            break v.normalize();
        }
    }
}
