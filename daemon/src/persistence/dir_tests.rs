//! The checked directory against hostile owners, modes and planted files. The tests run as
//! root (as the service does next to the robot); `nobody` (uid 65534) plays the other user.

use super::*;
use std::os::unix::fs::{PermissionsExt, chown, symlink};

const NOBODY: u32 = 65534;

fn chmod(path: &Path, mode: u32) {
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).unwrap();
}

fn refused(path: &Path, rule: Rule) -> String {
    match CheckedDir::open(path, "state.dir", rule) {
        Err(e @ DirError::Untrusted { .. }) => e.to_string(),
        other => panic!("{} must be refused: {other:?}", path.display()),
    }
}

#[test]
fn missing_directories_are_created_without_write_for_others_and_the_path_is_real() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("a/b/state");
    let dir = CheckedDir::open(&path, "state.dir", Rule::Owned).unwrap();
    assert_eq!(
        dir.path(),
        tmp.path().canonicalize().unwrap().join("a/b/state")
    );
    for p in [tmp.path().join("a"), tmp.path().join("a/b"), path.clone()] {
        let mode = std::fs::metadata(&p).unwrap().permissions().mode();
        assert_eq!(mode & 0o022, 0, "{} has mode {mode:o}", p.display());
    }
    // Opening again checks the same directory.
    CheckedDir::open(&path, "state.dir", Rule::Owned).unwrap();
}

#[test]
fn a_directory_owned_by_another_user_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let state = tmp.path().join("state");
    std::fs::create_dir(&state).unwrap();
    chown(&state, Some(NOBODY), Some(NOBODY)).unwrap();
    let e = refused(&state, Rule::Owned);
    assert!(
        e.contains("state.dir") && e.contains(&state.display().to_string()),
        "{e}"
    );
    assert!(e.contains("owned by uid 65534"), "{e}");
    // A socket's directory may be root's, never another user's.
    let e = refused(&state, Rule::Trusted);
    assert!(e.contains("owned by uid 65534"), "{e}");
}

#[test]
fn a_directory_writable_by_group_or_others_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let state = tmp.path().join("state");
    std::fs::create_dir(&state).unwrap();
    for mode in [0o777, 0o775, 0o757, 0o1777] {
        chmod(&state, mode);
        let e = refused(&state, Rule::Owned);
        assert!(e.contains("writable by group or others"), "{mode:o}: {e}");
    }
    chmod(&state, 0o755);
    CheckedDir::open(&state, "state.dir", Rule::Owned).unwrap();
}

#[test]
fn a_parent_another_user_owns_is_refused_before_anything_is_created_in_it() {
    // The attack: `/tmp/fri-service` created by nobody before the service starts.
    let tmp = tempfile::tempdir().unwrap();
    let parent = tmp.path().join("fri-service");
    std::fs::create_dir(&parent).unwrap();
    chmod(&parent, 0o755);
    chown(&parent, Some(NOBODY), Some(NOBODY)).unwrap();
    let state = parent.join("state");
    let e = refused(&state, Rule::Owned);
    assert!(
        e.contains(&parent.display().to_string()) && e.contains("parent") && e.contains("65534"),
        "{e}"
    );
    assert!(
        !state.exists(),
        "nothing is created below an untrusted parent"
    );
}

#[test]
fn a_parent_writable_by_others_is_refused_unless_it_is_sticky_and_root_owned() {
    let tmp = tempfile::tempdir().unwrap();
    let parent = tmp.path().join("shared");
    std::fs::create_dir(&parent).unwrap();
    let state = parent.join("state");
    chmod(&parent, 0o777);
    let e = refused(&state, Rule::Owned);
    assert!(e.contains("not sticky") && e.contains("0777"), "{e}");
    chmod(&parent, 0o775);
    refused(&state, Rule::Owned);
    // Like /tmp: nobody else can rename or remove what the service creates in it.
    chmod(&parent, 0o1777);
    CheckedDir::open(&state, "state.dir", Rule::Owned).unwrap();
    // A sticky directory of another user is still theirs.
    chown(&parent, Some(NOBODY), Some(NOBODY)).unwrap();
    refused(&state, Rule::Owned);
}

#[test]
fn the_directory_itself_as_a_symlink_is_refused_a_symlinked_parent_is_resolved() {
    let tmp = tempfile::tempdir().unwrap();
    let real = tmp.path().join("real");
    std::fs::create_dir(&real).unwrap();
    let link = tmp.path().join("link");
    symlink(&real, &link).unwrap();
    let e = refused(&link, Rule::Owned);
    assert!(e.contains("symbolic link"), "{e}");
    // A dangling symlink is not created through either.
    let dangling = tmp.path().join("dangling");
    symlink(tmp.path().join("nowhere"), &dangling).unwrap();
    refused(&dangling, Rule::Owned);
    assert!(!tmp.path().join("nowhere").exists());
    // A symlinked parent (as /var/run -> /run) is followed, then checked on its real path.
    let dir = CheckedDir::open(&link.join("state"), "state.dir", Rule::Owned).unwrap();
    assert_eq!(dir.path(), real.canonicalize().unwrap().join("state"));
}

#[test]
fn a_directory_renamed_and_replaced_by_a_symlink_after_the_check_is_not_followed() {
    let tmp = tempfile::tempdir().unwrap();
    let state = tmp.path().join("state");
    let dir = CheckedDir::open(&state, "state.dir", Rule::Owned).unwrap();
    let outside = tmp.path().join("outside");
    std::fs::create_dir(&outside).unwrap();
    std::fs::rename(&state, tmp.path().join("moved")).unwrap();
    symlink(&outside, &state).unwrap();
    dir.create_new("x.json", 0o644).unwrap();
    assert!(tmp.path().join("moved/x.json").exists());
    assert!(
        !outside.join("x.json").exists(),
        "written through the swapped path"
    );
}

#[test]
fn reads_refuse_symlinks_pipes_foreign_writable_and_oversized_files() {
    let tmp = tempfile::tempdir().unwrap();
    let state = tmp.path().join("state");
    let dir = CheckedDir::open(&state, "state.dir", Rule::Owned).unwrap();
    let secret = tmp.path().join("secret");
    std::fs::write(&secret, "{\"mass\": 6.9}").unwrap();
    symlink(&secret, state.join("link.json")).unwrap();
    let e = dir.read("link.json", 1000).unwrap_err().to_string();
    assert!(e.contains("symbolic link"), "{e}");

    let fifo = cstring(state.join("pipe.json").as_os_str()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o644) }, 0);
    let e = dir.read("pipe.json", 1000).unwrap_err().to_string();
    assert!(e.contains("named pipe"), "{e}");

    let foreign = state.join("foreign.json");
    std::fs::write(&foreign, "null").unwrap();
    chown(&foreign, Some(NOBODY), Some(NOBODY)).unwrap();
    let e = dir.read("foreign.json", 1000).unwrap_err().to_string();
    assert!(e.contains("owned by uid 65534"), "{e}");

    let writable = state.join("writable.json");
    std::fs::write(&writable, "null").unwrap();
    chmod(&writable, 0o666);
    let e = dir.read("writable.json", 1000).unwrap_err().to_string();
    assert!(e.contains("writable by group or others"), "{e}");

    std::fs::write(state.join("big.json"), vec![b' '; 1001]).unwrap();
    let e = dir.read("big.json", 1000).unwrap_err().to_string();
    assert!(e.contains("more than 1000"), "{e}");

    std::fs::write(state.join("ok.json"), "null").unwrap();
    assert_eq!(dir.read("ok.json", 1000).unwrap().unwrap(), b"null");
    assert_eq!(dir.read("absent.json", 1000).unwrap(), None);
    assert!(dir.read("../secret", 1000).is_err(), "a path, not a name");
}

#[test]
fn new_files_are_never_created_through_a_planted_symlink() {
    let tmp = tempfile::tempdir().unwrap();
    let state = tmp.path().join("state");
    let dir = CheckedDir::open(&state, "state.dir", Rule::Owned).unwrap();
    let target = tmp.path().join("target");
    symlink(&target, state.join("new.json")).unwrap();
    assert!(dir.create_new("new.json", 0o644).is_err());
    assert!(!target.exists());
    let names = dir.names().unwrap();
    assert_eq!(names, vec![OsString::from("new.json")]);
}
