//! Running the CLI in memory.
#![allow(dead_code)]

use stiction_cli::{run_from, Streams};

/// Exit status, stdout and stderr of one run.
pub struct Out {
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
}

/// Run `stiction ARGS` with `stdin`.
pub fn run(args: &[&str], stdin: &[u8]) -> Out {
    let mut input = stdin;
    let mut out = Vec::new();
    let mut err = Vec::new();
    let mut streams = Streams {
        stdin: &mut input,
        stdout: &mut out,
        stderr: &mut err,
        progress: false,
    };
    let mut all = vec!["stiction"];
    all.extend_from_slice(args);
    let code = run_from(all, &mut streams);
    Out {
        code,
        stdout: String::from_utf8_lossy(&out).into_owned(),
        stderr: String::from_utf8_lossy(&err).into_owned(),
    }
}

/// Run `stiction ARGS` with `stdin`, checked to exit 0 (its stderr the failure's message).
pub fn run_ok(args: &[&str], stdin: &[u8]) -> Out {
    let o = run(args, stdin);
    assert_eq!(o.code, 0, "{}", o.stderr);
    o
}

/// A fresh temporary directory `stiction-NAME-PID`.
pub fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("stiction-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// The rows of a JSONL file.
pub fn jsonl(path: &std::path::Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .expect("JSONL file")
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON row"))
        .collect()
}

/// The CSV of `stiction simulate` with a Kano valve S = 4, J = 1 (seed, samples), checked to
/// succeed.
pub fn simulate_kano_4_1(seed: &str, samples: &str) -> String {
    let args = [
        "simulate",
        "--valve",
        "kano",
        "--param",
        "S=4",
        "--param",
        "J=1",
        "--seed",
        seed,
        "--samples",
        samples,
    ];
    run_ok(&args, b"").stdout
}

/// The CSV of `stiction simulate` with a Kano valve S = 5, J = 2 behind a dead time of
/// `delay` samples, PI 0.3/0.2 (seed), checked to succeed.
pub fn simulate_dead_time(delay: &str, seed: &str) -> String {
    let args = [
        "simulate", "--param", "S=5", "--param", "J=2", "--delay", delay, "--kc", "0.3", "--ki",
        "0.2", "--seed", seed,
    ];
    run_ok(&args, b"").stdout
}

/// The column `name` of a CSV text, as numbers.
pub fn column(csv: &str, name: &str) -> Vec<f64> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let idx = header.iter().position(|h| *h == name).expect("column");
    lines
        .map(|l| {
            l.split(',')
                .nth(idx)
                .expect("cell")
                .parse()
                .expect("number")
        })
        .collect()
}

/// A historian export of 751 rows at 10 s whose stamps are written at a coarser resolution
/// than the sampling (every thirtieth stamp repeats the previous one and the next step, 20 s,
/// restores the grid), with PV frozen at 3.503246e-44 under a moving OP (40 ± 5 %): a stuck
/// valve or a frozen transmitter, which the data cannot tell apart.
pub fn frozen_pv_csv() -> String {
    let mut csv = String::from("t,SP,PV,OP,MODE\n");
    for k in 0..751usize {
        let t = if k.is_multiple_of(30) {
            10 * k
        } else {
            10 * (k + 1)
        };
        let op = 40.0 + 5.0 * (k as f64 / 40.0).sin() + ((k * 37) % 11) as f64 * 0.01;
        csv.push_str(&format!("{t},50,3.503246E-44,{op},1\n"));
    }
    csv
}
