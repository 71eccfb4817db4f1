//! The true arm (LWR 4+ of the shared model, plus the payload) and the controller's own model
//! (perturbed copy without the payload, lwr4-model.md §4).

use dynamics::{InertialParameters, Model};
use nalgebra::{Matrix3, Vector3};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal};

use crate::config::{ModelErrorSpec, PayloadSpec};

/// The payload's inertial parameters in DH frame 7 (wrist point).
pub fn payload_parameters(spec: &PayloadSpec) -> InertialParameters {
    let i = spec.inertia();
    let inertia = Matrix3::new(
        i[0][0], i[0][1], i[0][2], i[1][0], i[1][1], i[1][2], i[2][0], i[2][1], i[2][2],
    );
    InertialParameters::from_com(spec.mass_kg, Vector3::from(spec.com_m), inertia)
}

/// The controller's model: every link's mass and first moment perturbed by Gaussian errors
/// (σ from `spec`, seeded), inertia about the CoM kept; no payload.
pub fn perturbed_model(nominal: &Model<7>, spec: &ModelErrorSpec, seed: u64) -> Model<7> {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut normal = || -> f64 { StandardNormal.sample(&mut rng) };
    let links = nominal.links().map(|link| {
        let delta_m = normal() * spec.mass_sigma_kg;
        let delta_h = Vector3::new(normal(), normal(), normal()) * spec.first_moment_sigma_kgm;
        let mass = (link.mass + delta_m).max(0.01);
        let first_moment = link.first_moment + delta_h;
        InertialParameters::from_com(mass, first_moment / mass, link.inertia_about_com())
    });
    nominal.with_links(links)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_payload_matches_paper_and_is_physical() {
        let p = payload_parameters(&PayloadSpec::default());
        assert!((p.mass - 3.028).abs() < 1e-12);
        assert!((p.com().unwrap() - Vector3::new(0.0, 0.0, 0.119)).norm() < 1e-12);
        assert!(p.check_physical().is_ok());
    }

    #[test]
    fn perturbation_is_seeded_and_of_the_documented_size() {
        let nominal = dynamics::lwr4();
        let a = perturbed_model(&nominal, &ModelErrorSpec::default(), 4);
        let b = perturbed_model(&nominal, &ModelErrorSpec::default(), 4);
        let mut sq = 0.0;
        for i in 0..7 {
            assert_eq!(a.links()[i].mass, b.links()[i].mass);
            let d = a.links()[i].first_moment - nominal.links()[i].first_moment;
            sq += d.norm_squared();
            assert!((a.links()[i].mass - nominal.links()[i].mass).abs() < 0.1);
            assert!(a.links()[i].check_physical().is_ok());
        }
        // 21 components of σ 0.005: RMS within a factor 2.
        let rms = (sq / 21.0).sqrt();
        assert!(rms > 0.0025 && rms < 0.01, "rms {rms}");
        let exact = perturbed_model(&nominal, &ModelErrorSpec::exact(), 4);
        for i in 0..7 {
            assert!((exact.links()[i].to_vector() - nominal.links()[i].to_vector()).amax() < 1e-12);
        }
    }
}
