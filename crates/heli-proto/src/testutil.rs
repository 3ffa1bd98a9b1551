//! Shared checks for the binary framers, used by each device module's tests.

use crate::framer::{BinaryFormat, Framer, FramerStats};

/// Push every byte, collect the delivered frames.
pub fn run<F: BinaryFormat, const N: usize>(bytes: &[u8]) -> (Vec<Vec<u8>>, FramerStats) {
    let mut f: Framer<F, N> = Framer::new();
    let frames = bytes
        .iter()
        .filter_map(|&b| f.push(b).map(|x| x.to_vec()))
        .collect();
    (frames, f.stats())
}

/// Whether the header byte occurs anywhere after the first byte.
pub fn extra_header<F: BinaryFormat>(frame: &[u8]) -> bool {
    frame.iter().skip(1).any(|&b| b == F::HEADER)
}

/// Arbitrary bytes never panic the framer, and every delivered frame parses.
pub fn garbage_never_panics<F: BinaryFormat, const N: usize>(
    bytes: &[u8],
    parses: impl Fn(&[u8]) -> bool,
) {
    let (frames, stats) = run::<F, N>(bytes);
    for f in &frames {
        assert!(parses(f), "delivered frame does not parse: {f:02x?}");
        assert_eq!(f.first(), Some(&F::HEADER));
    }
    assert_eq!(stats.frames as usize, frames.len());
    assert!(stats.discarded_bytes as usize <= bytes.len());
}

/// Noise without any header byte, then a good frame: exactly that frame.
pub fn resync_after_noise<F: BinaryFormat, const N: usize>(noise: &[u8], frame: &[u8]) {
    let noise: Vec<u8> = noise.iter().copied().filter(|&b| b != F::HEADER).collect();
    let stream = [noise.as_slice(), frame].concat();
    let (frames, stats) = run::<F, N>(&stream);
    assert_eq!(frames, vec![frame.to_vec()]);
    assert_eq!(stats.discarded_bytes as usize, noise.len());
    assert_eq!(stats.checksum_errors, 0);
}

/// good, corrupted (one payload byte flipped), good, good: exactly the three
/// good frames and one checksum error. `payload` lists the byte offsets that
/// may be corrupted; frames must hold no extra header byte.
pub fn good_bad_good_good<F: BinaryFormat, const N: usize>(
    frames: [&[u8]; 4],
    payload: &[usize],
    pick: usize,
    mask: u8,
) {
    assert!(mask != 0);
    for f in frames {
        assert!(!extra_header::<F>(f));
    }
    let at = payload[pick % payload.len()];
    let mut bad = frames[1].to_vec();
    bad[at] ^= mask;
    if bad[at] == F::HEADER {
        // Keep it free of header bytes (and still corrupted).
        bad[at] = F::HEADER.wrapping_add(1);
        if bad[at] == frames[1][at] {
            bad[at] = F::HEADER.wrapping_add(2);
        }
    }
    assert_ne!(bad[at], frames[1][at]);
    let stream = [frames[0], &bad, frames[2], frames[3]].concat();
    let (got, stats) = run::<F, N>(&stream);
    assert_eq!(
        got,
        vec![frames[0].to_vec(), frames[2].to_vec(), frames[3].to_vec()]
    );
    assert_eq!(stats.checksum_errors, 1);
    assert_eq!(stats.frames, 3);
}

/// Noise, a stray header byte with a few junk bytes after it, then a good
/// frame: the good frame is still found. Returns false (check skipped) in the
/// rare case the false candidate happens to be a valid frame.
pub fn false_header_then_frame<F: BinaryFormat, const N: usize>(
    noise: &[u8],
    junk: &[u8],
    frame: &[u8],
) -> bool {
    let noise: Vec<u8> = noise.iter().copied().filter(|&b| b != F::HEADER).collect();
    let junk: Vec<u8> = junk.iter().copied().filter(|&b| b != F::HEADER).collect();
    let mut stream = noise.clone();
    stream.push(F::HEADER);
    stream.extend_from_slice(&junk);
    stream.extend_from_slice(frame);
    // Would the false candidate itself verify?
    let start = noise.len();
    if let Ok(Some(n)) = F::frame_len(&stream[start..])
        && let Some(cand) = stream.get(start..start + n)
        && F::checksum_ok(cand)
    {
        return false;
    }
    let (got, _) = run::<F, N>(&stream);
    assert_eq!(got, vec![frame.to_vec()]);
    true
}
