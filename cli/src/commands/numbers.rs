//! Value parsers of the numeric flags: each refuses NaN, infinities and values outside the
//! flag's range at parse time, so that clap names the flag and the run exits 2 (`--horizon
//! NaN` or `--min-fit 200` used to run and exit 0).

fn number(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{:?} is not a number", s.trim()))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{v}: expected a finite number"))
    }
}

/// Any finite number.
pub(crate) fn finite(s: &str) -> Result<f64, String> {
    number(s)
}

/// A finite number > 0.
pub(crate) fn positive(s: &str) -> Result<f64, String> {
    match number(s)? {
        v if v > 0.0 => Ok(v),
        v => Err(format!("{v}: expected a number above 0")),
    }
}

/// A finite number >= 0.
pub(crate) fn non_negative(s: &str) -> Result<f64, String> {
    match number(s)? {
        v if v >= 0.0 => Ok(v),
        v => Err(format!("{v}: expected a number of at least 0")),
    }
}

/// A fit in % (at most 100; a fit can be negative).
pub(crate) fn fit_percent(s: &str) -> Result<f64, String> {
    match number(s)? {
        v if v <= 100.0 => Ok(v),
        v => Err(format!("{v}: expected a fit in % of at most 100")),
    }
}

/// A count of at least 1.
pub(crate) fn count(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(0) => Err("0: expected at least 1".into()),
        Ok(v) => Ok(v),
        Err(_) => Err(format!(
            "{:?} is not a whole number of at least 1",
            s.trim()
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_and_out_of_range_values_are_refused() {
        for bad in ["NaN", "inf", "-inf", "1e400", "x", ""] {
            assert!(finite(bad).is_err(), "{bad}");
            assert!(positive(bad).is_err(), "{bad}");
            assert!(fit_percent(bad).is_err(), "{bad}");
        }
        assert!(positive("0").is_err());
        assert!(non_negative("-1").is_err());
        assert!(fit_percent("200").is_err());
        assert_eq!(fit_percent("-20"), Ok(-20.0));
        assert_eq!(count("3"), Ok(3));
        assert!(count("0").is_err());
    }
}
