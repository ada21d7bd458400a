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
    stages: Mutex<Stages>,
}

/// The stages of a count that restarts (a grid's coarse nodes, then its refinement): the bar
/// shows them end to end, so it never moves backwards.
#[derive(Debug, Default)]
struct Stages {
    /// Units of the stages before the current one.
    offset: usize,
    /// The current stage's total.
    total: usize,
    /// The last count reported.
    last: usize,
}

impl Stages {
    /// `(position, length)` of the bar for a report of `done` of `total`: a new stage when the
    /// total changes and the count restarts below the last one.
    fn place(&mut self, done: usize, total: usize) -> (usize, usize) {
        if total != self.total && done < self.last {
            self.offset += self.total;
            self.last = 0;
        }
        self.total = total;
        self.last = self.last.max(done);
        (self.offset + done, self.offset + total)
    }
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
            stages: Mutex::new(Stages::default()),
        }
    }

    /// Report `done` of `total` (called from worker threads).
    pub(crate) fn update(&self, done: usize, total: usize) {
        if !self.enabled {
            return;
        }
        let (done, total) = match self.stages.lock() {
            Ok(mut st) => st.place(done, total),
            Err(_) => (done, total),
        };
        if self.started.elapsed() < Duration::from_secs(1) {
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

#[cfg(test)]
mod tests {
    use super::Stages;

    #[test]
    fn a_restarting_count_never_moves_the_bar_backwards() {
        let mut st = Stages::default();
        assert_eq!(st.place(1, 800), (1, 800));
        assert_eq!(st.place(800, 800), (800, 800));
        // the refinement restarts its count: appended after the coarse grid
        assert_eq!(st.place(1, 300), (801, 1100));
        assert_eq!(st.place(300, 300), (1100, 1100));
        // a count whose total grows without restarting stays one stage
        let mut st = Stages::default();
        assert_eq!(st.place(3, 10), (3, 10));
        assert_eq!(st.place(4, 12), (4, 12));
    }
}
