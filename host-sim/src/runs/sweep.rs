//! `host-sim sweep SCENE --set KEY=V1,V2,… [--set …]`: one scene over a grid of overrides.
//!
//! This module owns the sweep: the grid (every combination of the `--set` lists, the last key
//! varying fastest), running its cases in parallel across the cores (rayon) with a progress
//! bar, one CSV row per case (the run's summary figures), a PNG of each figure against the
//! first swept key, shards (`--shard K/N`: every N-th case from K, so a cluster's job array
//! spreads a large sweep over machines) and joining the shards' CSVs (`--merge`).
//!
//! A key is any key of the scene file, dotted for a table's (`ambient`, `initial`,
//! `duration`, `camera.noise`, `camera.seed`, `fidelity.camera`, `plant.heater_power`, …); a
//! value is written as in the file (`"263 K"` or `263K`, `80%`, `true`, `3`). Each case's scene text is the scene's with the
//! overrides written in, then checked as any scene file is: a bad key or value is refused
//! before anything runs, naming the case.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use plotters::prelude::*;
use plotters::style::FontStyle;
use rayon::prelude::*;

use crate::runs::plot::{FONT, Key, LEGEND_PX, Swatch, draw_keys, fonts, strokes};
use crate::runs::run::{RunError, RunResult, run};
use crate::runs::scenario::{self, Scenario, ScenarioError};

/// Why a sweep is refused or fails.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// A `--set` is not `KEY=V1,V2,…`.
    #[error("--set {0}: write KEY=V1,V2,… (e.g. ambient=263K,298K)")]
    Set(String),
    /// A `--shard` is not `K/N` with K < N.
    #[error("--shard {0}: write K/N with 0 ≤ K < N (e.g. 0/4)")]
    Shard(String),
    /// The scene (or a case of it) is refused.
    #[error("{case}: {err}")]
    Case {
        /// The case, as `key=value …`.
        case: String,
        /// Why.
        err: ScenarioError,
    },
    /// The scene itself is refused.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// A run failed.
    #[error("{case}: {err}")]
    Run {
        /// The case.
        case: String,
        /// Why.
        err: Box<RunError>,
    },
    /// A file cannot be read or written.
    #[error("{}: {err}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// Why.
        err: std::io::Error,
    },
    /// The shards to merge do not share one header.
    #[error("{}: its header differs from {}'s", path.display(), first.display())]
    Header {
        /// The odd shard.
        path: PathBuf,
        /// The first shard.
        first: PathBuf,
    },
    /// A PNG could not be drawn.
    #[error("{0}")]
    Plot(String),
}

/// One swept key and its values.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// The scene key (dotted for a table's).
    pub key: String,
    /// Its values as written.
    pub values: Vec<String>,
}

impl std::str::FromStr for Axis {
    type Err = SweepError;

    fn from_str(s: &str) -> Result<Axis, SweepError> {
        let (key, values) = s.split_once('=').ok_or_else(|| SweepError::Set(s.into()))?;
        let values: Vec<String> = values.split(',').map(|v| v.trim().to_string()).collect();
        if key.trim().is_empty() || values.iter().any(String::is_empty) {
            return Err(SweepError::Set(s.into()));
        }
        Ok(Axis {
            key: key.trim().to_string(),
            values,
        })
    }
}

/// Every N-th case from K.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard, 0-based.
    pub k: usize,
    /// How many shards.
    pub n: usize,
}

impl std::str::FromStr for Shard {
    type Err = SweepError;

    fn from_str(s: &str) -> Result<Shard, SweepError> {
        let bad = || SweepError::Shard(s.into());
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (k, n): (usize, usize) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if n == 0 || k >= n {
            return Err(bad());
        }
        Ok(Shard { k, n })
    }
}

/// One case of the grid: its index and each axis's value.
#[derive(Clone, Debug, PartialEq)]
pub struct Case {
    /// Its index in the whole grid (row-major: the last axis varies fastest).
    pub index: usize,
    /// `(key, value)` per axis, in axis order.
    pub set: Vec<(String, String)>,
}

impl Case {
    /// The case as `key=value …`.
    pub fn label(&self) -> String {
        self.set
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// The grid's cases (every one, or `shard`'s).
pub fn cases(axes: &[Axis], shard: Option<Shard>) -> Vec<Case> {
    let total: usize = axes.iter().map(|a| a.values.len()).product();
    (0..total)
        .filter(|i| shard.is_none_or(|s| i % s.n == s.k))
        .map(|index| {
            let mut rest = index;
            let mut set = vec![(String::new(), String::new()); axes.len()];
            for (j, a) in axes.iter().enumerate().rev() {
                set[j] = (a.key.clone(), a.values[rest % a.values.len()].clone());
                rest /= a.values.len();
            }
            Case { index, set }
        })
        .collect()
}

/// A value as TOML: a boolean, an integer or a float stays one; anything else is a string.
fn toml_value(v: &str) -> toml_edit::Value {
    if let Ok(b) = v.parse::<bool>() {
        return b.into();
    }
    if let Ok(i) = v.parse::<i64>() {
        return i.into();
    }
    v.into()
}

/// The scene of `case`: `src` with the case's overrides written in, checked as a scene file.
pub fn scene_of(src: &scenario::Source, case: &Case) -> Result<Scenario, SweepError> {
    let mut doc: toml_edit::DocumentMut =
        src.text
            .parse()
            .map_err(|e: toml_edit::TomlError| SweepError::Case {
                case: case.label(),
                err: ScenarioError::Toml {
                    file: src.file.clone(),
                    line: 1,
                    message: e.message().trim_end().to_string(),
                },
            })?;
    for (key, value) in &case.set {
        let mut parts: Vec<&str> = key.split('.').collect();
        let last = parts.pop().unwrap_or_default();
        let mut table = doc.as_table_mut();
        for p in parts {
            table = table
                .entry(p)
                .or_insert_with(toml_edit::table)
                .as_table_mut()
                .ok_or_else(|| SweepError::Set(format!("{key}={value}: `{p}` is not a table")))?;
        }
        table.insert(last, toml_edit::value(toml_value(value)));
    }
    let file = format!("{} ({})", src.file, case.label());
    scenario::parse(&doc.to_string(), &file, &src.default_name).map_err(|err| SweepError::Case {
        case: case.label(),
        err,
    })
}

/// What one case gave: the figures of its summary, by column.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// The case.
    pub case: Case,
    /// `(column, value)`, in [`figures_of`] order; `None` where the run did not show it.
    pub figures: Vec<(String, Option<f64>)>,
    /// The faults the controller latched, as `code@time_s` separated by `;`.
    pub faults: String,
}

/// The figure columns of a run's result: the summary's figures, then each thesis figure's
/// simulated value by its key.
pub fn figures_of(r: &RunResult) -> Vec<(String, Option<f64>)> {
    let s = &r.summary;
    let rows = &r.rows;
    let fold =
        |f: &dyn Fn(&crate::runs::series::Row) -> f64| rows.iter().map(f).fold(f64::NAN, f64::max);
    let mut out = vec![
        ("max_heater_k".to_string(), Some(s.max_heater_k)),
        ("max_smp_outer_k".to_string(), Some(s.max_smp_outer_k)),
        (
            "max_smp_inner_k".to_string(),
            Some(fold(&|r| r.obs.smp_inner_k)),
        ),
        (
            "max_spring_k".to_string(),
            Some(fold(&|r| {
                r.obs.springs_k.iter().copied().fold(f64::NAN, f64::max)
            })),
        ),
        ("max_bend_deg".to_string(), Some(s.max_bend_deg)),
        ("final_bend_deg".to_string(), Some(s.final_bend_deg)),
        ("faults".to_string(), Some(s.faults.len() as f64)),
    ];
    for f in &s.figures {
        out.push((f.key.clone(), f.simulated_f64()));
    }
    out
}

/// Run `cases` of `src` in parallel (rayon, across the cores); `progress` is called with the
/// number done after each.
pub fn run_cases(
    src: &scenario::Source,
    cases: &[Case],
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<Outcome>, SweepError> {
    // Every case's scene is checked before any runs.
    let scenes = cases
        .iter()
        .map(|c| scene_of(src, c))
        .collect::<Result<Vec<_>, _>>()?;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let mut out = cases
        .par_iter()
        .zip(scenes.par_iter())
        .map(|(case, sc)| {
            let r = run(sc, &mut |_| {}).map_err(|err| SweepError::Run {
                case: case.label(),
                err: Box::new(err),
            })?;
            progress(done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1);
            Ok(Outcome {
                case: case.clone(),
                figures: figures_of(&r),
                faults: r
                    .summary
                    .faults
                    .iter()
                    .map(|f| format!("{}@{:.2}", f.code, f.at_s))
                    .collect::<Vec<_>>()
                    .join(";"),
            })
        })
        .collect::<Result<Vec<_>, SweepError>>()?;
    out.sort_by_key(|o| o.case.index);
    Ok(out)
}

/// Write the outcomes as CSV: `case`, each axis's key, each figure column, `fault_list`.
pub fn write_csv(axes: &[Axis], outcomes: &[Outcome], out: &mut impl Write) -> std::io::Result<()> {
    let columns: Vec<&str> = outcomes
        .first()
        .map(|o| o.figures.iter().map(|(c, _)| c.as_str()).collect())
        .unwrap_or_default();
    let mut header = vec!["case".to_string()];
    header.extend(axes.iter().map(|a| a.key.clone()));
    header.extend(columns.iter().map(|c| c.to_string()));
    header.push("fault_list".into());
    writeln!(out, "{}", header.join(","))?;
    for o in outcomes {
        let mut cells = vec![o.case.index.to_string()];
        cells.extend(o.case.set.iter().map(|(_, v)| csv_cell(v)));
        cells.extend(o.figures.iter().map(|(_, v)| match v {
            Some(x) if x.is_finite() => format!("{x:.3}"),
            _ => String::new(),
        }));
        cells.push(csv_cell(&o.faults));
        writeln!(out, "{}", cells.join(","))?;
    }
    Ok(())
}

fn csv_cell(v: &str) -> String {
    if v.contains([',', '"']) {
        format!("\"{}\"", v.replace('"', "\"\""))
    } else {
        v.to_string()
    }
}

/// Join shards' CSVs (one header, rows by case index) into `out`.
pub fn merge(shards: &[PathBuf], out: &mut impl Write) -> Result<usize, SweepError> {
    let mut header: Option<(String, &PathBuf)> = None;
    let mut rows: BTreeMap<usize, String> = BTreeMap::new();
    for path in shards {
        let text = std::fs::read_to_string(path).map_err(|err| SweepError::File {
            path: path.clone(),
            err,
        })?;
        let mut lines = text.lines();
        let h = lines.next().unwrap_or_default().to_string();
        match &header {
            None => header = Some((h, path)),
            Some((first, first_path)) if *first != h => {
                return Err(SweepError::Header {
                    path: path.clone(),
                    first: (*first_path).clone(),
                });
            }
            Some(_) => {}
        }
        for l in lines.filter(|l| !l.trim().is_empty()) {
            let index = l
                .split(',')
                .next()
                .and_then(|c| c.parse::<usize>().ok())
                .unwrap_or(usize::MAX - rows.len());
            rows.insert(index, l.to_string());
        }
    }
    let write = |e: std::io::Error| SweepError::File {
        path: PathBuf::from("<output>"),
        err: e,
    };
    if let Some((h, _)) = &header {
        writeln!(out, "{h}").map_err(write)?;
    }
    for r in rows.values() {
        writeln!(out, "{r}").map_err(write)?;
    }
    Ok(rows.len())
}

/// The leading number of a value as written (`"263 K"` → 263), if it has one.
fn leading_number(v: &str) -> Option<f64> {
    let end = v
        .char_indices()
        .find(|(i, c)| !(c.is_ascii_digit() || *c == '.' || (*i == 0 && (*c == '-' || *c == '+'))))
        .map_or(v.len(), |(i, _)| i);
    v[..end].parse().ok()
}

/// Draw each figure column against the first axis (one line per combination of the other
/// axes) into `dir/sweep-<column>.png`; returns the files written. Columns with no number
/// are skipped; so is everything when the first axis's values are not numbers.
pub fn write_pngs(
    axes: &[Axis],
    outcomes: &[Outcome],
    dir: &Path,
) -> Result<Vec<PathBuf>, SweepError> {
    let Some(first) = outcomes.first() else {
        return Ok(Vec::new());
    };
    if axes.is_empty() || axes[0].values.iter().any(|v| leading_number(v).is_none()) {
        return Ok(Vec::new());
    }
    fonts();
    let plot = |e: &dyn std::fmt::Display| SweepError::Plot(e.to_string());
    let mut written = Vec::new();
    for (col, (name, _)) in first.figures.iter().enumerate() {
        // One series per combination of the other axes.
        let mut series: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        for o in outcomes {
            let (Some(x), Some(y)) = (leading_number(&o.case.set[0].1), o.figures[col].1) else {
                continue;
            };
            if !y.is_finite() {
                continue;
            }
            let rest = o.case.set[1..]
                .iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect::<Vec<_>>()
                .join(" ");
            series.entry(rest).or_default().push((x, y));
        }
        if series.values().all(Vec::is_empty) {
            continue;
        }
        let points = series.values().flatten();
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y) in points {
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
        }
        let pad = |a: f64, b: f64| {
            if b > a {
                0.05 * (b - a)
            } else {
                0.5_f64.max(0.05 * a.abs())
            }
        };
        let (px, py) = (pad(x0, x1), pad(y0, y1));
        let path = dir.join(format!("sweep-{name}.png"));
        {
            let root = BitMapBackend::new(&path, (900 + LEGEND_PX, 540)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| plot(&e))?;
            let mut chart = ChartBuilder::on(&root)
                .margin(12)
                .margin_right(LEGEND_PX)
                .caption(
                    format!("{name} against {}", axes[0].key),
                    (FONT, 20).into_font().style(FontStyle::Bold),
                )
                .x_label_area_size(44)
                .y_label_area_size(80)
                .build_cartesian_2d((x0 - px)..(x1 + px), (y0 - py)..(y1 + py))
                .map_err(|e| plot(&e))?;
            chart
                .configure_mesh()
                .x_desc(axes[0].key.as_str())
                .y_desc(name.as_str())
                .label_style((FONT, 14))
                .axis_desc_style((FONT, 15))
                .draw()
                .map_err(|e| plot(&e))?;
            // The legend in a column right of the plot, over no point.
            let mut keys = Vec::new();
            for (i, (label, pts)) in series.iter().enumerate() {
                let c = Palette99::pick(i).to_rgba();
                let colour = RGBColor(c.0, c.1, c.2);
                chart
                    .draw_series(strokes(pts.clone(), colour.stroke_width(2)))
                    .map_err(|e| plot(&e))?;
                chart
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 4, colour.filled())))
                    .map_err(|e| plot(&e))?;
                if !label.is_empty() {
                    keys.push(Key {
                        label: label.clone(),
                        colour,
                        swatch: Swatch::Dot,
                    });
                }
            }
            let (x_px, y_px) = chart.plotting_area().get_pixel_range();
            draw_keys(&root, x_px.end, y_px.start, &keys).map_err(|e| plot(&e))?;
            root.present().map_err(|e| plot(&e))?;
        }
        written.push(path);
    }
    Ok(written)
}

/// Arguments of `host-sim sweep`.
#[derive(clap::Args, Debug, Clone)]
pub struct SweepArgs {
    /// Scene: a bundled name (cycle, open-loop, faults, two-cycles) or a TOML file (not with
    /// --merge).
    pub scene: Option<String>,
    /// A swept scene key and its values, `KEY=V1,V2,…` (repeat for a grid; the last varies
    /// fastest).
    #[arg(long = "set", value_name = "KEY=V1,V2,…")]
    pub set: Vec<Axis>,
    /// Run only every N-th case from K (`K/N`, 0-based), for a cluster's job array.
    #[arg(long)]
    pub shard: Option<Shard>,
    /// Output folder (default `runs/sweep-<scene>`; with --merge: the merged CSV file).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Join these shards' CSVs into one (`--out` names it; default standard output).
    #[arg(long, num_args = 1.., value_name = "CSV")]
    pub merge: Vec<PathBuf>,
    /// No progress bar and no summary.
    #[arg(long)]
    pub quiet: bool,
}

/// `host-sim sweep`: run the grid (or a shard of it) and write `sweep.csv` and the PNGs, or
/// join shards' CSVs.
pub fn cli(args: &SweepArgs) -> anyhow::Result<()> {
    if !args.merge.is_empty() {
        let n = match &args.out {
            Some(path) => {
                let mut buf = Vec::new();
                let n = merge(&args.merge, &mut buf)?;
                std::fs::write(path, buf).map_err(|err| SweepError::File {
                    path: path.clone(),
                    err,
                })?;
                n
            }
            None => merge(&args.merge, &mut std::io::stdout().lock())?,
        };
        if !args.quiet {
            eprintln!("merged {n} cases from {} shards", args.merge.len());
        }
        return Ok(());
    }
    let Some(scene) = &args.scene else {
        anyhow::bail!("sweep: give a SCENE (or --merge SHARD.csv …)");
    };
    if args.set.is_empty() {
        anyhow::bail!("sweep: give at least one --set KEY=V1,V2,…");
    }
    let src = scenario::source(scene)?;
    let name = scenario::parse(&src.text, &src.file, &src.default_name)?.name;
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("runs").join(format!("sweep-{name}")));
    let cases = cases(&args.set, args.shard);
    let bar = if args.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(cases.len() as u64).with_style(
            indicatif::ProgressStyle::with_template(
                "{bar:30} {pos}/{len} cases, {elapsed} ({eta} left)",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        )
    };
    let outcomes = run_cases(&src, &cases, &|n| bar.set_position(n as u64))?;
    bar.finish_and_clear();
    std::fs::create_dir_all(&dir).map_err(|err| SweepError::File {
        path: dir.clone(),
        err,
    })?;
    let csv = dir.join(match args.shard {
        Some(s) => format!("sweep-{}-of-{}.csv", s.k, s.n),
        None => "sweep.csv".into(),
    });
    let mut buf = Vec::new();
    write_csv(&args.set, &outcomes, &mut buf).map_err(|err| SweepError::File {
        path: csv.clone(),
        err,
    })?;
    std::fs::write(&csv, buf).map_err(|err| SweepError::File {
        path: csv.clone(),
        err,
    })?;
    let pngs = if args.shard.is_none() {
        write_pngs(&args.set, &outcomes, &dir)?
    } else {
        Vec::new()
    };
    if !args.quiet {
        for o in &outcomes {
            let get = |c: &str| {
                o.figures
                    .iter()
                    .find(|(k, _)| k == c)
                    .and_then(|(_, v)| *v)
                    .map_or("—".to_string(), |v| format!("{v:.1}"))
            };
            println!(
                "{:>4}  {:<40} max bend {:>6}°  hottest spring {:>6} K  max SMP inner {:>6} K  faults {}",
                o.case.index,
                o.case.label(),
                get("max_bend_deg"),
                get("max_spring_k"),
                get("max_smp_inner_k"),
                if o.faults.is_empty() {
                    "none"
                } else {
                    &o.faults
                }
            );
        }
        println!(
            "wrote {} ({} cases){}",
            csv.display(),
            outcomes.len(),
            if pngs.is_empty() {
                String::new()
            } else {
                format!(" and {} PNGs in {}", pngs.len(), dir.display())
            }
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_grid_is_row_major_and_shards_partition_it() {
        let axes: Vec<Axis> = ["ambient=263K,298K,323K", "camera.seed=1,2"]
            .iter()
            .map(|s| s.parse().unwrap())
            .collect();
        let all = cases(&axes, None);
        assert_eq!(all.len(), 6);
        assert_eq!(all[1].label(), "ambient=263K camera.seed=2");
        assert_eq!(all[2].label(), "ambient=298K camera.seed=1");
        let mut seen: Vec<usize> = (0..3)
            .flat_map(|k| cases(&axes, Some(Shard { k, n: 3 })))
            .map(|c| c.index)
            .collect();
        seen.sort();
        assert_eq!(seen, (0..6).collect::<Vec<_>>());
    }

    #[test]
    fn bad_sets_and_shards_are_refused() {
        assert!("ambient".parse::<Axis>().is_err());
        assert!("ambient=263K,,298K".parse::<Axis>().is_err());
        assert!("=1".parse::<Axis>().is_err());
        assert!("3/3".parse::<Shard>().is_err());
        assert!("1/0".parse::<Shard>().is_err());
        assert_eq!("1/4".parse::<Shard>().unwrap(), Shard { k: 1, n: 4 });
    }

    #[test]
    fn overrides_are_written_into_the_scene_and_checked() {
        let src = scenario::source("open-loop").unwrap();
        let case = |set: &[(&str, &str)]| Case {
            index: 0,
            set: set
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
        };
        let sc = scene_of(&src, &case(&[("ambient", "263 K"), ("camera.seed", "7")])).unwrap();
        assert_eq!(sc.ambient_k, 263.0);
        assert_eq!(sc.camera.seed, 7);
        let e = scene_of(&src, &case(&[("ambient", "900 K")]))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("ambient=900 K: ") && e.contains("`ambient`"),
            "{e}"
        );
        let e = scene_of(&src, &case(&[("colour", "red")]))
            .unwrap_err()
            .to_string();
        assert!(e.contains("colour"), "{e}");
        // The plant's factors: a `[plant]` table is made when the scene has none.
        let sc = scene_of(
            &src,
            &case(&[
                ("plant.heater_power", "80%"),
                ("plant.spring_supply", "120 %"),
            ]),
        )
        .unwrap();
        assert_eq!(sc.plant_scale.heater_power, 0.8);
        assert_eq!(sc.plant_scale.spring_supply, 1.2);
        assert_eq!(sc.block().options.scale, sc.plant_scale);
        let e = scene_of(&src, &case(&[("plant.heater_power", "0.8")]))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("`plant.heater_power`: `0.8` is not a percentage"),
            "{e}"
        );
        let e = scene_of(&src, &case(&[("plant.heater_power", "300%")]))
            .unwrap_err()
            .to_string();
        assert!(e.contains("300 % is out of range [50, 200] %"), "{e}");
    }

    #[test]
    fn merge_joins_shards_in_case_order_and_refuses_other_headers() {
        let dir = std::env::temp_dir().join(format!("thermorph-sweep-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let a = dir.join("a.csv");
        let b = dir.join("b.csv");
        let c = dir.join("c.csv");
        std::fs::write(&a, "case,ambient,x\n0,263K,1\n2,323K,3\n").unwrap();
        std::fs::write(&b, "case,ambient,x\n1,298K,2\n").unwrap();
        std::fs::write(&c, "case,ambient,y\n3,1,1\n").unwrap();
        let mut out = Vec::new();
        assert_eq!(merge(&[a.clone(), b], &mut out).unwrap(), 3);
        assert_eq!(
            String::from_utf8(out).unwrap(),
            "case,ambient,x\n0,263K,1\n1,298K,2\n2,323K,3\n"
        );
        assert!(matches!(
            merge(&[a, c], &mut Vec::new()),
            Err(SweepError::Header { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_legend_sits_right_of_the_points() {
        // A figure falling from the top left, where a legend inside the plot used to sit.
        let axes: Vec<Axis> = ["ambient=263K,298K,323K", "camera.seed=1,2"]
            .iter()
            .map(|a| a.parse().unwrap())
            .collect();
        let outcomes: Vec<Outcome> = cases(&axes, None)
            .into_iter()
            .map(|case| {
                let y = 100.0 - case.index as f64 * 15.0;
                Outcome {
                    case,
                    figures: vec![("falling_s".to_string(), Some(y))],
                    faults: String::new(),
                }
            })
            .collect();
        let dir = std::env::temp_dir().join(format!("thermorph-sweep-png-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let written = write_pngs(&axes, &outcomes, &dir).unwrap();
        assert_eq!(written, [dir.join("sweep-falling_s.png")]);
        let decoder = png::Decoder::new(std::io::BufReader::new(
            std::fs::File::open(&written[0]).unwrap(),
        ));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let frame = reader.next_frame(&mut buf).unwrap();
        let w = frame.width as usize;
        // The legend's border is the only (180, 180, 180): none of it left of the legend
        // column, inside the plot.
        let border = |xs: std::ops::Range<usize>| {
            (60..480)
                .flat_map(|y| xs.clone().map(move |x| 3 * (y * w + x)))
                .filter(|&i| buf[i..i + 3] == [180, 180, 180])
                .count()
        };
        assert_eq!(border(100..w - LEGEND_PX as usize), 0);
        assert!(border(w - LEGEND_PX as usize..w) > 100);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn leading_numbers_of_values() {
        assert_eq!(leading_number("263 K"), Some(263.0));
        assert_eq!(leading_number("298.15K"), Some(298.15));
        assert_eq!(leading_number("-5 °C"), Some(-5.0));
        assert_eq!(leading_number("true"), None);
    }
}
