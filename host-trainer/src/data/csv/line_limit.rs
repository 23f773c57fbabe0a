//! A bound on the length of a dataset line, enforced as the bytes are read.

use crate::error::TrainerError;

/// The longest line a dataset CSV may have \[bytes\], its `\n` excluded (a `\r` before it counts): far beyond any row of
/// numbers, and the most a reader holds of one line (a longer one is refused as it is read).
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// A line of [`MAX_LINE_BYTES`] bytes and more, found by [`LineLimit`] (physical line number,
/// 1-based).
#[derive(Debug)]
pub(super) struct LineTooLong {
    line: u64,
}

impl std::fmt::Display for LineTooLong {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {} is longer than {} bytes (the limit of a dataset line)", self.line, MAX_LINE_BYTES)
    }
}

impl std::error::Error for LineTooLong {}

/// A reader that fails as soon as a line grows past [`MAX_LINE_BYTES`], so that nothing above
/// it ever holds more of one line than that.
pub(super) struct LineLimit<R> {
    inner: R,
    /// Bytes of the current line so far.
    run: usize,
    /// Physical line number of the current line (1-based).
    line: u64,
}

impl<R> LineLimit<R> {
    pub(super) fn new(inner: R) -> Self {
        LineLimit { inner, run: 0, line: 1 }
    }

    /// The reader it reads from.
    pub(super) fn get_ref(&self) -> &R {
        &self.inner
    }
}

impl<R: std::io::Read> std::io::Read for LineLimit<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        for &b in &buf[..n] {
            if b == b'\n' {
                self.run = 0;
                self.line += 1;
            } else {
                self.run += 1;
                if self.run > MAX_LINE_BYTES {
                    return Err(std::io::Error::new(std::io::ErrorKind::InvalidData, LineTooLong { line: self.line }));
                }
            }
        }
        Ok(n)
    }
}

/// The [`LineTooLong`] inside an I/O error, if that is what it is.
pub(super) fn line_too_long(e: &std::io::Error) -> Option<&LineTooLong> {
    e.get_ref().and_then(|i| i.downcast_ref::<LineTooLong>())
}

/// The error of a line over [`MAX_LINE_BYTES`].
pub(super) fn line_error(name: &str, l: &LineTooLong) -> TrainerError {
    TrainerError::data(
        name,
        l.line,
        "-",
        format!("the line is longer than {MAX_LINE_BYTES} bytes (1 MiB, the limit of a dataset line): refused unread (not a dataset row?)"),
    )
}
