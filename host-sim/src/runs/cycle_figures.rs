//! The figures of one thesis cycle (SPEC section 8), measured on a closed-loop run's time
//! series: times from the supervisor's modes and phases, temperatures from its Tc, angles and
//! k_b from the plant's truth. `host-sim paper` judges them against the thesis, `host-sim run`
//! prints them beside it; this module depends on the time series alone.

use crate::runs::series::Row;

fn period(rows: &[Row]) -> f64 {
    match rows {
        [a, b, ..] => b.obs.time_s - a.obs.time_s,
        _ => 0.25,
    }
}

fn mode(r: &Row) -> &'static str {
    r.control.map_or("-", |c| c.mode)
}

fn phase(r: &Row) -> &'static str {
    r.control.map_or("-", |c| c.phase)
}

fn tc(r: &Row) -> f64 {
    r.control.map_or(f64::NAN, |c| c.tc_k)
}

/// What one cycle showed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CycleFigures {
    /// Power-up until Tc first reaches 322.5 K, s.
    pub preheat_time_s: Option<f64>,
    /// Largest Tc − 323 K after Tc first reaches 323 K, in standby before stepping, K.
    pub standby_overshoot_k: Option<f64>,
    /// Largest |Tc − 323 K| over 60 s from 20 s after Tc first reaches 323 K, K.
    pub standby_hold_band_k: Option<f64>,
    /// First spring phase's start to the last one's end, s.
    pub large_stepping_time_s: Option<f64>,
    /// Bend at each pulse's start minus at its end, degrees.
    pub pulse_drop_deg: Vec<f64>,
    /// Bend at the end of stepping, degrees.
    pub full_loading_deg: Option<f64>,
    /// Forming's start until the supervisor ends it, s.
    pub forming_time_s: Option<f64>,
    /// Bend at forming's start minus 20 s later, degrees.
    pub forming_angle_loss_deg: Option<f64>,
    /// k_b when forming ends, N·mm/rad.
    pub formed_k_b: Option<f64>,
    /// That over k_b at the end of stepping.
    pub stiffness_ratio: Option<f64>,
    /// Recovery's start until the bend is within 2° of straight and stays there until recovery
    /// ends, s.
    pub recovery_time_s: Option<f64>,
    /// First spring phase's start until recovery has restored the straight posture (the
    /// thesis's cycle: stepping 30 s + forming 50 s + recovery 40 s; the cooling that locks the
    /// straight shape after that is not counted), s.
    pub cycle_time_s: Option<f64>,
}

/// Measure SPEC section 8's figures on a cycle's rows.
pub fn measure(rows: &[Row]) -> CycleFigures {
    let p = period(rows);
    let start = |i: usize| rows[i].obs.time_s - p;
    let mut f = CycleFigures::default();
    let first = |from: usize, pred: &dyn Fn(&Row) -> bool| {
        rows.iter()
            .enumerate()
            .skip(from)
            .find(|(_, r)| pred(r))
            .map(|(i, _)| i)
    };
    f.preheat_time_s = first(0, &|r| tc(r) >= 322.5).map(|i| rows[i].obs.time_s);
    let step_cmd = first(0, &|r| mode(r) == "step-large").unwrap_or(rows.len());
    if let Some(i323) = first(0, &|r| tc(r) >= 323.0).filter(|&i| i < step_cmd) {
        let t323 = rows[i323].obs.time_s;
        f.standby_overshoot_k = rows[i323..step_cmd]
            .iter()
            .map(|r| tc(r) - 323.0)
            .reduce(f64::max);
        f.standby_hold_band_k = rows[i323..step_cmd]
            .iter()
            .filter(|r| (t323 + 20.0..=t323 + 80.0).contains(&r.obs.time_s))
            .map(|r| (tc(r) - 323.0).abs())
            .reduce(f64::max);
    }
    let springs: Vec<usize> = (step_cmd..rows.len())
        .filter(|&i| mode(&rows[i]) == "step-large" && phase(&rows[i]) == "spring")
        .collect();
    let (Some(&s0), Some(&s1)) = (springs.first(), springs.last()) else {
        return f;
    };
    f.large_stepping_time_s = Some(rows[s1].obs.time_s - start(s0));
    f.full_loading_deg = Some(rows[s1].obs.bend_deg);
    let mut i = s0;
    while i < s1 {
        if phase(&rows[i]) == "pulse" {
            let j = (i..s1).find(|&j| phase(&rows[j]) != "pulse").unwrap_or(s1);
            f.pulse_drop_deg
                .push(rows[i - 1].obs.bend_deg - rows[j - 1].obs.bend_deg);
            i = j;
        } else {
            i += 1;
        }
    }
    let k_b_hot = rows[s1].obs.k_b_nmm_per_rad;
    let Some(fs) = first(s1, &|r| mode(r) == "form") else {
        return f;
    };
    let t_form = start(fs);
    let bend_form = rows[fs - 1].obs.bend_deg;
    f.forming_angle_loss_deg =
        first(fs, &|r| r.obs.time_s >= t_form + 20.0).map(|i| bend_form - rows[i].obs.bend_deg);
    let Some(fe) = first(fs, &|r| mode(r) != "form") else {
        return f;
    };
    f.forming_time_s = Some(start(fe) - t_form);
    f.formed_k_b = Some(rows[fe - 1].obs.k_b_nmm_per_rad);
    f.stiffness_ratio = f.formed_k_b.map(|k| k / k_b_hot);
    let Some(rs) = first(fe, &|r| mode(r) == "recover") else {
        return f;
    };
    let t_rec = start(rs);
    // Settled: the bend is within 2° from then until recovery ends (a pass through straight
    // that swings out again does not count).
    let re = first(rs, &|r| mode(r) != "recover").unwrap_or(rows.len());
    let settled = (rs..re)
        .rev()
        .take_while(|&i| rows[i].obs.bend_deg <= 2.0)
        .last();
    f.recovery_time_s = settled.map(|i| rows[i].obs.time_s - t_rec);
    f.cycle_time_s = settled.map(|i| rows[i].obs.time_s - start(s0));
    f
}
