//! The report: one self-contained `index.html` (styles and SVG inline, no script, nothing
//! fetched) plus each figure as its own file.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::chart::svg_to_png;
use crate::figures::Figure;
use crate::ReportError;

/// A piece of a section.
#[derive(Debug, Clone)]
pub enum Block {
    /// A paragraph of text.
    Paragraph(String),
    /// A highlighted note (warnings, refusals).
    Note(String),
    /// The verdict a person acts on: one prominent box, the first thing a section says.
    Verdict(String),
    /// A bulleted list.
    List(Vec<String>),
    /// A table: header and rows (cells as text).
    Table {
        /// Column headers.
        header: Vec<String>,
        /// Rows.
        rows: Vec<Vec<String>>,
    },
    /// Name/value pairs.
    Facts(Vec<(String, String)>),
    /// A figure.
    Figure(Figure),
    /// Paragraphs collapsed under a one-line summary (`<details>`): explanations a reader
    /// opens when they want them.
    Details {
        /// The line shown while collapsed.
        summary: String,
        /// The paragraphs shown when opened.
        paragraphs: Vec<String>,
    },
}

/// A titled section.
#[derive(Debug, Clone)]
pub struct Section {
    /// Heading.
    pub heading: String,
    /// Content, in order.
    pub blocks: Vec<Block>,
}

impl Section {
    /// An empty section.
    pub fn new(heading: impl Into<String>) -> Section {
        Section {
            heading: heading.into(),
            blocks: Vec::new(),
        }
    }

    /// Append a block.
    pub fn push(&mut self, b: Block) -> &mut Self {
        self.blocks.push(b);
        self
    }
}

/// A whole report.
#[derive(Debug, Clone)]
pub struct Report {
    /// Page title and first heading.
    pub title: String,
    /// One line under the title: the data and the command.
    pub subtitle: String,
    /// The summary paragraph(s) for the engineer.
    pub summary: Vec<String>,
    /// Sections.
    pub sections: Vec<Section>,
}

/// Options of [`Report::write`].
#[derive(Debug, Clone, Copy, Default)]
pub struct WriteOptions {
    /// Also write each figure as PNG.
    pub png: bool,
}

/// What [`Report::write`] wrote.
#[derive(Debug, Clone)]
pub struct Written {
    /// The page.
    pub index: PathBuf,
    /// The figure files.
    pub files: Vec<PathBuf>,
    /// Bytes written in all.
    pub bytes: u64,
}

/// Escape text for HTML.
pub fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            c => o.push(c),
        }
    }
    o
}

const STYLE: &str = "\
html{font-size:16px}\
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,'DejaVu Sans',sans-serif;\
max-width:1400px;margin:1.5em auto;padding:0 1em;color:#1a1a1a;line-height:1.45}\
p,ul,dl.facts,details,.note,.summary{max-width:62rem}\
h1{font-size:1.6em;margin-bottom:.2em}h2{font-size:1.3em;margin-top:1.8em;\
border-bottom:1px solid #ddd;padding-bottom:.2em}.sub{color:#555;margin-top:0}\
.summary{background:#f4f7fb;border-left:4px solid #1f77b4;padding:.6em 1em}\
.note{background:#fff6e5;border-left:4px solid #e67814;padding:.5em 1em}\
.verdict{background:#fff;border:2px solid #1a1a1a;border-radius:6px;padding:.7em 1em;\
font-size:1.2em;font-weight:600;margin:1em 0;max-width:62rem}\
details{margin:.6em 0}details>summary{cursor:pointer;color:#1f4f8f;font-weight:600}\
table{border-collapse:collapse;margin:.8em 0;font-size:.95em}\
th,td{border:1px solid #ccc;padding:.25em .6em;text-align:right;vertical-align:top}\
th{background:#f0f0f0}td:first-child,th:first-child{text-align:left}\
td.t,th.t{text-align:left}td.nw{white-space:nowrap}\
dl.facts{display:grid;grid-template-columns:max-content auto;gap:.15em 1.2em}\
dl.facts dt{color:#555}dl.facts dd{margin:0}\
figure{margin:1.2em 0}figure svg{width:100%;height:auto;display:block}\
figcaption{font-size:.95em;color:#333;margin-top:.3em;max-width:62rem}\
footer{margin-top:3em;color:#666;font-size:.9em}";

/// Whether a table cell reads as a number or a numeric range (`1.20`, `-0.5`, `0.10-0.30`,
/// `-`, empty): such columns are right-aligned.
fn numeric_cell(c: &str) -> bool {
    let c = c.trim();
    c.is_empty()
        || c == "-"
        || c.parse::<f64>().is_ok()
        || c.split_once('-').is_some_and(|(a, b)| {
            !a.is_empty() && a.trim().parse::<f64>().is_ok() && b.trim().parse::<f64>().is_ok()
        })
}

/// The SVG document without an XML prolog, for inlining.
fn inline_svg(svg: &str) -> &str {
    match svg.find("<svg") {
        Some(i) => &svg[i..],
        None => svg,
    }
}

impl Report {
    /// The page as HTML.
    pub fn to_html(&self, png: bool) -> String {
        let mut h = String::new();
        let _ = write!(
            h,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
             <title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{}</h1>\n\
             <p class=\"sub\">{}</p>\n",
            escape(&self.title),
            escape(&self.title),
            escape(&self.subtitle)
        );
        if !self.summary.is_empty() {
            h.push_str("<div class=\"summary\">\n");
            for p in &self.summary {
                let _ = writeln!(h, "<p>{}</p>", escape(p));
            }
            h.push_str("</div>\n");
        }
        for s in &self.sections {
            let _ = writeln!(h, "<h2>{}</h2>", escape(&s.heading));
            for b in &s.blocks {
                match b {
                    Block::Paragraph(p) => {
                        let _ = writeln!(h, "<p>{}</p>", escape(p));
                    }
                    Block::Note(p) => {
                        let _ = writeln!(h, "<p class=\"note\">{}</p>", escape(p));
                    }
                    Block::Verdict(p) => {
                        let _ = writeln!(h, "<p class=\"verdict\">{}</p>", escape(p));
                    }
                    Block::List(items) => {
                        h.push_str("<ul>\n");
                        for i in items {
                            let _ = writeln!(h, "<li>{}</li>", escape(i));
                        }
                        h.push_str("</ul>\n");
                    }
                    Block::Table { header, rows } => {
                        // Numbers right-aligned, text left-aligned (by column: a column is
                        // text when any of its cells is); short cells (dates, ranges) never
                        // wrap.
                        let text_col: Vec<bool> = (0..header.len())
                            .map(|i| {
                                rows.iter()
                                    .any(|r| r.get(i).is_some_and(|c| !numeric_cell(c)))
                            })
                            .collect();
                        h.push_str("<table>\n<tr>");
                        for (i, c) in header.iter().enumerate() {
                            let class = if text_col.get(i) == Some(&true) {
                                " class=\"t\""
                            } else {
                                ""
                            };
                            let _ = write!(h, "<th{class}>{}</th>", escape(c));
                        }
                        h.push_str("</tr>\n");
                        for r in rows {
                            h.push_str("<tr>");
                            for (i, c) in r.iter().enumerate() {
                                let mut classes = Vec::new();
                                if text_col.get(i) == Some(&true) {
                                    classes.push("t");
                                }
                                if c.chars().count() <= 24 {
                                    classes.push("nw");
                                }
                                let class = if classes.is_empty() {
                                    String::new()
                                } else {
                                    format!(" class=\"{}\"", classes.join(" "))
                                };
                                let _ = write!(h, "<td{class}>{}</td>", escape(c));
                            }
                            h.push_str("</tr>\n");
                        }
                        h.push_str("</table>\n");
                    }
                    Block::Facts(kv) => {
                        h.push_str("<dl class=\"facts\">\n");
                        for (k, v) in kv {
                            let _ = writeln!(h, "<dt>{}</dt><dd>{}</dd>", escape(k), escape(v));
                        }
                        h.push_str("</dl>\n");
                    }
                    Block::Details {
                        summary,
                        paragraphs,
                    } => {
                        let _ = writeln!(h, "<details>\n<summary>{}</summary>", escape(summary));
                        for p in paragraphs {
                            let _ = writeln!(h, "<p>{}</p>", escape(p));
                        }
                        h.push_str("</details>\n");
                    }
                    Block::Figure(f) => {
                        let name = escape(&f.name);
                        let _ = write!(
                            h,
                            "<figure id=\"{name}\">\n{}\n<figcaption>{} \
                             <a href=\"{name}.svg\">{name}.svg</a>",
                            inline_svg(&f.svg),
                            escape(&f.caption)
                        );
                        if png {
                            let _ = write!(h, " · <a href=\"{name}.png\">{name}.png</a>");
                        }
                        h.push_str("</figcaption>\n</figure>\n");
                    }
                }
            }
        }
        let _ = write!(
            h,
            "<footer>Written by stiction {}.</footer>\n</body>\n</html>\n",
            env!("CARGO_PKG_VERSION")
        );
        h
    }

    /// Every figure, in page order.
    pub fn figures(&self) -> impl Iterator<Item = &Figure> {
        self.sections.iter().flat_map(|s| {
            s.blocks.iter().filter_map(|b| match b {
                Block::Figure(f) => Some(f),
                _ => None,
            })
        })
    }

    /// Write `dir/index.html` and each figure as `dir/<name>.svg` (and `.png` when asked),
    /// creating `dir` when needed.
    pub fn write(&self, dir: &Path, opts: WriteOptions) -> Result<Written, ReportError> {
        let io = |p: &Path| {
            let path = p.display().to_string();
            move |source| ReportError::Io { path, source }
        };
        std::fs::create_dir_all(dir).map_err(io(dir))?;
        let mut files = Vec::new();
        let mut bytes = 0u64;
        for f in self.figures() {
            let p = dir.join(format!("{}.svg", f.name));
            std::fs::write(&p, &f.svg).map_err(io(&p))?;
            bytes += f.svg.len() as u64;
            files.push(p);
            if opts.png {
                let png = svg_to_png(&f.svg)?;
                let p = dir.join(format!("{}.png", f.name));
                std::fs::write(&p, &png).map_err(io(&p))?;
                bytes += png.len() as u64;
                files.push(p);
            }
        }
        let html = self.to_html(opts.png);
        let index = dir.join("index.html");
        std::fs::write(&index, &html).map_err(io(&index))?;
        bytes += html.len() as u64;
        Ok(Written {
            index,
            files,
            bytes,
        })
    }
}
