//! The stop socket's non-blocking read of one request line.

/// What a non-blocking read found.
pub(super) enum Read1 {
    /// A complete request line (without `\n` and a trailing `\r`).
    Line(Vec<u8>),
    /// Not yet a whole line.
    Partial,
    /// The client closed its side without a line.
    Closed,
    /// More than the line limit without a newline.
    TooLarge,
}

/// Reads what is there with `read` (non-blocking) into `buf` and looks for the first non-blank
/// line.
pub(super) fn read_available(
    mut read: impl FnMut(&mut [u8]) -> std::io::Result<usize>,
    buf: &mut Vec<u8>,
    max: usize,
) -> std::io::Result<Read1> {
    let mut chunk = [0u8; 512];
    loop {
        if let Some(line) = take_line(buf) {
            return Ok(Read1::Line(line));
        }
        if buf.len() > max {
            return Ok(Read1::TooLarge);
        }
        match read(&mut chunk) {
            Ok(0) => return Ok(Read1::Closed),
            Ok(n) => buf.extend_from_slice(&chunk[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => return Ok(Read1::Partial),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
}

/// The first non-blank line of `buf`, removed from it.
pub(super) fn take_line(buf: &mut Vec<u8>) -> Option<Vec<u8>> {
    loop {
        let end = buf.iter().position(|b| *b == b'\n')?;
        let mut line: Vec<u8> = buf.drain(..=end).collect();
        line.pop();
        if line.last() == Some(&b'\r') {
            line.pop();
        }
        if !line.iter().all(u8::is_ascii_whitespace) {
            return Some(line);
        }
    }
}
