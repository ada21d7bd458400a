//! Every example in the help text (`cli/help/*.txt`) is a command the CLI accepts: the help
//! cannot advertise a flag that was renamed or a value that is refused.

use std::path::Path;

/// The `stiction ...` command lines of a help file, without pipes and redirections.
fn examples(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .skip_while(|l| l.trim() != "Examples:")
        .filter_map(|l| l.split_once("stiction ").map(|(_, rest)| rest))
        .map(|rest| {
            let cmd = rest.split(['|', '>']).next().unwrap_or_default();
            std::iter::once("stiction".to_string())
                .chain(cmd.split_whitespace().map(str::to_string))
                .collect()
        })
        .collect()
}

#[test]
fn every_help_example_parses() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("help");
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).expect("cli/help") {
        let path = entry.expect("entry").path();
        let text = std::fs::read_to_string(&path).expect("help text");
        let lines = examples(&text);
        assert!(!lines.is_empty(), "{}: no example", path.display());
        for args in lines {
            if let Err(e) = stiction_cli::parse(&args) {
                panic!("{}: `{}` is refused:\n{e}", path.display(), args.join(" "));
            }
            checked += 1;
        }
    }
    assert!(checked >= 30, "only {checked} examples found");
}
