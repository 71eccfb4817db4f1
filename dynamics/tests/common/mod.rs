//! Readers of the JSON fixtures (golden values, Pinocchio cross-check) into nalgebra types;
//! every length is checked so that a truncated fixture fails loudly instead of comparing less.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

pub mod christoffel;

use nalgebra::{SMatrix, SVector};
use serde_json::Value;

/// A JSON array of N numbers.
pub fn vector<const N: usize>(v: &Value) -> SVector<f64, N> {
    let items = v.as_array().unwrap();
    assert_eq!(items.len(), N);
    SVector::from_fn(|i, _| items[i].as_f64().unwrap())
}

/// A JSON array of R rows of C numbers.
pub fn matrix<const R: usize, const C: usize>(v: &Value) -> SMatrix<f64, R, C> {
    let rows = v.as_array().unwrap();
    assert_eq!(rows.len(), R);
    SMatrix::from_fn(|i, j| {
        let row = rows[i].as_array().unwrap();
        assert_eq!(row.len(), C);
        row[j].as_f64().unwrap()
    })
}
