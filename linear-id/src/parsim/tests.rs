#![allow(clippy::unwrap_used)]

use super::*;

#[test]
fn self_products_are_the_general_ones_bit_for_bit() {
    let (u, _) = crate::test_data::valve_loop(300, 5, 0.3);
    for (k, ncol) in [(1, 10), (4, 200), (20, 281)] {
        let general = shifted_products(&u, k, &u, k, ncol);
        let own = shifted_self_products(&u, k, ncol);
        let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&general), bits(&own), "k {k}, ncol {ncol}");
    }
}

#[test]
fn identify_predict_many_equals_one_call_each() {
    for n in [1, 3, 6] {
        for order in [2, 3] {
            let ss = ParsimK::params().n(order).check().unwrap();
            crate::test_data::identify_predict_many_matches(&ss, n);
        }
    }
}

#[test]
fn fast_route_matches_the_reference() {
    let (mut from_gram, mut from_cholesky) = (0, 0);
    // noisy records take the Gram path and the Cholesky factor of W²; the noise-free one
    // falls back to the QR
    for (seed, noise) in [(1, 3.0), (2, 2.0), (3, 4.0), (4, 1e-6)] {
        let (u, y) = crate::test_data::valve_loop(2000, seed, noise);
        for (n, f, p) in [(2, 10, 10), (2, 5, 8), (0, 6, 6)] {
            let ss = ParsimK::params().n(n).f(f).p(p).check().unwrap();
            let mut qr = ss.run(&u, &y, Route::Reference).unwrap();
            let mut auto = ss.run(&u, &y, Route::Fast).unwrap();
            qr.refresh_info(&u, &y).unwrap();
            auto.refresh_info(&u, &y).unwrap();
            let (f1, f2) = (qr.info().fit_pv, auto.info().fit_pv);
            assert!(
                (f1 - f2).abs() <= 1e-9 * f1.abs(),
                "seed {seed} n={n} f={f} p={p}: fit {f1} vs {f2}"
            );
            let p1 = qr.predict_one_step(&u, &y).unwrap();
            let p2 = auto.predict_one_step(&u, &y).unwrap();
            let big = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (a, b) in p1.iter().zip(&p2) {
                assert!((a - b).abs() <= 1e-9 * big, "seed {seed}: {a} vs {b}");
            }
            let (s1, s2) = (&qr.info().singular_values, &auto.info().singular_values);
            assert_eq!(s1.len(), s2.len());
            // the leading values agree to 1e-12 relative; those at the noise floor of the
            // nearly noise-free record (σ ≈ 3e-8 σ_1, W² nearly singular) to 4e-9 σ_1
            for (a, b) in s1.iter().zip(s2) {
                assert!(
                    (a - b).abs() <= 1e-8 * s1[0],
                    "seed {seed}: σ {s1:?} vs {s2:?}"
                );
            }
            let us: Vec<f64> = u.iter().map(|v| v - 50.0).collect();
            let ys: Vec<f64> = y.iter().map(|v| v - 40.0).collect();
            let ncol = u.len() + 1 - p - f;
            let cols: Vec<(bool, usize)> = (0..p)
                .map(|i| (false, i))
                .chain((0..p).map(|i| (true, i)))
                .chain([(false, p), (true, p)])
                .chain((0..f).map(|i| (true, p + i)))
                .collect();
            let h = ShiftedProducts::new(&us, &ys, p + f, ncol);
            from_gram += usize::from(step2_from_gram(&h, &cols, 2 * p + 2).is_some());
            let w2 = weight_squared(&hankel_gram(&h, p, f), 2 * p, Route::Fast).unwrap();
            from_cholesky += usize::from(la::cholesky_lower(w2.as_ref()).is_some());
        }
    }
    // both ways of factoring W² are compared: Cholesky on the noisy records (and one
    // horizon of the nearly noise-free one), the square root on the others
    assert!(
        from_cholesky == 10,
        "W² factored by Cholesky {from_cholesky} of 12 times, expected 10"
    );
    // the comparison is not vacuous: the Gram path is taken on these records
    assert!(
        from_gram == 9,
        "Gram path taken {from_gram} of 12 times, expected 9"
    );
}

#[test]
fn step2_gram_refuses_a_rank_deficient_record() {
    // u constant after the first samples: the u shifts are collinear over the columns
    let (mut u, y) = crate::test_data::valve_loop(600, 5, 0.3);
    u[10..].fill(51.0);
    let ncol = u.len() + 1 - 20;
    let cols: Vec<(bool, usize)> = (0..10)
        .map(|i| (false, i))
        .chain((0..10).map(|i| (true, i)))
        .chain([(false, 10), (true, 10)])
        .collect();
    let h = ShiftedProducts::new(&u, &y, 20, ncol);
    assert!(step2_from_gram(&h, &cols, 22).is_none());
}

#[test]
fn hankel_gram_matches_product() {
    let len = 700;
    let us: Vec<f64> = (0..len)
        .map(|k| ((k * 7919) % 113) as f64 / 56.0 - 1.0)
        .collect();
    let ys: Vec<f64> = (0..len)
        .map(|k| (k as f64 * 0.37).sin() + 0.1 * us[k])
        .collect();
    for (p, f) in [(10, 10), (3, 7), (12, 4)] {
        let ncol = len + 1 - p - f;
        let mut x = Mat::<f64>::zeros(ncol, 2 * p + f);
        for i in 0..p {
            x.col_as_slice_mut(i).copy_from_slice(&us[i..i + ncol]);
            x.col_as_slice_mut(p + i).copy_from_slice(&ys[i..i + ncol]);
        }
        for i in 0..f {
            x.col_as_slice_mut(2 * p + i)
                .copy_from_slice(&us[p + i..p + i + ncol]);
        }
        let direct = la::mul(x.as_ref().transpose(), x.as_ref());
        let fast = hankel_gram(&ShiftedProducts::new(&us, &ys, p + f, ncol), p, f);
        for i in 0..2 * p + f {
            for j in 0..2 * p + f {
                assert!(
                    (direct[(i, j)] - fast[(i, j)]).abs() < 1e-11 * ncol as f64,
                    "p={p} f={f} ({i},{j}): {} vs {}",
                    direct[(i, j)],
                    fast[(i, j)]
                );
            }
        }
    }
}

#[test]
fn step6_columns_match_separate_simulations() {
    let len = 300;
    let us: Vec<f64> = (0..len)
        .map(|k| ((k * 31) % 17) as f64 / 8.0 - 1.0)
        .collect();
    let ys: Vec<f64> = (0..len).map(|k| (k as f64 * 0.2).cos()).collect();
    for n in [1usize, 2, 3, 5] {
        let ak: Vec<f64> = (0..n * n)
            .map(|i| {
                if i % (n + 1) == 0 {
                    0.5
                } else {
                    0.05 * i as f64 / (n * n) as f64
                }
            })
            .collect();
        let c: Vec<f64> = (0..n).map(|i| 1.0 - 0.3 * i as f64).collect();
        for d_required in [false, true] {
            let npar = 3 * n + usize::from(d_required);
            let mut ab = vec![f64::NAN; len * npar];
            let step6 = Step6 {
                ak: &ak,
                c: &c,
                us: &us,
                ys: &ys,
                d_required,
            };
            step6.write(n, &mut ab);
            // reference: one simulation per column
            let sim = |bk: &[f64], k: &[f64], x0: &[f64]| -> Vec<f64> {
                let mut x = x0.to_vec();
                let mut out = vec![0.0; len];
                for t in 0..len {
                    out[t] = (0..n).map(|i| c[i] * x[i]).sum();
                    x = (0..n)
                        .map(|i| {
                            (0..n).map(|j| ak[i * n + j] * x[j]).sum::<f64>()
                                + bk[i] * us[t]
                                + k[i] * ys[t]
                        })
                        .collect();
                }
                out
            };
            let z = vec![0.0; n];
            let off = usize::from(d_required);
            for r in 0..n {
                let mut e = vec![0.0; n];
                e[r] = 1.0;
                for (col, want) in [
                    (r, sim(&e, &z, &z)),
                    (n + off + r, sim(&z, &e, &z)),
                    (2 * n + off + r, sim(&z, &z, &e)),
                ] {
                    // the row recursion sums in another order: equal to round-off
                    let got = &ab[col * len..(col + 1) * len];
                    let big = want.iter().fold(1.0f64, |m, v| m.max(v.abs()));
                    for (t, (g, w)) in got.iter().zip(&want).enumerate() {
                        assert!(
                            (g - w).abs() <= 1e-12 * big,
                            "n={n} col {col} t {t}: {g} vs {w}"
                        );
                    }
                }
            }
            if d_required {
                assert_eq!(&ab[n * len..(n + 1) * len], &us[..]);
            }
        }
    }
}
