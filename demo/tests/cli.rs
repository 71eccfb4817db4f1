//! `cargo run --release -- demo`: the demo's report, end to end in lockstep.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::process::Command;

#[test]
fn demo_in_lockstep_reports_the_estimate_and_the_three_contacts() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fri-demo"))
        .args(["demo", "--lockstep", "--json", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let report: serde_json::Value = serde_json::from_str(stdout.lines().last().unwrap()).unwrap();
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
    let det: Vec<f64> = report["detections_compensated"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(det.len(), 3, "{report}");
    for (d, c) in det.iter().zip([1.0, 8.0, 17.0]) {
        assert!(*d >= c && *d < c + 0.2, "{report}");
    }
    assert_eq!(report["false_alarms_compensated"], 0);
    // Robot time of the three controller runs: the free motion (20.5 s), the calibration's
    // contact-free run (26 s) and the two pattern runs; the wall time is reported beside it.
    let robot = report["robot_time_s"].as_f64().unwrap();
    assert!((50.0..120.0).contains(&robot), "{report}");
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
}
