//! Reading a loop registration from `FILE` (or `-`) with the shared data flags.

use std::path::Path;

use anyhow::anyhow;
use datasets::{read_csv, GapPolicy, Limits, LoopData, OpRange, ReadOptions};

use crate::{read_all, Failure, Streams};

/// Column remaps and the gap policy, shared by every command that reads data.
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Data options (columns, gaps, controller mode)")]
pub struct DataFlags {
    /// Name of the PV column (default `PV`, case-insensitive).
    #[arg(long, value_name = "NAME")]
    pv: Option<String>,
    /// Name of the OP column (default `OP`).
    #[arg(long, value_name = "NAME")]
    op: Option<String>,
    /// Name of the SP column (default `SP`).
    #[arg(long, value_name = "NAME")]
    sp: Option<String>,
    /// Name of the measured valve-position column (default `MV`).
    #[arg(long, value_name = "NAME")]
    mv: Option<String>,
    /// Name of the time column (default `t` or `time`).
    #[arg(long, value_name = "NAME")]
    time: Option<String>,
    /// Fill empty/NaN cells: `hold` carries the last valid value forward.
    #[arg(long, value_name = "hold", value_parser = ["hold"], conflicts_with = "drop_gaps")]
    fill: Option<String>,
    /// Use the longest run of rows without empty/NaN cells.
    #[arg(long)]
    drop_gaps: bool,
    /// Name of the controller-mode column (default `MODE`): only the longest closed-loop
    /// segment is used (0 / MAN = manual; other numbers, AUTO, CAS = closed loop).
    #[arg(long, value_name = "NAME")]
    mode: Option<String>,
    /// `.mat` files: the loop to read in a struct-of-loops file, e.g. `cdata.chemicals.loop1`
    /// (needed when the file has several loops; the error lists them).
    #[arg(long = "loop", value_name = "PATH")]
    mat_loop: Option<String>,
    /// OP's valve span `LO,HI` in OP's units (closed, fully open), e.g. `0,1`, `0,16383`,
    /// `4,20`: OP is rescaled to % of it. Default: assumed from OP's range (0-1, 0-100,
    /// integer counts), with a note saying which.
    #[arg(long, value_name = "LO,HI", value_parser = OpRange::parse, allow_hyphen_values = true)]
    op_range: Option<OpRange>,
    /// Most data rows read from a file (a longer file is refused, not read for minutes).
    #[arg(long, value_name = "N", default_value_t = datasets::Limits::default().max_rows, value_parser = super::numbers::count)]
    max_rows: usize,
    /// Analyse at most the latest N rows of a longer record (a note says which rows): S, J and
    /// the verdict then describe the valve at the end of the record, and the time a command
    /// takes stays bounded. Give the record's length to analyse all of it.
    #[arg(long, value_name = "N", default_value_t = datasets::DEFAULT_WINDOW, value_parser = super::numbers::count)]
    window: usize,
}

impl DataFlags {
    /// The OP column's name (`OP` unless remapped).
    pub(crate) fn op_column(&self) -> &str {
        self.op.as_deref().unwrap_or("OP")
    }

    /// These flags with OP and PV read from the columns `op` and `pv` when given.
    pub(crate) fn with_columns(&self, op: Option<&String>, pv: Option<&String>) -> DataFlags {
        DataFlags {
            op: op.or(self.op.as_ref()).cloned(),
            pv: pv.or(self.pv.as_ref()).cloned(),
            ..self.clone()
        }
    }

    /// The reader's options for these flags.
    pub(crate) fn read_options(&self, require_pv: bool, min_rows: usize) -> ReadOptions {
        let gaps = match (&self.fill, self.drop_gaps) {
            (Some(_), _) => GapPolicy::FillHold,
            (None, true) => GapPolicy::DropGaps,
            (None, false) => GapPolicy::Refuse,
        };
        ReadOptions {
            pv: self.pv.clone(),
            op: self.op.clone(),
            sp: self.sp.clone(),
            mv: self.mv.clone(),
            time: self.time.clone(),
            require_pv,
            gaps,
            min_rows,
            mode: self.mode.clone(),
            mat_loop: self.mat_loop.clone(),
            limits: Limits {
                max_rows: self.max_rows,
                ..Limits::default()
            },
            op_range: self.op_range.unwrap_or_default(),
            accept_constant: false,
            window: self.window,
        }
    }
}

/// Read `file` (`-` = stdin) into loop data; notes about what was done go to stderr.
pub(crate) fn load(
    file: &Path,
    flags: &DataFlags,
    require_pv: bool,
    min_rows: usize,
    s: &mut Streams<'_>,
) -> Result<LoopData, Failure> {
    load_with(file, &flags.read_options(require_pv, min_rows), s)
}

/// [`load`] with the reader's options given.
pub(crate) fn load_with(
    file: &Path,
    opts: &ReadOptions,
    s: &mut Streams<'_>,
) -> Result<LoopData, Failure> {
    let opts = opts.clone();
    let d = if file.as_os_str() == "-" {
        let bytes = read_all(s.stdin).map_err(|e| anyhow!("-: cannot read standard input: {e}"))?;
        read_csv(bytes.as_slice(), "-", &opts)?
    } else {
        datasets::read_path(file, &opts)?
    };
    for note in &d.notes {
        let _ = writeln!(s.stderr, "note: {}: {note}", d.source);
    }
    Ok(d)
}
