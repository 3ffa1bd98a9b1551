//! The one error type of every parser and encoder in this crate.

use core::fmt;

/// Why a frame could not be parsed or emitted.
///
/// The variants are deliberately coarse, in the style of smoltcp's `wire::Error`:
/// a caller normally only counts them or logs them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Error {
    /// The output buffer given to an `emit` is shorter than the frame.
    BufferTooSmall,
    /// The input is shorter than a whole frame.
    Truncated,
    /// The frame's checksum does not match its contents.
    Checksum,
    /// The frame does not start with the expected header (or, for the GPS,
    /// message id and complemented id).
    BadHeader,
    /// A length field holds a value this protocol does not allow.
    BadLength,
    /// A field holds a value outside its documented range, or the text of an
    /// ASCII message is not one this protocol knows.
    BadField,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let text = match self {
            Error::BufferTooSmall => "output buffer too small for the frame",
            Error::Truncated => "input shorter than a whole frame",
            Error::Checksum => "checksum mismatch",
            Error::BadHeader => "bad frame header",
            Error::BadLength => "bad length field",
            Error::BadField => "field value out of range or unrecognised",
        };
        f.write_str(text)
    }
}

impl core::error::Error for Error {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_is_nonempty_and_distinct() {
        let all = [
            Error::BufferTooSmall,
            Error::Truncated,
            Error::Checksum,
            Error::BadHeader,
            Error::BadLength,
            Error::BadField,
        ];
        let texts: Vec<String> = all.iter().map(|e| e.to_string()).collect();
        for (i, a) in texts.iter().enumerate() {
            assert!(!a.is_empty());
            for b in texts.iter().skip(i + 1) {
                assert_ne!(a, b);
            }
        }
    }
}
