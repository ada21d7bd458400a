//! Input limits: how much the readers accept before refusing, with one clear line.
//!
//! A reader that trusts its input reads `/dev/zero` until memory runs out, echoes a 1 GB cell
//! into its error message and grinds through 10 M rows for minutes. The limits below are
//! checked while the bytes come in (before anything is parsed), and errors quote at most a
//! short excerpt of a bad cell ([`excerpt`]).
//!
//! Defaults (generous for historian exports: 751 rows is a typical registration, a day at
//! 1 s is 86 400): 1 000 000 data rows, 1 MiB per line, 64 KiB per cell, 512 MiB per file.
//! The row limit is the one a user may want to change (`--max-rows`).

use std::io::Read;

use crate::DataError;

/// Limits of [`crate::read_csv`] and [`crate::read_mat`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct Limits {
    /// Most bytes read from one file or stream.
    pub max_bytes: u64,
    /// Longest line (CSV), bytes.
    pub max_line: usize,
    /// Longest cell (CSV), bytes.
    pub max_cell: usize,
    /// Most data rows (CSV; MATLAB: samples).
    pub max_rows: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_bytes: 512 << 20,
            max_line: 1 << 20,
            max_cell: 64 << 10,
            max_rows: 1_000_000,
        }
    }
}

/// At most 40 characters of `text` for a message, with its length when cut.
pub fn excerpt(text: &str) -> String {
    const KEEP: usize = 32;
    if text.chars().count() <= 40 {
        return text.to_string();
    }
    let head: String = text.chars().take(KEEP).collect();
    format!("{head}… ({} bytes)", text.len())
}

/// Read all of `reader`, refusing (as soon as it is seen) more than `max_bytes`, a line longer
/// than `max_line` bytes (when `lines`), or more than `max_rows + 1` lines (header included).
pub(crate) fn read_limited(
    mut reader: impl Read,
    file: &str,
    limits: &Limits,
    lines: bool,
) -> Result<Vec<u8>, DataError> {
    let mut bytes = Vec::new();
    let mut buf = vec![0u8; 64 << 10];
    let mut line_len = 0usize;
    let mut line_count = 0usize;
    loop {
        let n = match reader.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(error) => {
                return Err(DataError::Io {
                    file: file.to_string(),
                    error,
                })
            }
        };
        if bytes.len() as u64 + n as u64 > limits.max_bytes {
            return Err(DataError::Limit {
                file: file.to_string(),
                what: format!(
                    "more than {} MiB of input (the limit)",
                    limits.max_bytes >> 20
                ),
            });
        }
        if lines {
            for &b in &buf[..n] {
                if b == b'\n' {
                    line_count += 1;
                    line_len = 0;
                    if line_count > limits.max_rows.saturating_add(1) {
                        return Err(DataError::Limit {
                            file: file.to_string(),
                            what: format!(
                                "more than {} data rows (the limit; raise it with --max-rows)",
                                limits.max_rows
                            ),
                        });
                    }
                } else {
                    line_len += 1;
                    if line_len > limits.max_line {
                        return Err(DataError::Limit {
                            file: file.to_string(),
                            what: format!(
                                "line {} is longer than {} KiB (the limit): not a table of numbers",
                                line_count + 1,
                                limits.max_line >> 10
                            ),
                        });
                    }
                }
            }
        }
        bytes.extend_from_slice(&buf[..n]);
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn excerpts_are_short() {
        assert_eq!(excerpt("abc"), "abc");
        let long = "x".repeat(1000);
        let e = excerpt(&long);
        assert!(e.len() < 60 && e.ends_with("(1000 bytes)"), "{e}");
    }

    #[test]
    fn endless_input_stops_at_the_first_limit() {
        let zeros = std::io::repeat(0).take(10 << 30);
        let e = read_limited(zeros, "z", &Limits::default(), true).unwrap_err();
        assert!(e.to_string().contains("longer than 1024 KiB"), "{e}");
        let lines = std::io::repeat(b'\n').take(10 << 30);
        let e = read_limited(lines, "z", &Limits::default(), true).unwrap_err();
        assert!(e.to_string().contains("more than 1000000 data rows"), "{e}");
        let l = Limits {
            max_bytes: 1000,
            ..Limits::default()
        };
        let e = read_limited(std::io::repeat(b'1').take(5000), "z", &l, false).unwrap_err();
        assert!(e.to_string().contains("MiB of input"), "{e}");
    }
}
