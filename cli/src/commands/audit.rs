//! `stiction audit`: the batch's rows appended to a results history in SQLite, each
//! registration once (`audit`).

use std::path::PathBuf;

use monitoring::batch::{Labels, DEFAULT_MIN_FIT};
use monitoring::registration::file_name;

use super::batch::{Combos, RunFlags};
use crate::{CmdResult, Streams};

/// Arguments of `stiction audit`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Directories or files of registrations (.csv, .tsv, .txt, .mat).
    #[arg(required = true, value_name = "PATH")]
    paths: Vec<PathBuf>,
    /// The SQLite database (created when missing; registrations already in it are skipped).
    #[arg(long, value_name = "FILE")]
    db: PathBuf,
    /// Only the registrations of this valve (file-name prefix before `_`).
    #[arg(long, value_name = "TAG")]
    valve: Option<String>,
    #[command(flatten)]
    combos: Combos,
    /// Labels (CSV `file,label`, label `stiction` / `no-stiction`) stored in each row.
    #[arg(long, value_name = "FILE")]
    labels: Option<PathBuf>,
    /// Minimum validation F_PV (%) below which the evidence says "poor fit".
    #[arg(long, value_name = "PCT", default_value_t = DEFAULT_MIN_FIT)]
    min_fit: f64,
    #[command(flatten)]
    run: RunFlags,
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    let opts = args.run.options(&args.combos, args.min_fit)?;
    let labels = args.labels.as_deref().map(Labels::read).transpose()?;
    let exclude: Vec<PathBuf> = (args.labels.iter().cloned())
        .chain(std::iter::once(args.db.clone()))
        .collect();
    let mut files = args.run.files(&args.paths, &exclude, s)?;
    if let Some(v) = &args.valve {
        files.retain(|f| datasets::parse_registration_name(&file_name(f)).valve == *v);
    }
    let bar = crate::progress::Progress::new(s.progress, "audit");
    let run = ::audit::run(&files, &opts, labels.as_ref(), &args.db, Some(&bar.tick()));
    bar.finish();
    let run = run?;
    s.text(format!("{}\n", run.summary(&args.db)))
}
