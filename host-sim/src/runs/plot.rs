//! Every PNG plot, drawn with plotters: a time series as stacked panels over a shared time
//! axis, in the style of the thesis's figures 6.8–6.10 (region temperatures with the target, Tc
//! and the modes as coloured bands; heater and fan duties; spring states; bending angle with
//! the bending stiffness on a second axis), and a lane panel on the time axis marking injected
//! faults, latched faults and the frames MTTS did not resolve.
//!
//! Plots draw what the data holds: thick lines are separate strokes (no mitre reaching past the
//! points at a sharp zig-zag), every range covers its data with room to spare, and legends sit
//! in a column right of the plotting areas, over no data.
//!
//! This module owns the plot and the column table it reads. One renderer serves both
//! `host-sim run`'s `timeseries.csv` and the desk's recorded telemetry (`thermorph-desk
//! record`): a column that a CSV lacks (or that holds no number) is skipped, and a panel with no
//! column left is left out. Text is real text: DejaVu Sans from the `dejavu` crate's embedded
//! bytes, rasterised by ab_glyph, so nothing depends on system fonts or fontconfig.
//!
//! This module owns the plots' error type, [`PlotError`].

use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

/// Width of every plot, pixels.
pub const WIDTH_PX: u32 = 1400;
const TITLE_H: u32 = 46;
const TEMP_H: u32 = 380;
const PANEL_H: u32 = 210;
const SPRING_H: u32 = 150;
/// The events panel's height without its lanes, and each lane's.
const EVENTS_H: u32 = 76;
const LANE_H: u32 = 26;
/// The font family every plot registers and uses.
pub(crate) const FONT: &str = "sans-serif";
const RIGHT_PX: u32 = 90;

/// Why a CSV could not be read or plotted.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The CSV text has no header line.
    #[error("empty CSV: no header")]
    Empty,
    /// The CSV file has no header line.
    #[error("{}: empty CSV: no header", path.display())]
    EmptyFile {
        /// The file.
        path: PathBuf,
    },
    /// The file cannot be read.
    #[error("{}: {err}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        err: std::io::Error,
    },
    /// No time column with numbers.
    #[error("the CSV has no time column (time_s or t_s) with numbers")]
    NoTime,
    /// None of the plotted columns.
    #[error("the CSV has none of the plotted columns")]
    NoColumns,
    /// Drawing or encoding the PNG failed (plotters' message).
    #[error("plot: {0}")]
    Draw(String),
}

/// A CSV read as columns: every cell kept as text, numbers parsed on demand.
#[derive(Clone, Debug, Default)]
pub struct Table {
    names: Vec<String>,
    index: HashMap<String, usize>,
    rows: Vec<Vec<String>>,
}

impl Table {
    /// Parse CSV text: a header line, then rows (short rows are padded with empty cells).
    /// No quoting: neither CSV this reads ever quotes.
    pub fn parse(text: &str) -> Result<Table, PlotError> {
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header = lines.next().ok_or(PlotError::Empty)?;
        let names: Vec<String> = header.split(',').map(|s| s.trim().to_string()).collect();
        let index = names
            .iter()
            .enumerate()
            .map(|(i, n)| (n.clone(), i))
            .collect();
        let rows = lines
            .map(|l| {
                let mut r: Vec<String> = l.split(',').map(|s| s.trim().to_string()).collect();
                r.resize(names.len(), String::new());
                r
            })
            .collect();
        Ok(Table { names, index, rows })
    }

    /// Read and parse a CSV file.
    pub fn read(path: &Path) -> Result<Table, PlotError> {
        let text = std::fs::read_to_string(path).map_err(|err| PlotError::Read {
            path: path.to_path_buf(),
            err,
        })?;
        Table::parse(&text).map_err(|_| PlotError::EmptyFile {
            path: path.to_path_buf(),
        })
    }

    /// Return the column names.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Return the number of rows.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Return whether the table has no rows.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// Return a column as text, if the table has it.
    pub fn text(&self, name: &str) -> Option<Vec<&str>> {
        let i = *self.index.get(name)?;
        Some(self.rows.iter().map(|r| r[i].as_str()).collect())
    }

    /// Return a column as numbers (NaN where a cell is not a number), if the table has it and
    /// at least one cell is a finite number.
    pub fn num(&self, name: &str) -> Option<Vec<f64>> {
        let col: Vec<f64> = self
            .text(name)?
            .iter()
            .map(|s| s.parse::<f64>().unwrap_or(f64::NAN))
            .collect();
        col.iter().any(|v| v.is_finite()).then_some(col)
    }

    /// The first of `names` that [`Table::num`] finds.
    pub fn num_any(&self, names: &[&str]) -> Option<Vec<f64>> {
        names.iter().find_map(|n| self.num(n))
    }
}

/// Which panels a plot drew, where, and its size.
#[derive(Clone, Debug, PartialEq)]
pub struct PlotInfo {
    /// Panel titles, top to bottom.
    pub panels: Vec<String>,
    /// Where each panel was drawn, in the order of `panels`.
    pub panel_px: Vec<PanelPx>,
    /// Width and height, pixels.
    pub size_px: (u32, u32),
}

/// Where a panel sits in the PNG, pixels from its top-left corner, and the values its plotting
/// area spans (what a test needs to find a value's pixel).
#[derive(Clone, Debug, PartialEq)]
pub struct PanelPx {
    /// The panel's rows (its title included).
    pub area_y_px: Range<i32>,
    /// The plotting area's columns.
    pub plot_x_px: Range<i32>,
    /// The plotting area's rows.
    pub plot_y_px: Range<i32>,
    /// The left axis's values, bottom to top (lanes count 0, 1, … in a lane panel).
    pub y: Range<f64>,
}

impl PanelPx {
    /// The row at which the left axis shows `v` (±1 px of plotters' rounding).
    pub fn y_px(&self, v: f64) -> f64 {
        let f = (v - self.y.start) / (self.y.end - self.y.start);
        f64::from(self.plot_y_px.end) - f * f64::from(self.plot_y_px.end - self.plot_y_px.start)
    }
}

/// Register the embedded fonts (once per process).
pub(crate) fn fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The embedded DejaVu bytes are a valid font; a failure would only lose the text.
        let _ = register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
        let _ = register_font(FONT, FontStyle::Bold, dejavu::sans::bold());
    });
}

/// A band of one mode over time.
struct Band {
    from_s: f64,
    to_s: f64,
    mode: String,
}

fn mode_colour(mode: &str) -> RGBColor {
    match mode {
        "standby" => RGBColor(236, 236, 236),
        "step-small" => RGBColor(214, 240, 214),
        "step-large" => RGBColor(190, 230, 190),
        "form" => RGBColor(206, 226, 248),
        "recover" => RGBColor(252, 226, 196),
        "autotune" => RGBColor(230, 214, 244),
        "fault" => RGBColor(250, 200, 200),
        _ => RGBColor(250, 250, 250),
    }
}

fn bands(time: &[f64], modes: &[&str]) -> Vec<Band> {
    let mut out: Vec<Band> = Vec::new();
    for (i, (&t, &m)) in time.iter().zip(modes).enumerate() {
        if !t.is_finite() || m.is_empty() || m == "-" {
            continue;
        }
        let end = time[i + 1..]
            .iter()
            .copied()
            .find(|v| v.is_finite())
            .unwrap_or(t);
        match out.last_mut() {
            Some(b) if b.mode == m => b.to_s = end,
            _ => out.push(Band {
                from_s: t,
                to_s: end,
                mode: m.to_string(),
            }),
        }
    }
    out
}

/// Runs of finite points, so a missing measurement breaks a line instead of bridging it.
fn segments(time: &[f64], v: &[f64]) -> Vec<Vec<(f64, f64)>> {
    let mut out = vec![Vec::new()];
    for (&t, &y) in time.iter().zip(v) {
        if t.is_finite() && y.is_finite() {
            if let Some(s) = out.last_mut() {
                s.push((t, y));
            }
        } else if out.last().is_some_and(|s| !s.is_empty()) {
            out.push(Vec::new());
        }
    }
    out.retain(|s| !s.is_empty());
    out
}

fn range_of<'a>(
    cols: impl IntoIterator<Item = &'a [f64]>,
    pad_frac: f64,
    min_span: f64,
) -> Range<f64> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for c in cols {
        for &v in c.iter().filter(|v| v.is_finite()) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if !lo.is_finite() {
        return 0.0..1.0;
    }
    let span = (hi - lo).max(min_span);
    let mid = 0.5 * (lo + hi);
    let lo = mid - 0.5 * span;
    let hi = mid + 0.5 * span;
    (lo - pad_frac * span)..(hi + pad_frac * span)
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

fn err(e: impl std::fmt::Display) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// Width of the legend column right of every panel's plotting area (and its right axis),
/// pixels: a legend never covers data.
pub(crate) const LEGEND_PX: u32 = 250;

/// A line series to draw: its label, values, colour, width and whether it is dashed.
struct Series<'a> {
    label: &'a str,
    values: Vec<f64>,
    colour: RGBColor,
    width: u32,
    dashed: bool,
}

/// How a legend entry shows its series.
#[derive(Clone, Copy)]
pub(crate) enum Swatch {
    /// A line of this width, dashed or not.
    Line {
        /// Its width, pixels.
        width: u32,
        /// Whether it is dashed.
        dashed: bool,
    },
    /// A filled box (a lane's span).
    Box,
    /// A line through a dot (a sweep's points).
    Dot,
}

/// One legend entry.
pub(crate) struct Key {
    /// Its text.
    pub label: String,
    /// Its series' colour.
    pub colour: RGBColor,
    /// How it shows the series.
    pub swatch: Swatch,
}

impl From<&Series<'_>> for Key {
    fn from(s: &Series<'_>) -> Key {
        Key {
            label: s.label.to_string(),
            colour: s.colour,
            swatch: Swatch::Line {
                width: s.width + 1,
                dashed: s.dashed,
            },
        }
    }
}

/// Draw `keys` in the legend column of `area`, right of `right_px` (absolute), from `top_px`.
pub(crate) fn draw_keys(
    area: &Area<'_>,
    right_px: i32,
    top_px: i32,
    keys: &[Key],
) -> Result<(), PlotError> {
    if keys.is_empty() {
        return Ok(());
    }
    let (ax, ay) = area.get_base_pixel();
    let x0 = right_px - ax + 12;
    let y0 = top_px - ay;
    let row_px = 19;
    let w = LEGEND_PX as i32 - 24;
    let h = row_px * keys.len() as i32 + 8;
    area.draw(&Rectangle::new(
        [(x0, y0), (x0 + w, y0 + h)],
        WHITE.mix(0.85).filled(),
    ))
    .map_err(err)?;
    area.draw(&Rectangle::new(
        [(x0, y0), (x0 + w, y0 + h)],
        RGBColor(180, 180, 180),
    ))
    .map_err(err)?;
    for (i, k) in keys.iter().enumerate() {
        let y = y0 + 4 + row_px * i as i32 + row_px / 2;
        let (sx, ex) = (x0 + 6, x0 + 30);
        match k.swatch {
            Swatch::Line { width, dashed } => {
                let style = ShapeStyle::from(&k.colour).stroke_width(width);
                if dashed {
                    for d in [(sx, sx + 8), (sx + 13, sx + 21)] {
                        area.draw(&PathElement::new(vec![(d.0, y), (d.1, y)], style))
                            .map_err(err)?;
                    }
                } else {
                    area.draw(&PathElement::new(vec![(sx, y), (ex, y)], style))
                        .map_err(err)?;
                }
            }
            Swatch::Dot => {
                let style = ShapeStyle::from(&k.colour).stroke_width(2);
                area.draw(&PathElement::new(vec![(sx, y), (ex, y)], style))
                    .map_err(err)?;
                area.draw(&Circle::new((sx + 12, y), 4, k.colour.filled()))
                    .map_err(err)?;
            }
            Swatch::Box => {
                area.draw(&Rectangle::new(
                    [(sx, y - 5), (ex, y + 5)],
                    k.colour.filled(),
                ))
                .map_err(err)?;
            }
        }
        area.draw(&Text::new(
            k.label.clone(),
            (ex + 8, y - 7),
            (FONT, 13).into_font(),
        ))
        .map_err(err)?;
    }
    Ok(())
}

/// A polyline as separate two-point strokes. A thick polyline's joins are mitred, and at a
/// sharp zig-zag (a duty switching 0 ↔ 100 % each period) the mitre reaches far past the points
/// (above 100 %, into the title; below 0 % where the data has no dip): separate strokes end
/// at their points. One-pixel lines have no joins and stay one path.
pub(crate) fn strokes(seg: Vec<(f64, f64)>, style: ShapeStyle) -> Vec<PathElement<(f64, f64)>> {
    if style.stroke_width <= 1 || seg.len() < 3 {
        return vec![PathElement::new(seg, style)];
    }
    seg.windows(2)
        .map(|w| PathElement::new(vec![w[0], w[1]], style))
        .collect()
}

/// Build a panel's chart on `area`: the time axis `x`, the value axis `y`, room on the right
/// for a right axis (`right_axis`) and the legend column.
fn panel_chart<'a, 'b>(
    area: &'a Area<'b>,
    title: &str,
    x: Range<f64>,
    y: Range<f64>,
    right_axis: bool,
    x_desc: Option<&str>,
) -> Result<Chart<'a, BitMapBackend<'b>>, PlotError> {
    let mut b = ChartBuilder::on(area);
    b.margin_left(10)
        .margin_right(10 + LEGEND_PX)
        .margin_top(6)
        .caption(title, (FONT, 18).into_font().style(FontStyle::Bold))
        .x_label_area_size(if x_desc.is_some() { 42 } else { 24 })
        .y_label_area_size(78)
        .right_y_label_area_size(if right_axis { RIGHT_PX } else { 0 });
    if !right_axis {
        b.margin_right(10 + RIGHT_PX + LEGEND_PX);
    }
    b.build_cartesian_2d(x, y).map_err(err)
}

/// Where `chart`'s panel was drawn.
fn panel_px<DB: DrawingBackend>(area: &Area<'_>, chart: &Chart<'_, DB>, y: &Range<f64>) -> PanelPx {
    let (plot_x_px, plot_y_px) = chart.plotting_area().get_pixel_range();
    PanelPx {
        area_y_px: area.get_pixel_range().1,
        plot_x_px,
        plot_y_px,
        y: y.clone(),
    }
}

/// Draw one panel of lines (with the mode bands behind them when `modes` is given).
#[allow(clippy::too_many_arguments)]
fn line_panel(
    area: &Area<'_>,
    title: &str,
    unit: &str,
    time: &[f64],
    x: Range<f64>,
    y: Range<f64>,
    series: &[Series<'_>],
    modes: Option<&[Band]>,
    gaps: &[f64],
    x_desc: Option<&str>,
) -> Result<PanelPx, PlotError> {
    let mut chart = panel_chart(area, title, x.clone(), y.clone(), false, x_desc)?;
    let mut mesh = chart.configure_mesh();
    mesh.y_desc(unit)
        .light_line_style(RGBColor(238, 238, 238))
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14));
    mesh.x_label_formatter(&|v| format!("{v:.0}"));
    if let Some(d) = x_desc {
        mesh.x_desc(d);
    }
    mesh.draw().map_err(err)?;
    if let Some(bands) = modes {
        draw_bands(&mut chart, bands, &x, &y)?;
    }
    draw_gaps(&mut chart, gaps, &y)?;
    let mut keys = Vec::new();
    for s in series {
        let style = ShapeStyle::from(&s.colour).stroke_width(s.width);
        let segs = segments(time, &s.values);
        if !segs.is_empty() {
            keys.push(Key::from(s));
        }
        for seg in segs {
            if s.dashed {
                chart
                    .draw_series(DashedLineSeries::new(seg, 8, 5, style))
                    .map_err(err)?;
            } else {
                chart.draw_series(strokes(seg, style)).map_err(err)?;
            }
        }
    }
    let px = panel_px(area, &chart, &y);
    draw_keys(
        area,
        px.plot_x_px.end + RIGHT_PX as i32,
        px.plot_y_px.start,
        &keys,
    )?;
    Ok(px)
}

/// A panel's chart: time against a value, both `f64`.
type Chart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

fn draw_bands<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    bands: &[Band],
    x: &Range<f64>,
    y: &Range<f64>,
) -> Result<(), PlotError> {
    let top = y.end;
    chart
        .draw_series(bands.iter().map(|b| {
            Rectangle::new(
                [(b.from_s, y.start), (b.to_s, top)],
                mode_colour(&b.mode).mix(0.75).filled(),
            )
        }))
        .map_err(err)?;
    // A label where the band is wide enough for it.
    let px_per_s = chart.plotting_area().dim_in_pixel().0 as f64 / (x.end - x.start).max(1e-9);
    chart
        .draw_series(
            bands
                .iter()
                .filter(|b| (b.to_s - b.from_s) * px_per_s > 7.5 * b.mode.len() as f64 + 6.0)
                .map(|b| {
                    Text::new(
                        b.mode.clone(),
                        (b.from_s + 4.0 / px_per_s, y.start + 0.07 * (top - y.start)),
                        (FONT, 13).into_font().color(&RGBColor(90, 90, 90)),
                    )
                }),
        )
        .map_err(err)?;
    Ok(())
}

fn draw_gaps<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    gaps: &[f64],
    y: &Range<f64>,
) -> Result<(), PlotError> {
    let style = ShapeStyle::from(&RGBColor(200, 0, 0)).stroke_width(2);
    for &g in gaps {
        chart
            .draw_series(DashedLineSeries::new(
                [(g, y.start), (g, y.end)],
                6,
                4,
                style,
            ))
            .map_err(err)?;
    }
    Ok(())
}

/// A span of a lane: from, to (s), its colour and the text written in it where it fits.
#[derive(Clone, Debug, PartialEq)]
struct Span {
    from_s: f64,
    to_s: f64,
    colour: RGBColor,
    text: Option<String>,
}

/// One lane of a lane panel: its name on the axis and its spans.
struct Lane {
    name: String,
    spans: Vec<Span>,
}

/// The runs of rows with the same `Some` key: (from, to, key), a run lasting from its first
/// row's time to the time of the row that ends it (the last row's time at the end).
fn runs(time: &[f64], keys: &[Option<String>]) -> Vec<(f64, f64, String)> {
    let mut out: Vec<(f64, f64, String)> = Vec::new();
    let mut open: Option<(f64, &str)> = None;
    let mut last_t = f64::NAN;
    for (&t, k) in time.iter().zip(keys) {
        if !t.is_finite() {
            continue;
        }
        if let Some((from, key)) = open
            && k.as_deref() != Some(key)
        {
            out.push((from, t, key.to_string()));
            open = None;
        }
        if open.is_none()
            && let Some(k) = k
        {
            open = Some((t, k.as_str()));
        }
        last_t = t;
    }
    if let Some((from, key)) = open {
        out.push((from, last_t, key.to_string()));
    }
    out
}

/// Draw lanes of spans (springs on; faults and frames): one lane per row of the axis.
#[allow(clippy::too_many_arguments)]
fn lane_panel(
    area: &Area<'_>,
    title: &str,
    x: Range<f64>,
    lanes: &[Lane],
    keys: &[Key],
    gaps: &[f64],
    x_desc: Option<&str>,
) -> Result<PanelPx, PlotError> {
    let n = lanes.len() as f64;
    let y = 0.0..n;
    let mut chart = panel_chart(area, title, x.clone(), y.clone(), false, x_desc)?;
    let names: Vec<&str> = lanes.iter().map(|l| l.name.as_str()).collect();
    // Lane i spans [n − i − 1, n − i); its name sits at the middle.
    let lane_label = |v: &f64| {
        let lane = n - v - 0.5;
        let i = lane.round();
        if (lane - i).abs() < 0.05 && i >= 0.0 && (i as usize) < names.len() {
            names[i as usize].to_string()
        } else {
            String::new()
        }
    };
    let mut mesh = chart.configure_mesh();
    mesh.disable_y_mesh()
        .y_labels(lanes.len() * 2 + 1)
        .y_label_formatter(&lane_label)
        .light_line_style(RGBColor(238, 238, 238))
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14));
    mesh.x_label_formatter(&|v| format!("{v:.0}"));
    if let Some(d) = x_desc {
        mesh.x_desc(d);
    }
    mesh.draw().map_err(err)?;
    let px_per_s = chart.plotting_area().dim_in_pixel().0 as f64 / (x.end - x.start).max(1e-9);
    for (i, lane) in lanes.iter().enumerate() {
        let base = n - i as f64 - 1.0;
        chart
            .draw_series(
                [Rectangle::new(
                    [(x.start, base + 0.12), (x.end, base + 0.88)],
                    RGBColor(246, 246, 246).filled(),
                )]
                .into_iter()
                .chain(lane.spans.iter().map(|s| {
                    // A span of one instant still shows (two pixels wide).
                    let to_s = s.to_s.max(s.from_s + 2.0 / px_per_s);
                    Rectangle::new(
                        [(s.from_s, base + 0.12), (to_s, base + 0.88)],
                        s.colour.filled(),
                    )
                })),
            )
            .map_err(err)?;
        chart
            .draw_series(lane.spans.iter().enumerate().filter_map(|(j, s)| {
                // In the span (white) where it fits, else after it (in its colour) where the
                // lane is free up to the next span.
                let text = s.text.as_ref()?;
                let text_s = (7.0 * text.len() as f64 + 8.0) / px_per_s;
                let next_s = lane.spans.get(j + 1).map_or(x.end, |n| n.from_s);
                let (at_s, colour) = if s.to_s - s.from_s > text_s {
                    (s.from_s, WHITE)
                } else if next_s - s.to_s > text_s {
                    (s.to_s, s.colour)
                } else {
                    return None;
                };
                Some(Text::new(
                    text.clone(),
                    (at_s + 4.0 / px_per_s, base + 0.75),
                    (FONT, 12).into_font().color(&colour),
                ))
            }))
            .map_err(err)?;
    }
    draw_gaps(&mut chart, gaps, &y)?;
    let px = panel_px(area, &chart, &y);
    draw_keys(
        area,
        px.plot_x_px.end + RIGHT_PX as i32,
        px.plot_y_px.start,
        keys,
    )?;
    Ok(px)
}

/// The left (bending angle, °) and right (k_b, N·mm/rad) ranges of the bending panel, set so
/// that the curves do not lie on each other: the angle from its zero (or below) to its largest
/// value near the top; the stiffness from zero, its largest value at three quarters of the
/// height, so its smallest (the heated lattice's ≈ 310) sits clear above the straight column's
/// 0° and its formed ≈ 1500 below the bent column's largest angle.
fn twin_ranges(bend: Option<&[f64]>, k_b: Option<&[f64]>) -> (Range<f64>, Range<f64>) {
    let finite = |v: Option<&[f64]>| -> Vec<f64> {
        v.unwrap_or(&[])
            .iter()
            .copied()
            .filter(|x| x.is_finite())
            .collect()
    };
    let b = finite(bend);
    let lo = b.iter().copied().fold(0.0, f64::min);
    let hi = b.iter().copied().fold(lo + 5.0, f64::max);
    let span = hi - lo;
    let y = (lo - 0.05 * span)..(hi + 0.07 * span);
    let k = finite(k_b);
    let k_lo = k.iter().copied().fold(f64::INFINITY, f64::min);
    let y2 = if k_lo.is_finite() && k_lo >= 0.0 {
        let k_hi = k.iter().copied().fold(k_lo + 50.0, f64::max);
        0.0..(k_hi / 0.75)
    } else {
        range_of(k_b, 0.05, 50.0)
    };
    (y, y2)
}

/// Draw the bending angle (left axis), the firmware's estimate of it where the table has one
/// (`est_bend_deg`, a simulator run's; a desk recording's `bend_deg` is the estimate itself),
/// and the bending stiffness (right axis).
fn bending_panel(
    area: &Area<'_>,
    time: &[f64],
    x: Range<f64>,
    bend: Option<&[f64]>,
    est: Option<&[f64]>,
    k_b: Option<&[f64]>,
    x_desc: Option<&str>,
) -> Result<PanelPx, PlotError> {
    // A table without stiffness (a desk recording: the board does not measure it) gets no
    // right axis: an empty 0–1 scale there reads as a stiffness of nothing.
    let k_b = k_b.filter(|k| k.iter().any(|v| v.is_finite()));
    let (y, y2) = twin_ranges(bend, k_b);
    let blue = RGBColor(30, 90, 200);
    let green = RGBColor(20, 140, 60);
    let mut chart = panel_chart(
        area,
        if k_b.is_some() {
            "Bending performance and stiffness"
        } else {
            "Bending performance"
        },
        x.clone(),
        y.clone(),
        true,
        x_desc,
    )?
    .set_secondary_coord(x, y2);
    let mut mesh = chart.configure_mesh();
    mesh.y_desc("bending angle φ, °")
        .light_line_style(RGBColor(238, 238, 238))
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14).into_font().color(&blue));
    mesh.x_label_formatter(&|v| format!("{v:.0}"));
    if let Some(d) = x_desc {
        mesh.x_desc(d);
    }
    mesh.draw().map_err(err)?;
    if k_b.is_some() {
        chart
            .configure_secondary_axes()
            .y_desc("k_b, N·mm/rad")
            .label_style((FONT, 13))
            .axis_desc_style((FONT, 14).into_font().color(&green))
            .draw()
            .map_err(err)?;
    }
    let mut keys = Vec::new();
    // Which axis a line is read on, said only where there are two.
    let side = |label: &str| {
        if k_b.is_some() {
            format!("{label} (left)")
        } else {
            label.to_string()
        }
    };
    let line = |label: &str, colour| Key {
        label: label.to_string(),
        colour,
        swatch: Swatch::Line {
            width: 3,
            dashed: false,
        },
    };
    if let Some(b) = bend {
        keys.push(line(&side("bending angle φ"), blue));
        for seg in segments(time, b) {
            chart
                .draw_series(strokes(seg, blue.stroke_width(2)))
                .map_err(err)?;
        }
    }
    if let Some(e) = est {
        let orange = RGBColor(230, 120, 20);
        keys.push(line(&side("estimate, camera + model"), orange));
        for seg in segments(time, e) {
            chart
                .draw_series(strokes(seg, orange.stroke_width(1)))
                .map_err(err)?;
        }
    }
    if let Some(k) = k_b {
        keys.push(line("bending stiffness k_b (right)", green));
        for seg in segments(time, k) {
            chart
                .draw_secondary_series(strokes(seg, green.stroke_width(2)))
                .map_err(err)?;
        }
    }
    let (plot_x_px, plot_y_px) = chart.plotting_area().get_pixel_range();
    draw_keys(
        area,
        plot_x_px.end + RIGHT_PX as i32,
        plot_y_px.start,
        &keys,
    )?;
    Ok(PanelPx {
        area_y_px: area.get_pixel_range().1,
        plot_x_px,
        plot_y_px,
        y,
    })
}

/// The duty panel's range, %: 0–100 (wider if the data is), with room above 100 % for the line
/// and below 0 %, so the line at full duty stays clear of the panel's title.
fn duty_range(cols: &[&[f64]]) -> Range<f64> {
    let finite = cols
        .iter()
        .flat_map(|c| c.iter().copied().filter(|v| v.is_finite()));
    let (lo, hi) = finite.fold((0.0_f64, 100.0_f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
    let span = hi - lo;
    (lo - 0.05 * span)..(hi + 0.1 * span)
}

/// The events' lanes: injected faults (`faults`, a bit mask: bit i = the scene's fault i + 1),
/// latched faults (`fault`, its code; `none`, `-` or empty for none) and the frames MTTS did
/// not resolve (`quality` not `resolved`: `merged`, `fallback`; no frame where it is `none` or
/// the measured `t1_k` is not a number). A lane whose column the table lacks is left out.
fn event_lanes(table: &Table, time: &[f64]) -> (Vec<Lane>, Vec<Key>) {
    let injected_c = RGBColor(235, 140, 30);
    let latched_c = RGBColor(150, 20, 90);
    let no_frame_c = RGBColor(95, 95, 95);
    let unresolved_c = RGBColor(160, 120, 215);
    let mut lanes = Vec::new();
    let mut keys = Vec::new();
    let key = |label: &str, colour| Key {
        label: label.to_string(),
        colour,
        swatch: Swatch::Box,
    };
    let span = |(from_s, to_s, text): (f64, f64, String), colour| Span {
        from_s,
        to_s,
        colour,
        text: Some(text),
    };
    if let Some(mask) = table.text("faults") {
        let names: Vec<Option<String>> = mask
            .iter()
            .map(|m| {
                let bits = m.parse::<u32>().ok().filter(|b| *b != 0)?;
                let on: Vec<String> = (0..32)
                    .filter(|i| bits & (1 << i) != 0)
                    .map(|i| (i + 1).to_string())
                    .collect();
                Some(format!("fault {}", on.join("+")))
            })
            .collect();
        let spans = runs(time, &names)
            .into_iter()
            .map(|r| span(r, injected_c))
            .collect();
        lanes.push(Lane {
            name: "injected".into(),
            spans,
        });
        keys.push(key("injected fault (scene)", injected_c));
    }
    if let Some(codes) = table.text("fault") {
        let names: Vec<Option<String>> = codes
            .iter()
            .map(|c| (!matches!(*c, "" | "-" | "none")).then(|| c.to_string()))
            .collect();
        let spans = runs(time, &names)
            .into_iter()
            .map(|r| span(r, latched_c))
            .collect();
        lanes.push(Lane {
            name: "latched".into(),
            spans,
        });
        keys.push(key("latched fault (code)", latched_c));
    }
    let quality = table.text("quality");
    let t1 = table.text("t1_k");
    if quality.is_some() || t1.is_some() {
        let names: Vec<Option<String>> = (0..time.len())
            .map(|i| {
                let q = quality.as_ref().map_or("resolved", |q| q[i]);
                let measured = t1
                    .as_ref()
                    .is_none_or(|t| t[i].parse::<f64>().is_ok_and(f64::is_finite));
                match q {
                    _ if !measured => Some("no frame".to_string()),
                    "" | "-" | "none" => Some("no frame".to_string()),
                    "resolved" => None,
                    other => Some(other.to_string()),
                }
            })
            .collect();
        let spans = runs(time, &names)
            .into_iter()
            .map(|r| {
                let colour = if r.2 == "no frame" {
                    no_frame_c
                } else {
                    unresolved_c
                };
                span(r, colour)
            })
            .collect();
        lanes.push(Lane {
            name: "MTTS".into(),
            spans,
        });
        keys.push(key("no MTTS frame", no_frame_c));
        keys.push(key("frame not resolved", unresolved_c));
    }
    (lanes, keys)
}

/// The events panel's title, naming the lanes it has: `Faults and frames (injected, latched;
/// MTTS)` for a simulator run, `Faults and frames (latched; MTTS)` for a desk recording (the
/// board knows no injected faults).
fn events_title(lanes: &[Lane]) -> String {
    let faults: Vec<&str> = lanes
        .iter()
        .map(|l| l.name.as_str())
        .filter(|n| *n != "MTTS")
        .collect();
    let frames = lanes.iter().any(|l| l.name == "MTTS");
    match (faults.is_empty(), frames) {
        (false, true) => format!("Faults and frames ({}; MTTS)", faults.join(", ")),
        (false, false) => format!("Faults ({})", faults.join(", ")),
        (true, _) => "Frames (MTTS)".to_string(),
    }
}

enum Panel {
    Temps,
    Duties,
    Springs,
    Bending,
    Events,
}

/// Render `table` as a PNG at `out` with `title`; return which panels it drew.
///
/// Columns read (the first present of each alias): time `t_s` (the board's clock) where it never
/// goes back, else `time_s`; temperatures
/// `t1_k`…`t5_k`, `target_k`, `tc_k`; modes `mode`; duties `heater_duty_pct`/`heater_pct` and
/// `fan_duty_pct`/`fan_pct`; springs `spring_a`…`spring_c` (0/1) or `springs` (letters, `-`
/// for none); `bend_deg`, `k_b_nmm_per_rad`; `gap` (on the first row after a recording gap, why — any
/// value but empty, `-` or `0` — drawn as a red dashed line); the events lanes' `faults`,
/// `fault`, `quality` and `t1_k` (see `event_lanes`).
pub fn render(table: &Table, title: &str, out: &Path) -> Result<PlotInfo, PlotError> {
    fonts();
    // The board's clock where it runs steadily (a recording of the simulator at --speed X
    // shows simulated seconds); the host's where the board restarted.
    let board = table.num("t_s");
    let steady = |v: &[f64]| {
        let f: Vec<f64> = v.iter().copied().filter(|t| t.is_finite()).collect();
        f.windows(2).all(|w| w[1] >= w[0])
    };
    let (time, x_desc) = match (board, table.num("time_s")) {
        (Some(b), _) if steady(&b) => (b, "board time, s"),
        (Some(_), Some(h)) => (h, "host time, s (the board's clock restarted)"),
        (None, Some(h)) => (h, "time, s"),
        (Some(b), None) => (b, "board time, s"),
        (None, None) => {
            return Err(PlotError::NoTime);
        }
    };
    let x = {
        let r = range_of([time.as_slice()], 0.0, 1e-3);
        r.start..r.end
    };
    let temps: Vec<(String, Vec<f64>)> = (1..=5)
        .filter_map(|i| {
            let n = format!("t{i}_k");
            table.num(&n).map(|v| (n, v))
        })
        .collect();
    let target = table.num("target_k");
    let tc = table.num("tc_k");
    let heater = table.num_any(&["heater_duty_pct", "heater_pct"]);
    let fan = table.num_any(&["fan_duty_pct", "fan_pct"]);
    let springs = spring_columns(table);
    let bend = table.num("bend_deg");
    let est_bend = table.num("est_bend_deg");
    let k_b = table.num("k_b_nmm_per_rad");
    let modes = table.text("mode").map(|m| bands(&time, &m));
    let gaps: Vec<f64> = table
        .text("gap")
        .map(|g| {
            time.iter()
                .zip(&g)
                .filter(|(_, g)| !matches!(**g, "" | "-" | "0"))
                .map(|(t, _)| *t)
                .collect()
        })
        .unwrap_or_default();

    let mut panels = Vec::new();
    if !temps.is_empty() || target.is_some() || tc.is_some() {
        panels.push((Panel::Temps, TEMP_H));
    }
    if heater.is_some() || fan.is_some() {
        panels.push((Panel::Duties, PANEL_H));
    }
    if !springs.is_empty() {
        panels.push((Panel::Springs, SPRING_H));
    }
    if bend.is_some() || k_b.is_some() {
        panels.push((Panel::Bending, PANEL_H + 40));
    }
    if panels.is_empty() {
        return Err(PlotError::NoColumns);
    }
    let (event_lanes, event_keys) = event_lanes(table, &time);
    if !event_lanes.is_empty() {
        panels.push((Panel::Events, EVENTS_H + LANE_H * event_lanes.len() as u32));
    }
    let height = TITLE_H + panels.iter().map(|p| p.1).sum::<u32>() + 20;
    let root = BitMapBackend::new(out, (WIDTH_PX, height)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let body = root
        .titled(title, (FONT, 24).into_font().style(FontStyle::Bold))
        .map_err(err)?;
    let mut breaks = Vec::new();
    let mut y = 0;
    for p in &panels[..panels.len() - 1] {
        y += p.1 as i32;
        breaks.push(y);
    }
    let areas = body.split_by_breakpoints([] as [i32; 0], breaks);
    let mut names = Vec::new();
    let n = panels.len();
    for (i, ((panel, _), area)) in panels.iter().zip(&areas).enumerate() {
        let last = (i + 1 == n).then_some(x_desc);
        match panel {
            Panel::Temps => {
                let palette = [
                    RGBColor(200, 30, 30),
                    RGBColor(30, 90, 200),
                    RGBColor(120, 120, 120),
                    RGBColor(170, 150, 110),
                    RGBColor(160, 190, 200),
                ];
                let labels = [
                    "T1 first target (heater film)",
                    "T2 second target (SMP surface)",
                    "T3 cylinder",
                    "T4 radiation zone",
                    "T5 background",
                ];
                let mut series: Vec<Series<'_>> = temps
                    .iter()
                    .map(|(n, v)| {
                        let i = n[1..2].parse::<usize>().unwrap_or(1) - 1;
                        Series {
                            label: labels[i],
                            values: v.clone(),
                            colour: palette[i],
                            width: if i < 2 { 2 } else { 1 },
                            dashed: false,
                        }
                    })
                    .collect();
                if let Some(t) = &tc {
                    series.push(Series {
                        label: "Tc (controlled)",
                        values: t.clone(),
                        colour: RGBColor(0, 0, 0),
                        width: 1,
                        dashed: false,
                    });
                }
                if let Some(t) = &target {
                    series.push(Series {
                        label: "target",
                        values: t.clone(),
                        colour: RGBColor(20, 140, 60),
                        width: 2,
                        dashed: true,
                    });
                }
                let cols: Vec<&[f64]> = series.iter().map(|s| s.values.as_slice()).collect();
                let yr = range_of(cols, 0.12, 10.0);
                let px = line_panel(
                    area,
                    if modes.as_ref().is_some_and(|b| !b.is_empty()) {
                        "Region temperatures, target and Tc (bands: mode)"
                    } else {
                        "Region temperatures"
                    },
                    "temperature, K",
                    &time,
                    x.clone(),
                    yr,
                    &series,
                    modes.as_deref(),
                    &gaps,
                    last,
                )?;
                names.push(("temperatures".to_string(), px));
            }
            Panel::Duties => {
                let mut series = Vec::new();
                if let Some(h) = &heater {
                    series.push(Series {
                        label: "heater duty",
                        values: h.clone(),
                        colour: RGBColor(200, 30, 30),
                        width: 2,
                        dashed: false,
                    });
                }
                if let Some(f) = &fan {
                    series.push(Series {
                        label: "fan duty",
                        values: f.clone(),
                        colour: RGBColor(30, 90, 200),
                        width: 2,
                        dashed: false,
                    });
                }
                let cols: Vec<&[f64]> = series.iter().map(|s| s.values.as_slice()).collect();
                let px = line_panel(
                    area,
                    "Heater and fan duty",
                    "duty, %",
                    &time,
                    x.clone(),
                    duty_range(&cols),
                    &series,
                    None,
                    &gaps,
                    last,
                )?;
                names.push(("duties".to_string(), px));
            }
            Panel::Springs => {
                let colours = [
                    RGBColor(200, 40, 40),
                    RGBColor(230, 130, 0),
                    RGBColor(130, 60, 180),
                ];
                let lanes: Vec<Lane> = springs
                    .iter()
                    .enumerate()
                    .map(|(i, (name, on))| {
                        let keys: Vec<Option<String>> =
                            on.iter().map(|v| (*v > 0.5).then(String::new)).collect();
                        Lane {
                            name: format!("spring {name}"),
                            spans: runs(&time, &keys)
                                .into_iter()
                                .map(|(from_s, to_s, _)| Span {
                                    from_s,
                                    to_s,
                                    colour: colours[i % colours.len()],
                                    text: None,
                                })
                                .collect(),
                        }
                    })
                    .collect();
                let px = lane_panel(
                    area,
                    "SMA springs (on = driven)",
                    x.clone(),
                    &lanes,
                    &[],
                    &gaps,
                    last,
                )?;
                names.push(("springs".to_string(), px));
            }
            Panel::Bending => {
                let px = bending_panel(
                    area,
                    &time,
                    x.clone(),
                    bend.as_deref(),
                    est_bend.as_deref(),
                    k_b.as_deref(),
                    last,
                )?;
                names.push(("bending".to_string(), px));
            }
            Panel::Events => {
                let px = lane_panel(
                    area,
                    &events_title(&event_lanes),
                    x.clone(),
                    &event_lanes,
                    &event_keys,
                    &gaps,
                    last,
                )?;
                names.push(("events".to_string(), px));
            }
        }
    }
    root.present().map_err(err)?;
    let (panels, panel_px) = names.into_iter().unzip();
    Ok(PlotInfo {
        panels,
        panel_px,
        size_px: (WIDTH_PX, height),
    })
}

/// The spring states as 0/1 columns: `spring_a`… if present, else decoded from `springs`
/// letters with the library's own parser.
fn spring_columns(table: &Table) -> Vec<(char, Vec<f64>)> {
    let names = thermorph::outputs::SPRING_NAMES;
    let direct: Vec<(char, Vec<f64>)> = names
        .iter()
        .filter_map(|&c| {
            table
                .num(&format!("spring_{}", c.to_ascii_lowercase()))
                .map(|v| (c, v))
        })
        .collect();
    if !direct.is_empty() {
        return direct;
    }
    let Some(letters) = table.text("springs") else {
        return Vec::new();
    };
    names
        .iter()
        .enumerate()
        .map(|(i, &c)| {
            let v = letters
                .iter()
                .map(|w| match thermorph::outputs::SpringMask::parse(w) {
                    Some(m) => f64::from(u8::from(m.contains(i))),
                    None if *w == "-" => 0.0,
                    None => f64::NAN,
                })
                .collect();
            (c, v)
        })
        .collect()
}

/// Plot a CSV file (host-sim's `timeseries.csv` or a desk recording) as a PNG.
pub fn plot_csv(csv: &Path, out: &Path, title: Option<&str>) -> Result<PlotInfo, PlotError> {
    let table = Table::read(csv)?;
    let name = csv.file_name().map_or_else(
        || "time series".into(),
        |n| n.to_string_lossy().into_owned(),
    );
    render(&table, title.unwrap_or(&name), out)
}

/// Write the PNG plot of a run from its `timeseries.csv` text ([`crate::runs::series::csv_text`]).
pub fn write_png(csv: &str, scene: &str, path: &Path) -> Result<(), PlotError> {
    let table = Table::parse(csv)?;
    render(&table, &format!("host-sim run: scene {scene}"), path).map(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_reads_columns_and_pads_short_rows() {
        let t = Table::parse("time_s,a,mode\n0,1.5,standby\n1,nan\n2,x,form\n").unwrap();
        assert_eq!(t.len(), 3);
        assert_eq!(t.text("mode").unwrap(), ["standby", "", "form"]);
        let a = t.num("a").unwrap();
        assert_eq!(a[0], 1.5);
        assert!(a[1].is_nan() && a[2].is_nan());
        assert!(t.num("mode").is_none(), "no number in it");
        assert!(t.num("nope").is_none());
        assert!(Table::parse("\n\n").is_err());
    }

    #[test]
    fn bands_merge_runs_and_segments_break_at_nan() {
        let time = [0.0, 1.0, 2.0, 3.0, 4.0];
        let b = bands(&time, &["standby", "standby", "form", "form", "recover"]);
        let got: Vec<(f64, f64, &str)> = b
            .iter()
            .map(|b| (b.from_s, b.to_s, b.mode.as_str()))
            .collect();
        assert_eq!(
            got,
            [
                (0.0, 2.0, "standby"),
                (2.0, 4.0, "form"),
                (4.0, 4.0, "recover")
            ]
        );
        let s = segments(&time, &[1.0, f64::NAN, 3.0, 4.0, f64::NAN]);
        assert_eq!(s, vec![vec![(0.0, 1.0)], vec![(2.0, 3.0), (3.0, 4.0)]]);
    }

    #[test]
    fn springs_from_letters_use_the_library_parser() {
        let t = Table::parse("t_s,springs\n0,-\n1,AB\n2,C\n3,??\n").unwrap();
        let s = spring_columns(&t);
        assert_eq!(s.len(), 3);
        assert_eq!(&s[0].1[..3], [0.0, 1.0, 0.0]);
        assert_eq!(&s[1].1[..3], [0.0, 1.0, 0.0]);
        assert_eq!(&s[2].1[..3], [0.0, 0.0, 1.0]);
        assert!(s[0].1[3].is_nan());
    }

    #[test]
    fn telemetry_csv_plots_without_the_simulators_columns() {
        let mut csv = String::from(
            "time_s,t_s,mode,t1_k,t2_k,tc_k,target_k,heater_pct,fan_pct,springs,quality,fault,gap\n",
        );
        for i in 0..200 {
            let t = i as f64 * 0.5;
            let mode = if i < 80 {
                "standby"
            } else if i < 150 {
                "step-large"
            } else {
                "form"
            };
            let springs = if (90..120).contains(&i) { "AB" } else { "-" };
            let gap = if i == 100 { "reset" } else { "-" };
            csv += &format!(
                "{t},{t},{mode},{},{},{},{},{},{},{springs},resolved,none,{gap}\n",
                300.0 + i as f64 * 0.3,
                299.0 + i as f64 * 0.28,
                299.0 + i as f64 * 0.28,
                if i < 80 { 323.0 } else { 358.0 },
                if i < 150 { 60.0 } else { 0.0 },
                if i < 150 { 0.0 } else { 100.0 },
            );
        }
        let dir = std::env::temp_dir().join(format!("thermorph-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let png = dir.join("telemetry.png");
        let info = render(&Table::parse(&csv).unwrap(), "telemetry", &png).unwrap();
        assert_eq!(info.panels, ["temperatures", "duties", "springs", "events"]);
        assert_eq!(info.panel_px.len(), 4);
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        let reader = decoder.read_info().unwrap();
        assert_eq!((reader.info().width, reader.info().height), info.size_px);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Render `csv` into a temporary PNG; return what `render` says and the RGB pixels, row by
    /// row.
    fn rendered(csv: &str, name: &str) -> (PlotInfo, Vec<Vec<[u8; 3]>>) {
        let dir = std::env::temp_dir().join(format!("thermorph-plot-px-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let png = dir.join(format!("{name}.png"));
        let info = render(&Table::parse(csv).unwrap(), name, &png).unwrap();
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let frame = reader.next_frame(&mut buf).unwrap();
        assert_eq!(frame.color_type, png::ColorType::Rgb);
        let (w, h) = (frame.width as usize, frame.height as usize);
        let px = (0..h)
            .map(|y| {
                (0..w)
                    .map(|x| {
                        let i = 3 * (y * w + x);
                        [buf[i], buf[i + 1], buf[i + 2]]
                    })
                    .collect()
            })
            .collect();
        if std::env::var_os("THERMORPH_KEEP_PLOT").is_none() {
            std::fs::remove_file(&png).unwrap();
        }
        (info, px)
    }

    /// Whether a pixel is of `colour` (within the anti-aliasing of its edges).
    fn is(p: [u8; 3], colour: RGBColor) -> bool {
        let d = |a: u8, b: u8| (i32::from(a) - i32::from(b)).abs();
        d(p[0], colour.0) + d(p[1], colour.1) + d(p[2], colour.2) < 60
    }

    const HEATER: RGBColor = RGBColor(200, 30, 30);

    #[test]
    fn a_zig_zag_duty_stays_between_its_0_and_100_percent_lines() {
        // The heater duty switches 0 ↔ 100 % every period (a duty whose maximum is exactly
        // 100.0), with runs of a few periods between.
        let mut csv = String::from("time_s,heater_duty_pct,fan_duty_pct\n");
        for i in 0..1800 {
            let on = if i % 97 < 60 {
                i % 2 == 0
            } else {
                (i / 3) % 2 == 0
            };
            csv += &format!(
                "{},{},0.0\n",
                f64::from(i) * 0.25,
                if on { 100.0 } else { 0.0 }
            );
        }
        let (info, px) = rendered(&csv, "zig-zag duty");
        assert_eq!(info.panels, ["duties"]);
        let p = &info.panel_px[0];
        let (top_100, bottom_0) = (p.y_px(100.0), p.y_px(0.0));
        assert!(
            top_100 > f64::from(p.plot_y_px.start) + 5.0,
            "no room above 100 %: {p:?}"
        );
        let count = |rows: Range<i32>| {
            rows.flat_map(|y| p.plot_x_px.clone().map(move |x| (x, y)))
                .filter(|&(x, y)| is(px[y as usize][x as usize], HEATER))
                .count()
        };
        // Nothing of the duty's colour above 100 % (the panel's title included) or below 0 %,
        // beyond the line's half width and a pixel of rounding...
        let above = count(p.area_y_px.start..(top_100 - 2.5) as i32);
        let below = count((bottom_0 + 3.5) as i32..p.plot_y_px.end);
        assert_eq!(
            (above, below),
            (0, 0),
            "{p:?}: 100 % at {top_100}, 0 % at {bottom_0}"
        );
        // ... nor in the plot's title.
        let title = (0..TITLE_H as usize)
            .flat_map(|y| px[y].iter())
            .filter(|&&c| is(c, HEATER))
            .count();
        assert_eq!(title, 0);
        // The line is drawn, at 100 % and at 0 %.
        assert!(count((top_100 - 1.5) as i32..(top_100 + 2.0) as i32) > 500);
        assert!(count((bottom_0 - 1.5) as i32..(bottom_0 + 2.0) as i32) > 500);
    }

    #[test]
    fn legends_sit_beside_the_data_not_over_it() {
        // T1 climbs to the top right corner, where a legend inside the plot would sit; k_b
        // starts at the top left.
        let mut csv = String::from("time_s,t1_k,t2_k,bend_deg,k_b_nmm_per_rad\n");
        let n = 400;
        for i in 0..=n {
            let f = f64::from(i) / f64::from(n);
            csv += &format!(
                "{},{},290,{},{}\n",
                f * 100.0,
                300.0 + 100.0 * f,
                60.0 * f,
                1500.0 - 1190.0 * f
            );
        }
        let (info, px) = rendered(&csv, "legends");
        assert_eq!(info.panels, ["temperatures", "bending", "events"]);
        let t = &info.panel_px[0];
        // Every column of the plotting area shows T1 within a few pixels of where it is.
        let span = f64::from(t.plot_x_px.end - t.plot_x_px.start - 1);
        let hidden: Vec<i32> = t
            .plot_x_px
            .clone()
            .filter(|&x| {
                let f = f64::from(x - t.plot_x_px.start) / span;
                let y = t.y_px(300.0 + 100.0 * f).round() as i32;
                !((y - 4)..=(y + 4)).any(|y| is(px[y as usize][x as usize], HEATER))
            })
            .collect();
        assert!(hidden.is_empty(), "T1 covered at columns {hidden:?}");
        // The legend's text is right of the plotting area.
        let legend_text = |p: &PanelPx| {
            p.plot_y_px
                .clone()
                .flat_map(|y| {
                    (p.plot_x_px.end + RIGHT_PX as i32..WIDTH_PX as i32).map(move |x| (x, y))
                })
                .filter(|&(x, y)| px[y as usize][x as usize][0] < 80)
                .count()
        };
        assert!(legend_text(t) > 100);
        let b = &info.panel_px[1];
        assert!(legend_text(b) > 100);
        // k_b starts top left: its green is there, under no legend box.
        let green = RGBColor(20, 140, 60);
        let x = b.plot_x_px.start + 5;
        assert!((b.plot_y_px.clone()).any(|y| is(px[y as usize][x as usize], green)));
    }

    #[test]
    fn a_recording_without_stiffness_draws_no_stiffness_axis() {
        // A desk recording: the bend, no k_b (the column there, empty).
        let table = |k_b: &dyn Fn(f64) -> String| {
            let mut csv = String::from("time_s,t1_k,t2_k,bend_deg,k_b_nmm_per_rad\n");
            for i in 0..=100 {
                let f = f64::from(i) / 100.0;
                csv += &format!(
                    "{},{},290,{},{}\n",
                    f * 100.0,
                    300.0 + 50.0 * f,
                    60.0 * f,
                    k_b(f)
                );
            }
            csv
        };
        // Dark pixels (axis labels) in the right axis's margin of the bending panel.
        let right_axis_ink = |csv: &str, name: &str| {
            let (info, px) = rendered(csv, name);
            let b = info.panel_px[1].clone();
            b.plot_y_px
                .clone()
                .flat_map(|y| {
                    (b.plot_x_px.end + 3..b.plot_x_px.end + RIGHT_PX as i32 - 3)
                        .map(move |x| (x, y))
                })
                .filter(|&(x, y)| px[y as usize][x as usize][0] < 80)
                .count()
        };
        assert!(right_axis_ink(&table(&|f| format!("{}", 1500.0 - 1190.0 * f)), "with-kb") > 50);
        assert_eq!(
            right_axis_ink(&table(&|_| "-".to_string()), "without-kb"),
            0
        );
    }

    #[test]
    fn the_twin_axes_keep_the_angle_and_the_stiffness_apart() {
        // The cycle's extremes: straight and heated (0°, 310 N·mm/rad), bent and formed (64°,
        // 1510 N·mm/rad).
        let bend = [0.0, 64.0];
        let k_b = [310.0, 1510.0];
        let (y, y2) = twin_ranges(Some(&bend), Some(&k_b));
        let frac = |v: f64, r: &Range<f64>| (v - r.start) / (r.end - r.start);
        assert!(frac(0.0, &y) >= 0.0 && frac(64.0, &y) <= 1.0);
        assert!(frac(310.0, &y2) >= 0.0 && frac(1510.0, &y2) <= 1.0);
        // A tenth of the panel's height apart at both ends: ≈ 17 px of a 170 px plot.
        assert!(frac(310.0, &y2) - frac(0.0, &y) > 0.1, "{y:?} {y2:?}");
        assert!(frac(64.0, &y) - frac(1510.0, &y2) > 0.1, "{y:?} {y2:?}");
        // Either alone still gets a range.
        let (y, _) = twin_ranges(Some(&[f64::NAN]), None);
        assert!(y.end > y.start);
    }

    #[test]
    fn faults_and_unresolved_frames_are_marked_on_the_time_axis() {
        let mut csv = String::from("time_s,heater_duty_pct,t1_k,faults,fault,quality\n");
        for i in 0..200 {
            let t = f64::from(i);
            let t1 = if (120..130).contains(&i) {
                "nan".to_string()
            } else {
                "330".to_string()
            };
            let faults = if (20..60).contains(&i) {
                1
            } else if (60..70).contains(&i) {
                5
            } else {
                0
            };
            let fault = if (40..90).contains(&i) {
                "runaway-heating"
            } else {
                "none"
            };
            let quality = match i {
                120..130 => "none",
                150..170 => "merged",
                _ => "resolved",
            };
            csv += &format!("{t},50,{t1},{faults},{fault},{quality}\n");
        }
        let table = Table::parse(&csv).unwrap();
        let time = table.num("time_s").unwrap();
        let (lanes, keys) = event_lanes(&table, &time);
        let spans = |i: usize| -> Vec<(f64, f64, Option<String>)> {
            lanes[i]
                .spans
                .iter()
                .map(|s| (s.from_s, s.to_s, s.text.clone()))
                .collect()
        };
        let names: Vec<&str> = lanes.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names, ["injected", "latched", "MTTS"]);
        assert_eq!(
            events_title(&lanes),
            "Faults and frames (injected, latched; MTTS)"
        );
        assert_eq!(keys.len(), 4);
        assert_eq!(
            spans(0),
            [
                (20.0, 60.0, Some("fault 1".into())),
                (60.0, 70.0, Some("fault 1+3".into()))
            ]
        );
        assert_eq!(spans(1), [(40.0, 90.0, Some("runaway-heating".into()))]);
        assert_eq!(
            spans(2),
            [
                (120.0, 130.0, Some("no frame".into())),
                (150.0, 170.0, Some("merged".into()))
            ]
        );
        // Without a quality column, a missing T1 is a missing frame.
        let t = Table::parse("t_s,t1_k\n0,300\n1,nan\n2,nan\n3,301\n").unwrap();
        let (lanes, _) = event_lanes(&t, &t.num("t_s").unwrap());
        assert_eq!(lanes[0].spans.len(), 1);
        assert_eq!(
            (lanes[0].spans[0].from_s, lanes[0].spans[0].to_s),
            (1.0, 3.0)
        );
        let (info, _) = rendered(&csv, "events");
        assert_eq!(info.panels, ["temperatures", "duties", "events"]);
        // A desk recording has no injected faults: its panel's title does not promise them
        // (issue 44: docs/desk-cycle.png's title named a lane it did not draw).
        let desk = Table::parse("t_s,t1_k,fault,quality\n0,300,none,resolved\n1,301,none,merged\n")
            .unwrap();
        let (lanes, _) = event_lanes(&desk, &desk.num("t_s").unwrap());
        assert_eq!(events_title(&lanes), "Faults and frames (latched; MTTS)");
        assert_eq!(events_title(&lanes[1..]), "Frames (MTTS)");
        assert_eq!(events_title(&lanes[..1]), "Faults (latched)");
    }

    #[test]
    fn a_csv_without_time_or_plotted_columns_is_an_error() {
        let dir = std::env::temp_dir();
        let png = dir.join(format!("thermorph-plot-none-{}.png", std::process::id()));
        let t = Table::parse("a,b\n1,2\n").unwrap();
        assert!(
            render(&t, "x", &png)
                .unwrap_err()
                .to_string()
                .contains("time")
        );
        let t = Table::parse("time_s,b\n1,2\n").unwrap();
        assert!(
            render(&t, "x", &png)
                .unwrap_err()
                .to_string()
                .contains("none of")
        );
    }
}
