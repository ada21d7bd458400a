//! MATLAB v5 files: the fixtures written by `scripts/make_mat_fixtures.py` (committed, so no
//! Python is needed here).

#![allow(clippy::unwrap_used)]

use datasets::{list_mat_loops, read_mat, read_mat_path, read_path, ReadOptions};
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
fn single_struct_loop_is_read_without_selection() {
    let d = read_mat_path(fixture("loop_struct.mat"), &ReadOptions::default()).unwrap();
    assert_eq!(d.len(), 60);
    assert_eq!(d.notes[0], "loop cdata.chemicals.loop1");
    assert_eq!(d.notes[1], "time from the sampling time Ts = 10 s");
    let flat = read_path(fixture("loop_flat.mat"), &ReadOptions::default()).unwrap();
    assert_eq!((d.op, d.pv, d.sp, d.t), (flat.op, flat.pv, flat.sp, flat.t));
    assert_eq!(
        list_mat_loops(fixture("loop_struct.mat")).unwrap(),
        vec!["cdata.chemicals.loop1"]
    );
    assert_eq!(list_mat_loops(fixture("loop_flat.mat")).unwrap(), vec![""]);
}

fn isdb(name: &str, path: &str) -> datasets::LoopData {
    let opts = ReadOptions {
        mat_loop: Some(path.into()),
        ..ReadOptions::default()
    };
    read_mat_path(fixture(name), &opts).unwrap()
}

#[test]
fn isdb_struct_of_loops() {
    for name in ["loop_isdb.mat", "loop_isdb_z.mat"] {
        assert_eq!(
            list_mat_loops(fixture(name)).unwrap(),
            vec!["cdata.chemicals.loop1", "cdata.chemicals.loop2"],
            "{name}"
        );
        let e = read_mat_path(fixture(name), &ReadOptions::default()).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "{}: 2 loops (cdata.chemicals.loop1, cdata.chemicals.loop2): select one \
                 with --loop PATH",
                fixture(name).display()
            )
        );
        let d = isdb(name, "cdata.chemicals.loop1");
        assert_eq!(d.len(), 50);
        assert_eq!(d.notes[0], "loop cdata.chemicals.loop1");
        for k in [0usize, 1, 17, 49] {
            let x = k as f64;
            assert_eq!(d.op[k], 50.0 + 3.0 * x.sin(), "OP[{k}]");
            assert_eq!(d.pv.as_ref().unwrap()[k], 20.0 + x.cos(), "PV[{k}]");
            assert_eq!(d.sp.as_ref().unwrap()[k], 20.0);
            assert_eq!(d.t.as_ref().unwrap()[k], x);
        }
        // loop2: OP stored as int16, PV as single (a row vector), Ts = 2.5.
        let d = isdb(name, "cdata.chemicals.loop2");
        assert_eq!(d.len(), 50);
        for k in [0usize, 6, 7, 49] {
            let x = k as f64;
            assert_eq!(d.op[k], 40.0 + (k % 7) as f64, "OP[{k}]");
            let pv = f64::from((5.0 + 0.5 * (0.3 * x).sin()) as f32);
            assert!((d.pv.as_ref().unwrap()[k] - pv).abs() < 1e-6, "PV[{k}]");
            assert_eq!(d.t.as_ref().unwrap()[k], 2.5 * x);
        }
        let e = read_mat_path(
            fixture(name),
            &ReadOptions {
                mat_loop: Some("cdata.chemicals.loop3".into()),
                ..ReadOptions::default()
            },
        )
        .unwrap_err();
        assert!(
            e.to_string().ends_with(
                "no struct cdata.chemicals.loop3 (loops: cdata.chemicals.loop1, \
                 cdata.chemicals.loop2)"
            ),
            "{e}"
        );
    }
    // Compressed and uncompressed files hold the same data.
    for path in ["cdata.chemicals.loop1", "cdata.chemicals.loop2"] {
        let (a, b) = (isdb("loop_isdb.mat", path), isdb("loop_isdb_z.mat", path));
        assert_eq!((a.op, a.pv, a.sp, a.t), (b.op, b.pv, b.sp, b.t));
    }
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
    // 200 cases by default; `PROPTEST_CASES` (`cargo xtask proptest --cases N`) scales it.
    #![proptest_config(ProptestConfig::with_cases(
        std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(200)
    ))]

    #[test]
    fn never_panics_on_corrupted_files(cut in 0usize..1800, flip in 0usize..1800, byte in any::<u8>()) {
        let mut bytes = std::fs::read(fixture("loop_flat.mat")).unwrap();
        if flip < bytes.len() {
            bytes[flip] = byte;
        }
        bytes.truncate(cut.max(1));
        let _ = read_mat(bytes.as_slice(), "fuzz.mat", &ReadOptions::default());
    }

    #[test]
    fn never_panics_on_corrupted_struct_files(
        z in any::<bool>(), cut in 0usize..3000, flip in 0usize..3000, byte in any::<u8>(),
    ) {
        let name = if z { "loop_isdb_z.mat" } else { "loop_isdb.mat" };
        let mut bytes = std::fs::read(fixture(name)).unwrap();
        if flip < bytes.len() {
            bytes[flip] = byte;
        }
        bytes.truncate(cut.max(1));
        for mat_loop in [None, Some("cdata.chemicals.loop2".to_string())] {
            let opts = ReadOptions { mat_loop, ..ReadOptions::default() };
            if let Err(e) = read_mat(bytes.as_slice(), "fuzz.mat", &opts) {
                prop_assert!(!e.to_string().contains('\n'), "{}", e);
            }
        }
    }
}

/// A hand-built MAT v5 file in either byte order: top-level double vectors `OP`, `PV` (the
/// name in a small data element) and an int8 scalar `Ts` (value in a small data element).
fn hand_built(big: bool) -> Vec<u8> {
    let u32b = |x: u32| {
        if big {
            x.to_be_bytes()
        } else {
            x.to_le_bytes()
        }
    };
    let mut out = b"MATLAB 5.0 MAT-file, hand-built".to_vec();
    out.resize(116, b' ');
    out.extend([0u8; 8]);
    out.extend(if big { [1u8, 0] } else { [0u8, 1] });
    out.extend(if big { b"MI" } else { b"IM" });
    let pad = |v: &mut Vec<u8>| v.resize(v.len().div_ceil(8) * 8, 0);
    let small = |kind: u32, data: &[u8]| {
        let mut v = u32b(kind | (data.len() as u32) << 16).to_vec();
        v.extend(data);
        v.resize(8, 0);
        v
    };
    let element = |kind: u32, data: &[u8]| {
        let mut v = u32b(kind).to_vec();
        v.extend(u32b(data.len() as u32));
        v.extend(data);
        pad(&mut v);
        v
    };
    let matrix = |name: &str, class: u32, values: Element| {
        let mut body = element(6, &[u32b(class), [0; 4]].concat());
        body.extend(element(5, &[u32b(values.1), u32b(1)].concat()));
        body.extend(small(1, name.as_bytes()));
        body.extend(values.0);
        element(14, &body)
    };
    type Element = (Vec<u8>, u32);
    let doubles = |xs: &[f64]| -> Element {
        let bytes: Vec<u8> = xs
            .iter()
            .flat_map(|x| {
                if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                }
            })
            .collect();
        (element(9, &bytes), xs.len() as u32)
    };
    out.extend(matrix("OP", 6, doubles(&[1.0, 2.5, -3.0, 4.0])));
    out.extend(matrix("PV", 6, doubles(&[0.5, 0.25, 0.125, 8.0])));
    out.extend(matrix("Ts", 8, (small(1, &[3]), 1)));
    out
}

#[test]
fn both_byte_orders_and_small_elements() {
    for big in [false, true] {
        let d = read_mat(hand_built(big).as_slice(), "h.mat", &ReadOptions::default()).unwrap();
        assert_eq!(d.op, vec![1.0, 2.5, -3.0, 4.0], "big = {big}");
        assert_eq!(d.pv.unwrap(), vec![0.5, 0.25, 0.125, 8.0]);
        assert_eq!(d.t.unwrap(), vec![0.0, 3.0, 6.0, 9.0]);
    }
}
