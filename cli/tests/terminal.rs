//! The CLI at a real terminal: the README's main job and a long quantify run under a
//! pseudo-terminal (rexpect), where standard error is a terminal and the progress bar is drawn
//! from the search's worker threads. Locking standard error for the whole run made them hang
//! forever there (never seen with redirected output); these tests fail on that.
#![cfg(unix)]

use std::process::Command;

use rexpect::process::WaitStatus;
use rexpect::session::spawn_command;

/// Generous: the runs take a few seconds; a hang never ends.
const TIMEOUT_MS: u64 = 180_000;

/// Run the `stiction` binary with `args` at a pseudo-terminal; its whole output and exit code.
fn at_terminal(args: &[&str]) -> (String, i32) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_stiction"));
    cmd.args(args);
    let mut p = spawn_command(cmd, Some(TIMEOUT_MS)).expect("spawn under a pseudo-terminal");
    let out = match p.exp_eof() {
        Ok(out) => out,
        Err(e) => panic!(
            "`stiction {}` did not finish within {} s at a terminal: {e}",
            args.join(" "),
            TIMEOUT_MS / 1000
        ),
    };
    let code = match p.process().wait() {
        Ok(WaitStatus::Exited(_, code)) => code,
        other => panic!("`stiction {}` ended with {other:?}", args.join(" ")),
    };
    (out, code)
}

#[test]
fn readme_main_job_finishes_at_a_terminal() {
    let (out, code) = at_terminal(&["compare", "--example", "paper"]);
    assert_eq!(code, 0, "{out}");
    assert!(out.contains("kano       arx"), "{out}");
    assert!(out.contains("he         earmax"), "{out}");
}

#[test]
fn long_quantify_draws_and_clears_its_progress_bar() {
    let dir = std::env::temp_dir().join(format!("stiction-terminal-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let csv = dir.join("loop.csv");
    let csv = csv.to_str().expect("utf-8 path");
    let status = Command::new(env!("CARGO_BIN_EXE_stiction"))
        .args([
            "simulate", "--valve", "kano", "--param", "S=4", "--param", "J=1", "--seed", "2", "-o",
            csv,
        ])
        .output()
        .expect("simulate");
    assert!(status.status.success());
    // An exhaustive grid at a fine step: ~10^5 nodes, several seconds, so the bar appears.
    let (out, code) = at_terminal(&["quantify", csv, "--step", "0.02"]);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(code, 0, "{out}");
    assert!(out.contains("S = 4.00 %"), "{out}");
    // The bar was drawn ...
    let last_bar = out
        .rfind(" nodes, ")
        .unwrap_or_else(|| panic!("no progress bar drawn: {out:?}"));
    // ... and cleared before the result: the line is erased ("\r" + ESC[2K) after its last
    // drawing and before the result's first line.
    let result = out.find(": kano + arx").expect("result line");
    assert!(
        result > last_bar,
        "result printed before the bar's last drawing"
    );
    let between = &out[last_bar..result];
    assert!(
        between.contains("\x1b[2K"),
        "the bar was not cleared: {between:?}"
    );
}
