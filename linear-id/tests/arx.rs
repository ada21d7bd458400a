//! ARX by least squares: exact recovery on noise-free data.
#![allow(clippy::unwrap_used)]
mod common;

use common::*;
use linear_id::{Arx, LinearIdentifier, Structure};

fn poly(s: &Structure) -> (Vec<f64>, Vec<f64>, Vec<f64>, usize) {
    match s {
        Structure::Polynomial { a, b, c, delay } => (a.clone(), b.clone(), c.clone(), *delay),
        _ => panic!("not polynomial"),
    }
}

#[test]
fn noise_free_arx_coefficients_recovered_to_1e_8() {
    for (n, m, delay, seed) in [
        (2usize, 2usize, 0usize, 1u64),
        (3, 2, 3, 2),
        (1, 3, 1, 3),
        (2, 2, 5, 4),
    ] {
        let a_true: Vec<f64> = match n {
            1 => vec![1.0, -0.8],
            2 => vec![1.0, -1.5, 0.7],
            _ => vec![1.0, -1.4, 0.55, -0.06],
        };
        let b_true: Vec<f64> = [0.5, -0.3, 0.2][..m].to_vec();
        let u = gbn(600, 0.2, seed);
        let u: Vec<f64> = u.iter().map(|v| 50.0 + 3.0 * v).collect(); // offset: tests centering
        let y0 = simulate(&a_true, &b_true, &[1.0], delay, &u, &[], &[]);
        let y: Vec<f64> = y0.iter().map(|v| v + 7.0).collect();
        // steady initial state so that the offset is consistent: skip the transient
        let (u, y) = (&u[100..], &y[100..]);
        let id = Arx::params().n(n).m(m).delay(delay).check().unwrap();
        let fit = id.identify(u, y).unwrap();
        let (a, b, c, d) = poly(fit.structure());
        assert_eq!(d, delay);
        assert_eq!(c, vec![1.0]);
        assert!(max_abs_diff(&a, &a_true) < 1e-8, "a = {a:?}");
        assert!(max_abs_diff(&b, &b_true) < 1e-8, "b = {b:?}");
        assert!(fit.info().fit_pv > 100.0 - 1e-10);
        assert!(fit.is_stable());
    }
}
