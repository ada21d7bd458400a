//! A valve over repeated registrations: which registrations count, the level and trend of S,
//! and the maintenance verdict (the paper's §5.2 "repeated registrations").

use std::fmt;

use crate::stats::{median, theil_sen};

/// How one registration counts in a trend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flag {
    /// Used for the level and the trend.
    Used,
    /// Validation fit below the minimum: not used.
    Weak,
    /// Outside the band around the median S: not used.
    Outlier,
    /// Could not be read or quantified.
    Error,
}

impl Flag {
    /// The label in tables and JSON (`ok`, `weak`, `outlier`, `error`).
    pub fn label(self) -> &'static str {
        match self {
            Flag::Used => "ok",
            Flag::Weak => "weak",
            Flag::Outlier => "outlier",
            Flag::Error => "error",
        }
    }
}

impl fmt::Display for Flag {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.label())
    }
}

/// One registration as the trend sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Start time, seconds since the Unix epoch (when known).
    pub start: Option<f64>,
    /// `(S, validation F_PV)` of the combination, `None` when it failed.
    pub fit: Option<(f64, f64)>,
}

/// The trend of one combination over the registrations of one valve.
#[derive(Debug, Clone, PartialEq)]
pub struct Trend {
    /// Each registration's flag, in the registrations' order.
    pub flags: Vec<Flag>,
    /// Median S of the used registrations.
    pub level: Option<f64>,
    /// Theil–Sen slope of S over time, % per 30 days (dated used registrations).
    pub slope_30d: Option<f64>,
    /// S of the last used registration.
    pub latest: Option<f64>,
    /// The outlier band `[lo, hi]` of S (with at least four usable registrations).
    pub band: Option<[f64; 2]>,
}

/// Smallest half-width of the outlier band, % of valve span.
pub const MIN_BAND: f64 = 0.1;

/// The trend of `points` (in time order): registrations with a validation fit below
/// `min_fit` are weak; with at least four usable ones, those outside median ±
/// max(3 · 1.4826 · MAD, [`MIN_BAND`]) are outliers; the level is the median S of the rest and
/// the slope their Theil–Sen line.
pub fn trend(points: &[Point], min_fit: f64) -> Trend {
    let mut flags: Vec<Flag> = points
        .iter()
        .map(|p| match p.fit {
            None => Flag::Error,
            Some((_, fit)) if fit < min_fit => Flag::Weak,
            Some(_) => Flag::Used,
        })
        .collect();
    let s_of = |i: usize| points[i].fit.map_or(f64::NAN, |f| f.0);
    let usable: Vec<usize> = (0..points.len())
        .filter(|&i| flags[i] == Flag::Used)
        .collect();
    let mut band = None;
    if usable.len() >= 4 {
        let s: Vec<f64> = usable.iter().map(|&i| s_of(i)).collect();
        let m = median(&s);
        let mad = median(&s.iter().map(|x| (x - m).abs()).collect::<Vec<_>>());
        let half = (3.0 * 1.4826 * mad).max(MIN_BAND);
        band = Some([m - half, m + half]);
        for &i in &usable {
            if (s_of(i) - m).abs() > half {
                flags[i] = Flag::Outlier;
            }
        }
    }
    let kept: Vec<usize> = (0..points.len())
        .filter(|&i| flags[i] == Flag::Used)
        .collect();
    let s: Vec<f64> = kept.iter().map(|&i| s_of(i)).collect();
    let dated: Vec<(f64, f64)> = kept
        .iter()
        .filter_map(|&i| points[i].start.map(|t| (t / 86400.0, s_of(i))))
        .collect();
    Trend {
        flags,
        level: (!s.is_empty()).then(|| median(&s)),
        slope_30d: theil_sen(&dated).map(|v| 30.0 * v),
        latest: kept.last().map(|&i| s_of(i)),
        band,
    }
}

/// What to do with a valve.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Maintenance {
    /// The level is at or above the threshold.
    Schedule,
    /// Below the threshold, but the latest S, the projection or the level says look again.
    Watch,
    /// Well below the threshold.
    Healthy,
    /// No registration is usable.
    Undetermined,
}

impl Maintenance {
    /// The label in text and JSON.
    pub fn label(self) -> &'static str {
        match self {
            Maintenance::Schedule => "schedule maintenance",
            Maintenance::Watch => "watch",
            Maintenance::Healthy => "healthy",
            Maintenance::Undetermined => "undetermined",
        }
    }
}

impl fmt::Display for Maintenance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.label())
    }
}

/// The maintenance verdict on a level of S (with the latest used S and the 30-day slope) and
/// the sentence that justifies it: schedule when the level reaches `threshold`; watch when the
/// latest S or the `horizon`-day projection reaches it, or the level is at least half of it;
/// healthy otherwise.
pub fn maintenance(
    level: Option<f64>,
    latest: Option<f64>,
    slope_30d: Option<f64>,
    threshold: f64,
    horizon: f64,
) -> (Maintenance, String) {
    let Some(level) = level else {
        return (
            Maintenance::Undetermined,
            "no registration is usable (all failed, weak or outliers)".into(),
        );
    };
    let projected = level + slope_30d.unwrap_or(0.0) * horizon / 30.0;
    if level >= threshold {
        (
            Maintenance::Schedule,
            format!(
                "the stiction level S = {level:.2} % is at or above the threshold {threshold} %"
            ),
        )
    } else if latest.is_some_and(|l| l >= threshold) {
        (
            Maintenance::Watch,
            format!(
                "level S = {level:.2} % is below the threshold {threshold} %, but the latest usable registration reaches {:.2} %",
                latest.unwrap_or(f64::NAN)
            ),
        )
    } else if projected >= threshold {
        (
            Maintenance::Watch,
            format!(
                "level S = {level:.2} % is below the threshold {threshold} %, but the trend reaches {projected:.2} % within {horizon} days"
            ),
        )
    } else if level >= 0.5 * threshold {
        (
            Maintenance::Watch,
            format!("level S = {level:.2} % is at least half the threshold {threshold} %"),
        )
    } else {
        (
            Maintenance::Healthy,
            format!(
                "level S = {level:.2} % is below half the threshold {threshold} %, and neither the latest usable S nor the {horizon}-day projection {projected:.2} % reaches the threshold"
            ),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verdicts() {
        let v = |l, la, sl| maintenance(l, la, sl, 1.0, 90.0).0;
        assert_eq!(v(Some(1.2), None, None), Maintenance::Schedule);
        assert_eq!(v(Some(0.2), Some(1.1), None), Maintenance::Watch);
        assert_eq!(v(Some(0.2), Some(0.2), Some(0.3)), Maintenance::Watch);
        assert_eq!(v(Some(0.6), Some(0.6), Some(0.0)), Maintenance::Watch);
        assert_eq!(v(Some(0.2), Some(0.2), Some(0.0)), Maintenance::Healthy);
        assert_eq!(v(None, None, None), Maintenance::Undetermined);
    }

    #[test]
    fn weak_and_outlying_registrations_are_left_out() {
        let day = 86400.0;
        let mut pts: Vec<Point> = (0..6)
            .map(|k| Point {
                start: Some(k as f64 * 30.0 * day),
                fit: Some((2.0 + 0.01 * k as f64, 90.0)),
            })
            .collect();
        pts[2].fit = Some((5.0, 90.0));
        pts[4].fit = Some((2.0, 20.0));
        pts.push(Point {
            start: None,
            fit: None,
        });
        let t = trend(&pts, 50.0);
        assert_eq!(t.flags[2], Flag::Outlier);
        assert_eq!(t.flags[4], Flag::Weak);
        assert_eq!(t.flags[6], Flag::Error);
        assert_eq!(t.flags.iter().filter(|f| **f == Flag::Used).count(), 4);
        let level = t.level.unwrap_or(f64::NAN);
        assert!((level - 2.02).abs() < 1e-9, "{level}");
        let slope = t.slope_30d.unwrap_or(f64::NAN);
        assert!((slope - 0.01).abs() < 1e-9, "{slope}");
    }
}
