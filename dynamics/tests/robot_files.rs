//! TOML robot files and URDF import: the committed files reproduce the built-in models, the
//! TOML writer round-trips, and malformed or mismatched files give typed errors, never panics.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{
    Data, DynamicsError, Model, compute_generalized_gravity, coriolis_matrix, crba, flange_pose,
    lwr4, planar_2r, rnea,
};
use nalgebra::SVector;

const LWR_TOML: &str = include_str!("../robots/lwr4.toml");
const LWR_URDF: &str = include_str!("../robots/lwr4.urdf");
const PLANAR_TOML: &str = include_str!("../robots/planar_2r.toml");

fn configurations() -> Vec<SVector<f64, 7>> {
    (1..=20)
        .map(|k| {
            let primes = [2.0f64, 3.0, 5.0, 7.0, 11.0, 13.0, 17.0];
            SVector::<f64, 7>::from_fn(|j, _| {
                2.0 * (2.0 * (k as f64 * primes[j].sqrt()).fract() - 1.0)
            })
        })
        .collect()
}

fn assert_same_dynamics(a: &Model<7>, b: &Model<7>, tolerance: f64) {
    let mut data = Data::new(a);
    for q in configurations() {
        let qd = q.map(|v| 0.5 * v.cos());
        let qdd = q.map(|v| v.sin());
        let ga = compute_generalized_gravity(a, &mut data, &q);
        let gb = compute_generalized_gravity(b, &mut data, &q);
        assert!((ga - gb).abs().max() < tolerance, "g: {ga} vs {gb}");
        let ma = crba(a, &mut data, &q);
        let mb = crba(b, &mut data, &q);
        assert!((ma - mb).abs().max() < tolerance, "M: {ma} vs {mb}");
        let ta = rnea(a, &mut data, &q, &qd, &qdd);
        let tb = rnea(b, &mut data, &q, &qd, &qdd);
        assert!((ta - tb).abs().max() < tolerance, "tau: {ta} vs {tb}");
        let ca = coriolis_matrix(a, &mut data, &q, &qd);
        let cb = coriolis_matrix(b, &mut data, &q, &qd);
        assert!((ca - cb).abs().max() < tolerance, "C: {ca} vs {cb}");
    }
}

#[test]
fn committed_lwr4_toml_is_the_built_in_model() {
    let from_file = Model::<7>::from_toml_str(LWR_TOML).unwrap();
    let built_in = lwr4();
    assert_same_dynamics(&from_file, &built_in, 1e-12);
    assert_eq!(from_file.limits(), built_in.limits());
    assert_eq!(from_file.flange(), built_in.flange());
    assert_eq!(from_file.name(), "lwr4");
}

#[test]
fn committed_planar_2r_toml_is_the_built_in_model() {
    let from_file = Model::<2>::from_toml_str(PLANAR_TOML).unwrap();
    let built_in = planar_2r();
    let mut data = Data::new(&built_in);
    for k in 0..10 {
        let q = SVector::<f64, 2>::new(0.3 * k as f64, -0.2 * k as f64);
        assert!(
            (crba(&from_file, &mut data, &q) - crba(&built_in, &mut data, &q))
                .abs()
                .max()
                < 1e-12
        );
        assert!(
            (compute_generalized_gravity(&from_file, &mut data, &q)
                - compute_generalized_gravity(&built_in, &mut data, &q))
            .abs()
            .max()
                < 1e-12
        );
    }
}

#[test]
fn toml_writer_round_trips() {
    let model = lwr4();
    let text = model.to_toml_string().unwrap();
    let back = Model::<7>::from_toml_str(&text).unwrap();
    assert_same_dynamics(&model, &back, 1e-12);
    assert_eq!(back.limits(), model.limits());
    let mdh = dynamics::lwr4_modified_dh();
    let back = Model::<7>::from_toml_str(&mdh.to_toml_string().unwrap()).unwrap();
    assert_same_dynamics(&mdh, &back, 1e-12);
}

#[test]
fn urdf_of_the_lwr_gives_the_same_dynamics_and_flange() {
    let urdf = Model::<7>::from_urdf_str(LWR_URDF).unwrap();
    let dh = lwr4();
    assert_same_dynamics(&urdf, &dh, 1e-12);
    assert_eq!(urdf.limits(), dh.limits());
    // The URDF base is the mounting plate, 0.3105 m below the DH frame 0 (the shoulder).
    let mut data = Data::new(&dh);
    for q in configurations() {
        let a = flange_pose(&urdf, &mut data, &q);
        let b = flange_pose(&dh, &mut data, &q);
        let offset = a.translation.vector - b.translation.vector;
        assert!(
            (offset - nalgebra::Vector3::new(0.0, 0.0, dynamics::LWR_BASE_TO_SHOULDER)).norm()
                < 1e-12
        );
        assert!(a.rotation.angle_to(&b.rotation) < 1e-9);
    }
    let zero = flange_pose(&urdf, &mut data, &SVector::zeros());
    assert!((zero.translation.z - 1.1785).abs() < 1e-12);
}

#[test]
fn urdf_axes_off_z_fixed_joints_and_prismatic_joints() {
    // A 2-joint chain: a prismatic joint along x, a fixed offset, a revolute joint about y,
    // and a fixed tool link whose mass is merged into the last moving link.
    let xml = r#"<robot name="test">
      <link name="base"/>
      <joint name="slide" type="prismatic">
        <parent link="base"/><child link="carriage"/>
        <origin xyz="0 0 0.5" rpy="0 0 0"/><axis xyz="1 0 0"/>
        <limit lower="-1" upper="1" effort="100" velocity="1"/>
      </joint>
      <link name="carriage"><inertial><origin xyz="0 0 0"/><mass value="2"/>
        <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
      <joint name="bracket" type="fixed">
        <parent link="carriage"/><child link="bracket_link"/><origin xyz="0 0 0.1" rpy="0 0 0"/>
      </joint>
      <link name="bracket_link"/>
      <joint name="hinge" type="revolute">
        <parent link="bracket_link"/><child link="arm"/>
        <origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>
        <limit lower="-3" upper="3" effort="50" velocity="2"/>
      </joint>
      <link name="arm"><inertial><origin xyz="0.25 0 0"/><mass value="1"/>
        <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/></inertial></link>
      <joint name="tool_mount" type="fixed">
        <parent link="arm"/><child link="tool"/><origin xyz="0.5 0 0" rpy="0 0 0"/>
      </joint>
      <link name="tool"><inertial><origin xyz="0 0 0"/><mass value="0.5"/>
        <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
    </robot>"#;
    let model = Model::<2>::from_urdf_str(xml).unwrap();
    let mut data = Data::new(&model);
    // Arm horizontal along +x at q = 0; rotating about +y by q2 lowers it (z = −x sin q2).
    let q = SVector::<f64, 2>::new(0.2, 0.3);
    let g = compute_generalized_gravity(&model, &mut data, &q);
    let g0 = 9.81;
    // Prismatic along x carries no gravity; the hinge holds arm (1 kg at 0.25) and tool (0.5 kg at 0.5).
    // U = m g z with z = −x sin q2, so g2 = ∂U/∂q2 = −g0 Σ m x cos q2.
    let expected_hinge = -g0 * (1.0 * 0.25 + 0.5 * 0.5) * q[1].cos();
    assert!(g[0].abs() < 1e-12);
    assert!(
        (g[1] - expected_hinge).abs() < 1e-12,
        "{} vs {expected_hinge}",
        g[1]
    );
    // Mass matrix entry of the slide: total moving mass 3.5 kg.
    let m = crba(&model, &mut data, &q);
    assert!((m[(0, 0)] - 3.5).abs() < 1e-12);
    // Cart and pendulum: M12 = −Σ m x sin q2 = −0.5 sin q2 and M11, M22 constant, so the only
    // Christoffel term is C12 = ∂M12/∂q2 q̇2 = −0.5 cos q2 q̇2.
    assert!((m[(0, 1)] + 0.5 * q[1].sin()).abs() < 1e-12);
    let qd = SVector::<f64, 2>::new(0.7, -1.3);
    let c = coriolis_matrix(&model, &mut data, &q, &qd);
    let expected_c = nalgebra::Matrix2::new(0.0, -0.5 * q[1].cos() * qd[1], 0.0, 0.0);
    assert!((c - expected_c).abs().max() < 1e-12, "C = {c}");
    // Flange = tool frame: 0.5 m along the arm.
    let flange = flange_pose(&model, &mut data, &q);
    let expected = nalgebra::Vector3::new(0.2 + 0.5 * q[1].cos(), 0.0, 0.6 - 0.5 * q[1].sin());
    assert!((flange.translation.vector - expected).norm() < 1e-12);
    assert_eq!(model.limits().torque_max[1], 50.0);
}

#[test]
fn wrong_joint_count_is_a_typed_error() {
    assert_eq!(
        Model::<6>::from_toml_str(LWR_TOML).unwrap_err(),
        DynamicsError::JointCount {
            expected: 6,
            found: 7,
            source_kind: "TOML robot file"
        }
    );
    assert_eq!(
        Model::<8>::from_urdf_str(LWR_URDF).unwrap_err(),
        DynamicsError::JointCount {
            expected: 8,
            found: 7,
            source_kind: "URDF"
        }
    );
    assert_eq!(
        Model::<6>::from_urdf_str(LWR_URDF).unwrap_err(),
        DynamicsError::JointCount {
            expected: 6,
            found: 7,
            source_kind: "URDF"
        }
    );
}

#[test]
fn malformed_toml_names_the_problem() {
    // Syntax error: the message carries the line.
    let err = Model::<2>::from_toml_str("name = \"x\"\n[[joint]\n").unwrap_err();
    match err {
        DynamicsError::Toml(message) => assert!(message.contains("line 2"), "{message}"),
        other => panic!("unexpected {other:?}"),
    }
    // Unknown key.
    let err = Model::<2>::from_toml_str(&PLANAR_TOML.replace("gravity =", "gravty =")).unwrap_err();
    assert!(
        matches!(&err, DynamicsError::Toml(m) if m.contains("gravty")),
        "{err}"
    );
    // Two kinematic descriptions for one joint.
    let text = PLANAR_TOML.replacen(
        "dh = { a = 1.0",
        "modified_dh = { alpha = 0.0 }\ndh = { a = 1.0",
        1,
    );
    let err = Model::<2>::from_toml_str(&text).unwrap_err();
    assert!(
        matches!(err, DynamicsError::InvalidJoint { joint: 0, .. }),
        "{err}"
    );
    // Missing type.
    let text = PLANAR_TOML.replacen("type = \"revolute\"\n", "", 1);
    assert!(matches!(
        Model::<2>::from_toml_str(&text).unwrap_err(),
        DynamicsError::InvalidJoint { joint: 0, .. }
    ));
    // Bad type.
    let text = PLANAR_TOML.replacen("type = \"revolute\"", "type = \"spherical\"", 1);
    assert!(matches!(
        Model::<2>::from_toml_str(&text).unwrap_err(),
        DynamicsError::Toml(_)
    ));
    // Inverted limits.
    let text = PLANAR_TOML.replacen(
        "position = [-3.141592653589793, 3.141592653589793]",
        "position = [1.0, -1.0]",
        1,
    );
    assert!(matches!(
        Model::<2>::from_toml_str(&text).unwrap_err(),
        DynamicsError::InvalidLimits { joint: 0, .. }
    ));
    // Missing file.
    assert!(matches!(
        Model::<2>::from_toml_file("/nonexistent/robot.toml").unwrap_err(),
        DynamicsError::Io { .. }
    ));
}

#[test]
fn non_physical_links_in_files_are_rejected_with_their_index() {
    // Negative mass on link 1 (0-based).
    let text = PLANAR_TOML.replacen("mass = 2.0", "mass = -2.0", 1);
    assert_eq!(
        Model::<2>::from_toml_str(&text).unwrap_err(),
        DynamicsError::Link {
            link: 1,
            source: Box::new(DynamicsError::NegativeMass { mass: -2.0 })
        }
    );
    // Triangle inequality: Ixx + Iyy < Izz.
    let text = PLANAR_TOML.replacen("[0.0025, 0.25, 0.25,", "[0.0025, 0.1, 0.25,", 1);
    assert!(matches!(
        Model::<2>::from_toml_str(&text).unwrap_err(),
        DynamicsError::Link { link: 0, source } if matches!(*source, DynamicsError::TriangleInequality { .. })
    ));
    // Negative principal moment.
    let text = PLANAR_TOML.replacen("[0.0025, 0.25, 0.25,", "[-0.0025, 0.25, 0.25,", 1);
    assert!(matches!(
        Model::<2>::from_toml_str(&text).unwrap_err(),
        DynamicsError::Link { link: 0, source } if matches!(*source, DynamicsError::InertiaNotPositive { .. })
    ));
    // NaN (TOML spells it nan).
    let text = PLANAR_TOML.replacen("mass = 3.0", "mass = nan", 1);
    assert!(matches!(
        Model::<2>::from_toml_str(&text).unwrap_err(),
        DynamicsError::Link { link: 0, source } if matches!(*source, DynamicsError::NonFinite { what: "mass", .. })
    ));
    let text = PLANAR_TOML.replacen("a = 0.5", "a = inf", 1);
    assert!(matches!(
        Model::<2>::from_toml_str(&text).unwrap_err(),
        DynamicsError::NonFinite { what: "dh", .. }
    ));
}

#[test]
fn malformed_urdf_is_a_typed_error() {
    let cases: Vec<(String, &str)> = vec![
        (
            "<robot name=\"x\"><link name=\"a\"/>".to_string(),
            "unterminated",
        ),
        (
            LWR_URDF.replace("<axis xyz=\"0 0 1\"/>", "<axis xyz=\"0 0 0\"/>"),
            "zero axis",
        ),
        (
            // |axis| overflows to infinity: the normalised axis used to collapse to zero and the
            // joint silently turned about an arbitrary axis
            LWR_URDF.replace("<axis xyz=\"0 0 1\"/>", "<axis xyz=\"1e308 1e308 0\"/>"),
            "overflowing axis",
        ),
        (
            LWR_URDF.replace("type=\"revolute\"", "type=\"floating\""),
            "floating",
        ),
        (
            LWR_URDF.replace("<mass value=\"4.1948152162\"/>", "<mass value=\"-4\"/>"),
            "negative mass",
        ),
        (
            LWR_URDF.replace("<mass value=\"4.1948152162\"/>", "<mass value=\"NaN\"/>"),
            "NaN",
        ),
        (
            LWR_URDF.replace(
                "<parent link=\"lwr_link_3\"/>",
                "<parent link=\"lwr_link_2\"/>",
            ),
            "branch",
        ),
        (
            LWR_URDF.replace("<child link=\"lwr_link_4\"/>", "<child link=\"nowhere\"/>"),
            "unknown link",
        ),
    ];
    for (xml, what) in cases {
        let result = Model::<7>::from_urdf_str(&xml);
        assert!(result.is_err(), "{what}: accepted");
        let err = result.unwrap_err();
        assert!(
            matches!(
                err,
                DynamicsError::Urdf(_)
                    | DynamicsError::Link { .. }
                    | DynamicsError::JointCount { .. }
            ),
            "{what}: {err:?}"
        );
        // Every message names something.
        assert!(!err.to_string().is_empty());
    }
}
