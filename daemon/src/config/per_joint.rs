//! A per-joint value in the TOML file: seven numbers (joint 1 first) or one number for every
//! joint, so `thresholds = 6.0` of older files still reads.

use std::fmt;

use serde::Deserializer;
use serde::de::{self, SeqAccess, Visitor};

use super::JOINTS;

/// Reads one number (repeated on every joint) or an array of exactly [`JOINTS`] numbers.
pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; JOINTS], D::Error> {
    d.deserialize_any(PerJoint)
}

struct PerJoint;

impl<'de> Visitor<'de> for PerJoint {
    type Value = [f64; JOINTS];

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "one number for every joint or an array of {JOINTS} numbers (joint 1 first)"
        )
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Self::Value, E> {
        Ok([v; JOINTS])
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Self::Value, E> {
        // Integers in the file (`thresholds = 6`) are meant as the same number of Nm.
        Ok([v as f64; JOINTS])
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Self::Value, E> {
        Ok([v as f64; JOINTS])
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut values = [0.0; JOINTS];
        for (j, slot) in values.iter_mut().enumerate() {
            *slot = seq
                .next_element::<f64>()?
                .ok_or_else(|| de::Error::invalid_length(j, &self))?;
        }
        if seq.next_element::<de::IgnoredAny>()?.is_some() {
            return Err(de::Error::invalid_length(JOINTS + 1, &self));
        }
        Ok(values)
    }
}
