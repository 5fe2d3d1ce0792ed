//! `host-sim sweep SCENE --set KEY=V1,V2,… [--set …]`: one scene over a grid of overrides.
//!
//! This module owns the sweep: the grid (every combination of the `--set` lists, the last key
//! varying fastest), running its cases in parallel across the cores (rayon) with a progress
//! bar, one CSV row per case (the run's summary figures), a PNG of each figure against the
//! first swept key with more than one value (named and in units, the thesis's value and
//! tolerance drawn, failing cases red), each case's verdict as `host-sim run`'s table judges
//! the thesis's figures (`--check`: exit 1 when one fails), shards (`--shard K/N`: every N-th
//! case from K, so a cluster's job array spreads a large sweep over machines) and joining the
//! shards' CSVs (`--merge`). It owns the names and units of its own columns ([`RUN_COLUMNS`])
//! and of the swept keys ([`SWEPT_KEYS`]).
//!
//! A key is any key of the scene file, dotted for a table's (`ambient`, `initial`,
//! `duration`, `camera.noise`, `camera.seed`, `fidelity.camera`, `plant.heater_power`, …); a
//! value is written as in the file (`"263 K"` or `263K`, `80%`, `true`, `3`). Each case's scene text is the scene's with the
//! overrides written in, then checked as any scene file is: a bad key or value is refused
//! before anything runs, naming the case.

use std::collections::BTreeMap;
use std::io::Write;
use std::ops::Range;
use std::path::{Path, PathBuf};

use plotters::prelude::*;
use plotters::style::FontStyle;
use rayon::prelude::*;

use crate::runs::cycle_figures::Figure;
use crate::runs::plot::{FONT, Key, LEGEND_PX, Swatch, draw_keys, fonts, strokes};
use crate::runs::run::{RunError, RunResult, run};
use crate::runs::scenario::{self, Scenario, ScenarioError};
use crate::runs::series::Row;

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
    /// `--check`: cases fail a thesis figure.
    #[error("--check: {failed} of {total} cases fail a thesis figure: {cases}")]
    Check {
        /// How many fail.
        failed: usize,
        /// How many ran.
        total: usize,
        /// Each failing case as `index (key=value …: figure, …)`, separated by `; `.
        cases: String,
    },
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

/// What one case gave: the figures of its summary, by column, and the run's judged figures.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// The case.
    pub case: Case,
    /// Each axis's value as a number in its unit ([`SWEPT_KEYS`]; the leading number as
    /// written for a key not listed there), `None` where it is not a number.
    pub values: Vec<Option<f64>>,
    /// `(column, value)`, in [`figures_of`] order; `None` where the run did not show it.
    pub figures: Vec<(String, Option<f64>)>,
    /// The run's figures as its table judges them ([`Figure::fails`], [`Figure::verdict`]).
    pub judged: Vec<Figure>,
    /// The faults the controller latched, as `code@time_s` separated by `;`.
    pub faults: String,
}

impl Outcome {
    /// The figures that fail ([`Figure::fails`]: a known shortfall of the simulated block does
    /// not).
    pub fn failing(&self) -> Vec<&Figure> {
        self.judged.iter().filter(|f| f.fails()).collect()
    }

    /// `FAIL` when a figure fails, `pass` when none does and some were judged, `not judged`
    /// when none was (an open-loop scene, or a run too short to show any).
    pub fn verdict(&self) -> &'static str {
        if !self.failing().is_empty() {
            "FAIL"
        } else if self.judged.iter().all(|f| f.pass.is_none()) {
            "not judged"
        } else {
            "pass"
        }
    }
}

/// A column of the sweep's own, read off a run beside the thesis's figures.
pub struct RunColumn {
    /// Its CSV key.
    pub key: &'static str,
    /// What it is, for a person.
    pub name: &'static str,
    /// Its unit (empty: a pure number).
    pub unit: &'static str,
    /// A count: plotted on an integer axis from 0.
    pub count: bool,
    /// How it is read off a run.
    pub value: fn(&RunResult) -> f64,
}

/// The largest of `f` over a run's rows.
fn peak(r: &RunResult, f: impl Fn(&Row) -> f64) -> f64 {
    r.rows.iter().map(f).fold(f64::NAN, f64::max)
}

/// The sweep's own columns, first in the CSV: this table owns their keys, names and units
/// (the thesis's figures' are [`crate::runs::cycle_figures::judge`]'s).
pub const RUN_COLUMNS: [RunColumn; 7] = [
    RunColumn {
        key: "max_heater_k",
        name: "hottest heater film",
        unit: "K",
        count: false,
        value: |r| r.summary.max_heater_k,
    },
    RunColumn {
        key: "max_smp_outer_k",
        name: "hottest SMP surface",
        unit: "K",
        count: false,
        value: |r| r.summary.max_smp_outer_k,
    },
    RunColumn {
        key: "max_smp_inner_k",
        name: "hottest SMP inner layer",
        unit: "K",
        count: false,
        value: |r| peak(r, |row| row.obs.smp_inner_k),
    },
    RunColumn {
        key: "max_spring_k",
        name: "hottest spring wire",
        unit: "K",
        count: false,
        value: |r| {
            peak(r, |row| {
                row.obs.springs_k.iter().copied().fold(f64::NAN, f64::max)
            })
        },
    },
    RunColumn {
        key: "max_bend_deg",
        name: "largest bend",
        unit: "deg",
        count: false,
        value: |r| r.summary.max_bend_deg,
    },
    RunColumn {
        key: "final_bend_deg",
        name: "bend at the end",
        unit: "deg",
        count: false,
        value: |r| r.summary.final_bend_deg,
    },
    RunColumn {
        key: "faults",
        name: "faults latched",
        unit: "",
        count: true,
        value: |r| r.summary.faults.len() as f64,
    },
];

/// The figure columns of a run's result: [`RUN_COLUMNS`], then each thesis figure's simulated
/// value by its key.
pub fn figures_of(r: &RunResult) -> Vec<(String, Option<f64>)> {
    let mut out: Vec<(String, Option<f64>)> = RUN_COLUMNS
        .iter()
        .map(|c| (c.key.to_string(), Some((c.value)(r))))
        .collect();
    for f in &r.summary.figures {
        out.push((f.key.clone(), f.simulated_f64()));
    }
    out
}

/// A scene key a sweep plots along: what it is, its unit, and its value in that unit.
pub struct SweptKey {
    /// The scene key (dotted for a table's).
    pub key: &'static str,
    /// What it is, for a person.
    pub name: &'static str,
    /// The unit its axis is drawn in (empty: a pure number).
    pub unit: &'static str,
    /// Its value in `unit`, read off a case's checked scene (so `25 °C` is 298.15 K and
    /// `1.5 min` is 90 s).
    pub value: fn(&Scenario) -> f64,
}

/// The scene's numeric keys, as a sweep's x axis names them.
pub const SWEPT_KEYS: [SweptKey; 12] = [
    SweptKey {
        key: "ambient",
        name: "ambient",
        unit: "K",
        value: |s| s.ambient_k,
    },
    SweptKey {
        key: "initial",
        name: "initial temperature",
        unit: "K",
        value: |s| s.initial_k,
    },
    SweptKey {
        key: "duration",
        name: "duration",
        unit: "s",
        value: |s| s.duration_s,
    },
    SweptKey {
        key: "period",
        name: "sample period",
        unit: "s",
        value: |s| s.period_s,
    },
    SweptKey {
        key: "fidelity.max_step",
        name: "largest plant step",
        unit: "s",
        value: |s| s.max_step_s,
    },
    SweptKey {
        key: "camera.noise",
        name: "camera noise",
        unit: "K rms",
        value: |s| s.camera.noise_k,
    },
    SweptKey {
        key: "camera.seed",
        name: "camera seed",
        unit: "",
        value: |s| s.camera.seed as f64,
    },
    SweptKey {
        key: "camera.azimuth",
        name: "camera azimuth",
        unit: "deg",
        value: |s| s.camera.azimuth_deg,
    },
    SweptKey {
        key: "plant.heater_power",
        name: "heater power",
        unit: "% of fitted",
        value: |s| 100.0 * s.plant_scale.heater_power,
    },
    SweptKey {
        key: "plant.wall_capacity",
        name: "wall heat capacity",
        unit: "% of fitted",
        value: |s| 100.0 * s.plant_scale.wall_capacity,
    },
    SweptKey {
        key: "plant.spring_cooling",
        name: "spring cooling",
        unit: "% of fitted",
        value: |s| 100.0 * s.plant_scale.spring_cooling,
    },
    SweptKey {
        key: "plant.spring_supply",
        name: "spring supply voltage",
        unit: "% of fitted",
        value: |s| 100.0 * s.plant_scale.spring_supply,
    },
];

/// `key`'s entry in [`SWEPT_KEYS`].
pub fn swept_key(key: &str) -> Option<&'static SweptKey> {
    SWEPT_KEYS.iter().find(|k| k.key == key)
}

/// Each axis's value of `case` as a number ([`Outcome::values`]).
fn values_of(sc: &Scenario, case: &Case) -> Vec<Option<f64>> {
    case.set
        .iter()
        .map(|(k, v)| match swept_key(k) {
            Some(sk) => Some((sk.value)(sc)),
            None => leading_number(v),
        })
        .collect()
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
                values: values_of(sc, case),
                figures: figures_of(&r),
                judged: r.summary.figures.clone(),
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

/// Write the outcomes as CSV: `case`, each axis's key, each figure column, `fault_list`, and
/// `failing` (the keys of the figures that fail, separated by `;`).
pub fn write_csv(axes: &[Axis], outcomes: &[Outcome], out: &mut impl Write) -> std::io::Result<()> {
    let columns: Vec<&str> = outcomes
        .first()
        .map(|o| o.figures.iter().map(|(c, _)| c.as_str()).collect())
        .unwrap_or_default();
    let mut header = vec!["case".to_string()];
    header.extend(axes.iter().map(|a| a.key.clone()));
    header.extend(columns.iter().map(|c| c.to_string()));
    header.push("fault_list".into());
    header.push("failing".into());
    writeln!(out, "{}", header.join(","))?;
    for o in outcomes {
        let mut cells = vec![o.case.index.to_string()];
        cells.extend(o.case.set.iter().map(|(_, v)| csv_cell(v)));
        cells.extend(o.figures.iter().map(|(_, v)| match v {
            Some(x) if x.is_finite() => format!("{x:.3}"),
            _ => String::new(),
        }));
        cells.push(csv_cell(&o.faults));
        let failing: Vec<&str> = o.failing().iter().map(|f| f.key.as_str()).collect();
        cells.push(failing.join(";"));
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

/// What a plotted column is: its name and unit, and the thesis's value and tolerance where it
/// is one of the thesis's figures.
#[derive(Clone, Debug, PartialEq)]
pub struct Column {
    /// Its CSV key.
    pub key: String,
    /// What it is, for a person.
    pub name: String,
    /// Its unit (empty: a pure number).
    pub unit: String,
    /// The thesis's value.
    pub thesis: Option<f64>,
    /// The tolerance as numbers ([`Figure::limits`]).
    pub limits: Option<(f64, f64)>,
    /// The tolerance as printed.
    pub tolerance: Option<String>,
    /// A count: an integer axis from 0.
    pub count: bool,
}

/// The column `key`: one of [`RUN_COLUMNS`], or the figure of that key among `figures` (a run's
/// judged figures), or else a bare key.
pub fn column(key: &str, figures: &[Figure]) -> Column {
    let bare = Column {
        key: key.to_string(),
        name: key.to_string(),
        unit: String::new(),
        thesis: None,
        limits: None,
        tolerance: None,
        count: false,
    };
    if let Some(c) = RUN_COLUMNS.iter().find(|c| c.key == key) {
        return Column {
            name: c.name.into(),
            unit: c.unit.into(),
            count: c.count,
            ..bare
        };
    }
    match figures.iter().find(|f| f.key == key) {
        Some(f) => Column {
            name: f.name.clone(),
            unit: f.unit.clone(),
            thesis: f.thesis.as_f64(),
            limits: f.limits,
            tolerance: f.tolerance.clone(),
            ..bare
        },
        None => bare,
    }
}

/// A number as a person writes it: no trailing zeros (`25`, `1.3`, `0.125`).
pub fn number(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

/// A value with its unit (`25 s`; a bare number without one).
fn quantity(v: f64, unit: &str) -> String {
    if unit.is_empty() {
        number(v)
    } else {
        format!("{} {unit}", number(v))
    }
}

/// A name with its unit, as an axis says it (`ambient (K)`).
fn with_unit(name: &str, unit: &str) -> String {
    if unit.is_empty() {
        name.to_string()
    } else {
        format!("{name} ({unit})")
    }
}

/// A sweep PNG's text.
#[derive(Clone, Debug, PartialEq)]
pub struct Labels {
    /// The title: the column's name against the swept key's.
    pub title: String,
    /// The x axis: the swept key's name and unit.
    pub x: String,
    /// The y axis: the column's name and unit.
    pub y: String,
    /// What the marks mean: the thesis's value (dashed), its tolerance (shaded) and the
    /// failing cases (red); empty for a column the thesis has no value for.
    pub note: String,
}

/// The text of the PNG of `column` against the swept key `swept`.
pub fn labels(column: &Column, swept: &str) -> Labels {
    let (x_name, x_unit) = swept_key(swept).map_or((swept, ""), |k| (k.name, k.unit));
    let mut note = Vec::new();
    if let Some(t) = column.thesis {
        note.push(format!(
            "dashed: the thesis's {}",
            quantity(t, &column.unit)
        ));
    }
    if let (Some(tol), Some(_)) = (&column.tolerance, column.limits) {
        note.push(format!("shaded: its tolerance ({tol})"));
        note.push("red: a case outside it".into());
    }
    Labels {
        title: format!("{} against {x_name}", column.name),
        x: with_unit(x_name, x_unit),
        y: with_unit(&column.name, &column.unit),
        note: note.join(", "),
    }
}

/// The value axis of a count whose largest value is `max`: 0 to `max` (at least 1), so its
/// ticks are the integers.
pub fn count_range(max: f64) -> Range<f64> {
    0.0..max.max(1.0).ceil()
}

/// The value axis of `column` for the values `ys`: the values, the thesis's value and an edge
/// of the tolerance no further off than they span (a one-sided tolerance's floor of 0 under
/// values near 380 K is left out), with a little room, not below 0 for values that are not.
/// A count's is [`count_range`].
pub fn y_range(column: &Column, ys: &[f64]) -> Range<f64> {
    let ys = ys.iter().copied().filter(|y| y.is_finite());
    if column.count {
        return count_range(ys.fold(0.0, f64::max));
    }
    let (mut lo, mut hi) = ys.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
    if let Some(t) = column.thesis {
        (lo, hi) = (lo.min(t), hi.max(t));
    }
    if lo > hi {
        return 0.0..1.0;
    }
    let least = 0.5_f64.max(0.05 * lo.abs().max(hi.abs()));
    if let Some((a, b)) = column.limits {
        let span = (hi - lo).max(least);
        let (from, to) = (lo - span, hi + span);
        for e in [a, b].into_iter().filter(|e| (from..=to).contains(e)) {
            (lo, hi) = (lo.min(e), hi.max(e));
        }
    }
    let pad = if hi > lo { 0.06 * (hi - lo) } else { least };
    let floor = if lo >= 0.0 { 0.0 } else { f64::MIN };
    (lo - pad).max(floor)..(hi + pad)
}

/// A tick label: the number as written, without trailing zeros.
fn tick(v: &f64) -> String {
    number(*v)
}

/// A count's tick label: the integers only.
fn count_tick(v: &f64) -> String {
    if (v - v.round()).abs() < 1e-9 {
        format!("{v:.0}")
    } else {
        String::new()
    }
}

/// The colours of a sweep's lines (no red: red marks a failing case).
const SERIES: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
    RGBColor(23, 190, 207),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
];
/// A failing case's point.
pub const FAIL_RED: RGBColor = RGBColor(214, 39, 40);
/// The thesis's value (a dashed line) and its tolerance (a band of it, faint).
const THESIS_GREEN: RGBColor = RGBColor(30, 120, 60);
/// A sweep PNG's size, pixels.
pub const SWEEP_PX: (u32, u32) = (1150, 580);

/// One plotted case.
#[derive(Clone, Copy)]
struct Point {
    x: f64,
    y: f64,
    fails: bool,
}

/// The axis the PNGs plot along: the first with more than one value (else the first), if
/// every case's value of it is a number.
fn x_axis(axes: &[Axis], outcomes: &[Outcome]) -> Option<usize> {
    let xi = (0..axes.len())
        .find(|&i| axes[i].values.len() > 1)
        .or((!axes.is_empty()).then_some(0))?;
    outcomes
        .iter()
        .all(|o| o.values.get(xi).copied().flatten().is_some())
        .then_some(xi)
}

/// Draw each figure column against the first swept key with more than one value (one line per
/// combination of the other keys' values; a key with one value is said under the title) into
/// `dir/sweep-<column>.png`: titled and labelled with names and units, the thesis's value a
/// dashed line and its tolerance a shaded band where the column is one of its figures, a
/// failing case's point red. Returns the files written. Columns with no number are skipped;
/// so is everything when that key's values are not numbers.
pub fn write_pngs(
    axes: &[Axis],
    outcomes: &[Outcome],
    dir: &Path,
) -> Result<Vec<PathBuf>, SweepError> {
    let Some(first) = outcomes.first() else {
        return Ok(Vec::new());
    };
    let Some(xi) = x_axis(axes, outcomes) else {
        return Ok(Vec::new());
    };
    let fixed: Vec<String> = axes
        .iter()
        .enumerate()
        .filter(|(i, a)| *i != xi && a.values.len() == 1)
        .map(|(_, a)| format!("{} = {}", a.key, a.values[0]))
        .collect();
    fonts();
    let plot = |e: &dyn std::fmt::Display| SweepError::Plot(e.to_string());
    let mut written = Vec::new();
    for (col, (key, _)) in first.figures.iter().enumerate() {
        let column = column(key, &first.judged);
        // One series per combination of the other swept keys' values, in the grid's order.
        let mut series: Vec<(String, Vec<Point>)> = Vec::new();
        for o in outcomes {
            let (Some(x), Some(y)) = (o.values[xi], o.figures[col].1) else {
                continue;
            };
            if !y.is_finite() {
                continue;
            }
            let fails = o
                .judged
                .iter()
                .find(|f| f.key == *key)
                .is_some_and(Figure::fails);
            let label = o
                .case
                .set
                .iter()
                .enumerate()
                .filter(|(i, _)| *i != xi && axes[*i].values.len() > 1)
                .map(|(_, (k, v))| format!("{k}={v}"))
                .collect::<Vec<_>>()
                .join(" ");
            let p = Point { x, y, fails };
            match series.iter_mut().find(|(l, _)| *l == label) {
                Some((_, pts)) => pts.push(p),
                None => series.push((label, vec![p])),
            }
        }
        if series.is_empty() {
            continue;
        }
        let points: Vec<Point> = series.iter().flat_map(|(_, p)| p.iter().copied()).collect();
        let (x0, x1) = points
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.x), b.max(p.x)));
        let px = if x1 > x0 {
            0.05 * (x1 - x0)
        } else {
            0.5_f64.max(0.05 * x0.abs())
        };
        let ys: Vec<f64> = points.iter().map(|p| p.y).collect();
        let y = y_range(&column, &ys);
        let text = labels(&column, &axes[xi].key);
        let note = fixed
            .iter()
            .cloned()
            .chain((!text.note.is_empty()).then(|| text.note.clone()))
            .collect::<Vec<_>>()
            .join("; ");
        let legend = series.len() > 1;
        let thesis = column.thesis.filter(|t| y.contains(t));
        let path = dir.join(format!("sweep-{key}.png"));
        {
            let root = BitMapBackend::new(&path, SWEEP_PX).into_drawing_area();
            root.fill(&WHITE).map_err(|e| plot(&e))?;
            let mut area = root
                .margin(8, 0, 0, 0)
                .titled(&text.title, (FONT, 20).into_font().style(FontStyle::Bold))
                .map_err(|e| plot(&e))?;
            if !note.is_empty() {
                area = area
                    .titled(&note, (FONT, 14).into_font().color(&RGBColor(70, 70, 70)))
                    .map_err(|e| plot(&e))?;
            }
            // The plot takes the width: room on the right only for what is drawn there (the
            // thesis's line's name, the legend).
            let thesis_font = (FONT, 14).into_font().color(&THESIS_GREEN);
            let thesis_text = thesis.map(|t| format!("thesis {}", quantity(t, &column.unit)));
            let beside = match &thesis_text {
                Some(t) => {
                    root.estimate_text_size(t, &thesis_font)
                        .map_err(|e| plot(&e))?
                        .0
                        + 16
                }
                None => 0,
            };
            let right = 12 + beside + if legend { LEGEND_PX } else { 4 };
            let mut chart = ChartBuilder::on(&area)
                .margin(8)
                .margin_left(12)
                .margin_right(right)
                .x_label_area_size(48)
                .y_label_area_size(84)
                .build_cartesian_2d((x0 - px)..(x1 + px), y.clone())
                .map_err(|e| plot(&e))?;
            let mut mesh = chart.configure_mesh();
            mesh.x_desc(text.x.as_str())
                .y_desc(text.y.as_str())
                .label_style((FONT, 14))
                .axis_desc_style((FONT, 15))
                .light_line_style(RGBColor(238, 238, 238))
                .x_label_formatter(&tick);
            if column.count {
                let n = (y.end as usize).min(10) + 1;
                // Gridlines at the integers only.
                mesh.y_labels(n)
                    .y_max_light_lines(0)
                    .y_label_formatter(&count_tick);
            } else {
                mesh.y_label_formatter(&tick);
            }
            mesh.draw().map_err(|e| plot(&e))?;
            let xs = (x0 - px)..(x1 + px);
            if let Some((lo, hi)) = column.limits {
                let (lo, hi) = (lo.max(y.start), hi.min(y.end));
                if lo < hi {
                    chart
                        .draw_series(std::iter::once(Rectangle::new(
                            [(xs.start, lo), (xs.end, hi)],
                            THESIS_GREEN.mix(0.14).filled(),
                        )))
                        .map_err(|e| plot(&e))?;
                }
            }
            if let (Some(t), Some(name)) = (thesis, thesis_text) {
                chart
                    .draw_series(DashedLineSeries::new(
                        [(xs.start, t), (xs.end, t)],
                        10,
                        6,
                        THESIS_GREEN.stroke_width(2),
                    ))
                    .map_err(|e| plot(&e))?;
                let (px_x, px_y) = chart.backend_coord(&(xs.end, t));
                root.draw(&Text::new(name, (px_x + 8, px_y - 8), thesis_font))
                    .map_err(|e| plot(&e))?;
            }
            let mut keys = Vec::new();
            for (i, (label, pts)) in series.iter().enumerate() {
                let colour = SERIES[i % SERIES.len()];
                let line: Vec<(f64, f64)> = pts.iter().map(|p| (p.x, p.y)).collect();
                chart
                    .draw_series(strokes(line, colour.stroke_width(2)))
                    .map_err(|e| plot(&e))?;
                chart
                    .draw_series(pts.iter().map(|p| {
                        if p.fails {
                            Circle::new((p.x, p.y), 6, FAIL_RED.filled())
                        } else {
                            Circle::new((p.x, p.y), 4, colour.filled())
                        }
                    }))
                    .map_err(|e| plot(&e))?;
                if legend {
                    keys.push(Key {
                        label: label.clone(),
                        colour,
                        swatch: Swatch::Dot,
                    });
                }
            }
            // The legend in a column right of the plot (and of the thesis's name), over no
            // point.
            let (x_px, y_px) = chart.plotting_area().get_pixel_range();
            draw_keys(&root, x_px.end + beside as i32, y_px.start, &keys).map_err(|e| plot(&e))?;
            root.present().map_err(|e| plot(&e))?;
        }
        written.push(path);
    }
    Ok(written)
}

/// The sweep's verdict, as printed after its table: each failing case with the figures it
/// fails (the value, the thesis's and the tolerance), the known shortfalls seen, and the
/// count of cases that pass.
pub fn verdicts(outcomes: &[Outcome]) -> String {
    let mut out = String::new();
    for o in outcomes {
        let failing = o.failing();
        if failing.is_empty() {
            continue;
        }
        let what: Vec<String> = failing
            .iter()
            .map(|f| {
                let sim = f
                    .simulated_f64()
                    .map_or_else(|| f.simulated.to_string(), |v| quantity(v, &f.unit));
                let thesis = f
                    .thesis
                    .as_f64()
                    .map_or_else(|| f.thesis.to_string(), |v| quantity(v, &f.unit));
                format!(
                    "{} {sim} (thesis {thesis}, {})",
                    f.name,
                    f.tolerance.as_deref().unwrap_or("—")
                )
            })
            .collect();
        out += &format!(
            "case {} ({}) fails: {}\n",
            o.case.index,
            o.case.label(),
            what.join(", ")
        );
    }
    let mut known: Vec<&str> = outcomes
        .iter()
        .flat_map(|o| &o.judged)
        .filter(|f| f.pass == Some(false) && f.shortfall().is_some())
        .map(|f| f.name.as_str())
        .collect();
    known.sort_unstable();
    known.dedup();
    if !known.is_empty() {
        out += &format!(
            "not counted: {} (a known shortfall of the simulated block; `host-sim paper` says \
             why)\n",
            known.join(", ")
        );
    }
    let count = |v: &str| outcomes.iter().filter(|o| o.verdict() == v).count();
    let parts: Vec<String> = [
        (count("pass"), "pass"),
        (count("FAIL"), "fail"),
        (count("not judged"), "not judged (no thesis figure shown)"),
    ]
    .iter()
    .filter(|(n, _)| *n > 0)
    .map(|(n, what)| format!("{n} {what}"))
    .collect();
    out += &format!("{}: {}\n", cases_n(outcomes.len()), parts.join(", "));
    out
}

/// `n cases` (`1 case`).
fn cases_n(n: usize) -> String {
    format!("{n} case{}", if n == 1 { "" } else { "s" })
}

/// `--check`: an error naming the failing cases and their figures, if any case fails.
pub fn check(outcomes: &[Outcome]) -> Result<(), SweepError> {
    let failing: Vec<String> = outcomes
        .iter()
        .filter(|o| !o.failing().is_empty())
        .map(|o| {
            let keys: Vec<&str> = o.failing().iter().map(|f| f.key.as_str()).collect();
            format!("{} ({}: {})", o.case.index, o.case.label(), keys.join(", "))
        })
        .collect();
    if failing.is_empty() {
        return Ok(());
    }
    Err(SweepError::Check {
        failed: failing.len(),
        total: outcomes.len(),
        cases: failing.join("; "),
    })
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
    /// Exit with status 1, naming the failing cases, when any case fails a thesis figure (as
    /// `host-sim run`'s table judges it; a known shortfall of the simulated block does not).
    #[arg(long, conflicts_with = "merge")]
    pub check: bool,
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
        let width = outcomes
            .iter()
            .map(|o| o.case.label().chars().count())
            .fold(20, usize::max);
        for o in &outcomes {
            let get = |c: &str| {
                o.figures
                    .iter()
                    .find(|(k, _)| k == c)
                    .and_then(|(_, v)| *v)
                    .map_or("—".to_string(), |v| format!("{v:.1}"))
            };
            println!(
                "{:>4}  {:<width$}  {:<10}  max bend {:>6}°  hottest spring {:>6} K  max SMP inner {:>6} K  faults {}",
                o.case.index,
                o.case.label(),
                o.verdict(),
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
        print!("{}", verdicts(&outcomes));
        println!(
            "wrote {} ({}){}",
            csv.display(),
            cases_n(outcomes.len()),
            if pngs.is_empty() {
                String::new()
            } else {
                format!(" and {} PNGs in {}", pngs.len(), dir.display())
            }
        );
    }
    if args.check {
        check(&outcomes)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::runs::cycle_figures::{CycleFigures, KEYS, judge};

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
                outcome(case, "falling_s", y, Vec::new())
            })
            .collect();
        let dir = tmp("legend");
        let written = write_pngs(&axes, &outcomes, &dir).unwrap();
        assert_eq!(written, [dir.join("sweep-falling_s.png")]);
        let (w, buf) = pixels(&written[0]);
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

    /// A fresh folder for a test's PNGs.
    fn tmp(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("thermorph-sweep-png-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A PNG's width and RGB bytes.
    fn pixels(path: &Path) -> (usize, Vec<u8>) {
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let frame = reader.next_frame(&mut buf).unwrap();
        (frame.width as usize, buf)
    }

    /// A case's outcome with one column, `key` = `y`, the run's figures `judged`, and each
    /// axis's value its leading number.
    fn outcome(case: Case, key: &str, y: f64, judged: Vec<Figure>) -> Outcome {
        Outcome {
            values: case.set.iter().map(|(_, v)| leading_number(v)).collect(),
            case,
            figures: vec![(key.to_string(), Some(y))],
            judged,
            faults: String::new(),
        }
    }

    /// The thesis's figures with the stepping soak at `soak_s` (judged against ≤ 40 s) and,
    /// with `drops`, pulse drops the block cannot reach (a known shortfall).
    fn soak(soak_s: f64, drops: bool) -> Vec<Figure> {
        judge(
            &CycleFigures {
                stepping_soak_s: Some(soak_s),
                pulse_drop_deg: if drops { vec![0.1; 3] } else { Vec::new() },
                ..CycleFigures::default()
            },
            None,
        )
    }

    #[test]
    fn the_axes_and_title_name_the_figure_and_the_swept_key_with_units() {
        let figures = judge(&CycleFigures::default(), None);
        let soak = column("stepping_soak_s", &figures);
        assert_eq!(
            (soak.thesis, soak.limits, soak.count),
            (Some(25.0), Some((0.0, 40.0)), false)
        );
        let l = labels(&soak, "ambient");
        assert_eq!(l.title, "stepping soak against ambient");
        assert_eq!(l.x, "ambient (K)");
        assert_eq!(l.y, "stepping soak (s)");
        assert_eq!(
            l.note,
            "dashed: the thesis's 25 s, shaded: its tolerance (≤ 40 s), red: a case outside it"
        );
        // The sweep's own columns, named by its table; a plant factor in percent.
        let l = labels(&column("max_spring_k", &figures), "plant.heater_power");
        assert_eq!(l.title, "hottest spring wire against heater power");
        assert_eq!(l.x, "heater power (% of fitted)");
        assert_eq!(l.y, "hottest spring wire (K)");
        assert_eq!(l.note, "");
        assert_eq!(labels(&soak, "duration").x, "duration (s)");
        let l = labels(&column("faults", &figures), "camera.noise");
        assert_eq!(
            (l.x.as_str(), l.y.as_str()),
            ("camera noise (K rms)", "faults latched")
        );
        // A figure without a unit, and a key the tables do not know: named by its key.
        assert_eq!(
            labels(&column("stiffness_ratio", &figures), "x").y,
            "stiffness ratio formed/heated"
        );
        let l = labels(&column("other_s", &figures), "fidelity.camera");
        assert_eq!((l.x.as_str(), l.y.as_str()), ("fidelity.camera", "other_s"));
        // Every column a run gives has a name of its own.
        for key in RUN_COLUMNS.iter().map(|c| c.key).chain(KEYS) {
            assert_ne!(column(key, &figures).name, key);
        }
    }

    #[test]
    fn a_count_gets_an_integer_axis_from_zero() {
        assert_eq!(count_range(0.0), 0.0..1.0);
        assert_eq!(count_range(1.0), 0.0..1.0);
        assert_eq!(count_range(3.0), 0.0..3.0);
        let faults = column("faults", &[]);
        assert!(faults.count);
        assert_eq!(y_range(&faults, &[0.0, 0.0, 0.0]), 0.0..1.0);
        assert_eq!(y_range(&faults, &[0.0, 2.0]), 0.0..2.0);
        assert_eq!(count_tick(&1.0), "1");
        assert_eq!(count_tick(&0.5), "");
    }

    #[test]
    fn the_value_axis_shows_the_thesis_and_a_near_edge_of_the_tolerance() {
        let figures = judge(&CycleFigures::default(), None);
        // The soak: 23–75 s over ≤ 40 s: the thesis's 25 s, the edge at 40 s and the floor of 0.
        let y = y_range(
            &column("stepping_soak_s", &figures),
            &[23.0, 39.75, 63.0, 75.0],
        );
        assert_eq!(y.start, 0.0);
        assert!(y.end > 75.0 && y.end < 80.0, "{y:?}");
        // The hottest spring near 372 K under ≤ 383 K: the limit, not the floor of 0.
        let y = y_range(&column("spring_peak_k", &figures), &[372.2, 372.5]);
        assert!(y.start > 371.0 && y.start < 372.2 && y.end > 383.0, "{y:?}");
        // The preheat: both edges, with room above the top one.
        let y = y_range(&column("preheat_time_s", &figures), &[6.5, 12.0]);
        assert!(y.start < 6.5 && y.end > 13.0, "{y:?}");
        // No thesis: the values with room; one value, a span of its own.
        let y = y_range(&column("max_heater_k", &figures), &[380.0, 390.0]);
        assert!(y.start < 380.0 && y.start > 379.0 && y.end > 390.0 && y.end < 391.0);
        let y = y_range(&column("max_heater_k", &figures), &[380.0]);
        assert!(y.start < 380.0 && y.end > 380.0);
    }

    #[test]
    fn a_value_is_plotted_in_its_keys_unit() {
        let src = scenario::source("open-loop").unwrap();
        let case = Case {
            index: 0,
            set: [
                ("ambient", "25 °C"),
                ("plant.heater_power", "80%"),
                ("duration", "10 min"),
                ("camera.seed", "7"),
            ]
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
        };
        let sc = scene_of(&src, &case).unwrap();
        let v = values_of(&sc, &case);
        assert!((v[0].unwrap() - 298.15).abs() < 1e-9, "{v:?}");
        assert!((v[1].unwrap() - 80.0).abs() < 1e-9, "{v:?}");
        assert_eq!(v[2..], [Some(600.0), Some(7.0)]);
    }

    #[test]
    fn a_failing_case_is_red_inside_a_plot_that_takes_the_width() {
        let axes: Vec<Axis> = ["ambient=263K,273K,298K,323K", "duration=900s"]
            .iter()
            .map(|a| a.parse().unwrap())
            .collect();
        let soaks = [75.0, 61.0, 39.75, 23.0];
        let outcomes: Vec<Outcome> = cases(&axes, None)
            .into_iter()
            .zip(soaks)
            .map(|(case, s)| outcome(case, "stepping_soak_s", s, soak(s, false)))
            .collect();
        assert_eq!(
            outcomes.iter().map(Outcome::verdict).collect::<Vec<_>>(),
            ["FAIL", "FAIL", "pass", "pass"]
        );
        let dir = tmp("red");
        let written = write_pngs(&axes, &outcomes, &dir).unwrap();
        let (w, buf) = pixels(&written[0]);
        let h = buf.len() / 3 / w;
        let count = |rgb: [u8; 3], xs: Range<usize>| {
            (0..h)
                .flat_map(|y| xs.clone().map(move |x| 3 * (y * w + x)))
                .filter(|&i| buf[i..i + 3] == rgb)
                .count()
        };
        let red = [FAIL_RED.0, FAIL_RED.1, FAIL_RED.2];
        // Two red points (radius 6) on the left, where the cold cases are.
        assert!(count(red, 0..w / 3) > 150, "{}", count(red, 0..w / 3));
        assert_eq!(count(red, w / 3..w), 0);
        // The dashed thesis line (one series: no legend); the plot reaches the thesis's name,
        // not a blank quarter.
        let green = [THESIS_GREEN.0, THESIS_GREEN.1, THESIS_GREEN.2];
        assert!(count(green, (3 * w) / 4..w - 200) > 100);
        // All passing: nothing red.
        let passing: Vec<Outcome> = outcomes
            .iter()
            .map(|o| outcome(o.case.clone(), "stepping_soak_s", 30.0, soak(30.0, false)))
            .collect();
        let (w2, buf2) = pixels(&write_pngs(&axes, &passing, &tmp("green")).unwrap()[0]);
        assert_eq!(w2, w);
        assert!(!buf2.chunks(3).any(|p| p == red));
        // Without a thesis's value the plot reaches the right edge: its frame's gridlines
        // (the mesh's bold lines) stand in the last tenth of the width.
        let plain: Vec<Outcome> = outcomes
            .iter()
            .map(|o| {
                outcome(
                    o.case.clone(),
                    "max_heater_k",
                    380.0 + o.case.index as f64,
                    Vec::new(),
                )
            })
            .collect();
        let (w3, buf3) = pixels(&write_pngs(&axes, &plain, &tmp("plain")).unwrap()[0]);
        let dark = (0..buf3.len() / 3 / w3)
            .flat_map(|y| (w3 - w3 / 10..w3).map(move |x| 3 * (y * w3 + x)))
            .filter(|&i| buf3[i..i + 3].iter().all(|&c| c < 240))
            .count();
        assert!(dark > 200, "{dark}");
        for d in ["red", "green", "plain"] {
            let _ = std::fs::remove_dir_all(tmp(d));
        }
    }

    #[test]
    fn the_verdict_names_the_failing_cases_and_a_known_shortfall_is_not_one() {
        let axes: Vec<Axis> = vec!["ambient=263K,298K".parse().unwrap()];
        let c = cases(&axes, None);
        let outcomes = vec![
            outcome(c[0].clone(), "stepping_soak_s", 61.0, soak(61.0, true)),
            outcome(c[1].clone(), "stepping_soak_s", 30.0, soak(30.0, true)),
        ];
        assert_eq!(outcomes[1].verdict(), "pass");
        let v = verdicts(&outcomes);
        assert!(
            v.contains("case 0 (ambient=263K) fails: stepping soak 61 s (thesis 25 s, ≤ 40 s)\n"),
            "{v}"
        );
        assert!(!v.contains("case 1"), "{v}");
        assert!(v.contains("not counted: pulse drops ("), "{v}");
        assert!(v.ends_with("2 cases: 1 pass, 1 fail\n"), "{v}");
        let e = check(&outcomes).unwrap_err().to_string();
        assert_eq!(
            e,
            "--check: 1 of 2 cases fail a thesis figure: 0 (ambient=263K: stepping_soak_s)"
        );
        assert!(check(&outcomes[1..]).is_ok());
        // Nothing judged (an open-loop scene): not a pass, not a failure.
        let open = [outcome(c[0].clone(), "max_heater_k", 380.0, Vec::new())];
        assert_eq!(open[0].verdict(), "not judged");
        assert!(verdicts(&open).ends_with("1 case: 1 not judged (no thesis figure shown)\n"));
        assert!(check(&open).is_ok());
        // The CSV's last column names the failing figures.
        let mut csv = Vec::new();
        write_csv(&axes, &outcomes, &mut csv).unwrap();
        let csv = String::from_utf8(csv).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert!(lines[0].ends_with(",fault_list,failing"), "{csv}");
        assert!(
            lines[1].ends_with(",stepping_soak_s") && lines[2].ends_with(','),
            "{csv}"
        );
    }

    #[test]
    fn leading_numbers_of_values() {
        assert_eq!(leading_number("263 K"), Some(263.0));
        assert_eq!(leading_number("298.15K"), Some(298.15));
        assert_eq!(leading_number("-5 °C"), Some(-5.0));
        assert_eq!(leading_number("true"), None);
    }
}
