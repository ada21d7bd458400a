//! `stiction batch`: many loops in parallel, one result row per loop and combination, failures in
//! their rows, resumable (`monitoring::batch`).

use std::path::PathBuf;

use monitoring::batch::{self, BatchOptions, Labels, DEFAULT_MIN_FIT};
use monitoring::kind::file_name;
use monitoring::registration::expand;
use stiction_models::find_model;

use super::load::DataFlags;
use super::search_flags::{KindFlags, SearchFlags};
use crate::{usage, CmdResult, Failure, Streams};

/// Arguments of `stiction batch`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Directories or files of registrations (.csv, .tsv, .txt, .mat).
    #[arg(required = true, value_name = "DIR")]
    paths: Vec<PathBuf>,
    /// Output prefix: writes OUT.jsonl and OUT.csv (resumable). Without it, a table on stdout.
    #[arg(short = 'o', long, value_name = "OUT")]
    out: Option<PathBuf>,
    #[command(flatten)]
    fleet: Fleet,
}

/// The registrations of a fleet run (`batch`, `audit`) and how each is read and searched.
#[derive(Debug, clap::Args)]
pub(crate) struct Fleet {
    /// Only the registrations of this valve (file-name prefix before `_`).
    #[arg(long, value_name = "TAG")]
    valve: Option<String>,
    #[command(flatten)]
    combos: Combos,
    /// Labels (CSV `file,label`, label `stiction` / `no-stiction`): `batch` reports the ROC
    /// AUC of S and of the detector's score, `audit` stores each in its row.
    #[arg(long, value_name = "FILE")]
    pub labels: Option<PathBuf>,
    /// Minimum validation F_PV (%) below which the evidence says "poor fit".
    #[arg(long, value_name = "PCT", default_value_t = DEFAULT_MIN_FIT, value_parser = super::numbers::fit_percent, allow_negative_numbers = true)]
    min_fit: f64,
    #[command(flatten)]
    pub run: RunFlags,
}

/// What a fleet run takes: its options, the labels and the registration files.
pub(crate) struct FleetRun {
    pub opts: BatchOptions,
    pub labels: Option<Labels>,
    pub files: Vec<PathBuf>,
}

impl Fleet {
    /// The options, the labels and the registration files among `paths` (of the valve asked
    /// for), leaving out the labels' file and `exclude` (the run's own outputs).
    pub(crate) fn take(
        &self,
        paths: &[PathBuf],
        exclude: &[PathBuf],
        s: &mut Streams<'_>,
    ) -> Result<FleetRun, Failure> {
        let opts = self.run.options(&self.combos, self.min_fit)?;
        let labels = self.labels.as_deref().map(Labels::read).transpose()?;
        let exclude: Vec<PathBuf> = self.labels.iter().chain(exclude).cloned().collect();
        let mut files = self.run.files(paths, &exclude, s)?;
        if let Some(v) = &self.valve {
            files.retain(|f| datasets::parse_registration_name(&file_name(f)).valve == *v);
        }
        Ok(FleetRun {
            opts,
            labels,
            files,
        })
    }
}

/// The combinations of a run: stiction models × linear identifiers (each command has its
/// defaults: [`Combos::or`]).
#[derive(Debug, clap::Args)]
pub(crate) struct Combos {
    /// Stiction models, comma-separated [default: kano; for compare kano,he].
    #[arg(long, value_name = "A,B", value_delimiter = ',')]
    pub stiction: Vec<String>,
    /// Linear identifiers, comma-separated [default: arx; for compare
    /// arx,armax,ss,earx,earmax].
    #[arg(long, value_name = "X,Y", value_delimiter = ',')]
    pub linear: Vec<String>,
}

/// The combinations of `batch`, `trend` and `audit` when none are named.
pub(crate) const FLEET_COMBOS: (&[&str], &[&str]) = (&["kano"], &["arx"]);

impl Combos {
    /// These combinations, `defaults` (stiction models, linear identifiers) for a flag not
    /// given.
    pub(crate) fn or(&self, (stiction, linear): (&[&str], &[&str])) -> Combos {
        let pick = |given: &[String], default: &[&str]| {
            if given.is_empty() {
                default.iter().map(ToString::to_string).collect()
            } else {
                given.to_vec()
            }
        };
        Combos {
            stiction: pick(&self.stiction, stiction),
            linear: pick(&self.linear, linear),
        }
    }
}

/// How every registration of a `batch` or `trend` run is read and searched.
#[derive(Debug, clap::Args)]
pub(crate) struct RunFlags {
    #[command(flatten)]
    kind: KindFlags,
    #[command(flatten)]
    search: SearchFlags,
    #[command(flatten)]
    pub data: DataFlags,
}

impl RunFlags {
    /// The search flags as the library's arguments (what `diagnose` takes).
    pub(crate) fn search_args(&self) -> run::SearchArgs {
        self.search.args()
    }

    /// The options of a run over `c` (a model name or a setting is bad usage).
    pub(crate) fn options(&self, c: &Combos, min_fit: f64) -> Result<BatchOptions, Failure> {
        let c = c.or(FLEET_COMBOS);
        for name in &c.stiction {
            find_model(name).map_err(usage)?;
        }
        Ok(BatchOptions {
            stiction: c.stiction.clone(),
            linear: c.linear.clone(),
            settings: self.search.settings(&c.linear)?,
            read: self.data.read_options(true, batch::MIN_ROWS),
            integrating: self.kind.integrating(),
            min_fit,
        })
    }

    /// The registration files among `paths` (`note: skipped` on stderr for the others).
    pub(crate) fn files(
        &self,
        paths: &[PathBuf],
        exclude: &[PathBuf],
        s: &mut Streams<'_>,
    ) -> Result<Vec<PathBuf>, Failure> {
        let (files, not_loops) = expand(paths, exclude, self.data.op_column()).map_err(usage)?;
        for n in &not_loops {
            let _ = writeln!(s.stderr, "note: skipped {}: {n}", n.path.display());
        }
        Ok(files)
    }
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    let out = args.out.as_deref().map(batch::out_paths);
    let outputs: Vec<PathBuf> = out
        .iter()
        .flat_map(|(jsonl, csv)| [jsonl.clone(), csv.clone()])
        .collect();
    let FleetRun {
        opts,
        labels,
        files,
    } = args.fleet.take(&args.paths, &outputs, s)?;
    if files.is_empty() {
        return Err(monitoring::MonitoringError::NoFiles.into());
    }
    let jsonl = out.as_ref().map(|(jsonl, _)| jsonl.as_path());
    let bar = crate::progress::Progress::new(s.progress, "batch");
    let run = batch::run(&files, &opts, labels.as_ref(), jsonl, Some(&bar.tick()));
    bar.finish();
    let run = run?;
    if let (Some(path), Some(note)) = (jsonl, run.torn_note()) {
        let _ = writeln!(s.stderr, "note: {}: {note}", path.display());
    }
    match &out {
        Some((_, csv)) => batch::write_csv(csv, &run.rows)?,
        None => s.text(report::text::batch_table(&run.rows))?,
    }
    let first = (&opts.stiction[0], &opts.linear[0]);
    let labelled = labels.map(|_| (first.0.as_str(), first.1.as_str()));
    s.text(report::text::batch_summary(
        files.len(),
        &run,
        jsonl,
        labelled,
    ))
}
