//! No plausible wrong answer: units, edge values, flags checked against the data, one batch
//! per output, messages. Each test failed on the code before its fix.
#![allow(clippy::unwrap_used)]

mod common;
use common::{column, jsonl, run, run_ok, simulate_kano_4_1, temp_dir};
use std::path::{Path, PathBuf};

/// `stiction simulate` Kano S = 4, J = 1 (seed, samples): columns t, SP, PV, OP.
fn simulated(seed: &str, samples: &str) -> [Vec<f64>; 4] {
    let csv = simulate_kano_4_1(seed, samples);
    ["t", "SP", "PV", "OP"].map(|c| column(&csv, c))
}

/// The loop as CSV with OP mapped by `op`.
fn csv(cols: &[Vec<f64>; 4], op: impl Fn(f64) -> f64) -> String {
    let [t, sp, pv, o] = cols;
    let mut s = String::from("t,SP,PV,OP\n");
    for i in 0..t.len() {
        s.push_str(&format!("{},{},{},{}\n", t[i], sp[i], pv[i], op(o[i])));
    }
    s
}

fn err_line(args: &[&str], stdin: &[u8]) -> (i32, String) {
    let o = run(args, stdin);
    assert_eq!(o.stdout, "", "nothing on stdout on failure");
    assert_eq!(o.stderr.lines().count(), 1, "one line: {:?}", o.stderr);
    (o.code, o.stderr.trim_end().to_string())
}

fn json(o: &common::Out) -> serde_json::Value {
    assert_eq!(o.code, 0, "{}", o.stderr);
    serde_json::from_str(&o.stdout).unwrap()
}

/// OP in unknown units (× 1e9/16383, and × 1e3 of that): the detector's verdict and score and
/// the diagnosis' S do not depend on the factor, and S is in % of the span it assumed (the old
/// code: detect searched bands in % steps of OP's own units, the diagnosis printed
/// "S = 39949948.12 %").
#[test]
fn op_in_unknown_units_gives_one_answer_in_percent() {
    let cols = simulated("2", "1500");
    let k = 1e9 / 16383.0;
    let a = csv(&cols, |v| v * k);
    let b = csv(&cols, |v| v * k * 1e3);
    let da = json(&run(&["detect", "-", "--json"], a.as_bytes()));
    let db = json(&run(&["detect", "-", "--json"], b.as_bytes()));
    assert_eq!(da["verdict"], db["verdict"]);
    let (sa, sb) = (da["score"].as_f64().unwrap(), db["score"].as_f64().unwrap());
    assert!((sa - sb).abs() < 1e-6, "{sa} {sb}");
    // a sticky valve is never called healthy; with the span unknown, the range seen stands
    // for it and this valve's band (S = 4 in an OP range of 8.3: 48 % of the span assumed) lies
    // past the detector's grid edge (12 %), which is no evidence either way: `inconclusive` with that reason is the answer
    assert_ne!(da["verdict"], "no-stiction", "{da}");
    let o = run(&["quantify", "-", "--json"], a.as_bytes());
    assert!(o.stderr.contains("% of the OP range seen"), "{}", o.stderr);
    let s = json(&o)["S"].as_f64().unwrap();
    assert!(s > 0.0 && s <= 100.0, "S = {s}");
}

/// `--op-range` must hold OP: a span that does not is a usage error naming the flag (the old
/// code: S = 40 for `0,10`, 4e11 % for `0,1e-9`, a data error for `0,1e-300`, "singular
/// regression" for `0,1e300`). OP within 4-20 gets a note that it may be 4-20 mA.
#[test]
fn op_range_is_checked_against_op() {
    let cols = simulated("3", "600");
    let data = csv(&cols, |v| 50.0 + v / 10.0);
    for range in ["0,10", "0,1e-9", "0,1e-300", "0,1e300"] {
        let (code, line) = err_line(
            &["quantify", "-", "--op-range", range, "--step", "0.5"],
            data.as_bytes(),
        );
        assert_eq!(code, 2, "{range}: {line}");
        assert!(line.contains("--op-range"), "{range}: {line}");
    }
    let (lo, hi) = cols[3]
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    let o = run_ok(
        &["quantify", "-", "--step", "1"],
        csv(&cols, |v| v).as_bytes(),
    );
    assert!(
        o.stderr
            .contains("warning: --step 1: the 95 % region is a single grid node"),
        "{}",
        o.stderr
    );
    let ma = csv(&cols, |v| 4.5 + (v - lo) * 15.0 / (hi - lo));
    let o = run(&["detect", "-"], ma.as_bytes());
    assert!(o.stderr.contains("--op-range 4,20"), "{}", o.stderr);
}

/// Every numeric flag refuses NaN, infinities and out-of-range values with exit 2 naming the
/// flag (the old code ran `trend --horizon NaN` and `--min-fit 200` to exit 0).
#[test]
fn numeric_flags_refuse_nan_inf_and_out_of_range() {
    let dir = temp_dir("numeric-flags");
    let cols = simulated("4", "600");
    let f = dir.join("V1_20240101-0800.csv");
    std::fs::write(&f, csv(&cols, |v| v)).unwrap();
    let f = f.to_str().unwrap();
    for (args, flag) in [
        (vec!["trend", f, "--horizon", "NaN"], "--horizon"),
        (vec!["trend", f, "--horizon", "inf"], "--horizon"),
        (vec!["trend", f, "--horizon", "0"], "--horizon"),
        (vec!["trend", f, "--min-fit", "NaN"], "--min-fit"),
        (vec!["trend", f, "--min-fit", "200"], "--min-fit"),
        (vec!["trend", f, "--threshold", "-1"], "--threshold"),
        (vec!["batch", f, "--min-fit", "inf"], "--min-fit"),
        (vec!["quantify", f, "--step", "NaN"], "--step"),
        (vec!["quantify", f, "--max-nodes", "0"], "--max-nodes"),
        (vec!["quantify", f, "--max-rows", "0"], "--max-rows"),
        (vec!["quantify", f, "--window", "0"], "--window"),
        (vec!["quantify", f, "--max-work", "NaN"], "--max-work"),
        (vec!["detect", f, "--window", "inf"], "--window"),
        (vec!["identify", f, "--split", "NaN"], "--split"),
        (vec!["simulate", "--noise", "NaN"], "--noise"),
        (vec!["simulate", "--kc", "inf"], "--kc"),
        (vec!["simulate", "--param", "S=NaN"], "parameter S"),
        (vec!["valve", f, "--model", "kano", "--us0", "NaN"], "--us0"),
    ] {
        let (code, line) = err_line(&args, b"");
        assert_eq!(code, 2, "{args:?}: {line}");
        assert!(line.contains(flag), "{args:?}: {line}");
    }
}

/// `batch` on a folder with no registration exits 1 as `trend` does (the old code: 0).
#[test]
fn batch_on_an_empty_folder_is_an_error() {
    let dir = temp_dir("empty-batch");
    let (code, line) = err_line(&["batch", dir.to_str().unwrap()], b"");
    assert_eq!(code, 1, "{line}");
    assert!(line.contains("no registration files"), "{line}");
    let (code, _) = err_line(&["trend", dir.to_str().unwrap()], b"");
    assert_eq!(code, 1);
}

fn write_loop(dir: &Path, name: &str, seed: &str) -> PathBuf {
    let cols = simulated(seed, "600");
    let f = dir.join(name);
    std::fs::write(&f, csv(&cols, |v| v)).unwrap();
    f
}

/// A second batch on the same output while the first holds it is refused (the old code
/// appended every row a second time).
#[test]
fn a_second_batch_on_the_same_output_is_refused() {
    let dir = temp_dir("batch-lock");
    let data = dir.join("data");
    std::fs::create_dir_all(&data).unwrap();
    write_loop(&data, "V1_20240101-0800.csv", "5");
    let out = dir.join("out");
    let lock = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(dir.join("out.jsonl.lock"))
        .unwrap();
    lock.try_lock().unwrap();
    let args = ["batch", data.to_str().unwrap(), "-o", out.to_str().unwrap()];
    let (code, line) = err_line(&args, b"");
    assert_eq!(code, 1, "{line}");
    assert!(line.contains("another batch run"), "{line}");
    lock.unlock().unwrap();
    run_ok(&args, b"");
    assert_eq!(jsonl(&dir.join("out.jsonl")).len(), 1);
}

/// Resume is keyed by the full path and the content: a file replaced by other bytes of the same
/// size and modification time is computed again (the old code kept its stale row), and the
/// same name in another folder is another registration.
#[test]
fn resume_is_keyed_by_path_and_content() {
    let dir = temp_dir("batch-resume-key");
    let (a, b) = (dir.join("a"), dir.join("b"));
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();
    let fa = write_loop(&a, "V1_20240101-0800.csv", "6");
    let out = dir.join("out");
    run_ok(
        &["batch", a.to_str().unwrap(), "-o", out.to_str().unwrap()],
        b"",
    );
    let before = jsonl(&dir.join("out.jsonl"));
    assert_eq!(before.len(), 1);
    // Other bytes, same length, same modification time.
    let meta = std::fs::metadata(&fa).unwrap();
    let text = std::fs::read_to_string(&fa).unwrap();
    let (header, body) = text.split_once('\n').unwrap();
    let changed = format!("{header}\n{}", body.replace('1', "2"));
    std::fs::write(&fa, &changed).unwrap();
    write_loop(&b, "V1_20240101-0800.csv", "7");
    let f = std::fs::File::options().write(true).open(&fa).unwrap();
    f.set_modified(meta.modified().unwrap()).unwrap();
    drop(f);
    assert_eq!(std::fs::metadata(&fa).unwrap().len(), meta.len());
    let o = run_ok(
        &["batch", a.to_str().unwrap(), "-o", out.to_str().unwrap()],
        b"",
    );
    assert!(o.stdout.contains("1 file(s) computed"), "{}", o.stdout);
    // Both folders: the same name elsewhere is computed, the unchanged file is kept.
    let o = run_ok(
        &[
            "batch",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
        b"",
    );
    assert_eq!(jsonl(&dir.join("out.jsonl")).len(), 2, "{}", o.stdout);
    assert!(o.stdout.contains("1 file(s) computed"), "{}", o.stdout);
}

/// Every registration file found gets a row, an error row when it cannot be read (the old
/// code left out the empty, UTF-16, header-less and `#` files without a row); the same file
/// given twice counts once, with a note.
#[test]
fn every_registration_file_gets_a_row_and_duplicates_count_once() {
    let dir = temp_dir("batch-rows");
    let good = write_loop(&dir, "V1_20240101-0800.csv", "8");
    std::fs::write(dir.join("V1_20240201-0800.csv"), b"").unwrap();
    let utf16: Vec<u8> = std::fs::read_to_string(&good)
        .unwrap()
        .encode_utf16()
        .flat_map(|u| u.to_be_bytes())
        .collect();
    std::fs::write(dir.join("V1_20240301-0800.csv"), utf16).unwrap();
    std::fs::write(dir.join("V1_20240401-0800.csv"), b"1,2,3\n4,5,6\n").unwrap();
    std::fs::write(dir.join("V1_20240501-0800.csv"), b"# exported\nt,PV,OP\n").unwrap();
    let out = dir.join("out");
    let o = run_ok(
        &[
            "batch",
            dir.to_str().unwrap(),
            good.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
        b"",
    );
    assert!(o.stderr.contains("counted once"), "{}", o.stderr);
    let rows_out = jsonl(Path::new(&format!("{}.jsonl", out.display())));
    let files: std::collections::BTreeSet<String> = rows_out
        .iter()
        .map(|r| r["file"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(rows_out.len(), 5, "{files:?}");
    assert_eq!(files.len(), 5, "{files:?}");
    let utf16_row = rows_out
        .iter()
        .find(|r| r["file"] == "V1_20240301-0800.csv")
        .unwrap();
    assert!(
        utf16_row["error"].as_str().unwrap().contains("UTF-16"),
        "{utf16_row}"
    );
    // trend: the same file twice is one registration.
    let o = run(
        &[
            "trend",
            good.to_str().unwrap(),
            good.to_str().unwrap(),
            "--json",
        ],
        b"",
    );
    assert!(o.stderr.contains("counted once"), "{}", o.stderr);
}

/// `compare --stiction kano,kano` runs Kano once, with a note.
#[test]
fn compare_runs_each_model_once() {
    let cols = simulated("9", "600");
    let data = csv(&cols, |v| v);
    let o = run(
        &[
            "compare",
            "-",
            "--stiction",
            "kano,kano",
            "--linear",
            "arx",
            "--json",
        ],
        data.as_bytes(),
    );
    let v = json(&o);
    assert!(o.stderr.contains("more than once"), "{}", o.stderr);
    let rows = v["rows"]
        .as_array()
        .or_else(|| v["results"].as_array())
        .unwrap();
    assert_eq!(rows.len(), 1, "{v}");
}

/// UTF-16 is named, never printed with its NUL bytes; `valve` does not refuse a file for its
/// PV, which it does not use.
#[test]
fn utf16_is_named_and_valve_ignores_pv() {
    let cols = simulated("10", "300");
    let text = csv(&cols, |v| v);
    for bytes in [
        text.encode_utf16()
            .flat_map(|u| u.to_be_bytes())
            .collect::<Vec<u8>>(),
        [0xFF, 0xFE]
            .into_iter()
            .chain(text.encode_utf16().flat_map(|u| u.to_le_bytes()))
            .collect(),
    ] {
        let (code, line) = err_line(&["quantify", "-"], &bytes);
        assert_eq!(code, 1);
        assert!(!line.contains('\0'), "{line:?}");
        assert!(line.contains("UTF-16"), "{line}");
        assert!(line.contains("UTF-8"), "{line}");
    }
    let bad_pv = text.replacen(&format!(",{},", cols[2][5]), ",abc,", 1);
    assert_ne!(bad_pv, text);
    let o = run_ok(
        &["valve", "-", "--model", "kano", "--param", "S=3"],
        bad_pv.as_bytes(),
    );
    assert!(o.stderr.contains("PV is not needed"), "{}", o.stderr);
}

/// A cell equal to 1e150 is refused like larger ones (the limit leaves room for the squares
/// the solvers form); one OP sample of 1000 or one `-0` in a simulated Kano loop is a spike,
/// replaced with a note, and S stays near 4 (the old code: S = 973.8; S = 0.7).
#[test]
fn edge_values_and_single_sample_spikes() {
    let cols = simulated("1", "1500");
    let mut bad = cols.clone();
    bad[2][40] = 1e150;
    let (code, line) = err_line(&["quantify", "-"], csv(&bad, |v| v).as_bytes());
    assert_eq!(code, 1, "{line}");
    assert!(
        line.contains("row 42, column PV") && line.contains("too large"),
        "{line}"
    );
    for (k, v) in [(700, 1000.0), (700, -0.0), (0, 0.0)] {
        let mut spiky = cols.clone();
        spiky[3][k] = v;
        let o = run(&["quantify", "-", "--json"], csv(&spiky, |v| v).as_bytes());
        assert!(
            o.stderr.contains("single-sample spike"),
            "OP[{k}] = {v}: {}",
            o.stderr
        );
        let s = json(&o)["S"].as_f64().unwrap();
        assert!((s - 4.0).abs() < 0.5, "OP[{k}] = {v}: S = {s}");
    }
}

/// A long record is analysed on its latest `--window` rows, with a note, and every command
/// gives the answer it gives on those rows cut by hand (the old code had no window: 1 M rows
/// of `quantify` ran past 150 s). `--window` longer than the record changes nothing.
#[test]
fn a_long_record_is_analysed_on_its_latest_rows() {
    let dir = temp_dir("window");
    let cols = simulated("6", "3000");
    let whole = dir.join("whole.csv");
    std::fs::write(&whole, csv(&cols, |v| v)).unwrap();
    let tail: [Vec<f64>; 4] = cols.clone().map(|c| c[1800..].to_vec());
    let cut = dir.join("cut.csv");
    std::fs::write(&cut, csv(&tail, |v| v)).unwrap();
    let (whole, cut) = (whole.to_str().unwrap(), cut.to_str().unwrap());
    for cmd in ["quantify", "detect", "diagnose"] {
        let w = run(&[cmd, whole, "--window", "1200", "--json"], b"");
        assert!(
            w.stderr
                .contains("analysed the latest 1200 of 3000 rows (rows 1802-3001)"),
            "{cmd}: {}",
            w.stderr
        );
        let c = run(&[cmd, cut, "--json"], b"");
        let (mut w, mut c) = (json(&w), json(&c));
        for v in [&mut w, &mut c] {
            strip_volatile(v);
        }
        assert_eq!(w, c, "{cmd}: the window and the rows cut by hand");
        let all = run(&[cmd, whole, "--window", "3000", "--json"], b"");
        assert!(
            !all.stderr.contains("analysed the latest"),
            "{}",
            all.stderr
        );
    }
}

/// Timings, file names and the reader's notes differ between two files of the same rows.
fn strip_volatile(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(m) => {
            m.retain(|k, _| {
                !matches!(
                    k.as_str(),
                    "elapsed_ms" | "source" | "file" | "notes" | "reader_notes" | "seconds"
                )
            });
            for x in m.values_mut() {
                strip_volatile(x);
            }
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(strip_volatile),
        _ => {}
    }
}

/// The work budget counts samples × the model's cost per node, not nodes alone: ARMAX
/// 50,50,50 on 3000 samples (a few thousand nodes, within the node budget) ran for minutes;
/// now a usage error naming `--max-work`, and a smaller budget refuses the default plan.
#[test]
fn the_work_budget_counts_samples_and_orders() {
    let dir = temp_dir("work");
    let cols = simulated("7", "3000");
    let f = dir.join("loop.csv");
    std::fs::write(&f, csv(&cols, |v| v)).unwrap();
    let f = f.to_str().unwrap();
    for args in [
        vec!["quantify", f, "--linear", "armax", "--orders", "50,50,50"],
        vec!["quantify", f, "--max-work", "1e6"],
    ] {
        let (code, line) = err_line(&args, b"");
        assert_eq!(code, 2, "{args:?}: {line}");
        assert!(
            line.contains("--max-work") && line.contains("3000 samples"),
            "{line}"
        );
    }
}
