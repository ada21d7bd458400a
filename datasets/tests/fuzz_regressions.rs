//! Every saved fuzz regression (`tests/fuzz-regressions`, see its README) is read under every
//! gap policy without a panic; `cargo xtask fuzz` replays them through the search too.

use datasets::{read_csv, read_mat, GapPolicy, ReadOptions};

#[test]
fn saved_regressions_read_without_panic() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-regressions");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap().flatten() {
        let path = entry.path();
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if ext != "csv" && ext != "mat" {
            continue;
        }
        let bytes = std::fs::read(&path).unwrap();
        for gaps in [GapPolicy::Refuse, GapPolicy::FillHold, GapPolicy::DropGaps] {
            let opts = ReadOptions {
                gaps,
                min_rows: 30,
                ..ReadOptions::default()
            };
            let r = if ext == "mat" {
                read_mat(bytes.as_slice(), "r.mat", &opts)
            } else {
                read_csv(bytes.as_slice(), "r.csv", &opts)
            };
            if let Err(e) = r {
                let msg = e.to_string();
                assert!(
                    msg.len() < 400 && !msg.contains('\n'),
                    "{}: {msg}",
                    path.display()
                );
            }
        }
        n += 1;
    }
    assert!(n >= 5, "{n} regression files");
}
