//! `host-sim pose-table`: posture control (`mode pose ANGLE SPRINGS form`) against the
//! simulated block, camera on, over targets × spring sets × ambients, and the bend estimate's
//! error against the truth in those runs and in the default cycle.
//!
//! Every case powers up in standby at its ambient and at [`POSE_AT_S`] sends `mode pose
//! TARGET SPRINGS form`; a case "from a formed 40°" first poses and forms at 40° with AB, then
//! (once back in standby) poses to its target. The posture after forming is the plant's bend
//! at the case's end, the springs cooled to the room (the shape the frozen wall keeps),
//! against the target; the bend when the pose handed back to standby is shown beside it. The
//! tables are `docs/posture.md`'s.

use std::fmt::Write as _;

use rayon::prelude::*;

use crate::runs::run::{RunError, run_with};
use crate::runs::scenario;
use crate::runs::series::Row;

/// When the (first) pose command is sent, s.
pub const POSE_AT_S: f64 = 60.0;
/// Each case's length, s: long enough for the springs to cool to the room after the last
/// forming (at 283 and 298 K they are martensite again ≈ 5 min after it).
pub const CASE_S: f64 = 1200.0;
/// The targets from straight, degrees.
pub const TARGETS_DEG: [f64; 5] = [10.0, 20.0, 30.0, 45.0, 60.0];
/// The spring sets.
pub const SPRING_SETS: [&str; 4] = ["A", "B", "AB", "BC"];
/// The ambients, K.
pub const AMBIENTS_K: [f64; 3] = [283.15, 298.15, 318.15];
/// The formed posture the re-pose cases start from, degrees (with AB).
pub const FORMED_DEG: f64 = 40.0;
/// The re-pose cases' targets from the formed posture, degrees.
pub const REPOSE_DEG: [f64; 2] = [20.0, 55.0];
/// The turned camera's mount ([`crate::rig::faults::CameraSettings::azimuth_deg`]): spring A's plane,
/// and so A's and BC's bends, along its line of sight.
pub const TURNED_AZIMUTH_DEG: f64 = 90.0;
/// The turned camera's cases: spring sets and targets, at 298 K.
pub const TURNED: [(&str, &[f64]); 2] = [
    ("A", &[10.0, 20.0, 30.0]),
    ("BC", &[10.0, 20.0, 30.0, 45.0]),
];

/// One pose case.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Case {
    /// Ambient, K.
    pub ambient_k: f64,
    /// The spring set, as letters.
    pub springs: &'static str,
    /// Posed and formed here first (with AB), degrees; `None`: from straight.
    pub from_deg: Option<f64>,
    /// The target, degrees.
    pub target_deg: f64,
    /// The camera's mount, degrees (0: the product's; the firmware is told with `set
    /// cam_azimuth_deg`).
    pub azimuth_deg: f64,
}

/// What one case did.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// The case.
    pub case: Case,
    /// The pose command's reply.
    pub reply: String,
    /// The command refused the target as beyond the springs' reach.
    pub out_of_reach: bool,
    /// The springs pulled all they could short of the target (`# pose out of reach`): the
    /// pose ended in standby unformed.
    pub short: bool,
    /// From the (last) pose command to the target reached (the forming's start), s.
    pub reach_s: Option<f64>,
    /// The plant's bend when the pose ended in standby (forming's end), degrees.
    pub formed_deg: Option<f64>,
    /// The plant's bend at the case's end ([`CASE_S`]), degrees: the formed posture once the
    /// springs have cooled towards martensite (`None` when it did not form).
    pub rest_deg: Option<f64>,
    /// The estimate at the case's end, degrees.
    pub estimate_deg: Option<f64>,
    /// Its standard deviation then, degrees.
    pub estimate_sd_deg: Option<f64>,
    /// The hottest any spring got, K.
    pub hottest_spring_k: f64,
    /// The faults latched.
    pub faults: Vec<String>,
    /// The run's rows.
    pub rows: Vec<Row>,
}

impl Outcome {
    /// |at rest − target|, degrees: the posture error after forming.
    pub fn error_deg(&self) -> Option<f64> {
        self.rest_deg.map(|f| (f - self.case.target_deg).abs())
    }
}

/// Every case: targets × spring sets × ambients from straight, then the re-poses from a formed
/// 40° at every ambient.
pub fn cases() -> Vec<Case> {
    let mut out = Vec::new();
    for &ambient_k in &AMBIENTS_K {
        for &springs in &SPRING_SETS {
            for &target_deg in &TARGETS_DEG {
                out.push(Case {
                    ambient_k,
                    springs,
                    from_deg: None,
                    target_deg,
                    azimuth_deg: 0.0,
                });
            }
        }
        for &target_deg in &REPOSE_DEG {
            out.push(Case {
                ambient_k,
                springs: "AB",
                from_deg: Some(FORMED_DEG),
                target_deg,
                azimuth_deg: 0.0,
            });
        }
    }
    out
}

/// The turned camera's cases ([`TURNED`]): the bend along the line of sight, which the
/// camera cannot see, so the pose steps by the model.
pub fn turned_cases() -> Vec<Case> {
    TURNED
        .iter()
        .flat_map(|&(springs, targets)| {
            targets.iter().map(move |&target_deg| Case {
                ambient_k: 298.15,
                springs,
                from_deg: None,
                target_deg,
                azimuth_deg: TURNED_AZIMUTH_DEG,
            })
        })
        .collect()
}

fn scene(c: &Case) -> Result<scenario::Scenario, scenario::ScenarioError> {
    let first = match c.from_deg {
        Some(from) => format!("mode pose {from} AB form"),
        None => format!("mode pose {} {} form", c.target_deg, c.springs),
    };
    // A turned camera's mount is the firmware's setting too, told before anything else.
    let mount = if c.azimuth_deg == 0.0 {
        String::new()
    } else {
        format!(
            "[[command]]\nat = \"0 s\"\nline = \"set cam_azimuth_deg {}\"\n",
            c.azimuth_deg
        )
    };
    let text = format!(
        "name = \"pose\"\nduration = \"{CASE_S} s\"\nambient = \"{a} K\"\ninitial = \"{a} K\"\n\
         period = \"0.25 s\"\n[fidelity]\ncamera = true\n[camera]\nnoise = \"0.1 K\"\nseed = 1\n\
         azimuth = \"{z} deg\"\n{mount}\
         [[command]]\nat = \"0 s\"\nline = \"mode standby\"\n\
         [[command]]\nat = \"{POSE_AT_S} s\"\nline = \"{first}\"\n",
        a = c.ambient_k,
        z = c.azimuth_deg
    );
    scenario::parse(&text, "<pose>", "pose")
}

/// Run one case.
pub fn run_case(c: &Case) -> Result<Outcome, RunError> {
    let sc = scene(c).map_err(RunError::from)?;
    let mut sent = false;
    let second = format!("mode pose {} {} form", c.target_deg, c.springs);
    let repose = c.from_deg.is_some();
    // The re-pose: once the first pose has formed and handed back to standby.
    let mut react = |t_s: f64, s: &thermorph::supervisor::Supervisor| {
        (repose && !sent && t_s > POSE_AT_S + 1.0 && s.mode().name() == "standby").then(|| {
            sent = true;
            second.clone()
        })
    };
    let r = run_with(&sc, &mut |_| {}, &mut react)?;
    let last_pose = r
        .summary
        .replies
        .iter()
        .rfind(|x| x.line.starts_with("mode pose"));
    let (sent_at, reply) =
        last_pose.map_or((POSE_AT_S, String::new()), |x| (x.at_s, x.reply.clone()));
    let after: Vec<&Row> = r.rows.iter().filter(|x| x.obs.time_s > sent_at).collect();
    let phase = |x: &Row| x.control.map_or("-", |c| c.phase);
    let mode = |x: &Row| x.control.map_or("-", |c| c.mode);
    let reach_s = after
        .iter()
        .find(|x| phase(x) == "cool")
        .map(|x| x.obs.time_s - sent_at);
    let end = after
        .iter()
        .skip_while(|x| mode(x) != "pose")
        .find(|x| mode(x) != "pose");
    let short = end.is_some() && reach_s.is_none();
    let end = end.filter(|_| !short);
    // The case's last row, when the pose formed: the posture at rest and its estimate.
    let rest = end.and(r.rows.last());
    let rest_bend = rest.and_then(|x| x.control).map(|c| c.bend);
    let hottest_spring_k = r
        .rows
        .iter()
        .flat_map(|x| x.obs.springs_k)
        .fold(f64::MIN, f64::max);
    Ok(Outcome {
        case: *c,
        out_of_reach: reply.starts_with("err out-of-reach"),
        short,
        reply,
        reach_s,
        formed_deg: end.map(|x| x.obs.bend_deg),
        rest_deg: rest.map(|x| x.obs.bend_deg),
        estimate_deg: rest_bend.map(|b| b.deg as f64),
        estimate_sd_deg: rest_bend.map(|b| b.sd_deg as f64),
        hottest_spring_k,
        faults: r
            .summary
            .faults
            .iter()
            .map(|f| f.code.to_string())
            .collect(),
        rows: r.rows,
    })
}

/// Run every case of `cases` in parallel.
pub fn run_all(cases: &[Case]) -> Result<Vec<Outcome>, RunError> {
    cases.par_iter().map(run_case).collect()
}

/// |estimate − truth| over closed-loop rows: (fused mean, fused max, model-alone mean,
/// model-alone max, rows), degrees.
pub fn estimate_errors<'a>(rows: impl Iterator<Item = &'a Row>) -> (f64, f64, f64, f64, usize) {
    let (mut fs, mut fm, mut ms, mut mm, mut n) = (0.0, 0.0f64, 0.0, 0.0f64, 0usize);
    for r in rows {
        let Some(c) = r.control else { continue };
        let f = (c.bend.deg as f64 - r.obs.bend_deg).abs();
        let m = (c.model_bend_deg - r.obs.bend_deg).abs();
        fs += f;
        fm = fm.max(f);
        ms += m;
        mm = mm.max(m);
        n += 1;
    }
    let d = n.max(1) as f64;
    (fs / d, fm, ms / d, mm, n)
}

/// The posture table (one row per case) as Markdown.
pub fn posture_table(outcomes: &[Outcome]) -> String {
    let mut t = String::from(
        "| ambient | springs | from | target | outcome | reached after | forming's end | at rest (truth) | error | estimate ± sd | hottest spring | faults |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for o in outcomes {
        let c = &o.case;
        let from = c
            .from_deg
            .map_or("straight".to_string(), |f| format!("formed {f:.0}°"));
        let opt =
            |v: Option<f64>, unit: &str| v.map_or("—".to_string(), |v| format!("{v:.1}{unit}"));
        let outcome = if o.out_of_reach {
            // `err out-of-reach: springs AB reach 52.3`: what the springs reach.
            let reach = o.reply.rsplit(' ').next().unwrap_or("?");
            format!("out of reach (refused: reach {reach}°)")
        } else if o.short {
            "out of reach (springs full, unformed)".to_string()
        } else if o.formed_deg.is_some() {
            "formed".to_string()
        } else {
            "not formed".to_string()
        };
        let est = match (o.estimate_deg, o.estimate_sd_deg) {
            (Some(e), Some(s)) => format!("{e:.1} ± {s:.1}°"),
            _ => "—".into(),
        };
        let _ = writeln!(
            t,
            "| {:.0} K | {} | {from} | {:.0}° | {outcome} | {} | {} | {} | {} | {est} | {:.1} K | {} |",
            c.ambient_k,
            c.springs,
            c.target_deg,
            opt(o.reach_s, " s"),
            opt(o.formed_deg, "°"),
            opt(o.rest_deg, "°"),
            opt(o.error_deg(), "°"),
            o.hottest_spring_k,
            if o.faults.is_empty() {
                "none".to_string()
            } else {
                o.faults.join(", ")
            },
        );
    }
    t
}

/// The summary of the posture table: (cases formed, mean error, max error, out of reach —
/// refused or found short), degrees.
pub fn posture_summary(outcomes: &[Outcome]) -> (usize, f64, f64, usize) {
    let errors: Vec<f64> = outcomes.iter().filter_map(Outcome::error_deg).collect();
    let n = errors.len();
    let mean = errors.iter().sum::<f64>() / n.max(1) as f64;
    let max = errors.iter().copied().fold(0.0, f64::max);
    (
        n,
        mean,
        max,
        outcomes
            .iter()
            .filter(|o| o.out_of_reach || o.short)
            .count(),
    )
}

/// The estimate-error table as Markdown: the default cycle and the pose runs, by the bending
/// plane's angle to the camera's view (`turned`: the runs of [`turned_cases`]).
pub fn estimate_table(cycle: &[Row], outcomes: &[Outcome], turned: &[Outcome]) -> String {
    let mut t = String::from(
        "| runs | bending plane | rows | camera + model: mean | max | model alone: mean | max |\n\
         |---|---|---|---|---|---|---|\n",
    );
    let mut line = |name: &str, plane: &str, e: (f64, f64, f64, f64, usize)| {
        let _ = writeln!(
            t,
            "| {name} | {plane} | {} | {:.2}° | {:.1}° | {:.2}° | {:.1}° |",
            e.4, e.0, e.1, e.2, e.3
        );
    };
    line(
        "default cycle (AB)",
        "60° (half across)",
        estimate_errors(cycle.iter()),
    );
    let by = |sets: &[&str]| {
        estimate_errors(
            outcomes
                .iter()
                .filter(|o| sets.contains(&o.case.springs) && !o.out_of_reach)
                .flat_map(|o| o.rows.iter()),
        )
    };
    line(
        "pose runs, A and BC",
        "0° / 180° (across)",
        by(&["A", "BC"]),
    );
    line("pose runs, B and AB", "120° / 60°", by(&["B", "AB"]));
    line(
        "pose runs, A and BC, camera turned 90°",
        "90° (along the view)",
        estimate_errors(turned.iter().flat_map(|o| o.rows.iter())),
    );
    t
}

/// `host-sim pose-table`: run every case and print both tables (Markdown).
pub fn cli() -> anyhow::Result<()> {
    let outcomes = run_all(&cases())?;
    let turned = run_all(&turned_cases())?;
    let cycle = crate::runs::run::run(&scenario::load("cycle")?, &mut |_| {})?;
    let (n, mean, max, refused) = posture_summary(&outcomes);
    println!("{}", posture_table(&outcomes));
    println!("formed: {n} cases, error mean {mean:.2}° max {max:.2}°; out of reach: {refused}\n");
    println!("{}", estimate_table(&cycle.rows, &outcomes, &turned));
    let (n, mean, max, _) = posture_summary(&turned);
    println!("The camera turned {TURNED_AZIMUTH_DEG:.0}° (298 K):\n");
    println!("{}", posture_table(&turned));
    println!("formed: {n} cases, error mean {mean:.2}° max {max:.2}°");
    Ok(())
}
