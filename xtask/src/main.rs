//! Project automation, run as `cargo xtask <task>` (alias in `.cargo/config.toml`).
//!
//! | task | what it runs |
//! |------|--------------|
//! | `test` | formatting check, then the fast test suite of every crate (what CI runs) |
//! | `proptest [--cases N]` | the property tests at scale (`PROPTEST_CASES=N`, default 10000) |
//! | `bench [ARGS...]` | the divan benchmarks of every crate (`cargo bench --workspace`) |

use std::process::Command;

use anyhow::{bail, Context, Result};

const USAGE: &str = "\
usage: cargo xtask <task>

tasks:
  test                 formatting check + the fast test suite (what CI runs)
  proptest [--cases N] property tests at scale (default N = 10000)
  bench [ARGS...]      benchmarks (divan); ARGS go to the bench binaries, e.g. `cargo xtask bench kano`

examples:
  cargo xtask test
  cargo xtask proptest --cases 50000
  cargo xtask bench";

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(task) = args.first() else {
        println!("{USAGE}");
        return Ok(());
    };
    let rest = &args[1..];
    match task.as_str() {
        "test" => test(rest),
        "proptest" => proptest(rest),
        "bench" => bench(rest),
        "help" | "--help" | "-h" => {
            println!("{USAGE}");
            Ok(())
        }
        other => bail!("unknown task {other:?}\n{USAGE}"),
    }
}

fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

fn status(cmd: &mut Command) -> Result<()> {
    eprintln!("xtask: running {cmd:?}");
    let st = cmd
        .status()
        .with_context(|| format!("could not start {cmd:?}"))?;
    if !st.success() {
        bail!("{cmd:?} failed ({st})");
    }
    Ok(())
}

fn test(rest: &[String]) -> Result<()> {
    let fmt_available = cargo()
        .args(["fmt", "--version"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if fmt_available {
        status(cargo().args(["fmt", "--all", "--check"]))?;
    } else {
        eprintln!("xtask: rustfmt is not installed; skipping the formatting check");
    }
    status(cargo().args(["test", "--workspace"]).args(rest))
}

fn proptest(rest: &[String]) -> Result<()> {
    let mut cases: u64 = 10_000;
    let mut extra = Vec::new();
    let mut it = rest.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--cases" => {
                let v = it.next().context("--cases needs a number")?;
                cases = v
                    .parse()
                    .with_context(|| format!("--cases {v:?} is not a whole number"))?;
            }
            _ => extra.push(a.clone()),
        }
    }
    status(
        cargo()
            .env("PROPTEST_CASES", cases.to_string())
            .args(["test", "--workspace", "--release"])
            .args(&extra),
    )
}

fn bench(rest: &[String]) -> Result<()> {
    let mut cmd = cargo();
    cmd.args(["bench", "--workspace"]);
    if !rest.is_empty() {
        cmd.arg("--").args(rest);
    }
    status(&mut cmd)
}
