//! One module per subcommand, plus the argument helpers they share.

pub mod audit;
pub mod batch;
pub mod detect;
pub mod diagnose;
pub mod identify;
pub mod load;
pub mod models;
pub(crate) mod numbers;
pub mod quantify;
pub mod search_flags;
pub mod simulate;
pub mod trend;
pub mod valve;

use std::io::Write;
use std::path::Path;

use anyhow::{anyhow, Context};
use stiction_models::{Direction, InitialState};

use crate::{usage, CmdResult, Failure};

/// Parse `K=V` (for `--param`).
pub(crate) fn parse_param(s: &str) -> Result<(String, f64), String> {
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=VALUE (e.g. S=4), got {s:?}"))?;
    let k = k.trim();
    if k.is_empty() {
        return Err(format!("missing parameter name in {s:?}"));
    }
    let value: f64 = v
        .trim()
        .parse()
        .map_err(|_| format!("parameter {k}: {:?} is not a number", v.trim()))?;
    Ok((k.to_string(), value))
}

/// The initial valve state from the `--start`, `--us0`, `--mv0` flags.
pub(crate) fn initial_state(
    start: StartFlag,
    us0: Option<f64>,
    mv0: Option<f64>,
) -> Result<InitialState, Failure> {
    // The flags' names, not the library's fields (`stuck_at`, `position`).
    for (flag, v) in [("--us0", us0), ("--mv0", mv0)] {
        if let Some(v) = v.filter(|v| !v.is_finite()) {
            return Err(usage(anyhow!("{flag} {v}: expected a finite OP value")));
        }
    }
    let (direction, stuck) = match start {
        StartFlag::Down => (Direction::Down, true),
        StartFlag::Up => (Direction::Up, true),
        StartFlag::MovingDown => (Direction::Down, false),
        StartFlag::MovingUp => (Direction::Up, false),
    };
    let st = InitialState {
        direction,
        stuck,
        stuck_at: us0,
        position: mv0,
    };
    st.validate().map_err(usage)?;
    Ok(st)
}

/// The valve's state at the first sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum StartFlag {
    /// At rest after moving down (d0 = -1, stp0 = 1): the default.
    Down,
    /// At rest after moving up (d0 = +1, stp0 = 1).
    Up,
    /// Moving down (d0 = -1, stp0 = 0).
    MovingDown,
    /// Moving up (d0 = +1, stp0 = 0).
    MovingUp,
}

/// Parse `LO,HI` (for `--clip`).
pub(crate) fn parse_clip(s: &str) -> Result<(f64, f64), String> {
    let (a, b) =
        (s.split_once(',')).ok_or_else(|| format!("expected LO,HI (e.g. 0,100), got {s:?}"))?;
    let number = |t: &str| {
        t.trim()
            .parse()
            .map_err(|_| format!("{t:?} is not a number"))
    };
    let (lo, hi): (f64, f64) = (number(a)?, number(b)?);
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return Err(format!("expected finite LO < HI, got {lo},{hi}"));
    }
    Ok((lo, hi))
}

/// Open `path` for writing, or stdout for `None`/`-`.
pub(crate) fn with_output<F>(path: Option<&Path>, stdout: &mut dyn Write, f: F) -> CmdResult
where
    F: FnOnce(&mut dyn Write) -> anyhow::Result<()>,
{
    match path {
        Some(p) if p.as_os_str() != "-" => {
            let file = std::fs::File::create(p)
                .with_context(|| format!("cannot create {}", p.display()))?;
            let mut w = std::io::BufWriter::new(file);
            f(&mut w)?;
            Ok(w.flush()
                .with_context(|| format!("cannot write {}", p.display()))?)
        }
        _ => Ok(f(stdout)?),
    }
}
