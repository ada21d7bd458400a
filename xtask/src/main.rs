//! Project automation, run as `cargo xtask <task>` (alias in `.cargo/config.toml`).
//!
//! | task | what it runs |
//! |------|--------------|
//! | `test` | formatting check, clippy `-D warnings` and the tidy rules ([`tidy`]), the fast test suite of every crate, a one-minute fuzz run (what CI runs) |
//! | `tidy` | the tidy rules alone ([`tidy`]: the sources' rules, the crates' layer order from ARCHITECTURE.md, its size) |
//! | `proptest [--cases N]` | the property tests at scale (`PROPTEST_CASES=N`, default 10000) |
//! | `bench [ARGS...]` | the divan benchmarks of every crate (`cargo bench --workspace`) |
//! | `reproduce [--runs N] [--out DIR] [--only ...]` | the paper's §3 simulation study, the criterion study and the recovery rates ([`reproduce`]) |
//! | `suite [--size N]` | the hidden-effect suite of `diagnose` at full size (release build) |
//! | `fuzz [--minutes N]` | mutated plant and generated loop data through the reader and the search, in process, with a time and memory budget per case ([`fuzz`]) |
//! | `detect-calibrate [--train N] [--train-seed N] [--valid N] [--ridge L] [--plant DIR] [--no-plant] [--integrating auto|truth] [--paper] [--dump DIR] [--cases FILE]` | fit the detection score's coefficients on a simulated training population, measure them on validation populations never fitted on, then on the shared plant data as a test set ([`detect_calibrate`]) |
//! | `report-check [--out DIR] [--plant DIR] [--html FILE...]` | the CLI's HTML reports (`--report DIR`) opened in headless Chromium and checked, screenshots saved; the fleet page of a synthetic fleet written and driven (sort, filters, link) ([`browser`]) |

use std::process::Command;

use anyhow::{bail, Context, Result};

mod audit_bench;
mod browser;
mod detect_calibrate;
mod fuzz;
mod reproduce;
mod tidy;
mod unify;

/// Counts live memory for the fuzzer's per-case budget (a relaxed atomic add per allocation).
#[global_allocator]
static ALLOC: fuzz::Counting = fuzz::Counting;

const USAGE: &str = "\
usage: cargo xtask <task>

tasks:
  test                 formatting check + the fast test suite (what CI runs)
  tidy                 the tidy rules alone: only the CLI prints, no faer/nalgebra in public
                       signatures, error enums #[non_exhaustive], each Cargo.toml against
                       ARCHITECTURE.md's layer order, ARCHITECTURE.md at most 15 360 bytes
  proptest [--cases N] property tests at scale (default N = 10000)
  bench [ARGS...]      benchmarks (divan); ARGS go to the bench binaries, e.g. `cargo xtask bench kano`
  suite [--size N]     the hidden-effect suite of `diagnose` at full size (N loops per effect,
                       default 24; docs/DIAGNOSE.md)
  reproduce [--runs N] [--out DIR] [--only table1|table2|fig5|fig6|fig7|criterion|recovery]
                       the paper's simulation study (§3) next to the paper's numbers, CSVs in DIR
                       (default runs 10, out target/reproduce); `reproduce --help` for all options
  fuzz [--minutes N] [--seed N] [--case-seconds S] [--memory-mb M] [--no-plant]
                       mutate plant (../shared) and generated CSV/MAT loops, run the reader and the
                       search in process; a panic, abort, time-out or memory overrun is saved under
                       datasets/tests/fuzz-regressions (default 1 minute; `cargo xtask test` runs it)
  detect-calibrate [--train N] [--train-seed N] [--valid N] [--ridge L] [--plant DIR] [--no-plant] [--integrating auto|truth] [--paper] [--dump DIR] [--cases FILE]
                       fit the coefficients of `stiction detect`'s score on simulated loops and
                       ../shared/data/plant, validated leaving one valve out (docs/DETECTION.md)
  report-check [--out DIR] [--plant DIR] [--html FILE...]
                       build the CLI, write its HTML reports (--report) into DIR (default
                       target/report-check) and check them in headless Chromium (console errors,
                       broken images, empty plots), screenshots next to each page; also the
                       fleet page of a synthetic fleet, sorted and filtered in the browser; --plant also
                       diagnoses every CSV in DIR; `report-check --help` for details
  audit-bench [--files N] [--samples M] [--out DIR]
                       the plant audit at scale: N generated registrations of M samples (default
                       1000 x 3000) through `stiction audit --db --report`, timed as a whole
                       process (release), then the resume (must add nothing)

examples:
  cargo xtask test
  cargo xtask proptest --cases 50000
  cargo xtask bench
  cargo xtask suite --size 24
  cargo xtask reproduce --runs 10 --only table1,table2
  cargo xtask report-check --plant ../shared/data/plant";

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
        "tidy" => tidy_rules(),
        "proptest" => proptest(rest),
        "bench" => bench(rest),
        "reproduce" => reproduce_release(rest),
        "fuzz" => fuzz_release(rest),
        "suite" => suite(rest),
        "report-check" => browser::report_check(rest),
        "audit-bench" => in_release(
            "audit-bench",
            "XTASK_AUDIT_BENCH_NO_RELEASE",
            rest,
            audit_bench::audit_bench,
        ),
        "detect-calibrate" => in_release(
            "detect-calibrate",
            "XTASK_DETECT_NO_RELEASE",
            rest,
            detect_calibrate::detect_calibrate,
        ),
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

/// One line per phase on standard error, so a first run (which compiles the whole workspace
/// for several minutes on two cores) shows where it is.
fn phase(n: usize, of: usize, what: &str) {
    eprintln!("xtask test [{n}/{of}]: {what}");
}

fn test(rest: &[String]) -> Result<()> {
    let started = std::time::Instant::now();
    let fmt_available = cargo()
        .args(["fmt", "--version"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    phase(1, 5, "formatting check (cargo fmt --all --check)");
    if fmt_available {
        status(cargo().args(["fmt", "--all", "--check"]))?;
    } else {
        eprintln!("xtask: rustfmt is not installed; skipping the formatting check");
    }
    phase(
        2,
        5,
        "clippy on every target and the API docs, warnings are errors (the workspace lints, \
         rustdoc's links), and the tidy rules",
    );
    let clippy_available = cargo()
        .args(["clippy", "--version"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if clippy_available {
        status(cargo().args([
            "clippy",
            "--workspace",
            "--all-targets",
            "--",
            "-D",
            "warnings",
        ]))?;
    } else {
        eprintln!("xtask: clippy is not installed; skipping the lint check");
    }
    // The API docs: a link to an item that does not exist, or that a reader of the public
    // docs cannot see, is an error (the Python extension's crate needs libpython to build).
    status(
        cargo()
            .args([
                "doc",
                "--no-deps",
                "--workspace",
                "--exclude",
                "stiction-python",
            ])
            .env("RUSTDOCFLAGS", "-D warnings"),
    )?;
    tidy_rules()?;
    phase(
        3,
        5,
        "building the tests (the first build compiles every crate: several minutes on 2 cores)",
    );
    // The Python extension (a PyO3 cdylib) is built by maturin (`.ci/run`'s pip install) and
    // has no Rust tests; linked by `cargo test` it would want libpython.
    status(
        cargo()
            .args([
                "test",
                "--workspace",
                "--exclude",
                "stiction-python",
                "--no-run",
            ])
            .args(rest),
    )?;
    // The gate is deterministic: the property tests draw from a fixed seed here (an explicit
    // PROPTEST_RNG_SEED wins), so a run on a clean clone passes or fails the same way every
    // time; `cargo xtask proptest` explores with fresh random seeds and 10 000 cases a suite.
    let seed = std::env::var("PROPTEST_RNG_SEED").unwrap_or_else(|_| GATE_PROPTEST_SEED.into());
    phase(
        4,
        5,
        &format!("running the fast test suite (PROPTEST_RNG_SEED={seed})"),
    );
    status(
        cargo()
            .env("PROPTEST_RNG_SEED", &seed)
            .args(["test", "--workspace", "--exclude", "stiction-python"])
            .args(rest),
    )?;
    // The short fuzz run (about a minute; `cargo xtask fuzz --minutes N` for a long one). It
    // runs xtask built in the test profile (optimised, with overflow checks and debug
    // assertions), which reuses the crates the tests just compiled (the features are unified,
    // xtask/Cargo.toml); a release build would compile the workspace once more.
    phase(
        5,
        5,
        "a one-minute fuzz run (xtask in the test profile; `cargo xtask fuzz --minutes N` for more)",
    );
    in_profile(
        "test",
        "fuzz",
        "XTASK_FUZZ_NO_RELEASE",
        &["--minutes".to_string(), "1".to_string()],
        fuzz::fuzz,
    )?;
    eprintln!(
        "xtask test: all phases passed in {:.0} s (from xtask's start; building xtask itself, before it, is not counted)",
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The tidy rules of `src/tidy.rs` on the workspace: each broken one on a line of its own.
fn tidy_rules() -> Result<()> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let root = root.canonicalize().unwrap_or(root);
    let broken = tidy::check_workspace(&root)
        .context("reading the sources and manifests for the tidy rules")?;
    if !broken.is_empty() {
        for v in &broken {
            eprintln!("{v}");
        }
        bail!(
            "{} of ARCHITECTURE.md's rules broken (xtask/src/tidy.rs)",
            broken.len()
        );
    }
    unify::check(&root)
        .context("one build for the CLI, the Python extension, xtask and the tests")?;
    eprintln!("xtask tidy: the sources, the layer order and ARCHITECTURE.md's size keep the rules; the CLI, the Python extension, xtask and the tests share every compiled crate (report's png aside)");
    Ok(())
}

/// `fuzz` runs searches: like `reproduce`, re-run xtask in the release profile.
fn fuzz_release(rest: &[String]) -> Result<()> {
    in_release("fuzz", "XTASK_FUZZ_NO_RELEASE", rest, fuzz::fuzz)
}

/// Run `task` here when this xtask is a release build (or `no_release_env` is set),
/// otherwise re-run xtask itself in the release profile with that variable set: the
/// compute-bound tasks (their figures are release-build figures) would run with debug
/// assertions and overflow checks in `cargo xtask`'s build (the dev profile).
fn in_release(
    task: &str,
    no_release_env: &str,
    rest: &[String],
    run: fn(&[String]) -> Result<()>,
) -> Result<()> {
    if cfg!(debug_assertions) && std::env::var_os(no_release_env).is_none() {
        return in_profile("release", task, no_release_env, rest, run);
    }
    run(rest)
}

/// Run `task` in xtask built in the cargo `profile` (`release`, or `test`: optimised, with
/// debug assertions), unless `no_release_env` is set: then here (the re-run itself).
fn in_profile(
    profile: &str,
    task: &str,
    no_release_env: &str,
    rest: &[String],
    run: fn(&[String]) -> Result<()>,
) -> Result<()> {
    if std::env::var_os(no_release_env).is_some() {
        return run(rest);
    }
    status(
        cargo()
            .env(no_release_env, "1")
            .args([
                "run",
                "--quiet",
                "--profile",
                profile,
                "--package",
                "xtask",
                "--",
                task,
            ])
            .args(rest),
    )
}

/// The property tests' seed in `cargo xtask test` (see there).
const GATE_PROPTEST_SEED: &str = "20261123";

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
            .args([
                "test",
                "--workspace",
                "--exclude",
                "stiction-python",
                "--release",
            ])
            .args(&extra),
    )
}

fn bench(rest: &[String]) -> Result<()> {
    let mut cmd = cargo();
    cmd.args(["bench", "--workspace", "--exclude", "stiction-python"]);
    if !rest.is_empty() {
        cmd.arg("--").args(rest);
    }
    status(&mut cmd)
}

/// `reproduce` is compute-bound: run it in the release profile ([`in_release`]).
fn reproduce_release(rest: &[String]) -> Result<()> {
    in_release(
        "reproduce",
        "XTASK_REPRODUCE_NO_RELEASE",
        rest,
        reproduce::reproduce,
    )
}

/// `cargo xtask suite [--size N]`: the hidden-effect suite of `discrepancy` at full size
/// (N loops per effect and N clean loops, default 24, 3000 samples), release build.
fn suite(rest: &[String]) -> Result<()> {
    let size = match rest {
        [flag, n] if flag == "--size" => n.clone(),
        [] => "24".to_string(),
        _ => bail!("usage: cargo xtask suite [--size N]"),
    };
    status(
        cargo()
            .args([
                "test",
                "--release",
                "-p",
                "discrepancy",
                "--test",
                "hidden_effects",
                "--",
                "--nocapture",
            ])
            .env("STICTION_SUITE_SIZE", size)
            .env("STICTION_SUITE_SAMPLES", "3000"),
    )
}
