//! Rust side of the side-by-side comparison with Pinocchio's C++ (`tools/bench_vs_pinocchio.sh`):
//! the same state as `benches/dynamics.rs` and the same measurement as
//! `tools/pinocchio_bench/pinocchio_bench.cpp` — median and minimum over 300 batches of the mean
//! time per call in a batch of 2000 calls. `--values` prints M, C, τ and g with 17 digits instead,
//! in the harness's format, so that the two outputs can be compared number by number.
//!
//! `cargo run --release -p dynamics --example bench_vs_pinocchio [-- --values]`

use std::hint::black_box;
use std::time::Instant;

use dynamics::{Data, compute_generalized_gravity, coriolis_matrix, crba, lwr4, rnea};
use nalgebra::{DMatrix, SVector};

const BATCHES: usize = 300;
const PER_BATCH: u32 = 2000;

/// (median, minimum) over the batches of the mean time per call, ns.
fn measure(mut f: impl FnMut()) -> (f64, f64) {
    for _ in 0..PER_BATCH {
        f();
    }
    let mut means: Vec<f64> = (0..BATCHES)
        .map(|_| {
            let start = Instant::now();
            for _ in 0..PER_BATCH {
                f();
            }
            start.elapsed().as_nanos() as f64 / f64::from(PER_BATCH)
        })
        .collect();
    means.sort_by(f64::total_cmp);
    (means[means.len() / 2], means[0])
}

fn print_matrix(name: &str, m: &DMatrix<f64>) {
    for i in 0..m.nrows() {
        let row: Vec<String> = (0..m.ncols())
            .map(|j| format!("{:.17e}", m[(i, j)]))
            .collect();
        println!("{name} {i} {}", row.join(" "));
    }
}

fn main() {
    let model = lwr4();
    let mut data = Data::new(&model);
    let q = SVector::<f64, 7>::from([0.1, 0.5, -0.3, -1.2, 0.4, 0.9, -0.2]);
    let qd = SVector::<f64, 7>::from([0.3, -0.2, 0.5, 0.1, -0.4, 0.6, 0.2]);
    let qdd = SVector::<f64, 7>::from([1.0, -0.5, 0.2, 0.3, -0.1, 0.4, 0.7]);

    if std::env::args().any(|a| a == "--values") {
        let dynamic =
            |m: nalgebra::SMatrix<f64, 7, 7>| DMatrix::from_column_slice(7, 7, m.as_slice());
        print_matrix("M", &dynamic(crba(&model, &mut data, &q)));
        print_matrix("C", &dynamic(coriolis_matrix(&model, &mut data, &q, &qd)));
        let tau = rnea(&model, &mut data, &q, &qd, &qdd);
        print_matrix("tau", &DMatrix::from_row_slice(1, 7, tau.as_slice()));
        let g = compute_generalized_gravity(&model, &mut data, &q);
        print_matrix("g", &DMatrix::from_row_slice(1, 7, g.as_slice()));
        return;
    }

    let d = &mut data;
    let m = &model;
    let rows = [
        (
            "crba",
            measure(|| {
                black_box(crba(m, d, black_box(&q)));
            }),
        ),
        (
            "coriolis_matrix",
            measure(|| {
                black_box(coriolis_matrix(m, d, black_box(&q), black_box(&qd)));
            }),
        ),
        (
            "rnea",
            measure(|| {
                black_box(rnea(m, d, black_box(&q), black_box(&qd), black_box(&qdd)));
            }),
        ),
        (
            "gravity",
            measure(|| {
                black_box(compute_generalized_gravity(m, d, black_box(&q)));
            }),
        ),
    ];
    println!(
        "# dynamics (Rust); ns per call: median and min over {BATCHES} batches of {PER_BATCH}"
    );
    for (name, (median, min)) in rows {
        println!("rust {name:24} {median:9.1} {min:9.1}");
    }
}
