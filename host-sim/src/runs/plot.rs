//! Every PNG plot, drawn with plotters: a time series as stacked panels over a shared time
//! axis, in the style of the thesis's figures 6.8–6.10 (region temperatures with the target, Tc
//! and the modes as coloured bands; heater and fan duties; spring states; bending angle with
//! the bending stiffness on a second axis).
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

/// Which panels a plot drew, and its size.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlotInfo {
    /// Panel titles, top to bottom.
    pub panels: Vec<String>,
    /// Width and height, pixels.
    pub size_px: (u32, u32),
}

/// Style a legend as every plot draws it (at `pos`, on white, grey border, 13 px text).
pub(crate) fn legend<'s, 'a, 'b, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    labels: &'s mut plotters::chart::SeriesLabelStyle<'a, 'b, DB, CT>,
    pos: SeriesLabelPosition,
) -> &'s mut plotters::chart::SeriesLabelStyle<'a, 'b, DB, CT> {
    labels
        .position(pos)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .label_font((FONT, 13))
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

/// A line series to draw: its label, values, colour, width and whether it is dashed.
struct Series<'a> {
    label: &'a str,
    values: Vec<f64>,
    colour: RGBColor,
    width: u32,
    dashed: bool,
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
) -> Result<(), PlotError> {
    let mut chart = ChartBuilder::on(area)
        .margin_left(10)
        .margin_right(10 + RIGHT_PX)
        .margin_top(6)
        .caption(title, (FONT, 18).into_font().style(FontStyle::Bold))
        .x_label_area_size(if x_desc.is_some() { 42 } else { 24 })
        .y_label_area_size(78)
        .build_cartesian_2d(x.clone(), y.clone())
        .map_err(err)?;
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
    for s in series {
        let style = ShapeStyle::from(&s.colour).stroke_width(s.width);
        let colour = s.colour;
        let width = s.width;
        for (i, seg) in segments(time, &s.values).into_iter().enumerate() {
            let ann = if s.dashed {
                chart
                    .draw_series(DashedLineSeries::new(seg, 8, 5, style))
                    .map_err(err)?
            } else {
                chart
                    .draw_series(LineSeries::new(seg, style))
                    .map_err(err)?
            };
            if i == 0 {
                ann.label(s.label).legend(move |(lx, ly)| {
                    PathElement::new(
                        vec![(lx, ly), (lx + 22, ly)],
                        ShapeStyle::from(&colour).stroke_width(width + 1),
                    )
                });
            }
        }
    }
    legend(
        &mut chart.configure_series_labels(),
        SeriesLabelPosition::UpperRight,
    )
    .draw()
    .map_err(err)?;
    Ok(())
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

/// Draw the spring states as bars: one lane per spring, filled where it is on.
fn spring_panel(
    area: &Area<'_>,
    time: &[f64],
    x: Range<f64>,
    springs: &[(char, Vec<f64>)],
    gaps: &[f64],
    x_desc: Option<&str>,
) -> Result<(), PlotError> {
    let lanes = springs.len() as f64;
    let mut chart = ChartBuilder::on(area)
        .margin_left(10)
        .margin_right(10 + RIGHT_PX)
        .margin_top(6)
        .caption(
            "SMA springs (on = driven)",
            (FONT, 18).into_font().style(FontStyle::Bold),
        )
        .x_label_area_size(if x_desc.is_some() { 42 } else { 24 })
        .y_label_area_size(78)
        .build_cartesian_2d(x.clone(), 0.0..lanes)
        .map_err(err)?;
    let names: Vec<char> = springs.iter().map(|(n, _)| *n).collect();
    // Lane i spans [lanes − i − 1, lanes − i); its name sits at the middle.
    let lane_label = |v: &f64| {
        let lane = lanes - v - 0.5;
        let i = lane.round();
        if (lane - i).abs() < 0.05 && i >= 0.0 && (i as usize) < names.len() {
            format!("spring {}", names[i as usize])
        } else {
            String::new()
        }
    };
    let mut mesh = chart.configure_mesh();
    mesh.disable_y_mesh()
        .y_labels(springs.len() * 2 + 1)
        .y_label_formatter(&lane_label)
        .light_line_style(RGBColor(238, 238, 238))
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14));
    mesh.x_label_formatter(&|v| format!("{v:.0}"));
    if let Some(d) = x_desc {
        mesh.x_desc(d);
    }
    mesh.draw().map_err(err)?;
    let colours = [
        RGBColor(200, 40, 40),
        RGBColor(230, 130, 0),
        RGBColor(130, 60, 180),
    ];
    for (i, (_, on)) in springs.iter().enumerate() {
        let base = lanes - i as f64 - 1.0;
        let colour = colours[i % colours.len()];
        let mut rects = Vec::new();
        let mut start: Option<f64> = None;
        for (j, (&t, &v)) in time.iter().zip(on).enumerate() {
            let next = time
                .get(j + 1)
                .copied()
                .filter(|n| n.is_finite())
                .unwrap_or(t);
            match (start, v > 0.5) {
                (None, true) => start = Some(t),
                (Some(s), false) => {
                    rects.push((s, t));
                    start = None;
                }
                _ => {}
            }
            if j + 1 == time.len()
                && let Some(s) = start
            {
                rects.push((s, next));
            }
        }
        chart
            .draw_series(
                [Rectangle::new(
                    [(x.start, base + 0.12), (x.end, base + 0.88)],
                    RGBColor(246, 246, 246).filled(),
                )]
                .into_iter()
                .chain(rects.into_iter().map(|(a, b)| {
                    Rectangle::new([(a, base + 0.12), (b, base + 0.88)], colour.filled())
                })),
            )
            .map_err(err)?;
    }
    draw_gaps(&mut chart, gaps, &(0.0..lanes))?;
    Ok(())
}

/// Draw the bending angle (left axis) and the bending stiffness (right axis).
fn bending_panel(
    area: &Area<'_>,
    time: &[f64],
    x: Range<f64>,
    bend: Option<&[f64]>,
    k_b: Option<&[f64]>,
    x_desc: Option<&str>,
) -> Result<(), PlotError> {
    let y = range_of(bend, 0.05, 5.0);
    let y2 = range_of(k_b, 0.05, 50.0);
    let mut chart = ChartBuilder::on(area)
        .margin_left(10)
        .margin_right(10)
        .margin_top(6)
        .caption(
            "Bending performance and stiffness",
            (FONT, 18).into_font().style(FontStyle::Bold),
        )
        .x_label_area_size(if x_desc.is_some() { 42 } else { 24 })
        .y_label_area_size(78)
        .right_y_label_area_size(RIGHT_PX)
        .build_cartesian_2d(x.clone(), y)
        .map_err(err)?
        .set_secondary_coord(x, y2);
    let mut mesh = chart.configure_mesh();
    mesh.y_desc("bending angle, °")
        .light_line_style(RGBColor(238, 238, 238))
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14));
    mesh.x_label_formatter(&|v| format!("{v:.0}"));
    if let Some(d) = x_desc {
        mesh.x_desc(d);
    }
    mesh.draw().map_err(err)?;
    chart
        .configure_secondary_axes()
        .y_desc("k_b, N·mm/rad")
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14))
        .draw()
        .map_err(err)?;
    let blue = RGBColor(30, 90, 200);
    let green = RGBColor(20, 140, 60);
    if let Some(b) = bend {
        for (i, seg) in segments(time, b).into_iter().enumerate() {
            let a = chart
                .draw_series(LineSeries::new(seg, blue.stroke_width(2)))
                .map_err(err)?;
            if i == 0 {
                a.label("bending angle φ").legend(move |(lx, ly)| {
                    PathElement::new(vec![(lx, ly), (lx + 22, ly)], blue.stroke_width(3))
                });
            }
        }
    }
    if let Some(k) = k_b {
        for (i, seg) in segments(time, k).into_iter().enumerate() {
            let a = chart
                .draw_secondary_series(LineSeries::new(seg, green.stroke_width(2)))
                .map_err(err)?;
            if i == 0 {
                a.label("bending stiffness k_b (right)")
                    .legend(move |(lx, ly)| {
                        PathElement::new(vec![(lx, ly), (lx + 22, ly)], green.stroke_width(3))
                    });
            }
        }
    }
    legend(
        &mut chart.configure_series_labels(),
        SeriesLabelPosition::UpperLeft,
    )
    .draw()
    .map_err(err)?;
    Ok(())
}

enum Panel {
    Temps,
    Duties,
    Springs,
    Bending,
}

/// Render `table` as a PNG at `out` with `title`; return which panels it drew.
///
/// Columns read (the first present of each alias): time `t_s` (the board's clock) where it never
/// goes back, else `time_s`; temperatures
/// `t1_k`…`t5_k`, `target_k`, `tc_k`; modes `mode`; duties `heater_duty_pct`/`heater_pct` and
/// `fan_duty_pct`/`fan_pct`; springs `spring_a`…`spring_c` (0/1) or `springs` (letters, `-`
/// for none); `bend_deg`, `k_b_nmm_per_rad`; `gap` (on the first row after a recording gap, why — any
/// value but empty, `-` or `0` — drawn as a red dashed line).
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
                line_panel(
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
                names.push("temperatures".to_string());
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
                line_panel(
                    area,
                    "Heater and fan duty",
                    "duty, %",
                    &time,
                    x.clone(),
                    -3.0..118.0,
                    &series,
                    None,
                    &gaps,
                    last,
                )?;
                names.push("duties".to_string());
            }
            Panel::Springs => {
                spring_panel(area, &time, x.clone(), &springs, &gaps, last)?;
                names.push("springs".to_string());
            }
            Panel::Bending => {
                bending_panel(
                    area,
                    &time,
                    x.clone(),
                    bend.as_deref(),
                    k_b.as_deref(),
                    last,
                )?;
                names.push("bending".to_string());
            }
        }
    }
    root.present().map_err(err)?;
    Ok(PlotInfo {
        panels: names,
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
        assert_eq!(info.panels, ["temperatures", "duties", "springs"]);
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        let reader = decoder.read_info().unwrap();
        assert_eq!((reader.info().width, reader.info().height), info.size_px);
        std::fs::remove_dir_all(&dir).unwrap();
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
