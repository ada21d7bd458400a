//! One build for both front ends: the CLI (`stiction-cli`) and the Python extension
//! (`stiction-python`) must resolve every crate they share with the same features, or `pip
//! install ./python` after the CLI's build compiles that crate and everything above it again
//! (cli/Cargo.toml and python/Cargo.toml carry the dependencies that keep them equal).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

use anyhow::{bail, Context, Result};

/// Each crate (name and version) of `package`'s normal and build dependency graph with its
/// enabled features, as `cargo tree --format "{p}|{f}"` lists them.
fn features(root: &Path, package: &str) -> Result<BTreeMap<String, BTreeSet<String>>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .current_dir(root)
        .args([
            "tree",
            "--quiet",
            "-p",
            package,
            "-e",
            "normal,build",
            "--prefix",
            "none",
            "--no-dedupe",
            "--format",
            "{p}|{f}",
        ])
        .output()
        .context("running cargo tree")?;
    if !out.status.success() {
        bail!(
            "cargo tree -p {package}: {}",
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
                .filter(|f| !f.is_empty())
                .map(str::to_string),
        );
    }
    map
}

/// The shared crates whose features differ between the two front ends, one line each.
pub fn differences(
    a: &BTreeMap<String, BTreeSet<String>>,
    b: &BTreeMap<String, BTreeSet<String>>,
) -> Vec<String> {
    a.iter()
        .filter_map(|(name, fa)| {
            let fb = b.get(name)?;
            (fa != fb).then(|| {
                format!(
                    "{name}: features only for the CLI {:?}, only for the Python extension {:?}",
                    fa.difference(fb).collect::<Vec<_>>(),
                    fb.difference(fa).collect::<Vec<_>>()
                )
            })
        })
        .collect()
}

/// Fails when the CLI and the Python extension resolve a shared crate with other features.
pub fn check(root: &Path) -> Result<()> {
    let cli = features(root, "stiction-cli")?;
    let py = features(root, "stiction-python")?;
    let diff = differences(&cli, &py);
    if !diff.is_empty() {
        for d in &diff {
            eprintln!("{d}");
        }
        bail!(
            "{} crate(s) would be compiled twice, once for the CLI and once for `pip install ./python`: align the features in cli/Cargo.toml and python/Cargo.toml",
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
        let d = differences(&a, &b);
        assert_eq!(d.len(), 2, "{d:?}");
        assert!(d[0].starts_with("num-complex v0.4.6:") && d[0].contains("\"default\""));
        assert!(
            d[1].starts_with("syn v3.0.9:") && d[1].contains("\"visit-mut\""),
            "{d:?}"
        );
        assert!(differences(&a, &a).is_empty());
    }
}
