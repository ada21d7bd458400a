#![allow(clippy::unwrap_used)]
use super::*;
use proptest::prelude::*;

/// A valve-like input through a second-order plant, a sine of frequency `omega` added in the
/// difference equation, noise of amplitude `noise` (`crate::test_data::valve_loop` plus the
/// sine).
fn loop_with_sine(len: usize, seed: u64, noise: f64, omega: f64) -> (Vec<f64>, Vec<f64>) {
    let (u, y) = crate::test_data::valve_loop(len, seed, noise);
    let y = y
        .iter()
        .enumerate()
        .map(|(k, v)| v + 0.8 * (omega * k as f64 + 0.4).sin())
        .collect();
    (u, y)
}

/// Relative difference, against the larger magnitude (at least 1).
fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(1.0)
}

/// The batch of `h` on `inputs` against `identify` + `predict_one_step_into` input by input:
/// the same errors; coefficients, operating point, diagnostics and predictions within `tol`.
fn batch_matches_qr(h: &Harx, inputs: &[(usize, Vec<f64>)], y: &[f64], split: usize, tol: f64) {
    batch_on_matches_qr(h, &h.prepare(y).unwrap(), inputs, split, tol);
}

/// The batch of `h` on `inputs`, the output `output` (its record `y`).
fn batch(
    h: &Harx,
    output: &crate::PreparedOutput,
    inputs: &[(usize, Vec<f64>)],
    split: usize,
) -> (Vec<Result<Identified, IdError>>, Vec<Vec<f64>>) {
    let refs: Vec<(usize, &[f64])> = inputs.iter().map(|(s, u)| (*s, u.as_slice())).collect();
    let mut outs = vec![Vec::new(); refs.len()];
    let many = h.identify_predict_many(crate::Batch {
        inputs: &refs,
        output,
        split,
        outs: &mut outs,
    });
    (many, outs)
}

/// [`batch_matches_qr`] with the output as given.
fn batch_on_matches_qr(
    h: &Harx,
    output: &crate::PreparedOutput,
    inputs: &[(usize, Vec<f64>)],
    split: usize,
    tol: f64,
) {
    let y = output.y();
    let refs: Vec<(usize, &[f64])> = inputs.iter().map(|(s, u)| (*s, u.as_slice())).collect();
    let (many, outs) = batch(h, output, inputs, split);
    for (i, got) in many.into_iter().enumerate() {
        let (start, u) = refs[i];
        let start = start.min(split);
        let want = h.identify(&u[start..split], &y[start..split]);
        match (want, got) {
            (Err(w), Err(g)) => assert_eq!(w.to_string(), g.to_string()),
            (Ok(w), Ok(g)) => {
                let (
                    Structure::Polynomial { a, b, .. },
                    Structure::Polynomial { a: ga, b: gb, .. },
                ) = (w.structure(), g.fit.structure())
                else {
                    panic!("polynomial models")
                };
                for (p, q) in a.iter().zip(ga).chain(b.iter().zip(gb)) {
                    assert!(rel(*p, *q) < tol, "input {i}: {a:?} {b:?} vs {ga:?} {gb:?}");
                }
                let ((wu, wy), (gu, gy)) = (w.means(), g.fit.means());
                assert!(
                    rel(wu, gu) < tol && rel(wy, gy) < tol,
                    "{wu} {wy} vs {gu} {gy}"
                );
                assert!(rel(w.info().fit_pv, g.fit.info().fit_pv) < tol);
                assert_eq!(w.info().first_sample, g.fit.info().first_sample);
                let mut pred = vec![0.0; y.len() - start];
                w.predict_one_step_into(&u[start..], &y[start..], &mut pred)
                    .unwrap();
                g.prediction.unwrap();
                for (p, q) in pred.iter().zip(&outs[i]) {
                    assert!(rel(*p, *q) < tol, "input {i}: prediction {p} vs {q}");
                }
            }
            (w, g) => panic!("input {i}: {w:?} against {:?}", g.map(|g| g.fit)),
        }
    }
}

/// [`fit_from_sums`] of the input `u` from `start`, the window ending at `split`.
fn sums_fit(h: &Harx, u: &[f64], y: &[f64], start: usize, split: usize) -> Option<LinearFit> {
    let mut out = vec![0.0; y.len() - start];
    let prepared = HarxOutput::new(h, y);
    let (y, window) = (&y[start..], split - start);
    let block = prepared.block(h, start, y, window);
    let sums = block.sums.as_ref()?;
    fit_from_sums(h, (&prepared, sums), (&u[start..], y), window, &mut out)
}

/// Inputs derived from `u0`, one per start (scaled and perturbed differently).
fn inputs(u0: &[f64], starts: &[usize]) -> Vec<(usize, Vec<f64>)> {
    starts
        .iter()
        .enumerate()
        .map(|(i, &start)| (start, crate::test_data::varied_input(u0, i)))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// On random loops, orders, frequencies and window starts, the batch from sums gives the
    /// QR's models, operating points, fits and predictions to 1e-9 relative, and takes the
    /// sums path (not the QR fallback) on these well-posed windows.
    #[test]
    fn sums_path_matches_the_qr(
        seed in 1u64..10_000,
        noise in 0.01f64..1.0,
        omega in 0.02f64..0.6,
        n in 1usize..=3,
        m in 1usize..=3,
        delay in 0usize..=4,
        starts in proptest::collection::vec(0usize..200, 1..6),
    ) {
        let (u0, y) = loop_with_sine(1200, seed, noise, omega);
        let h = Harx::params().n(n).m(m).delay(delay).omega(omega).check().unwrap();
        let ins = inputs(&u0, &starts);
        batch_matches_qr(&h, &ins, &y, 800, 1e-9);
        for (start, u) in &ins {
            prop_assert!(sums_fit(&h, u, &y, *start, 800).is_some());
        }
    }
}

/// Every field of a batch's results and its predictions (NaN compares equal; a float's
/// shortest round-trip text is its value).
fn shown((many, outs): (Vec<Result<Identified, IdError>>, Vec<Vec<f64>>)) -> String {
    let bits: Vec<Vec<u64>> = outs
        .iter()
        .map(|o| o.iter().map(|v| v.to_bits()).collect())
        .collect();
    format!("{many:?} {bits:?}")
}

/// The same windows asked again from one prepared output, by several batches, give the bits
/// of a fresh output; an output prepared otherwise (plain, or for another frequency or
/// orders) gives them too (each batch then works on its own); and each gives the QR's results.
#[test]
fn prepared_windows_belong_to_their_output() {
    let h = Harx::params().omega(0.08).check().unwrap();
    let (u0, y1) = loop_with_sine(900, 5, 0.2, 0.08);
    let (_, y2) = loop_with_sine(900, 6, 0.2, 0.08);
    let ins = inputs(&u0, &[0, 40, 0, 3]);
    for y in [&y1, &y2] {
        let prepared = h.prepare(y).unwrap();
        let fresh = shown(batch(&h, &h.prepare(y).unwrap(), &ins, 600));
        for _ in 0..2 {
            assert_eq!(shown(batch(&h, &prepared, &ins, 600)), fresh);
        }
        let other = Harx::params().omega(0.09).check().unwrap();
        let wider = Harx::params().n(3).omega(0.08).check().unwrap();
        for output in [
            crate::PreparedOutput::plain(y),
            other.prepare(y).unwrap(),
            wider.prepare(y).unwrap(),
            crate::Arx::params().check().unwrap().prepare(y).unwrap(),
        ] {
            assert_eq!(shown(batch(&h, &output, &ins, 600)), fresh);
        }
        batch_on_matches_qr(&h, &prepared, &ins, 600, 1e-9);
    }
    let mut y3 = y1.clone();
    y3[100] += 1e-12;
    let a = sums_fit(&h, &ins[0].1, &y1, 0, 600).unwrap();
    let b = sums_fit(&h, &ins[0].1, &y3, 0, 600).unwrap();
    assert_ne!(format!("{a:?}"), format!("{b:?}"));
}

/// A record not finite after a window's start (the prediction runs over it) takes the QR path
/// for that window and gives its results; windows starting after it take the sums.
#[test]
fn a_record_not_finite_takes_the_qr_path_before_it() {
    let h = Harx::params().omega(0.1).check().unwrap();
    let (u0, mut y) = loop_with_sine(900, 3, 0.3, 0.1);
    y[120] = f64::NAN;
    let ins = inputs(&u0, &[0, 130]);
    assert!(sums_fit(&h, &ins[0].1, &y, 0, 600).is_none());
    assert!(sums_fit(&h, &ins[1].1, &y, 130, 600).is_some());
    batch_matches_qr(&h, &ins, &y, 600, 1e-9);
}

/// Orders the sums do not handle (n + m > 9), a constant input, and a window too short: the
/// QR path's results and errors.
#[test]
fn other_cases_take_the_qr_path() {
    let (u0, y) = loop_with_sine(900, 3, 0.3, 0.1);
    let wide = Harx::params().n(5).m(5).omega(0.1).check().unwrap();
    assert!(sums_fit(&wide, &u0, &y, 0, 600).is_none());
    let mut ins = inputs(&u0, &[0, 12, 590]);
    ins.push((0, vec![1.5; y.len()]));
    for h in [wide, Harx::params().omega(0.1).check().unwrap()] {
        batch_matches_qr(&h, &ins, &y, 600, 1e-9);
    }
}
