//! Built-in robot models: the KUKA LWR 4+ (classical and modified DH) and the paper's planar 2R.
//! Numbers from `shared/docs/lwr4-model.md` (sections 1, 2 and 7).

use std::f64::consts::FRAC_PI_2;

use nalgebra::{Isometry3, Matrix3, SVector, Vector3};

use crate::inertia::InertialParameters;
use crate::joint::{ClassicalDh, Joint, JointKind, ModifiedDh};
use crate::model::{JointLimits, Model};

/// Standard gravity used by the paper and the reference model, m/s².
pub const STANDARD_GRAVITY: f64 = 9.81;

/// Classical DH twists α_i of the LWR 4+ (lwr4-model.md §1.1), rad.
const LWR_ALPHA: [f64; 7] = [
    FRAC_PI_2, -FRAC_PI_2, -FRAC_PI_2, FRAC_PI_2, FRAC_PI_2, -FRAC_PI_2, 0.0,
];
/// Classical DH offsets d_i of the LWR 4+, m.
const LWR_D: [f64; 7] = [0.0, 0.0, 0.4, 0.0, 0.39, 0.0, 0.0];
/// Flange offset along z7 from the wrist point, m.
pub const LWR_FLANGE_OFFSET: f64 = 0.078;
/// Height of the LWR's frame 0 (shoulder) above the base mounting plate, m.
pub const LWR_BASE_TO_SHOULDER: f64 = 0.3105;

/// (m kg, c m, I about CoM [xx, yy, zz, xy, xz, yz] kg·m²) per link in classical DH frames
/// (lwr4-model.md §2.2, placeholders substituted as in §2.3).
#[allow(clippy::type_complexity)]
const LWR_LINKS: [(f64, [f64; 3], [f64; 6]); 7] = [
    (
        4.1948152162,
        [-0.0216387515, 0.01, -0.0376881829],
        [0.01776, 0.0018932828, 0.01776, 0.0, 0.0, 0.0],
    ),
    (
        4.2996847737,
        [0.0003284751, -0.0041132249, 0.0823647642],
        [
            0.0474108647,
            0.04739,
            0.001601901,
            -6.21e-06,
            0.0001166457,
            -0.0009141575,
        ],
    ),
    (
        3.658530333,
        [0.0002593328, 0.1137431845, -0.000100257],
        [
            0.0469510749,
            0.0008344566,
            0.04695,
            -0.000271431,
            4.09e-08,
            -0.000577228,
        ],
    ),
    (
        2.3846673548,
        [-0.0014648843, -4.61e-05, 0.148580959],
        [
            0.0124233226,
            0.0072708907,
            0.0099884782,
            2.25e-07,
            -0.0005187982,
            -0.0005484476,
        ],
    ),
    (
        1.7035567183,
        [-0.0003791484, -0.0553526131, -0.0101255137],
        [
            0.006322648,
            0.0012020203,
            0.0070806218,
            -0.0002163196,
            6.52e-06,
            0.0,
        ],
    ),
    (
        0.4000713156,
        [0.0020739022, 0.0586184696, -0.044799983],
        [
            0.0005278646,
            0.00349,
            0.0034899625,
            4.83e-05,
            -3.75e-05,
            0.0,
        ],
    ),
    (
        0.6501439811,
        [-0.0004601303, 0.0014789221, 0.0715608282],
        [0.0001187, 3.23e-05, 0.0001187527, -5.77e-07, 0.0, 0.0],
    ),
];

/// Symmetric inertia tensor from [xx, yy, zz, xy, xz, yz].
pub fn inertia_tensor(i: &[f64; 6]) -> Matrix3<f64> {
    Matrix3::new(i[0], i[3], i[4], i[3], i[1], i[5], i[4], i[5], i[2])
}

/// Nominal LWR 4+ link parameters in classical DH frames.
pub fn lwr4_links() -> [InertialParameters; 7] {
    std::array::from_fn(|i| {
        let (m, c, inertia) = &LWR_LINKS[i];
        InertialParameters::from_com(*m, Vector3::from(*c), inertia_tensor(inertia))
    })
}

/// LWR 4+ joint limits (lwr4-model.md §1.2): positions rad, velocities rad/s, torques Nm.
pub fn lwr4_limits() -> JointLimits<7> {
    let deg = |v: [f64; 7]| SVector::<f64, 7>::from(v.map(f64::to_radians));
    JointLimits::symmetric(
        deg(LWR4_POSITION_LIMITS_DEG),
        deg(LWR4_VELOCITY_LIMITS_DEG_S),
        SVector::<f64, 7>::from(LWR4_TORQUE_LIMITS_NM),
    )
}

/// LWR 4+ joint position limits, ± deg (lwr4-model.md §1.2).
pub const LWR4_POSITION_LIMITS_DEG: [f64; 7] = [170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 170.0];

/// LWR 4+ joint velocity limits, deg/s (lwr4-model.md §1.2, CentroEPiaggio set).
pub const LWR4_VELOCITY_LIMITS_DEG_S: [f64; 7] = [110.0, 110.0, 128.0, 128.0, 204.0, 184.0, 184.0];

/// LWR 4+ joint torque limits, ± Nm (lwr4-model.md §1.2).
pub const LWR4_TORQUE_LIMITS_NM: [f64; 7] = [176.0, 176.0, 100.0, 100.0, 100.0, 38.0, 38.0];

/// The paper's pick pose of the LWR 4+ (Sec. VI-A: the static poses, the collision runs and the
/// simulated robot's start pose are around it), deg.
pub const LWR4_PICK_POSE_DEG: [f64; 7] = [0.0, 30.0, 0.0, -60.0, 0.0, 60.0, 0.0];

/// [`LWR4_PICK_POSE_DEG`] in rad (each angle `f64::to_radians` of the degrees).
pub const LWR4_PICK_POSE_RAD: [f64; 7] = degrees_to_radians(LWR4_PICK_POSE_DEG);

/// Each of `degrees` (deg) in rad, as `f64::to_radians`; usable in constants.
pub const fn degrees_to_radians<const N: usize>(degrees: [f64; N]) -> [f64; N] {
    let mut radians = [0.0; N];
    let mut i = 0;
    while i < N {
        radians[i] = degrees[i].to_radians();
        i += 1;
    }
    radians
}

fn lwr_flange() -> Isometry3<f64> {
    Isometry3::translation(0.0, 0.0, LWR_FLANGE_OFFSET)
}

/// The KUKA LWR 4+: classical DH table of the paper (Fig. 3), frame 7 at the wrist point, flange
/// 0.078 m along z7, nominal inertial set of lwr4-model.md, gravity (0, 0, −9.81) m/s².
pub fn lwr4() -> Model<7> {
    let joints = std::array::from_fn(|i| {
        Joint::classical_dh(
            JointKind::Revolute,
            &ClassicalDh {
                a: 0.0,
                alpha: LWR_ALPHA[i],
                d: LWR_D[i],
                theta: 0.0,
            },
        )
    });
    built_in(Model::new(
        "lwr4",
        joints,
        lwr4_links(),
        Vector3::new(0.0, 0.0, -STANDARD_GRAVITY),
        lwr_flange(),
        lwr4_limits(),
    ))
}

/// The LWR 4+ described with modified DH (Khalil; lwr4-model.md §1.3), link parameters converted
/// with c_MDH = Rx(α_i)·c_DH, I_MDH = Rx(α_i)·I_DH·Rx(α_i)ᵀ (α_i classical). Frame 7 and the flange
/// coincide with [`lwr4`]'s.
pub fn lwr4_modified_dh() -> Model<7> {
    let joints = std::array::from_fn(|i| {
        Joint::modified_dh(
            JointKind::Revolute,
            &ModifiedDh {
                alpha: if i == 0 { 0.0 } else { LWR_ALPHA[i - 1] },
                d: 0.0,
                theta: 0.0,
                r: LWR_D[i],
            },
        )
    });
    let classical = lwr4_links();
    let links = std::array::from_fn(|i| {
        let rotation =
            *nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), LWR_ALPHA[i]).matrix();
        classical[i].transformed(&rotation, &Vector3::zeros())
    });
    built_in(Model::new(
        "lwr4-mdh",
        joints,
        links,
        Vector3::new(0.0, 0.0, -STANDARD_GRAVITY),
        lwr_flange(),
        lwr4_limits(),
    ))
}

/// The paper's heavy payload (3.028 kg at (0, 0, 0.119) m in frame 7, eq. 39) as a point mass.
pub fn lwr4_heavy_payload() -> InertialParameters {
    InertialParameters::point_mass(3.028, Vector3::new(0.0, 0.0, 0.119))
}

/// The paper's light payload (0.144 kg at (0, 0, 0.1146) m in frame 7) as a point mass.
pub fn lwr4_light_payload() -> InertialParameters {
    InertialParameters::point_mass(0.144, Vector3::new(0.0, 0.0, 0.1146))
}

/// Inertia about the CoM of a slender body along x with transverse moment `transverse` (kg·m²):
/// a small axial moment keeps the tensor physical (only J_zz matters for a planar arm).
fn rod_along_x(transverse: f64) -> Matrix3<f64> {
    Matrix3::from_diagonal(&Vector3::new(transverse * 0.01, transverse, transverse))
}

/// The paper's planar 2R robot (Sec. IV; lwr4-model.md §7): a1 = 1 m, a2 = 0.5 m, m = (3, 2) kg,
/// CoMs (−0.6, 0.01) and (−0.2, 0.02) m in the DH frames at the link tips, J_zz about those frame
/// origins 1.3303 and 0.1225 kg·m², gravity 9.81 m/s² along −y of the base.
pub fn planar_2r() -> Model<2> {
    let joint = |a: f64| {
        Joint::classical_dh(
            JointKind::Revolute,
            &ClassicalDh {
                a,
                alpha: 0.0,
                d: 0.0,
                theta: 0.0,
            },
        )
    };
    // About-CoM moments: 1.3303 − 3·(0.6² + 0.01²) = 0.25 and 0.1225 − 2·(0.2² + 0.02²) = 0.0417.
    let link1 = InertialParameters::from_com(3.0, Vector3::new(-0.6, 0.01, 0.0), rod_along_x(0.25));
    let link2 =
        InertialParameters::from_com(2.0, Vector3::new(-0.2, 0.02, 0.0), rod_along_x(0.0417));
    let limits = JointLimits::symmetric(
        SVector::<f64, 2>::repeat(std::f64::consts::PI),
        SVector::<f64, 2>::repeat(2.0),
        SVector::<f64, 2>::repeat(200.0),
    );
    built_in(Model::new(
        "planar-2r",
        [joint(1.0), joint(0.5)],
        [link1, link2],
        Vector3::new(0.0, -STANDARD_GRAVITY, 0.0),
        Isometry3::identity(),
        limits,
    ))
}

/// The paper's 2R payload (m_L = 1.5 kg, c_L = (0.3, 0.1) m, J_Lzz = 0.1813 kg·m² about the link-2
/// frame origin, i.e. 0.0313 about its CoM).
pub fn planar_2r_payload() -> InertialParameters {
    InertialParameters::from_com(1.5, Vector3::new(0.3, 0.1, 0.0), rod_along_x(0.0313))
}

/// Built-in models are valid by construction; this unwraps without panicking by construction
/// (checked by the tests, which call every built-in constructor and `Model::new`'s validation).
fn built_in<const N: usize>(model: Result<Model<N>, crate::DynamicsError>) -> Model<N> {
    match model {
        Ok(m) => m,
        Err(e) => unreachable!("built-in model failed validation: {e}"),
    }
}
