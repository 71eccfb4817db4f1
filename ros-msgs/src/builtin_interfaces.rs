//! `builtin_interfaces`: time stamps.

use serde::{Deserialize, Serialize};

use crate::{MessageType, RosMessage};

/// `builtin_interfaces/msg/Time`: seconds and nanoseconds (0..1e9) of a time point.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Time {
    /// Whole seconds, s.
    pub sec: i32,
    /// Nanoseconds past `sec`, 0..=999_999_999 ns.
    pub nanosec: u32,
}

impl Time {
    /// The time point `seconds` s after the epoch of its time base; NaN and negative times are
    /// zero, times past `i32::MAX` s saturate.
    pub fn from_seconds(seconds: f64) -> Self {
        if seconds.is_nan() || seconds <= 0.0 {
            return Self::default();
        }
        if seconds >= f64::from(i32::MAX) {
            return Self {
                sec: i32::MAX,
                nanosec: 999_999_999,
            };
        }
        let whole = seconds.floor();
        // Rounding can reach a full second: carry it.
        let nanos = ((seconds - whole) * 1e9).round() as u32;
        let (sec, nanosec) = if nanos >= 1_000_000_000 {
            (whole as i32 + 1, nanos - 1_000_000_000)
        } else {
            (whole as i32, nanos)
        };
        Self { sec, nanosec }
    }

    /// This time in seconds.
    pub fn as_seconds(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}

impl RosMessage for Time {
    const TYPE: &'static MessageType = &TIME;
}

/// The type of [`Time`].
pub static TIME: MessageType = MessageType {
    package: "builtin_interfaces",
    name: "Time",
    definition: "int32 sec\nuint32 nanosec\n",
    dependencies: &[],
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_split_into_sec_and_nanosec_and_back() {
        let t = Time::from_seconds(12.345_678_9);
        assert_eq!(t.sec, 12);
        assert_eq!(t.nanosec, 345_678_900);
        assert!((t.as_seconds() - 12.345_678_9).abs() < 1e-9);
        // Rounding to a whole second carries.
        assert_eq!(
            Time::from_seconds(0.999_999_999_9),
            Time { sec: 1, nanosec: 0 }
        );
        assert_eq!(Time::from_seconds(f64::NAN), Time::default());
        assert_eq!(Time::from_seconds(-3.0), Time::default());
        assert_eq!(Time::from_seconds(1e12).sec, i32::MAX);
    }
}
