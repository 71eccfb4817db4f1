//! Standard output of the binaries without panics.
//!
//! `println!` panics when stdout cannot be written (a full disk, `> /dev/full`, a reader that
//! went away as in `fri-ctl watch | head -1`; Rust ignores SIGPIPE, so the write fails with
//! EPIPE). The binaries write through [`Stdout`] instead, which remembers the first failure so
//! that `main` can tell it apart from the command's own errors: a closed pipe ends the program
//! quietly with [`EXIT_BROKEN_PIPE`], any other failure is reported as
//! "cannot write to stdout: …" on stderr.

use std::io::{self, Write};

/// Exit status after the reader closed stdout: 128 + SIGPIPE, what a shell reports for a program
/// that SIGPIPE ended.
pub const EXIT_BROKEN_PIPE: u8 = 141;

/// How writing to stdout failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StdoutFailure {
    kind: io::ErrorKind,
    os: Option<i32>,
}

impl StdoutFailure {
    fn of(e: &io::Error) -> Self {
        Self {
            kind: e.kind(),
            os: e.raw_os_error(),
        }
    }

    /// Whether the reader closed the pipe (nothing to report, just stop).
    pub fn is_broken_pipe(&self) -> bool {
        self.kind == io::ErrorKind::BrokenPipe
    }

    /// Ends the program's output: quietly on a closed pipe ([`EXIT_BROKEN_PIPE`]), otherwise
    /// reports the error on stderr and returns `code`.
    pub fn exit_code(&self, code: u8) -> u8 {
        if self.is_broken_pipe() {
            return EXIT_BROKEN_PIPE;
        }
        let e = match self.os {
            Some(os) => io::Error::from_raw_os_error(os),
            None => io::Error::from(self.kind),
        };
        stderr_line(format_args!("error: cannot write to stdout: {e}"));
        code
    }
}

/// Locked stdout that remembers its first write or flush error.
#[derive(Debug)]
pub struct Stdout {
    inner: io::StdoutLock<'static>,
    failure: Option<StdoutFailure>,
}

impl Default for Stdout {
    fn default() -> Self {
        Self::new()
    }
}

impl Stdout {
    /// Locks the process's stdout.
    pub fn new() -> Self {
        Self {
            inner: io::stdout().lock(),
            failure: None,
        }
    }

    /// The first failure, if any write or flush failed so far.
    pub fn failure(&self) -> Option<StdoutFailure> {
        self.failure
    }

    /// Flushes and returns the first failure of the whole run (drop would ignore it).
    pub fn finish(&mut self) -> Option<StdoutFailure> {
        let _ = self.flush();
        self.failure
    }

    fn note<T>(&mut self, r: io::Result<T>) -> io::Result<T> {
        if let Err(e) = &r
            && self.failure.is_none()
            && e.kind() != io::ErrorKind::Interrupted
        {
            self.failure = Some(StdoutFailure::of(e));
        }
        r
    }
}

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let r = self.inner.write(buf);
        self.note(r)
    }

    fn flush(&mut self) -> io::Result<()> {
        let r = self.inner.flush();
        self.note(r)
    }
}

/// Writes one line to stderr, ignoring failure (there is nowhere left to report it).
pub fn stderr_line(args: std::fmt::Arguments<'_>) {
    let _ = writeln!(io::stderr().lock(), "{args}");
}

/// Handles a clap parse "error": help and version go to [`Stdout`], usage errors to stderr.
/// Returns the exit status; `failed` is used when the help text cannot be written.
pub fn clap_exit(e: &clap::Error, failed: u8) -> u8 {
    if e.use_stderr() {
        // Nothing to do if stderr itself is gone.
        let _ = e.print();
        return u8::try_from(e.exit_code()).unwrap_or(2);
    }
    let mut out = Stdout::new();
    let _ = write!(out, "{}", e.render().ansi());
    match out.finish() {
        Some(f) => f.exit_code(failed),
        None => 0,
    }
}

/// The process's exit status after a run that returned `result`: a failed write to stdout
/// decides first (quietly for a closed pipe), then the run's own error, printed on stderr with
/// its context chain (`{:#}`); `failed` is the binary's status for a failure.
pub fn exit_status<E: std::fmt::Display>(
    result: Result<(), E>,
    stdout: &mut Stdout,
    failed: u8,
) -> u8 {
    match (result, stdout.finish()) {
        (_, Some(f)) => f.exit_code(failed),
        (Ok(()), None) => 0,
        (Err(e), None) => {
            stderr_line(format_args!("error: {e:#}"));
            failed
        }
    }
}
