//! `fri-ctl offline` on the real KUKA LWR 4+ recordings in `data/real-lwr4` (the same
//! excitation run twice): identify on run 1, then on run 2 the service's monitor at thresholds
//! calibrated on run 1 crosses nothing, and every payload route reports no payload. A missing
//! recording is a failure, never a skip.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod real_arm;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use real_arm::assert_no_payload;

fn run(name: &str) -> String {
    let path = format!("{}/../data/real-lwr4/{name}", env!("CARGO_MANIFEST_DIR"));
    assert!(
        Path::new(&path).is_file(),
        "{path} is missing (the shared real-arm recordings must be beside the repository)"
    );
    path
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
    String::from_utf8_lossy(&out.stderr).into_owned()
}

struct Dir(PathBuf);

impl Dir {
    fn new(tag: &str) -> Self {
        let d = std::env::temp_dir().join(format!("fri-ctl-real-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        Dir(d)
    }
    fn file(&self, name: &str) -> String {
        self.0.join(name).to_string_lossy().into_owned()
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// `offline identify` on the recording `name`, written to `out`; its JSON report.
fn identify(name: &str, out: &str) -> serde_json::Value {
    ok_json(&["identify", "--log", &run(name), "--out", out, "--json"])
}

/// `offline calibrate-thresholds` on run 1 with the identified `arm` (budget 0.1/h), `edge`
/// seconds dropped at each end, written to `out`; its JSON report.
fn calibrate_run_1(arm: &str, out: &str, edge: &str) -> serde_json::Value {
    ok_json(&[
        "calibrate-thresholds",
        "--log",
        &run("flobaroid-run1.csv"),
        "--calibration",
        arm,
        "--edge-s",
        edge,
        "--out",
        out,
        "--json",
    ])
}

/// `offline monitor` over run 2 with the identified `arm` and the `thresholds` file, `edge`
/// seconds dropped at each end; the log's JSON report.
fn monitor_run_2(arm: &str, thresholds: &str, edge: &str) -> serde_json::Value {
    let v = ok_json(&[
        "monitor",
        "--log",
        &run("flobaroid-run2.csv"),
        "--calibration",
        arm,
        "--thresholds",
        thresholds,
        "--edge-s",
        edge,
        "--json",
    ]);
    v["logs"][0].clone()
}

/// A monitor report with no crossing and no sample over its threshold.
fn assert_never_crossed(log: &serde_json::Value) {
    assert_eq!(log["crossings"].as_array().unwrap().len(), 0, "{log}");
    assert!(
        log["samples_over"]
            .as_array()
            .unwrap()
            .iter()
            .all(|n| n == 0),
        "{log}"
    );
}

/// Joints whose calibrated threshold reaches the service's ceiling somewhere on the log.
fn capped(fit: &serde_json::Value) -> Vec<usize> {
    (0..7)
        .filter(|&j| {
            let max = fit["joints"][j]["threshold_max"].as_f64().unwrap();
            max >= fri_api::bounds::threshold(j).max * (1.0 - 1e-9)
        })
        .map(|j| j + 1)
        .collect()
}

/// Joints whose block maxima the report calls heavier-tailed than Gumbel.
fn heavy(fit: &serde_json::Value) -> Vec<usize> {
    (0..7)
        .filter(|&j| fit["joints"][j]["model"] == "heavy")
        .map(|j| j + 1)
        .collect()
}

/// `offline calibrate-thresholds` on `logs` with the identified `arm` (budget 0.1/h), `edge`
/// seconds dropped at each end, written to `out`; its JSON report and its text report.
fn calibrate(logs: &[&str], arm: &str, out: &str, edge: &str) -> (serde_json::Value, String) {
    let mut args = vec!["calibrate-thresholds"];
    let paths: Vec<String> = logs.iter().map(|l| run(l)).collect();
    for p in &paths {
        args.extend(["--log", p.as_str()]);
    }
    args.extend(["--calibration", arm, "--edge-s", edge, "--out", out]);
    let text = fri_ctl(&args);
    assert!(text.status.success(), "{text:?}");
    args.push("--json");
    (
        ok_json(&args),
        String::from_utf8_lossy(&text.stdout).into_owned(),
    )
}

/// Issue 33's bar for the thresholds: calibrated on run 1, and on runs 1 + 2 (as separate
/// segments), whole or without the recordings' filter edges, every joint's threshold at rest
/// and over the whole schedule is at most the paper's constant 6 Nm (the scheduled envelope
/// is capped at the constant the logs support — or, where they support none below 6 Nm, at
/// the stated 6 Nm, said in a warning: J5, whose heavy-tailed maxima sit at its velocity
/// reversals, the test below), none at the service's ceiling, its own recording never
/// crossed, the minimum detectable force on every link at or below the constant's; and run 2,
/// which the run-1 fits never saw, is never crossed.
#[test]
fn calibrated_on_run_1_or_on_runs_1_and_2_every_threshold_is_at_most_6_nm_and_run_2_holds() {
    let dir = Dir::new("edges");
    let (arm, thresholds) = (dir.file("arm.toml"), dir.file("thresholds.json"));
    let _ = identify("flobaroid-run1.csv", &arm);
    let both = ["flobaroid-run1.csv", "flobaroid-run2.csv"];
    for (logs, edge) in [
        (&both[..1], "0"),
        (&both[..], "0"),
        (&both[..], "0.5"),
        (&both[..1], "0.5"),
    ] {
        let (fit, text) = calibrate(logs, &arm, &thresholds, edge);
        let case = format!("{logs:?}, edge {edge} s");
        assert_eq!(capped(&fit), Vec::<usize>::new(), "{case}: {fit}");
        for j in 0..7 {
            let x = &fit["joints"][j];
            for field in [
                "threshold_at_rest",
                "threshold_median",
                "threshold_max",
                "cap",
            ] {
                let v = x[field].as_f64().unwrap();
                assert!(v <= 6.0 + 1e-9, "{case}: J{} {field} {v} Nm", j + 1);
            }
            assert_eq!(x["exceedances"], 0, "{case}: J{}: {x}", j + 1);
            let ceiling = fit["schedule"]["ceiling"][j].as_f64().unwrap();
            assert_eq!(ceiling, x["cap"].as_f64().unwrap(), "{case}");
            if x["cap_source"] == "fallback" {
                assert!(
                    text.contains("WARNING: the logs support no constant"),
                    "{text}"
                );
                assert!(text.contains(&format!("J{} (", j + 1)), "{case}: {text}");
            }
        }
        for key in ["min_force_at_rest", "min_force_median"] {
            for l in 0..7 {
                let at = fit[key][l]["median"].as_f64().unwrap();
                let constant = fit["min_force_fallback"][l]["median"].as_f64().unwrap();
                assert!(
                    at <= constant,
                    "{case}: L{} {key} {at} N > {constant} N",
                    l + 1
                );
            }
        }
        // the reversals' heavy tail is reported, and held at the stated constant
        assert!(heavy(&fit).contains(&5), "{case}: {fit}");
        assert_eq!(fit["joints"][4]["cap_source"], "fallback", "{case}");
        if logs.len() == 1 {
            assert_never_crossed(&monitor_run_2(&arm, &thresholds, edge));
        }
    }
    // the last fit (run 1 without its edges) is in `thresholds`
    let monitor = |edge: &str| monitor_run_2(&arm, &thresholds, edge);
    let log = monitor("0.5");
    assert_never_crossed(&log);
    // played whole, run 2 is crossed only inside its own filter edges (joint 4 at 24.98 s of
    // 25.13 s here): thresholds calibrated without the edges must be run without them too
    let whole = monitor("0");
    for crossing in whole["crossings"].as_array().unwrap() {
        let t = crossing["time_s"].as_f64().unwrap();
        assert!(!(0.5..=25.13 - 0.5).contains(&t), "inside the run: {whole}");
    }
    // the edge is checked against its range, named
    let e = err_text(&[
        "monitor",
        "--log",
        &run("flobaroid-run2.csv"),
        "--edge-s",
        "-1",
    ]);
    assert!(e.contains("--edge-s") && e.contains("0…10 s"), "{e}");
    let e = err_text(&[
        "monitor",
        "--log",
        &run("flobaroid-run2.csv"),
        "--edge-s",
        "11",
    ]);
    assert!(e.contains("--edge-s") && e.contains("11"), "{e}");
}

/// Times (s) at which joint `joint` (1-based) of a real recording reverses: its q̇ column
/// changes sign.
fn reversals(path: &str, joint: usize) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    rows.windows(2)
        .filter(|w| w[0][7 + joint] * w[1][7 + joint] < 0.0)
        .map(|w| w[1][0])
        .collect()
}

/// Why joint 5's tail is heavy (issue 21): its residual's largest peaks sit at its own
/// velocity reversals (five in this excitation, four of them with q6 ≈ 0, where J5's inertia —
/// and so its envelope's velocity-noise feature — is smallest). No envelope feature represents
/// a reversal (|q̇| is zero there), so the few blocks holding one carry block maxima far above
/// the rest: a heavy tail (shape 0.21–0.68) that a GEV extrapolation turned into the ceiling
/// (the calibration now reports it and keeps the light-tail level). It is not the Coulomb
/// model's smoothness (the same five onsets at v0 = 0.005 and 0.05 rad/s), nor the envelope
/// fit's weighting (fitted to relative error, J2's tail grew heavy too). When a model or a
/// feature covers the reversals, these onsets go and this test is to say so instead.
#[test]
fn joint_5s_largest_residuals_sit_at_its_velocity_reversals() {
    let dir = Dir::new("reversals");
    let arm = dir.file("arm.toml");
    identify("flobaroid-run1.csv", &arm);
    let log = monitor_run_2(&arm, "40,40,20,20,0.8,9,9", "0.5");
    let onsets: Vec<f64> = log["crossings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            assert_eq!(c["joints"][0][0], 5, "{c}");
            c["time_s"].as_f64().unwrap()
        })
        .collect();
    let turns = reversals(&run("flobaroid-run2.csv"), 5);
    assert!(onsets.len() >= 4, "{onsets:?} {log}");
    for t in &onsets {
        let nearest = turns
            .iter()
            .map(|r| (r - t).abs())
            .fold(f64::INFINITY, f64::min);
        assert!(
            nearest < 0.15,
            "J5 onset at {t} s is {nearest} s from a reversal {turns:?}"
        );
    }
}

#[test]
fn thresholds_calibrated_on_run_1_are_never_crossed_on_run_2() {
    let dir = Dir::new("monitor");
    let (arm, thresholds) = (dir.file("arm.toml"), dir.file("thresholds.json"));
    let id = identify("flobaroid-run1.csv", &arm);
    // the arm the thresholds are calibrated with is no worse than the nominal model on
    // segments of other speeds
    let heldout = &id["identified"]["fit"]["heldout_rms"];
    let nominal = &id["identified"]["fit"]["residual_rms_nominal"];
    for j in 0..7 {
        assert!(
            heldout[j].as_f64().unwrap() <= nominal[j].as_f64().unwrap(),
            "J{}: {heldout} vs nominal {nominal}",
            j + 1
        );
    }
    let fit = ok_json(&[
        "calibrate-thresholds",
        "--log",
        &run("flobaroid-run1.csv"),
        "--calibration",
        &arm,
        "--budget",
        "0.1",
        "--out",
        &thresholds,
        "--json",
    ]);
    assert_eq!(fit["recording"]["budget_per_hour"], 0.1);
    assert!(fit["recording"]["blocks"].as_u64().unwrap() >= 20, "{fit}");
    // 25 s cannot bound every joint's residual for 0.1/h: the report says where the fit
    // reached the service's ceiling (there "no crossing" means "no detection")
    let text = fri_ctl(&[
        "calibrate-thresholds",
        "--log",
        &run("flobaroid-run1.csv"),
        "--calibration",
        &arm,
        "--budget",
        "0.1",
        "--out",
        &thresholds,
    ]);
    let text = String::from_utf8_lossy(&text.stdout).into_owned();
    let capped = capped(&fit);
    assert_eq!(
        text.contains("reaches the service's ceiling"),
        !capped.is_empty(),
        "{capped:?}: {text}"
    );
    for j in &capped {
        assert!(text.contains(&format!("J{j}")), "{text}");
    }
    // the check below has teeth only where the fit bounds the residual: on the whole log all
    // but J4 (it reaches the ceiling from the recording's filter edges, see the test above)
    for j in [1, 2, 3, 5, 6, 7] {
        assert!(!capped.contains(&j), "J{j} at the ceiling: {fit}");
    }
    let log = &monitor_run_2(&arm, &thresholds, "0");
    assert_never_crossed(log);
    // 25 s at 1 ms, less the warm-up
    assert!(log["live_samples"].as_u64().unwrap() > 24_000, "{log}");
    // the identified observer leaves a residual of the identification's size, below the
    // nominal model's on every joint
    let rms = log["residual_rms"].as_array().unwrap();
    assert!(rms.iter().all(|v| v.as_f64().unwrap() < 0.45), "{rms:?}");
    let nominal = ok_json(&["monitor", "--log", &run("flobaroid-run2.csv"), "--json"]);
    let nominal_rms = nominal["logs"][0]["residual_rms"].as_array().unwrap();
    for (j, (a, b)) in rms.iter().zip(nominal_rms).enumerate() {
        assert!(
            a.as_f64().unwrap() < b.as_f64().unwrap(),
            "J{}: identified {a} Nm, nominal {b} Nm",
            j + 1
        );
    }
    for f in log["min_force_at_rest"].as_array().unwrap() {
        let n = f["median"].as_f64().unwrap();
        assert!(n.is_finite() && n > 0.0, "{f}");
    }
    // the nominal model at the thresholds the simulated arm calibrates to (≈ 0.31 Nm) trips
    // at once (issue 21)
    let v = ok_json(&[
        "monitor",
        "--log",
        &run("flobaroid-run2.csv"),
        "--thresholds",
        "0.31",
        "--json",
    ]);
    assert!(
        !v["logs"][0]["crossings"].as_array().unwrap().is_empty(),
        "{v}"
    );
}

#[test]
fn every_payload_route_reports_no_payload_on_an_unloaded_run() {
    let dir = Dir::new("routes");
    let arm = dir.file("arm.toml");
    identify("flobaroid-run1.csv", &arm);
    let arm2 = dir.file("arm2.toml");
    identify("flobaroid-run2.csv", &arm2);
    let run2 = run("flobaroid-run2.csv");
    let run1 = run("flobaroid-run1.csv");
    // each run against the arm identified on the other
    for (log, arm, what) in [(&run2, &arm, "run 2"), (&run1, &arm2, "run 1")] {
        let text = err_text(&["estimate-motion", "--log", log, "--calibration", arm]);
        assert_no_payload(&text, &format!("motion route, {what}"));
        let text = err_text(&["coefficients", "--loaded-log", log, "--calibration", arm]);
        assert_no_payload(&text, &format!("coefficient route, {what}"));
    }
    // the same trajectory run twice is a valid tare (refused before: "tare pose mismatch: joint
    // 1 differs by 0.00211 rad")
    let text = err_text(&[
        "estimate-motion",
        "--log",
        &run2,
        "--tare-log",
        &run("flobaroid-run1.csv"),
    ]);
    assert!(!text.contains("tare pose mismatch"), "{text}");
    assert_no_payload(&text, "tare route");
    let text = err_text(&["estimate-motion", "--log", &run1, "--tare-log", &run2]);
    assert_no_payload(&text, "tare route, run 1 on run 2");
}

/// `path` (a real recording: t, q, q̇, q̈, τ) written to `out` as if it had carried the paper's
/// payload (3.028 kg, CoM z 119 mm, a cylinder r 40 mm, l 80 mm): its torques plus the
/// payload's, by RNEA on the recorded q, q̇, q̈ (the arm's model error and noise stay real).
fn with_paper_payload(path: &str, out: &str) {
    use dynamics::{Data, InertialParameters, lwr4, rnea};
    use nalgebra::{Matrix3, SVector, Vector3};
    let (m, r, l) = (3.028, 0.04, 0.08);
    let transverse = m * (3.0 * r * r + l * l) / 12.0;
    let payload = InertialParameters::from_com(
        m,
        Vector3::new(0.0, 0.0, 0.119),
        Matrix3::from_diagonal(&Vector3::new(transverse, transverse, 0.5 * m * r * r)),
    );
    let model = lwr4();
    let loaded = model.with_payload(&payload);
    let (mut data, mut loaded_data) = (Data::new(&model), Data::new(&loaded));
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    assert!(
        header.starts_with("t,q1,") && header.ends_with(",tau7"),
        "{header}"
    );
    let mut written = format!("{header}\n");
    for line in lines {
        let f: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let v = |k: usize| SVector::<f64, 7>::from_fn(|j, _| f[1 + 7 * k + j]);
        let (q, qd, qdd) = (v(0), v(1), v(2));
        let tau = v(3) + rnea(&loaded, &mut loaded_data, &q, &qd, &qdd)
            - rnea(&model, &mut data, &q, &qd, &qdd);
        let cells: Vec<String> = f[..22]
            .iter()
            .chain(tau.iter())
            .map(|x| format!("{x:e}"))
            .collect();
        written += &cells.join(",");
        written.push('\n');
    }
    std::fs::write(out, written).unwrap();
}

/// Issue 21 item 4 as the operator reads it: run 2 with the paper's payload added, against the
/// arm identified on run 1. This excitation cannot resolve a payload's inertia (σ ≈ 0.2 kg·m²,
/// every inertia a 3 kg flange load can have); both routes print the mass and the centre of
/// mass, say that the inertia is not resolved and print no inertia numbers. Before, both
/// refused the estimate as "no rigid body" (inertia 2.2σ below zero).
#[test]
fn a_known_payload_on_run_2_gives_mass_and_com_and_says_the_inertia_is_not_resolved() {
    let dir = Dir::new("known");
    let arm = dir.file("arm.toml");
    identify("flobaroid-run1.csv", &arm);
    let loaded = dir.file("run2-loaded.csv");
    with_paper_payload(&run("flobaroid-run2.csv"), &loaded);
    for route in [
        ["estimate-motion", "--log"],
        ["coefficients", "--loaded-log"],
    ] {
        let mut args = vec![route[0], route[1], &loaded, "--calibration", &arm];
        let out = fri_ctl(&args);
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{route:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(text.contains("mass     3.0"), "{route:?}: {text}");
        assert!(text.contains("NOT RESOLVED"), "{route:?}: {text}");
        assert!(text.contains("inertia not resolved"), "{route:?}: {text}");
        assert!(!text.contains("Jxx"), "{route:?}: {text}");
        args.push("--json");
        let v = ok_json(&args);
        let e = if v["estimate"].is_object() {
            &v["estimate"]
        } else {
            &v
        };
        assert_eq!(e["inertia_resolved"], false, "{route:?}: {e}");
        let (mass, std) = (
            e["mass"].as_f64().unwrap(),
            e["parameters_std"][0].as_f64().unwrap(),
        );
        assert!(
            (mass - 3.028).abs() <= 2.0 * std,
            "{route:?}: {mass} ± {std}"
        );
        let (cz, cz_std) = (
            e["com"][2].as_f64().unwrap(),
            e["com_std"][2].as_f64().unwrap(),
        );
        assert!(
            (cz - 0.119).abs() <= 2.0 * cz_std,
            "{route:?}: {cz} ± {cz_std}"
        );
    }
}

#[test]
fn broken_or_foreign_files_are_refused_naming_the_cause() {
    let dir = Dir::new("hostile");
    let run2 = run("flobaroid-run2.csv");
    // a thresholds file out of the service's range
    let bad = dir.file("bad.json");
    let arm = dir.file("arm.toml");
    let thresholds = dir.file("thr.json");
    identify("flobaroid-run1.csv", &arm);
    calibrate_run_1(&arm, &thresholds, "0");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&thresholds).unwrap()).unwrap();
    v["schedule"]["thresholds"][2] = serde_json::json!(1e9);
    std::fs::write(&bad, v.to_string()).unwrap();
    let text = err_text(&["monitor", "--log", &run2, "--thresholds", &bad]);
    assert!(text.contains("schedule.thresholds[2] (joint 3)"), "{text}");
    std::fs::write(&bad, "{\"format\": 1").unwrap();
    let text = err_text(&["monitor", "--log", &run2, "--thresholds", &bad]);
    assert!(text.contains("thresholds file"), "{text}");
    // gains other than the file's
    let text = err_text(&[
        "monitor",
        "--log",
        &run2,
        "--thresholds",
        &thresholds,
        "--gains",
        "200",
    ]);
    assert!(text.contains("calibrated at"), "{text}");
    // an identified-arm file altered by hand
    let altered =
        std::fs::read_to_string(&arm)
            .unwrap()
            .replacen("robot = \"lwr4\"", "robot = \"iiwa\"", 1);
    std::fs::write(&bad, altered).unwrap();
    let text = err_text(&["monitor", "--log", &run2, "--calibration", &bad]);
    assert!(text.contains("`robot`"), "{text}");
    let text = err_text(&["estimate-motion", "--log", &run2, "--calibration", &bad]);
    assert!(text.contains("`robot`"), "{text}");
    // a log with too few rows to identify from
    let short = dir.file("short.csv");
    let rows: Vec<String> = std::fs::read_to_string(&run2)
        .unwrap()
        .lines()
        .take(40)
        .map(str::to_owned)
        .collect();
    std::fs::write(&short, rows.join("\n")).unwrap();
    let text = err_text(&["identify", "--log", &short, "--out", &dir.file("x.toml")]);
    assert!(
        text.contains("too few samples") || text.contains("usable samples"),
        "{text}"
    );
}

/// Issue 33: identified on runs 1 + 2 together, the fit puts model error into negative
/// friction, which grows with speed beyond the logs; the report says so loudly, naming the
/// joints, and does not on a joint it fits with friction ≥ 0. With `--non-negative-friction`
/// the written file holds no negative coefficient and nothing is said of friction. Either
/// way the report says which links, as written, are no rigid body (their pseudo-inertia), in
/// text and in `--json`, naming each.
#[test]
fn the_identification_warns_of_negative_friction_and_of_links_that_are_no_rigid_body() {
    let dir = Dir::new("warnings");
    let out = dir.file("arm12.toml");
    let (run1, run2) = (run("flobaroid-run1.csv"), run("flobaroid-run2.csv"));
    let both = ["--log", &run1, "--log", &run2, "--out", &out];
    let text = |extra: &[&str]| {
        let args: Vec<&str> = ["identify"]
            .iter()
            .chain(&both)
            .chain(extra)
            .copied()
            .collect();
        let o = fri_ctl(&args);
        assert!(o.status.success(), "{o:?}");
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let json = |extra: &[&str]| {
        let args: Vec<&str> = ["identify"]
            .iter()
            .chain(&both)
            .chain(extra)
            .chain(&["--json"])
            .copied()
            .collect();
        ok_json(&args)
    };
    let free = text(&[]);
    let line = free
        .lines()
        .find(|l| l.contains("WARNING: negative viscous friction"))
        .unwrap_or_else(|| panic!("no friction warning: {free}"));
    let file = json(&[]);
    let viscous = file["identified"]["joint"]["viscous"].as_array().unwrap();
    for (j, v) in viscous.iter().enumerate() {
        let named = line.contains(&format!("J{} (", j + 1));
        assert_eq!(named, v.as_f64().unwrap() < 0.0, "J{}: {line}", j + 1);
    }
    // the same words for a tool reading `--json`
    let warnings = file["warnings"].as_array().unwrap();
    assert!(
        warnings.iter().any(|w| line.ends_with(w.as_str().unwrap())),
        "{warnings:?}"
    );

    let physical = text(&["--non-negative-friction"]);
    assert!(!physical.contains("negative viscous"), "{physical}");
    assert!(physical.contains("friction kept ≥ 0"), "{physical}");
    let written = std::fs::read_to_string(&out).unwrap();
    let arm = dynamics::IdentifiedModel::<7>::from_toml_str(&dynamics::lwr4(), &written).unwrap();
    let joint = &arm.file().joint;
    assert!(
        joint
            .viscous
            .iter()
            .chain(&joint.coulomb)
            .all(|v| *v >= 0.0),
        "{joint:?}"
    );
    let file = json(&["--non-negative-friction"]);
    let eig: Vec<f64> = file["smallest_pseudo_inertia_eigenvalue"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(eig.len(), 7);
    let warnings: Vec<&str> = file["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    let bodies = warnings.iter().find(|w| w.contains("no rigid body"));
    for (l, e) in eig.iter().enumerate() {
        let named = bodies.is_some_and(|w| w.contains(&format!("L{} (", l + 1)));
        assert_eq!(named, *e <= 0.0, "L{}: {e} {warnings:?}", l + 1);
    }
    if let Some(w) = bodies {
        assert!(physical.contains(&format!("WARNING: {w}")), "{physical}");
    }
}

/// The stated constant of `calibrate-thresholds` is bounded by the thresholds' range, named per
/// joint, and given once or for all seven joints.
#[test]
fn a_stated_constant_out_of_range_is_refused_naming_the_joint() {
    let dir = Dir::new("fallback");
    let out = dir.file("thr.json");
    let run1 = run("flobaroid-run1.csv");
    let args = |fallback: &'static str| -> Vec<String> {
        [
            "calibrate-thresholds",
            "--log",
            &run1,
            "--out",
            &out,
            "--fallback",
            fallback,
        ]
        .map(str::to_owned)
        .to_vec()
    };
    let refused = |fallback: &'static str| {
        let a = args(fallback);
        err_text(&a.iter().map(String::as_str).collect::<Vec<_>>())
    };
    // 20 Nm is within the shoulder's range, beyond the wrist's quarter of 38 Nm
    let e = refused("20");
    assert!(e.contains("fallback[6]") && e.contains("9.5"), "{e}");
    let e = refused("1,2");
    assert!(e.contains("--fallback") && e.contains("2 values"), "{e}");
    let e = refused("0");
    assert!(e.contains("fallback[1]"), "{e}");
    assert!(
        !std::path::Path::new(&out).exists(),
        "a refused calibration wrote {out}"
    );
}
