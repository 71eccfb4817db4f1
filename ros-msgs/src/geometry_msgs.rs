//! `geometry_msgs`: vectors, wrenches and rigid-body inertia.

use serde::{Deserialize, Serialize};

use crate::std_msgs::{HEADER, Header};
use crate::{MessageType, RosMessage};

/// `geometry_msgs/msg/Vector3`: a free vector (units by use).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x component.
    pub x: f64,
    /// y component.
    pub y: f64,
    /// z component.
    pub z: f64,
}

impl Vector3 {
    /// The vector `[x, y, z]`.
    pub fn from_array(v: [f64; 3]) -> Self {
        Self {
            x: v[0],
            y: v[1],
            z: v[2],
        }
    }
}

impl RosMessage for Vector3 {
    const TYPE: &'static MessageType = &VECTOR3;
}

/// The type of [`Vector3`].
pub static VECTOR3: MessageType = MessageType {
    package: "geometry_msgs",
    name: "Vector3",
    definition: "float64 x\nfloat64 y\nfloat64 z\n",
    dependencies: &[],
};

/// `geometry_msgs/msg/Inertia`: mass, centre of mass and inertia tensor about the centre of mass.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Inertia {
    /// Mass, kg.
    pub m: f64,
    /// Centre of mass, m.
    pub com: Vector3,
    /// Inertia tensor element xx about the centre of mass, kg·m².
    pub ixx: f64,
    /// Inertia tensor element xy, kg·m².
    pub ixy: f64,
    /// Inertia tensor element xz, kg·m².
    pub ixz: f64,
    /// Inertia tensor element yy, kg·m².
    pub iyy: f64,
    /// Inertia tensor element yz, kg·m².
    pub iyz: f64,
    /// Inertia tensor element zz, kg·m².
    pub izz: f64,
}

impl RosMessage for Inertia {
    const TYPE: &'static MessageType = &INERTIA;
}

/// The type of [`Inertia`].
pub static INERTIA: MessageType = MessageType {
    package: "geometry_msgs",
    name: "Inertia",
    definition: "# Mass [kg]\nfloat64 m\n\n# Center of mass [m]\ngeometry_msgs/Vector3 com\n\n# Inertia Tensor [kg-m^2]\nfloat64 ixx\nfloat64 ixy\nfloat64 ixz\nfloat64 iyy\nfloat64 iyz\nfloat64 izz\n",
    dependencies: &[&VECTOR3],
};

/// `geometry_msgs/msg/InertiaStamped`: an [`Inertia`] in a named frame.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct InertiaStamped {
    /// Stamp and the frame of `com`.
    pub header: Header,
    /// The inertia.
    pub inertia: Inertia,
}

impl RosMessage for InertiaStamped {
    const TYPE: &'static MessageType = &INERTIA_STAMPED;
}

/// The type of [`InertiaStamped`].
pub static INERTIA_STAMPED: MessageType = MessageType {
    package: "geometry_msgs",
    name: "InertiaStamped",
    definition: "std_msgs/Header header\ngeometry_msgs/Inertia inertia\n",
    dependencies: &[&HEADER, &INERTIA],
};

/// `geometry_msgs/msg/Wrench`: force and torque.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Wrench {
    /// Force, N.
    pub force: Vector3,
    /// Torque, Nm.
    pub torque: Vector3,
}

impl RosMessage for Wrench {
    const TYPE: &'static MessageType = &WRENCH;
}

/// The type of [`Wrench`].
pub static WRENCH: MessageType = MessageType {
    package: "geometry_msgs",
    name: "Wrench",
    definition: "Vector3  force\nVector3  torque\n",
    dependencies: &[&VECTOR3],
};

/// `geometry_msgs/msg/WrenchStamped`: a [`Wrench`] in a named frame.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct WrenchStamped {
    /// Stamp and the frame of the wrench.
    pub header: Header,
    /// The wrench.
    pub wrench: Wrench,
}

impl RosMessage for WrenchStamped {
    const TYPE: &'static MessageType = &WRENCH_STAMPED;
}

/// The type of [`WrenchStamped`].
pub static WRENCH_STAMPED: MessageType = MessageType {
    package: "geometry_msgs",
    name: "WrenchStamped",
    definition: "std_msgs/Header header\nWrench wrench\n",
    dependencies: &[&HEADER, &WRENCH],
};
