//! `stiction valve` and `stiction simulate` end to end, in memory.

mod common;
use common::{column, run, run_ok};

#[test]
fn valve_reproduces_the_golden_vector() {
    // Spec §8.1, Kano S = 4, J = 1, start at rest after moving up.
    let op = [
        50.0, 50.5, 51.0, 52.0, 54.0, 56.0, 56.0, 56.5, 57.5, 58.0, 57.0, 55.0, 53.0, 52.0, 51.5,
        52.0, 53.0, 54.0, 55.0, 56.0,
    ];
    let csv: String = std::iter::once("OP".to_string())
        .chain(op.iter().map(|v| v.to_string()))
        .collect::<Vec<_>>()
        .join("\n");
    let o = run_ok(
        &[
            "valve", "-", "--model", "kano", "--param", "S=4", "--param", "J=1", "--start", "up",
        ],
        csv.as_bytes(),
    );
    let mv = column(&o.stdout, "MV");
    let golden = [
        48.5, 48.5, 48.5, 50.5, 52.5, 54.5, 54.5, 54.5, 56.0, 56.5, 56.5, 56.5, 54.5, 53.5, 53.0,
        53.0, 53.0, 53.0, 53.0, 54.5,
    ];
    assert_eq!(mv, golden);
    assert_eq!(column(&o.stdout, "OP"), op);

    let he = run_ok(
        &[
            "valve", "-", "--model", "he", "--param", "fs=2.5", "--param", "fd=1.5", "--start",
            "up",
        ],
        csv.as_bytes(),
    );
    let golden_he = [
        48.5, 48.5, 48.5, 50.5, 52.5, 54.5, 54.5, 54.5, 56.0, 56.0, 56.0, 56.0, 54.5, 54.5, 53.0,
        53.0, 53.0, 53.0, 53.0, 54.5,
    ];
    assert_eq!(column(&he.stdout, "MV"), golden_he);
}

#[test]
fn simulated_op_fed_to_valve_reproduces_mv() {
    for (model, params) in [
        ("kano", vec!["S=9", "J=3"]),
        ("he", vec!["fs=3", "fd=1"]),
        ("kano-asym", vec!["D=2", "J_up=0.5", "J_dn=2"]),
    ] {
        let mut args = vec![
            "simulate",
            "--valve",
            model,
            "--samples",
            "1500",
            "--seed",
            "3",
        ];
        for p in &params {
            args.extend(["--param", p]);
        }
        let sim = run_ok(&args, b"");
        let mut vargs = vec!["valve", "-", "--model", model];
        for p in &params {
            vargs.extend(["--param", p]);
        }
        let valve = run_ok(&vargs, sim.stdout.as_bytes());
        assert_eq!(
            column(&valve.stdout, "MV"),
            column(&sim.stdout, "MV"),
            "{model}"
        );
    }
}

#[test]
fn simulate_is_reproducible_and_seed_dependent() {
    let a = run(&["simulate", "--samples", "300", "--seed", "5"], b"");
    let b = run(&["simulate", "--samples", "300", "--seed", "5"], b"");
    let c = run(&["simulate", "--samples", "300", "--seed", "6"], b"");
    assert_eq!(a.code, 0, "{}", a.stderr);
    assert_eq!(a.stdout, b.stdout);
    assert_ne!(a.stdout, c.stdout);
    assert_eq!(a.stdout.lines().next(), Some("t,SP,PV,OP,MV"));
    assert_eq!(a.stdout.lines().count(), 301);
}

#[test]
fn simulate_without_stiction_tracks_the_set_point_and_with_stiction_limit_cycles() {
    let lin = run_ok(&["simulate", "--plant", "paper", "--samples", "3000"], b"");
    let sp = column(&lin.stdout, "SP");
    let pv = column(&lin.stdout, "PV");
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let err: Vec<f64> = sp.iter().zip(&pv).map(|(s, p)| s - p).collect();
    let rms_err = (err.iter().map(|e| e * e).sum::<f64>() / err.len() as f64).sqrt();
    let sp_std = {
        let m = mean(&sp);
        (sp.iter().map(|s| (s - m).powi(2)).sum::<f64>() / sp.len() as f64).sqrt()
    };
    // Tracking: the error is a small fraction of the set-point excursions (noise σ_e = 0.1
    // passes through C(q), whose gain is large, so the error cannot be zero).
    assert!(
        rms_err < 0.3 * sp_std,
        "rms error {rms_err}, SP std {sp_std}"
    );
    assert!(mean(&err).abs() < 0.1, "mean error {}", mean(&err));

    let sticky = run_ok(
        &[
            "simulate",
            "--plant",
            "paper",
            "--param",
            "S=9",
            "--param",
            "J=3",
            "--samples",
            "3000",
        ],
        b"",
    );
    let mv = column(&sticky.stdout, "MV");
    let op = column(&sticky.stdout, "OP");
    // Stick-slip: MV is held most of the time and moves in jumps of about J or more.
    let moves: Vec<f64> = mv
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d != 0.0)
        .collect();
    let stuck = 1.0 - moves.len() as f64 / (mv.len() - 1) as f64;
    assert!(stuck > 0.7, "stuck fraction {stuck}");
    let big = moves.iter().filter(|d| d.abs() >= 3.0 - 1e-9).count();
    assert!(big >= 10, "only {big} slip jumps >= J");
    // OP oscillates: it reverses many times by more than S.
    let mut reversals = 0;
    let (mut lo, mut hi) = (op[0], op[0]);
    let mut dir = 0;
    for &u in &op {
        lo = lo.min(u);
        hi = hi.max(u);
        if dir >= 0 && hi - u > 9.0 {
            reversals += 1;
            dir = -1;
            lo = u;
        } else if dir <= 0 && u - lo > 9.0 {
            reversals += 1;
            dir = 1;
            hi = u;
        }
    }
    assert!(
        reversals >= 10,
        "OP reversed by more than S only {reversals} times"
    );
}

#[test]
fn print_config_round_trips() {
    let asym = |tail: &[&str]| {
        let mut args = vec![
            "simulate",
            "--valve",
            "kano-asym",
            "--param",
            "D=2",
            "--param",
            "J_dn=1",
        ];
        args.extend_from_slice(tail);
        run_ok(&args, b"")
    };
    let cfg = asym(&["--print-config"]);
    assert!(
        cfg.stdout.contains("\"kind\": \"kano-asym\""),
        "{}",
        cfg.stdout
    );
    let direct = asym(&["--samples", "200"]);
    let via = run_ok(
        &["simulate", "--config", "-", "--samples", "200"],
        cfg.stdout.as_bytes(),
    );
    assert_eq!(direct.stdout, via.stdout);
}
