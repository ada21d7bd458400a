//! `stiction models`: what is registered.

use crate::{CmdResult, Streams};

/// Arguments of `stiction models`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    if args.json {
        return s.json(&run::models_record());
    }
    s.text(report::text::models())
}
