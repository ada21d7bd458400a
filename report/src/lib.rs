//! Pictures of a stiction run and the self-contained HTML report.
//!
//! * [`chart`]: line/point panels and a heat map on plotters, written as SVG (text measured
//!   with an embedded font, so the layout is the same on every machine) and rasterised to
//!   PNG by resvg when asked.
//! * [`figures`]: the paper's figures from our results: time trends of SP, PV, OP with the
//!   estimated PV and MV (Figs. 12-16), PV(OP) and MV(OP) phase plots with the fitted
//!   model's signature (Figs. 2, 3, 11, 18), the fit surface over (S, J) with the optimum and
//!   its region, the residuals of the baseline and extended models of a diagnosis with their
//!   spectrum and the estimated disturbance η̂, S over repeated registrations
//!   (Figs. 15, 19, 21), and the detection tests' PV-OP plot with the fitted ellipse and OP-PV
//!   cross-correlation (from `detection::figures`).
//! * [`html`]: one `index.html` per run with the numbers, the plots inline (no network, no
//!   script) and the summary, plus each plot as its own file.
//! * [`pages`]: the page of each command (`quantify`, `compare`, `diagnose`, `trend`,
//!   `detect`, a refused loop) from the typed results of `monitoring` and `discrepancy`.
//! * [`fleet`]: one page for a whole plant: every valve once, ranked by the repair benefit to
//!   expect (benefit × detector score), with sorting and filters in a small inline script.
//! * [`text`]: the plain-text output of each command.
//! * [`verdict`]: the sentences on an estimate that pages and text share.
//! * [`inspect`]: reads a figure's SVG back (title, panels, axis descriptions, legend, series)
//!   for structure snapshots and for checking that every plot says what it shows.
//!
//! Every figure's title names the loop and the model (the detection figures, which no model
//! made, say `detection tests`); every axis has its unit; every chart has a legend.

pub mod chart;
pub mod figures;
pub mod fleet;
pub mod html;
pub mod inspect;
pub mod pages;
pub mod text;
pub mod verdict;

pub use figures::{Figure, LoopSignals, TrendPoint, TrendStatus};
pub use html::{Block, Report, Section, WriteOptions, Written};

/// Whether this build writes PNG copies of the figures (the `png` feature).
pub const PNG: bool = cfg!(feature = "png");

/// Why `--png` cannot be honoured in a build without the `png` feature.
pub const NO_PNG: &str = "PNG output is not in this build: build the CLI with `cargo install --path cli --features png` (the SVG figures and the page need nothing more)";

/// What can go wrong while drawing or writing a report.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportError {
    /// plotters or resvg refused a figure.
    #[error("plot: {0}")]
    Plot(String),
    /// A file could not be written.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
}
