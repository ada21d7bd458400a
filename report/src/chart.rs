//! Chart primitives on plotters: stacked or side-by-side line/point panels, and a heat map
//! with a colour bar. Every chart has a title, axis descriptions with units and a legend;
//! the domain figures in [`crate::figures`] fill them in.
//!
//! Series are split at non-finite values (a `NaN` sample ends a line: plotters would write it
//! into the SVG, which a browser rejects), and long series are reduced to the minimum and
//! maximum of each of [`MAX_POINTS`]/2 buckets, which keeps spikes and keeps the SVG small.

use std::sync::Once;

use plotters::coord::Shift;
use plotters::element::{Circle, Cross, PathElement, Rectangle};
use plotters::prelude::*;
use plotters::style::colors::colormaps::{ColorMap, ViridisRGB};
use plotters::style::{register_font, FontStyle, RGBColor, ShapeStyle};

use crate::ReportError;

/// Longest series drawn as is; longer ones are min/max-decimated to this many points.
pub const MAX_POINTS: usize = 2400;

/// Font family used for all text (registered from the embedded font, so text is measured
/// the same way on every machine).
const FONT: &str = "sans-serif";

static FONT_ONCE: Once = Once::new();

/// Text sizes as asked of plotters (which writes `font-size` as the size / 1.24), one per
/// role so that the inspector (`inspect`) can tell the roles apart. Sized so that a tick label
/// is at least 13 px on a page 1400 px wide, where a figure is drawn at the page's width.
pub(crate) const TITLE_PX: u32 = 21;
/// A panel caption.
pub(crate) const CAPTION_PX: u32 = 18;
/// An axis description.
pub(crate) const AXIS_PX: u32 = 17;
/// The description of a heat map's colour scale (rotated).
pub(crate) const SCALE_PX: u32 = 16;
/// Tick and legend labels.
pub(crate) const LABEL_PX: u32 = 15;
/// The colour scale's tick labels.
pub(crate) const SCALE_LABEL_PX: u32 = 14;

/// A tick on a date axis (`x` in days since 1970-01-01 UTC): the date, with the time of day
/// when the axis spans less than three days.
fn date_tick(x: f64, range: f64) -> String {
    let text = datasets::format_epoch(x * 86_400.0);
    if range < 3.0 {
        text
    } else {
        text.chars().take(10).collect()
    }
}

/// Register the embedded font with plotters (needed to measure text; idempotent).
pub(crate) fn ensure_font() {
    FONT_ONCE.call_once(|| {
        // Registration only fails on malformed font data, which the embedded font is not;
        // should it fail, text measurement falls back to an error at draw time.
        let _ = register_font(FONT, FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT);
        let _ = register_font(FONT, FontStyle::Bold, epaint_default_fonts::UBUNTU_LIGHT);
    });
}

/// The palette, in the order series are usually given: measured first, estimates after.
pub mod palette {
    use plotters::style::RGBColor;
    /// Measured PV, OP.
    pub const BLACK: RGBColor = RGBColor(20, 20, 20);
    /// Set point.
    pub const GREY: RGBColor = RGBColor(140, 140, 140);
    /// First estimate.
    pub const BLUE: RGBColor = RGBColor(31, 119, 180);
    /// Second estimate.
    pub const ORANGE: RGBColor = RGBColor(230, 120, 20);
    /// Third.
    pub const GREEN: RGBColor = RGBColor(44, 160, 44);
    /// Markers of the optimum, thresholds.
    pub const RED: RGBColor = RGBColor(214, 39, 40);
    /// Fourth.
    pub const PURPLE: RGBColor = RGBColor(148, 103, 189);
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mark {
    /// A line of the given width.
    Line(u32),
    /// A dashed line.
    Dashed,
    /// Filled dots of the given radius.
    Dots(u32),
    /// Hollow circles of the given radius.
    Rings(u32),
    /// Crosses (the optimum of a surface).
    Crosses,
}

/// One named series.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// The points (non-finite values break the line).
    pub points: Vec<(f64, f64)>,
    /// Drawing style.
    pub mark: Mark,
    /// Colour.
    pub color: RGBColor,
    /// Vertical error bars `(x, low, high)` drawn in the same colour.
    pub bars: Vec<(f64, f64, f64)>,
}

impl Series {
    /// A line series.
    pub fn line(name: impl Into<String>, points: Vec<(f64, f64)>, color: RGBColor) -> Series {
        Series {
            name: name.into(),
            points,
            mark: Mark::Line(1),
            color,
            bars: Vec::new(),
        }
    }

    /// A series with another mark.
    pub fn marked(
        name: impl Into<String>,
        points: Vec<(f64, f64)>,
        mark: Mark,
        color: RGBColor,
    ) -> Series {
        Series {
            name: name.into(),
            points,
            mark,
            color,
            bars: Vec::new(),
        }
    }

    /// A time series `y[i]` against `x[i]`.
    pub fn from_xy(name: impl Into<String>, x: &[f64], y: &[f64], color: RGBColor) -> Series {
        Series::line(
            name,
            x.iter().copied().zip(y.iter().copied()).collect(),
            color,
        )
    }
}

/// A reference line across a panel.
#[derive(Debug, Clone)]
pub struct Rule {
    /// Position (x for vertical rules, y for horizontal ones).
    pub at: f64,
    /// Legend text.
    pub name: String,
    /// Colour.
    pub color: RGBColor,
    /// Vertical (`true`) or horizontal.
    pub vertical: bool,
}

/// One set of axes.
#[derive(Debug, Clone, Default)]
pub struct Panel {
    /// Axis description of y, with its unit.
    pub y_label: String,
    /// Axis description of x, with its unit (the figure's when empty).
    pub x_label: String,
    /// The series, drawn in order.
    pub series: Vec<Series>,
    /// Reference lines.
    pub rules: Vec<Rule>,
    /// Fixed y range (else from the data).
    pub y_range: Option<(f64, f64)>,
    /// Fixed x range (else from the data).
    pub x_range: Option<(f64, f64)>,
    /// Panel caption (above the axes; the figure title names loop and model).
    pub caption: String,
    /// x is a date in days since 1970-01-01 (UTC): the ticks are written as dates.
    pub x_dates: bool,
}

impl Panel {
    /// Add the line of `y` over `x` ([`Series::from_xy`]).
    pub fn push_xy(&mut self, name: impl Into<String>, x: &[f64], y: &[f64], color: RGBColor) {
        self.series.push(Series::from_xy(name, x, y, color));
    }
}

/// A figure of one or more panels.
#[derive(Debug, Clone)]
pub struct LineChart {
    /// Title: loop and model.
    pub title: String,
    /// Axis description of x shared by the panels, with its unit.
    pub x_label: String,
    /// Panels, top to bottom (or left to right when `side_by_side`).
    pub panels: Vec<Panel>,
    /// Place the panels side by side.
    pub side_by_side: bool,
    /// Size in pixels.
    pub size: (u32, u32),
}

/// A cell of a heat map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    /// Centre.
    pub x: f64,
    /// Centre.
    pub y: f64,
    /// Width.
    pub w: f64,
    /// Height.
    pub h: f64,
    /// Value (`None` = not evaluated, drawn grey).
    pub value: Option<f64>,
}

/// A heat map over two parameters with a colour bar.
#[derive(Debug, Clone)]
pub struct HeatMap {
    /// Title: loop and model.
    pub title: String,
    /// Axis descriptions with units.
    pub x_label: String,
    /// See `x_label`.
    pub y_label: String,
    /// Description of the colour scale, with its unit.
    pub value_label: String,
    /// Cells, drawn in order (later ones on top).
    pub cells: Vec<Cell>,
    /// Colour scale limits (values outside are clamped).
    pub range: (f64, f64),
    /// Marks drawn over the cells (optimum, region).
    pub overlay: Vec<Series>,
    /// Axis ranges.
    pub x_range: (f64, f64),
    /// See `x_range`.
    pub y_range: (f64, f64),
    /// Size in pixels.
    pub size: (u32, u32),
}

fn err(what: &str, e: impl std::fmt::Display) -> ReportError {
    ReportError::Plot(format!("{what}: {e}"))
}

/// Split `points` at non-finite coordinates into drawable runs.
pub fn finite_runs(points: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut cur = Vec::new();
    for &(x, y) in points {
        if x.is_finite() && y.is_finite() {
            cur.push((x, y));
        } else if !cur.is_empty() {
            runs.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        runs.push(cur);
    }
    runs
}

/// Reduce a run to at most about `max` points: the first, then the minimum and maximum of
/// each bucket in their order, then the last.
pub fn decimate(run: &[(f64, f64)], max: usize) -> Vec<(f64, f64)> {
    if run.len() <= max || max < 4 {
        return run.to_vec();
    }
    let buckets = max / 2;
    let size = run.len().div_ceil(buckets);
    let mut out = Vec::with_capacity(2 * buckets + 2);
    for chunk in run.chunks(size) {
        let (mut lo, mut hi) = (0, 0);
        for (i, p) in chunk.iter().enumerate() {
            if p.1 < chunk[lo].1 {
                lo = i;
            }
            if p.1 > chunk[hi].1 {
                hi = i;
            }
        }
        let (a, b) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        out.push(chunk[a]);
        if b != a {
            out.push(chunk[b]);
        }
    }
    out
}

/// Data range of the finite values with a 5 % margin (a constant gets ±1 or ±5 %).
fn padded(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
    if !lo.is_finite() {
        return None;
    }
    let span = hi - lo;
    if span <= 1e-12 * lo.abs().max(hi.abs()).max(1e-300) {
        let d = if lo == 0.0 { 1.0 } else { 0.05 * lo.abs() };
        return Some((lo - d, hi + d));
    }
    Some((lo - 0.05 * span, hi + 0.05 * span))
}

/// Tick label with as many decimals as the axis range needs.
pub fn tick(v: f64, range: f64) -> String {
    let r = range.abs();
    if r == 0.0 || !r.is_finite() {
        return format!("{v}");
    }
    let mag = r.log10().floor();
    if !(-4.0..6.0).contains(&mag) {
        return format!("{v:.2e}");
    }
    let decimals = (1.0 - mag).clamp(0.0, 6.0) as usize;
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s.trim_start_matches(['-', '0', '.']).is_empty() {
        s[1..].to_string()
    } else {
        s
    }
}

fn style(color: RGBColor, width: u32) -> ShapeStyle {
    ShapeStyle {
        color: color.to_rgba(),
        filled: false,
        stroke_width: width,
    }
}

/// What a legend entry shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Glyph {
    /// A line series.
    Line,
    /// Points (dots, rings, crosses).
    Dot,
    /// A dashed reference line.
    Rule,
}

/// The x and y ranges of `panel`: its own, else its data, bars and rules padded.
fn ranges(panel: &Panel) -> ((f64, f64), (f64, f64)) {
    let all = || panel.series.iter().flat_map(|s| s.points.iter());
    let bars = || panel.series.iter().flat_map(|s| s.bars.iter());
    let range = |own: Option<(f64, f64)>, values: &mut dyn Iterator<Item = f64>| {
        own.or_else(|| padded(values)).unwrap_or((0.0, 1.0))
    };
    let x_range = range(
        panel.x_range,
        &mut all()
            .map(|p| p.0)
            .chain(bars().map(|b| b.0))
            .chain(panel.rules.iter().filter(|r| r.vertical).map(|r| r.at)),
    );
    let y_range = range(
        panel.y_range,
        &mut all()
            .map(|p| p.1)
            .chain(bars().flat_map(|b| [b.1, b.2]))
            .chain(panel.rules.iter().filter(|r| !r.vertical).map(|r| r.at)),
    );
    (x_range, y_range)
}

/// The legend box of `panel`'s `entries` (name, colour, glyph) in the strip right of its plot.
fn draw_legend(
    legend_area: &DrawingArea<SVGBackend<'_>, Shift>,
    panel: &Panel,
    entries: Vec<(String, RGBColor, Glyph)>,
) -> Result<(), ReportError> {
    // A chart without axes in the strip right of the plot holds the legend box, top
    // aligned with the plotting area.
    let top = 8 + if panel.caption.is_empty() { 0 } else { 24 };
    let mut lc = ChartBuilder::on(legend_area)
        .margin_top(top)
        .margin_left(4)
        .margin_right(8)
        .build_cartesian_2d(0f64..1f64, 0f64..1f64)
        .map_err(|e| err("legend", e))?;
    for (name, c, glyph) in entries {
        lc.draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
            .map_err(|e| err("legend", e))?
            .label(name)
            .legend(move |(x, y)| {
                let (r, path, w) = match glyph {
                    Glyph::Dot => (3, vec![(0, 0), (0, 0)], 1),
                    Glyph::Line => (0, vec![(0, 0), (18, 0)], 2),
                    Glyph::Rule => (0, vec![(0, 0), (18, 0)], 1),
                };
                let dx = if glyph == Glyph::Dot { 9 } else { 0 };
                EmptyElement::at((x, y))
                    + Circle::new((dx, 0), r, c.filled())
                    + PathElement::new(path, style(c, w))
            });
    }
    draw_series_labels(&mut lc)
}

/// The chart's series labels in a box at its upper left.
fn draw_series_labels<'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, CT>,
) -> Result<(), ReportError> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(160, 160, 160))
        .label_font((FONT, LABEL_PX))
        .draw()
        .map_err(|e| err("legend", e))
}

fn draw_panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    panel: &Panel,
    x_label: &str,
) -> Result<(), ReportError> {
    let (x_range, y_range) = ranges(panel);
    let entries = panel.rules.len()
        + panel
            .series
            .iter()
            .filter(|s| s.points.iter().any(|p| p.0.is_finite() && p.1.is_finite()))
            .count();
    // The legend sits in a strip right of the plotting area, never on the data: wide enough
    // for the longest label (15 px text, about 8.2 px a character, plus the glyph).
    let longest = panel
        .rules
        .iter()
        .map(|r| r.name.chars().count())
        .chain(panel.series.iter().map(|s| s.name.chars().count()))
        .max()
        .unwrap_or(0);
    let legend_w = if entries > 0 {
        (longest as f64 * 8.2 + 44.0).clamp(100.0, 340.0) as u32
    } else {
        0
    };
    let (w, _) = area.dim_in_pixel();
    let legend_w = legend_w.min(w * 2 / 5);
    let (plot_area, legend_area) = area.split_horizontally((w - legend_w) as i32);
    let mut builder = ChartBuilder::on(&plot_area);
    builder
        .margin(8)
        .margin_right(16)
        .x_label_area_size(48)
        .y_label_area_size(80);
    if !panel.caption.is_empty() {
        builder.caption(&panel.caption, (FONT, CAPTION_PX));
    }
    let mut chart = builder
        .build_cartesian_2d(x_range.0..x_range.1, y_range.0..y_range.1)
        .map_err(|e| err("axes", e))?;
    let (xs, ys) = (x_range.1 - x_range.0, y_range.1 - y_range.0);
    let dates = panel.x_dates;
    let x_fmt = move |v: &f64| {
        if dates {
            date_tick(*v, xs)
        } else {
            tick(*v, xs)
        }
    };
    let y_fmt = move |v: &f64| tick(*v, ys);
    chart
        .configure_mesh()
        .x_desc(if panel.x_label.is_empty() {
            x_label
        } else {
            &panel.x_label
        })
        .y_desc(panel.y_label.as_str())
        .x_labels(8)
        .y_labels(6)
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .axis_desc_style((FONT, AXIS_PX))
        .label_style((FONT, LABEL_PX))
        // A light major grid only: minor lines would compete with the data.
        .light_line_style(plotters::style::colors::TRANSPARENT)
        .bold_line_style(RGBColor(228, 228, 228))
        .draw()
        .map_err(|e| err("mesh", e))?;
    // Legend entries: drawn after the data, in their own strip (see below).
    let mut entries: Vec<(String, RGBColor, Glyph)> = Vec::new();
    for rule in &panel.rules {
        let pts = if rule.vertical {
            vec![(rule.at, y_range.0), (rule.at, y_range.1)]
        } else {
            vec![(x_range.0, rule.at), (x_range.1, rule.at)]
        };
        let c = rule.color;
        chart
            .draw_series(DashedLineSeries::new(pts, 6, 4, style(c, 1)))
            .map_err(|e| err("rule", e))?;
        entries.push((rule.name.clone(), c, Glyph::Rule));
    }
    for s in &panel.series {
        let c = s.color;
        let mut first = true;
        let runs = finite_runs(&s.points);
        if runs.is_empty() && s.bars.is_empty() {
            continue;
        }
        for run in runs {
            let anno = match s.mark {
                Mark::Line(w) => chart
                    .draw_series(LineSeries::new(decimate(&run, MAX_POINTS), style(c, w)))
                    .map_err(|e| err("line", e))?,
                Mark::Dashed => chart
                    .draw_series(DashedLineSeries::new(
                        decimate(&run, MAX_POINTS),
                        5,
                        3,
                        style(c, 1),
                    ))
                    .map_err(|e| err("dashed line", e))?,
                Mark::Dots(r) => chart
                    .draw_series(run.iter().map(|&p| Circle::new(p, r, c.filled())))
                    .map_err(|e| err("dots", e))?,
                Mark::Rings(r) => chart
                    .draw_series(run.iter().map(|&p| Circle::new(p, r, style(c, 1))))
                    .map_err(|e| err("rings", e))?,
                Mark::Crosses => chart
                    .draw_series(run.iter().map(|&p| Cross::new(p, 6, style(c, 2))))
                    .map_err(|e| err("crosses", e))?,
            };
            let _ = anno;
            if first {
                let glyph = match s.mark {
                    Mark::Dots(_) | Mark::Rings(_) | Mark::Crosses => Glyph::Dot,
                    _ => Glyph::Line,
                };
                entries.push((s.name.clone(), c, glyph));
                first = false;
            }
        }
        for &(x, lo, hi) in &s.bars {
            if x.is_finite() && lo.is_finite() && hi.is_finite() {
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![(x, lo), (x, hi)],
                        style(c, 1),
                    )))
                    .map_err(|e| err("error bar", e))?;
            }
        }
    }
    if !entries.is_empty() {
        draw_legend(&legend_area, panel, entries)?;
    }
    Ok(())
}

/// Render a line chart to an SVG document.
pub fn render_lines(chart: &LineChart) -> Result<String, ReportError> {
    render_svg(chart.size, &chart.title, |body| {
        let n = chart.panels.len().max(1);
        let areas = if chart.side_by_side {
            body.split_evenly((1, n))
        } else {
            body.split_evenly((n, 1))
        };
        for (panel, area) in chart.panels.iter().zip(&areas) {
            draw_panel(area, panel, &chart.x_label)?;
        }
        Ok(())
    })
}

/// An SVG document of `size` on white with `title` above the area that `draw` fills.
fn render_svg(
    size: (u32, u32),
    title: &str,
    draw: impl FnOnce(&DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), ReportError>,
) -> Result<String, ReportError> {
    ensure_font();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err("background", e))?;
        let body = root
            .titled(title, (FONT, TITLE_PX))
            .map_err(|e| err("title", e))?;
        draw(&body)?;
        root.present().map_err(|e| err("svg", e))?;
    }
    Ok(svg)
}

/// Colour of `v` on the viridis scale over `range`.
pub fn heat_color(v: f64, range: (f64, f64)) -> RGBColor {
    let (lo, hi) = range;
    let t = if hi > lo {
        ((v - lo) / (hi - lo)).clamp(0.0, 1.0)
    } else {
        1.0
    };
    ViridisRGB.get_color_normalized(t as f32, 0.0, 1.0)
}

/// Render a heat map with its colour bar to an SVG document.
pub fn render_heatmap(map: &HeatMap) -> Result<String, ReportError> {
    render_svg(map.size, &map.title, |body| {
        let w = body.dim_in_pixel().0;
        let (main, bar) = body.split_horizontally(w.saturating_sub(110));
        let mut chart = ChartBuilder::on(&main)
            .margin(8)
            .margin_right(16)
            .x_label_area_size(44)
            .y_label_area_size(70)
            .build_cartesian_2d(map.x_range.0..map.x_range.1, map.y_range.0..map.y_range.1)
            .map_err(|e| err("axes", e))?;
        let (xs, ys) = (map.x_range.1 - map.x_range.0, map.y_range.1 - map.y_range.0);
        let x_fmt = move |v: &f64| tick(*v, xs);
        let y_fmt = move |v: &f64| tick(*v, ys);
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(map.x_label.as_str())
            .y_desc(map.y_label.as_str())
            .x_label_formatter(&x_fmt)
            .y_label_formatter(&y_fmt)
            .axis_desc_style((FONT, AXIS_PX))
            .label_style((FONT, LABEL_PX))
            .draw()
            .map_err(|e| err("mesh", e))?;
        let range = map.range;
        let grey = RGBColor(200, 200, 200);
        chart
            .draw_series(map.cells.iter().map(|c| {
                let color = c.value.map_or(grey, |v| heat_color(v, range));
                Rectangle::new(
                    [
                        (c.x - c.w / 2.0, c.y - c.h / 2.0),
                        (c.x + c.w / 2.0, c.y + c.h / 2.0),
                    ],
                    color.filled(),
                )
            }))
            .map_err(|e| err("cells", e))?;
        if map.cells.iter().any(|c| c.value.is_none()) {
            chart
                .draw_series(std::iter::empty::<Rectangle<(f64, f64)>>())
                .map_err(|e| err("legend", e))?
                .label("skipped node")
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], grey.filled()));
        }
        for s in &map.overlay {
            let c = s.color;
            let anno = match s.mark {
                Mark::Crosses => chart
                    .draw_series(s.points.iter().map(|&p| Cross::new(p, 7, style(c, 3))))
                    .map_err(|e| err("optimum", e))?,
                Mark::Dots(r) => chart
                    .draw_series(s.points.iter().map(|&p| Circle::new(p, r, c.filled())))
                    .map_err(|e| err("dots", e))?,
                Mark::Rings(r) => chart
                    .draw_series(s.points.iter().map(|&p| Circle::new(p, r, style(c, 1))))
                    .map_err(|e| err("rings", e))?,
                Mark::Dashed => chart
                    .draw_series(DashedLineSeries::new(s.points.clone(), 5, 3, style(c, 2)))
                    .map_err(|e| err("outline", e))?,
                Mark::Line(wd) => chart
                    .draw_series(LineSeries::new(s.points.clone(), style(c, wd)))
                    .map_err(|e| err("outline", e))?,
            };
            // One element type for every mark: unused parts get zero size.
            let (cross, dot, ring, line) = match s.mark {
                Mark::Crosses => (5, 0, 0, false),
                Mark::Dots(_) => (0, 3, 3, false),
                Mark::Rings(_) => (0, 0, 3, false),
                Mark::Line(_) | Mark::Dashed => (0, 0, 0, true),
            };
            anno.label(s.name.clone()).legend(move |(x, y)| {
                EmptyElement::at((x, y))
                    + Cross::new((8, 0), cross, style(c, 2))
                    + Circle::new((8, 0), dot, c.filled())
                    + Circle::new((8, 0), ring, style(palette::BLACK, 1))
                    + PathElement::new(
                        if line { vec![(0, 0), (18, 0)] } else { vec![] },
                        style(c, 2),
                    )
            });
        }
        draw_series_labels(&mut chart)?;
        // The colour bar.
        let (lo, hi) = if map.range.1 > map.range.0 {
            map.range
        } else {
            (map.range.0 - 1.0, map.range.0 + 1.0)
        };
        let mut cb = ChartBuilder::on(&bar)
            .margin_top(8)
            .margin_bottom(52)
            .margin_right(8)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..1.0, lo..hi)
            .map_err(|e| err("colour bar", e))?;
        let vs = hi - lo;
        let v_fmt = move |v: &f64| tick(*v, vs);
        cb.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc(map.value_label.as_str())
            .y_label_formatter(&v_fmt)
            .axis_desc_style((FONT, SCALE_PX))
            .label_style((FONT, SCALE_LABEL_PX))
            .draw()
            .map_err(|e| err("colour bar", e))?;
        let steps = 64;
        cb.draw_series((0..steps).map(|i| {
            let a = lo + vs * i as f64 / steps as f64;
            let b = lo + vs * (i + 1) as f64 / steps as f64;
            Rectangle::new(
                [(0.0, a), (1.0, b)],
                heat_color((a + b) / 2.0, (lo, hi)).filled(),
            )
        }))
        .map_err(|e| err("colour bar", e))?;
        Ok(())
    })
}

/// Rasterise an SVG document (as written by this module) to PNG bytes: not in this build (the
/// `png` feature is off), so an error that says how to get it.
#[cfg(not(feature = "png"))]
pub fn svg_to_png(_svg: &str) -> Result<Vec<u8>, ReportError> {
    Err(ReportError::Plot(crate::NO_PNG.into()))
}

/// Rasterise an SVG document (as written by this module) to PNG bytes with the embedded font.
#[cfg(feature = "png")]
pub fn svg_to_png(svg: &str) -> Result<Vec<u8>, ReportError> {
    use resvg::{tiny_skia, usvg};
    static DB: std::sync::OnceLock<std::sync::Arc<usvg::fontdb::Database>> =
        std::sync::OnceLock::new();
    let db = DB.get_or_init(|| {
        let mut db = usvg::fontdb::Database::new();
        db.load_font_data(epaint_default_fonts::UBUNTU_LIGHT.to_vec());
        let family = db
            .faces()
            .next()
            .and_then(|f| f.families.first().map(|(name, _)| name.clone()))
            .unwrap_or_else(|| "Ubuntu".to_string());
        db.set_sans_serif_family(family);
        std::sync::Arc::new(db)
    });
    let opt = usvg::Options {
        fontdb: db.clone(),
        ..Default::default()
    };
    let tree = usvg::Tree::from_str(svg, &opt).map_err(|e| err("png: parsing the svg", e))?;
    let size = tree.size().to_int_size();
    let mut pixmap = tiny_skia::Pixmap::new(size.width(), size.height())
        .ok_or_else(|| ReportError::Plot("png: empty image".into()))?;
    pixmap.fill(tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        tiny_skia::Transform::identity(),
        &mut pixmap.as_mut(),
    );
    pixmap.encode_png().map_err(|e| err("png: encoding", e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_split_at_nan_and_decimation_keeps_extremes() {
        let pts = vec![(0.0, 1.0), (1.0, f64::NAN), (2.0, 3.0), (3.0, 4.0)];
        assert_eq!(finite_runs(&pts).len(), 2);
        let long: Vec<(f64, f64)> = (0..10_000)
            .map(|i| (i as f64, if i == 5000 { 100.0 } else { (i % 7) as f64 }))
            .collect();
        let d = decimate(&long, 200);
        assert!(d.len() <= 202, "{}", d.len());
        assert!(d.iter().any(|p| p.1 == 100.0), "the spike must survive");
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0), "order kept");
    }

    #[test]
    fn ticks_have_the_decimals_the_range_needs() {
        assert_eq!(tick(0.30000000000000004, 1.0), "0.3");
        assert_eq!(tick(0.30000000000000004, 0.5), "0.30");
        assert_eq!(tick(12.0, 100.0), "12");
        assert_eq!(tick(-0.0001, 1.0), "0.0");
        assert_eq!(tick(1.5e-7, 1e-6), "1.50e-7");
    }
}
