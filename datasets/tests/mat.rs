//! MATLAB v5 files: the fixtures written by `scripts/make_mat_fixtures.py` (committed, so no
//! Python is needed here).

#![allow(clippy::unwrap_used)]

use datasets::{read_mat, read_mat_path, read_path, ReadOptions};
use proptest::prelude::*;

fn fixture(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

#[test]
fn reads_flat_variables_with_ts() {
    let d = read_path(fixture("loop_flat.mat"), &ReadOptions::default()).unwrap();
    assert_eq!(d.len(), 60);
    for k in 0..60 {
        let op = 50.0 + 2.0 * (2.0 * std::f64::consts::PI * k as f64 / 20.0).sin();
        assert!((d.op[k] - op).abs() < 1e-12, "OP[{k}]");
        assert_eq!(
            d.pv.as_ref().unwrap()[k],
            10.0 + (op - 50.0).round(),
            "PV[{k}]"
        );
    }
    assert_eq!(d.sp.as_deref().unwrap()[7], 10.0);
    let t = d.t.as_deref().unwrap();
    assert_eq!((t[0], t[1], t[59]), (0.0, 10.0, 590.0));
    assert_eq!(d.notes[0], "time from the sampling time Ts = 10 s");
}

#[test]
fn struct_of_loops_is_refused_clearly() {
    let e = read_mat_path(fixture("loop_struct.mat"), &ReadOptions::default()).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("loop_struct.mat: no numeric variable PV"),
        "{msg}"
    );
    assert!(msg.contains("cdata.<sector>.loop<N>"), "{msg}");
}

#[test]
fn remaps_and_missing_variables() {
    let opts = ReadOptions {
        pv: Some("SP".into()),
        ..ReadOptions::default()
    };
    // SP is constant: remapped as PV it is refused like a constant CSV column.
    let e = read_mat_path(fixture("loop_flat.mat"), &opts).unwrap_err();
    assert!(e.to_string().contains("column PV: constant (10.0)"), "{e}");
    let e = read_mat(
        &b"not a mat file at all"[..],
        "x.mat",
        &ReadOptions::default(),
    )
    .unwrap_err();
    assert!(
        e.to_string()
            .starts_with("x.mat: not a readable MATLAB v5 file"),
        "{e}"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn never_panics_on_corrupted_files(cut in 0usize..1800, flip in 0usize..1800, byte in any::<u8>()) {
        let mut bytes = std::fs::read(fixture("loop_flat.mat")).unwrap();
        if flip < bytes.len() {
            bytes[flip] = byte;
        }
        bytes.truncate(cut.max(1));
        let _ = read_mat(bytes.as_slice(), "fuzz.mat", &ReadOptions::default());
    }
}
