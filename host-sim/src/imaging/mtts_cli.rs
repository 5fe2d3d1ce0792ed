//! `host-sim mtts` and `host-sim scene`: MTTS on an image file, and rendered scenes as images.
//!
//! `mtts` reads either image format the tools write: the 24 × 32 grid in kelvin (`host-sim
//! scene`'s) or `host-sim decode`'s `pixel,row,col,value` lines in °C, told apart by that
//! header; a grid whose values all look like °C gets a hint on standard error.

use std::io::Write;
use std::path::Path;

use thermorph::mtts::{
    self, IMG_COLS, IMG_PIXELS, IMG_ROWS, Method, Mtts, Prior, REGION_NAMES, Scratch,
};
use thermorph::units::k_or_nan;

use anyhow::{Context as _, bail};

use crate::imaging::SensingError;
use crate::imaging::view::standard_scenes;

/// Parse an image CSV: 24 lines of 32 comma-separated Kelvin values (`nan` for a broken pixel);
/// blank lines and lines starting with `#` are skipped. Errors name the line and column.
pub fn parse_image(text: &str) -> Result<[f32; IMG_PIXELS], SensingError> {
    let mut img = [0f32; IMG_PIXELS];
    let mut row = 0;
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        if row == IMG_ROWS {
            return Err(SensingError::TooManyRows { line: n + 1 });
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != IMG_COLS {
            return Err(SensingError::RowLength {
                line: n + 1,
                values: cells.len(),
            });
        }
        for (c, cell) in cells.iter().enumerate() {
            let v = if cell.eq_ignore_ascii_case("nan") {
                f32::NAN
            } else {
                cell.parse::<f32>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| SensingError::NotANumber {
                        line: n + 1,
                        column: c + 1,
                        cell: cell.to_string(),
                    })?
            };
            img[row * IMG_COLS + c] = v;
        }
        row += 1;
    }
    if row != IMG_ROWS {
        return Err(SensingError::RowCount { rows: row });
    }
    Ok(img)
}

/// The header line of `host-sim decode`'s CSV ([`crate::imaging::decode::write_csv`]).
pub const DECODED_HEADER: &str = "pixel,row,col,value";

/// Parse `host-sim decode`'s CSV: the header [`DECODED_HEADER`], then one `pixel,row,col,value`
/// line per pixel (the value in °C, `nan` where no subpage covered it), every pixel once; return
/// the image in kelvin. Errors name the line.
pub fn parse_decoded(text: &str) -> Result<[f32; IMG_PIXELS], SensingError> {
    let mut img = [f32::NAN; IMG_PIXELS];
    let mut seen = [false; IMG_PIXELS];
    let mut header = false;
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        if !header {
            header = line == DECODED_HEADER;
            if !header {
                return Err(SensingError::DecodedLine {
                    line: n + 1,
                    text: line.to_string(),
                });
            }
            continue;
        }
        let bad = || SensingError::DecodedLine {
            line: n + 1,
            text: line.to_string(),
        };
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let [p, r, c, v] = cells[..] else {
            return Err(bad());
        };
        let (Ok(p), Ok(r), Ok(c)) = (p.parse::<usize>(), r.parse::<usize>(), c.parse::<usize>())
        else {
            return Err(bad());
        };
        if p >= IMG_PIXELS || r != p / IMG_COLS || c != p % IMG_COLS || seen[p] {
            return Err(bad());
        }
        seen[p] = true;
        img[p] = if v.eq_ignore_ascii_case("nan") {
            f32::NAN
        } else {
            let celsius = v
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(bad)?;
            celsius + 273.15
        };
    }
    let pixels = seen.iter().filter(|s| **s).count();
    if pixels != IMG_PIXELS {
        return Err(SensingError::DecodedPixels { pixels });
    }
    Ok(img)
}

/// Parse an image file's text in either format: `host-sim decode`'s CSV (its first line is
/// [`DECODED_HEADER`]; °C, returned in kelvin) or the 24 × 32 grid in kelvin ([`parse_image`]).
pub fn parse_any(text: &str) -> Result<[f32; IMG_PIXELS], SensingError> {
    let first = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'));
    if first == Some(DECODED_HEADER) {
        parse_decoded(text)
    } else {
        parse_image(text)
    }
}

/// Below this every value of a kelvin image would be colder than the MLX90640 measures (−40 °C
/// is 233 K): an image whose values all are lies in °C.
const CELSIUS_BELOW: f32 = 200.0;

/// A hint for an image whose every value is below 200 (an image in °C given where kelvin is
/// read), or `None`.
pub fn unit_hint(img: &[f32; IMG_PIXELS]) -> Option<String> {
    let mut finite = img.iter().filter(|v| v.is_finite()).peekable();
    finite.peek()?;
    let hottest = finite.fold(f32::MIN, |a, &b| a.max(b));
    (hottest < CELSIUS_BELOW).then(|| {
        format!(
            "hint: every value is below {CELSIUS_BELOW} (the hottest {hottest}): the image looks \
             like °C; MTTS reads kelvin (add 273.15, or give `host-sim decode`'s CSV as it is)"
        )
    })
}

/// Write an image as CSV (24 lines of 32 values, K).
pub fn write_image(img: &[f32; IMG_PIXELS], out: &mut impl Write) -> std::io::Result<()> {
    for r in 0..IMG_ROWS {
        let row: Vec<String> = img[r * IMG_COLS..(r + 1) * IMG_COLS]
            .iter()
            .map(|v| {
                if v.is_nan() {
                    "nan".into()
                } else {
                    format!("{v:.3}")
                }
            })
            .collect();
        writeln!(out, "{}", row.join(","))?;
    }
    Ok(())
}

/// The clustering methods as the command line (and `bench-m4`) spells them.
pub const METHODS: [(&str, Method); 3] = [
    ("exact", Method::Exact),
    ("lloyd", Method::Lloyd),
    ("kmeanspp", Method::KMeansPlusPlus),
];

/// Parse a method name.
pub fn parse_method(s: &str) -> Result<Method, SensingError> {
    METHODS
        .iter()
        .find(|(n, _)| *n == s)
        .map(|(_, m)| *m)
        .ok_or_else(|| SensingError::UnknownMethod(s.to_string()))
}

/// The name of a method, as [`parse_method`] reads it.
pub fn method_name(m: Method) -> &'static str {
    METHODS
        .iter()
        .find(|(_, x)| *x == m)
        .map_or("exact", |(n, _)| *n)
}

/// Prior names, as `--prior` reads them.
pub const PRIORS: [(&str, Prior); 3] = [
    ("unknown", Prior::Unknown),
    ("heater-hotter", Prior::HeaterHotter),
    ("surface-hotter", Prior::SurfaceHotter),
];

/// Parse a prior name.
pub fn parse_prior(s: &str) -> Result<Prior, SensingError> {
    PRIORS
        .iter()
        .find(|(n, _)| *n == s)
        .map(|(_, p)| *p)
        .ok_or_else(|| SensingError::UnknownPrior(s.to_string()))
}

/// Run MTTS on an image file ([`parse_any`]: the kelvin grid or `host-sim decode`'s CSV) with
/// a prior and write `region,name,temp_k,pixels` (pixels: upsampled pixels in the region's
/// cluster), then a `# quality <q>, bound <b> K` line, where the frame fitted a lattice a
/// `# exposure fitted <f> %, design <d> %` line, and where the image shows the lattice exposed
/// unlike its design a `# warning: …` line ([`exposure_warning`]); a hint about the image's unit
/// ([`unit_hint`]) goes to `hints`.
pub fn run(
    path: &Path,
    config: mtts::Config,
    prior: Prior,
    out: &mut impl Write,
    hints: &mut impl Write,
) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let img = parse_any(&text).with_context(|| path.display().to_string())?;
    if let Some(h) = unit_hint(&img) {
        writeln!(hints, "{}: {h}", path.display())?;
    }
    let mut m = Mtts::new(config).map_err(SensingError::Mtts)?;
    m.set_prior(prior);
    let mut scratch = Box::new(Scratch::new());
    let res = m
        .process(&img, &mut scratch)
        .map_err(SensingError::Mtts)
        .with_context(|| path.display().to_string())?;
    let mut s = String::from("region,name,temp_k,pixels\n");
    for (i, r) in res.regions.iter().enumerate() {
        s += &format!(
            "{},{},{:.3},{}\n",
            i + 1,
            REGION_NAMES[i],
            k_or_nan(r.temp),
            r.pixels
        );
    }
    s += &format!(
        "# quality {}, bound {:.3} K\n",
        res.quality.name(),
        res.bound.k()
    );
    if let Some(e) = res.exposure {
        s += &format!(
            "# exposure fitted {:.1} %, design {:.1} %\n",
            e.fitted_pct, e.design_pct
        );
        if let Some(shows) = e.shows_pct {
            s += &format!("# warning: {}\n", exposure_warning(shows, e.design_pct));
        }
    }
    out.write_all(s.as_bytes())?;
    Ok(())
}

/// The `#` warning of a frame whose image shows the lattice exposed `shows_pct` against the
/// design's `design_pct`: one frame cannot tell a lattice unlike its design from a prior that
/// lags the block, so MTTS fits with what many frames show (the board's `# warning`, once
/// they agree).
pub fn exposure_warning(shows_pct: f32, design_pct: f32) -> String {
    format!(
        "the image shows the lattice {shows_pct:.0} % exposed, its design {design_pct:.0} % \
         (as the prior orders the targets; set --exposed-pct if the block is built so)"
    )
}

/// Write standard scene `name` (rendered with `seed`) as an image CSV, with its truth as
/// `#` comment lines; without a name, list the scenes (name, true T1 and T2, noise).
pub fn scene(name: Option<&str>, seed: u64, out: &mut impl Write) -> anyhow::Result<()> {
    let scenes = standard_scenes();
    let Some(name) = name else {
        let mut buf = String::new();
        for s in &scenes {
            buf += &format!(
                "{:<20} T1 {:.1} K, T2 {:.1} K, background {:.1} K, noise {} K rms\n",
                s.name, s.temps.heater_k, s.temps.surface_k, s.temps.background_k, s.noise_k
            );
        }
        out.write_all(buf.as_bytes())?;
        return Ok(());
    };
    let Some(s) = scenes.iter().find(|s| s.name == name) else {
        let names: Vec<&str> = scenes.iter().map(|s| s.name).collect();
        bail!("no scene `{name}`; scenes: {}", names.join(", "));
    };
    let r = s.render(seed);
    let mut buf = Vec::new();
    writeln!(buf, "# scene {name}, noise seed {seed}")?;
    for (i, t) in r.truth_k.iter().enumerate() {
        writeln!(
            buf,
            "# truth region {} {}: {t:.3} K",
            i + 1,
            REGION_NAMES[i]
        )?;
    }
    write_image(&r.image_k, &mut buf)?;
    out.write_all(&buf)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_round_trip_and_errors() {
        let mut img = [300.5f32; IMG_PIXELS];
        img[40] = f32::NAN;
        let mut buf = Vec::new();
        write_image(&img, &mut buf).unwrap();
        let back = parse_image(std::str::from_utf8(&buf).unwrap()).unwrap();
        assert!(back[40].is_nan());
        assert_eq!(back[41], 300.5);
        assert!(
            parse_image("1,2,3\n")
                .unwrap_err()
                .to_string()
                .contains("line 1: 3 values")
        );
        let bad = std::str::from_utf8(&buf)
            .unwrap()
            .replacen("300.500", "hot", 1);
        assert!(parse_image(&bad).unwrap_err().to_string().contains("`hot`"));
        let short: String = std::str::from_utf8(&buf)
            .unwrap()
            .lines()
            .take(5)
            .collect::<Vec<_>>()
            .join("\n");
        assert!(
            parse_image(&short)
                .unwrap_err()
                .to_string()
                .contains("5 rows")
        );
        assert!(parse_image(&"1.0,".repeat(32)).is_err());
        assert!(parse_method("kmeans").is_err());
    }

    #[test]
    fn decoded_csv_reads_in_kelvin_and_refuses_what_is_not_one() {
        let mut text = format!("{DECODED_HEADER}\n");
        for p in 0..IMG_PIXELS {
            if p == 5 {
                text += &format!("{p},0,5,nan\n");
            } else {
                text += &format!("{p},{},{},{:.6}\n", p / IMG_COLS, p % IMG_COLS, 25.0);
            }
        }
        let img = parse_any(&text).unwrap();
        assert!(img[5].is_nan());
        assert!((img[6] - 298.15).abs() < 1e-4);
        assert_eq!(unit_hint(&img), None);
        // A line out of place, a value that is not a number, a pixel missing.
        let e = parse_decoded(&text.replacen("7,0,7,", "7,1,7,", 1)).unwrap_err();
        assert!(
            e.to_string().starts_with("line 9: `7,1,7,25.000000`"),
            "{e}"
        );
        let e = parse_decoded(&text.replacen("7,0,7,25.000000", "7,0,7,warm", 1)).unwrap_err();
        assert!(e.to_string().contains("`7,0,7,warm`"), "{e}");
        let short: String = text.lines().take(700).map(|l| format!("{l}\n")).collect();
        assert!(
            parse_decoded(&short)
                .unwrap_err()
                .to_string()
                .contains("699 pixels")
        );
        // The grid of the same image in °C gets the hint; in kelvin none.
        let mut grid = Vec::new();
        write_image(&[25.0; IMG_PIXELS], &mut grid).unwrap();
        let img = parse_any(std::str::from_utf8(&grid).unwrap()).unwrap();
        let hint = unit_hint(&img).unwrap();
        assert!(
            hint.contains("looks like °C") && hint.contains("kelvin"),
            "{hint}"
        );
        assert_eq!(unit_hint(&[298.0; IMG_PIXELS]), None);
        assert_eq!(unit_hint(&[f32::NAN; IMG_PIXELS]), None);
    }
}
