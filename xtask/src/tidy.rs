//! The workspace's rules from ARCHITECTURE.md, checked on the source text (run by
//! `cargo xtask test` through this module's test):
//!
//! * only `cli` (and `xtask`, examples, benches, tests) prints: no `println!`, `eprintln!`,
//!   `print!`, `eprint!` or `dbg!` in a library crate's `src/` outside its `#[cfg(test)]` part;
//! * no faer or nalgebra type in a public signature of a library crate (they are
//!   implementation details: `pub` items never name them);
//! * every public error enum of a library crate (`pub enum ...Error`) is `#[non_exhaustive]`;
//! * the layer order: each workspace member's `Cargo.toml` (and `python/Cargo.toml`, a workspace
//!   of its own) names in `[dependencies]` (target-specific ones too; not dev-dependencies)
//!   only crates of a lower layer of ARCHITECTURE.md's `layers` block, and every crate is in
//!   that block;
//! * ARCHITECTURE.md stays a map: at most [`ARCHITECTURE_MAX_BYTES`] bytes;
//! * no source file of a crate's `src/` over [`MAX_FILE_LINES`] lines, no function over
//!   [`MAX_FN_LINES`].

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The library crates the rules apply to.
pub const LIBRARIES: [&str; 11] = [
    "stiction-models",
    "linear-id",
    "grid-search",
    "datasets",
    "run",
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

/// Every rule on the workspace under `root`: the sources' rules, the layer order of the
/// manifests, the size of ARCHITECTURE.md and the lengths, sorted by file and line.
pub fn check_workspace(root: &Path) -> std::io::Result<Vec<Violation>> {
    let mut out = check_sources(root)?;
    out.extend(check_architecture(root)?.violations);
    out.extend(check_length_sources(root)?);
    out.sort_by(|a, b| (&a.file, a.line).cmp(&(&b.file, b.line)));
    Ok(out)
}

/// The rules on every `src/**/*.rs` of the library crates under `root`.
pub fn check_sources(root: &Path) -> std::io::Result<Vec<Violation>> {
    let mut out = Vec::new();
    for krate in LIBRARIES {
        for p in rust_files(&root.join(krate).join("src"))? {
            let text = std::fs::read_to_string(&p)?;
            out.extend(check_text(&p, &text));
        }
    }
    out.sort_by(|a, b| (&a.file, a.line).cmp(&(&b.file, b.line)));
    Ok(out)
}

/// Every `*.rs` file under `dir`.
fn rust_files(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let (mut files, mut stack) = (Vec::new(), vec![dir.to_path_buf()]);
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir)? {
            let p = entry?.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "rs") {
                files.push(p);
            }
        }
    }
    Ok(files)
}

/// The longest function allowed, in lines (from the line of `fn` to its closing brace).
pub const MAX_FN_LINES: usize = 150;

/// The longest source file allowed under a crate's `src/`, in lines.
pub const MAX_FILE_LINES: usize = 1000;

/// The crates whose `src/` the length rules read, besides [`LIBRARIES`].
const LENGTH_CRATES: [&str; 4] = ["cli", "xtask", "python", "examples/custom-model"];

/// The length rules on every `src/**/*.rs` of the workspace under `root`.
pub fn check_length_sources(root: &Path) -> std::io::Result<Vec<Violation>> {
    let mut out = Vec::new();
    for krate in LIBRARIES.iter().chain(&LENGTH_CRATES) {
        for p in rust_files(&root.join(krate).join("src"))? {
            out.extend(check_lengths(&p, &std::fs::read_to_string(&p)?));
        }
    }
    out.sort_by(|a, b| (&a.file, a.line).cmp(&(&b.file, b.line)));
    Ok(out)
}

/// The length rules on one source file's text: at most [`MAX_FILE_LINES`] lines, and no
/// function (its `fn` line to its closing brace) over [`MAX_FN_LINES`].
pub fn check_lengths(file: &Path, text: &str) -> Vec<Violation> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    if lines.len() > MAX_FILE_LINES {
        out.push(Violation {
            file: file.to_path_buf(),
            line: 1,
            what: format!(
                "{} lines, over {MAX_FILE_LINES}: split the file by what it does",
                lines.len()
            ),
        });
    }
    let mut i = 0;
    while i < lines.len() {
        let Some(name) = fn_name(lines[i]) else {
            i += 1;
            continue;
        };
        match body_end(&lines, i) {
            Some(end) => {
                let n = end - i + 1;
                if n > MAX_FN_LINES {
                    out.push(Violation {
                        file: file.to_path_buf(),
                        line: i + 1,
                        what: format!("function `{name}` of {n} lines, over {MAX_FN_LINES}"),
                    });
                }
                i = end + 1;
            }
            None => i += 1,
        }
    }
    out
}

/// The name of the function a line declares (`pub(crate) const unsafe fn name...`), if it
/// does.
fn fn_name(line: &str) -> Option<&str> {
    let mut rest = line.trim_start();
    if rest.starts_with("pub(") {
        rest = rest[rest.find(')')? + 1..].trim_start();
    }
    for word in ["pub ", "const ", "async ", "unsafe ", "extern \"C\" "] {
        if let Some(r) = rest.strip_prefix(word) {
            rest = r.trim_start();
        }
    }
    let rest = rest.strip_prefix("fn ")?;
    let name = rest
        .split(|c: char| !c.is_alphanumeric() && c != '_')
        .next()
        .filter(|n| !n.is_empty())?;
    Some(name)
}

/// The line of the brace that closes the body of the function declared at `start`, or `None`
/// for a declaration without a body (`fn f();`). Braces inside strings, character literals
/// and comments do not count.
fn body_end(lines: &[&str], start: usize) -> Option<usize> {
    let mut depth = 0usize;
    let mut opened = false;
    let mut in_block_comment = false;
    for (k, line) in lines.iter().enumerate().skip(start) {
        let b = line.as_bytes();
        let mut j = 0;
        let mut in_string = false;
        while j < b.len() {
            let c = b[j];
            if in_block_comment {
                if c == b'*' && b.get(j + 1) == Some(&b'/') {
                    in_block_comment = false;
                    j += 1;
                }
            } else if in_string {
                if c == b'\\' {
                    j += 1;
                } else if c == b'"' {
                    in_string = false;
                }
            } else {
                match c {
                    b'/' if b.get(j + 1) == Some(&b'/') => break,
                    b'/' if b.get(j + 1) == Some(&b'*') => in_block_comment = true,
                    b'"' => in_string = true,
                    // a character literal ('{', '\'', '\\'), not a lifetime ('a)
                    b'\'' if b.get(j + 2) == Some(&b'\'') => j += 2,
                    b'\'' if b.get(j + 1) == Some(&b'\\') => {
                        j += 2;
                        while j < b.len() && b[j] != b'\'' {
                            j += 1;
                        }
                    }
                    b'{' => {
                        depth += 1;
                        opened = true;
                    }
                    b'}' => {
                        depth = depth.saturating_sub(1);
                        if opened && depth == 0 {
                            return Some(k);
                        }
                    }
                    b';' if !opened && depth == 0 => return None,
                    _ => {}
                }
            }
            j += 1;
        }
    }
    None
}

/// ARCHITECTURE.md's size limit: a map, not a logbook (15 KiB).
pub const ARCHITECTURE_MAX_BYTES: usize = 15 * 1024;

/// The fence that opens the layer order in ARCHITECTURE.md.
const LAYERS_FENCE: &str = "```layers";

/// The layer order: each crate (by package name) and its layer, 0 the lowest.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layers {
    of: BTreeMap<String, usize>,
    /// The line of ARCHITECTURE.md where each crate is placed (1-based).
    line: BTreeMap<String, usize>,
}

impl Layers {
    /// Reads the ```` ```layers ```` block of ARCHITECTURE.md: one line per layer from the
    /// lowest, `N: crate crate ...`, the layers numbered 0, 1, 2, ... in order.
    pub fn parse(architecture: &str) -> Result<Layers, String> {
        let lines: Vec<&str> = architecture.lines().collect();
        let start = lines
            .iter()
            .position(|l| l.trim() == LAYERS_FENCE)
            .ok_or_else(|| format!("no {LAYERS_FENCE} block"))?;
        let mut of = BTreeMap::new();
        let mut line = BTreeMap::new();
        for (due, (i, l)) in lines.iter().enumerate().skip(start + 1).enumerate() {
            let l = l.trim();
            if l == "```" {
                if of.is_empty() {
                    return Err("the layers block is empty".into());
                }
                return Ok(Layers { of, line });
            }
            let (n, crates) = l
                .split_once(':')
                .ok_or_else(|| format!("line {}: expected `N: crate ...`", i + 1))?;
            let n: usize = n
                .trim()
                .parse()
                .map_err(|_| format!("line {}: {n:?} is not a layer number", i + 1))?;
            if n != due {
                return Err(format!("line {}: layer {n} where {due} was due", i + 1));
            }
            for c in crates.split_whitespace() {
                if of.insert(c.to_string(), n).is_some() {
                    return Err(format!("line {}: `{c}` is placed twice", i + 1));
                }
                line.insert(c.to_string(), i + 1);
            }
        }
        Err("the layers block is not closed".into())
    }

    /// The layer of a crate, if it is placed.
    pub fn of(&self, krate: &str) -> Option<usize> {
        self.of.get(krate).copied()
    }
}

/// What the layer check found.
#[derive(Debug, Default)]
pub struct LayerCheck {
    /// The broken rules.
    pub violations: Vec<Violation>,
    /// How many dependencies between our crates were checked.
    pub edges: usize,
}

/// One manifest's dependencies on crates of the layer order, against it. `workspace_deps`
/// resolves `name.workspace = true` to the workspace's entry (its `package` when renamed).
pub fn check_manifest(
    file: &Path,
    text: &str,
    layers: &Layers,
    workspace_deps: &BTreeMap<String, String>,
) -> LayerCheck {
    let mut out = LayerCheck::default();
    let mut push = |line: usize, what: String| {
        out.violations.push(Violation {
            file: file.to_path_buf(),
            line,
            what,
        })
    };
    let doc = match toml_edit::Document::parse(text) {
        Ok(d) => d,
        Err(e) => {
            push(1, format!("not a TOML manifest: {e}"));
            return out;
        }
    };
    let Some(name) = doc
        .get("package")
        .and_then(|p| p.get("name"))
        .and_then(|n| n.as_str())
    else {
        push(1, "no [package] name".into());
        return out;
    };
    let Some(own) = layers.of(name) else {
        push(
            1,
            format!("crate `{name}` is not in ARCHITECTURE.md's layers block"),
        );
        return out;
    };
    let mut tables = vec![doc.get("dependencies")];
    if let Some(targets) = doc.get("target").and_then(|t| t.as_table_like()) {
        for (_, t) in targets.iter() {
            tables.push(t.get("dependencies"));
        }
    }
    for deps in tables.into_iter().flatten() {
        let Some(deps) = deps.as_table_like() else {
            continue;
        };
        for (key, spec) in deps.iter() {
            let renamed = spec.get("package").and_then(|p| p.as_str());
            let from_workspace = spec
                .get("workspace")
                .and_then(|w| w.as_bool())
                .unwrap_or(false);
            let dep = match renamed {
                Some(p) => p,
                None if from_workspace => workspace_deps.get(key).map_or(key, String::as_str),
                None => key,
            };
            let Some(theirs) = layers.of(dep) else {
                continue;
            };
            out.edges += 1;
            if theirs >= own {
                let line = line_of(text, key);
                push(
                    line,
                    format!(
                        "`{name}` (layer {own}) depends on `{dep}` (layer {theirs}): only lower layers \
                         (ARCHITECTURE.md's layers block)"
                    ),
                );
            }
        }
    }
    out
}

/// The first line (1-based) that starts with the dependency `key`, else 1.
fn line_of(text: &str, key: &str) -> usize {
    text.lines()
        .position(|l| {
            l.trim_start()
                .strip_prefix(key)
                .is_some_and(|rest| rest.starts_with([' ', '.', '=']))
        })
        .map_or(1, |i| i + 1)
}

/// ARCHITECTURE.md's size as a rule.
pub fn check_size(file: &Path, text: &str) -> Option<Violation> {
    (text.len() > ARCHITECTURE_MAX_BYTES).then(|| Violation {
        file: file.to_path_buf(),
        line: 1,
        what: format!(
            "{} bytes, more than {ARCHITECTURE_MAX_BYTES}: ARCHITECTURE.md is a map (move \
             measurements and history to docs/decisions/)",
            text.len()
        ),
    })
}

/// The layer order and the size rule on the workspace under `root`: every member and every
/// excluded crate of the root manifest (python) against ARCHITECTURE.md's layers block.
pub fn check_architecture(root: &Path) -> std::io::Result<LayerCheck> {
    let arch_path = root.join("ARCHITECTURE.md");
    let arch = std::fs::read_to_string(&arch_path)?;
    let mut out = LayerCheck::default();
    out.violations.extend(check_size(&arch_path, &arch));
    let layers = match Layers::parse(&arch) {
        Ok(l) => l,
        Err(e) => {
            out.violations.push(Violation {
                file: arch_path,
                line: 1,
                what: e,
            });
            return Ok(out);
        }
    };
    let root_manifest = root.join("Cargo.toml");
    let text = std::fs::read_to_string(&root_manifest)?;
    let doc = toml_edit::Document::parse(text.as_str())
        .map_err(|e| std::io::Error::other(format!("{}: {e}", root_manifest.display())))?;
    let ws = doc.get("workspace");
    let list = |key: &str| -> Vec<String> {
        ws.and_then(|w| w.get(key))
            .and_then(|m| m.as_array())
            .map(|a| {
                a.iter()
                    .filter_map(|v| v.as_str().map(String::from))
                    .collect()
            })
            .unwrap_or_default()
    };
    let mut workspace_deps = BTreeMap::new();
    if let Some(deps) = ws
        .and_then(|w| w.get("dependencies"))
        .and_then(|d| d.as_table_like())
    {
        for (key, spec) in deps.iter() {
            let name = spec.get("package").and_then(|p| p.as_str()).unwrap_or(key);
            workspace_deps.insert(key.to_string(), name.to_string());
        }
    }
    let mut placed = Vec::new();
    for dir in list("members").into_iter().chain(list("exclude")) {
        let manifest = root.join(&dir).join("Cargo.toml");
        let text = std::fs::read_to_string(&manifest)?;
        let check = check_manifest(&manifest, &text, &layers, &workspace_deps);
        out.violations.extend(check.violations);
        out.edges += check.edges;
        if let Some(name) = toml_edit::Document::parse(text.as_str())
            .ok()
            .and_then(|d| Some(d.get("package")?.get("name")?.as_str()?.to_string()))
        {
            placed.push(name);
        }
    }
    for (krate, line) in &layers.line {
        if !placed.contains(krate) {
            out.violations.push(Violation {
                file: arch_path.clone(),
                line: *line,
                what: format!(
                    "the layers block places `{krate}`, which is no crate of the workspace"
                ),
            });
        }
    }
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
    fn the_length_rules_count_functions_and_files() {
        let f = Path::new("x.rs");
        let body = |n: usize| "    let x = 1;\n".repeat(n);
        // 150 lines in all (the `fn` line, 148 of body, the closing brace): allowed
        let at_limit = format!("pub(crate) fn f() {{\n{}}}\n", body(148));
        assert!(check_lengths(f, &at_limit).is_empty());
        let over = format!("fn long() {{\n{}}}\nfn short() {{}}\n", body(149));
        let v = check_lengths(f, &over);
        assert_eq!(v.len(), 1, "{v:?}");
        assert_eq!(
            (v[0].line, v[0].what.contains("`long` of 151 lines")),
            (1, true)
        );
        // braces in strings, characters and comments do not close the body early
        let tricky = format!(
            "fn g() {{\n    let s = \"}}\";\n    let c = '}}';\n    // }}\n{}}}\n",
            body(148)
        );
        assert_eq!(check_lengths(f, &tricky).len(), 1);
        let declaration = "trait T {\n    fn f(&self);\n}\n";
        assert!(check_lengths(f, declaration).is_empty());
        let long_file = "// x\n".repeat(MAX_FILE_LINES + 1);
        assert_eq!(check_lengths(f, &long_file).len(), 1);
        assert!(check_lengths(f, &"// x\n".repeat(MAX_FILE_LINES)).is_empty());
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

    #[test]
    fn the_layer_order_is_read_and_enforced_on_the_workspace() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let arch = std::fs::read_to_string(root.join("ARCHITECTURE.md")).expect("the map");
        let layers = Layers::parse(&arch).expect("ARCHITECTURE.md's layers block");
        assert_eq!(layers.of("stiction-models"), Some(0));
        assert!(layers.of("stiction-cli") > layers.of("monitoring"));
        let check = check_architecture(&root).expect("read the manifests");
        // Every dependency between our crates was looked at (not a vacuous pass).
        assert!(check.edges >= 40, "only {} edges checked", check.edges);
        let list: Vec<String> = check.violations.iter().map(ToString::to_string).collect();
        assert!(list.is_empty(), "layer order broken:\n{}", list.join("\n"));
    }

    const MAP: &str = "# A\n\n```layers\n0: low other\n1: mid\n2: top\n```\n";

    fn manifest(deps: &str) -> String {
        format!("[package]\nname = \"mid\"\n\n[dependencies]\n{deps}\n")
    }

    fn broken(text: &str) -> Vec<Violation> {
        let layers = Layers::parse(MAP).expect("the test map");
        let ws = BTreeMap::from([("alias".to_string(), "top".to_string())]);
        check_manifest(Path::new("mid/Cargo.toml"), text, &layers, &ws).violations
    }

    #[test]
    fn an_upward_or_sideways_dependency_is_caught() {
        assert!(broken(&manifest("low.workspace = true\nserde = \"1\"")).is_empty());
        let up = broken(&manifest("serde = \"1\"\ntop.workspace = true"));
        assert_eq!(up.len(), 1, "{up:?}");
        assert_eq!(up[0].line, 6, "the line of the dependency");
        assert!(up[0].what.contains("depends on `top`"), "{}", up[0].what);
        let inline = broken(&manifest("top = { path = \"../top\" }"));
        assert_eq!(inline.len(), 1, "a path dependency");
        let renamed = broken(&manifest("t = { package = \"top\", path = \"../top\" }"));
        assert_eq!(renamed.len(), 1, "a renamed dependency");
        let via_workspace = broken(&manifest("alias.workspace = true"));
        assert_eq!(via_workspace.len(), 1, "a renamed workspace dependency");
        let same = broken(&manifest("mid2 = \"1\""));
        assert!(same.is_empty(), "not one of ours");
        let target =
            "[package]\nname = \"mid\"\n\n[target.'cfg(unix)'.dependencies]\ntop = \"1\"\n";
        assert_eq!(broken(target).len(), 1, "a target-specific dependency");
        let dev = "[package]\nname = \"mid\"\n\n[dev-dependencies]\ntop = \"1\"\n";
        assert!(broken(dev).is_empty(), "dev-dependencies are free");
        let layers = Layers::parse(MAP).expect("the test map");
        let low = "[package]\nname = \"low\"\n\n[dependencies]\nother = \"1\"\n";
        let sideways = check_manifest(Path::new("x"), low, &layers, &BTreeMap::new());
        assert_eq!(
            sideways.violations.len(),
            1,
            "the same layer is not allowed"
        );
        let unplaced = "[package]\nname = \"new\"\n";
        let v = check_manifest(Path::new("x"), unplaced, &layers, &BTreeMap::new());
        assert_eq!(v.violations.len(), 1, "a crate outside the layers block");
    }

    #[test]
    fn a_bad_layers_block_is_refused() {
        assert!(Layers::parse("no block").is_err());
        assert!(Layers::parse("```layers\n0: a\n0: b\n```").is_err());
        assert!(Layers::parse("```layers\n0: a\n1: a\n```").is_err());
        assert!(Layers::parse("```layers\n0: a\n").is_err());
        assert!(Layers::parse("```layers\nx: a\n```").is_err());
        let l = Layers::parse("```layers\n0: a b\n1: c\n```").expect("a good block");
        assert_eq!(
            (l.of("a"), l.of("b"), l.of("c"), l.of("d")),
            (Some(0), Some(0), Some(1), None)
        );
    }

    #[test]
    fn the_map_stays_small() {
        let f = Path::new("ARCHITECTURE.md");
        assert!(check_size(f, &"x".repeat(ARCHITECTURE_MAX_BYTES)).is_none());
        assert!(check_size(f, &"x".repeat(ARCHITECTURE_MAX_BYTES + 1)).is_some());
    }
}
