//! What every board's serial link shares: the blocking read of `embedded_io::Read` over a
//! receiver that polls one byte at a time and idles (sleeps or spins) between bytes.

/// A serial receiver polled a byte at a time.
pub trait ByteReceiver {
    /// The next received byte, if one is there (without blocking).
    fn try_read_byte(&mut self) -> Option<u8>;
    /// Wait for the next event (sleep until a byte may have arrived, or spin).
    fn idle(&mut self);
}

/// `embedded_io::Read::read` over `rx`: block until at least one byte arrived, then take what
/// is there without blocking, up to `buf.len()`. Returns the bytes read (0 only for an empty
/// `buf`).
pub fn read_available(rx: &mut impl ByteReceiver, buf: &mut [u8]) -> usize {
    let mut n = 0;
    for slot in buf.iter_mut() {
        let byte = loop {
            match rx.try_read_byte() {
                Some(b) => break Some(b),
                None if n > 0 => break None,
                None => rx.idle(),
            }
        };
        match byte {
            Some(b) => {
                *slot = b;
                n += 1;
            }
            None => break,
        }
    }
    n
}
