//! Test data shared by the unit tests of several modules.
#![allow(clippy::needless_range_loop)]

/// A sticky-valve-like input (held levels with jumps) through a second-order plant with
/// noise of amplitude `noise`.
pub(crate) fn valve_loop(len: usize, seed: u64, noise: f64) -> (Vec<f64>, Vec<f64>) {
    let mut state = seed;
    let mut rnd = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    let (mut u, mut y) = (vec![0.0; len], vec![0.0; len]);
    let mut level = 50.0;
    for k in 0..len {
        if rnd() > 0.3 {
            level += 2.0 * rnd();
        }
        u[k] = level;
        let mut v = 40.0 + noise * rnd();
        if k >= 2 {
            v += 1.5 * (y[k - 1] - 40.0) - 0.7 * (y[k - 2] - 40.0)
                + 0.4 * (u[k - 1] - 50.0)
                + 0.1 * (u[k - 2] - 50.0);
        }
        y[k] = v;
    }
    (u, y)
}

/// The `i`-th input derived from `u0` (scaled and perturbed differently for each `i`).
pub(crate) fn varied_input(u0: &[f64], i: usize) -> Vec<f64> {
    u0.iter()
        .enumerate()
        .map(|(k, v)| v * (1.0 + 0.07 * i as f64) + ((k * (i + 1)) % 7) as f64 * 0.01)
        .collect()
}

/// [`crate::LinearIdentifier::identify_predict_many`] of `id` against `identify` +
/// `predict_one_step_into`, input by input, compared bit for bit: `n` inputs starting at
/// different samples, the third of them constant (an error in its place).
pub(crate) fn identify_predict_many_matches(id: &dyn crate::LinearIdentifier, n: usize) {
    let (u0, y) = valve_loop(900, 3, 0.3);
    let inputs: Vec<(usize, Vec<f64>)> = (0..n)
        .map(|i| {
            let start = [0, 40, 3, 0, 170, 12, 12, 90, 1][i % 9];
            if i == 2 {
                (start, vec![1.5; y.len()])
            } else {
                (start, varied_input(&u0, i))
            }
        })
        .collect();
    let refs: Vec<(usize, &[f64])> = inputs.iter().map(|(s, u)| (*s, u.as_slice())).collect();
    let split = 600;
    let mut outs = vec![Vec::new(); n];
    let output = id.prepare(&y).unwrap();
    let many = id.identify_predict_many(crate::Batch {
        inputs: &refs,
        output: &output,
        split,
        outs: &mut outs,
    });
    assert_eq!(many.len(), n);
    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
    for (i, got) in many.into_iter().enumerate() {
        let (start, u) = refs[i];
        let want = id.identify(&u[start..split], &y[start..split]);
        match (want, got) {
            (Err(w), Err(g)) => assert_eq!(w.to_string(), g.to_string()),
            (Ok(w), Ok(g)) => {
                assert_eq!(
                    format!("{:?}", w.structure()),
                    format!("{:?}", g.fit.structure())
                );
                assert_eq!(format!("{:?}", w.info()), format!("{:?}", g.fit.info()));
                assert_eq!(w.disturbance(), g.fit.disturbance());
                let mut pred = vec![0.0; y.len() - start];
                w.predict_one_step_into(&u[start..], &y[start..], &mut pred)
                    .unwrap();
                g.prediction.unwrap();
                assert_eq!(bits(&pred), bits(&outs[i]), "input {i}: predictions differ");
            }
            (w, g) => panic!("input {i}: {w:?} against {:?}", g.map(|g| g.fit)),
        }
    }
}
