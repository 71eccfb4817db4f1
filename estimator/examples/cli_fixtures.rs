//! Writes the small CSV/JSON fixtures used by the root package's `tests/offline_cli.rs`:
//! `cargo run -p estimator --example cli_fixtures -- tests/fixtures`. Seeded, so reproducible.
//! Data: `dynamics::lwr4()` with the 3.028 kg payload at (0, 0, 0.119) m in frame 7, the
//! controller model perturbed by the example draw of lwr4-model.md §4, σ = 0.05 Nm noise.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::fs::File;
use std::path::PathBuf;

use dynamics::{InertialParameters, lwr4};
use estimator::basis::spread_poses;
use estimator::poses::paper_pattern;
use estimator::samples::write_csv;
use estimator::sim::{LWR4_EXAMPLE_PERTURBATION, perturbed_model, static_samples};
use nalgebra::{SVector, Vector3};
use rand::{Rng, SeedableRng, rngs::StdRng};
use rand_distr::Normal;

fn main() {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "tests/fixtures".into()),
    );
    std::fs::create_dir_all(&dir).unwrap();
    let model = lwr4();
    let ctrl = perturbed_model(&model, &LWR4_EXAMPLE_PERTURBATION);
    let heavy = InertialParameters::point_mass(3.028, Vector3::new(0.0, 0.0, 0.119));
    let none = InertialParameters::zero();
    let mut rng = StdRng::seed_from_u64(2017);
    let normal = Normal::new(0.0, 0.05).unwrap();
    let pick = SVector::<f64, 7>::from(dynamics::LWR4_PICK_POSE_RAD);
    let q10 = paper_pattern(&model, &pick, 7f64.to_radians(), 10);
    let write = |name: &str, s: &[estimator::samples::StaticSample<7>]| {
        write_csv(File::create(dir.join(name)).unwrap(), s).unwrap();
    };
    let loaded = static_samples(&model, &heavy, &ctrl, &q10, |_, _| rng.sample(normal));
    write("lwr4_loaded_q10.csv", &loaded);
    let tare = static_samples(&model, &none, &ctrl, &q10, |_, _| rng.sample(normal));
    write("lwr4_tare_q10.csv", &tare);
    let lim = model.limits();
    let ws = spread_poses(&(lim.position_min * 0.95), &(lim.position_max * 0.95), 80);
    let unloaded_ws = static_samples(&model, &none, &ctrl, &ws, |_, _| rng.sample(normal));
    write("lwr4_unloaded_workspace.csv", &unloaded_ws);
    // bad inputs
    let mut moving = loaded.clone();
    for s in moving.iter_mut() {
        s.qd = Some(SVector::zeros());
    }
    moving[4].qd = Some(SVector::from([0.0, 0.0, 0.05, 0.0, 0.0, 0.0, 0.0]));
    write("lwr4_moving.csv", &moving);
    let same = static_samples(&model, &heavy, &ctrl, &vec![pick; 10], |_, _| {
        rng.sample(normal)
    });
    write("lwr4_same_pose.csv", &same);
    let mut shifted = q10.clone();
    shifted[6][2] += 0.02;
    let tare_shifted = static_samples(&model, &none, &ctrl, &shifted, |_, _| rng.sample(normal));
    write("lwr4_tare_shifted.csv", &tare_shifted);
    // NaN and wrong column count, derived from the loaded file's text
    let text = std::fs::read_to_string(dir.join("lwr4_loaded_q10.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut cells: Vec<String> = lines[3].split(',').map(str::to_string).collect();
    cells[9] = "NaN".into();
    lines[3] = cells.join(",");
    std::fs::write(dir.join("lwr4_nan.csv"), lines.join("\n") + "\n").unwrap();
    let six: Vec<String> = text
        .lines()
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            // drop q7, tau7, g7
            c.iter()
                .enumerate()
                .filter(|(i, _)| ![6, 13, 20].contains(i))
                .map(|(_, v)| *v)
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect();
    std::fs::write(dir.join("lwr4_6_joints.csv"), six.join("\n") + "\n").unwrap();
    // coefficient vectors of the paper: eq. (34) and eq. (42) (6th element restored, see tests)
    std::fs::write(
        dir.join("planar2r_pi_unloaded.json"),
        "[0.1112, 0.6, 0.04, 1.3651, 3.2, 0.03]\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("planar2r_pi_loaded.json"),
        "[0.6144, 1.8, 0.19, 2.1152, 4.7, 0.03]\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("lwr4_pig_unloaded.json"),
        "[1.6136e-5, -0.0013, -0.0046, 0.0315, -0.0417, 0.0054, 1.3544, 0.0183, -0.0036, 0.0271, -0.0129, 3.4459]\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("lwr4_pig_loaded.json"),
        "[0.0016, -0.0021, -0.0093, 0.3983, -0.0033, 0.0054, 2.5458, 0.005, -0.0032, 0.0629, -0.0028, 4.6775]\n",
    )
    .unwrap();
    eprintln!("fixtures written to {}", dir.display());
}
