//! Parsing, validation and serialisation of requests and replies.

use super::*;

fn code(line: &str) -> (Option<RequestId>, ErrorCode) {
    let (id, e) = parse_request(line.as_bytes()).unwrap_err();
    (id, e.code)
}

#[test]
fn parses_commands_with_and_without_arguments() {
    let r = parse_request(br#"{"id": 3, "cmd": "status"}"#).unwrap();
    assert_eq!(r.id, 3);
    assert_eq!(r.command, Command::Status);
    let r =
        parse_request(br#"{"cmd":"apply-payload","id":4,"mass":3.028,"com":[0,0,0.119]}"#).unwrap();
    assert_eq!(
        r.command,
        Command::ApplyPayload {
            mass: 3.028,
            com: [0.0, 0.0, 0.119],
            force: None,
        }
    );
    let r = parse_request(
        br#"{"cmd":"apply-payload","id":4,"mass":3.9,"com":[0,0,0.119],"force":true}"#,
    )
    .unwrap();
    assert!(matches!(
        r.command,
        Command::ApplyPayload {
            force: Some(true),
            ..
        }
    ));
    // `force` is a boolean, never a number or a string.
    for bad in [r#""force":1"#, r#""force":"yes""#] {
        let line = format!(r#"{{"id":6,"cmd":"apply-payload","mass":1,"com":[0,0,0],{bad}}}"#);
        assert_eq!(
            code(&line),
            (Some(6), ErrorCode::InvalidArguments),
            "{line}"
        );
    }
    let r = parse_request(
        br#"{"id":5,"cmd":"collision","action":"configure","thresholds":[6,6,6,6,6,6,5]}"#,
    )
    .unwrap();
    assert!(matches!(
        r.command,
        Command::Collision {
            action: CollisionAction::Configure,
            thresholds: Some(t),
            gains: None,
            reaction: None,
            pause_s: None,
        } if t[6] == 5.0
    ));
}

#[test]
fn request_line_round_trips() {
    let req = Request {
        id: 9,
        ros2: None,
        command: Command::EstimatePayload {
            around: Some([0.1; 7]),
            poses: Some(10),
            step_deg: Some(7.0),
            pattern: Some(crate::pattern::PatternKind::Optimized),
            use_tare: None,
            apply: Some(true),
        },
    };
    assert_eq!(parse_request(req.to_line().as_bytes()).unwrap(), req);
    let forwarded = Request {
        ros2: Some(Ros2Caller {
            participant: "010f2c4d.00001234.00000001.000001c1".into(),
            authenticated: true,
        }),
        ..req
    };
    assert_eq!(
        parse_request(forwarded.to_line().as_bytes()).unwrap(),
        forwarded
    );
}

#[test]
fn a_forwarded_participant_is_bounded() {
    let line = |p: &str| {
        format!(r#"{{"id":1,"cmd":"stop","ros2":{{"participant":"{p}","authenticated":true}}}}"#)
    };
    assert!(parse_request(line("01.02").as_bytes()).is_ok());
    for bad in ["", "x; rm -rf", &"0".repeat(65)] {
        let (id, e) = parse_request(line(bad).as_bytes()).unwrap_err();
        assert_eq!(id, Some(1));
        assert_eq!(e.code, ErrorCode::InvalidArguments);
        assert!(e.message.contains("ros2.participant"), "{}", e.message);
    }
    let extra =
        r#"{"id":1,"cmd":"stop","ros2":{"participant":"01","authenticated":true,"admin":true}}"#;
    assert!(parse_request(extra.as_bytes()).is_err());
}

#[test]
fn errors_have_codes_and_keep_the_id_when_readable() {
    assert_eq!(code("not json"), (None, ErrorCode::Malformed));
    assert_eq!(code("[1,2]"), (None, ErrorCode::Malformed));
    assert_eq!(code(r#"{"cmd":"status"}"#), (None, ErrorCode::Malformed));
    assert_eq!(
        code(r#"{"id":-1,"cmd":"status"}"#),
        (None, ErrorCode::Malformed)
    );
    assert_eq!(code(r#"{"id":2}"#), (Some(2), ErrorCode::UnknownCommand));
    assert_eq!(
        code(r#"{"id":2,"cmd":"fly"}"#),
        (Some(2), ErrorCode::UnknownCommand)
    );
    assert_eq!(
        code(r#"{"id":2,"cmd":"status","extra":1}"#),
        (Some(2), ErrorCode::InvalidArguments)
    );
    assert_eq!(
        code(r#"{"id":2,"cmd":"apply-payload","mass":"heavy","com":[0,0,0]}"#),
        (Some(2), ErrorCode::InvalidArguments)
    );
    assert_eq!(
        code(r#"{"id":2,"cmd":"collision","action":"explode"}"#),
        (Some(2), ErrorCode::InvalidArguments)
    );
}

#[test]
fn every_numeric_argument_out_of_range_is_rejected_naming_the_field_and_range() {
    let cases = [
        (
            r#""cmd":"sample","duration_s":0"#,
            "duration_s = 0 s is outside 0.001…60 s",
        ),
        (
            r#""cmd":"tare","around":[0,0,0,0,0,0,1e300]"#,
            "around[6] = 1e300 rad is outside",
        ),
        (
            r#""cmd":"estimate-payload","around":[1e300,0,0,0,0,0,0]"#,
            "around[0] = 1e300 rad is outside",
        ),
        (
            r#""cmd":"tare","poses":1000"#,
            "poses = 1000 is outside 2…100",
        ),
        (
            r#""cmd":"estimate-payload","step_deg":-7"#,
            "step_deg = -7 deg is outside 1…30 deg",
        ),
        (
            r#""cmd":"apply-payload","mass":1e300,"com":[0,0,0]"#,
            "mass = 1e300 kg is outside 0…20 kg",
        ),
        (
            r#""cmd":"apply-payload","mass":1,"com":[0,0,5]"#,
            "com[2] = 5 m is outside -1…1 m",
        ),
        (
            r#""cmd":"collision","action":"configure","thresholds":[6,6,6,1e300,6,6,6]"#,
            "thresholds[3] = 1e300 Nm is outside 0.1…25 Nm (joint 4)",
        ),
        (
            r#""cmd":"collision","action":"configure","gains":[400,400,400,400,400,400,1e308]"#,
            "gains[6] = 1e308 1/s is outside 1…500 1/s (joint 7)",
        ),
        (
            r#""cmd":"record","path":"/tmp/x","kind":"log","duration_s":1e9"#,
            "duration_s = 1e9 s is outside 0.001…3600 s",
        ),
        (
            r#""cmd":"record","path":"/tmp/x","kind":"samples","count":0"#,
            "count = 0 is outside 1…1000",
        ),
        (
            r#""cmd":"watch","state_every":1e12"#,
            "state_every = 1e12 cycles is outside 1…100000 cycles",
        ),
        (
            r#""cmd":"collision-install","period_s":0"#,
            "period_s = 0 s is outside",
        ),
        (
            r#""cmd":"collision-install","arm_offset":[0,500,0,0,0,0,0]"#,
            "arm_offset[1] = 500 Nm is outside",
        ),
    ];
    for (args, expected) in cases {
        let line = format!("{{\"id\":7,{args}}}");
        let (id, e) = parse_request(line.as_bytes()).unwrap_err();
        assert_eq!(
            (id, e.code),
            (Some(7), ErrorCode::InvalidArguments),
            "{line}"
        );
        assert!(e.message.starts_with(expected), "{line}: {}", e.message);
    }
}

#[test]
fn every_known_name_parses_with_minimal_arguments() {
    let minimal = [
        r#"{"id":1,"cmd":"status"}"#,
        r#"{"id":1,"cmd":"sample"}"#,
        r#"{"id":1,"cmd":"tare"}"#,
        r#"{"id":1,"cmd":"estimate-payload"}"#,
        r#"{"id":1,"cmd":"apply-payload","mass":1,"com":[0,0,0]}"#,
        r#"{"id":1,"cmd":"clear-payload"}"#,
        r#"{"id":1,"cmd":"expect-payload"}"#,
        r#"{"id":1,"cmd":"collision","action":"show"}"#,
        r#"{"id":1,"cmd":"collision-calibrate"}"#,
        concat!(
            r#"{"id":1,"cmd":"collision-install","schedule":{"thresholds":[1,1,1,1,1,1,1],"#,
            r#""speed":[0,0,0,0,0,0,0],"velocity_noise":[0,0,0,0,0,0,0],"#,
            r#""payload_dynamics":[0,0,0,0,0,0,0],"inertial":[0,0,0,0,0,0,0],"#,
            r#""gravity":[0,0,0,0,0,0,0],"scale":[1,1,1,1,1,1,1]},"recording":"#,
            r#"{"budget_per_hour":0.1,"duration_s":25,"blocks":24,"block_s":1,"#,
            r#""max_speed":[0,0,0,0,0,0,0],"max_acceleration":[0,0,0,0,0,0,0]},"#,
            r#""median_thresholds":[1,1,1,1,1,1,1],"period_s":0.001,"#,
            r#""gains":[400,400,400,400,400,400,400],"source":"run1.json"}"#
        ),
        r#"{"id":1,"cmd":"stop"}"#,
        r#"{"id":1,"cmd":"resume"}"#,
        r#"{"id":1,"cmd":"record","path":"x.csv","kind":"log","duration_s":1}"#,
        r#"{"id":1,"cmd":"watch"}"#,
    ];
    assert_eq!(minimal.len(), Command::NAMES.len());
    for (line, name) in minimal.iter().zip(Command::NAMES) {
        let r = parse_request(line.as_bytes()).unwrap_or_else(|e| panic!("{line}: {e:?}"));
        assert_eq!(r.command.name(), *name);
    }
}

#[test]
fn replies_serialise_as_documented() {
    let ok = Reply::ok(Some(1), serde_json::json!({"a": 1})).to_line();
    assert_eq!(ok, r#"{"id":1,"ok":true,"result":{"a":1}}"#);
    let err = Reply::err(None, OperatorError::new(ErrorCode::TooLarge, "x")).to_line();
    assert_eq!(
        err,
        r#"{"id":null,"ok":false,"error":{"code":"too-large","message":"x"}}"#
    );
    let ev = Reply::Event {
        id: Some(2),
        event: "progress".into(),
        data: serde_json::json!({"pose": 1}),
    };
    assert_eq!(
        ev.to_line(),
        r#"{"id":2,"event":"progress","data":{"pose":1}}"#
    );
    for line in [ok, err, ev.to_line()] {
        let back: Reply = serde_json::from_str(&line).unwrap();
        assert_eq!(back.to_line(), line);
    }
    assert!(!ev.is_final());
}
