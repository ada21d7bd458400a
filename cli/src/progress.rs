//! Progress bars (indicatif) on standard error, only on a terminal and for runs over a second.
//!
//! The bar is drawn from the search's worker threads, so standard error must not be locked by
//! the main thread for the whole run (see `crate::run`): that was a deadlock at a terminal.

use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A progress bar that appears only when enabled and once the run has lasted a second.
pub(crate) struct Progress {
    enabled: bool,
    label: String,
    unit: &'static str,
    started: Instant,
    bar: Mutex<Option<ProgressBar>>,
}

impl Progress {
    /// A bar over grid nodes whose one-second clock starts now.
    pub(crate) fn new(enabled: bool, label: &str) -> Self {
        Self::since(enabled, label, "nodes", Instant::now())
    }

    /// A bar counting `unit` whose one-second clock started at `started` (the command's start,
    /// so that a command made of several short steps still shows its progress).
    pub(crate) fn since(enabled: bool, label: &str, unit: &'static str, started: Instant) -> Self {
        Progress {
            enabled,
            label: label.to_string(),
            unit,
            started,
            bar: Mutex::new(None),
        }
    }

    /// Report `done` of `total` (called from worker threads).
    pub(crate) fn update(&self, done: usize, total: usize) {
        if !self.enabled || self.started.elapsed() < Duration::from_secs(1) {
            return;
        }
        let Ok(mut guard) = self.bar.lock() else {
            return;
        };
        let bar = guard.get_or_insert_with(|| {
            let template = format!(
                "{{msg}} [{{bar:30}}] {{pos}}/{{len}} {}, {{elapsed}} (eta {{eta}})",
                self.unit
            );
            let mut b =
                ProgressBar::with_draw_target(Some(total as u64), ProgressDrawTarget::stderr())
                    .with_elapsed(self.started.elapsed())
                    .with_position(done as u64)
                    .with_message(self.label.clone());
            if let Ok(style) = ProgressStyle::with_template(&template) {
                b = b.with_style(style.progress_chars("=> "));
            }
            b
        });
        if bar.length() != Some(total as u64) {
            bar.set_length(total as u64);
        }
        bar.set_position(done as u64);
    }

    /// [`Progress::update`] as the libraries' progress callback.
    pub(crate) fn tick(&self) -> impl Fn(usize, usize) + Sync + '_ {
        move |done, total| self.update(done, total)
    }

    /// Remove the bar.
    pub(crate) fn finish(&self) {
        if let Ok(mut guard) = self.bar.lock() {
            if let Some(b) = guard.take() {
                b.finish_and_clear();
            }
        }
    }
}
