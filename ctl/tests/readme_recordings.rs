//! The README's block "With your own arm's recordings", run as written: every `cargo run -p
//! fri-ctl -- …` line of its first `sh` block, with `$D` the shared real recordings
//! (`data/real-lwr4`, beside every clone: a missing file fails), in a fresh directory
//! (the files the block writes, `arm.toml` and `thresholds.json`, are read by its later lines).
//! A line must succeed, except under the comment that promises "no payload is detected": there
//! it must fail (an offline command's exit 1) and say exactly that. Editing the block edits the test.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::path::Path;
use std::process::Command;

/// The first `sh` block after the heading `## With your own arm's recordings`, its
/// continuation lines joined, as (the comment above it, the command line).
fn readme_block() -> Vec<(String, String)> {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../README.md"))
            .unwrap();
    let section = &readme[readme.find("## With your own arm's recordings").unwrap()..];
    let start = section.find("```sh\n").unwrap() + "```sh\n".len();
    let block = &section[start..start + section[start..].find("```").unwrap()];
    let joined = block.replace("\\\n", " ");
    let mut comment = String::new();
    let mut out = Vec::new();
    for line in joined.lines().map(str::trim) {
        if let Some(c) = line.strip_prefix('#') {
            comment = c.trim().to_owned();
        } else if !line.is_empty() {
            out.push((comment.clone(), line.to_owned()));
        }
    }
    out
}

#[test]
fn the_readme_block_on_the_real_recordings_runs_as_written() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/real-lwr4");
    assert!(
        data.join("flobaroid-run1.csv").is_file(),
        "the real recordings must be beside the clone: {}",
        data.display()
    );
    let dir = tempfile::tempdir().unwrap();
    let lines = readme_block();
    assert_eq!(lines[0].1, "D=data/real-lwr4", "{lines:?}");
    let mut ran = 0;
    for (comment, line) in &lines[1..] {
        let args = line
            .strip_prefix("cargo run -p fri-ctl -- ")
            .unwrap_or_else(|| panic!("not a fri-ctl line: {line}"));
        let args: Vec<String> = args
            .split_whitespace()
            .map(|a| a.replace("$D", &data.display().to_string()))
            .collect();
        let out = Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
            .args(&args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        if comment.contains("no payload is detected") {
            assert_eq!(out.status.code(), Some(1), "{line}\n{text}");
            assert!(text.contains("no payload is detected"), "{line}\n{text}");
        } else {
            assert!(out.status.success(), "{line}\n{text}");
        }
        ran += 1;
    }
    // identify, monitor, calibrate-thresholds, monitor with them, three estimates.
    assert_eq!(ran, 7, "{lines:?}");
    assert!(dir.path().join("arm.toml").is_file());
    assert!(dir.path().join("thresholds.json").is_file());
}
