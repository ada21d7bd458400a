//! The files `cargo xtask detect-calibrate` writes beside its tables: the per-loop rows of
//! `--cases` and the validation loops of `--dump`.

use super::*;

/// `--cases FILE`: one CSV row per loop of `sets` under the model they were last judged with.
pub(super) fn write_cases(
    path: &Path,
    train: &[(&str, Vec<Case>)],
    valid: &[(&str, Vec<Case>)],
) -> Result<()> {
    let quote = |s: &str| format!("\"{}\"", s.replace('"', "'"));
    let names: Vec<&str> = registry().iter().map(|e| e.name).collect();
    let mut text = String::from(
        "population,what,sticky,no_trace,judgeable,kind_integrating,integrating,tie,score,verdict,reason",
    );
    for n in &names {
        text.push_str(&format!(",{n},{n}_verdict"));
    }
    text.push_str(
        ",hammerstein_lr_arx,hammerstein_S,hammerstein_delay,hammerstein_S_upper,hammerstein_J,hammerstein_S_arx,hammerstein_S_lower,hammerstein_free_share,stick_slip_window,oracle_lr,pv_straight_share\n",
    );
    for (set, cases) in train.iter().chain(valid) {
        for c in cases {
            let j = c.judged()?;
            text.push_str(&format!(
                "{},{},{},{},{},{},{},{},{:.4},{},{}",
                quote(set),
                quote(&c.what),
                c.sticky,
                c.no_trace,
                c.judgeable,
                c.kind_integrating,
                c.integrating,
                c.tie,
                j.score,
                j.verdict,
                quote(&j.reason)
            ));
            for n in &names {
                let o = c.outcomes.iter().find(|o| o.name == *n);
                let stat = o
                    .and_then(|o| o.statistic)
                    .map_or(String::new(), |v| format!("{v:.4}"));
                let verdict = o.map_or(String::new(), |o| o.verdict.to_string());
                text.push_str(&format!(",{stat},{verdict}"));
            }
            let h = c.outcomes.iter().find(|o| o.name == "hammerstein");
            for key in [
                "lr_arx",
                "S",
                "delay",
                "S_upper",
                "J",
                "S_arx",
                "S_lower",
                "free_share",
            ] {
                let v = h
                    .and_then(|o| o.values.iter().find(|(k, _)| *k == key))
                    .map_or(String::new(), |(_, v)| format!("{v:.4}"));
                text.push_str(&format!(",{v}"));
            }
            let w = c
                .outcomes
                .iter()
                .find(|o| o.name == "stick-slip")
                .and_then(|o| o.value("window"))
                .map_or(String::new(), |v| format!("{v:.0}"));
            let oracle = c.oracle.map_or(String::new(), |v| format!("{v:.4}"));
            let straight = datasets::compression(&c.pv)
                .filter(datasets::Compression::detected)
                .map_or("0".to_string(), |k| format!("{:.3}", k.share));
            text.push_str(&format!(",{w},{oracle},{straight}\n"));
        }
    }
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
}

/// Write each case as `sim-<index>.csv` (t, SP, PV, OP) under `dir`, with `index.csv` naming
/// what each is.
pub(super) fn dump_cases(dir: &Path, cases: &[Case]) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut index = String::from("file,what,sticky,judgeable,integrating\n");
    for (i, c) in cases.iter().enumerate() {
        let name = format!("sim-{i:03}.csv");
        let mut text = String::from("t,SP,PV,OP\n");
        for k in 0..c.pv.len() {
            let sp = c.sp.as_ref().map_or(f64::NAN, |s| s[k]);
            text.push_str(&format!(
                "{},{sp},{},{}\n",
                k as f64 * c.ts,
                c.pv[k],
                c.op[k]
            ));
        }
        std::fs::write(dir.join(&name), text).with_context(|| format!("writing {name}"))?;
        index.push_str(&format!(
            "{name},\"{}\",{},{},{}\n",
            c.what, c.sticky, c.judgeable, c.kind_integrating
        ));
    }
    std::fs::write(dir.join("index.csv"), index).context("writing index.csv")
}
