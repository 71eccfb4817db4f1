//! `fri-ctl offline …` end to end on the committed fixtures (written by
//! `cargo run -p estimator --example cli_fixtures -- tests/fixtures`): LWR 4+ with 3.028 kg at
//! (0, 0, 0.119) m in frame 7, controller model perturbed as in lwr4-model.md §4, σ = 0.05 Nm.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::process::{Command, Output};

fn fixture(name: &str) -> String {
    format!("{}/tests/fixtures/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn fri_ctl(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
        .arg("offline")
        .args(args)
        .output()
        .unwrap()
}

fn ok_json(args: &[&str]) -> serde_json::Value {
    let out = fri_ctl(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn err_text(args: &[&str]) -> String {
    let out = fri_ctl(args);
    assert!(!out.status.success(), "{args:?} should fail");
    assert!(out.stdout.is_empty());
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn estimate_json_has_the_documented_keys_and_values() {
    let v = ok_json(&[
        "estimate",
        "--samples",
        &fixture("lwr4_loaded_q10.csv"),
        "--json",
    ]);
    for key in [
        "mass",
        "com",
        "com_flange",
        "mass_std",
        "com_std",
        "condition_number",
        "samples",
    ] {
        assert!(v.get(key).is_some(), "missing {key}: {v}");
    }
    let m = v["mass"].as_f64().unwrap();
    // one-shot carries the controller's model error: about +1 %
    assert!((m / 3.028 - 1.0).abs() < 0.02, "{m}");
    assert_eq!(v["samples"].as_u64(), Some(10));
    let cz = v["com"][2].as_f64().unwrap();
    let cz_flange = v["com_flange"][2].as_f64().unwrap();
    assert!((cz - cz_flange - 0.078).abs() < 1e-9);
    assert!((cz - 0.119).abs() < 0.01, "{cz}");
}

#[test]
fn tare_and_calibration_remove_the_bias() {
    let t = ok_json(&[
        "estimate",
        "--samples",
        &fixture("lwr4_loaded_q10.csv"),
        "--tare",
        &fixture("lwr4_tare_q10.csv"),
        "--json",
    ]);
    let mt = t["mass"].as_f64().unwrap();
    let st = t["mass_std"].as_f64().unwrap();
    assert!((mt - 3.028).abs() < 3.0 * st, "tare {mt} ± {st}");
    assert_eq!(t["correction"], "tare");

    let dir = std::env::temp_dir().join(format!("fri-ctl-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cal = dir.join("cal.json");
    let c = ok_json(&[
        "calibrate",
        "--samples",
        &fixture("lwr4_unloaded_workspace.csv"),
        "--out",
        cal.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(c["delta"].as_array().unwrap().len(), 12);
    let e = ok_json(&[
        "estimate",
        "--samples",
        &fixture("lwr4_loaded_q10.csv"),
        "--calibration",
        cal.to_str().unwrap(),
        "--json",
    ]);
    let mc = e["mass"].as_f64().unwrap();
    let sc = e["mass_std"].as_f64().unwrap();
    assert!(
        (mc - 3.028).abs() < 3.0 * sc + 0.004,
        "calibrated {mc} ± {sc}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn human_report_shows_units_frames_and_uncertainty() {
    let out = fri_ctl(&[
        "estimate",
        "--samples",
        &fixture("lwr4_loaded_q10.csv"),
        "--method",
        "coefficients",
    ]);
    assert!(out.status.success());
    let s = String::from_utf8(out.stdout).unwrap();
    for needle in [
        "kg",
        "± ",
        "1σ",
        "frame 7",
        "flange frame",
        "[mm]",
        "condition number",
        "Nm",
        "coefficient route",
    ] {
        assert!(s.contains(needle), "missing `{needle}` in\n{s}");
    }
}

#[test]
fn coefficients_reproduce_the_paper() {
    let v = ok_json(&[
        "coefficients",
        "--set",
        "planar-2r",
        "--unloaded",
        &fixture("planar2r_pi_unloaded.json"),
        "--loaded",
        &fixture("planar2r_pi_loaded.json"),
        "--json",
    ]);
    let p: Vec<f64> = v["p_l"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let printed = [1.5, 0.45, 0.15, 0.1814];
    for (a, b) in p.iter().zip(printed) {
        assert!((a - b).abs() < 5e-5, "{p:?}");
    }
    let v = ok_json(&[
        "coefficients",
        "--set",
        "lwr4-gravity",
        "--unloaded",
        &fixture("lwr4_pig_unloaded.json"),
        "--loaded",
        &fixture("lwr4_pig_loaded.json"),
        "--json",
    ]);
    assert!((v["mass"].as_f64().unwrap() - 3.067).abs() < 5e-4);
    assert!((v["com"][2].as_f64().unwrap() - 0.1196).abs() < 5e-5);
    let e = err_text(&[
        "coefficients",
        "--set",
        "planar-2r",
        "--unloaded",
        &fixture("lwr4_pig_unloaded.json"),
        "--loaded",
        &fixture("planar2r_pi_loaded.json"),
    ]);
    assert!(
        e.contains("12 elements") && e.contains("6 coefficients"),
        "{e}"
    );
    let e = err_text(&[
        "coefficients",
        "--set",
        "no-such-set",
        "--unloaded",
        &fixture("planar2r_pi_unloaded.json"),
        "--loaded",
        &fixture("planar2r_pi_loaded.json"),
    ]);
    assert!(e.contains("neither a built-in set"), "{e}");
}

/// The paper's pick pose as an `--around` argument, rad.
fn pick_pose_arg() -> String {
    dynamics::LWR4_PICK_POSE_RAD
        .map(|v| format!("{v:.10}"))
        .join(",")
}

#[test]
fn poses_paper_and_optimised() {
    let around = pick_pose_arg();
    let around = around.as_str();
    let paper = ok_json(&[
        "poses", "--robot", "lwr4", "--around", around, "--count", "10", "--json",
    ]);
    assert_eq!(paper["poses"].as_array().unwrap().len(), 10);
    let opt = ok_json(&[
        "poses",
        "--robot",
        "lwr4",
        "--around",
        around,
        "--count",
        "10",
        "--spread-deg",
        "3",
        "--optimize",
        "--json",
    ]);
    let ps = paper["predicted"]["mass_std"].as_f64().unwrap();
    let os = opt["predicted"]["mass_std"].as_f64().unwrap();
    assert!(os <= 1.01 * ps, "{os} vs {ps}");
    for q in opt["poses"].as_array().unwrap() {
        let q2 = q[1].as_f64().unwrap();
        assert!((q2 - dynamics::LWR4_PICK_POSE_RAD[1]).abs() <= 3f64.to_radians() + 1e-9);
    }
    let e = err_text(&["poses", "--around", "0,0.5,0", "--count", "5"]);
    assert!(e.contains("3 values") && e.contains("7 joints"), "{e}");
}

#[test]
fn poses_reject_out_of_range_numbers() {
    let around = pick_pose_arg();
    let around = around.as_str();
    // usize::MAX poses used to abort on the up-front allocation ("capacity overflow")
    for count in ["18446744073709551615", "1"] {
        for optimize in [false, true] {
            let mut args = vec!["poses", "--around", around, "--count", count];
            if optimize {
                args.push("--optimize");
            }
            let e = err_text(&args);
            assert!(e.contains("--count") && e.contains("2 to 10000"), "{e}");
        }
    }
    for (flag, value) in [
        ("--sigma", "0"),
        ("--sigma", "NaN"),
        ("--mass-guess", "0"),
        ("--mass-guess", "inf"),
    ] {
        let e = err_text(&["poses", "--around", around, flag, value]);
        assert!(
            e.contains("must be positive numbers"),
            "{flag} {value}: {e}"
        );
    }
}

#[test]
fn bad_inputs_fail_with_clear_errors() {
    let cases: [(&[&str], &[&str]); 7] = [
        (
            &["estimate", "--samples", &fixture("lwr4_same_pose.csv")],
            &["poses too similar", "condition number"],
        ),
        (
            &["estimate", "--samples", &fixture("lwr4_6_joints.csv")],
            &["wrong column count", "q1..q7"],
        ),
        (
            &["estimate", "--samples", &fixture("lwr4_moving.csv")],
            &["not static", "sample 5", "joint 3"],
        ),
        (
            &["estimate", "--samples", &fixture("lwr4_nan.csv")],
            &["not a finite number", "tau3"],
        ),
        (
            &[
                "estimate",
                "--samples",
                &fixture("lwr4_loaded_q10.csv"),
                "--tare",
                &fixture("lwr4_tare_shifted.csv"),
            ],
            &["tare pose mismatch", "sample 7", "same poses"],
        ),
        (
            &["estimate", "--samples", &fixture("does_not_exist.csv")],
            &["cannot open samples file"],
        ),
        (
            &[
                "calibrate",
                "--samples",
                &fixture("lwr4_tare_q10.csv"),
                "--robot",
                "planar-2r",
                "--out",
                "/nonexistent/x.json",
            ],
            &["wrong column count"],
        ),
    ];
    for (args, needles) in cases {
        let e = err_text(args);
        for n in needles {
            assert!(e.contains(n), "{args:?}: `{n}` not in {e}");
        }
    }
}

/// Copies a fixture with the cell at (1-based data `row`, `column`) replaced by `value`.
fn corrupted(name: &str, row: usize, column: &str, value: &str, dir: &std::path::Path) -> String {
    let text = std::fs::read_to_string(fixture(name)).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    let col = lines[0].split(',').position(|h| h == column).unwrap();
    let mut cells: Vec<&str> = lines[row].split(',').collect();
    cells[col] = value;
    lines[row] = cells.join(",");
    let path = dir.join(format!("{column}-row{row}-{name}"));
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    path.to_string_lossy().into_owned()
}

#[test]
fn implausible_values_name_the_file_row_column_and_range() {
    let dir = tempfile::tempdir().unwrap();
    let q = corrupted("lwr4_loaded_q10.csv", 3, "q2", "1e308", dir.path());
    let e = err_text(&["estimate", "--samples", &q]);
    for n in [
        q.as_str(),
        "row 3",
        "`q2`",
        "1e308",
        "[-2.1044, 2.1044] rad",
        "joint limits",
    ] {
        assert!(e.contains(n), "`{n}` not in {e}");
    }
    // Just inside the limit (120° = 2.0944 rad) is fine.
    let edge = corrupted("lwr4_loaded_q10.csv", 3, "q2", "2.0944", dir.path());
    let v = ok_json(&["estimate", "--samples", &edge, "--json"]);
    assert!(v["mass"].is_number());
    let tau = corrupted("lwr4_tare_q10.csv", 2, "tau4", "-5e9", dir.path());
    let e = err_text(&[
        "estimate",
        "--samples",
        &fixture("lwr4_loaded_q10.csv"),
        "--tare",
        &tau,
    ]);
    for n in [tau.as_str(), "row 2", "`tau4`", "[-200, 200] Nm"] {
        assert!(e.contains(n), "`{n}` not in {e}");
    }
    let g = corrupted("lwr4_unloaded_workspace.csv", 1, "g7", "1e300", dir.path());
    let e = err_text(&["calibrate", "--samples", &g, "--out", "/nonexistent/c.json"]);
    assert!(e.contains("row 1") && e.contains("`g7`"), "{e}");
}

/// Writes the paper's q_B sweep (joint 1 chirp, q6 = −π/2) of the loaded LWR as a log CSV,
/// 15 s at 200 Hz, σ = 0.05 Nm noise (deterministic pseudo-noise, no RNG dependency).
fn write_sweep_log(path: &std::path::Path, fixed: [f64; 6]) {
    use dynamics::{Data, InertialParameters, lwr4, rnea};
    use nalgebra::{Matrix3, SVector, Vector3};
    let payload = InertialParameters::from_com(
        3.028,
        Vector3::new(0.004, -0.003, 0.119),
        Matrix3::from_diagonal(&Vector3::new(0.0073, 0.0082, 0.0041)),
    );
    let truth = lwr4().with_payload(&payload);
    let mut data = Data::new(&truth);
    let mut text = String::from("t,q1,q2,q3,q4,q5,q6,q7,tau1,tau2,tau3,tau4,tau5,tau6,tau7,note\n");
    for k in 0..3001 {
        let t = k as f64 * 0.005;
        let (q1, qd1, qdd1) =
            estimator::motion::chirp(t, 15.0, 100f64.to_radians(), 150f64.to_radians());
        let q = SVector::<f64, 7>::from([
            q1, fixed[0], fixed[1], fixed[2], fixed[3], fixed[4], fixed[5],
        ]);
        let qd = SVector::<f64, 7>::from([qd1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let qdd = SVector::<f64, 7>::from([qdd1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let tau = rnea(&truth, &mut data, &q, &qd, &qdd);
        let mut row = vec![format!("{t:.3}")];
        row.extend(q.iter().map(|v| format!("{v:.9}")));
        // ±0.05 Nm pseudo-noise: a fixed irrational sequence, zero mean
        row.extend(tau.iter().enumerate().map(|(j, v)| {
            format!(
                "{:.6}",
                v + 0.05
                    * 1.7320508
                    * (2.0 * ((k * 7 + j) as f64 * 0.618_033_988_75).fract() - 1.0)
            )
        }));
        row.push("x".into());
        text += &row.join(",");
        text.push('\n');
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn estimate_motion_on_generated_sweeps() {
    use std::f64::consts::FRAC_PI_2;
    let dir = std::env::temp_dir().join(format!("fri-ctl-motion-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let names = ["qa.csv", "qb.csv", "qc.csv"];
    let fixed = [
        [FRAC_PI_2, 0.0, 0.0, 0.0, 0.0, 0.0],
        [FRAC_PI_2, 0.0, 0.0, 0.0, -FRAC_PI_2, 0.0],
        [FRAC_PI_2, 0.0, 0.0, -FRAC_PI_2, 0.0, 0.0],
    ];
    for (n, f) in names.iter().zip(fixed) {
        write_sweep_log(&dir.join(n), f);
    }
    let paths: Vec<String> = names
        .iter()
        .map(|n| dir.join(n).to_string_lossy().into_owned())
        .collect();
    let v = ok_json(&[
        "estimate-motion",
        "--log",
        &paths[0],
        "--log",
        &paths[1],
        "--log",
        &paths[2],
        "--json",
    ]);
    let m = v["mass"].as_f64().unwrap();
    assert!((m / 3.028 - 1.0).abs() < 0.005, "{m}");
    let cz = v["com"][2].as_f64().unwrap();
    assert!((cz - 0.119).abs() < 0.003, "{cz}");
    assert!(
        v["inertia_com"].is_array() && v["physical_warning"].is_null(),
        "{v}"
    );
    let out = fri_ctl(&[
        "estimate-motion",
        "--log",
        &paths[0],
        "--log",
        &paths[1],
        "--log",
        &paths[2],
    ]);
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(
        s.contains("inertia about the frame-7 origin") && s.contains("kg·m²") && s.contains("± "),
        "{s}"
    );
    let e = err_text(&[
        "estimate-motion",
        "--log",
        &paths[0],
        "--tare-log",
        &paths[1],
        "--tare-log",
        &paths[2],
    ]);
    assert!(e.contains("one tare log per loaded log"), "{e}");
    // The service's log names its time column `time_s` and skips lost cycles: the log is read
    // as it is and cut at its gap.
    let text = std::fs::read_to_string(&paths[0]).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    lines[0] = lines[0].replacen("t,", "time_s,", 1);
    let middle = lines.len() / 2;
    lines.drain(middle..middle + 3);
    let recorded = dir.join("recorded.csv");
    std::fs::write(&recorded, lines.join("\n") + "\n").unwrap();
    let recorded = recorded.to_string_lossy().into_owned();
    let out = fri_ctl(&[
        "estimate-motion",
        "--log",
        &recorded,
        "--log",
        &paths[1],
        "--log",
        &paths[2],
    ]);
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(
        out.status.success(),
        "{s} {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        s.contains("1 gaps (lost cycles)") && s.contains("2 contiguous pieces"),
        "{s}"
    );
    let v = ok_json(&[
        "estimate-motion",
        "--log",
        &recorded,
        "--log",
        &paths[1],
        "--log",
        &paths[2],
        "--json",
    ]);
    let m = v["mass"].as_f64().unwrap();
    assert!((m / 3.028 - 1.0).abs() < 0.005, "{m}");
    let e = err_text(&["estimate-motion", "--log", &fixture("lwr4_loaded_q10.csv")]);
    assert!(e.contains("no column `t`"), "{e}");
    // A 2 s log (issue 23 item 4): the zero-phase filter's 3 s edges leave nothing; the error
    // says so and what to do, not "record more static poses".
    let text = std::fs::read_to_string(&paths[1]).unwrap();
    let short = dir.join("short.csv");
    let lines: Vec<&str> = text.lines().take(1 + 401).collect();
    std::fs::write(&short, lines.join("\n") + "\n").unwrap();
    let e = err_text(&["estimate-motion", "--log", short.to_str().unwrap()]);
    for n in [
        "lasts 2.000 s",
        "3.000 s at each end",
        "record at least",
        "--trim-s",
    ] {
        assert!(e.contains(n), "`{n}` not in {e}");
    }
    assert!(!e.contains("static poses"), "{e}");
    // An implausible joint value in a log is named with its row.
    let text = std::fs::read_to_string(&paths[1]).unwrap();
    let bad = dir.join("bad.csv");
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    // Column 1 is q1 (header t,q1,..).
    let mut cells: Vec<&str> = lines[5].split(',').collect();
    cells[1] = "1e308";
    lines[5] = cells.join(",");
    std::fs::write(&bad, lines.join("\n") + "\n").unwrap();
    let e = err_text(&["estimate-motion", "--log", bad.to_str().unwrap()]);
    for n in ["bad.csv", "row 5", "`q1`", "joint limits"] {
        assert!(e.contains(n), "`{n}` not in {e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn robot_files_work_like_the_builtin_model() {
    let builtin = ok_json(&[
        "estimate",
        "--samples",
        &fixture("lwr4_loaded_q10.csv"),
        "--json",
    ]);
    for file in ["lwr4.toml", "lwr4.urdf"] {
        let path = format!("{}/../dynamics/robots/{file}", env!("CARGO_MANIFEST_DIR"));
        let v = ok_json(&[
            "estimate",
            "--samples",
            &fixture("lwr4_loaded_q10.csv"),
            "--robot",
            &path,
            "--json",
        ]);
        let (a, b) = (
            v["mass"].as_f64().unwrap(),
            builtin["mass"].as_f64().unwrap(),
        );
        assert!((a - b).abs() < 1e-9, "{file}: {a} vs {b}");
    }
    let two = format!(
        "{}/../dynamics/robots/planar_2r.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let e = err_text(&[
        "estimate",
        "--samples",
        &fixture("lwr4_loaded_q10.csv"),
        "--robot",
        &two,
    ]);
    assert!(e.contains("2 joints"), "{e}");
    let e = err_text(&[
        "estimate",
        "--samples",
        &fixture("lwr4_loaded_q10.csv"),
        "--robot",
        "/no/such/robot.toml",
    ]);
    assert!(e.contains("cannot read robot file"), "{e}");
}

/// A user-written coefficient-set file in the explicit π_L form of eq. (30) (payload symbols
/// written out) gives the same p̂_L as the built-in eq. (29) set.
#[test]
fn coefficient_set_file_in_explicit_form() {
    let dir = std::env::temp_dir().join(format!("fri-ctl-coef-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let set = dir.join("eq30.coef");
    std::fs::write(
        &set,
        "# eq. (30)\nlinks 2\nconst a1 = 1\nconst a2 = 0.5\npayload m, mcx, mcy, Jzz\n\
         coef p1 = 0.5*(a2^2*(m2 + mL) + J2zz + JLzz) + a2*(c2x*m2 + cLx*mL)\n\
         coef p2 = c2x*m2 + cLx*mL + a2*(m2 + mL)\n\
         coef p3 = c2y*m2 + cLy*mL\n\
         coef p4 = 0.5*(J1zz + a1^2*m1 + a1^2*(m2 + mL)) + a1*c1x*m1\n\
         coef p5 = c1x*m1 + a1*m1 + a1*(m2 + mL)\n\
         coef p6 = c1y*m1\n",
    )
    .unwrap();
    let v = ok_json(&[
        "coefficients",
        "--set",
        set.to_str().unwrap(),
        "--unloaded",
        &fixture("planar2r_pi_unloaded.json"),
        "--loaded",
        &fixture("planar2r_pi_loaded.json"),
        "--json",
    ]);
    let p: Vec<f64> = v["p_l"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    for (a, b) in p.iter().zip([1.5, 0.45, 0.15, 0.1814]) {
        assert!((a - b).abs() < 5e-5, "{p:?}");
    }
    std::fs::write(&set, "links 2\ncoef p1 = m1*m2\n").unwrap();
    let e = err_text(&[
        "coefficients",
        "--set",
        set.to_str().unwrap(),
        "--unloaded",
        &fixture("planar2r_pi_unloaded.json"),
        "--loaded",
        &fixture("planar2r_pi_loaded.json"),
    ]);
    assert!(e.contains("line 2") && e.contains("linear"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn planar_2r_pose_design() {
    let v = ok_json(&[
        "poses",
        "--robot",
        "planar-2r",
        "--around",
        "0.3,-0.5",
        "--count",
        "6",
        "--spread-deg",
        "20",
        "--mass-guess",
        "1.5",
        "--json",
    ]);
    assert_eq!(v["poses"].as_array().unwrap().len(), 6);
    assert!(v["predicted"]["mass_std"].as_f64().unwrap() > 0.0);
    assert!(v["predicted"]["com_std"][2].is_null());
}

/// Writes `log` as the service's MCAP recorder does (`record --kind mcap`): one robot state per
/// row, stamped with the row's time.
fn write_mcap_log(path: &std::path::Path, log: &estimator::motion::Trajectory<7>) {
    use fri_service::mcap_recording::{Item, McapRecording, McapSettings};
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let settings = McapSettings {
        namespace: "/lwr".into(),
        cycle_s: 0.005,
    };
    let mut rec = McapRecording::create(file, settings).unwrap();
    for (k, t) in log.t.iter().enumerate() {
        let state = fri_api::ipc::RobotState {
            cycle: k as u64 + 1,
            time_s: *t,
            q: log.q[k].into(),
            tau: log.tau[k].into(),
            ..fri_api::ipc::RobotState::default()
        };
        rec.item(&Item::State(state)).unwrap();
    }
    rec.finish().unwrap();
}

/// `estimate-motion` reads the service's MCAP recordings (`/joint_states`: header stamp, position,
/// effort) as it reads CSV logs: the same sweeps give the same estimate, a lost cycle is a gap,
/// and a recording without joint states is refused by name.
#[test]
fn estimate_motion_reads_mcap_recordings_like_csv_logs() {
    use std::f64::consts::FRAC_PI_2;
    let dir = tempfile::tempdir().unwrap();
    let fixed = [
        [FRAC_PI_2, 0.0, 0.0, 0.0, 0.0, 0.0],
        [FRAC_PI_2, 0.0, 0.0, 0.0, -FRAC_PI_2, 0.0],
        [FRAC_PI_2, 0.0, 0.0, -FRAC_PI_2, 0.0, 0.0],
    ];
    let mut csvs = Vec::new();
    let mut mcaps = Vec::new();
    for (i, f) in fixed.into_iter().enumerate() {
        let csv = dir.path().join(format!("sweep{i}.csv"));
        write_sweep_log(&csv, f);
        if i == 0 {
            // Three lost cycles in the middle of the first recording.
            let text = std::fs::read_to_string(&csv).unwrap();
            let mut lines: Vec<&str> = text.lines().collect();
            let middle = lines.len() / 2;
            lines.drain(middle..middle + 3);
            std::fs::write(&csv, lines.join("\n") + "\n").unwrap();
        }
        let log =
            estimator::motion::read_log_csv::<7, _>(std::fs::File::open(&csv).unwrap()).unwrap();
        let mcap = dir.path().join(format!("sweep{i}.mcap"));
        write_mcap_log(&mcap, &log);
        csvs.push(csv.to_string_lossy().into_owned());
        mcaps.push(mcap.to_string_lossy().into_owned());
    }
    let run = |logs: &[String], json: bool| {
        let mut args = vec!["estimate-motion"];
        for l in logs {
            args.extend(["--log", l.as_str()]);
        }
        if json {
            args.push("--json");
            Some(ok_json(&args))
        } else {
            let out = fri_ctl(&args);
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            let text = String::from_utf8(out.stdout).unwrap();
            assert!(
                text.contains("1 gaps (lost cycles)") && text.contains("2 contiguous pieces"),
                "{text}"
            );
            None
        }
    };
    let from_csv = run(&csvs, true).unwrap();
    let from_mcap = run(&mcaps, true).unwrap();
    run(&mcaps, false);
    let m = from_mcap["mass"].as_f64().unwrap();
    assert!((m / 3.028 - 1.0).abs() < 0.005, "{m}");
    // Stamps are whole nanoseconds in MCAP: the estimate equals the CSV one to rounding.
    for (a, b) in from_csv["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .zip(from_mcap["parameters"].as_array().unwrap())
    {
        let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
        assert!((a - b).abs() <= 1e-9 * a.abs().max(1e-3), "{a} vs {b}");
    }
    // An MCAP file without joint states.
    let empty = dir.path().join("empty.mcap");
    write_mcap_log(
        &empty,
        &estimator::motion::Trajectory {
            t: Vec::new(),
            q: Vec::new(),
            tau: Vec::new(),
        },
    );
    let e = err_text(&["estimate-motion", "--log", empty.to_str().unwrap()]);
    assert!(
        e.contains("empty.mcap") && e.contains("no /joint_states"),
        "{e}"
    );
}
