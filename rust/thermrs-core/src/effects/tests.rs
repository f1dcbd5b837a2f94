//! Tests of the SPEC §6 effects: validation, checks against a rig, their actions.

use super::*;

fn rig() -> Rig {
    Rig::from_toml(
        include_str!("../../../../python/thermrs/data/kr15-paper.toml"),
        "kr15",
    )
    .unwrap()
}

#[test]
fn every_name_has_its_keys_and_round_trips_through_json() {
    for name in EFFECT_NAMES {
        assert!(Effect::keys(name).is_some(), "{name}");
    }
    let all = [
        r#"{"name":"alpha_per_link","alpha_per_k":{"link2":2e-5}}"#,
        r#"{"name":"thermal_lag","tau_min":25.0}"#,
        r#"{"name":"unmodelled_length","length":"a3","temperature":"link3"}"#,
        r#"{"name":"fixture_drift","camera":"A","um_per_k":[1.0,2.0]}"#,
        r#"{"name":"laser_tilt","tilt_deg":0.5}"#,
        r#"{"name":"joint_offset","joint":"joint_a2","temperature":"link2","urad_per_k":5.0}"#,
        r#"{"name":"nonlinear_alpha","kappa_per_k":0.01}"#,
        r#"{"name":"sensor_drift","camera":"B","tau_min":30.0,"um":[3.0,-1.0]}"#,
    ];
    let mut names = Vec::new();
    for j in all {
        let e: Effect = serde_json::from_str(j).unwrap();
        e.validate().unwrap();
        e.check(&rig()).unwrap();
        let back: Effect = serde_json::from_str(&serde_json::to_string(&e).unwrap()).unwrap();
        assert_eq!(back, e);
        names.push(e.name());
    }
    assert_eq!(names, EFFECT_NAMES);
    assert!(serde_json::from_str::<Effect>(r#"{"name":"thermal_lag","tau":3}"#).is_err());
}

#[test]
fn values_out_of_range_are_named() {
    let bad = [
        (r#"{"name":"thermal_lag","tau_min":-3.0}"#, "tau_min"),
        (r#"{"name":"thermal_lag","tau_min":0.0}"#, "tau_min"),
        (
            r#"{"name":"thermal_lag","tau_min":30.0,"weight":0.0}"#,
            "weight",
        ),
        (
            r#"{"name":"sensor_drift","camera":"A","tau_min":1e9,"um":[1,1]}"#,
            "tau_min",
        ),
        (
            r#"{"name":"alpha_per_link","alpha_per_k":{"link2":23.2}}"#,
            "alpha_per_k.link2",
        ),
        (
            r#"{"name":"alpha_per_link","alpha_per_k":{}}"#,
            "alpha_per_k",
        ),
        (
            r#"{"name":"nonlinear_alpha","kappa_per_k":5.0}"#,
            "kappa_per_k",
        ),
        (r#"{"name":"laser_tilt","tilt_deg":45.0}"#, "tilt_deg"),
        (
            r#"{"name":"unmodelled_length","length":"b3","temperature":"link3"}"#,
            "length",
        ),
        (
            r#"{"name":"fixture_drift","camera":"A","um_per_k":[1e6,0]}"#,
            "um_per_k",
        ),
    ];
    for (j, key) in bad {
        let e: Effect = serde_json::from_str(j).unwrap();
        let KeyError { key: k, message: m } = e.validate().unwrap_err();
        assert_eq!(k, key, "{j}: {m}");
    }
}

#[test]
fn names_are_checked_against_the_rig() {
    let r = rig();
    for (j, needle) in [
        (
            r#"{"name":"fixture_drift","camera":"Z","um_per_k":[1,1]}"#,
            "camera \"Z\"",
        ),
        (
            r#"{"name":"joint_offset","joint":"joint_a9","temperature":"link2","urad_per_k":1}"#,
            "joint_a9",
        ),
        (
            r#"{"name":"unmodelled_length","length":"a2","temperature":"link2"}"#,
            "already expands",
        ),
        (
            r#"{"name":"unmodelled_length","length":"a3","temperature":"link9"}"#,
            "link9",
        ),
        (
            r#"{"name":"alpha_per_link","alpha_per_k":{"link9":1e-5}}"#,
            "link9",
        ),
    ] {
        let e: Effect = serde_json::from_str(j).unwrap();
        let m = e.check(&r).unwrap_err().to_string();
        assert!(m.contains(needle), "{m}");
    }
    let twice = [
        Effect::ThermalLag {
            tau_min: 3.0,
            weight: 1.0,
        },
        Effect::ThermalLag {
            tau_min: 4.0,
            weight: 1.0,
        },
    ];
    assert!(matches!(
        Effects::build(&r, &twice, 2e-5, 20.0),
        Err(Error::DuplicateEffect { key }) if key == "thermal_lag"
    ));
}

#[test]
fn errors_carry_their_cause() {
    let r = rig();
    // The cause as data: which kind of name, which one, which the rig has.
    let e = Effect::from_json(r#"{"name":"fixture_drift","camera":"Z","um_per_k":[1,1]}"#).unwrap();
    match e.check(&r) {
        Err(Error::UnknownName(u)) => {
            assert_eq!((u.kind, u.name.as_str()), (NameKind::Camera, "Z"));
            assert_eq!(u.known, ["A", "B"]);
        }
        other => panic!("{other:?}"),
    }
    let e =
        Effect::from_json(r#"{"name":"unmodelled_length","length":"a2","temperature":"link2"}"#)
            .unwrap();
    assert!(matches!(
        e.check(&r),
        Err(Error::LengthAlreadyExpands { length }) if length == "a2"
    ));
    assert!(matches!(
        Effect::from_json(r#"{"name":"thermal_lag","tau_min":-1}"#),
        Err(Error::EffectValue { effect: "thermal_lag", error }) if error.key == "tau_min"
    ));
    assert!(matches!(
        Effect::list_from_json("not json"),
        Err(Error::EffectJson {
            what: "effects",
            ..
        })
    ));
}

#[test]
fn spec_keys_are_checked_like_the_scenario_file() {
    let s = EffectSpec {
        name: "thermal_lag".into(),
        tau_min: Some(3.0),
        um: Some([1.0, 2.0]),
        ..Default::default()
    };
    assert_eq!(Effect::from_spec(&s).unwrap_err().key, "um");
    let s = EffectSpec {
        name: "thermal_lag".into(),
        ..Default::default()
    };
    assert!(Effect::from_spec(&s)
        .unwrap_err()
        .message
        .contains("needs `tau_min`"));
    let s = EffectSpec {
        name: "thermal_lag".into(),
        tau_min: Some(-1.0),
        ..Default::default()
    };
    assert_eq!(Effect::from_spec(&s).unwrap_err().key, "tau_min");
}

#[test]
fn chip_shifts_have_their_closed_forms() {
    let r = rig();
    let fx = Effects::build(
        &r,
        &[
            Effect::FixtureDrift {
                camera: "A".into(),
                um_per_k: [2.0, -1.0],
                mount_tau_min: 0.0,
            },
            Effect::SensorDrift {
                camera: "A".into(),
                tau_min: 10.0,
                um: [4.0, 0.0],
            },
        ],
        2e-5,
        20.0,
    )
    .unwrap();
    let d = fx.chip_shift_um(0, 23.0, 99.0, 600.0);
    let f = 1.0 - (-1.0f64).exp();
    assert!((d[0] - (6.0 + 4.0 * f)).abs() < 1e-12);
    assert!((d[1] + 3.0).abs() < 1e-12);
    assert_eq!(fx.chip_shift_um(1, 23.0, 99.0, 600.0), [0.0, 0.0]);
    assert_eq!(fx.mount_lag_s(0), None);
}

#[test]
fn a_mount_with_inertia_follows_the_room_through_its_lag() {
    let r = rig();
    let fx = Effects::build(
        &r,
        &[Effect::FixtureDrift {
            camera: "A".into(),
            um_per_k: [2.0, -1.0],
            mount_tau_min: 20.0,
        }],
        2e-5,
        20.0,
    )
    .unwrap();
    assert_eq!(fx.mount_lag_s(0), Some(1200.0));
    assert_eq!(fx.mount_lag_s(1), None);
    // The shift follows the mount's temperature, not the room's.
    let d = fx.chip_shift_um(0, 30.0, 23.0, 0.0);
    assert!((d[0] - 6.0).abs() < 1e-12 && (d[1] + 3.0).abs() < 1e-12);
    // The room rises by 1 K over the first minute and stays: after the ramp the mount is at
    // 1 − (τ/h)(1 − e^(−h/τ))·e^(−(t − h)/τ) of the rise (h = 60 s), the closed form.
    let t: Vec<f64> = (0..=120).map(|k| 60.0 * k as f64).collect();
    let x: Vec<f64> = t
        .iter()
        .map(|&tk| if tk > 0.0 { 21.0 } else { 20.0 })
        .collect();
    let y = fx.mount_series(0, &t, &x).unwrap();
    let (h, tau): (f64, f64) = (60.0, 1200.0);
    for (tk, yk) in t.iter().zip(&y).skip(1) {
        let want = 21.0 - (tau / h) * (1.0 - (-h / tau).exp()) * (-(tk - h) / tau).exp();
        assert!((yk - want).abs() < 1e-9, "{tk}: {yk} against {want}");
    }
    // Out of range: a mount time constant is a time constant.
    let bad = Effect::FixtureDrift {
        camera: "A".into(),
        um_per_k: [1.0, 0.0],
        mount_tau_min: -3.0,
    };
    assert_eq!(bad.validate().unwrap_err().key, "mount_tau_min");
}

#[test]
fn a_lag_of_weight_w_is_the_surface_moved_w_of_the_way_to_its_first_order_lag() {
    // A step of 10 K at t = 0 seen every minute for two hours through τ = 30 min: the full
    // lag is 10·(1 − e^(−t/τ)) (closed form); with weight 0.4 the structure sees
    // 10 − 0.4·10·e^(−t/τ).
    let t: Vec<f64> = (0..=120).map(|k| 60.0 * k as f64).collect();
    let x: Vec<f64> = t
        .iter()
        .map(|&s| if s > 0.0 { 10.0 } else { 0.0 })
        .collect();
    let lag: Effect =
        serde_json::from_str(r#"{"name":"thermal_lag","tau_min":30.0,"weight":0.4}"#).unwrap();
    let fx = Effects::build(&rig(), std::slice::from_ref(&lag), 2.3e-5, 20.0).unwrap();
    let full = Effects::build(
        &rig(),
        &[Effect::ThermalLag {
            tau_min: 30.0,
            weight: 1.0,
        }],
        2.3e-5,
        20.0,
    )
    .unwrap();
    let y = fx.structure_series(&t, &x).unwrap();
    let y1 = full.structure_series(&t, &x).unwrap();
    for k in 1..t.len() {
        let closed = 10.0 - 0.4 * 10.0 * (-(t[k] - 60.0) / 1800.0).exp();
        let ramp = y1[k] - 10.0; // the full lag's departure, whatever the first step's ramp
        assert!((y[k] - (10.0 + 0.4 * ramp)).abs() < 1e-9, "{k}");
        if k > 5 {
            assert!(
                (y[k] - closed).abs() < 0.2,
                "{k}: {} against {closed}",
                y[k]
            );
        }
    }
    // The default weight is not written: the SPEC §6 shape is unchanged.
    let plain = Effect::ThermalLag {
        tau_min: 30.0,
        weight: 1.0,
    };
    assert_eq!(
        serde_json::to_string(&plain).unwrap(),
        r#"{"name":"thermal_lag","tau_min":30.0}"#
    );
    assert!(serde_json::to_string(&lag)
        .unwrap()
        .contains(r#""weight":0.4"#));
}

#[test]
fn an_unmodelled_length_of_weight_w_expands_w_times_as_fast_as_its_temperature_says() {
    // Closed form: a3 = 152.91 mm at link3 = reference + 10 K, α = 2.32e-5/K, weight 2.5:
    // a3·(1 + 2.5·α·10). The rig's own lengths (a2 at link2, d4 at link3) keep α.
    let r = rig();
    let alpha = 2.32e-5;
    let e = Effect::from_json(
        r#"{"name":"unmodelled_length","length":"a3","temperature":"link3","weight":2.5}"#,
    )
    .unwrap();
    let set = Effects::build(&r, std::slice::from_ref(&e), alpha, 23.0).unwrap();
    let m = crate::model::ForwardModel::new(&r, &set.params).unwrap();
    let names = m.temperature_names().to_vec();
    let temps: Vec<f64> = names
        .iter()
        .map(|n| if n == "link3" { 33.0 } else { 23.0 })
        .collect();
    let (a, d) = m.lengths_at(Some(&temps));
    assert!((a[2] - 152.91 * (1.0 + 2.5 * alpha * 10.0)).abs() < 1e-12);
    assert!((d[3] - -600.0 * (1.0 + alpha * 10.0)).abs() < 1e-12);
    assert_eq!(a[1], 650.0);
    // Out of range by name; the default not written.
    for bad in ["0.0", "-1.0", "11.0"] {
        let j = format!(
            r#"{{"name":"unmodelled_length","length":"a3","temperature":"link3","weight":{bad}}}"#
        );
        assert!(matches!(
            Effect::from_json(&j),
            Err(Error::EffectValue { effect: "unmodelled_length", error }) if error.key == "weight"
        ));
    }
    let plain = Effect::UnmodelledLength {
        length: "a3".into(),
        temperature: "link3".into(),
        weight: 1.0,
    };
    assert!(!serde_json::to_string(&plain).unwrap().contains("weight"));
}
