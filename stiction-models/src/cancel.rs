//! A process-wide request to stop long computations early: the Python binding sets it when
//! the interpreter reports Ctrl-C, and the grid search (between nodes and after each stage)
//! and the detector's model fits (between stiction bands) check it and return early with an
//! error or an empty answer, which the caller discards. Checking is one relaxed atomic load.
//!
//! It is one flag for the process: a request stops every computation running at that moment
//! (Ctrl-C interrupts the whole interpreter anyway). The caller that set it clears it once its
//! computation has returned.

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Ask running computations to stop.
pub fn request() {
    REQUESTED.store(true, Ordering::Relaxed);
}

/// Withdraw the request (before a new computation, after a cancelled one returned).
pub fn clear() {
    REQUESTED.store(false, Ordering::Relaxed);
}

/// Whether a stop was asked for.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::Relaxed)
}
