//! Registry, serde configs, typed errors on degenerate input, stability reporting.
#![allow(clippy::unwrap_used)]
mod common;

use common::*;
use linear_id::{
    find_identifier, registry, Arx, Earx, IdError, LinearIdentifier, OrderKind, OrderValue,
    ParsimK, Structure,
};

const NAMES: [&str; 5] = ["armax", "arx", "earmax", "earx", "ss"];

#[test]
fn builtins_are_registered_with_defaults_of_the_paper() {
    let names: Vec<&str> = registry().iter().map(|e| e.name).collect();
    for n in NAMES {
        assert!(names.contains(&n), "{n} missing from {names:?}");
        let e = find_identifier(n).unwrap();
        let id = e.build_default().unwrap();
        assert_eq!(id.name(), n);
        let orders = id.orders();
        let get = |k: &str| orders.iter().find(|(name, _)| *name == k).map(|(_, v)| *v);
        assert_eq!(get("n"), Some(OrderValue::Int(2)), "{n}");
        if n != "ss" {
            assert_eq!(get("m"), Some(OrderValue::Int(2)));
            assert_eq!(get("delay"), Some(OrderValue::Int(0)));
        }
        if n == "armax" || n == "earmax" {
            assert_eq!(get("p"), Some(OrderValue::Int(2)));
        }
        // every value has its spec's type, in the spec's order
        let kinds: Vec<(&str, OrderKind)> = orders.iter().map(|(k, v)| (*k, v.kind())).collect();
        let specs: Vec<(&str, OrderKind)> = e.orders.iter().map(|o| (o.name, o.kind())).collect();
        assert_eq!(kinds, specs, "{n}");
    }
    assert!(matches!(
        find_identifier("nope"),
        Err(IdError::UnknownIdentifier { .. })
    ));
    let e = find_identifier("arx").unwrap();
    assert!(matches!(
        (e.build)(&[("q".into(), OrderValue::Int(1))]),
        Err(IdError::UnknownOrder { .. })
    ));
    assert!(matches!(
        (e.build)(&[("n".into(), OrderValue::Real(1.5))]),
        Err(IdError::InvalidOrder { .. })
    ));
    // an order is an integer: neither 2.0 nor true
    for bad in [OrderValue::Real(2.0), OrderValue::Bool(true)] {
        assert!(matches!(
            (e.build)(&[("n".into(), bad)]),
            Err(IdError::InvalidOrder { .. })
        ));
    }
    let id = (e.build)(&[
        ("n".into(), OrderValue::Int(3)),
        ("delay".into(), OrderValue::Int(2)),
    ])
    .unwrap();
    let int = OrderValue::Int;
    assert_eq!(
        id.orders(),
        vec![("n", int(3)), ("m", int(2)), ("delay", int(2))]
    );
    // a switch takes true/false or 1/0, a real option an integer too
    let ss = find_identifier("ss").unwrap();
    let id = (ss.build)(&[
        ("center".into(), OrderValue::Int(0)),
        ("d_required".into(), OrderValue::Bool(true)),
        ("threshold".into(), OrderValue::Real(0.2)),
    ])
    .unwrap();
    let orders = id.orders();
    assert!(orders.contains(&("center", OrderValue::Bool(false))));
    assert!(orders.contains(&("d_required", OrderValue::Bool(true))));
    assert!(orders.contains(&("threshold", OrderValue::Real(0.2))));
    assert!((ss.build)(&[("center".into(), OrderValue::Int(2))]).is_err());
    let earx = find_identifier("earx").unwrap();
    let id = (earx.build)(&[("lambda_beta".into(), OrderValue::Int(1))]).unwrap();
    assert!(id
        .orders()
        .contains(&("lambda_beta", OrderValue::Real(1.0))));
}

#[test]
fn configs_round_trip_through_typetag_json() {
    let id: Box<dyn LinearIdentifier> =
        serde_json::from_str(r#"{"kind":"arx","n":2,"m":2,"delay":0}"#).unwrap();
    assert_eq!(id.name(), "arx");
    for n in NAMES {
        let id = find_identifier(n).unwrap().build_default().unwrap();
        let json = serde_json::to_string(&id).unwrap();
        assert!(json.contains(&format!(r#""kind":"{n}""#)), "{json}");
        let back: Box<dyn LinearIdentifier> = serde_json::from_str(&json).unwrap();
        assert_eq!(back.orders(), id.orders());
    }
    let earx: Box<dyn LinearIdentifier> =
        serde_json::from_str(r#"{"kind":"earx","tuning":{"lambda_beta":0.7}}"#).unwrap();
    assert!(earx
        .orders()
        .contains(&("lambda_beta", OrderValue::Real(0.7))));
    // unchecked values are rejected at deserialisation
    assert!(serde_json::from_str::<Box<dyn LinearIdentifier>>(r#"{"kind":"arx","m":0}"#).is_err());
    assert!(serde_json::from_str::<Box<dyn LinearIdentifier>>(r#"{"kind":"earx","p":2}"#).is_err());
    assert!(
        serde_json::from_str::<Box<dyn LinearIdentifier>>(r#"{"kind":"ss","n":30,"f":10}"#)
            .is_err()
    );
    assert!(serde_json::from_str::<Box<dyn LinearIdentifier>>(
        r#"{"kind":"earx","tuning":{"lambda_beta":1.5}}"#
    )
    .is_err());
    // fitted models serialise too
    let (u, y) = paper_closed_loop(500, 0.0, 0.1, 1);
    let fit = Arx::params().check().unwrap().identify(&u, &y).unwrap();
    let back: linear_id::LinearFit =
        serde_json::from_str(&serde_json::to_string(&fit).unwrap()).unwrap();
    assert_eq!(back, fit);
}

#[test]
fn degenerate_input_gives_typed_errors_never_panics_or_nan() {
    let (u, y) = paper_closed_loop(400, 0.0, 0.1, 2);
    for n in NAMES {
        let id = find_identifier(n).unwrap().build_default().unwrap();
        // constant input
        let c = vec![3.0; 400];
        assert!(
            matches!(
                id.identify(&c, &y),
                Err(IdError::ConstantInput { signal: "u", .. })
            ),
            "{n}"
        );
        assert!(
            matches!(
                id.identify(&u, &c),
                Err(IdError::ConstantInput { signal: "y", .. })
            ),
            "{n}"
        );
        // too few samples
        let k = id.min_samples();
        assert!(
            matches!(id.identify(&u[..k - 1], &y[..k - 1]), Err(IdError::TooFewSamples { needed, got }) if needed == k && got == k - 1),
            "{n}"
        );
        assert!(
            matches!(id.identify(&[], &[]), Err(IdError::TooFewSamples { .. })),
            "{n}"
        );
        // the minimum itself works or fails with a typed error, and never yields NaN
        match id.identify(&u[..k], &y[..k]) {
            Ok(fit) => assert!(fit
                .predict_one_step(&u[..k], &y[..k])
                .map(|p| p.iter().all(|v| v.is_finite()))
                .unwrap_or(true)),
            Err(e) => assert!(
                matches!(e, IdError::Singular { .. } | IdError::NotConverged { .. }),
                "{n}: {e}"
            ),
        }
        // length mismatch, non-finite
        assert!(
            matches!(
                id.identify(&u[..100], &y[..99]),
                Err(IdError::LengthMismatch { u: 100, y: 99 })
            ),
            "{n}"
        );
        let mut bad = u.clone();
        bad[17] = f64::NAN;
        assert!(
            matches!(
                id.identify(&bad, &y),
                Err(IdError::NonFinite {
                    signal: "u",
                    index: 17,
                    ..
                })
            ),
            "{n}"
        );
        // two-level input with a period that makes the regression singular: never NaN output
        let sq: Vec<f64> = (0..400)
            .map(|k| if k % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let y2 = simulate(&[1.0, -0.5], &[1.0], &[1.0], 0, &sq, &[], &[]);
        match id.identify(&sq, &y2) {
            Ok(fit) => {
                let p = fit.predict_one_step(&sq, &y2);
                assert!(
                    p.map(|p| p.iter().all(|v| v.is_finite())).unwrap_or(true),
                    "{n}"
                );
            }
            Err(e) => assert!(
                matches!(e, IdError::Singular { .. } | IdError::NotConverged { .. }),
                "{n}: {e}"
            ),
        }
    }
}

#[test]
fn singular_regression_is_a_typed_error() {
    // first-order noise-free data fitted with ARX(2,2): exactly collinear lags
    let u = gbn(300, 0.2, 1);
    let y = simulate(&[1.0, -0.5], &[1.0], &[1.0], 0, &u, &[], &[]);
    let err = Arx::params().check().unwrap().identify(&u, &y).unwrap_err();
    assert!(
        matches!(
            err,
            IdError::Singular {
                identifier: "arx",
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn unstable_model_is_reported_not_silently_used() {
    // an integrating-unstable process: y(k) = 1.05 y(k-1) + u(k-1) + e
    let u = gbn(200, 0.3, 1);
    let e = white(200, 0.01, 2);
    let y = simulate(&[1.0, -1.05], &[1.0], &[1.0], 0, &u, &e, &[]);
    let fit = Arx::params()
        .n(1)
        .m(1)
        .check()
        .unwrap()
        .identify(&u, &y)
        .unwrap();
    assert!(!fit.is_stable());
    assert!(fit.info().process_max_pole > 1.0);
    assert!(matches!(
        fit.check_stable(false),
        Err(IdError::Unstable {
            identifier: "arx",
            part: "process",
            ..
        })
    ));
    // the one-step predictor of an ARX model is FIR: always usable
    assert!(fit.is_predictor_stable());
    let (u, y) = paper_closed_loop(1000, 0.0, 0.1, 1);
    let fit = Arx::params().check().unwrap().identify(&u, &y).unwrap();
    assert!(fit.check_stable(true).is_ok());
}

#[test]
fn prediction_simulation_and_disturbance_of_a_fit() {
    let (u, y) = closed_loop_valve(&PAPER, 1500, 0.5, 0.1, 4, (5.0, 2.0));
    let earx = Earx::params().check().unwrap().identify(&u, &y).unwrap();
    let eta = earx.disturbance().unwrap();
    assert_eq!(eta.len(), 1500);
    // β̂ follows the true disturbance (eq. 11, a = 0.5, after 500 warm-up samples), up to the
    // centering offset: correlation > 0.8
    let truth = paper_disturbance(2000, 0.5, 0)[500..].to_vec();
    let (me, mt) = (
        eta.iter().sum::<f64>() / 1500.0,
        truth.iter().sum::<f64>() / 1500.0,
    );
    let cov: f64 = eta
        .iter()
        .zip(&truth)
        .map(|(a, b)| (a - me) * (b - mt))
        .sum();
    let ve: f64 = eta.iter().map(|a| (a - me).powi(2)).sum();
    let vt: f64 = truth.iter().map(|b| (b - mt).powi(2)).sum();
    let corr = cov / (ve * vt).sqrt();
    assert!(corr > 0.8, "corr {corr}");
    let pred = earx.predict_one_step(&u, &y).unwrap();
    assert!(linear_id::fit_pv(&y[100..], &pred[100..]) > 90.0);
    let arx = Arx::params().check().unwrap().identify(&u, &y).unwrap();
    let sim = arx.simulate(&u, &y[..2]).unwrap();
    assert_eq!(&sim[..2], &y[..2]);
    assert!(arx.disturbance().is_none());
    // ss prediction and simulation are finite and the prediction fits
    let ss = ParsimK::params().check().unwrap().identify(&u, &y).unwrap();
    assert!(matches!(ss.structure(), Structure::StateSpace { .. }));
    let p = ss.predict_one_step(&u, &y).unwrap();
    assert!(linear_id::fit_pv(&y[100..], &p[100..]) > 80.0);
    assert!(ss.simulate(&u, &[]).unwrap().iter().all(|v| v.is_finite()));
    // prepared path equals the plain path
    let id = Arx::params().check().unwrap();
    let prep = id.prepare(&y).unwrap();
    let f2 = id.identify_prepared(&prep, &u).unwrap();
    assert_eq!(f2, arx);
}
