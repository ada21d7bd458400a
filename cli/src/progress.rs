//! Progress bars (indicatif) on standard error, only on a terminal and for runs over a second.

use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

/// A progress bar that appears only when enabled and after the run has lasted a second.
pub(crate) struct Progress {
    enabled: bool,
    label: String,
    started: Instant,
    bar: Mutex<Option<ProgressBar>>,
}

impl Progress {
    pub(crate) fn new(enabled: bool, label: &str) -> Self {
        Progress {
            enabled,
            label: label.to_string(),
            started: Instant::now(),
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
            let b = ProgressBar::new(total as u64);
            if let Ok(style) = ProgressStyle::with_template(
                "{msg} [{bar:30}] {pos}/{len} nodes, {elapsed} (eta {eta})",
            ) {
                b.set_style(style.progress_chars("=> "));
            }
            b.set_message(self.label.clone());
            b
        });
        if bar.length() != Some(total as u64) {
            bar.set_length(total as u64);
        }
        bar.set_position(done as u64);
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
