//! The file-system calls of a held directory: `openat`, `fstat`, `fstatat`, directory listing,
//! each relative to a descriptor and never following a symbolic link unless asked.

use std::ffi::{CString, OsStr, OsString};
use std::io;
use std::os::fd::{AsRawFd, BorrowedFd, FromRawFd, OwnedFd};
use std::os::unix::ffi::OsStrExt;

/// What `fstat` says of a file: type, owner, mode bits.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Stat {
    /// `st_mode` (type and permission bits).
    pub(crate) mode: libc::mode_t,
    /// Owner.
    pub(crate) uid: u32,
    /// Size, bytes.
    pub(crate) size: u64,
}

impl Stat {
    /// From the C structure.
    pub(crate) fn of(st: &libc::stat) -> Self {
        Self {
            mode: st.st_mode,
            uid: st.st_uid,
            size: u64::try_from(st.st_size).unwrap_or(0),
        }
    }
    /// Whether it is a directory.
    pub(crate) fn is_dir(&self) -> bool {
        self.mode & libc::S_IFMT == libc::S_IFDIR
    }
    /// Whether it is a regular file.
    pub(crate) fn is_file(&self) -> bool {
        self.mode & libc::S_IFMT == libc::S_IFREG
    }
    /// Whether it is a Unix socket.
    pub(crate) fn is_socket(&self) -> bool {
        self.mode & libc::S_IFMT == libc::S_IFSOCK
    }
    /// Whether group or others may write it.
    pub(crate) fn writable_by_others(&self) -> bool {
        self.mode & 0o022 != 0
    }
    /// Whether the sticky bit is set (only owners rename or remove entries).
    pub(crate) fn sticky(&self) -> bool {
        self.mode & libc::S_ISVTX != 0
    }
    /// What kind of file this is, for messages.
    pub(crate) fn kind(&self) -> &'static str {
        match self.mode & libc::S_IFMT {
            libc::S_IFREG => "regular file",
            libc::S_IFDIR => "directory",
            libc::S_IFLNK => "symbolic link",
            libc::S_IFIFO => "named pipe",
            libc::S_IFSOCK => "socket",
            libc::S_IFCHR | libc::S_IFBLK => "device",
            _ => "file of unknown type",
        }
    }
}

/// `name` as a C string (a NUL byte inside is invalid input).
pub(crate) fn cstring(name: &OsStr) -> io::Result<CString> {
    CString::new(name.as_bytes()).map_err(|_| io::Error::from(io::ErrorKind::InvalidInput))
}

/// `fstat` of an open descriptor.
pub(crate) fn fstat(fd: BorrowedFd<'_>) -> io::Result<Stat> {
    let mut st = std::mem::MaybeUninit::<libc::stat>::uninit();
    // SAFETY: `fd` is open for the call; `st` is a valid out-pointer of the right type.
    if unsafe { libc::fstat(fd.as_raw_fd(), st.as_mut_ptr()) } != 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: fstat succeeded, so it initialised `st`.
    let st = unsafe { st.assume_init() };
    Ok(Stat::of(&st))
}

/// `openat(dir, name, flags | O_CLOEXEC, mode)`.
pub(crate) fn openat(
    dir: BorrowedFd<'_>,
    name: &CString,
    flags: libc::c_int,
    mode: libc::mode_t,
) -> io::Result<OwnedFd> {
    // SAFETY: `dir` is open, `name` is NUL-terminated and outlives the call.
    let fd = unsafe {
        libc::openat(
            dir.as_raw_fd(),
            name.as_ptr(),
            flags | libc::O_CLOEXEC,
            libc::c_uint::from(mode),
        )
    };
    if fd < 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: openat returned a new descriptor that nothing else owns.
    Ok(unsafe { OwnedFd::from_raw_fd(fd) })
}

/// `fstatat(dir, name, AT_SYMLINK_NOFOLLOW)`.
pub(crate) fn lstat_at(dir: BorrowedFd<'_>, name: &CString) -> io::Result<Stat> {
    let mut st = std::mem::MaybeUninit::<libc::stat>::uninit();
    // SAFETY: `dir` is open, `name` NUL-terminated, `st` a valid out-pointer.
    let r = unsafe {
        libc::fstatat(
            dir.as_raw_fd(),
            name.as_ptr(),
            st.as_mut_ptr(),
            libc::AT_SYMLINK_NOFOLLOW,
        )
    };
    if r != 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: fstatat succeeded, so it initialised `st`.
    let st = unsafe { st.assume_init() };
    Ok(Stat::of(&st))
}

/// `name` as a single path component (no `/`, not `.` or `..`, not empty).
pub(crate) fn single(name: &str) -> io::Result<CString> {
    if name.is_empty() || name == "." || name == ".." || name.contains('/') {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{name:?} is not a file name"),
        ));
    }
    cstring(OsStr::new(name))
}

/// The names in the directory `dir` (without `.` and `..`).
pub(crate) fn names(dir: BorrowedFd<'_>) -> io::Result<Vec<OsString>> {
    // A descriptor of its own: closedir closes it.
    let own = openat(
        dir,
        &cstring(OsStr::new("."))?,
        libc::O_RDONLY | libc::O_DIRECTORY,
        0,
    )?;
    // SAFETY: `own` is an open directory descriptor whose ownership passes to the stream.
    let stream = unsafe { libc::fdopendir(own.as_raw_fd()) };
    if stream.is_null() {
        return Err(io::Error::last_os_error());
    }
    std::mem::forget(own);
    let mut names = Vec::new();
    loop {
        // SAFETY: `stream` is a valid open directory stream until closedir below.
        let entry = unsafe { libc::readdir(stream) };
        if entry.is_null() {
            break;
        }
        // SAFETY: readdir returned a valid entry whose d_name is NUL-terminated and stays
        // valid until the next readdir on this stream.
        let name = unsafe { std::ffi::CStr::from_ptr((*entry).d_name.as_ptr()) };
        let bytes = name.to_bytes();
        if bytes != b"." && bytes != b".." {
            names.push(OsStr::from_bytes(bytes).to_owned());
        }
    }
    // SAFETY: `stream` is open; closedir releases it and its descriptor.
    unsafe { libc::closedir(stream) };
    Ok(names)
}
