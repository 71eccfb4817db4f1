//! Little-endian accessors at fixed offsets. Callers guarantee the buffer length (the views
//! check it in `new_checked`), so indexing is in bounds by construction.

use super::field::Field;

pub(crate) fn read_u16(b: &[u8], f: Field) -> u16 {
    u16::from_le_bytes([b[f.start], b[f.start + 1]])
}

pub(crate) fn write_u16(b: &mut [u8], f: Field, v: u16) {
    b[f.start..f.start + 2].copy_from_slice(&v.to_le_bytes());
}

pub(crate) fn read_u32(b: &[u8], f: Field) -> u32 {
    u32::from_le_bytes([b[f.start], b[f.start + 1], b[f.start + 2], b[f.start + 3]])
}

pub(crate) fn write_u32(b: &mut [u8], f: Field, v: u32) {
    b[f.start..f.start + 4].copy_from_slice(&v.to_le_bytes());
}

pub(crate) fn read_f32_at(b: &[u8], off: usize) -> f32 {
    f32::from_le_bytes([b[off], b[off + 1], b[off + 2], b[off + 3]])
}

pub(crate) fn write_f32_at(b: &mut [u8], off: usize, v: f32) {
    b[off..off + 4].copy_from_slice(&v.to_le_bytes());
}

pub(crate) fn read_f32(b: &[u8], f: Field) -> f32 {
    read_f32_at(b, f.start)
}

pub(crate) fn write_f32(b: &mut [u8], f: Field, v: f32) {
    write_f32_at(b, f.start, v);
}

/// Decodes consecutive little-endian 4-byte values from `s` (one bounds check for the whole
/// field instead of one per element; the loop then vectorises).
fn decode_words<const N: usize, V: Copy + Default>(s: &[u8], decode: fn([u8; 4]) -> V) -> [V; N] {
    let mut out = [V::default(); N];
    for (o, c) in out.iter_mut().zip(s[..4 * N].chunks_exact(4)) {
        *o = decode([c[0], c[1], c[2], c[3]]);
    }
    out
}

pub(crate) fn read_f32s<const N: usize>(b: &[u8], f: Field) -> [f32; N] {
    decode_words(&b[f.start..f.start + 4 * N], f32::from_le_bytes)
}

pub(crate) fn write_f32s<const N: usize>(b: &mut [u8], f: Field, v: &[f32; N]) {
    for (c, x) in b[f.start..f.start + 4 * N].chunks_exact_mut(4).zip(v) {
        c.copy_from_slice(&x.to_le_bytes());
    }
}

pub(crate) fn read_f32_rows<const R: usize, const C: usize>(b: &[u8], f: Field) -> [[f32; C]; R] {
    let flat = &b[f.start..f.start + 4 * R * C];
    let mut out = [[0.0f32; C]; R];
    for (row, bytes) in out.iter_mut().zip(flat.chunks_exact(4 * C)) {
        *row = decode_words(bytes, f32::from_le_bytes);
    }
    out
}

pub(crate) fn write_f32_rows<const R: usize, const C: usize>(
    b: &mut [u8],
    f: Field,
    v: &[[f32; C]; R],
) {
    let flat = &mut b[f.start..f.start + 4 * R * C];
    for (c, x) in flat.chunks_exact_mut(4).zip(v.iter().flatten()) {
        c.copy_from_slice(&x.to_le_bytes());
    }
}

pub(crate) fn read_i32s<const N: usize>(b: &[u8], f: Field) -> [i32; N] {
    decode_words(&b[f.start..f.start + 4 * N], i32::from_le_bytes)
}

pub(crate) fn write_i32s<const N: usize>(b: &mut [u8], f: Field, v: &[i32; N]) {
    for (c, x) in b[f.start..f.start + 4 * N].chunks_exact_mut(4).zip(v) {
        c.copy_from_slice(&x.to_le_bytes());
    }
}

/// First non-finite f32 in any of `fields`, as (field name, element index).
pub(crate) fn first_non_finite(
    b: &[u8],
    fields: &[(&'static str, Field)],
) -> Option<(&'static str, usize)> {
    const EXPONENT: u32 = 0x7F80_0000;
    let is_non_finite =
        |c: &[u8]| u32::from_le_bytes([c[0], c[1], c[2], c[3]]) & EXPONENT == EXPONENT;
    for (name, f) in fields {
        // All exponent bits set means NaN or ±infinity. A branch-free pass (vectorised) finds
        // out whether the field is clean; only a bad field is searched for the element.
        let field = &b[f.clone()];
        let any = field
            .chunks_exact(4)
            .fold(false, |acc, c| acc | is_non_finite(c));
        if any && let Some(index) = field.chunks_exact(4).position(is_non_finite) {
            return Some((name, index));
        }
    }
    None
}

/// Narrows an f64 to the wire's f32, refusing values that are or become non-finite.
pub(crate) fn to_wire_f32(
    v: f64,
    field: &'static str,
    index: usize,
) -> Result<f32, super::WireError> {
    let narrowed = v as f32;
    if narrowed.is_finite() {
        Ok(narrowed)
    } else {
        Err(super::WireError::NonFinite { field, index })
    }
}

/// Narrows an array of f64 to f32 (see [`to_wire_f32`]).
pub(crate) fn to_wire_f32s<const N: usize>(
    v: &[f64; N],
    field: &'static str,
) -> Result<[f32; N], super::WireError> {
    let mut out = [0.0f32; N];
    for (i, x) in v.iter().enumerate() {
        out[i] = to_wire_f32(*x, field, i)?;
    }
    Ok(out)
}

/// Narrows a row-major matrix of f64 to f32 (see [`to_wire_f32`]); the index is row-major.
pub(crate) fn to_wire_f32_rows<const R: usize, const C: usize>(
    v: &[[f64; C]; R],
    field: &'static str,
) -> Result<[[f32; C]; R], super::WireError> {
    let mut out = [[0.0f32; C]; R];
    for (r, row) in v.iter().enumerate() {
        for (c, x) in row.iter().enumerate() {
            out[r][c] = to_wire_f32(*x, field, r * C + c)?;
        }
    }
    Ok(out)
}

/// Widens f32 values to f64 (exact).
pub(crate) fn widen<const N: usize>(v: [f32; N]) -> [f64; N] {
    v.map(f64::from)
}

/// Widens a row-major f32 matrix to f64 (exact).
pub(crate) fn widen_rows<const R: usize, const C: usize>(v: [[f32; C]; R]) -> [[f64; C]; R] {
    v.map(|row| row.map(f64::from))
}

/// Widens a decoded field to f64 after checking that every element is finite (one pass that
/// vectorises; the element is searched only on failure).
pub(crate) fn finite<const N: usize>(
    v: [f32; N],
    field: &'static str,
) -> Result<[f64; N], super::WireError> {
    if v.iter().fold(true, |ok, x| ok & x.is_finite()) {
        Ok(widen(v))
    } else {
        let index = v.iter().position(|x| !x.is_finite()).unwrap_or(0);
        Err(super::WireError::NonFinite { field, index })
    }
}

/// [`finite`] for a scalar field.
pub(crate) fn finite_scalar(v: f32, field: &'static str) -> Result<f64, super::WireError> {
    if v.is_finite() {
        Ok(f64::from(v))
    } else {
        Err(super::WireError::NonFinite { field, index: 0 })
    }
}

/// [`finite`] for a row-major matrix field; the index is row-major.
pub(crate) fn finite_rows<const R: usize, const C: usize>(
    v: [[f32; C]; R],
    field: &'static str,
) -> Result<[[f64; C]; R], super::WireError> {
    let flat = v.as_flattened();
    if flat.iter().fold(true, |ok, x| ok & x.is_finite()) {
        Ok(widen_rows(v))
    } else {
        let index = flat.iter().position(|x| !x.is_finite()).unwrap_or(0);
        Err(super::WireError::NonFinite { field, index })
    }
}
