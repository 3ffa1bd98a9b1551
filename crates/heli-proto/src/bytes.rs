//! Private helpers: big/little-endian field access, checksums and float
//! conversions that cannot panic.
//!
//! The readers return 0 and the writers do nothing for an offset outside the
//! buffer; every caller checks the buffer length against the frame length
//! first, so that never happens in practice, but it keeps the code free of
//! panicking indexing.

/// Byte at `at`, or 0 past the end.
pub(crate) fn u8_at(buf: &[u8], at: usize) -> u8 {
    buf.get(at).copied().unwrap_or(0)
}

/// Two bytes starting at `at` (0 for any byte past the end).
fn pair(buf: &[u8], at: usize) -> [u8; 2] {
    [u8_at(buf, at), u8_at(buf, at.wrapping_add(1))]
}

/// Four bytes starting at `at` (0 for any byte past the end).
fn quad(buf: &[u8], at: usize) -> [u8; 4] {
    [
        u8_at(buf, at),
        u8_at(buf, at.wrapping_add(1)),
        u8_at(buf, at.wrapping_add(2)),
        u8_at(buf, at.wrapping_add(3)),
    ]
}

pub(crate) fn u16_be(buf: &[u8], at: usize) -> u16 {
    u16::from_be_bytes(pair(buf, at))
}

pub(crate) fn i16_be(buf: &[u8], at: usize) -> i16 {
    i16::from_be_bytes(pair(buf, at))
}

pub(crate) fn u16_le(buf: &[u8], at: usize) -> u16 {
    u16::from_le_bytes(pair(buf, at))
}

pub(crate) fn i16_le(buf: &[u8], at: usize) -> i16 {
    i16::from_le_bytes(pair(buf, at))
}

pub(crate) fn u32_le(buf: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(quad(buf, at))
}

pub(crate) fn i32_le(buf: &[u8], at: usize) -> i32 {
    i32::from_le_bytes(quad(buf, at))
}

/// Copy `bytes` into `buf` starting at `at`; bytes that would fall past the
/// end are dropped.
pub(crate) fn put(buf: &mut [u8], at: usize, bytes: &[u8]) {
    for (i, b) in bytes.iter().enumerate() {
        if let Some(slot) = buf.get_mut(at.wrapping_add(i)) {
            *slot = *b;
        }
    }
}

pub(crate) fn put_u8(buf: &mut [u8], at: usize, v: u8) {
    put(buf, at, &[v]);
}

pub(crate) fn put_u16_be(buf: &mut [u8], at: usize, v: u16) {
    put(buf, at, &v.to_be_bytes());
}

pub(crate) fn put_i16_be(buf: &mut [u8], at: usize, v: i16) {
    put(buf, at, &v.to_be_bytes());
}

pub(crate) fn put_u16_le(buf: &mut [u8], at: usize, v: u16) {
    put(buf, at, &v.to_le_bytes());
}

pub(crate) fn put_i16_le(buf: &mut [u8], at: usize, v: i16) {
    put(buf, at, &v.to_le_bytes());
}

pub(crate) fn put_u32_le(buf: &mut [u8], at: usize, v: u32) {
    put(buf, at, &v.to_le_bytes());
}

pub(crate) fn put_i32_le(buf: &mut [u8], at: usize, v: i32) {
    put(buf, at, &v.to_le_bytes());
}

/// Sum of the bytes modulo 256.
pub(crate) fn sum8(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0u8, |acc, b| acc.wrapping_add(*b))
}

/// Sum of the bytes modulo 65536.
pub(crate) fn sum16(bytes: &[u8]) -> u16 {
    bytes
        .iter()
        .fold(0u16, |acc, b| acc.wrapping_add(u16::from(*b)))
}

/// `bytes[range]`, or an empty slice if the range does not fit.
pub(crate) fn span(bytes: &[u8], start: usize, end: usize) -> &[u8] {
    bytes.get(start..end).unwrap_or(&[])
}

/// Nearest integer count of `value / lsb`, saturating at the `i16` limits
/// (NaN gives 0).
#[expect(
    clippy::cast_possible_truncation,
    reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
)]
pub(crate) fn to_i16(value: f64, lsb: f64) -> i16 {
    libm::round(value / lsb) as i16
}

/// Nearest integer count of `value / lsb`, saturating at the `i32` limits
/// (NaN gives 0).
#[expect(
    clippy::cast_possible_truncation,
    reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
)]
pub(crate) fn to_i32(value: f64, lsb: f64) -> i32 {
    libm::round(value / lsb) as i32
}

/// Nearest integer count of `value / lsb`, saturating at the `u8` limits
/// (NaN gives 0).
#[expect(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
)]
pub(crate) fn to_u8(value: f64, lsb: f64) -> u8 {
    libm::round(value / lsb) as u8
}

/// Nearest integer of `value`, saturating at the `u16` limits (NaN gives 0).
#[expect(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
)]
pub(crate) fn round_u16(value: f64) -> u16 {
    libm::round(value) as u16
}
