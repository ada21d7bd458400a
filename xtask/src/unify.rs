//! One build for the front ends and the tests: the CLI (`stiction-cli`), the Python extension
//! (`stiction-python`), xtask and the test suite (`cargo test --workspace`, dev-dependencies
//! included) must resolve every crate they share with the same features, or each build after
//! the first compiles that crate and everything above it again: `pip install ./python` after
//! the CLI's build, and in `cargo xtask test` the gate's fuzz run (xtask in the test profile)
//! and the browser check's CLI after the tests. cli/Cargo.toml, python/Cargo.toml and
//! xtask/Cargo.toml carry the dependencies that keep them equal. One exception: the tests build
//! the `report` crate with its default `png` feature, which the CLI's default build leaves
//! off, so `report` and the crates above it are compiled once more for the CLI and xtask.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

use anyhow::{bail, Context, Result};

/// Each crate (name and version) of `package`'s normal and build dependency graph with its
/// enabled features, as `cargo tree --format "{p}|{f}"` lists them.
fn features(root: &Path, package: &str) -> Result<BTreeMap<String, BTreeSet<String>>> {
    tree(root, &["-p", package, "-e", "normal,build"])
}

/// The same for the test suite: every member but the Python extension, dev-dependencies
/// included (what `cargo test --workspace --exclude stiction-python` builds).
fn test_features(root: &Path) -> Result<BTreeMap<String, BTreeSet<String>>> {
    tree(
        root,
        &[
            "--workspace",
            "--exclude",
            "stiction-python",
            "-e",
            "normal,build,dev",
        ],
    )
}

fn tree(root: &Path, selection: &[&str]) -> Result<BTreeMap<String, BTreeSet<String>>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .current_dir(root)
        .args(["tree", "--quiet"])
        .args(selection)
        .args(["--prefix", "none", "--no-dedupe", "--format", "{p}|{f}"])
        .output()
        .context("running cargo tree")?;
    if !out.status.success() {
        bail!(
            "cargo tree {}: {}",
            selection.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    Ok(parse(&String::from_utf8_lossy(&out.stdout)))
}

/// `name v1.2.3 (path)|f1,f2` lines: the crate `name v1.2.3` with features f1 and f2 (the
/// union when a crate is listed more than once; two versions of a crate are two crates).
fn parse(tree: &str) -> BTreeMap<String, BTreeSet<String>> {
    let mut map: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for line in tree.lines() {
        let Some((package, feats)) = line.split_once('|') else {
            continue;
        };
        let mut words = package.split_whitespace();
        let (Some(name), Some(version)) = (words.next(), words.next()) else {
            continue;
        };
        let entry = map.entry(format!("{name} {version}")).or_default();
        entry.extend(
            feats
                .split(',')
                .map(str::trim)
                // `(*)` marks a crate whose dependencies were listed before, not a feature
                .filter(|f| !f.is_empty() && *f != "(*)")
                .map(str::to_string),
        );
    }
    map
}

/// The shared crates whose features differ between two builds (named `names`), one line each.
pub fn differences(
    a: &BTreeMap<String, BTreeSet<String>>,
    b: &BTreeMap<String, BTreeSet<String>>,
    names: (&str, &str),
) -> Vec<String> {
    a.iter()
        .filter_map(|(name, fa)| {
            let fb = b.get(name)?;
            (fa != fb).then(|| {
                format!(
                    "{name}: features only for {} {:?}, only for {} {:?}",
                    names.0,
                    fa.difference(fb).collect::<Vec<_>>(),
                    names.1,
                    fb.difference(fa).collect::<Vec<_>>()
                )
            })
        })
        .collect()
}

/// Fails when the CLI, the Python extension, xtask and the test suite resolve a shared crate
/// with other features (the `report` crate's own `png` excepted, module documentation).
pub fn check(root: &Path) -> Result<()> {
    let cli = features(root, "stiction-cli")?;
    let py = features(root, "stiction-python")?;
    let xtask = features(root, "xtask")?;
    let mut tests = test_features(root)?;
    // the tests' report has its default `png`; the CLI's (and xtask's) does not
    for (name, feats) in tests.iter_mut() {
        if name.starts_with("report v") {
            feats.remove("default");
            feats.remove("png");
        }
    }
    let mut diff = differences(&cli, &py, ("the CLI", "the Python extension"));
    diff.extend(differences(&cli, &xtask, ("the CLI", "xtask")));
    diff.extend(differences(&tests, &cli, ("the tests", "the CLI")));
    if !diff.is_empty() {
        for d in &diff {
            eprintln!("{d}");
        }
        bail!(
            "{} shared crate(s) would be compiled twice (for the CLI and `pip install ./python`, or for the tests and the gate's xtask and CLI): align the features in cli/Cargo.toml, python/Cargo.toml and xtask/Cargo.toml",
            diff.len()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_feature_on_one_side_only_is_a_difference() {
        let a = parse("num-complex v0.4.6|std\nsyn v2.0.1|full\nsyn v3.0.9|full\nfaer v0.24.4|\n");
        let b = parse(
            "num-complex v0.4.6|default,std\nsyn v2.0.1|full\nsyn v3.0.9|full,visit-mut\npyo3 v0.30.0 (/x)|\n",
        );
        let d = differences(&a, &b, ("the CLI", "the Python extension"));
        assert_eq!(d.len(), 2, "{d:?}");
        assert!(d[0].starts_with("num-complex v0.4.6:") && d[0].contains("\"default\""));
        assert!(
            d[1].starts_with("syn v3.0.9:") && d[1].contains("\"visit-mut\""),
            "{d:?}"
        );
        assert!(
            d[0].contains("only for the CLI []")
                && d[0].contains("the Python extension [\"default\"]"),
            "{d:?}"
        );
        assert!(differences(&a, &a, ("a", "b")).is_empty());
    }
}
