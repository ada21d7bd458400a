//! The `stiction` command line: quantify control-valve stiction from logged loop data.
//!
//! The binary's `main` only calls [`run`](fn@run). A third party who adds stiction models in its own
//! crate builds its own binary with the same three lines plus `use my_models as _;`, so that
//! the linker keeps the crate and its `inventory` registrations (see
//! `examples/custom-model`). Tests call [`run_from`] with in-memory streams.
//!
//! This is the only crate that reads argv, prints, and uses `anyhow`. Exit status: 0 success;
//! 1 bad data or a failed computation; 2 bad usage (see the CLI contract).

use std::ffi::OsString;
use std::io::Read;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod commands;
mod io;
mod progress;
mod reporting;

pub use io::Streams;

/// Quantify control-valve stiction from the data the plant already logs (SP, PV, OP).
#[derive(Debug, Parser)]
#[command(
    name = "stiction",
    version,
    about = "Quantify control-valve stiction from logged loop data (SP, PV, OP)",
    long_about = "Quantify control-valve stiction from logged loop data (SP, PV, OP).\n\n\
        A stiction model (Kano, He, ...) turns the controller output OP into an estimated valve \
        position MV; a linear model maps MV to the process variable PV.",
    after_help = include_str!("../help/stiction.txt")
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// List the registered stiction models and linear identifiers with their parameters.
    #[command(after_help = include_str!("../help/models.txt"))]
    Models(commands::models::Args),
    /// Run a stiction model over the OP column of a CSV or MAT file; writes CSV `OP,MV`.
    #[command(after_help = include_str!("../help/valve.txt"))]
    Valve(commands::valve::Args),
    /// Identify a linear model from an input column (MV, or OP) to PV and print its fits.
    #[command(after_help = include_str!("../help/identify.txt"))]
    Identify(commands::identify::Args),
    /// Quantify stiction: grid search of a stiction model with a linear model (paper §2.3).
    #[command(after_help = include_str!("../help/quantify.txt"))]
    Quantify(commands::quantify::QuantifyArgs),
    /// Every stiction x linear combination on one loop, in one table (paper Tables 3-8).
    #[command(after_help = include_str!("../help/compare.txt"))]
    Compare(commands::quantify::CompareArgs),
    /// Simulate the paper's closed-loop benchmark (PI loop, sticky valve); writes CSV `t,SP,PV,OP,MV`.
    #[command(after_help = include_str!("../help/simulate.txt"))]
    Simulate(commands::simulate::Args),
    /// What the model gets wrong, its cause, the extended model and the gain (discrepancy).
    /// (long help: `commands::diagnose::help`, the cause table from the registry)
    Diagnose(commands::diagnose::Args),
    /// Follow one valve over repeated registrations: S trend, outliers explained, maintenance verdict.
    #[command(after_help = include_str!("../help/trend.txt"))]
    Trend(commands::trend::Args),
    /// Is it the valve? The published stiction detection tests and one calibrated verdict.
    #[command(after_help = include_str!("../help/detect.txt"))]
    Detect(commands::detect::Args),
    /// Quantify many loops in parallel: one row per loop (JSON lines and CSV), resumable.
    #[command(after_help = include_str!("../help/batch.txt"))]
    Batch(commands::batch::Args),
    /// Append the batch's rows to a results history in SQLite; registrations already there are skipped.
    #[command(after_help = include_str!("../help/audit.txt"))]
    Audit(commands::audit::Args),
}

/// A failure and its exit status: 1 bad data or a failed computation, 2 bad usage.
#[derive(Debug)]
pub(crate) struct Failure {
    error: anyhow::Error,
    usage: bool,
}

/// Any error with `?` is bad data (exit 1); bad usage is marked with [`usage`].
impl<E: Into<anyhow::Error>> From<E> for Failure {
    fn from(e: E) -> Self {
        Failure {
            error: e.into(),
            usage: false,
        }
    }
}

impl Failure {
    /// The error and its causes on one line (`run::error_line`).
    pub(crate) fn line(&self) -> String {
        run::error_line(self.error.as_ref())
    }
}

pub(crate) type CmdResult = Result<(), Failure>;

/// Shorthand: wrap any error as bad usage (exit 2).
pub(crate) fn usage<E: Into<anyhow::Error>>(e: E) -> Failure {
    Failure {
        error: e.into(),
        usage: true,
    }
}

/// Run with the process's arguments and standard streams; returns the exit status.
pub fn run() -> ExitCode {
    let stdin = std::io::stdin();
    let stdout = std::io::stdout();
    // Standard error is NOT locked for the whole run: the progress bar (indicatif) draws on it
    // from worker threads, and a lock held by the main thread while it waits for those
    // workers is a deadlock (the run hung at a terminal). Each write locks it briefly.
    let mut stderr = std::io::stderr();
    let mut streams = Streams {
        stdin: &mut stdin.lock(),
        stdout: &mut stdout.lock(),
        stderr: &mut stderr,
        progress: std::io::IsTerminal::is_terminal(&std::io::stderr()),
    };
    let code = run_from(std::env::args_os(), &mut streams);
    ExitCode::from(code as u8)
}

/// Parse the arguments (the first is the program name) as `run_from` does, without running.
pub fn parse<I, T>(args: I) -> Result<Cli, clap::Error>
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    // Negative numbers are values wherever a flag takes one (`--split -0.1` is a bad split,
    // not an unknown flag `-0`); no flag of ours is a digit.
    let command = <Cli as clap::CommandFactory>::command()
        .mut_subcommands(|c| c.allow_negative_numbers(true))
        .mut_subcommand("diagnose", |c| c.after_help(commands::diagnose::help()));
    let m = command.try_get_matches_from(args)?;
    // `--png` in a build without PNG support: refused before any work is done.
    let wants_png = m
        .subcommand()
        .and_then(|(_, sub)| sub.try_get_one::<bool>("png").ok().flatten().copied())
        .unwrap_or(false);
    if wants_png && !report::PNG {
        return Err(clap::Error::raw(
            clap::error::ErrorKind::ArgumentConflict,
            format!("--png: {}\n", report::NO_PNG),
        ));
    }
    <Cli as clap::FromArgMatches>::from_arg_matches(&m)
}

/// Run with explicit arguments (the first is the program name) and streams; returns the exit
/// status (0, 1 or 2). Never panics on user input.
pub fn run_from<I, T>(args: I, streams: &mut Streams<'_>) -> i32
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let cli = match parse(args) {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            let _ = write!(streams.stdout, "{}", e.render());
            return 0;
        }
        Err(e) => {
            // One line: clap's message up to its first blank line (the usage and the `--help`
            // hint follow it).
            let rendered = e.render().to_string();
            let head: Vec<&str> = rendered
                .lines()
                .take_while(|l| !l.trim().is_empty())
                .map(str::trim)
                .collect();
            let _ = writeln!(streams.stderr, "{} (see --help)", head.join(" "));
            return 2;
        }
    };
    let result = match cli.command {
        Command::Models(a) => commands::models::run(a, streams),
        Command::Valve(a) => commands::valve::run(a, streams),
        Command::Simulate(a) => commands::simulate::run(a, streams),
        Command::Identify(a) => commands::identify::run(a, streams),
        Command::Quantify(a) => commands::quantify::run_quantify(a, streams),
        Command::Compare(a) => commands::quantify::run_compare(a, streams),
        Command::Diagnose(a) => commands::diagnose::run(a, streams),
        Command::Trend(a) => commands::trend::run(a, streams),
        Command::Batch(a) => commands::batch::run(a, streams),
        Command::Audit(a) => commands::audit::run(a, streams),
        Command::Detect(a) => commands::detect::run(a, streams),
    };
    match result {
        Ok(()) => {
            let _ = streams.stdout.flush();
            0
        }
        Err(f) if is_broken_pipe(&f.error) => 0,
        Err(f) => {
            let usage = f.usage || is_usage_in_disguise(&f.error);
            let _ = streams.stdout.flush();
            let _ = writeln!(streams.stderr, "error: {}", f.line());
            1 + i32::from(usage)
        }
    }
}

/// A library error that is the user's choice of options (a grid over the node budget, an
/// option out of range): bad usage, exit 2, wherever it surfaced.
fn is_usage_in_disguise(e: &anyhow::Error) -> bool {
    use monitoring::MonitoringError::Run;
    use run::RunError::Search;
    e.chain().any(|c| {
        match (
            c.downcast_ref::<monitoring::MonitoringError>(),
            c.downcast_ref::<run::RunError>(),
        ) {
            (Some(Run(Search(e))), _) | (_, Some(Search(e))) => e.is_usage(),
            _ => {
                c.downcast_ref::<grid_search::SearchError>()
                    .is_some_and(|e| e.is_usage())
                    || matches!(
                        c.downcast_ref::<datasets::DataError>(),
                        Some(datasets::DataError::OpRange { .. })
                    )
            }
        }
    })
}

/// A closed stdout (`stiction ... | head`) ends the run quietly, as other Unix tools do.
fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        let io = c.downcast_ref::<std::io::Error>().or_else(|| {
            c.downcast_ref::<csv::Error>().and_then(|e| match e.kind() {
                csv::ErrorKind::Io(io) => Some(io),
                _ => None,
            })
        });
        io.is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// Read all of `r` (for `FILE` = `-`).
pub(crate) fn read_all(r: &mut dyn Read) -> std::io::Result<Vec<u8>> {
    let mut buf = Vec::new();
    r.read_to_end(&mut buf)?;
    Ok(buf)
}
