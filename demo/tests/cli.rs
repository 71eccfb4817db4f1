//! `cargo run --release -- demo`: the demo's report, end to end in lockstep.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::process::Command;

/// One demo at a time. In lockstep the simulated controller still gives up waiting for an
/// answer after a wall-clock timeout, and the demo and the service wait on wall-clock timers
/// while robot time runs on (issue 22): two demos side by side on this 2-core machine starve
/// each other's threads, and the real-arm profile's drift over the longer robot time then spoils
/// its estimate (seen here: 3.2297 ± 0.1124 kg, refused, in 2 of 4 parallel runs; 0 of 6 alone).
static ONE_DEMO: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// `fri-demo demo --lockstep --json [extra] --out dir`: its report (the last line), once it
/// succeeded.
fn run_demo(extra: &[&str], dir: &std::path::Path) -> serde_json::Value {
    let _alone = ONE_DEMO
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let out = Command::new(env!("CARGO_BIN_EXE_fri-demo"))
        .args(["demo", "--lockstep", "--json"])
        .args(extra)
        .arg("--out")
        .arg(dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    serde_json::from_str(stdout.lines().last().unwrap()).unwrap()
}

/// A report's list of times, s.
fn seconds(list: &serde_json::Value) -> Vec<f64> {
    list.as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect()
}

#[test]
fn demo_in_lockstep_reports_the_estimate_and_the_three_contacts() {
    let dir = tempfile::tempdir().unwrap();
    let report = run_demo(&[], dir.path());
    let truth = report["payload_truth"]["mass"].as_f64().unwrap();
    let est = &report["payload_estimate"];
    let mass = est["mass"].as_f64().unwrap();
    assert!(((mass - truth) / truth).abs() < 0.0025, "{report}");
    for k in 0..3 {
        let c = est["com"][k].as_f64().unwrap();
        let t = report["payload_truth"]["com"][k].as_f64().unwrap();
        assert!((c - t).abs() < 0.005, "{report}");
        assert!(est["com_std"][k].as_f64().unwrap() > 0.0);
    }
    assert!(est["mass_std"].as_f64().unwrap() > 0.0);
    // The compensated residual detects each contact within 0.2 s and raises no false alarm;
    // without the payload the residual sits above the threshold (the paper's Fig. 6 problem).
    let det = seconds(&report["detections_compensated"]);
    assert_eq!(det.len(), 3, "{report}");
    for (d, c) in det.iter().zip([1.0, 8.0, 17.0]) {
        assert!(*d >= c && *d < c + 0.2, "{report}");
    }
    assert_eq!(report["false_alarms_compensated"], 0);
    // Robot time of the three controller runs: at least the free motion (20.5 s), the
    // calibration's contact-free run (26 s) and the two pattern runs; the wall time is reported
    // beside it. No upper bound: in lockstep the controller runs on while the service and the
    // demo wait on wall-clock timers (issue 22), so the robot time grows with the host's load
    // (60.8 s idle here, 128.2 s in a loaded CI run) — a timing, not an outcome.
    let robot = report["robot_time_s"].as_f64().unwrap();
    assert!(robot >= 50.0 && robot.is_finite(), "{report}");
    assert!(report["wall_time_s"].as_f64().unwrap() > 0.0, "{report}");
    assert!(report["false_alarms_uncompensated"].as_u64().unwrap() >= 1);
    let plots: Vec<std::path::PathBuf> = report["plots"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.as_str().unwrap().into())
        .collect();
    // Fig. 5 and Fig. 6, each as PNG and SVG.
    assert_eq!(plots.len(), 4, "{report}");
    for path in &plots {
        let bytes = std::fs::read(path).unwrap();
        match path.extension().and_then(|e| e.to_str()) {
            Some("png") => assert!(
                bytes.starts_with(b"\x89PNG\r\n\x1a\n") && bytes.len() > 10_000,
                "{}",
                path.display()
            ),
            Some("svg") => {
                let svg = String::from_utf8(bytes).unwrap();
                assert!(svg.contains("<svg"), "{}", path.display());
                // Quantity symbols with units on the axes, dashed thresholds labelled, contacts.
                assert!(svg.contains("t [s]"), "{}", path.display());
                assert!(
                    svg.contains("C1") && svg.contains("C3"),
                    "{}",
                    path.display()
                );
            }
            other => panic!("unexpected plot {other:?}"),
        }
    }
    let fig6 = std::fs::read_to_string(
        plots
            .iter()
            .find(|p| p.ends_with("fig6-residuals.svg"))
            .unwrap(),
    )
    .unwrap();
    assert!(
        fig6.contains("r [Nm]") && fig6.contains("θ = ±6 Nm"),
        "Fig. 6 labels"
    );
    let fig5 = std::fs::read_to_string(
        plots
            .iter()
            .find(|p| p.ends_with("fig5-torque-validation.svg"))
            .unwrap(),
    )
    .unwrap();
    assert!(fig5.contains("joint torque [Nm]"), "Fig. 5 labels");
    // Labels are text, never a literal TeX subscript.
    assert!(
        !fig5.contains("τ_") && !fig6.contains("τ_"),
        "literal underscores"
    );
    // Panel (c) marks where the monitor detected the three contacts.
    assert!(
        fig6.contains("monitor detection"),
        "Fig. 6 detection legend"
    );
    // One legend per figure (it was repeated on every panel), and in Fig. 6 one labelled
    // threshold per plotted joint (θ₁(t) … θ₇(t), in the joints' colours).
    // (plotters writes each text on a line of its own)
    let entries = |svg: &str, label: &str| svg.lines().filter(|l| l.trim() == label).count();
    for label in [
        "joint 1",
        "joint 7",
        "monitor detection",
        "contact onset C1–C3",
    ] {
        assert_eq!(entries(&fig6, label), 1, "Fig. 6 legend entry {label:?}");
    }
    for j in '₁'..='₇' {
        assert_eq!(entries(&fig6, &format!("θ{j}(t)")), 1, "Fig. 6 θ{j}(t)");
    }
    for label in ["measured", "computed (RNEA)", "contact onset C1–C3"] {
        assert_eq!(entries(&fig5, label), 1, "Fig. 5 legend entry {label:?}");
    }
}

/// Seeds 6 and 23 raised 21–87 false alarms on joint 6 (and a few on joint 1) while the demo
/// calibrated on a contact-free run of another simulated arm (the run's seed drew that arm's
/// sensor offsets); calibrated on the same arm with other noise (`arm_seed`), they detect the
/// three contacts and raise none (BENCHMARKS.md, "The demo over seeds 1–50").
#[test]
fn demo_seeds_that_once_calibrated_on_another_arm_raise_no_false_alarm() {
    for seed in ["6", "23"] {
        let dir = tempfile::tempdir().unwrap();
        let report = run_demo(&["--seed", seed], dir.path());
        assert_eq!(
            seconds(&report["detections_compensated"]).len(),
            3,
            "seed {seed}: {report}"
        );
        assert_eq!(
            report["false_alarms_compensated"], 0,
            "seed {seed}: {report}"
        );
    }
}

/// The demo on the real arm's profile (`--arm real-lwr4`: the identified LWR 4+ of
/// data/real-lwr4 with its offsets, friction and unexplained torque): the estimate's σ
/// grows to what that arm's torques allow and still covers the truth, and the three contacts
/// are detected.
#[test]
fn demo_on_the_real_arm_profile_keeps_an_honest_sigma_and_detects_the_contacts() {
    let dir = tempfile::tempdir().unwrap();
    let report = run_demo(&["--arm", "real-lwr4"], dir.path());
    let truth = report["payload_truth"]["mass"].as_f64().unwrap();
    let est = &report["payload_estimate"];
    let (mass, sigma) = (
        est["mass"].as_f64().unwrap(),
        est["mass_std"].as_f64().unwrap(),
    );
    // On the nominal arm σ is below 1 g; the real arm's unexplained torque (0.2–0.3 Nm,
    // correlated over about a second) cannot be averaged away over a few seconds per pose.
    assert!(sigma > 0.005, "{report}");
    assert!((mass - truth).abs() < 3.0 * sigma, "{report}");
    let det = seconds(&report["detections_compensated"]);
    for c in [1.0, 8.0, 17.0] {
        assert!(det.iter().any(|d| *d >= c && *d < c + 0.2), "{report}");
    }
}
