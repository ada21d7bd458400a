//! The search's summary statistics: the best node, its confidence interval over the surface,
//! the doubts about it, and the quantiles they need.

use super::*;

/// The largest of 1, 2, 5 × 10^k that is at most `x` (x > 0).
pub(crate) fn nice_step_at_most(x: f64) -> f64 {
    if !(x.is_finite() && x > 0.0) {
        return 1e-6;
    }
    let decade = 10f64.powf(x.log10().floor());
    [5.0, 2.0, 1.0]
        .iter()
        .map(|m| m * decade)
        .find(|v| *v <= x * (1.0 + 1e-12))
        .unwrap_or(decade)
}

/// χ² quantile for `p` degrees of freedom (1-4) at the usual levels; other levels fall back
/// to the Wilson–Hilferty approximation.
pub(crate) fn chi2_quantile(p: usize, level: f64) -> f64 {
    const TABLE: [(f64, [f64; 4]); 3] = [
        (0.90, [2.706, 4.605, 6.251, 7.779]),
        (0.95, [3.841, 5.991, 7.815, 9.488]),
        (0.99, [6.635, 9.210, 11.345, 13.277]),
    ];
    if (1..=4).contains(&p) {
        if let Some((_, q)) = TABLE.iter().find(|(l, _)| (l - level).abs() < 1e-9) {
            return q[p - 1];
        }
    }
    // Wilson–Hilferty with the normal quantile by Acklam-free bisection on erf-less logistic:
    // adequate for a guide interval.
    let z = normal_quantile(level);
    let k = p as f64;
    k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3)
}

pub(crate) fn normal_quantile(level: f64) -> f64 {
    // Bisection on the normal CDF computed from a series of erf.
    let cdf = |x: f64| 0.5 * (1.0 + erf(x / std::f64::consts::SQRT_2));
    let (mut lo, mut hi) = (-10.0, 10.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) < level {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

pub(crate) fn erf(x: f64) -> f64 {
    // Abramowitz & Stegun 7.1.26 (|error| < 1.5e-7).
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let y = 1.0
        - (((((1.061_405_429 * t - 1.453_152_027) * t) + 1.421_413_741) * t - 0.284_496_736) * t
            + 0.254_829_592)
            * t
            * (-x * x).exp();
    if x >= 0.0 {
        y
    } else {
        -y
    }
}
/// Number of direction reversals of `x` by more than `band` (a hysteresis count).
pub(crate) fn reversals(x: &[f64], band: f64) -> usize {
    let Some(&first) = x.first() else {
        return 0;
    };
    let (mut lo, mut hi) = (first, first);
    let mut dir = 0i8;
    let mut count = 0;
    for &v in x {
        lo = lo.min(v);
        hi = hi.max(v);
        if dir >= 0 && hi - v > band {
            if dir > 0 {
                count += 1;
            }
            dir = -1;
            lo = v;
        } else if dir <= 0 && v - lo > band {
            if dir < 0 {
                count += 1;
            }
            dir = 1;
            hi = v;
        }
    }
    count
}

pub(crate) fn doubts(
    nodes: &[NodeFit],
    interval: &Interval,
    fits: &Fits,
    span: f64,
    c: Criterion,
    skipped: usize,
) -> Vec<Doubt> {
    let mut w = Vec::new();
    let zero_in_region = nodes
        .iter()
        .any(|n| n.params.iter().all(|&v| v == 0.0) && n.score(c) >= interval.fit_threshold);
    if zero_in_region {
        w.push(Doubt::NoEvidence);
    }
    if interval.s[1] - interval.s[0] > 0.25 * span {
        w.push(Doubt::SPoorlyDetermined {
            lo: interval.s[0],
            hi: interval.s[1],
            span,
        });
    }
    if interval.s[1] > 0.0 && interval.s[1] >= trust::AT_SPAN * span {
        w.push(Doubt::SAtSpan {
            hi: interval.s[1],
            span,
        });
    }
    let j_width = interval.j[1] - interval.j[0];
    if j_width > 0.5 * interval.s[1].max(1e-12) && j_width > 0.5 {
        w.push(Doubt::JPoorlyDetermined {
            lo: interval.j[0],
            hi: interval.j[1],
        });
    }
    if fits.init_fell_back {
        w.push(Doubt::InitFellBack);
    }
    let (id, val) = fits.rank(c);
    if val < trust::WEAK_FIT {
        w.push(Doubt::WeakFit { val });
    }
    if (id - val).abs() > trust::FIT_DISAGREEMENT {
        w.push(Doubt::FitsDisagree { id, val });
    }
    if skipped as f64 > trust::MOSTLY_SKIPPED * nodes.len() as f64 {
        w.push(Doubt::MostlySkipped {
            skipped,
            total: nodes.len(),
        });
    }
    w
}

/// A node's parameters in thousandths of the fine step `fine`: distinct nodes of the fine
/// lattice differ by at least a thousand in some key, and a coarse node equal to a fine one up
/// to the round-off of `k · step` has its key.
pub(crate) fn node_key(p: &[f64], fine: f64) -> Vec<i64> {
    p.iter()
        .map(|x| (x / (fine * 1e-3)).round() as i64)
        .collect()
}

pub(crate) fn min_max(x: &[f64]) -> (f64, f64) {
    x.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        })
}

/// The best node: highest validation fit; ties within 1e-9 go to the earliest node in grid
/// order (smaller first parameter, then second, ...).
pub(crate) fn best_index(nodes: &[NodeFit], c: Criterion) -> Option<usize> {
    let max = nodes
        .iter()
        .map(|n| n.score(c))
        .filter(|f| f.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        return None;
    }
    nodes.iter().position(|n| n.score(c) >= max - 1e-9)
}

pub(crate) fn interval(
    nodes: &[NodeFit],
    best: usize,
    c: Criterion,
    pv: &[f64],
    split: usize,
    confidence: f64,
    p: usize,
) -> Interval {
    let val = &pv[split..];
    let n_val = val.len() as f64;
    let f_best = nodes[best].score(c);
    // F = 100 (1 - SSE/SST) on the validation window, so SSE ratios follow from F.
    let sse = |f: f64| (1.0 - f / 100.0).max(1e-300);
    let q = chi2_quantile(p, confidence);
    // n ln(SSE/SSE_best) <= q  <=>  SSE <= SSE_best exp(q/n)
    let sse_max = sse(f_best) * (q / n_val).exp();
    let threshold = 100.0 * (1.0 - sse_max);
    let mut s = [f64::INFINITY, f64::NEG_INFINITY];
    let mut j = [f64::INFINITY, f64::NEG_INFINITY];
    let mut count = 0;
    for nf in nodes {
        let f = nf.score(c);
        if f.is_finite() && f >= threshold {
            count += 1;
            s = [s[0].min(nf.s), s[1].max(nf.s)];
            j = [j[0].min(nf.j), j[1].max(nf.j)];
        }
    }
    Interval {
        s,
        j,
        nodes: count,
        fit_threshold: threshold,
        confidence,
    }
}
