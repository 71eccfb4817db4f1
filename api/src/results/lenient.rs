//! Deserialisers for floats the daemon may write as `null` (serde_json's form of NaN and ±∞).

use serde::{Deserialize, Deserializer};

/// A float, `null` read as NaN.
pub(crate) fn nan<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// A float, `null` read as +∞ (a silence "since forever").
pub(crate) fn infinity<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::INFINITY))
}

/// A fixed-length array of floats, each `null` read as NaN.
pub(crate) fn nan_array<'de, D: Deserializer<'de>, const N: usize>(
    d: D,
) -> Result<[f64; N], D::Error> {
    let v = Vec::<Option<f64>>::deserialize(d)?;
    let n = v.len();
    let v: Vec<f64> = v.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect();
    <[f64; N]>::try_from(v).map_err(|_| {
        serde::de::Error::invalid_length(n, &format!("an array of {N} numbers").as_str())
    })
}

/// A list of floats, each `null` read as NaN.
pub(crate) fn nan_vec<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
    let v = Vec::<Option<f64>>::deserialize(d)?;
    Ok(v.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect())
}

/// A 4 × 4 matrix of floats (rows), each `null` read as NaN.
pub(crate) fn nan_matrix4<'de, D: Deserializer<'de>>(d: D) -> Result<[[f64; 4]; 4], D::Error> {
    let rows = Vec::<Vec<Option<f64>>>::deserialize(d)?;
    let bad = |n| serde::de::Error::invalid_length(n, &"a 4 × 4 matrix");
    if rows.len() != 4 {
        return Err(bad(rows.len()));
    }
    let mut m = [[f64::NAN; 4]; 4];
    for (r, row) in rows.iter().enumerate() {
        if row.len() != 4 {
            return Err(bad(row.len()));
        }
        for (c, x) in row.iter().enumerate() {
            m[r][c] = x.unwrap_or(f64::NAN);
        }
    }
    Ok(m)
}

/// An optional fixed-length array of floats, each `null` element read as NaN (`null` as a
/// whole is `None`).
pub(crate) fn opt_nan_array<'de, D: Deserializer<'de>, const N: usize>(
    d: D,
) -> Result<Option<[f64; N]>, D::Error> {
    let Some(v) = Option::<Vec<Option<f64>>>::deserialize(d)? else {
        return Ok(None);
    };
    let n = v.len();
    let v: Vec<f64> = v.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect();
    <[f64; N]>::try_from(v).map(Some).map_err(|_| {
        serde::de::Error::invalid_length(n, &format!("an array of {N} numbers").as_str())
    })
}
