//! `host-sim mtts` and `host-sim scene`: MTTS on an image file, and rendered scenes as images.

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

/// Run MTTS on an image file with a prior and write `region,name,temp_k,pixels` (pixels:
/// upsampled pixels in the region's cluster), then a `# quality <q>, bound <b> K` line.
pub fn run(
    path: &Path,
    config: mtts::Config,
    prior: Prior,
    out: &mut impl Write,
) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let img = parse_image(&text).with_context(|| path.display().to_string())?;
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
    out.write_all(s.as_bytes())?;
    Ok(())
}

/// Write standard scene `name` (rendered with `seed`) as an image CSV, with its truth as
/// `#` comment lines.
pub fn scene(name: &str, seed: u64, out: &mut impl Write) -> anyhow::Result<()> {
    let scenes = standard_scenes();
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
}
