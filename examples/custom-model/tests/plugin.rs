//! A third party's model is listed, built and run by the stock CLI code: the example's own
//! binary, `stiction-custom`.

use std::io::Write;
use std::process::{Command, Stdio};

use custom_model as _;

/// Run `stiction-custom ARGS` with `stdin`: exit status, stdout, stderr.
fn run(args: &[&str], stdin: &str) -> (i32, String, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_stiction-custom"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the example's binary runs");
    let mut input = child.stdin.take().expect("stdin");
    input.write_all(stdin.as_bytes()).expect("stdin written");
    drop(input);
    let out = child.wait_with_output().expect("the binary ends");
    (
        out.status.code().expect("an exit status"),
        String::from_utf8(out.stdout).expect("utf8"),
        String::from_utf8(out.stderr).expect("utf8"),
    )
}

#[test]
fn plugin_is_listed_next_to_the_built_ins() {
    let (code, out, err) = run(&["models"], "");
    assert_eq!(code, 0, "{err}");
    for name in ["backlash", "kano", "he", "kano-asym"] {
        assert!(out.contains(name), "{name} missing from:\n{out}");
    }
}

#[test]
fn plugin_runs_through_the_valve_command() {
    // OP rises 0 -> 4, falls back to 0; backlash width 2: MV lags by 1 and holds across the band.
    let csv = "OP\n0\n1\n2\n3\n4\n3\n2\n1\n0\n";
    let (code, out, err) = run(
        &["valve", "-", "--model", "backlash", "--param", "B=2"],
        csv,
    );
    assert_eq!(code, 0, "{err}");
    let mv: Vec<f64> = out
        .lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .nth(1)
                .expect("MV column")
                .parse()
                .expect("number")
        })
        .collect();
    // Start: direction down => MV(0) = OP(0) + 1 = 1.
    assert_eq!(mv, vec![1.0, 1.0, 1.0, 2.0, 3.0, 3.0, 3.0, 2.0, 1.0]);
}

#[test]
fn plugin_parameters_are_validated_by_the_plugin() {
    let (code, _, err) = run(
        &["valve", "-", "--model", "backlash", "--param", "B=-1"],
        "OP\n1\n2\n",
    );
    assert_eq!(code, 2);
    assert_eq!(
        err.trim(),
        "error: backlash: parameter B = -1 is out of range: expected a finite number >= 0 (OP units)"
    );
}

#[test]
fn plugin_config_round_trips_through_typetag() {
    let m: Box<dyn stiction_models::StictionModel> =
        serde_json::from_str(r#"{"kind":"backlash","B":1.5}"#).expect("registered tag");
    assert_eq!(m.param_values(), vec![1.5]);
    let back = serde_json::to_string(&m).expect("serialize");
    assert_eq!(back, r#"{"kind":"backlash","B":1.5}"#);
}
