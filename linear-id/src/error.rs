//! The error type of the crate.

/// Errors of the linear identifiers and of the fitted models. Every variant carries the
/// offending values.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum IdError {
    /// An order, horizon or tuning value is out of range.
    #[error("{identifier}: {name} = {value} is out of range: expected {expected}")]
    InvalidOrder {
        /// Registered identifier name.
        identifier: &'static str,
        /// Order / option name.
        name: String,
        /// The rejected value.
        value: f64,
        /// The valid range, in words.
        expected: String,
    },
    /// An order name the identifier does not have (registry builder).
    #[error("{identifier}: unknown order {name:?}; its orders are {known}")]
    UnknownOrder {
        /// Registered identifier name.
        identifier: &'static str,
        /// The unknown name.
        name: String,
        /// Comma-separated list of valid names.
        known: String,
    },
    /// An identifier name that is not registered.
    #[error("unknown linear identifier {name:?}; registered identifiers are {known}")]
    UnknownIdentifier {
        /// The unknown name.
        name: String,
        /// Comma-separated list of registered names.
        known: String,
    },
    /// Not enough samples for the orders / horizons.
    #[error("too few samples: {needed} needed for these orders, got {got}")]
    TooFewSamples {
        /// Minimum number of samples.
        needed: usize,
        /// Samples given.
        got: usize,
    },
    /// Input and output have different lengths.
    #[error("length mismatch: u has {u} samples, y has {y}")]
    LengthMismatch {
        /// Input length.
        u: usize,
        /// Output length.
        y: usize,
    },
    /// The input (or the output) is constant over the identification window: nothing to identify.
    #[error("{signal} is constant over the identification window (value {value})")]
    ConstantInput {
        /// `"u"` or `"y"`.
        signal: &'static str,
        /// The constant value.
        value: f64,
    },
    /// The regression is rank deficient (e.g. an input that is a linear combination of lags).
    #[error("{identifier}: singular regression ({detail})")]
    Singular {
        /// Registered identifier name.
        identifier: &'static str,
        /// What was singular and how (ratio of smallest to largest pivot, ...).
        detail: String,
    },
    /// An iterative algorithm (SVD, eigenvalues, recursive estimator) did not converge or
    /// diverged.
    #[error("{identifier}: {detail}")]
    NotConverged {
        /// Registered identifier name.
        identifier: &'static str,
        /// What did not converge.
        detail: String,
    },
    /// A sample is NaN or infinite (or an estimate became non-finite).
    #[error("{signal} sample {index} is not finite ({value})")]
    NonFinite {
        /// `"u"`, `"y"`, `"omega"` or `"estimate"`.
        signal: &'static str,
        /// Index of the first bad value.
        index: usize,
        /// The value.
        value: f64,
    },
    /// The identified model (or its one-step predictor) has a pole on or outside the unit
    /// circle.
    #[error("{identifier}: unstable {part} (largest pole modulus {max_modulus:.6})")]
    Unstable {
        /// Registered identifier name.
        identifier: &'static str,
        /// `"process"` (A(q) / A) or `"predictor"` (C(q) / A - K C).
        part: &'static str,
        /// Largest pole modulus.
        max_modulus: f64,
    },
}

/// Reject NaN / infinite samples, naming the first.
pub(crate) fn check_finite(signal: &'static str, x: &[f64]) -> Result<(), IdError> {
    if crate::la::all_finite(x) {
        return Ok(());
    }
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(IdError::NonFinite {
            signal,
            index,
            value: x[index],
        }),
        None => Ok(()),
    }
}

/// Common input checks: equal lengths, finite, enough samples, non-constant input.
pub(crate) fn check_data(u: &[f64], y: &[f64], needed: usize) -> Result<(), IdError> {
    if u.len() != y.len() {
        return Err(IdError::LengthMismatch {
            u: u.len(),
            y: y.len(),
        });
    }
    if u.len() < needed {
        return Err(IdError::TooFewSamples {
            needed,
            got: u.len(),
        });
    }
    check_finite("u", u)?;
    check_finite("y", y)?;
    if let Some(&u0) = u.first() {
        if u.iter().all(|&v| v == u0) {
            return Err(IdError::ConstantInput {
                signal: "u",
                value: u0,
            });
        }
    }
    if let Some(&y0) = y.first() {
        if y.iter().all(|&v| v == y0) {
            return Err(IdError::ConstantInput {
                signal: "y",
                value: y0,
            });
        }
    }
    Ok(())
}

/// Validate an order: `lo <= value <= hi`.
pub(crate) fn check_order(
    identifier: &'static str,
    name: &str,
    value: usize,
    lo: usize,
    hi: usize,
) -> Result<(), IdError> {
    if value < lo || value > hi {
        return Err(IdError::InvalidOrder {
            identifier,
            name: name.to_string(),
            value: value as f64,
            expected: format!("an integer in [{lo}, {hi}]"),
        });
    }
    Ok(())
}

/// Validate a real option: finite and `lo <= value <= hi` (`open_hi`: strictly below `hi`).
pub(crate) fn check_real(
    identifier: &'static str,
    name: &str,
    value: f64,
    lo: f64,
    hi: f64,
) -> Result<(), IdError> {
    if !(value.is_finite() && value >= lo && value <= hi) {
        return Err(IdError::InvalidOrder {
            identifier,
            name: name.to_string(),
            value,
            expected: format!("a finite number in [{lo}, {hi}]"),
        });
    }
    Ok(())
}
