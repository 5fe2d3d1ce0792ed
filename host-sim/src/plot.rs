//! The PNG plot of a run: five stacked panels over a shared time axis — temperatures (the
//! plant's and, where there is one, the measurement), heater and fan duties, spring states
//! with their austenite fractions, bending angle, and bending stiffness.
//!
//! This module owns a small raster plotter (lines, axes, nice ticks, a 5×7 bitmap font) so the
//! plot needs no font files or system libraries; the PNG is encoded by the `png` crate.

use std::path::Path;

use crate::run::Row;

const WIDTH: usize = 1200;
const PANEL_H: usize = 190;
const GAP: usize = 34;
const LEFT: usize = 84;
const RIGHT: usize = 20;
const TOP: usize = 70;
const BOTTOM: usize = 50;
const PANELS: usize = 5;
const HEIGHT: usize = TOP + PANELS * PANEL_H + (PANELS - 1) * GAP + BOTTOM;

type Rgb = [u8; 3];
const BLACK: Rgb = [0, 0, 0];
const GRID: Rgb = [225, 225, 225];
const RED: Rgb = [200, 30, 30];
const ORANGE: Rgb = [230, 130, 0];
const BROWN: Rgb = [130, 80, 40];
const BLUE: Rgb = [30, 90, 200];
const SKY: Rgb = [90, 170, 220];
const PURPLE: Rgb = [130, 50, 170];
const GREEN: Rgb = [20, 140, 60];
const GREY: Rgb = [120, 120, 120];

/// An RGB raster.
struct Canvas {
    px: Vec<u8>,
}

impl Canvas {
    fn new() -> Self {
        Canvas {
            px: vec![255; WIDTH * HEIGHT * 3],
        }
    }

    fn set(&mut self, x: i64, y: i64, c: Rgb) {
        if x >= 0 && y >= 0 && (x as usize) < WIDTH && (y as usize) < HEIGHT {
            let i = (y as usize * WIDTH + x as usize) * 3;
            self.px[i..i + 3].copy_from_slice(&c);
        }
    }

    fn line(&mut self, (x0, y0): (f64, f64), (x1, y1): (f64, f64), c: Rgb, thick: bool) {
        let n = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).max(1);
        for i in 0..=n {
            let t = i as f64 / n as f64;
            let x = (x0 + t * (x1 - x0)).round() as i64;
            let y = (y0 + t * (y1 - y0)).round() as i64;
            self.set(x, y, c);
            if thick {
                self.set(x, y + 1, c);
                self.set(x + 1, y, c);
            }
        }
    }

    /// Draw text with its top-left corner at (x, y), `scale` pixels per font dot; return the
    /// x just after it.
    fn text(&mut self, x: i64, y: i64, s: &str, c: Rgb, scale: i64) -> i64 {
        let mut cx = x;
        for ch in s.chars() {
            let g = glyph(ch);
            for (row, bits) in g.iter().enumerate() {
                for col in 0..5 {
                    if bits & (0x10 >> col) != 0 {
                        for dy in 0..scale {
                            for dx in 0..scale {
                                self.set(cx + col * scale + dx, y + row as i64 * scale + dy, c);
                            }
                        }
                    }
                }
            }
            cx += 6 * scale;
        }
        cx
    }
}

/// Width of `s` in pixels at `scale`.
fn text_width(s: &str, scale: i64) -> i64 {
    s.chars().count() as i64 * 6 * scale
}

/// 5×7 glyphs (row bits, MSB left); lower case is drawn as upper case, unknown as a box.
fn glyph(c: char) -> [u8; 7] {
    match c.to_ascii_uppercase() {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        'A' => [0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'B' => [0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E],
        'C' => [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E],
        'D' => [0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        'F' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10],
        'G' => [0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F],
        'H' => [0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'I' => [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'J' => [0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C],
        'K' => [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F],
        'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
        'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
        'O' => [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'P' => [0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10],
        'Q' => [0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D],
        'R' => [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11],
        'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
        'T' => [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'U' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'V' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'W' => [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A],
        'X' => [0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11],
        'Y' => [0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04],
        'Z' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F],
        '.' | '·' => [0, 0, 0, 0, 0, 0x0C, 0x0C],
        '-' | '−' => [0, 0, 0, 0x1F, 0, 0, 0],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        '/' => [0, 0x01, 0x02, 0x04, 0x08, 0x10, 0],
        ':' => [0, 0x0C, 0x0C, 0, 0x0C, 0x0C, 0],
        '_' => [0, 0, 0, 0, 0, 0, 0x1F],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        '+' => [0, 0x04, 0x04, 0x1F, 0x04, 0x04, 0],
        '=' => [0, 0, 0x1F, 0, 0x1F, 0, 0],
        ',' => [0, 0, 0, 0, 0x0C, 0x04, 0x08],
        ' ' => [0; 7],
        _ => [0x1F, 0x11, 0x11, 0x11, 0x11, 0x11, 0x1F],
    }
}

/// Tick positions: a 1-2-5 step giving about `n` ticks over [lo, hi].
pub fn nice_ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        return vec![lo];
    }
    let raw = (hi - lo) / n.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|i| i as f64 * step).collect()
}

fn label(v: f64, step: f64) -> String {
    if step >= 1.0 || v == 0.0 {
        format!("{v:.0}")
    } else {
        let digits = (-step.log10().floor()) as usize;
        format!("{v:.digits$}")
    }
}

/// How a series reads its value from a row (`None`: a gap in the line).
type Getter<'a> = Box<dyn Fn(&Row) -> Option<f64> + 'a>;

/// One line of a panel.
struct Series<'a> {
    name: &'a str,
    color: Rgb,
    thick: bool,
    get: Getter<'a>,
}

/// Draw one panel: `index` from the top, its title, y range from the data (padded) unless
/// `fixed` gives it, and its series.
fn panel(
    cv: &mut Canvas,
    rows: &[Row],
    index: usize,
    title: &str,
    fixed: Option<(f64, f64)>,
    series: &[Series],
    t_max_s: f64,
) {
    let y0 = (TOP + index * (PANEL_H + GAP)) as f64;
    let (x0, x1) = (LEFT as f64, (WIDTH - RIGHT) as f64);
    let y1 = y0 + PANEL_H as f64;
    let (lo, hi) = fixed.unwrap_or_else(|| {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for s in series {
            for v in rows
                .iter()
                .filter_map(|r| (s.get)(r))
                .filter(|v| v.is_finite())
            {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        if !lo.is_finite() {
            (0.0, 1.0)
        } else if hi - lo < 1e-9 {
            (lo - 1.0, hi + 1.0)
        } else {
            let pad = 0.06 * (hi - lo);
            (lo - pad, hi + pad)
        }
    });
    let ty = |v: f64| y1 - (v - lo) / (hi - lo) * (y1 - y0);
    let tx = |t: f64| x0 + t / t_max_s.max(1e-9) * (x1 - x0);
    // Grid and ticks.
    let yt = nice_ticks(lo, hi, 5);
    let ystep = if yt.len() > 1 { yt[1] - yt[0] } else { 1.0 };
    for v in &yt {
        let y = ty(*v);
        cv.line((x0, y), (x1, y), GRID, false);
        let l = label(*v, ystep);
        cv.text(
            LEFT as i64 - 6 - text_width(&l, 1),
            y as i64 - 3,
            &l,
            BLACK,
            1,
        );
    }
    for t in nice_ticks(0.0, t_max_s, 10) {
        let x = tx(t);
        cv.line((x, y0), (x, y1), GRID, false);
    }
    // Frame.
    cv.line((x0, y0), (x1, y0), BLACK, false);
    cv.line((x0, y1), (x1, y1), BLACK, false);
    cv.line((x0, y0), (x0, y1), BLACK, false);
    cv.line((x1, y0), (x1, y1), BLACK, false);
    // Title and legend above the panel.
    let mut x = cv.text(LEFT as i64, y0 as i64 - 18, title, BLACK, 2) + 24;
    for s in series {
        x = cv.text(x, y0 as i64 - 14, s.name, s.color, 1) + 18;
    }
    // Data.
    for s in series {
        let mut prev: Option<(f64, f64)> = None;
        for r in rows {
            match (s.get)(r).filter(|v| v.is_finite()) {
                Some(v) => {
                    let p = (tx(r.obs.time_s), ty(v.clamp(lo, hi)));
                    if let Some(q) = prev {
                        cv.line(q, p, s.color, s.thick);
                    } else {
                        cv.set(p.0 as i64, p.1 as i64, s.color);
                    }
                    prev = Some(p);
                }
                None => prev = None,
            }
        }
    }
}

/// Render the run's plot as PNG bytes.
pub fn render_png(rows: &[Row], title: &str) -> Result<Vec<u8>, String> {
    let mut cv = Canvas::new();
    let t_max_s = rows.last().map_or(1.0, |r| r.obs.time_s);
    cv.text(LEFT as i64, 8, &format!("THERMORPH RUN: {title}"), BLACK, 2);
    let s = |name, color, thick, get: Getter<'static>| Series {
        name,
        color,
        thick,
        get,
    };
    panel(
        &mut cv,
        rows,
        0,
        "TEMPERATURES (K)",
        None,
        &[
            s("HEATER FILM", RED, true, Box::new(|r| Some(r.obs.heater_k))),
            s(
                "SMP OUTER",
                ORANGE,
                true,
                Box::new(|r| Some(r.obs.smp_outer_k)),
            ),
            s(
                "SMP INNER",
                BROWN,
                false,
                Box::new(|r| Some(r.obs.smp_inner_k)),
            ),
            s("DUCT AIR", SKY, false, Box::new(|r| Some(r.obs.duct_air_k))),
            s(
                "SPRINGS (MEAN)",
                PURPLE,
                false,
                Box::new(|r| Some(r.obs.springs_k.iter().sum::<f64>() / 3.0)),
            ),
            s(
                "T1 MEASURED",
                GREY,
                false,
                Box::new(|r| r.measured_k.map(|m| m[0])),
            ),
            s(
                "T2 MEASURED",
                GREEN,
                false,
                Box::new(|r| r.measured_k.map(|m| m[1])),
            ),
        ],
        t_max_s,
    );
    panel(
        &mut cv,
        rows,
        1,
        "DUTY (%)",
        Some((-5.0, 105.0)),
        &[
            s(
                "HEATER",
                RED,
                true,
                Box::new(|r| Some(100.0 * r.inputs.heater_duty)),
            ),
            s(
                "FAN",
                BLUE,
                true,
                Box::new(|r| Some(100.0 * r.inputs.fan_duty)),
            ),
        ],
        t_max_s,
    );
    let spring = |i: usize| {
        move |r: &Row| Some(i as f64 * 1.25 + if r.inputs.springs_on[i] { 1.0 } else { 0.0 })
    };
    let austenite = |i: usize| move |r: &Row| Some(i as f64 * 1.25 + r.obs.austenite[i]);
    panel(
        &mut cv,
        rows,
        2,
        "SPRINGS A/B/C: ON, AUSTENITE FRACTION",
        Some((-0.15, 3.65)),
        &[
            s("A ON", RED, false, Box::new(spring(0))),
            s("A AUST.", RED, true, Box::new(austenite(0))),
            s("B ON", BLUE, false, Box::new(spring(1))),
            s("B AUST.", BLUE, true, Box::new(austenite(1))),
            s("C ON", GREEN, false, Box::new(spring(2))),
            s("C AUST.", GREEN, true, Box::new(austenite(2))),
        ],
        t_max_s,
    );
    panel(
        &mut cv,
        rows,
        3,
        "BENDING ANGLE (DEG)",
        None,
        &[s("BEND", BLACK, true, Box::new(|r| Some(r.obs.bend_deg)))],
        t_max_s,
    );
    panel(
        &mut cv,
        rows,
        4,
        "BENDING STIFFNESS K_B (N.MM/RAD)",
        None,
        &[s(
            "K_B",
            PURPLE,
            true,
            Box::new(|r| Some(r.obs.k_b_nmm_per_rad)),
        )],
        t_max_s,
    );
    // Time axis under the last panel.
    let y = (TOP + PANELS * PANEL_H + (PANELS - 1) * GAP) as i64;
    let ticks = nice_ticks(0.0, t_max_s, 10);
    let step = if ticks.len() > 1 {
        ticks[1] - ticks[0]
    } else {
        1.0
    };
    for t in &ticks {
        let x = LEFT as f64 + t / t_max_s.max(1e-9) * (WIDTH - LEFT - RIGHT) as f64;
        let l = label(*t, step);
        cv.text(x as i64 - text_width(&l, 1) / 2, y + 6, &l, BLACK, 1);
    }
    cv.text(
        (WIDTH / 2) as i64 - text_width("TIME (S)", 2) / 2,
        y + 22,
        "TIME (S)",
        BLACK,
        2,
    );
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, WIDTH as u32, HEIGHT as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(|e| e.to_string())?;
        w.write_image_data(&cv.px).map_err(|e| e.to_string())?;
    }
    Ok(out)
}

/// Render the plot and write it to `path`.
pub fn write_png(rows: &[Row], title: &str, path: &Path) -> Result<(), String> {
    let bytes = render_png(rows, title)?;
    std::fs::write(path, bytes).map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_nice_and_cover_the_range() {
        assert_eq!(
            nice_ticks(0.0, 100.0, 5),
            vec![0.0, 20.0, 40.0, 60.0, 80.0, 100.0]
        );
        assert_eq!(
            nice_ticks(295.0, 362.0, 5),
            vec![300.0, 320.0, 340.0, 360.0]
        );
        let t = nice_ticks(0.0, 0.7, 4);
        assert!(t.len() == 4 && (t[1] - t[0] - 0.2).abs() < 1e-12, "{t:?}");
        assert_eq!(nice_ticks(1.0, 1.0, 5), vec![1.0]);
        assert_eq!(label(0.2, 0.2), "0.2");
        assert_eq!(label(300.0, 20.0), "300");
    }

    #[test]
    fn text_is_drawn_where_asked() {
        let mut cv = Canvas::new();
        let end = cv.text(10, 10, "K", BLACK, 1);
        assert_eq!(end, 16);
        // `K` has its top-left dot set and its top-middle dot clear.
        let at = |x: usize, y: usize| cv.px[(y * WIDTH + x) * 3];
        assert_eq!(at(10, 10), 0);
        assert_eq!(at(12, 10), 255);
    }
}
