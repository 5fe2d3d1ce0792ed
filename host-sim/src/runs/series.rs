//! A run's time series: one [`Row`] per scene period (the plant, what the controller was
//! given and what it did) and its CSV form. Runs write it, `paper` measures it and the plots
//! draw it; it depends on none of them.

use std::io::Write;

use thermorph::mtts::{Quality, REGIONS};
use thermorph::observer::Estimate;
use thermorph::posture::Bend;

use crate::plant::{Inputs, Observation};

/// One scene period of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// The inputs the plant was given (after faults).
    pub inputs: Inputs,
    /// Spring MOSFETs as commanded (before a stuck-MOSFET fault).
    pub springs_cmd: [bool; 3],
    /// The plant at the end of the period.
    pub obs: Observation,
    /// Region temperatures 1–5 as measured (camera on) or true (camera off), K; `None`
    /// while the sensor has no good frame.
    pub measured_k: Option<[f64; REGIONS]>,
    /// True region temperatures 1–5, K.
    pub truth_k: [f64; REGIONS],
    /// The quality of the frame behind `measured_k` (camera off: the truth, `Resolved`);
    /// `None` while the sensor has no good frame.
    pub quality: Option<Quality>,
    /// Bit mask of the scene's faults active in this period (bit i = fault i).
    pub faults: u32,
    /// The supervisor in this period (closed-loop scenes only).
    pub control: Option<ControlRow>,
}

/// What the supervisor did in one period of a closed-loop run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlRow {
    /// Its mode (as `status` names it).
    pub mode: &'static str,
    /// Its phase within the mode (`-` where none).
    pub phase: &'static str,
    /// The loop's target, K (NaN when no loop runs).
    pub target_k: f64,
    /// Tc as the supervisor computed it, K (NaN before the first measurement).
    pub tc_k: f64,
    /// The latched fault's code, if any.
    pub fault: Option<&'static str>,
    /// The observer's estimate at the period's start (the wall, the springs, the ambient).
    pub estimate: Estimate,
    /// The supervisor's bend estimate (camera and model) at the period's start.
    pub bend: Bend,
    /// The same model without the camera (run beside the supervisor's), degrees.
    pub model_bend_deg: f64,
    /// Each spring channel's current as the firmware measured it, A (NaN before a reading).
    pub spring_a: [f64; 3],
}

/// The CSV header.
pub const CSV_HEADER: &str = "time_s,heater_duty_pct,fan_duty_pct,spring_a,spring_b,spring_c,\
heater_k,smp_inner_k,smp_outer_k,duct_air_k,spring_a_k,spring_b_k,spring_c_k,\
austenite_a,austenite_b,austenite_c,frozen_fraction,bend_deg,bend_plane_deg,k_b_nmm_per_rad,\
heater_power_w,spring_power_w,t1_k,t2_k,t3_k,t4_k,t5_k,faults,mode,phase,target_k,tc_k,fault,\
est_frozen_fraction,est_frozen_std,est_inner_k,est_inner_std_k,est_outer_k,est_ambient_k,\
est_spring_a_k,est_spring_b_k,est_spring_c_k,est_spring_a_std_k,est_spring_b_std_k,\
est_spring_c_std_k,est_austenite_a,est_austenite_b,est_austenite_c,est_bend_deg,est_bend_sd_deg,\
model_bend_deg,quality,spring_power,meas_spring_a_a,meas_spring_b_a,meas_spring_c_a,\
res_spring_a_k,res_spring_b_k,res_spring_c_k";

/// The estimate's columns in an open-loop run (no observer).
const NO_ESTIMATE: &str =
    ",nan,nan,nan,nan,nan,nan,nan,nan,nan,nan,nan,nan,nan,nan,nan,nan,nan,nan";

/// Write the time series as CSV (`nan` where there is no measurement; `quality` is the MTTS
/// frame's, `resolved`, `merged` or `fallback`, and `none` without a frame).
pub fn write_csv(rows: &[Row], out: &mut impl Write) -> std::io::Result<()> {
    writeln!(out, "{CSV_HEADER}")?;
    write_rows(rows, out)
}

/// The CSV text of `rows` (header included), exactly as [`write_csv`] writes it, formatted in
/// chunks on rayon's threads (a float with fixed decimals costs ≈ 100 ns; a 1800-row run has
/// ≈ 90 000 of them).
pub fn csv_text(rows: &[Row]) -> String {
    use rayon::prelude::*;
    const CHUNK_ROWS: usize = 256;
    let chunks: Vec<Vec<u8>> = rows
        .par_chunks(CHUNK_ROWS)
        .map(|chunk| {
            let mut buf = Vec::with_capacity(chunk.len() * 320);
            write_rows(chunk, &mut buf).expect("writing to a Vec cannot fail");
            buf
        })
        .collect();
    let mut text =
        String::with_capacity(CSV_HEADER.len() + 1 + chunks.iter().map(Vec::len).sum::<usize>());
    text.push_str(CSV_HEADER);
    text.push('\n');
    for c in chunks {
        text.push_str(std::str::from_utf8(&c).expect("the rows are written as UTF-8"));
    }
    text
}

/// Write `rows` as CSV lines (no header).
fn write_rows(rows: &[Row], out: &mut impl Write) -> std::io::Result<()> {
    for r in rows {
        let o = &r.obs;
        let s = |b: bool| u8::from(b);
        write!(
            out,
            "{:.3},{:.1},{:.1},{},{},{},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.4},{:.4},{:.4},{:.4},{:.3},{:.2},{:.1},{:.3},{:.3}",
            o.time_s,
            100.0 * r.inputs.heater_duty,
            100.0 * r.inputs.fan_duty,
            s(r.inputs.springs_on[0]),
            s(r.inputs.springs_on[1]),
            s(r.inputs.springs_on[2]),
            o.heater_k,
            o.smp_inner_k,
            o.smp_outer_k,
            o.duct_air_k,
            o.springs_k[0],
            o.springs_k[1],
            o.springs_k[2],
            o.austenite[0],
            o.austenite[1],
            o.austenite[2],
            o.frozen_fraction,
            o.bend_deg,
            o.bend_plane_deg,
            o.k_b_nmm_per_rad,
            o.heater_power_w,
            o.spring_power_w.iter().sum::<f64>(),
        )?;
        for i in 0..REGIONS {
            match r.measured_k {
                Some(m) => write!(out, ",{:.3}", m[i])?,
                None => write!(out, ",nan")?,
            }
        }
        write!(out, ",{}", r.faults)?;
        // The supervisor's columns: `-`/`nan` in open-loop scenes; `fault` is `none` unless
        // a fault is latched.
        match &r.control {
            Some(c) => {
                let k = |v: f64| {
                    if v.is_finite() {
                        format!("{v:.3}")
                    } else {
                        "nan".into()
                    }
                };
                write!(
                    out,
                    ",{},{},{},{},{}",
                    c.mode,
                    c.phase,
                    k(c.target_k),
                    k(c.tc_k),
                    c.fault.unwrap_or("none")
                )?;
                // Austenite (the estimate's) beside the plant's `austenite_*` columns, which
                // are austenite fractions too.
                let e = &c.estimate;
                let values = [e.frozen, e.frozen_std, e.layers_k[0], e.layers_std_k[0]]
                    .into_iter()
                    .chain([e.layers_k[e.layers_k.len() - 1], e.ambient_k])
                    .chain(e.springs_k)
                    .chain(e.springs_std_k)
                    .chain(e.austenite)
                    .chain([c.bend.deg, c.bend.sd_deg]);
                for v in values {
                    write!(out, ",{}", k(v as f64))?;
                }
                write!(out, ",{}", k(c.model_bend_deg))?;
            }
            None => write!(out, ",-,-,nan,nan,none{NO_ESTIMATE}")?,
        }
        write!(out, ",{}", r.quality.map_or("none", Quality::name))?;
        write!(out, ",{}", s(!r.inputs.spring_power_off))?;
        let measured = r.control.map_or([f64::NAN; 3], |c| c.spring_a);
        for a in measured {
            if a.is_finite() {
                write!(out, ",{a:.2}")?;
            } else {
                write!(out, ",nan")?;
            }
        }
        // Each driven spring's temperature by its resistance (the firmware's reading).
        let by_resistance = r
            .control
            .map_or([f32::NAN; 3], |c| c.estimate.springs_wire_k);
        for k in by_resistance {
            if k.is_finite() {
                write!(out, ",{k:.3}")?;
            } else {
                write!(out, ",nan")?;
            }
        }
        writeln!(out)?;
    }
    Ok(())
}
