//! The host side of the device link ([`fbg_shared::protocol`]) over any `std::io::Read + Write`:
//! a TCP socket to QEMU's serial port, a serial-port handle to a real board, or an in-memory
//! pipe in tests.
//!
//! The client speaks in lock-step (one request, one answer), which is the link's flow control.
//!
//! Time-outs bound a whole answer, not a single read: [`LinkClient::with_answer_timeout`] gives
//! every answer a deadline (from the request sent to the answer's last byte) and sets the
//! stream's read time-out before each read to what is left of it, so a device that trickles a
//! byte now and then fails with [`LinkError::TimedOut`] at the deadline like a silent one. A
//! time-out set on the stream alone (`TcpStream::set_read_timeout`) bounds each read only.
//!
//! ```no_run
//! # fn main() -> Result<(), fbg_link::LinkError> {
//! use fbg_link::LinkClient;
//! let stream = std::net::TcpStream::connect("127.0.0.1:4321")?;
//! let mut link = LinkClient::with_answer_timeout(stream, std::time::Duration::from_secs(5))?;
//! link.ping(1)?;
//! let blob = std::fs::read("model.fbgm")?;
//! let result = link.update_model(&blob)?; // Accepted, or Rejected with the reason
//! println!("{result:?}");
//! # Ok(()) }
//! ```

use std::io::{ErrorKind, Read, Write};
use std::time::{Duration, Instant};

use fbg_shared::protocol::{
    crc32, encode_host, DeviceEstimate, DeviceMsg, Feed, FrameReader, HostMsg, Malformed, Status, UpdateResult,
    DEVICE_MAX_FRAME, HOST_MAX_FRAME, MAX_CHUNK,
};
use fbg_shared::Sample;

/// What can go wrong talking to a device.
#[derive(Debug)]
#[non_exhaustive]
pub enum LinkError {
    /// The stream failed (or a read timed out on a stream without an answer deadline).
    Io(std::io::Error),
    /// The device's answer was not complete within the answer deadline
    /// ([`LinkClient::with_answer_timeout`]); `received` bytes of it had arrived.
    TimedOut {
        /// The deadline of one answer.
        timeout: Duration,
        /// Bytes received while waiting (a trickling device sends some, a silent one none).
        received: usize,
    },
    /// The stream ended (the device or emulator went away).
    Closed,
    /// The device sent a frame the client could not decode.
    Malformed(Malformed),
    /// The device answered with something other than the expected message.
    Unexpected {
        /// What the client was waiting for.
        expected: &'static str,
        /// What arrived (boxed: a `Status` is large, and every `Result` of the client carries
        /// this error).
        got: Box<DeviceMsg>,
    },
    /// A message could not be framed (only for blobs or chunks beyond the protocol limits).
    TooLarge,
}

impl core::fmt::Display for LinkError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LinkError::Io(e) => write!(f, "device link I/O error: {e}"),
            LinkError::TimedOut { timeout, received } => write!(
                f,
                "the device did not complete its answer within {:.3} s ({received} bytes received meanwhile)",
                timeout.as_secs_f64()
            ),
            LinkError::Closed => f.write_str("device link closed"),
            LinkError::Malformed(m) => write!(f, "malformed frame from the device: {m}"),
            LinkError::Unexpected { expected, got } => {
                write!(f, "device answered {got:?} where {expected} was expected")
            }
            LinkError::TooLarge => f.write_str("message too large for the link protocol"),
        }
    }
}

impl std::error::Error for LinkError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            LinkError::Io(e) => Some(e),
            _ => None,
        }
    }
}

impl From<std::io::Error> for LinkError {
    fn from(e: std::io::Error) -> Self {
        LinkError::Io(e)
    }
}

/// A stream whose reads can be given a time-out, so that [`LinkClient`] can hold a whole
/// answer to a deadline.
pub trait ReadTimeout {
    /// Bound the next reads (`None`: block).
    fn set_read_timeout(&self, timeout: Option<Duration>) -> std::io::Result<()>;
}

impl ReadTimeout for std::net::TcpStream {
    fn set_read_timeout(&self, timeout: Option<Duration>) -> std::io::Result<()> {
        std::net::TcpStream::set_read_timeout(self, timeout)
    }
}

/// Sets the stream's read time-out to what is left of an answer's deadline.
type SetReadTimeout<S> = fn(&S, Option<Duration>) -> std::io::Result<()>;

/// A lock-step client of one device.
pub struct LinkClient<S> {
    io: S,
    /// The deadline of each answer, from the request sent to the answer's last byte.
    answer_timeout: Option<Duration>,
    /// How to bound a read by the time left (without it the deadline is checked after each
    /// read, which bounds a trickling device but not a read that blocks).
    set_read_timeout: Option<SetReadTimeout<S>>,
    reader: FrameReader<DEVICE_MAX_FRAME>,
    /// Received bytes not fed to the reader yet.
    pending: Vec<u8>,
    /// Device frames that did not decode (the client skips them and keeps waiting).
    malformed: u32,
}

impl<S: Read + Write> LinkClient<S> {
    /// Wrap a connected stream.
    pub fn new(io: S) -> Self {
        LinkClient {
            io,
            answer_timeout: None,
            set_read_timeout: None,
            reader: FrameReader::new(),
            pending: Vec::new(),
            malformed: 0,
        }
    }

    /// Wrap a connected stream and give every answer `timeout`: a device whose answer is not
    /// complete by then, however many bytes it sends meanwhile, is [`LinkError::TimedOut`].
    pub fn with_answer_timeout(io: S, timeout: Duration) -> Result<Self, LinkError>
    where
        S: ReadTimeout,
    {
        let mut link = LinkClient::new(io);
        link.answer_timeout = Some(timeout);
        link.set_read_timeout = Some(<S as ReadTimeout>::set_read_timeout);
        link.io.set_read_timeout(Some(timeout))?;
        Ok(link)
    }

    /// Give every answer a deadline on a stream without [`ReadTimeout`]: checked after each
    /// read, so a read that blocks must be bounded by the stream itself.
    pub fn set_answer_timeout(&mut self, timeout: Option<Duration>) {
        self.answer_timeout = timeout;
    }

    /// The underlying stream.
    pub fn get_ref(&self) -> &S {
        &self.io
    }

    /// The underlying stream, mutably (e.g. to change its time-out).
    pub fn get_mut(&mut self) -> &mut S {
        &mut self.io
    }

    /// Give the stream back.
    pub fn into_inner(self) -> S {
        self.io
    }

    /// Device frames that could not be decoded so far (skipped).
    pub fn malformed_from_device(&self) -> u32 {
        self.malformed
    }

    /// Send one message without waiting for an answer.
    pub fn send(&mut self, msg: &HostMsg<'_>) -> Result<(), LinkError> {
        let mut buf = [0u8; HOST_MAX_FRAME];
        let frame = encode_host(msg, &mut buf).map_err(|_| LinkError::TooLarge)?;
        self.io.write_all(frame)?;
        self.io.flush()?;
        Ok(())
    }

    /// Send raw bytes (tests: garbage, damaged frames).
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.io.write_all(bytes)?;
        self.io.flush()?;
        Ok(())
    }

    /// Wait for the next decodable device message, until the answer deadline when there is one.
    /// Malformed device frames are counted and skipped.
    pub fn recv(&mut self) -> Result<DeviceMsg, LinkError> {
        let deadline = self.answer_timeout.map(|t| (t, Instant::now() + t));
        let mut received = 0usize;
        loop {
            // Drain what is buffered first.
            let mut consumed = 0;
            let mut found = None;
            {
                let mut window: &[u8] = &self.pending;
                while !window.is_empty() {
                    let before = window.len();
                    let (ev, rest) = self.reader.feed::<DeviceMsg>(window);
                    consumed += before - rest.len();
                    window = rest;
                    match ev {
                        Feed::Pending => {}
                        Feed::Malformed(_) => self.malformed += 1,
                        Feed::Message(m) => {
                            found = Some(m);
                            break;
                        }
                    }
                }
            }
            self.pending.drain(..consumed.min(self.pending.len()));
            if let Some(m) = found {
                return Ok(m);
            }
            let mut buf = [0u8; 512];
            if let Some((timeout, at)) = deadline {
                let left = at.saturating_duration_since(Instant::now());
                if left.is_zero() {
                    return Err(LinkError::TimedOut { timeout, received });
                }
                if let Some(set) = self.set_read_timeout {
                    set(&self.io, Some(left))?;
                }
            }
            let n = match self.io.read(&mut buf) {
                Ok(n) => n,
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    return Err(match deadline {
                        Some((timeout, _)) => LinkError::TimedOut { timeout, received },
                        None => LinkError::Io(e),
                    })
                }
                Err(e) => return Err(e.into()),
            };
            received += n;
            if n == 0 {
                return Err(LinkError::Closed);
            }
            self.pending.extend_from_slice(buf.get(..n).unwrap_or(&[]));
        }
    }

    /// Send `msg` and wait for its answer.
    pub fn request(&mut self, msg: &HostMsg<'_>) -> Result<DeviceMsg, LinkError> {
        self.send(msg)?;
        self.recv()
    }

    /// Round trip a ping; fails unless the device echoes `nonce`.
    pub fn ping(&mut self, nonce: u32) -> Result<(), LinkError> {
        match self.request(&HostMsg::Ping { nonce })? {
            DeviceMsg::Pong { nonce: n } if n == nonce => Ok(()),
            got => Err(LinkError::Unexpected { expected: "Pong with the same nonce", got: Box::new(got) }),
        }
    }

    /// Reset the device's stream state (direction latches, memory operators) and set the new
    /// stream's clock (the band's lead time).
    pub fn reset_stream(&mut self, nonce: u32, clock: fbg_shared::StreamClock) -> Result<(), LinkError> {
        match self.request(&HostMsg::ResetStream { nonce, clock })? {
            DeviceMsg::Pong { nonce: n } if n == nonce => Ok(()),
            got => Err(LinkError::Unexpected { expected: "Pong after ResetStream", got: Box::new(got) }),
        }
    }

    /// Compensate one sample on the device.
    pub fn compensate(&mut self, seq: u32, sample: &Sample<f32>) -> Result<DeviceEstimate, LinkError> {
        match self.request(&HostMsg::Sample { seq, sample: *sample })? {
            DeviceMsg::Estimate(e) if e.seq == seq => Ok(e),
            got => Err(LinkError::Unexpected { expected: "Estimate with the same seq", got: Box::new(got) }),
        }
    }

    /// Compensate every sample in order, numbering them from `first_seq`, and hand each answer
    /// to `on_estimate` (which may stop the stream by returning an error). Returns the count.
    pub fn stream<I, E>(
        &mut self,
        first_seq: u32,
        samples: I,
        mut on_estimate: impl FnMut(&Sample<f32>, &DeviceEstimate) -> Result<(), E>,
    ) -> Result<u32, E>
    where
        I: IntoIterator<Item = Sample<f32>>,
        E: From<LinkError>,
    {
        let mut n = 0u32;
        for s in samples {
            let est = self.compensate(first_seq.wrapping_add(n), &s)?;
            on_estimate(&s, &est)?;
            n += 1;
        }
        Ok(n)
    }

    /// The device's counters and active model.
    pub fn status(&mut self) -> Result<Status, LinkError> {
        match self.request(&HostMsg::GetStatus)? {
            DeviceMsg::Status(s) => Ok(s),
            got => Err(LinkError::Unexpected { expected: "Status", got: Box::new(got) }),
        }
    }

    /// Send a model blob (begin, chunks of [`MAX_CHUNK`], commit) and return the device's
    /// verdict. A rejection at any step ends the transfer and is returned as
    /// `Ok(UpdateResult::Rejected(..))`: the device then still runs its previous model.
    pub fn update_model(&mut self, blob: &[u8]) -> Result<UpdateResult, LinkError> {
        self.update_model_with(blob, crc32(blob), MAX_CHUNK)
    }

    /// [`Self::update_model`] with an explicit transfer CRC and chunk size (tests use these to
    /// provoke transfer errors).
    pub fn update_model_with(
        &mut self,
        blob: &[u8],
        transfer_crc: u32,
        chunk: usize,
    ) -> Result<UpdateResult, LinkError> {
        let total_len = u32::try_from(blob.len()).map_err(|_| LinkError::TooLarge)?;
        let chunk = chunk.clamp(1, MAX_CHUNK);
        if let Some(r) = self.update_step(&HostMsg::ModelBegin { total_len, crc32: transfer_crc })? {
            return Ok(r);
        }
        let mut offset = 0u32;
        for data in blob.chunks(chunk) {
            if let Some(r) = self.update_step(&HostMsg::ModelChunk { offset, data })? {
                return Ok(r);
            }
            offset += data.len() as u32;
        }
        match self.request(&HostMsg::ModelCommit)? {
            DeviceMsg::UpdateResult(r) => Ok(r),
            got => Err(LinkError::Unexpected { expected: "UpdateResult", got: Box::new(got) }),
        }
    }

    /// One transfer step: `None` to go on, `Some(result)` when the device ended the transfer.
    fn update_step(&mut self, msg: &HostMsg<'_>) -> Result<Option<UpdateResult>, LinkError> {
        match self.request(msg)? {
            DeviceMsg::UpdateProgress { .. } => Ok(None),
            DeviceMsg::UpdateResult(r) => Ok(Some(r)),
            got => Err(LinkError::Unexpected { expected: "UpdateProgress", got: Box::new(got) }),
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::VecDeque;

    use fbg_shared::protocol::{encode_device, RejectReason, Rejection};

    use super::*;

    /// A scripted device: answers each complete host frame from a closure.
    struct Script<F: FnMut(HostMsg<'_>) -> Option<DeviceMsg>> {
        reader: FrameReader<HOST_MAX_FRAME>,
        answer: F,
        out: VecDeque<u8>,
        seen: Vec<String>,
    }

    impl<F: FnMut(HostMsg<'_>) -> Option<DeviceMsg>> Write for Script<F> {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            let mut w = buf;
            while !w.is_empty() {
                let (ev, rest) = self.reader.feed::<HostMsg<'_>>(w);
                w = rest;
                if let Feed::Message(m) = ev {
                    self.seen.push(format!("{m:?}"));
                    if let Some(reply) = (self.answer)(m) {
                        let mut b = [0u8; DEVICE_MAX_FRAME];
                        self.out.extend(encode_device(&reply, &mut b).unwrap().iter());
                    }
                }
            }
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl<F: FnMut(HostMsg<'_>) -> Option<DeviceMsg>> Read for Script<F> {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            // Hand out bytes in small pieces to exercise reassembly.
            let n = buf.len().min(self.out.len()).min(7);
            for b in buf.iter_mut().take(n) {
                *b = self.out.pop_front().unwrap();
            }
            Ok(n)
        }
    }

    fn script<F: FnMut(HostMsg<'_>) -> Option<DeviceMsg>>(answer: F) -> Script<F> {
        Script { reader: FrameReader::new(), answer, out: VecDeque::new(), seen: Vec::new() }
    }

    #[test]
    fn ping_status_and_samples() {
        let dev = script(|m| match m {
            HostMsg::Ping { nonce } => Some(DeviceMsg::Pong { nonce }),
            HostMsg::GetStatus => Some(DeviceMsg::Status(Status { samples: 2, ..Status::default() })),
            HostMsg::Sample { seq, sample } => Some(DeviceMsg::Estimate(DeviceEstimate {
                seq,
                values: [sample.dl_pm[0], 0.0, 0.0, 0.0],
                outputs: 3,
                ..DeviceEstimate::default()
            })),
            _ => None,
        });
        let mut link = LinkClient::new(dev);
        link.ping(42).unwrap();
        let samples = (0..2).map(|i| Sample::new([i as f32, 0.0, 0.0], 20.0, 0.0));
        let mut got = Vec::new();
        let n = link
            .stream(10, samples, |s, e| -> Result<(), LinkError> {
                got.push((s.dl_pm[0], e.seq, e.values[0]));
                Ok(())
            })
            .unwrap();
        assert_eq!(n, 2);
        assert_eq!(got, [(0.0, 10, 0.0), (1.0, 11, 1.0)]);
        assert_eq!(link.status().unwrap().samples, 2);
    }

    #[test]
    fn wrong_answers_are_errors_and_a_silent_device_is_closed() {
        let mut link = LinkClient::new(script(|_| Some(DeviceMsg::Pong { nonce: 0 })));
        assert!(matches!(link.ping(1), Err(LinkError::Unexpected { .. })));
        let mut link = LinkClient::new(script(|_| None));
        assert!(matches!(link.ping(1), Err(LinkError::Closed)));
    }

    #[test]
    fn update_sends_begin_chunks_commit_and_stops_at_a_rejection() {
        let blob: Vec<u8> = (0..500u32).map(|i| (i % 251) as u8).collect();
        let mut staged = Vec::new();
        let dev = script(|m| match m {
            HostMsg::ModelBegin { total_len, crc32: c } => {
                assert_eq!(total_len, 500);
                assert_eq!(c, crc32(&(0..500u32).map(|i| (i % 251) as u8).collect::<Vec<_>>()));
                Some(DeviceMsg::UpdateProgress { received: 0 })
            }
            HostMsg::ModelChunk { offset, data } => {
                assert_eq!(offset as usize, staged.len());
                assert!(data.len() <= MAX_CHUNK);
                staged.extend_from_slice(data);
                Some(DeviceMsg::UpdateProgress { received: staged.len() as u32 })
            }
            HostMsg::ModelCommit => {
                Some(DeviceMsg::UpdateResult(UpdateResult::Accepted { centres: staged.len() as u16, crc: 7 }))
            }
            _ => None,
        });
        let mut link = LinkClient::new(dev);
        assert_eq!(link.update_model(&blob).unwrap(), UpdateResult::Accepted { centres: 500, crc: 7 });
        assert_eq!(link.get_ref().seen.len(), 1 + 3 + 1);

        let rej = Rejection { reason: RejectReason::TooLarge, detail: 500 };
        let dev = script(move |_| Some(DeviceMsg::UpdateResult(UpdateResult::Rejected(rej))));
        let mut link = LinkClient::new(dev);
        assert_eq!(link.update_model(&blob).unwrap(), UpdateResult::Rejected(rej));
        assert_eq!(link.get_ref().seen.len(), 1, "nothing sent after the rejection");
    }

    /// Sends the bytes of a valid `Pong` frame one at a time, `gap` apart: every read returns
    /// within `gap`, the answer takes far longer.
    fn trickle_pong(gap: Duration) -> impl FnMut(&mut std::net::TcpStream) {
        move |sock| {
            let mut b = [0u8; DEVICE_MAX_FRAME];
            let frame = encode_device(&DeviceMsg::Pong { nonce: 1 }, &mut b).unwrap().to_vec();
            for byte in frame.iter().cycle().take(10_000) {
                std::thread::sleep(gap);
                if sock.write_all(&[*byte ^ 0x55]).is_err() {
                    return;
                }
            }
        }
    }

    #[test]
    fn a_trickling_device_times_out_at_the_answer_deadline() {
        use std::net::{TcpListener, TcpStream};
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let dev = std::thread::spawn(move || {
            let (mut sock, _) = listener.accept().unwrap();
            trickle_pong(Duration::from_millis(20))(&mut sock);
        });
        let timeout = Duration::from_millis(400);
        let mut link = LinkClient::with_answer_timeout(TcpStream::connect(addr).unwrap(), timeout).unwrap();
        let t0 = Instant::now();
        let err = link.ping(1).unwrap_err();
        let took = t0.elapsed();
        assert!(matches!(err, LinkError::TimedOut { received, .. } if received > 5), "{err}");
        assert!(took >= timeout && took < timeout + Duration::from_millis(200), "{took:?}");
        assert!(err.to_string().contains("did not complete its answer within 0.400 s"), "{err}");
        drop(link);
        dev.join().unwrap();
    }

    /// A pipe-like stream without [`ReadTimeout`]: one garbage byte per read, `gap` apart.
    struct Trickle(Duration);
    impl Read for Trickle {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            std::thread::sleep(self.0);
            buf[0] = 0xA5;
            Ok(1)
        }
    }
    impl Write for Trickle {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn the_deadline_holds_on_a_stream_without_read_timeouts() {
        let mut link = LinkClient::new(Trickle(Duration::from_millis(10)));
        link.set_answer_timeout(Some(Duration::from_millis(150)));
        let t0 = Instant::now();
        assert!(matches!(link.status(), Err(LinkError::TimedOut { .. })));
        assert!(t0.elapsed() < Duration::from_millis(300), "{:?}", t0.elapsed());
    }
}
