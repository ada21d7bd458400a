//! Read back the structure of a figure's SVG: title, panels, axis descriptions, legend
//! labels and the series drawn, for tests (snapshots of the structure, not of pixels) and for
//! checking that every plot of a report says what it shows.
//!
//! The parser is small and dependency-free, and only knows the SVG that plotters' SVG
//! backend writes through [`crate::chart`]: a flat list of elements in drawing order. It
//! recognises the parts of a chart by what `chart` draws them with, never by coordinates:
//!
//! * **text roles by font size.** plotters writes `font-size` as the size asked for divided by
//!   1.24; multiplied back, the sizes are `chart`'s: the title 21 px, a panel caption 18 px, an
//!   axis description 17 px (16 px for the colour bar of a heat map), tick and legend labels
//!   15 px (14 px on the colour bar). Legend labels are the 15 px texts anchored at their
//!   start; tick labels are centred (x) or right-aligned (y). The y axis description is the
//!   rotated 17 px text.
//! * **panels by drawing order.** Each panel is drawn whole before the next: caption, mesh,
//!   axis descriptions, ticks, series, then the legend box. A panel starts at a caption, or at
//!   a y axis description when the current panel already has one.
//! * **the legend box** is the outlined rectangle (`fill="none"` with a stroke) drawn over its
//!   white background; everything after it up to the next panel is the legend.
//! * **series** are what is drawn between the axes and the legend, grouped by colour: mesh
//!   lines (axis-aligned `<line>`s) and the axes and tick marks (pure black `#000000`
//!   polylines, a colour the palette does not use) are left out; diagonal `<line>`s are the
//!   arms of crosses; filled rectangles are heat-map cells (all counted as one series).

use std::collections::BTreeMap;
use std::fmt::Write as _;

/// The factor by which plotters' SVG backend divides font sizes.
const PLOTTERS_FONT_SCALE: f64 = 1.24;

/// One element of the document, in drawing order.
#[derive(Debug, Clone, PartialEq)]
pub struct Element {
    /// Tag name (`text`, `polyline`, `rect`, ...).
    pub tag: String,
    /// Attributes in document order, values unescaped.
    pub attrs: Vec<(String, String)>,
    /// Text content (trimmed, unescaped) of a `<text>` element; empty for the others.
    pub content: String,
}

impl Element {
    /// The value of attribute `name`.
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    fn num(&self, name: &str) -> Option<f64> {
        self.attr(name).and_then(|v| v.trim().parse().ok())
    }
}

/// What a text is, judged by its size and alignment (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The figure's title (21 px; the first one).
    Title,
    /// A panel caption (18 px).
    Caption,
    /// An axis description (17 px).
    Axis,
    /// The description of a heat map's colour scale (16 px).
    Scale,
    /// A legend label (15 px, anchored at its start).
    Legend,
    /// A tick label (15 px centred or right-aligned, or 14 px).
    Tick,
    /// Anything else.
    Other,
}

/// A text of the figure.
#[derive(Debug, Clone, PartialEq)]
pub struct Text {
    /// The string shown.
    pub content: String,
    /// Font size in px as asked of plotters.
    pub px: f64,
    /// `text-anchor` (`start`, `middle`, `end`).
    pub anchor: String,
    /// Drawn rotated (y axis descriptions).
    pub rotated: bool,
    /// What it is.
    pub role: Role,
}

/// What is drawn in one colour in a panel's plot area.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Series {
    /// `#RRGGBB`, or `cells` for the cells of a heat map.
    pub color: String,
    /// The kinds of marks, in order of appearance: `polyline`, `dot`, `ring`, `cross`,
    /// `cells`, or another tag name.
    pub kinds: Vec<String>,
}

/// One set of axes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Panel {
    /// Caption above the axes.
    pub caption: Option<String>,
    /// Description of the y axis.
    pub y_axis: Option<String>,
    /// Description of the x axis.
    pub x_axis: Option<String>,
    /// Description of the colour scale (heat maps).
    pub scale: Option<String>,
    /// Number of tick labels (depends on the data; not in the summary).
    pub ticks: usize,
    /// Legend labels in order.
    pub legend: Vec<String>,
    /// What is drawn, by colour, in order of first appearance.
    pub series: Vec<Series>,
}

/// The structure of a figure.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Structure {
    /// Width and height in px.
    pub size: (u32, u32),
    /// The title (empty when there is none).
    pub title: String,
    /// Every text in drawing order.
    pub texts: Vec<Text>,
    /// Number of elements by tag (depends on the data; not in the summary).
    pub elements: BTreeMap<String, usize>,
    /// Every axis description, panel by panel (y, x, colour scale).
    pub axes: Vec<String>,
    /// Every legend label in order.
    pub legend: Vec<String>,
    /// Number of legend boxes.
    pub legend_boxes: usize,
    /// The panels in drawing order.
    pub panels: Vec<Panel>,
}

/// Replace character references and the predefined entities.
fn unescape(s: &str) -> String {
    if !s.contains('&') {
        return s.to_string();
    }
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(i) = rest.find('&') {
        out.push_str(&rest[..i]);
        rest = &rest[i..];
        let Some(end) = rest.find(';').filter(|&e| e <= 10) else {
            out.push('&');
            rest = &rest[1..];
            continue;
        };
        let name = &rest[1..end];
        let ch = match name {
            "amp" => Some('&'),
            "lt" => Some('<'),
            "gt" => Some('>'),
            "quot" => Some('"'),
            "apos" => Some('\''),
            _ => name
                .strip_prefix("#x")
                .or_else(|| name.strip_prefix("#X"))
                .and_then(|h| u32::from_str_radix(h, 16).ok())
                .or_else(|| name.strip_prefix('#').and_then(|d| d.parse().ok()))
                .and_then(char::from_u32),
        };
        match ch {
            Some(c) => {
                out.push(c);
                rest = &rest[end + 1..];
            }
            None => {
                out.push('&');
                rest = &rest[1..];
            }
        }
    }
    out.push_str(rest);
    out
}

/// The elements of an SVG document in order (closing tags, comments, the prolog and
/// anything malformed are skipped).
pub fn elements(svg: &str) -> Vec<Element> {
    let b = svg.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while let Some(off) = svg[i..].find('<') {
        i += off + 1;
        match b.get(i) {
            Some(b'/') | Some(b'?') => {
                i = svg[i..].find('>').map_or(b.len(), |e| i + e + 1);
                continue;
            }
            Some(b'!') => {
                let end = if svg[i..].starts_with("!--") {
                    svg[i..].find("-->").map(|e| e + 3)
                } else {
                    svg[i..].find('>').map(|e| e + 1)
                };
                i = end.map_or(b.len(), |e| i + e);
                continue;
            }
            _ => {}
        }
        let start = i;
        while i < b.len() && (b[i].is_ascii_alphanumeric() || matches!(b[i], b':' | b'_' | b'-')) {
            i += 1;
        }
        if i == start {
            continue;
        }
        let tag = svg[start..i].to_string();
        let mut attrs = Vec::new();
        let mut closed = false;
        loop {
            while i < b.len() && b[i].is_ascii_whitespace() {
                i += 1;
            }
            match b.get(i) {
                None => break,
                Some(b'>') => {
                    i += 1;
                    break;
                }
                Some(b'/') => {
                    closed = true;
                    i += 1;
                    continue;
                }
                _ => {}
            }
            let k0 = i;
            while i < b.len() && !b[i].is_ascii_whitespace() && !matches!(b[i], b'=' | b'>' | b'/')
            {
                i += 1;
            }
            let key = svg[k0..i].to_string();
            while i < b.len() && b[i].is_ascii_whitespace() {
                i += 1;
            }
            if b.get(i) != Some(&b'=') {
                if key.is_empty() {
                    i += 1;
                } else {
                    attrs.push((key, String::new()));
                }
                continue;
            }
            i += 1;
            while i < b.len() && b[i].is_ascii_whitespace() {
                i += 1;
            }
            let value = match b.get(i) {
                Some(&q) if q == b'"' || q == b'\'' => {
                    let v0 = i + 1;
                    let v1 = svg[v0..].find(q as char).map_or(b.len(), |e| v0 + e);
                    i = (v1 + 1).min(b.len());
                    &svg[v0..v1]
                }
                _ => {
                    let v0 = i;
                    while i < b.len() && !b[i].is_ascii_whitespace() && b[i] != b'>' {
                        i += 1;
                    }
                    &svg[v0..i]
                }
            };
            attrs.push((key, unescape(value)));
        }
        let content = if tag == "text" && !closed {
            let end = svg[i..].find('<').map_or(b.len(), |e| i + e);
            unescape(svg[i..end].trim())
        } else {
            String::new()
        };
        out.push(Element {
            tag,
            attrs,
            content,
        });
    }
    out
}

/// A colour attribute that paints something (`none` and absent do not).
fn paint(e: &Element, name: &str) -> Option<String> {
    e.attr(name)
        .map(str::trim)
        .filter(|v| !v.is_empty() && *v != "none")
        .map(str::to_ascii_uppercase)
}

fn point_count(e: &Element) -> usize {
    e.attr("points").map_or(0, |p| p.split_whitespace().count())
}

/// A mark in a plot area: (colour, kind), or `None` for axes, ticks and mesh.
fn mark(e: &Element) -> Option<(String, String)> {
    match e.tag.as_str() {
        "polyline" => {
            let c = paint(e, "stroke")?;
            (c != "#000000" && point_count(e) >= 2).then(|| (c, "polyline".to_string()))
        }
        "line" => {
            let (x1, y1, x2, y2) = (e.num("x1")?, e.num("y1")?, e.num("x2")?, e.num("y2")?);
            // Axis-aligned lines are the mesh; crosses are drawn as two diagonals.
            if x1 == x2 || y1 == y2 {
                return None;
            }
            Some((paint(e, "stroke")?, "cross".to_string()))
        }
        "circle" => match paint(e, "fill") {
            Some(c) => Some((c, "dot".into())),
            None => Some((paint(e, "stroke")?, "ring".into())),
        },
        "rect" => paint(e, "fill").map(|_| ("cells".to_string(), "cells".to_string())),
        "text" | "svg" => None,
        other => Some((
            paint(e, "stroke").or_else(|| paint(e, "fill"))?,
            other.to_string(),
        )),
    }
}

fn role(px: f64, anchor: &str, rotated: bool, have_title: bool) -> Role {
    use crate::chart::{AXIS_PX, CAPTION_PX, LABEL_PX, SCALE_LABEL_PX, SCALE_PX, TITLE_PX};
    let near = |v: u32| (px - f64::from(v)).abs() < 0.25;
    if near(TITLE_PX) && !have_title {
        Role::Title
    } else if near(CAPTION_PX) {
        Role::Caption
    } else if near(AXIS_PX) {
        Role::Axis
    } else if near(SCALE_PX) && rotated {
        Role::Scale
    } else if near(LABEL_PX) && anchor == "start" {
        Role::Legend
    } else if near(LABEL_PX) || near(SCALE_LABEL_PX) {
        Role::Tick
    } else {
        Role::Other
    }
}

/// Same outline: the legend's background and its border.
fn same_box(a: &Element, b: &Element) -> bool {
    ["x", "y", "width", "height"]
        .iter()
        .all(|k| a.attr(k).is_some() && a.attr(k) == b.attr(k))
}

fn add_mark(panel: &mut Panel, (color, kind): (String, String)) {
    match panel.series.iter_mut().find(|s| s.color == color) {
        Some(s) => {
            if !s.kinds.contains(&kind) {
                s.kinds.push(kind);
            }
        }
        None => panel.series.push(Series {
            color,
            kinds: vec![kind],
        }),
    }
}

/// The structure of a figure's SVG (see the module docs for how the parts are recognised).
pub fn structure(svg: &str) -> Structure {
    let els = elements(svg);
    let mut st = Structure::default();
    for e in &els {
        *st.elements.entry(e.tag.clone()).or_default() += 1;
    }
    if let Some(root) = els.iter().find(|e| e.tag == "svg") {
        let dim = |k: &str| root.num(k).map_or(0, |v| v.max(0.0).round() as u32);
        st.size = (dim("width"), dim("height"));
    }
    let mut panels: Vec<Panel> = Vec::new();
    // In the legend of the current panel (its marks are legend glyphs, not series).
    let mut in_legend = false;
    // A filled rectangle held back: a heat-map cell, or the background of a legend box.
    let mut pending: Option<&Element> = None;
    let commit = |pending: &mut Option<&Element>, panels: &mut Vec<Panel>| {
        if let (Some(p), Some(panel)) = (pending.take(), panels.last_mut()) {
            if let Some(m) = mark(p) {
                add_mark(panel, m);
            }
        }
    };
    for e in &els {
        if e.tag == "text" {
            commit(&mut pending, &mut panels);
            let px = e.num("font-size").unwrap_or(0.0) * PLOTTERS_FONT_SCALE;
            let px = (px * 100.0).round() / 100.0;
            let anchor = e.attr("text-anchor").unwrap_or("start").to_string();
            let rotated = e.attr("transform").is_some_and(|t| t.contains("rotate"));
            let role = role(px, &anchor, rotated, !st.title.is_empty());
            let text = e.content.clone();
            match role {
                Role::Title => st.title = text.clone(),
                Role::Caption => {
                    panels.push(Panel {
                        caption: Some(text.clone()),
                        ..Panel::default()
                    });
                    in_legend = false;
                }
                Role::Axis if rotated => {
                    match panels.last_mut() {
                        Some(p) if p.y_axis.is_none() && !in_legend => {
                            p.y_axis = Some(text.clone())
                        }
                        _ => panels.push(Panel {
                            y_axis: Some(text.clone()),
                            ..Panel::default()
                        }),
                    }
                    in_legend = false;
                }
                Role::Axis => match panels.last_mut() {
                    Some(p) if p.x_axis.is_none() => p.x_axis = Some(text.clone()),
                    _ => panels.push(Panel {
                        x_axis: Some(text.clone()),
                        ..Panel::default()
                    }),
                },
                Role::Scale => {
                    if let Some(p) = panels.last_mut() {
                        p.scale = Some(text.clone());
                    }
                }
                Role::Legend => {
                    if let Some(p) = panels.last_mut() {
                        p.legend.push(text.clone());
                    }
                }
                Role::Tick => {
                    if let Some(p) = panels.last_mut() {
                        p.ticks += 1;
                    }
                }
                Role::Other => {}
            }
            st.texts.push(Text {
                content: text,
                px,
                anchor,
                rotated,
                role,
            });
            continue;
        }
        if panels.is_empty() {
            continue;
        }
        if e.tag == "rect" && paint(e, "fill").is_none() && paint(e, "stroke").is_some() {
            // The legend's border: drop its background, held back just before.
            if pending.is_some_and(|p| same_box(p, e)) {
                pending = None;
            }
            commit(&mut pending, &mut panels);
            st.legend_boxes += 1;
            in_legend = true;
            continue;
        }
        commit(&mut pending, &mut panels);
        if in_legend {
            continue;
        }
        if e.tag == "rect" && paint(e, "fill").is_some() {
            pending = Some(e);
            continue;
        }
        if let (Some(m), Some(p)) = (mark(e), panels.last_mut()) {
            add_mark(p, m);
        }
    }
    commit(&mut pending, &mut panels);
    for p in &panels {
        st.axes.extend(
            [&p.y_axis, &p.x_axis, &p.scale]
                .into_iter()
                .flatten()
                .cloned(),
        );
        st.legend.extend(p.legend.iter().cloned());
    }
    st.panels = panels;
    st
}

/// `text` with every number (digits, with a decimal point or exponent) replaced by `#`.
fn mask_numbers(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let chars: Vec<char> = text.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        if chars[i].is_ascii_digit() {
            while i < chars.len()
                && (chars[i].is_ascii_digit()
                    || (chars[i] == '.' && chars.get(i + 1).is_some_and(char::is_ascii_digit)))
            {
                i += 1;
            }
            out.push('#');
        } else {
            out.push(chars[i]);
            i += 1;
        }
    }
    out
}

impl Structure {
    /// Number of series drawn over all panels (distinct colours per panel; the cells of a
    /// heat map count as one).
    pub fn series_count(&self) -> usize {
        self.panels.iter().map(|p| p.series.len()).sum()
    }

    /// A stable, human-readable description of the structure for snapshots: size, title,
    /// panels with caption, axis descriptions, legend labels in order and the series drawn
    /// (by colour and kind). Counts that follow the data values (tick labels, dashes, cells,
    /// elements by tag) are left out, and numbers in legend labels (`S = 9.00`, `nodes in
    /// the region (12)`) are masked as `#`: the snapshot pins what is drawn, not where or with
    /// which values.
    pub fn summary(&self) -> String {
        let q = |s: &str| format!("\"{s}\"");
        let opt = |s: &Option<String>| s.as_deref().map_or_else(|| "-".to_string(), q);
        let mut o = String::new();
        let _ = writeln!(o, "size: {} x {}", self.size.0, self.size.1);
        let _ = writeln!(o, "title: {}", q(&self.title));
        let _ = writeln!(
            o,
            "panels: {}, legend boxes: {}, legend labels: {}, series: {}",
            self.panels.len(),
            self.legend_boxes,
            self.legend.len(),
            self.series_count()
        );
        let tags: Vec<&str> = self
            .elements
            .keys()
            .map(String::as_str)
            .filter(|t| *t != "svg")
            .collect();
        let _ = writeln!(o, "element kinds: {}", tags.join(", "));
        for (i, p) in self.panels.iter().enumerate() {
            let _ = writeln!(o, "panel {}: caption {}", i + 1, opt(&p.caption));
            let _ = writeln!(o, "  y axis: {}", opt(&p.y_axis));
            let _ = writeln!(o, "  x axis: {}", opt(&p.x_axis));
            if p.scale.is_some() {
                let _ = writeln!(o, "  colour scale: {}", opt(&p.scale));
            }
            let _ = writeln!(o, "  ticks: {}", if p.ticks > 0 { "yes" } else { "no" });
            let _ = writeln!(o, "  legend ({}):", p.legend.len());
            for l in &p.legend {
                let _ = writeln!(o, "    \"{}\"", mask_numbers(l));
            }
            let _ = writeln!(o, "  series ({}):", p.series.len());
            for s in &p.series {
                let _ = writeln!(o, "    {} {}", s.kinds.join("+"), s.color);
            }
        }
        o
    }
}

/// `A × B` in `title`: the model pair, when there is one.
fn model_pair(title: &str) -> Option<(String, String)> {
    let word = |s: &str| !s.is_empty() && s.chars().any(char::is_alphanumeric);
    title.match_indices('×').find_map(|(i, m)| {
        let left = title[..i].split_whitespace().last().unwrap_or("");
        let right = title[i + m.len()..]
            .split_whitespace()
            .next()
            .unwrap_or("")
            .trim_end_matches(',');
        (word(left) && word(right)).then(|| (left.to_string(), right.to_string()))
    })
}

/// An axis description ending with its unit in parentheses: `time (s)`, `sample (-)`.
pub fn has_unit(desc: &str) -> bool {
    let d = desc.trim();
    let Some(body) = d.strip_suffix(')') else {
        return false;
    };
    match body.rfind('(') {
        Some(i) => !body[..i].trim().is_empty() && !body[i + 1..].trim().is_empty(),
        None => false,
    }
}

/// Check that a figure says what it shows: the title names `loop_name` and a model (`kano ×
/// arx`; two kinds of figure no model made name none: the raw-data figure of refused data,
/// "Raw data: loop X, not analysed", and the figures of the detection tests, "...: loop X,
/// detection tests", [`crate::figures::DETECTION_TESTS`]),
/// there are at least two axis descriptions and each ends with its unit in parentheses, every
/// panel has both axis descriptions and a legend. Returns the structure, or every problem
/// found.
pub fn check_plot(svg: &str, loop_name: &str) -> Result<Structure, String> {
    let st = structure(svg);
    let mut problems = Vec::new();
    if st.size.0 == 0 || st.size.1 == 0 {
        problems.push("no size".to_string());
    }
    if st.title.is_empty() {
        problems.push("no title (no 21 px text)".to_string());
    } else {
        if !st.title.contains(loop_name) {
            problems.push(format!("the title does not name the loop {loop_name:?}"));
        }
        let raw = st.title.starts_with("Raw data:") && st.title.ends_with("not analysed");
        let detection = st
            .title
            .ends_with(&format!(", {}", crate::figures::DETECTION_TESTS));
        if !raw && !detection && model_pair(&st.title).is_none() {
            problems.push("the title names no model (`stiction × linear`)".to_string());
        }
    }
    if st.axes.len() < 2 {
        problems.push(format!(
            "{} axis description(s), expected at least 2",
            st.axes.len()
        ));
    }
    for a in &st.axes {
        if !has_unit(a) {
            problems.push(format!("axis description {a:?} has no unit in parentheses"));
        }
    }
    if st.panels.is_empty() {
        problems.push("no panel".to_string());
    }
    for (i, p) in st.panels.iter().enumerate() {
        let which = p
            .caption
            .as_deref()
            .map_or_else(|| format!("panel {}", i + 1), |c| format!("panel {c:?}"));
        if p.y_axis.is_none() || p.x_axis.is_none() {
            problems.push(format!("{which} lacks an axis description"));
        }
        if p.legend.is_empty() {
            problems.push(format!("{which} has no legend"));
        }
    }
    if st.legend.is_empty() {
        problems.push("no legend label".to_string());
    }
    if problems.is_empty() {
        Ok(st)
    } else {
        Err(format!("{:?}: {}", st.title, problems.join("; ")))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    const SVG: &str = r##"<svg width="300" height="200" viewBox="0 0 300 200" xmlns="http://www.w3.org/2000/svg">
<rect x="0" y="0" width="300" height="200" opacity="1" fill="#FFFFFF" stroke="none"/>
<text x="150" y="5" dy="0.76em" text-anchor="middle" font-family="sans-serif" font-size="16.935483870967744" opacity="1" fill="#000000">
Time trends: loop a&amp;b, kano × arx
</text>
<line opacity="1" stroke="#EBEBEB" stroke-width="1" x1="91" y1="169" x2="91" y2="54"/>
<text x="8" y="100" dy="0.76em" text-anchor="middle" font-family="sans-serif" font-size="13.709677419354838" opacity="1" fill="#000000" transform="rotate(270, 8, 100)">
PV (engineering units)
</text>
<text x="150" y="190" dy="-0.5ex" text-anchor="middle" font-family="sans-serif" font-size="13.709677419354838" opacity="1" fill="#000000">
time (s)
</text>
<polyline fill="none" opacity="1" stroke="#000000" stroke-width="1" points="70,10 70,170 "/>
<text x="68" y="99" dy="0.5ex" text-anchor="end" font-family="sans-serif" font-size="12.096774193548388" opacity="1" fill="#000000">
12.5
</text>
<polyline fill="none" opacity="1" stroke="#141414" stroke-width="1" points="70,10 80,20 90,15 "/>
<circle cx="75" cy="40" r="2" opacity="1" fill="#1F77B4" stroke="none" stroke-width="1"/>
<rect x="200" y="20" width="90" height="40" opacity="0.85" fill="#FFFFFF" stroke="none"/>
<rect x="200" y="20" width="90" height="40" opacity="1" fill="none" stroke="#A0A0A0"/>
<text x="230" y="30" dy="0.5ex" text-anchor="start" font-family="sans-serif" font-size="12.096774193548388" opacity="1" fill="#000000">
PV measured
</text>
<polyline fill="none" opacity="1" stroke="#141414" stroke-width="2" points="205,30 223,30 "/>
</svg>
"##;

    #[test]
    fn recognises_title_axes_legend_and_series() {
        let st = structure(SVG);
        assert_eq!(st.size, (300, 200));
        assert_eq!(st.title, "Time trends: loop a&b, kano × arx");
        assert_eq!(st.axes, ["PV (engineering units)", "time (s)"]);
        assert_eq!(st.legend, ["PV measured"]);
        assert_eq!(st.legend_boxes, 1);
        assert_eq!(st.panels.len(), 1);
        assert_eq!(st.panels[0].ticks, 1);
        let series: Vec<_> = st.panels[0]
            .series
            .iter()
            .map(|s| format!("{} {}", s.kinds.join("+"), s.color))
            .collect();
        assert_eq!(series, ["polyline #141414", "dot #1F77B4"]);
        assert_eq!(st.elements["text"], 5);
        assert!(check_plot(SVG, "a&b").is_ok());
        let e = check_plot(SVG, "other").unwrap_err();
        assert!(e.contains("does not name the loop"), "{e}");
        let s = st.summary();
        assert!(
            s.contains("title: \"Time trends: loop a&b, kano × arx\""),
            "{s}"
        );
        assert!(!s.contains("12.5"), "tick labels stay out: {s}");
    }

    #[test]
    fn check_plot_wants_a_model_units_and_a_legend() {
        let no_model = SVG.replace("kano × arx", "kano");
        assert!(check_plot(&no_model, "a&b")
            .unwrap_err()
            .contains("no model"));
        let no_unit = SVG.replace("time (s)", "time");
        assert!(check_plot(&no_unit, "a&b").unwrap_err().contains("no unit"));
        let no_legend = SVG.replace("text-anchor=\"start\"", "text-anchor=\"end\"");
        assert!(check_plot(&no_legend, "a&b")
            .unwrap_err()
            .contains("no legend"));
        let raw = SVG.replace(
            "Time trends: loop a&amp;b, kano × arx",
            "Raw data: loop x, not analysed",
        );
        assert!(check_plot(&raw, "x").is_ok());
        let detection = SVG.replace(
            "Time trends: loop a&amp;b, kano × arx",
            "PV-OP plot: loop x, detection tests",
        );
        assert!(check_plot(&detection, "x").is_ok());
        let not_detection = SVG.replace(
            "Time trends: loop a&amp;b, kano × arx",
            "PV-OP plot: loop x, detection tests of kano",
        );
        assert!(check_plot(&not_detection, "x")
            .unwrap_err()
            .contains("no model"));
    }

    #[test]
    fn units_and_numbers() {
        assert!(has_unit("time (s)"));
        assert!(has_unit("sample (-)"));
        assert!(has_unit("OP, MV (% of valve span)"));
        assert!(!has_unit("time"));
        assert!(!has_unit("(s)"));
        assert!(!has_unit("time ()"));
        assert_eq!(
            mask_numbers("S = 9.00, J = 3 (12 nodes) 1.5e-7"),
            "S = #, J = # (# nodes) #e-#"
        );
        assert_eq!(
            unescape("a &lt;b&gt; &#215; &#x00D7; &bogus"),
            "a <b> × × &bogus"
        );
    }
}
