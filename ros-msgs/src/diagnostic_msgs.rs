//! `diagnostic_msgs`: the status reports `rqt_robot_monitor` and the diagnostic aggregator read.

use serde::{Deserialize, Serialize};

use crate::std_msgs::{HEADER, Header};
use crate::{MessageType, RosMessage};

/// `diagnostic_msgs/msg/KeyValue`: one named value.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct KeyValue {
    /// What the value is.
    pub key: String,
    /// The value as text.
    pub value: String,
}

impl KeyValue {
    /// The pair `key` = `value`.
    pub fn new(key: &str, value: impl ToString) -> Self {
        Self {
            key: key.to_owned(),
            value: value.to_string(),
        }
    }
}

impl RosMessage for KeyValue {
    const TYPE: &'static MessageType = &KEY_VALUE;
}

/// The type of [`KeyValue`].
pub static KEY_VALUE: MessageType = MessageType {
    package: "diagnostic_msgs",
    name: "KeyValue",
    definition: "# What to label this value when viewing.\nstring key\n# A value to track over time.\nstring value\n",
    dependencies: &[],
};

/// [`DiagnosticStatus::level`]: all is well.
pub const OK: u8 = 0;
/// [`DiagnosticStatus::level`]: a warning.
pub const WARN: u8 = 1;
/// [`DiagnosticStatus::level`]: an error.
pub const ERROR: u8 = 2;
/// [`DiagnosticStatus::level`]: no recent data.
pub const STALE: u8 = 3;

/// `diagnostic_msgs/msg/DiagnosticStatus`: the state of one component.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// [`OK`], [`WARN`], [`ERROR`] or [`STALE`].
    pub level: u8,
    /// Component name, e.g. `lwr/fri`.
    pub name: String,
    /// Human-readable summary.
    pub message: String,
    /// Hardware identifier.
    pub hardware_id: String,
    /// The component's values.
    pub values: Vec<KeyValue>,
}

impl RosMessage for DiagnosticStatus {
    const TYPE: &'static MessageType = &DIAGNOSTIC_STATUS;
}

/// The type of [`DiagnosticStatus`].
pub static DIAGNOSTIC_STATUS: MessageType = MessageType {
    package: "diagnostic_msgs",
    name: "DiagnosticStatus",
    definition: "# Possible levels of operations.\nbyte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\n\n# Level of operation enumerated above.\nbyte level\n# A description of the test/component reporting.\nstring name\n# A description of the status.\nstring message\n# A hardware unique string.\nstring hardware_id\n# An array of values associated with the status.\nKeyValue[] values\n",
    dependencies: &[&KEY_VALUE],
};

/// `diagnostic_msgs/msg/DiagnosticArray`: the statuses of one report.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// Stamp of the report.
    pub header: Header,
    /// One status per component.
    pub status: Vec<DiagnosticStatus>,
}

impl RosMessage for DiagnosticArray {
    const TYPE: &'static MessageType = &DIAGNOSTIC_ARRAY;
}

/// The type of [`DiagnosticArray`].
pub static DIAGNOSTIC_ARRAY: MessageType = MessageType {
    package: "diagnostic_msgs",
    name: "DiagnosticArray",
    definition: "# This message is used to send diagnostic information about the state of the robot.\nstd_msgs/Header header # for timestamp\nDiagnosticStatus[] status # an array of components being reported on\n",
    dependencies: &[&HEADER, &DIAGNOSTIC_STATUS],
};
