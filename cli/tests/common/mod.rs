//! Running the CLI in memory.
#![allow(dead_code)]

use stiction_cli::{run_from, Streams};

/// Exit status, stdout and stderr of one run.
pub struct Out {
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
}

/// Run `stiction ARGS` with `stdin`.
pub fn run(args: &[&str], stdin: &[u8]) -> Out {
    let mut input = stdin;
    let mut out = Vec::new();
    let mut err = Vec::new();
    let mut streams = Streams {
        stdin: &mut input,
        stdout: &mut out,
        stderr: &mut err,
        progress: false,
    };
    let mut all = vec!["stiction"];
    all.extend_from_slice(args);
    let code = run_from(all, &mut streams);
    Out {
        code,
        stdout: String::from_utf8_lossy(&out).into_owned(),
        stderr: String::from_utf8_lossy(&err).into_owned(),
    }
}

/// The column `name` of a CSV text, as numbers.
pub fn column(csv: &str, name: &str) -> Vec<f64> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let idx = header.iter().position(|h| *h == name).expect("column");
    lines
        .map(|l| {
            l.split(',')
                .nth(idx)
                .expect("cell")
                .parse()
                .expect("number")
        })
        .collect()
}
