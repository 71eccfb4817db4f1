//! Line framing of the operator socket: newline-terminated lines with a size limit.
//!
//! Kept apart from connection handling (as in mini-redis) so the size and resynchronisation rules
//! are testable without sockets.

use tokio::io::{AsyncRead, AsyncReadExt};

/// One framed item read from a connection.
#[derive(Debug, PartialEq, Eq)]
pub enum Frame {
    /// A complete line without its terminating `\n` (and without a trailing `\r`).
    Line(Vec<u8>),
    /// A line longer than the limit; its bytes were discarded up to and including its newline.
    TooLarge,
}

/// Reads size-limited lines from a byte stream.
#[derive(Debug)]
pub struct LineReader<R> {
    inner: R,
    buffer: Vec<u8>,
    max_line: usize,
    /// True while skipping the rest of an oversized line.
    discarding: bool,
}

impl<R: AsyncRead + Unpin> LineReader<R> {
    /// Wraps a reader; lines longer than `max_line` bytes become [`Frame::TooLarge`].
    pub fn new(inner: R, max_line: usize) -> Self {
        Self {
            inner,
            buffer: Vec::with_capacity(1024),
            max_line,
            discarding: false,
        }
    }

    /// Next frame; `Ok(None)` at end of stream (a trailing unterminated line is dropped).
    pub async fn next_frame(&mut self) -> std::io::Result<Option<Frame>> {
        let mut chunk = [0u8; 4096];
        loop {
            if let Some(pos) = self.buffer.iter().position(|&b| b == b'\n') {
                let mut line: Vec<u8> = self.buffer.drain(..=pos).collect();
                line.pop();
                if self.discarding {
                    self.discarding = false;
                    continue;
                }
                if line.last() == Some(&b'\r') {
                    line.pop();
                }
                if line.len() > self.max_line {
                    return Ok(Some(Frame::TooLarge));
                }
                return Ok(Some(Frame::Line(line)));
            }
            if self.buffer.len() > self.max_line {
                // Report once, then skip to the next newline without buffering the rest.
                self.buffer.clear();
                if !self.discarding {
                    self.discarding = true;
                    return Ok(Some(Frame::TooLarge));
                }
            }
            let n = self.inner.read(&mut chunk).await?;
            if n == 0 {
                return Ok(None);
            }
            self.buffer.extend_from_slice(&chunk[..n]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    async fn frames(input: &[u8], max: usize) -> Vec<Frame> {
        let mut reader = LineReader::new(input, max);
        let mut out = Vec::new();
        while let Some(f) = reader.next_frame().await.unwrap() {
            out.push(f);
        }
        out
    }

    #[tokio::test]
    async fn splits_lines_and_strips_cr() {
        let f = frames(b"a\r\nbc\n\n", 10).await;
        assert_eq!(
            f,
            vec![
                Frame::Line(b"a".to_vec()),
                Frame::Line(b"bc".to_vec()),
                Frame::Line(Vec::new())
            ]
        );
    }

    #[tokio::test]
    async fn oversized_line_is_reported_once_and_stream_resynchronises() {
        let mut input = vec![b'x'; 20_000];
        input.extend_from_slice(b"\nok\n");
        let f = frames(&input, 100).await;
        assert_eq!(f, vec![Frame::TooLarge, Frame::Line(b"ok".to_vec())]);
    }

    #[tokio::test]
    async fn short_oversized_line_in_one_chunk() {
        let f = frames(b"0123456789AB\nz\n", 10).await;
        assert_eq!(f, vec![Frame::TooLarge, Frame::Line(b"z".to_vec())]);
    }

    #[tokio::test]
    async fn unterminated_tail_is_dropped() {
        assert_eq!(frames(b"a\nb", 10).await, vec![Frame::Line(b"a".to_vec())]);
    }
}
