//! Malformed and hostile logs are refused before anything is replayed, each with an error that
//! names the file, the line (or message) and the column with the range it must lie in.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::path::{Path, PathBuf};

use mock_robot::replay::{LogLimits, MAX_LOG_BYTES, ReplayError, read_log};

const HEADER: &str = "t,q1,q2,q3,q4,q5,q6,q7,tau1,tau2,tau3,tau4,tau5,tau6,tau7";

fn row(t: f64) -> String {
    format!("{t},0.1,0.5,0,-1,0,0.5,0,1,-20,0.5,10,0.1,0.2,0")
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn good_rows(n: usize) -> String {
    (0..n).map(|k| row(k as f64 * 0.005) + "\n").collect()
}

/// The error of reading `text` as a log, as the operator reads it.
fn refusal(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "log.csv", text);
    let e = read_log(&path, &LogLimits::default()).expect_err("refused");
    let shown = e.to_string();
    assert!(shown.starts_with(&path.display().to_string()), "{shown}");
    shown[path.display().to_string().len()..].to_owned()
}

#[test]
fn a_well_formed_log_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "log.csv",
        &format!("{HEADER}\n{}", good_rows(10)),
    );
    let log = read_log(&path, &LogLimits::default()).unwrap();
    assert_eq!(log.rows(), 10);
}

#[test]
fn missing_columns_are_named() {
    let header = HEADER.replace(",tau3", "");
    let e = refusal(&format!("{header}\n"));
    assert!(e.starts_with(": line 1: no column `tau3`"), "{e}");
    let e = refusal("q1,q2\n");
    assert!(e.starts_with(": line 1: no time column"), "{e}");
    let e = refusal(&format!("{HEADER},qd1,qd2\n{}", good_rows(3)));
    assert!(e.starts_with(": line 1: no column `qd3`"), "{e}");
    let e = refusal(&format!("{HEADER},q2\n"));
    assert!(
        e.starts_with(": line 1, column 16 (`q2`): the name appears twice"),
        "{e}"
    );
    let e = refusal("");
    assert!(e.contains("the file is empty"), "{e}");
}

#[test]
fn bad_values_name_line_column_and_range() {
    let nan = row(0.01).replacen("0.5", "NaN", 1);
    let e = refusal(&format!("{HEADER}\n{}{nan}\n", good_rows(2)));
    assert_eq!(e, ": line 4, column 3 (`q2`): NaN is not a finite number");
    let word = row(0.01).replacen(",1,", ",one,", 1);
    let e = refusal(&format!("{HEADER}\n{}{word}\n", good_rows(2)));
    assert_eq!(e, ": line 4, column 9 (`tau1`): `one` is not a number");
    let far = row(0.01).replacen(",-1,", ",-3,", 1);
    let e = refusal(&format!("{HEADER}\n{}{far}\n", good_rows(2)));
    assert_eq!(
        e,
        ": line 4, column 5 (`q4`): -3 rad is outside -2.1817..=2.1817 rad"
    );
    let strong = row(0.01).replacen(",-20,", ",-400,", 1);
    let e = refusal(&format!("{HEADER}\n{}{strong}\n", good_rows(2)));
    assert_eq!(
        e,
        ": line 4, column 10 (`tau2`): -400 Nm is outside -352.0000..=352.0000 Nm"
    );
    let short = "0.01,1,2,3";
    let e = refusal(&format!("{HEADER}\n{}{short}\n", good_rows(2)));
    assert_eq!(e, ": line 4: 4 fields, the header has 15");
    let e = refusal(&format!("{HEADER}\n{}\n\n{}\n", row(0.0), row(0.005)));
    assert_eq!(e, ": line 3: empty line");
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = format!("{HEADER}\n{}", good_rows(1)).into_bytes();
    bytes.extend_from_slice(b"0.01,\xFF\n");
    let path = dir.path().join("latin1.csv");
    std::fs::write(&path, bytes).unwrap();
    let e = read_log(&path, &LogLimits::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.ends_with(": line 3: not UTF-8 text: invalid utf-8 sequence of 1 bytes from index 5"),
        "{e}"
    );
}

#[test]
fn stamps_must_increase_and_not_jump() {
    let e = refusal(&format!(
        "{HEADER}\n{}\n{}\n{}\n",
        row(0.0),
        row(0.01),
        row(0.005)
    ));
    assert_eq!(
        e,
        ": line 4, column 1 (`t`): stamp 0.005 s is not after the previous one, 0.01 s: stamps \
         must increase"
    );
    let e = refusal(&format!("{HEADER}\n{}\n{}\n", row(0.0), row(0.0)));
    assert!(
        e.starts_with(": line 3, column 1 (`t`): stamp 0 s is not after"),
        "{e}"
    );
    let e = refusal(&format!("{HEADER}\n{}\n{}\n", row(0.0), row(2.0)));
    assert!(
        e.starts_with(": line 3, column 1 (`t`): stamp 2 s is 2.0000 s after the previous one"),
        "{e}"
    );
    let e = refusal(&format!("{HEADER}\n{}\n", row(0.0)));
    assert_eq!(e, ": 1 data rows; a replay needs at least 2");
}

#[test]
fn a_line_beyond_64_kib_is_refused_without_reading_it_whole() {
    let long = format!("{},{}", row(0.005), "0".repeat(70_000));
    let e = refusal(&format!("{HEADER}\n{}\n{long}\n", row(0.0)));
    assert_eq!(e, ": line 3: longer than 65536 bytes");
}

#[test]
fn a_10_gb_file_is_refused_before_it_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("huge.csv");
    let f = std::fs::File::create(&path).unwrap();
    // Sparse: claims 10 GB, occupies nothing.
    f.set_len(10_000_000_000).unwrap();
    let e = read_log(&path, &LogLimits::default()).unwrap_err();
    assert!(
        matches!(
            e,
            ReplayError::TooLarge {
                bytes: 10_000_000_000,
                limit: MAX_LOG_BYTES,
                ..
            }
        ),
        "{e}"
    );
    assert!(
        e.to_string()
            .contains("10000000000 bytes, more than the 2147483648 bytes")
    );
}

#[test]
fn more_rows_than_the_limit_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "log.csv",
        &format!("{HEADER}\n{}", good_rows(101)),
    );
    let limits = LogLimits {
        max_rows: 100,
        ..LogLimits::default()
    };
    let e = read_log(&path, &limits).unwrap_err();
    assert!(
        matches!(e, ReplayError::TooManyRows { limit: 100, .. }),
        "{e}"
    );
    assert!(
        read_log(
            &path,
            &LogLimits {
                max_rows: 101,
                ..limits
            }
        )
        .is_ok()
    );
    assert_eq!(LogLimits::default().max_rows, 2_000_000);
}

#[test]
fn symlinks_fifos_and_directories_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let target = write(
        dir.path(),
        "log.csv",
        &format!("{HEADER}\n{}", good_rows(3)),
    );
    let link = dir.path().join("link.csv");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let e = read_log(&link, &LogLimits::default()).unwrap_err();
    assert!(matches!(e, ReplayError::Symlink { .. }), "{e}");
    assert!(
        e.to_string()
            .ends_with("is a symbolic link; give the log file itself")
    );
    let e = read_log(dir.path(), &LogLimits::default()).unwrap_err();
    assert!(matches!(e, ReplayError::NotAFile { .. }), "{e}");
    let fifo = dir.path().join("fifo");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path; mkfifo has no other preconditions.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let e = read_log(&fifo, &LogLimits::default()).unwrap_err();
    assert!(matches!(e, ReplayError::NotAFile { .. }), "{e}");
    let e = read_log(&dir.path().join("missing.csv"), &LogLimits::default()).unwrap_err();
    assert!(matches!(e, ReplayError::Open { .. }), "{e}");
}

/// An MCAP file with one zstd chunk, made by the `mcap` writer.
fn mcap_file() -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    let mut writer = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        .create(&mut out)
        .unwrap();
    let schema = writer
        .add_schema("sensor_msgs/msg/JointState", "ros2msg", b"")
        .unwrap();
    let channel = writer
        .add_channel(schema, "/joint_states", "cdr", &Default::default())
        .unwrap();
    let js = fri_ros_msgs::sensor_msgs::JointState {
        position: vec![0.0; 7],
        effort: vec![0.0; 7],
        ..Default::default()
    };
    let data = fri_ros_msgs::cdr::encode_cdr(&js).unwrap();
    let header = mcap::records::MessageHeader {
        channel_id: channel,
        sequence: 0,
        log_time: 0,
        publish_time: 0,
    };
    writer.write_to_known_channel(&header, &data).unwrap();
    writer.finish().unwrap();
    drop(writer);
    out.into_inner()
}

#[test]
fn an_mcap_chunk_claiming_10_gb_is_refused_before_decompression() {
    let mut bytes = mcap_file();
    // The chunk record (opcode 0x06): opcode, u64 length, then message start and end times and
    // the uncompressed size.
    let magic = 8;
    let header_len = u64::from_le_bytes(bytes[magic + 1..magic + 9].try_into().unwrap()) as usize;
    let chunk = magic + 9 + header_len;
    assert_eq!(
        bytes[chunk], 0x06,
        "the writer puts the chunk after the header"
    );
    let size = chunk + 9 + 16;
    bytes[size..size + 8].copy_from_slice(&10_000_000_000u64.to_le_bytes());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("claim.mcap");
    std::fs::write(&path, &bytes).unwrap();
    let e = read_log(&path, &LogLimits::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("is a chunk of 10000000000 bytes uncompressed, more than the 67108864 bytes"),
        "{e}"
    );
}

#[test]
fn mcap_messages_with_the_wrong_shape_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("one.mcap");
    std::fs::write(&path, mcap_file()).unwrap();
    // One message is not enough to interpolate.
    let e = read_log(&path, &LogLimits::default()).unwrap_err();
    assert!(matches!(e, ReplayError::TooShort { rows: 1, .. }), "{e}");
    // Garbage after the magic.
    let mut bytes = b"\x89MCAP0\r\n".to_vec();
    bytes.extend_from_slice(&[0xFF; 64]);
    std::fs::write(&path, &bytes).unwrap();
    let e = read_log(&path, &LogLimits::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("MCAP"), "{e}");
}
