#![allow(clippy::unwrap_used)]

use super::*;
use crate::LinearIdentifier;

/// The shared valve-like record with output noise 0.3.
fn data(len: usize, seed: u64) -> (Vec<f64>, Vec<f64>) {
    crate::test_data::valve_loop(len, seed, 0.3)
}

#[test]
fn gram_fit_matches_the_qr() {
    for seed in [1, 2, 3] {
        let (u, y) = data(3000, seed);
        for (n, m, delay) in [(2, 2, 0), (1, 3, 2), (4, 1, 0), (3, 3, 5)] {
            let arx = Arx::params().n(n).m(m).delay(delay).check().unwrap();
            let sums = arx.output_sums(&y).unwrap();
            for (from, to) in [(0, 2000), (137, 2000), (900, 1500)] {
                let qr = arx.identify(&u[from..to], &y[from..to]).unwrap();
                let gram = sums.identify_window(&u, from, to).unwrap();
                let (
                    Structure::Polynomial { a: a1, b: b1, .. },
                    Structure::Polynomial { a: a2, b: b2, .. },
                ) = (qr.structure(), gram.structure())
                else {
                    panic!()
                };
                let big = a1.iter().chain(b1).fold(0.0f64, |m, v| m.max(v.abs()));
                for (p, q) in a1.iter().chain(b1).zip(a2.iter().chain(b2)) {
                    assert!((p - q).abs() <= 1e-9 * big, "{n} {m} {delay}: {p} vs {q}");
                }
                let (m1, m2) = (qr.means(), gram.means());
                assert!(
                    (m1.0 - m2.0).abs() < 1e-9 * m1.0.abs().max(1.0),
                    "{m1:?} {m2:?}"
                );
                assert!(
                    (m1.1 - m2.1).abs() < 1e-9 * m1.1.abs().max(1.0),
                    "{m1:?} {m2:?}"
                );
                let (f1, f2) = (qr.info().fit_pv, gram.info().fit_pv);
                assert!((f1 - f2).abs() < 1e-9 * f1.abs(), "{f1} vs {f2}");
            }
        }
    }
}

#[test]
fn poorly_conditioned_windows_fall_back() {
    let (u, y) = data(600, 4);
    let arx = Arx::params().n(2).m(2).check().unwrap();
    let sums = arx.output_sums(&y).unwrap();
    // a ramp: u(t-1) and u(t-2) collinear after centering, up to a 1e-6 wiggle
    let v: Vec<f64> = (0..u.len())
        .map(|k| k as f64 + 1e-6 * (k as f64).sin())
        .collect();
    assert!(sums.identify_window(&v, 0, 600).is_none());
    assert!(sums.identify_window(&u, 0, 600).is_some());
    // Centering::Mean is not handled from sums
    let mean = Arx::params().centering(Centering::Mean).check().unwrap();
    assert!(mean.output_sums(&y).is_none());
}

/// The identification SSE from the residual pass and the refinement step equals the sum
/// of squared one-step residuals of the returned model, computed directly, also on
/// noise-free data (where `y'y - θ'X'y` would be round-off).
#[test]
fn the_sse_is_the_direct_one() {
    for noise in [0.3, 0.0] {
        let (u, y) = crate::test_data::valve_loop(3000, 5, noise);
        for (n, m, delay) in [(2, 2, 0), (1, 3, 2), (4, 1, 0), (3, 3, 5)] {
            let arx = Arx::params().n(n).m(m).delay(delay).check().unwrap();
            let sums = arx.output_sums(&y).unwrap();
            let (from, to) = (137, 2000);
            let fit = sums.identify_window(&u, from, to).unwrap();
            let (uw, yw) = (&u[from..to], &y[from..to]);
            let pred = fit.predict_one_step(uw, yw).unwrap();
            let n0 = fit.info().first_sample;
            let direct: f64 = yw[n0..]
                .iter()
                .zip(&pred[n0..])
                .map(|(a, b)| (a - b) * (a - b))
                .sum();
            let rss = fit.info().residual_variance * (yw.len() - n0) as f64;
            // relative to the residual, or to the output's variation where the residual
            // is round-off (the exact orders on noise-free data)
            let mean = yw[n0..].iter().sum::<f64>() / (yw.len() - n0) as f64;
            let y_ss: f64 = yw[n0..].iter().map(|v| (v - mean) * (v - mean)).sum();
            assert!(
                (rss - direct).abs() <= 1e-10 * direct + 1e-15 * y_ss,
                "{noise} {n} {m} {delay}: {rss} vs {direct}"
            );
            let fit_direct = crate::fit_pv(&yw[n0..], &pred[n0..]);
            assert!(
                (fit.info().fit_pv - fit_direct).abs() <= 1e-10,
                "{} vs {fit_direct}",
                fit.info().fit_pv
            );
        }
    }
}

/// Where the factor alone gives the RSS (a well-conditioned matrix, a residual not small
/// against the output) the fit is the refined one's to round-off: coefficients within 1e-10
/// of the largest, the RSS within 1e-12 of the output's sum of squares. A residual that is
/// round-off (the exact orders on noise-free data) takes the pass.
#[test]
fn the_factor_sse_is_the_refined_one() {
    let coefficients = |f: &LinearFit| match f.structure() {
        Structure::Polynomial { a, b, .. } => a.iter().chain(b).copied().collect::<Vec<_>>(),
        _ => panic!("ARX"),
    };
    let mut from_factor = 0;
    for (noise, seed) in [(3.0, 7), (1.0, 8), (0.0, 9)] {
        let (u, y) = crate::test_data::valve_loop(3000, seed, noise);
        for (n, m, delay) in [(2, 2, 0), (1, 3, 2), (4, 1, 0), (3, 3, 5)] {
            let arx = Arx::params().n(n).m(m).delay(delay).check().unwrap();
            let sums = arx.output_sums(&y).unwrap();
            for (from, to) in [(0, 2000), (137, 2000), (900, 1500)] {
                let stats = WindowStats::of(&u[from..to]).unwrap();
                let (fast, refined) = match (
                    sums.identify(&u, from, to, &stats, false),
                    sums.identify(&u, from, to, &stats, true),
                ) {
                    (Some(f), Some((r, _))) => (f, r),
                    // a poorly conditioned window goes to the QR either way
                    (None, None) => continue,
                    (f, r) => panic!("{n} {m} {delay}: {f:?} / {r:?}"),
                };
                let (fast, passed) = fast;
                from_factor += usize::from(!passed);
                let (c1, c2) = (coefficients(&fast), coefficients(&refined));
                let big = c2.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                for (p, q) in c1.iter().zip(&c2) {
                    assert!((p - q).abs() <= 1e-10 * big, "{n} {m} {delay}: {p} vs {q}");
                }
                let rows = (to - from - fast.info().first_sample) as f64;
                let (r1, r2) = (
                    fast.info().residual_variance * rows,
                    refined.info().residual_variance * rows,
                );
                let yw = &y[from + fast.info().first_sample..to];
                let mean = yw.iter().sum::<f64>() / rows;
                let y_ss: f64 = yw.iter().map(|v| (v - mean) * (v - mean)).sum();
                assert!(
                    (r1 - r2).abs() <= 1e-12 * y_ss,
                    "{n} {m} {delay}: {r1} vs {r2}"
                );
                if r2 < 1e-6 * y_ss {
                    // a residual that is round-off (the exact orders on noise-free data)
                    assert!(
                        passed,
                        "{n} {m} {delay}: a round-off residual takes the pass"
                    );
                }
            }
        }
    }
    assert!(
        from_factor >= 8,
        "the factor gave the RSS in {from_factor} of 36 windows"
    );
}

/// The fused passes: the AVX register and the plain array give the same bits, and both
/// equal one dot product per product (the path of the larger orders) to round-off.
#[test]
fn passes_give_the_same_bits_everywhere() {
    let (u, y) = data(1003, 6);
    for n in 0..=3 {
        for m in 1..=3 {
            for delay in [0, 2] {
                let arx = Arx::params().n(n).m(m).delay(delay).check().unwrap();
                let sums = arx.output_sums(&y).unwrap();
                let rows = (17 + n.max(m + delay), 1003 - 2);
                let u_mean = 49.5;
                let lags = || LagPass {
                    sums: &sums,
                    u: &u,
                    u_mean,
                    rows,
                };
                let native = Arch::new().dispatch(Dispatch(lags()));
                let portable = lags().run(Portable);
                let dots = sums.lag_products(&u, u_mean, rows);
                let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(1.0);
                assert!(close(native.u, dots.u));
                assert_eq!(native.u.to_bits(), portable.u.to_bits());
                for (p, q, r) in [
                    (&native.yu[..], &portable.yu[..], &dots.yu[..]),
                    (&native.y0u[..], &portable.y0u[..], &dots.y0u[..]),
                    (&native.uu[..], &portable.uu[..], &dots.uu[..]),
                ] {
                    for k in 0..p.len() {
                        assert_eq!(p[k].to_bits(), q[k].to_bits(), "{n} {m} {delay}");
                        assert!(close(p[k], r[k]), "{n} {m} {delay}: {} vs {}", p[k], r[k]);
                    }
                }
                let mut x = [0.0; MAX_COLS];
                for (k, v) in x.iter_mut().take(n + m).enumerate() {
                    *v = 0.3 - 0.2 * k as f64;
                }
                let res = || ResidualPass {
                    lags: lags(),
                    x: &x,
                    c: 0.7,
                };
                let native = Arch::new().dispatch(Dispatch(res()));
                let portable = res().run(Portable);
                let dots = sums.residual_products(&u, u_mean, rows, &x, 0.7);
                let all = |p: &ResidualProducts| {
                    let mut v = vec![p.sum, p.sq];
                    v.extend_from_slice(&p.cols[..n + m]);
                    v
                };
                for ((p, q), r) in all(&native).iter().zip(all(&portable)).zip(all(&dots)) {
                    assert_eq!(p.to_bits(), q.to_bits(), "{n} {m} {delay}");
                    assert!(
                        (p - r).abs() <= 1e-11 * p.abs().max(1.0),
                        "{n} {m} {delay}: {p} vs {r}"
                    );
                }
            }
        }
    }
}

/// ARX(2, 2)'s one-step SSE: the AVX registers, the plain arrays and a per-row loop of eight
/// scalar lanes give the same bits, at every length's tail.
#[test]
fn arx22_sse_is_the_scalar_lanes_bit_for_bit() {
    // errors spread over six decades, so that any other order of the additions shows
    let mut state = 3u64;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut wide = || (next() - 0.5) * 10f64.powf(6.0 * next());
    let u: Vec<f64> = (0..1003).map(|_| wide()).collect();
    let y: Vec<f64> = (0..1003).map(|_| wide()).collect();
    let coeffs = [-1.3, 0.42, 0.051, 0.037];
    let (kconst, ym) = (0.31, 49.7);
    for len in (0..40).chain([997, 1000]) {
        let (lo, hi) = (3, 3 + len);
        let cols = |delay: usize| {
            (
                [&y[lo..hi], &y[lo - 1..hi - 1], &y[lo - 2..hi - 2]],
                [
                    &u[lo - delay - 1..hi - delay - 1],
                    &u[lo - delay - 2..hi - delay - 2],
                ],
            )
        };
        let (ys, us) = cols(1);
        let [a1, a2, b1, b2] = coeffs;
        let row = |t: usize| {
            let mut v = kconst;
            v -= a1 * ys[1][t];
            v -= a2 * ys[2][t];
            v += b1 * us[0][t];
            v += b2 * us[1][t];
            let e = (v + ym) - ys[0][t];
            e * e
        };
        let mut acc = [0.0; 8];
        let full = len / 8 * 8;
        for t in 0..full {
            acc[t % 8] += row(t);
        }
        let mut reference =
            ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]));
        for t in full..len {
            reference += row(t);
        }
        let native = arx22_one_step_sse(coeffs, kconst, ym, ys, us);
        let portable = Sse22Pass {
            coeffs,
            kconst,
            ym,
            cols: [ys[0], ys[1], ys[2], us[0], us[1]],
        }
        .run(Portable);
        assert_eq!(native.to_bits(), reference.to_bits(), "{len}");
        assert_eq!(portable.to_bits(), reference.to_bits(), "{len}");
    }
}
