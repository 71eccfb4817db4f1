//! Identified-arm files (`fri-ctl offline identify`): the corrected model predicts
//! Y(q, q̇, q̈)(π_nom + δπ) + offset + friction exactly, the file round-trips, and a file that does
//! not fit the model it is loaded for — another robot, other link parameters, another joint
//! count, an out-of-range or non-finite value, a hostile text — is a typed error naming the field.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::identified::{
    BaseTerms, FitSummary, IDENTIFIED_FORMAT, IdentifiedFile, JointTerms, ModelErrorTerms,
    base_regressor, identification_base, link_parameter_vector,
};
use dynamics::{Data, DynamicsError, IdentifiedModel, lwr4, lwr4_heavy_payload, planar_2r, rnea};
use nalgebra::{DVector, SVector};
use proptest::prelude::*;

type V7 = SVector<f64, 7>;

fn file_for(model: &dynamics::Model<7>, delta_scale: f64) -> IdentifiedFile {
    let base = identification_base(model);
    let pi = &base.map * link_parameter_vector(model);
    let p = base.rank;
    let v = |k: usize, a: f64| {
        (0..k)
            .map(|i| a * ((i as f64 * 1.7).sin()))
            .collect::<Vec<f64>>()
    };
    IdentifiedFile {
        format: IDENTIFIED_FORMAT,
        robot: model.name().to_owned(),
        joints: 7,
        joint: JointTerms {
            coulomb_velocity: 0.02,
            offset: v(7, 0.9),
            offset_std: vec![0.05; 7],
            viscous: v(7, 1.2),
            viscous_std: vec![0.1; 7],
            coulomb: v(7, 0.4),
            coulomb_std: vec![0.05; 7],
        },
        base: BaseTerms {
            columns: base.independent.clone(),
            nominal: pi.iter().copied().collect(),
            // a relative correction of each coefficient (≥ 1e-3 absolute)
            delta: (0..p)
                .map(|k| delta_scale * ((k as f64 * 0.9).cos()) * pi[k].abs().max(1e-3))
                .collect(),
            delta_std: vec![1e-3; p],
        },
        model_error: ModelErrorTerms {
            residual_rms: vec![0.25; 7],
            correlation_time_s: vec![0.5; 7],
        },
        fit: FitSummary {
            logs: vec!["run1.csv".into()],
            samples: 5027,
            duration_s: 25.1,
            ridge_weight: 0.32,
            folds: 5,
            condition_number: 59.0,
            residual_rms_nominal: vec![1.3; 7],
            residual_rms: vec![0.2; 7],
            heldout_rms: vec![0.25; 7],
            heldout_rms_joint_terms: vec![0.3; 7],
            heldout_rms_free: vec![f64::NAN; 7],
            residual_peak_nominal: Vec::new(),
            residual_peak: Vec::new(),
            heldout_peak: Vec::new(),
        },
    }
}

fn field_of(e: DynamicsError) -> String {
    match e {
        DynamicsError::Identified { field, .. } => field,
        other => panic!("expected an identified-file error, got {other}"),
    }
}

#[test]
fn the_corrected_model_predicts_the_base_coefficients_plus_joint_terms() {
    let model = lwr4();
    let file = file_for(&model, 0.05);
    let m = IdentifiedModel::new(&model, file.clone()).unwrap();
    let mut data = Data::new(&model);
    let pi = DVector::from_iterator(
        file.base.nominal.len(),
        file.base
            .nominal
            .iter()
            .zip(&file.base.delta)
            .map(|(a, b)| a + b),
    );
    for k in 0..20 {
        let f = |j: usize, s: f64| ((k * 7 + j) as f64 * s).sin();
        let q = V7::from_fn(|j, _| 1.5 * f(j, 0.37));
        let qd = V7::from_fn(|j, _| 0.8 * f(j, 0.91));
        let qdd = V7::from_fn(|j, _| 2.0 * f(j, 1.3));
        let y = base_regressor(&model, &mut data, &file.base.columns, &q, &qd, &qdd);
        let expect_rigid = &y * &pi;
        let joint = V7::from_fn(|j, _| {
            file.joint.offset[j]
                + file.joint.viscous[j] * qd[j]
                + file.joint.coulomb[j] * (qd[j] / 0.02).tanh()
        });
        let got = m.predict(&mut data, &q, &qd, &qdd);
        for j in 0..7 {
            assert!(
                (got[j] - expect_rigid[j] - joint[j]).abs() < 1e-9,
                "sample {k} joint {j}: {} vs {}",
                got[j],
                expect_rigid[j] + joint[j]
            );
        }
        // and the nominal coefficients alone are the nominal model
        let nominal = &y * DVector::from_column_slice(&file.base.nominal);
        let tau = rnea(&model, &mut data, &q, &qd, &qdd);
        assert!((0..7).all(|j| (nominal[j] - tau[j]).abs() < 1e-9));
    }
}

#[test]
fn the_file_round_trips_through_toml() {
    let model = lwr4();
    let m = IdentifiedModel::new(&model, file_for(&model, 0.05)).unwrap();
    let text = m.to_toml_string().unwrap();
    assert!(text.contains("robot = \"lwr4\""), "{text}");
    let back = IdentifiedModel::from_toml_str(&model, &text).unwrap();
    assert_eq!(back.file().base.delta, m.file().base.delta);
    assert_eq!(back.file().joint.offset, m.file().joint.offset);
    assert!(back.file().fit.heldout_rms_free[0].is_nan());
}

#[test]
fn a_file_for_another_model_is_refused_naming_the_field() {
    let model = lwr4();
    let good = file_for(&model, 0.05);
    // other link parameters (the arm with a payload as its "nominal" model)
    let loaded = model.with_payload(&lwr4_heavy_payload());
    let e = IdentifiedModel::new(&loaded, good.clone()).unwrap_err();
    assert!(field_of(e).starts_with("base.nominal"));
    // another robot name
    let mut f = good.clone();
    f.robot = "iiwa".into();
    assert_eq!(
        field_of(IdentifiedModel::new(&model, f).unwrap_err()),
        "robot"
    );
    // another joint count
    let e = IdentifiedModel::<2>::new(&planar_2r(), good.clone()).unwrap_err();
    assert_eq!(field_of(e), "joints");
    // another version
    let mut f = good.clone();
    f.format = 2;
    assert_eq!(
        field_of(IdentifiedModel::new(&model, f).unwrap_err()),
        "format"
    );
    // other base columns
    let mut f = good.clone();
    f.base.columns.swap(0, 1);
    assert_eq!(
        field_of(IdentifiedModel::new(&model, f).unwrap_err()),
        "base.columns"
    );
}

#[test]
fn out_of_range_values_are_refused_naming_the_field_and_range() {
    let model = lwr4();
    let good = file_for(&model, 0.05);
    type Change = Box<dyn Fn(&mut IdentifiedFile)>;
    let cases: Vec<(Change, &str)> = vec![
        (Box::new(|f| f.joint.offset[2] = 60.0), "joint.offset[3]"),
        (
            Box::new(|f| f.joint.offset[0] = f64::NAN),
            "joint.offset[1]",
        ),
        (Box::new(|f| f.joint.coulomb[6] = -20.0), "joint.coulomb[7]"),
        (Box::new(|f| f.joint.viscous[1] = 1e9), "joint.viscous[2]"),
        (
            Box::new(|f| f.joint.coulomb_velocity = 0.0),
            "joint.coulomb_velocity",
        ),
        (
            Box::new(|f| f.joint.offset.pop().map(|_| ()).unwrap_or(())),
            "joint.offset",
        ),
        (
            Box::new(|f| f.joint.offset_std[4] = -1.0),
            "joint.offset_std[5]",
        ),
        (
            Box::new(|f| f.model_error.residual_rms[0] = f64::INFINITY),
            "model_error.residual_rms[1]",
        ),
        (
            Box::new(|f| f.model_error.correlation_time_s[3] = 1e9),
            "model_error.correlation_time_s[4]",
        ),
        (Box::new(|f| f.base.delta[0] = f64::NAN), "base.delta[1]"),
        (Box::new(|f| f.base.delta.push(0.0)), "base.delta"),
        (Box::new(|f| f.fit.ridge_weight = -1.0), "fit.ridge_weight"),
    ];
    for (change, field) in cases {
        let mut f = good.clone();
        change(&mut f);
        let e = IdentifiedModel::new(&model, f).unwrap_err();
        let text = e.to_string();
        assert_eq!(field_of(e), field, "{text}");
    }
    // a correction that is not one: every coefficient tripled changes torques by far more than
    // a quarter of the limits
    let e = IdentifiedModel::new(&model, file_for(&model, 3.0)).unwrap_err();
    let text = e.to_string();
    assert_eq!(field_of(e), "base.delta", "{text}");
    assert!(text.contains("torque limit"), "{text}");
}

#[test]
fn unknown_keys_and_broken_text_are_toml_errors() {
    let model = lwr4();
    let text = IdentifiedModel::new(&model, file_for(&model, 0.05))
        .unwrap()
        .to_toml_string()
        .unwrap();
    let extra = text.replacen("joints = 7", "joints = 7\nsurprise = 1", 1);
    assert!(matches!(
        IdentifiedModel::from_toml_str(&model, &extra),
        Err(DynamicsError::Toml(_))
    ));
    assert!(matches!(
        IdentifiedModel::from_toml_str(&model, &text[..text.len() / 2]),
        Err(DynamicsError::Toml(_))
    ));
    assert!(matches!(
        IdentifiedModel::from_toml_file(&model, std::path::Path::new("/nonexistent/arm.toml")),
        Err(DynamicsError::Io { .. })
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Arbitrary text never panics the loader.
    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,400}") {
        let _ = IdentifiedModel::from_toml_str(&lwr4(), &text);
    }

    /// Arbitrary numbers in every vector either load (and then predict finite torques) or are
    /// refused with the field named.
    #[test]
    fn arbitrary_values_load_or_name_the_field(
        offset in prop::collection::vec(-1e3f64..1e3, 7),
        scale in -2.0f64..2.0,
        v0 in -1.0f64..2.0,
    ) {
        let model = lwr4();
        let mut f = file_for(&model, scale);
        f.joint.offset = offset;
        f.joint.coulomb_velocity = v0;
        match IdentifiedModel::new(&model, f) {
            Ok(m) => {
                let mut data = Data::new(&model);
                let tau = m.predict(&mut data, &V7::repeat(0.3), &V7::repeat(0.1), &V7::zeros());
                prop_assert!(tau.iter().all(|v| v.is_finite()));
            }
            Err(DynamicsError::Identified { field, .. }) => prop_assert!(!field.is_empty()),
            Err(other) => prop_assert!(false, "unexpected {other}"),
        }
    }
}
