//! A valve over repeated registrations: which registrations count, the level and trend of S,
//! and the maintenance verdict (the paper's §5.2 "repeated registrations").

use std::collections::BTreeMap;
use std::fmt;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use datasets::{format_epoch, LoopData};
use discrepancy::registration::{diagnose_all, diagnose_one};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::batch::BatchOptions;
use crate::detect::DetectionRecord;
use crate::kind::file_name;
use crate::registration::{evaluate, Evidence, FitEvidence, Plan, Registration, TimeSource};
use crate::stats::{median, theil_sen};
use crate::MonitoringError;
use detection::Verdict;
use run::QuantifyRecord;

/// How one registration counts in a trend.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Flag {
    /// Used for the level and the trend.
    #[serde(rename = "ok")]
    Used,
    /// Validation fit below the minimum: not used.
    Weak,
    /// Outside the band around the median S: not used.
    Outlier,
    /// Could not be read or quantified.
    Error,
    /// Read and judged by the detector (its verdict and reason), but with nothing to fit: a
    /// PV or OP constant, or flat over more than half of the record
    /// ([`Registration::unfit`]). Not used, and not an error.
    Inconclusive,
}

impl Flag {
    /// The label in tables and JSON (`ok`, `weak`, `outlier`, `error`).
    pub fn label(self) -> &'static str {
        match self {
            Flag::Used => "ok",
            Flag::Weak => "weak",
            Flag::Outlier => "outlier",
            Flag::Error => "error",
            Flag::Inconclusive => "inconclusive",
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
        // S is never negative: the band's lower end is at least 0 (no flag changes)
        band = Some([(m - half).max(0.0), m + half]);
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
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Maintenance {
    /// The level is at or above the threshold.
    #[serde(rename = "schedule maintenance")]
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

/// How many of a valve's latest usable registrations the detector's word is taken from
/// ([`with_detection`]).
pub const DETECT_WINDOW: usize = 3;

/// The maintenance verdict of [`maintenance`] with the detector's word on the valve's latest
/// usable registrations (`latest`: `(file, verdict)` of up to [`DETECT_WINDOW`] of them, in
/// time order): *schedule maintenance* stands only when the detector calls at least one of
/// them `stiction`. When it calls every one it can judge `no-stiction` (at least one), or can
/// judge none of them, the valve is only watched, and the reason says which. A level of S is
/// no maintenance call by itself: on simulated loops, a single record the detector leaves
/// `inconclusive` with a reported S at the threshold is a valve that sticks that much about
/// one time in three (`cargo run --release -p monitoring --example s_evidence`; docs/DETECTION.md).
/// Without any detector verdict (rows written before the detector ran) the call is S's alone,
/// as is every other verdict.
pub fn with_detection(
    verdict: Maintenance,
    reason: String,
    latest: &[(String, Verdict)],
) -> (Maintenance, String) {
    if verdict != Maintenance::Schedule
        || latest.is_empty()
        || latest.iter().any(|(_, v)| *v == Verdict::Stiction)
    {
        return (verdict, reason);
    }
    let conclusive: Vec<&str> = latest
        .iter()
        .filter(|(_, v)| *v != Verdict::Inconclusive)
        .map(|(f, _)| f.as_str())
        .collect();
    let plural = |n: usize| if n == 1 { "" } else { "s" };
    let why = if conclusive.is_empty() {
        let files: Vec<&str> = latest.iter().map(|(f, _)| f.as_str()).collect();
        format!(
            "{reason}, but the stiction detector cannot judge the latest usable registration{} \
             ({}: inconclusive): S alone is no maintenance call, watch",
            plural(files.len()),
            files.join(", ")
        )
    } else {
        let others = latest.len() - conclusive.len();
        format!(
            "{reason}, but the stiction detector finds no stiction in the latest usable \
             registration{} ({}{}): no maintenance call on S alone, watch",
            plural(conclusive.len()),
            conclusive.join(", "),
            match others {
                0 => String::new(),
                n => format!("; {n} more inconclusive"),
            }
        )
    };
    (Maintenance::Watch, why)
}

/// Default maintenance threshold on S, % of valve span (see `docs/PLANT_DATA.md`).
pub const DEFAULT_THRESHOLD: f64 = grid_search::MAINTENANCE_S;

/// Default horizon of the projection, days.
pub const DEFAULT_HORIZON: f64 = 90.0;

/// What a valve's trend computes: each registration as a batch computes it, then the trend.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TrendOptions {
    /// What each registration computes (combinations, settings, reader, integrating loops,
    /// the minimum validation F_PV for a registration to count).
    pub run: BatchOptions,
    /// Maintenance threshold on S, % of valve span.
    pub threshold: f64,
    /// How far ahead (days) the trend is projected for the `watch` verdict.
    pub horizon: f64,
}

impl Default for TrendOptions {
    fn default() -> Self {
        TrendOptions {
            run: BatchOptions::default(),
            threshold: DEFAULT_THRESHOLD,
            horizon: DEFAULT_HORIZON,
        }
    }
}

/// The trend of one combination, with its names.
#[derive(Debug, Clone, PartialEq)]
pub struct CombinationTrend {
    /// Stiction model.
    pub stiction: &'static str,
    /// Linear identifier.
    pub linear: &'static str,
    /// Its trend.
    pub trend: Trend,
}

/// One valve followed over its registrations: each registration's results, each
/// combination's trend and the maintenance verdict on their mean, with the detector's word
/// ([`with_detection`]).
#[derive(Debug)]
pub struct ValveTrend {
    /// The valve.
    pub valve: String,
    /// The options.
    pub options: TrendOptions,
    /// The registrations in time (unknown times last, by name).
    pub registrations: Vec<Registration>,
    /// One trend per combination.
    pub combinations: Vec<CombinationTrend>,
    /// Mean over the combinations of the level (median S of the usable registrations).
    pub level: Option<f64>,
    /// Mean of the latest usable S.
    pub latest: Option<f64>,
    /// Mean of the Theil–Sen slope, % per 30 days.
    pub slope_30d: Option<f64>,
    /// The verdict.
    pub verdict: Maintenance,
    /// Why, in one sentence.
    pub reason: String,
    /// What the registrations' diagnoses agree on, with the first combination as baseline
    /// (`None` without a diagnoser).
    pub causes: Option<run::Consensus>,
}

/// The registration files of `files` grouped by valve (file-name prefix before `_`).
pub fn by_valve(files: Vec<PathBuf>) -> BTreeMap<String, Vec<PathBuf>> {
    let mut out: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    for f in files {
        let valve = datasets::parse_registration_name(&file_name(&f)).valve;
        out.entry(valve).or_default().push(f);
    }
    out
}

/// The valve a trend follows and its files: `valve` when given (an error when it has no
/// registration), else the only valve among `files` (an error when there are none or
/// several).
pub fn select(
    files: Vec<PathBuf>,
    valve: Option<&str>,
) -> Result<(String, Vec<PathBuf>), MonitoringError> {
    let mut by_valve = by_valve(files);
    match valve {
        Some(v) => match by_valve.remove(v) {
            Some(f) => Ok((v.to_string(), f)),
            None => Err(MonitoringError::NoRegistration {
                valve: v.to_string(),
                found: by_valve.keys().cloned().collect(),
            }),
        },
        None if by_valve.len() == 1 => by_valve.pop_first().ok_or(MonitoringError::NoFiles),
        None if by_valve.is_empty() => Err(MonitoringError::NoFiles),
        None => Err(MonitoringError::SeveralValves(
            by_valve
                .iter()
                .map(|(k, v)| format!("{k} ({})", v.len()))
                .collect(),
        )),
    }
}

/// Follow `valve` over its registration `files`: search each one with every combination (in
/// parallel), order them in time, flag weak and outlying registrations, and give the verdict.
/// With `diagnose`, each weak or outlying registration's evidence starts with its diagnosis
/// (`discrepancy::registration`, on the record as searched), and the diagnoses of every
/// fitted registration give the causes they agree on. `progress` receives
/// `(registrations done, registrations)`.
pub fn follow(
    valve: &str,
    files: &[PathBuf],
    options: &TrendOptions,
    diagnose: bool,
    progress: Option<&(dyn Fn(usize, usize) + Sync)>,
) -> Result<ValveTrend, MonitoringError> {
    let run = &options.run;
    let combinations = run.combinations()?;
    let explainer = FitEvidence {
        min_fit: run.min_fit,
    };
    let plan = Plan {
        combinations: &combinations,
        read: &run.read,
        integrating: run.integrating,
        explainer: &explainer,
        keep_data: diagnose,
    };
    let done = AtomicUsize::new(0);
    let mut regs: Vec<Registration> = files
        .par_iter()
        .map(|f| {
            let r = evaluate(f, &plan);
            let k = done.fetch_add(1, Ordering::Relaxed) + 1;
            if let Some(p) = progress {
                p(k, files.len());
            }
            r
        })
        .collect();
    regs.sort_by(|a, b| match (a.start, b.start) {
        (Some(x), Some(y)) => x.total_cmp(&y).then_with(|| a.file.cmp(&b.file)),
        (Some(_), None) => std::cmp::Ordering::Less,
        (None, Some(_)) => std::cmp::Ordering::Greater,
        (None, None) => a.file.cmp(&b.file),
    });
    let trends: Vec<CombinationTrend> = combinations
        .iter()
        .enumerate()
        .map(|(c, comb)| {
            let points: Vec<Point> = regs
                .iter()
                .map(|r| Point {
                    start: r.start,
                    // the registration's one answer: the S that explains the detector's
                    // verdict (`Registration::reported`), not the one-step S alone
                    fit: r
                        .fit(c)
                        .zip(r.reported(c))
                        .map(|(f, rep)| (rep.s, f.fit_val)),
                })
                .collect();
            let mut trend = trend(&points, run.min_fit);
            // a record the detector judged but nothing could fit is no error
            for (flag, r) in trend.flags.iter_mut().zip(&regs) {
                if *flag == Flag::Error && r.unfit() {
                    *flag = Flag::Inconclusive;
                }
            }
            CombinationTrend {
                stiction: comb.stiction.name,
                linear: comb.linear.name,
                trend,
            }
        })
        .collect();
    let causes = if diagnose {
        diagnose_registrations(&mut regs, &trends, &combinations)
    } else {
        None
    };
    let mean_of = |f: &dyn Fn(&Trend) -> Option<f64>| {
        let v: Vec<f64> = trends.iter().filter_map(|t| f(&t.trend)).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let level = mean_of(&|t| t.level);
    let latest = mean_of(&|t| t.latest);
    let slope_30d = mean_of(&|t| t.slope_30d);
    let (verdict, reason) =
        maintenance(level, latest, slope_30d, options.threshold, options.horizon);
    let (verdict, reason) = with_detection(verdict, reason, &latest_detections(&regs, &trends));
    let (verdict, reason) = in_units(verdict, reason, &regs, &trends);
    Ok(ValveTrend {
        valve: valve.to_string(),
        options: options.clone(),
        registrations: regs,
        combinations: trends,
        level,
        latest,
        slope_30d,
        verdict,
        reason,
        causes,
    })
}

/// Every registration with a fit of the first combination diagnosed once: its sentence serves
/// that combination's doubtful registrations, and the diagnoses give the causes the valve's
/// registrations agree on (returned). The other combinations' doubtful registrations are
/// diagnosed with their own combination. The records kept for this are dropped.
fn diagnose_registrations(
    regs: &mut [Registration],
    trends: &[CombinationTrend],
    combinations: &[run::Combination],
) -> Option<run::Consensus> {
    let mut causes = None;
    let fitted: Vec<usize> = (0..regs.len())
        .filter(|&k| !combinations.is_empty() && regs[k].fit(0).is_some() && regs[k].data.is_some())
        .collect();
    let mut first: Vec<Option<String>> = vec![None; regs.len()];
    if !fitted.is_empty() {
        let refs: Vec<&Registration> = fitted.iter().map(|&k| &regs[k]).collect();
        let labels: Vec<String> = refs
            .iter()
            .map(|r| r.start.map(format_epoch).unwrap_or_else(|| r.file.clone()))
            .collect();
        let records: Vec<&LoopData> = refs.iter().filter_map(|r| r.data.as_ref()).collect();
        let (sentences, consensus) = diagnose_all(&records, &labels, &combinations[0]);
        for (&k, sentence) in fitted.iter().zip(sentences) {
            first[k] = Some(sentence.unwrap_or_else(|e| format!("diagnosis failed: {e}")));
        }
        causes = Some(consensus);
    }
    let jobs: Vec<(usize, usize)> = trends
        .iter()
        .enumerate()
        .flat_map(|(c, t)| {
            t.trend
                .flags
                .iter()
                .enumerate()
                .filter(|(_, f)| **f != Flag::Used)
                .map(move |(k, _)| (k, c))
        })
        .filter(|&(k, c)| regs[k].fit(c).is_some())
        .collect();
    let found: Vec<((usize, usize), String)> = jobs
        .par_iter()
        .map(|&(k, c)| {
            let why = match (c, &first[k]) {
                (0, Some(sentence)) => sentence.clone(),
                _ => regs[k]
                    .data
                    .as_ref()
                    .map_or(Err("the record was not kept".to_string()), |d| {
                        diagnose_one(d, &combinations[c])
                    })
                    .unwrap_or_else(|e| format!("diagnosis failed: {e}")),
            };
            ((k, c), why)
        })
        .collect();
    for ((k, c), why) in found {
        if let Ok(combos) = &mut regs[k].outcome {
            if let Some(Ok(f)) = combos.get_mut(c).map(|o| &mut o.result) {
                f.evidence.insert(0, Evidence::Diagnosis(why));
            }
        }
    }
    for r in regs.iter_mut() {
        r.data = None;
    }
    causes
}

/// Whether the registration's S is in % of the OP range it shows (OP's valve span unknown:
/// `datasets::units::span_unknown`) rather than in % of valve span.
pub fn span_unknown(r: &Registration) -> bool {
    datasets::units::span_unknown(&r.notes)
}

/// The verdict `verdict` (with its `reason`) kept when every usable registration's S is in %
/// of valve span; else `undetermined`: a usable registration whose OP's valve span is unknown
/// has S in % of the OP range that record shows, a unit no threshold in % of valve span
/// applies to and that differs between registrations whose OP ranges differ, so neither the
/// level nor the trend can be judged against the threshold.
pub fn in_units(
    verdict: Maintenance,
    reason: String,
    regs: &[Registration],
    trends: &[CombinationTrend],
) -> (Maintenance, String) {
    let used: Vec<&Registration> = usable(regs, trends).collect();
    let unknown = used.iter().filter(|r| span_unknown(r)).count();
    if unknown == 0 {
        return (verdict, reason);
    }
    (
        Maintenance::Undetermined,
        format!(
            "OP's valve span is unknown in {unknown} of the {} usable registration(s): their S is \
             in % of the OP range each record shows, which no threshold in % of valve span applies \
             to and which compares across registrations only where their OP ranges match; give \
             OP's span (--op-range LO,HI) to judge the valve",
            used.len()
        ),
    )
}

/// `(file, detector verdict)` of the latest [`DETECT_WINDOW`] usable registrations (used in
/// the trend of at least one combination), in time order.
fn latest_detections(regs: &[Registration], trends: &[CombinationTrend]) -> Vec<(String, Verdict)> {
    let usable: Vec<(String, Verdict)> = usable(regs, trends)
        .filter_map(|r| Some((r.file.clone(), r.detect_verdict()?)))
        .collect();
    usable[usable.len().saturating_sub(DETECT_WINDOW)..].to_vec()
}

/// The usable registrations: those used in the trend of at least one combination, in order.
fn usable<'a>(
    regs: &'a [Registration],
    trends: &'a [CombinationTrend],
) -> impl Iterator<Item = &'a Registration> {
    regs.iter().enumerate().filter_map(move |(k, r)| {
        trends
            .iter()
            .any(|t| t.trend.flags.get(k) == Some(&Flag::Used))
            .then_some(r)
    })
}

impl Registration {
    /// The S registration reports for combination `c` (`None` without a fit): the S that
    /// explains the detector's verdict on it ([`crate::answer::reported`]), as `quantify`
    /// reports it for the record.
    pub fn reported(&self, c: usize) -> Option<crate::answer::Reported> {
        let f = self.fit(c)?;
        let one_step = crate::answer::Estimate {
            s: f.s,
            range: f.s_range,
        };
        Some(crate::answer::reported(
            one_step,
            self.detection.as_ref(),
            datasets::units::span_unknown(&self.notes),
        ))
    }

    /// Why combination `c`'s repair estimate (simulated with its one-step valve) does not go
    /// with the registration's answer ([`crate::answer::repair_refusal`]); `None` when it does,
    /// without a fit, or without the detector's verdict.
    pub fn repair_refusal(&self, c: usize) -> Option<repair::NoRepair> {
        let f = self.fit(c)?;
        crate::answer::repair_refusal(
            self.detect_verdict()?,
            crate::answer::Estimate {
                s: f.s,
                range: f.s_range,
            },
            datasets::units::span_unknown(&self.notes),
        )
    }
}

/// One registration in a combination's trend (`trend --json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RegistrationRecord {
    /// Base name of the file.
    pub file: String,
    /// Registration time, `YYYY-MM-DD HH:MM` UTC.
    pub time: Option<String>,
    /// Where the time came from.
    pub time_source: TimeSource,
    /// How it counts.
    pub flag: Flag,
    /// Identified from MV to ΔPV.
    pub integrating: bool,
    /// What the reader did, in words.
    pub notes: Vec<String>,
    /// Why there is no estimate.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// S reported: the S that explains the detector's verdict ([`Registration::reported`]),
    /// rounded to the grid.
    #[serde(rename = "S", skip_serializing_if = "Option::is_none")]
    pub s: Option<f64>,
    /// Its range: the hull of both fits' 95 % regions.
    #[serde(rename = "S_range", skip_serializing_if = "Option::is_none")]
    pub s_range: Option<[f64; 2]>,
    /// Which fit S comes from: `one-step` (the combination's) or `output-error` (the
    /// detector's).
    #[serde(rename = "S_from", skip_serializing_if = "Option::is_none")]
    pub s_from: Option<crate::answer::SFrom>,
    /// The unit of S: `% of valve span`, or `% of the OP range seen` when OP's valve span is
    /// unknown (absent without a fit).
    #[serde(rename = "S_unit", skip_serializing_if = "Option::is_none")]
    pub s_unit: Option<&'static str>,
    /// The combination's one-step-prediction S, rounded to the grid.
    #[serde(rename = "S_one_step", skip_serializing_if = "Option::is_none")]
    pub s_one_step: Option<f64>,
    /// Its 95 % likelihood-ratio region.
    #[serde(rename = "S_one_step_range", skip_serializing_if = "Option::is_none")]
    pub s_one_step_range: Option<[f64; 2]>,
    /// J.
    #[serde(rename = "J", skip_serializing_if = "Option::is_none")]
    pub j: Option<f64>,
    /// Range of J.
    #[serde(rename = "J_range", skip_serializing_if = "Option::is_none")]
    pub j_range: Option<[f64; 2]>,
    /// Validation F_PV, %.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fit_pv_val: Option<f64>,
    /// The evidence behind a doubtful estimate, in words.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub why: Option<Vec<String>>,
    /// The contract's quantify object.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub quantify: Option<QuantifyRecord>,
    /// The detector's verdict on the registration (absent when the file could not be read).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub detection: Option<DetectionRecord>,
}

/// One combination's trend (`trend --json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CombinationRecord {
    /// Stiction model.
    pub stiction_model: &'static str,
    /// Linear identifier.
    pub linear_model: &'static str,
    /// Median S of the usable registrations.
    pub level: Option<f64>,
    /// Theil–Sen slope, % per 30 days.
    pub slope_per_30_days: Option<f64>,
    /// Latest usable S.
    pub latest: Option<f64>,
    /// The outlier band of S.
    pub outlier_band: Option<[f64; 2]>,
    /// Every registration.
    pub registrations: Vec<RegistrationRecord>,
}

/// The document of `trend --json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrendRecord {
    /// The valve.
    pub valve: String,
    /// Number of registrations.
    pub registrations: usize,
    /// Maintenance threshold, %.
    pub threshold: f64,
    /// Minimum validation fit, %.
    pub min_fit: f64,
    /// Projection horizon, days.
    pub horizon_days: f64,
    /// Mean level.
    pub level: Option<f64>,
    /// Mean latest usable S.
    pub latest: Option<f64>,
    /// Mean slope, % per 30 days.
    pub slope_per_30_days: Option<f64>,
    /// The verdict.
    pub verdict: Maintenance,
    /// Why.
    pub reason: String,
    /// The rule, in words.
    pub rule: String,
    /// Each combination.
    pub combinations: Vec<CombinationRecord>,
    /// What the registrations' diagnoses agree on (first combination as baseline; `null`
    /// without diagnoses).
    pub causes: Option<run::Consensus>,
}

impl ValveTrend {
    /// The rule of the verdict, in words.
    pub fn rule(&self) -> String {
        format!(
            "schedule maintenance when the level (median S of the usable registrations, mean over \
             combinations) >= {t} %; watch when it is below but the latest usable S or the \
             {h}-day projection of the Theil-Sen trend reaches {t} %, or the level >= {half} %; \
             healthy otherwise; no maintenance call (watch instead) unless the stiction detector \
             calls at least one of the latest usable registrations (up to {w}) stiction; \
             undetermined when a usable registration's OP has no known valve span (its S \
             is in % of the OP range seen)",
            t = self.options.threshold,
            h = self.options.horizon,
            half = self.options.threshold / 2.0,
            w = DETECT_WINDOW
        )
    }

    /// The document of `trend --json`.
    pub fn record(&self) -> TrendRecord {
        let combinations = self
            .combinations
            .iter()
            .enumerate()
            .map(|(c, t)| CombinationRecord {
                stiction_model: t.stiction,
                linear_model: t.linear,
                level: t.trend.level,
                slope_per_30_days: t.trend.slope_30d,
                latest: t.trend.latest,
                outlier_band: t.trend.band,
                registrations: self
                    .registrations
                    .iter()
                    .zip(&t.trend.flags)
                    .map(|(r, flag)| {
                        let fit = r.fit(c);
                        let rep = r.reported(c);
                        let g = |x: f64| fit.map_or(x, |f| run::on_grid(x, f.step));
                        RegistrationRecord {
                            file: r.file.clone(),
                            time: r.start.map(format_epoch),
                            time_source: r.time_source,
                            flag: *flag,
                            integrating: r.integrating,
                            notes: r.notes.iter().map(|n| n.text.clone()).collect(),
                            error: r.error(c).map(ToString::to_string),
                            s: rep.map(|p| g(p.s)),
                            s_range: rep.map(|p| p.range.map(g)),
                            s_from: rep.map(|p| p.from),
                            s_unit: rep.map(|_| {
                                if span_unknown(r) {
                                    crate::answer::RANGE_UNIT
                                } else {
                                    crate::answer::SPAN_UNIT
                                }
                            }),
                            s_one_step: fit.map(|f| g(f.s)),
                            s_one_step_range: fit.map(|f| f.s_range.map(g)),
                            j: fit.map(|f| g(f.j)),
                            j_range: fit.map(|f| f.j_range.map(g)),
                            fit_pv_val: fit.map(|f| f.fit_val),
                            why: fit.map(|f| f.evidence.iter().map(ToString::to_string).collect()),
                            quantify: fit.map(|f| f.record.clone()),
                            detection: r.detection.as_ref().map(|d| d.record()),
                        }
                    })
                    .collect(),
            })
            .collect();
        TrendRecord {
            valve: self.valve.clone(),
            registrations: self.registrations.len(),
            threshold: self.options.threshold,
            min_fit: self.options.run.min_fit,
            horizon_days: self.options.horizon,
            level: self.level,
            latest: self.latest,
            slope_per_30_days: self.slope_30d,
            verdict: self.verdict,
            reason: self.reason.clone(),
            rule: self.rule(),
            combinations,
            causes: self.causes.clone(),
        }
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
    fn a_maintenance_call_needs_the_detector_to_find_stiction() {
        let (schedule, why) = maintenance(Some(1.2), Some(1.2), None, 1.0, 90.0);
        assert_eq!(schedule, Maintenance::Schedule);
        let regs = |v: &[Verdict]| -> Vec<(String, Verdict)> {
            v.iter()
                .enumerate()
                .map(|(k, v)| (format!("V_{k}.csv"), *v))
                .collect()
        };
        use Verdict::{Inconclusive as I, NoStiction as N, Stiction as S};
        let (m, reason) = with_detection(schedule, why.clone(), &regs(&[N, I, N]));
        assert_eq!(m, Maintenance::Watch);
        assert!(reason.starts_with(&why), "{reason}");
        assert!(reason.contains("detector finds no stiction"), "{reason}");
        assert!(
            reason.contains("V_0.csv, V_2.csv; 1 more inconclusive"),
            "{reason}"
        );
        // A sticky or a mixed record keeps the call, and so does a valve without any
        // detector verdict.
        for v in [&[S][..], &[N, S], &[I, S, I], &[]] {
            assert_eq!(
                with_detection(schedule, why.clone(), &regs(v)),
                (schedule, why.clone()),
                "{v:?}"
            );
        }
        // Records the detector cannot judge make no call on S alone.
        let (m, reason) = with_detection(schedule, why.clone(), &regs(&[I, I]));
        assert_eq!(m, Maintenance::Watch);
        assert!(reason.starts_with(&why), "{reason}");
        assert!(
            reason.contains("cannot judge the latest usable registrations (V_0.csv, V_1.csv"),
            "{reason}"
        );
        // Every other verdict is kept as it is.
        let (watch, w) = maintenance(Some(0.6), Some(0.6), Some(0.0), 1.0, 90.0);
        assert_eq!(
            with_detection(watch, w.clone(), &regs(&[S])),
            (watch, w.clone())
        );
        assert_eq!(with_detection(watch, w.clone(), &regs(&[N])), (watch, w));
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
