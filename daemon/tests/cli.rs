//! `fri-service`'s command line: configuration errors name the key; a full stdout is reported,
//! not a panic.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::process::{Command, Stdio};

#[test]
fn fri_service_help_into_a_full_disk_reports_stdout() {
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fri-service"))
        .arg("--help")
        .stdout(Stdio::from(full))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_ne!(out.status.code(), Some(101), "panicked: {err}");
    assert_ne!(out.status.code(), Some(0), "claims success: {err}");
    assert!(err.contains("cannot write to stdout"), "{err}");
}

#[test]
fn fri_service_rejects_a_bad_config_with_the_key_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(
        &path,
        "[observer]\nthresholds = [6.0, 6.0, 6.0, 6.0, 6.0, 6.0, 0.0]\n",
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fri-service"))
        .args(["run", "--config"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("observer.thresholds[6] (joint 7)"), "{err}");

    std::fs::write(&path, "[operator]\nsokcet = \"/tmp/x\"\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fri-service"))
        .args(["run", "--config"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("sokcet"), "{err}");
}
