//! Byte-at-a-time framers: the interrupt service routine of the thesis.
//!
//! Every serial device on the helicopter delivers its data one byte per UART
//! interrupt. A framer takes those bytes one at a time and hands back a whole
//! frame once one is complete and its checksum has verified:
//!
//! 1. **Hunt**: bytes are discarded until the header byte arrives.
//! 2. **Fill**: bytes are buffered; as soon as the length of the frame can be
//!    told from its first bytes ([`BinaryFormat::frame_len`]), the framer
//!    knows how many more to wait for. A prefix that cannot start a frame
//!    (a bad message id or length field) is a *framing error*.
//! 3. **Check**: a complete frame's checksum is verified
//!    ([`BinaryFormat::checksum_ok`]). A good frame is delivered.
//! 4. **Resynchronise**: after a checksum or framing error the framer does not
//!    throw the whole buffer away. It looks in the buffered bytes after the
//!    failed header for the next header byte and re-examines from there, so a
//!    good frame that began inside a corrupted one (or right after a stray
//!    header byte in line noise) is still found. Only the bytes skipped over
//!    are lost, and they are counted in [`FramerStats::discarded_bytes`].
//!
//! [`Framer`] does this for the fixed binary formats (IMU, servo board, GPS);
//! [`LineFramer`] does the same for ASCII lines (the barometer).

use core::marker::PhantomData;

/// What a framer needs to know about a binary wire format.
///
/// Implemented by the zero-sized `...Format` types of each device module.
pub trait BinaryFormat {
    /// First byte of every frame.
    const HEADER: u8;
    /// Length of the longest frame: header + payload + checksum.
    const MAX_FRAME_LEN: usize;

    /// Whole frame length from the first bytes of a candidate (header first):
    /// `Ok(Some(n))` known; `Ok(None)` need more bytes; `Err(())` this prefix
    /// cannot start a frame (e.g. bad id / length field).
    #[allow(clippy::result_unit_err)]
    fn frame_len(prefix: &[u8]) -> Result<Option<usize>, ()>;

    /// Whether the checksum of a complete frame matches its contents.
    /// Must return `false` (not panic) for a slice of the wrong length.
    fn checksum_ok(frame: &[u8]) -> bool;
}

/// Counters kept by a framer since it was created.
///
/// All counters saturate at `u32::MAX` instead of wrapping.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FramerStats {
    /// Frames delivered (checksum verified).
    pub frames: u32,
    /// Complete candidate frames whose checksum failed.
    pub checksum_errors: u32,
    /// Candidates rejected before completion: a prefix that cannot start a
    /// frame, an over-long ASCII line, or (for [`LineFramer`]) a line cut
    /// short by a new header byte.
    pub framing_errors: u32,
    /// Bytes thrown away: noise while hunting and bytes skipped while
    /// resynchronising.
    pub discarded_bytes: u32,
}

fn bump(counter: &mut u32) {
    *counter = counter.saturating_add(1);
}

fn bump_by(counter: &mut u32, n: usize) {
    let n = u32::try_from(n).unwrap_or(u32::MAX);
    *counter = counter.saturating_add(n);
}

/// Byte-at-a-time framer for a [`BinaryFormat`], with a fixed buffer of `N`
/// bytes (`N` must be at least `F::MAX_FRAME_LEN`; use the `...Framer` type
/// aliases of the device modules, which get it right).
///
/// ```
/// use heli_proto::imu::{ImuFramer, ImuRepr, FRAME_LEN};
///
/// let mut frame = [0u8; FRAME_LEN];
/// let repr = ImuRepr { temp_c: 21.5, ..ImuRepr::default() };
/// repr.emit(&mut frame).unwrap();
///
/// let mut framer = ImuFramer::new();
/// let mut got = None;
/// for &b in [0x00, 0x13].iter().chain(frame.iter()) {
///     if let Some(f) = framer.push(b) {
///         got = Some(ImuRepr::parse(f).unwrap());
///     }
/// }
/// assert_eq!(got, Some(repr));
/// assert_eq!(framer.stats().discarded_bytes, 2);
/// ```
pub struct Framer<F: BinaryFormat, const N: usize> {
    buf: [u8; N],
    /// Bytes held in `buf`; `buf[0]` is a header byte whenever `len > 0`.
    len: usize,
    /// Length of a frame delivered by the previous `push`, to drop from the
    /// front of the buffer at the start of the next one.
    consume: usize,
    stats: FramerStats,
    format: PhantomData<F>,
}

impl<F: BinaryFormat, const N: usize> Framer<F, N> {
    /// An empty framer, hunting for a header byte.
    pub const fn new() -> Self {
        const {
            assert!(
                N >= F::MAX_FRAME_LEN && N > 0,
                "framer buffer shorter than the longest frame"
            )
        };
        Framer {
            buf: [0; N],
            len: 0,
            consume: 0,
            stats: FramerStats {
                frames: 0,
                checksum_errors: 0,
                framing_errors: 0,
                discarded_bytes: 0,
            },
            format: PhantomData,
        }
    }

    /// Feed one byte; returns a complete frame whose checksum verified.
    ///
    /// The returned slice starts with the header byte and is exactly one
    /// frame long. It stays valid until the next call.
    pub fn push(&mut self, byte: u8) -> Option<&[u8]> {
        if self.consume > 0 {
            let consumed = core::mem::take(&mut self.consume);
            self.drop_front(consumed);
            self.skip_to_header(0);
        }

        if self.len == 0 && byte != F::HEADER {
            bump(&mut self.stats.discarded_bytes);
            return None;
        }
        match self.buf.get_mut(self.len) {
            Some(slot) => {
                *slot = byte;
                self.len = self.len.saturating_add(1);
            }
            None => {
                // Cannot happen (the buffer always has room for one more byte
                // here), but if it did: give up on the buffered candidate.
                bump(&mut self.stats.framing_errors);
                bump_by(&mut self.stats.discarded_bytes, self.len);
                self.len = 0;
                if byte != F::HEADER {
                    bump(&mut self.stats.discarded_bytes);
                    return None;
                }
                if let Some(slot) = self.buf.get_mut(0) {
                    *slot = byte;
                    self.len = 1;
                }
            }
        }

        // Examine the buffer from its start until a frame is complete or more
        // bytes are needed. Every pass that does not return drops at least
        // one byte, so this terminates.
        while self.len > 0 {
            let candidate = self.buf.get(..self.len).unwrap_or(&[]);
            match F::frame_len(candidate) {
                Err(()) => {
                    bump(&mut self.stats.framing_errors);
                    self.resync();
                }
                Ok(None) => {
                    if self.len < N {
                        return None;
                    }
                    // The format could not decide within N bytes.
                    bump(&mut self.stats.framing_errors);
                    self.resync();
                }
                Ok(Some(n)) if n == 0 || n > N => {
                    bump(&mut self.stats.framing_errors);
                    self.resync();
                }
                Ok(Some(n)) if self.len < n => return None,
                Ok(Some(n)) => {
                    let frame = self.buf.get(..n).unwrap_or(&[]);
                    if F::checksum_ok(frame) {
                        bump(&mut self.stats.frames);
                        self.consume = n;
                        return self.buf.get(..n);
                    }
                    bump(&mut self.stats.checksum_errors);
                    self.resync();
                }
            }
        }
        None
    }

    /// Counters since creation.
    pub fn stats(&self) -> FramerStats {
        self.stats
    }

    /// Drop any partial frame and go back to hunting for a header byte.
    /// The statistics are kept.
    pub fn reset(&mut self) {
        self.len = 0;
        self.consume = 0;
    }

    /// Remove the first `n` buffered bytes (all of them if `n >= len`).
    fn drop_front(&mut self, n: usize) {
        if n >= self.len {
            self.len = 0;
        } else {
            // n < len <= N, so both ranges are inside the buffer.
            self.buf.copy_within(n..self.len, 0);
            self.len = self.len.saturating_sub(n);
        }
    }

    /// Discard buffered bytes from the front, starting the search at index
    /// `from`, up to the next header byte; everything if there is none.
    fn skip_to_header(&mut self, from: usize) {
        let held = self.buf.get(..self.len).unwrap_or(&[]);
        let skip = held
            .iter()
            .skip(from)
            .position(|&b| b == F::HEADER)
            .map_or(self.len, |i| i.saturating_add(from));
        bump_by(&mut self.stats.discarded_bytes, skip);
        self.drop_front(skip);
    }

    /// The candidate starting at `buf[0]` failed: restart at the next header
    /// byte after it.
    fn resync(&mut self) {
        self.skip_to_header(1);
    }
}

impl<F: BinaryFormat, const N: usize> Default for Framer<F, N> {
    fn default() -> Self {
        Self::new()
    }
}

// Manual impl: a derive would needlessly require `F: Clone` of the marker type.
impl<F: BinaryFormat, const N: usize> Clone for Framer<F, N> {
    fn clone(&self) -> Self {
        Framer {
            buf: self.buf,
            len: self.len,
            consume: self.consume,
            stats: self.stats,
            format: PhantomData,
        }
    }
}

impl<F: BinaryFormat, const N: usize> core::fmt::Debug for Framer<F, N> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Framer")
            .field("buffered", &self.len)
            .field("stats", &self.stats)
            .finish()
    }
}

/// Byte-at-a-time framer for ASCII lines that start with a header byte and end
/// with a terminator byte (the barometer's `?00CP=1013.250\r\n`).
///
/// Bytes outside a line are discarded. A header byte arriving in the middle of
/// a line drops the partial line and starts a new one (a framing error); a
/// line longer than `N` bytes is dropped (a framing error) and the framer goes
/// back to hunting.
///
/// ```
/// use heli_proto::framer::LineFramer;
///
/// let mut framer: LineFramer<32> = LineFramer::new(b'?', b'\n');
/// let mut line = None;
/// for &b in b"xx?00IN=OK\r\n" {
///     if let Some(l) = framer.push(b) {
///         line = Some(l.to_vec());
///     }
/// }
/// assert_eq!(line.as_deref(), Some(&b"?00IN=OK\r\n"[..]));
/// ```
#[derive(Clone, Debug)]
pub struct LineFramer<const N: usize> {
    buf: [u8; N],
    len: usize,
    header: u8,
    terminator: u8,
    /// A line was delivered by the previous `push`; empty the buffer first.
    delivered: bool,
    stats: FramerStats,
}

impl<const N: usize> LineFramer<N> {
    /// An empty line framer for lines running from `header` to `terminator`
    /// inclusive, at most `N` bytes long.
    pub const fn new(header: u8, terminator: u8) -> Self {
        LineFramer {
            buf: [0; N],
            len: 0,
            header,
            terminator,
            delivered: false,
            stats: FramerStats {
                frames: 0,
                checksum_errors: 0,
                framing_errors: 0,
                discarded_bytes: 0,
            },
        }
    }

    /// Feed one byte; returns the complete line, header through terminator
    /// inclusive, when the terminator arrives.
    pub fn push(&mut self, byte: u8) -> Option<&[u8]> {
        if self.delivered {
            self.delivered = false;
            self.len = 0;
        }
        if byte == self.header {
            if self.len > 0 {
                // A new line started before the old one ended.
                bump(&mut self.stats.framing_errors);
                bump_by(&mut self.stats.discarded_bytes, self.len);
            }
            self.len = 0;
        } else if self.len == 0 {
            bump(&mut self.stats.discarded_bytes);
            return None;
        }
        match self.buf.get_mut(self.len) {
            Some(slot) => {
                *slot = byte;
                self.len = self.len.saturating_add(1);
            }
            None => {
                // Over-long line: drop it, this byte included.
                bump(&mut self.stats.framing_errors);
                bump_by(&mut self.stats.discarded_bytes, self.len.saturating_add(1));
                self.len = 0;
                return None;
            }
        }
        if byte == self.terminator && byte != self.header {
            bump(&mut self.stats.frames);
            self.delivered = true;
            return self.buf.get(..self.len);
        }
        None
    }

    /// Counters since creation (`checksum_errors` stays 0: lines carry no
    /// checksum).
    pub fn stats(&self) -> FramerStats {
        self.stats
    }

    /// Drop any partial line and go back to hunting for a header byte.
    /// The statistics are kept.
    pub fn reset(&mut self) {
        self.len = 0;
        self.delivered = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A toy variable-length format: 0x7E, len, payload[len], sum8(payload).
    struct Toy;
    impl BinaryFormat for Toy {
        const HEADER: u8 = 0x7E;
        const MAX_FRAME_LEN: usize = 8;
        fn frame_len(prefix: &[u8]) -> Result<Option<usize>, ()> {
            match prefix.get(1) {
                None => Ok(None),
                Some(&l) if l <= 5 => Ok(Some(usize::from(l) + 3)),
                Some(_) => Err(()),
            }
        }
        fn checksum_ok(frame: &[u8]) -> bool {
            let (last, body) = match frame.split_last() {
                Some(x) => x,
                None => return false,
            };
            body.len() >= 2 && crate::bytes::sum8(&body[2..]) == *last
        }
    }

    /// A format whose second byte is the whole frame's length, whatever it says (0, or
    /// more than the framer holds), with no checksum.
    struct Declared;
    impl BinaryFormat for Declared {
        const HEADER: u8 = 0x7E;
        const MAX_FRAME_LEN: usize = 4;
        fn frame_len(prefix: &[u8]) -> Result<Option<usize>, ()> {
            Ok(prefix.get(1).map(|&n| usize::from(n)))
        }
        fn checksum_ok(_: &[u8]) -> bool {
            true
        }
    }

    /// A format that can never tell where a frame ends.
    struct Undecided;
    impl BinaryFormat for Undecided {
        const HEADER: u8 = 0x7E;
        const MAX_FRAME_LEN: usize = 4;
        fn frame_len(_: &[u8]) -> Result<Option<usize>, ()> {
            Ok(None)
        }
        fn checksum_ok(_: &[u8]) -> bool {
            true
        }
    }

    #[test]
    fn a_declared_length_of_zero_or_beyond_the_buffer_is_a_framing_error() {
        let mut f: Framer<Declared, 4> = Framer::new();
        // Length 0, length 9 (the framer holds 4), then a good 3-byte frame.
        let got = run(&mut f, &[0x7E, 0, 0x7E, 9, 0x7E, 3, 1]);
        assert_eq!(got, vec![vec![0x7E, 3, 1]]);
        assert_eq!(f.stats().framing_errors, 2);
        assert_eq!(f.stats().discarded_bytes, 4);
    }

    #[test]
    fn a_format_that_cannot_decide_within_the_buffer_is_a_framing_error() {
        let mut f: Framer<Undecided, 4> = Framer::new();
        assert!(run(&mut f, &[0x7E, 1, 2]).is_empty());
        assert_eq!(
            f.stats().framing_errors,
            0,
            "three bytes: it may still decide"
        );
        assert!(run(&mut f, &[3]).is_empty());
        assert_eq!(
            f.stats().framing_errors,
            1,
            "four bytes, the buffer full: given up"
        );
        assert_eq!(f.stats().discarded_bytes, 4);
    }

    #[test]
    fn a_clone_carries_on_from_the_same_place() {
        let mut f: Framer<Toy, 8> = Framer::new();
        let a = toy(&[1, 2, 3]);
        assert!(run(&mut f, &[0x55]).is_empty());
        assert!(run(&mut f, &a[..3]).is_empty());
        let mut g = f.clone();
        assert_eq!(run(&mut g, &a[3..]), vec![a.clone()]);
        assert_eq!((g.stats().frames, g.stats().discarded_bytes), (1, 1));
        assert_eq!(run(&mut f, &a[3..]), vec![a]);
    }

    #[test]
    fn a_reset_drops_the_partial_frame_and_keeps_the_counts() {
        let mut f: Framer<Toy, 8> = Framer::new();
        let a = toy(&[1, 2, 3]);
        let b = toy(&[4]);
        assert!(run(&mut f, &a[..3]).is_empty());
        f.reset();
        // The rest of `a` is not a frame without its start; `b` is.
        let mut stream = a[3..].to_vec();
        stream.extend_from_slice(&b);
        assert_eq!(run(&mut f, &stream), vec![b.clone()]);
        assert_eq!(f.stats().frames, 1);
        // A reset right after a frame: the next one still comes out whole.
        f.reset();
        assert_eq!(run(&mut f, &b), vec![b]);
    }

    fn toy(payload: &[u8]) -> Vec<u8> {
        let mut v = vec![0x7E, payload.len() as u8];
        v.extend_from_slice(payload);
        v.push(crate::bytes::sum8(payload));
        v
    }

    fn run<F: BinaryFormat, const N: usize>(f: &mut Framer<F, N>, bytes: &[u8]) -> Vec<Vec<u8>> {
        bytes
            .iter()
            .filter_map(|&b| f.push(b).map(|x| x.to_vec()))
            .collect()
    }

    #[test]
    fn delivers_frames_back_to_back() {
        let mut f: Framer<Toy, 8> = Framer::new();
        let a = toy(&[1, 2, 3]);
        let b = toy(&[]);
        let c = toy(&[9, 9, 9, 9, 9]);
        let stream: Vec<u8> = [a.clone(), b.clone(), c.clone()].concat();
        assert_eq!(run(&mut f, &stream), vec![a, b, c]);
        assert_eq!(f.stats().frames, 3);
        assert_eq!(f.stats().discarded_bytes, 0);
    }

    #[test]
    fn bad_length_resyncs_on_buffered_header() {
        let mut f: Framer<Toy, 8> = Framer::new();
        let good = toy(&[1, 2]);
        // 0x7E then 0x7E: first header has "length" 0x7E -> framing error,
        // the second header is re-examined and begins the good frame.
        let mut stream = vec![0x7E];
        stream.extend_from_slice(&good);
        assert_eq!(run(&mut f, &stream), vec![good]);
        assert_eq!(f.stats().framing_errors, 1);
        assert_eq!(f.stats().discarded_bytes, 1);
    }

    #[test]
    fn frame_inside_corrupted_frame_is_found() {
        let mut f: Framer<Toy, 8> = Framer::new();
        let inner = toy(&[]); // 7E 00 00
        // A corrupted 5-payload frame whose tail holds the start of `inner`.
        let mut stream = vec![0x7E, 5, 1, 2];
        stream.extend_from_slice(&inner);
        stream.push(0x55); // bad checksum
        // The outer frame is 8 bytes: 7E 05 01 02 7E 00 00 55.
        let got = run(&mut f, &stream);
        assert_eq!(got, vec![inner]);
        assert_eq!(f.stats().checksum_errors, 1);
    }

    #[test]
    fn leftover_bytes_after_resync_are_kept() {
        // A corrupted long frame that contains a whole short frame and the
        // first byte of another: the short frame comes out, then the next.
        let mut f: Framer<Toy, 8> = Framer::new();
        let short = toy(&[]); // 3 bytes
        let next = toy(&[4]); // 4 bytes
        let mut stream = vec![0x7E, 5, 0x11];
        stream.extend_from_slice(&short);
        stream.extend_from_slice(&next[..2]);
        // outer: 7E 05 11 7E 00 00 7E 01 -> checksum fails
        stream.extend_from_slice(&next[2..]);
        let got = run(&mut f, &stream);
        assert_eq!(got, vec![short, next]);
    }

    #[test]
    fn reset_and_default() {
        let mut f: Framer<Toy, 8> = Framer::default();
        f.push(0x7E);
        f.push(2);
        f.reset();
        let good = toy(&[3]);
        assert_eq!(run(&mut f, &good), vec![good]);
        assert!(format!("{f:?}").contains("Framer"));
    }

    #[test]
    fn line_framer_basics() {
        let mut f: LineFramer<8> = LineFramer::new(b'?', b'\n');
        let got: Vec<Vec<u8>> = b"ab?12\n?34?56\n?123456789\n?7\n"
            .iter()
            .filter_map(|&b| f.push(b).map(|l| l.to_vec()))
            .collect();
        assert_eq!(
            got,
            vec![b"?12\n".to_vec(), b"?56\n".to_vec(), b"?7\n".to_vec()]
        );
        let s = f.stats();
        assert_eq!(s.frames, 3);
        assert_eq!(s.framing_errors, 2); // cut short by '?', and over-long
        assert_eq!(s.checksum_errors, 0);
        f.push(b'?');
        f.reset();
        assert_eq!(f.push(b'\n'), None);
    }
}
