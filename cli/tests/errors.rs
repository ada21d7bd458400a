//! Bad input: one `error:` line naming what is wrong, the right exit status, never a panic.

mod common;
use common::{run, run_ok};
use proptest::prelude::*;

fn err_line(args: &[&str], stdin: &str) -> (i32, String) {
    let o = run(args, stdin.as_bytes());
    assert_eq!(o.stdout, "", "nothing on stdout on failure");
    assert_eq!(o.stderr.lines().count(), 1, "one line: {:?}", o.stderr);
    (o.code, o.stderr.trim_end().to_string())
}

#[test]
fn invalid_parameters_name_the_parameter_and_its_range() {
    let csv = "OP\n1\n2\n3\n";
    let cases = [
        (vec!["--param", "S=3", "--param", "J=5"], "error: kano: parameter J = 5 is out of range: expected 0 <= J <= S (= 3)"),
        (vec!["--param", "S=-1"], "error: kano: parameter S = -1 is out of range: expected a finite number >= 0 (OP units)"),
        (vec!["--param", "S=NaN"], "error: kano: parameter S = NaN is out of range: expected a finite number >= 0 (OP units)"),
        (vec!["--param", "X=1"], "error: kano: unknown parameter \"X\"; the model's parameters are S, J"),
    ];
    for (extra, want) in cases {
        let mut args = vec!["valve", "-", "--model", "kano"];
        args.extend(extra);
        assert_eq!(err_line(&args, csv), (2, want.to_string()));
    }
    assert_eq!(
        err_line(
            &["valve", "-", "--model", "he", "--param", "fs=1", "--param", "fd=2"],
            csv
        ),
        (
            2,
            "error: he: parameter fd = 2 is out of range: expected 0 <= fd <= fs (= 1)".into()
        )
    );
    assert_eq!(
        err_line(&["valve", "-", "--model", "nope"], csv),
        (
            2,
            "error: unknown stiction model \"nope\"; registered models are he, kano, kano-asym, kano-char"
                .into()
        )
    );
}

#[test]
fn malformed_csv_names_file_row_and_column() {
    let args = ["valve", "-", "--model", "kano", "--param", "S=1"];
    assert_eq!(
        err_line(&args, "OP\n1\nabc\n3\n"),
        (
            1,
            "error: -: row 3, column OP: \"abc\" is not a number".into()
        )
    );
    let (code, msg) = err_line(&args, "PV\n1\n2\n3\n");
    assert_eq!(code, 1);
    assert!(msg.starts_with("error: -: no column OP"), "{msg}");
    let (code, msg) = err_line(&args, "OP\n1\n\n3\n4\nnan\n");
    assert_eq!(code, 1);
    assert!(msg.contains("row") && msg.contains("OP"), "{msg}");
    let (code, msg) = err_line(&args, "");
    assert_eq!(code, 1);
    assert!(msg.contains("empty"), "{msg}");
}

#[test]
fn missing_file_and_bad_flags() {
    let (code, msg) = err_line(&["valve", "/nonexistent/loop.csv", "--model", "kano"], "");
    assert_eq!(code, 1);
    assert!(msg.starts_with("error: /nonexistent/loop.csv"), "{msg}");
    let o = run(&["valve"], b"");
    assert_eq!(o.code, 2);
    assert!(o.stderr.starts_with("error:"), "{}", o.stderr);
    let o = run(&["simulate", "--plant", "moon"], b"");
    assert_eq!(o.code, 2);
    assert_eq!(
        o.stderr.trim_end(),
        "error: unknown plant \"moon\"; presets are paper, slow"
    );
    // An unstable closed loop is a failed computation (exit 1), refused before simulating.
    let o = run(&["simulate", "--kc", "5", "--ki", "5"], b"");
    assert_eq!(o.code, 1, "{}", o.stderr);
    assert!(
        o.stderr.starts_with("error:") && o.stderr.contains("unstable"),
        "{}",
        o.stderr
    );
}

#[test]
fn help_shows_an_example_for_each_command() {
    for cmd in [
        "models", "valve", "simulate", "identify", "quantify", "compare",
    ] {
        let o = run(&[cmd, "--help"], b"");
        assert_eq!(o.code, 0);
        assert!(
            o.stdout.contains("Examples:") && o.stdout.contains(&format!("stiction {cmd}")),
            "{cmd}:\n{}",
            o.stdout
        );
    }
}

proptest! {
    /// Random bytes on stdin never make the CLI panic: it exits 0 or 1.
    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let o = run(&["valve", "-", "--model", "kano", "--param", "S=1", "--param", "J=0.5"], &bytes);
        prop_assert!(o.code == 0 || o.code == 1, "code {} {}", o.code, o.stderr);
        if o.code == 1 {
            prop_assert!(o.stderr.starts_with("error: ") && o.stderr.lines().count() == 1);
        }
    }

    /// Random tables of numbers, empty cells and text never make the CLI panic.
    #[test]
    fn random_tables_never_panic(
        header in proptest::sample::subsequence(vec!["t", "OP", "PV", "SP", "MV", "x"], 0..=6),
        cells in proptest::collection::vec(
            prop_oneof![
                Just(String::new()),
                Just("nan".to_string()),
                Just("1e400".to_string()),
                "[a-z]{1,3}",
                any::<f64>().prop_map(|v| v.to_string()),
                (-100.0..100.0f64).prop_map(|v| v.to_string()),
            ],
            0..60,
        ),
        sep in prop_oneof![Just(","), Just(";"), Just("\t")],
        fill in any::<bool>(),
    ) {
        let width = header.len().max(1);
        let mut text = header.join(sep);
        for row in cells.chunks(width) {
            text.push('\n');
            text.push_str(&row.join(sep));
        }
        let mut args = vec!["valve", "-", "--model", "he", "--param", "fs=1", "--param", "fd=0.5"];
        if fill {
            args.extend(["--fill", "hold"]);
        }
        let o = run(&args, text.as_bytes());
        prop_assert!(o.code == 0 || o.code == 1, "code {} {}", o.code, o.stderr);
    }
}

#[test]
fn mat_struct_of_loops_needs_a_loop_path() {
    let file = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../datasets/tests/fixtures/loop_isdb.mat"
    );
    let args = ["valve", file, "--model", "kano", "--param", "S=1"];
    let (code, msg) = err_line(&args, "");
    assert_eq!(code, 1);
    assert!(
        msg.ends_with(
            "loop_isdb.mat: 2 loops (cdata.chemicals.loop1, cdata.chemicals.loop2): select one \
             with --loop PATH"
        ),
        "{msg}"
    );
    let mut with_loop = args.to_vec();
    with_loop.extend(["--loop", "cdata.chemicals.loop2"]);
    let o = run_ok(&with_loop, b"");
    assert!(o.stdout.starts_with("OP,MV\n40"), "{}", o.stdout);
}
