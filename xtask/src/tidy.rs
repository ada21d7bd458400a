//! The workspace's rules from ARCHITECTURE.md, checked on the source text (run by
//! `cargo xtask test` through this module's test):
//!
//! * only `cli` (and `xtask`, examples, benches, tests) prints: no `println!`, `eprintln!`,
//!   `print!`, `eprint!` or `dbg!` in a library crate's `src/` outside its `#[cfg(test)]` part;
//! * no faer or nalgebra type in a public signature of a library crate (they are
//!   implementation details: `pub` items never name them);
//! * every public error enum of a library crate (`pub enum ...Error`) is `#[non_exhaustive]`.

use std::path::{Path, PathBuf};

/// The library crates the rules apply to.
pub const LIBRARIES: [&str; 10] = [
    "stiction-models",
    "linear-id",
    "grid-search",
    "datasets",
    "monitoring",
    "detection",
    "discrepancy",
    "report",
    "repair",
    "audit",
];

/// One broken rule: file, line (1-based) and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Violation {
    /// The file.
    pub file: PathBuf,
    /// The line, 1-based.
    pub line: usize,
    /// The rule broken.
    pub what: String,
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}: {}", self.file.display(), self.line, self.what)
    }
}

/// The rules on one library source file's text.
pub fn check_text(file: &Path, text: &str) -> Vec<Violation> {
    let mut out = Vec::new();
    let mut push = |line: usize, what: String| {
        out.push(Violation {
            file: file.to_path_buf(),
            line,
            what,
        })
    };
    let lines: Vec<&str> = text.lines().collect();
    // Test modules sit at the end of a file, after `#[cfg(test)]`.
    let end = lines
        .iter()
        .position(|l| l.trim() == "#[cfg(test)]")
        .unwrap_or(lines.len());
    let mut in_pub_signature = false;
    for (i, raw) in lines[..end].iter().enumerate() {
        let l = raw.trim_start();
        if l.starts_with("//") {
            continue;
        }
        for mac in ["println!", "eprintln!", "print!", "eprint!", "dbg!"] {
            let found = l.match_indices(mac).any(|(k, _)| {
                // `eprintln!` contains `println!`; count the macro only at a word start.
                k == 0 || !l.as_bytes()[k - 1].is_ascii_alphanumeric()
            });
            if found {
                push(
                    i + 1,
                    format!("`{mac}` in a library crate (only the CLI prints)"),
                );
            }
        }
        let starts_pub = l.starts_with("pub ") && !l.starts_with("pub(");
        if starts_pub && (l.contains("fn ") || l.contains("type ") || l.contains("struct ")) {
            in_pub_signature = true;
        }
        let is_pub_field = l.starts_with("pub ") && l.contains(':') && !l.contains("fn ");
        if (in_pub_signature || is_pub_field) && (l.contains("faer::") || l.contains("nalgebra::"))
        {
            push(
                i + 1,
                "faer or nalgebra type in a public signature (keep them inside the crate)".into(),
            );
        }
        if in_pub_signature && (l.contains('{') || l.ends_with(';')) {
            in_pub_signature = false;
        }
        if starts_pub && l.starts_with("pub enum ") {
            let name = l["pub enum ".len()..]
                .split(|c: char| !c.is_alphanumeric() && c != '_')
                .next()
                .unwrap_or("");
            if name.ends_with("Error") {
                let attrs = lines[..i]
                    .iter()
                    .rev()
                    .take_while(|p| {
                        let p = p.trim_start();
                        p.starts_with("#[") || p.starts_with("///") || p.starts_with("//")
                    })
                    .any(|p| p.trim() == "#[non_exhaustive]");
                if !attrs {
                    push(
                        i + 1,
                        format!("error enum `{name}` is not #[non_exhaustive]"),
                    );
                }
            }
        }
    }
    out
}

/// The rules on every `src/**/*.rs` of the library crates under `root`.
pub fn check_workspace(root: &Path) -> std::io::Result<Vec<Violation>> {
    let mut out = Vec::new();
    for krate in LIBRARIES {
        let mut stack = vec![root.join(krate).join("src")];
        while let Some(dir) = stack.pop() {
            for entry in std::fs::read_dir(&dir)? {
                let p = entry?.path();
                if p.is_dir() {
                    stack.push(p);
                } else if p.extension().is_some_and(|e| e == "rs") {
                    let text = std::fs::read_to_string(&p)?;
                    out.extend(check_text(&p, &text));
                }
            }
        }
    }
    out.sort_by(|a, b| (&a.file, a.line).cmp(&(&b.file, b.line)));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_workspace_keeps_its_rules() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let v = check_workspace(&root).expect("read the sources");
        let list: Vec<String> = v.iter().map(ToString::to_string).collect();
        assert!(
            list.is_empty(),
            "ARCHITECTURE.md's rules broken:\n{}",
            list.join("\n")
        );
    }

    #[test]
    fn each_rule_catches_its_breach() {
        let f = Path::new("x.rs");
        let bad_print = "fn f() {\n    println!(\"hi\");\n}\n";
        assert_eq!(check_text(f, bad_print).len(), 1);
        let eprint = "fn f() { eprintln!(\"hi\"); }\n";
        assert_eq!(check_text(f, eprint).len(), 1, "eprintln counts once");
        let in_test = "#[cfg(test)]\nmod tests {\n    fn f() { println!(\"ok\"); }\n}\n";
        assert!(check_text(f, in_test).is_empty());
        let faer_sig = "pub fn solve(\n    a: faer::Mat<f64>,\n) -> f64 {\n    0.0\n}\n";
        assert_eq!(check_text(f, faer_sig).len(), 1);
        let faer_field = "pub struct S {\n    pub m: nalgebra::DMatrix<f64>,\n}\n";
        assert_eq!(check_text(f, faer_field).len(), 1);
        let private = "fn solve(a: faer::Mat<f64>) -> f64 {\n    0.0\n}\n";
        assert!(check_text(f, private).is_empty());
        let open_error = "/// E.\n#[derive(Debug)]\npub enum MyError {\n    A,\n}\n";
        assert_eq!(check_text(f, open_error).len(), 1);
        let closed = "/// E.\n#[derive(Debug)]\n#[non_exhaustive]\npub enum MyError {\n    A,\n}\n";
        assert!(check_text(f, closed).is_empty());
    }
}
