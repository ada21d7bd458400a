//! One build for both front ends: the CLI (`stiction-cli`) and the Python extension
//! (`stiction-python`) must resolve every crate they share with the same features, or `pip
//! install ./python` after the CLI's build compiles that crate and everything above it again
//! (cli/Cargo.toml and python/Cargo.toml carry the dependencies that keep them equal).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

use anyhow::{bail, Context, Result};

/// Each crate of `package`'s normal and build dependency graph with its enabled features, as
/// `cargo tree -e features,normal,build` lists them.
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
            "features,normal,build",
            "--prefix",
            "none",
            "--no-dedupe",
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

/// `name v1.2.3 ...` lines name a crate, `name feature "f"` lines one of its features.
fn parse(tree: &str) -> BTreeMap<String, BTreeSet<String>> {
    let mut map: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for line in tree.lines() {
        let mut words = line.split_whitespace();
        let (Some(name), Some(second)) = (words.next(), words.next()) else {
            continue;
        };
        let entry = map.entry(name.to_string()).or_default();
        if second == "feature" {
            if let Some(f) = words.next() {
                entry.insert(f.trim_matches('"').to_string());
            }
        }
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
        let a = parse("num-complex v0.4.6\nnum-complex feature \"std\"\nfaer v0.24.4\n");
        let b = parse(
            "num-complex v0.4.6\nnum-complex feature \"std\"\nnum-complex feature \"default\"\npyo3 v0.30.0\n",
        );
        let d = differences(&a, &b);
        assert_eq!(d.len(), 1, "{d:?}");
        assert!(d[0].starts_with("num-complex:") && d[0].contains("\"default\""));
        assert!(differences(&a, &a).is_empty());
    }
}
