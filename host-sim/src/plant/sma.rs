//! The SMA springs: phase kinetics (a wide martensite band and a narrow R-phase-like band, both
//! shifted by the spring's stress), latent heat as an enthalpy state and the two-way spring's force
//! law (the electrical circuit is [`super::circuit`]).
//!
//! Kinetics (`Hysteretic`): Liang & Rogers (1990) cosine branches — cooling
//! ξ_M(T) = ½[1 − cos(π(Ms − T)/(Ms − Mf))] on (Mf, Ms), heating
//! ξ_A(T) = ½[1 + cos(π(T − As)/(Af − As))] on (As, Af), ξ the martensite fraction — with
//! partial cycles by the clamp between branches, ξ ← min(ξ_A(T), max(ξ_M(T), ξ)): inner loops
//! are flat, no sign(dT/dt) detection, no chatter. A share β of the stroke (the R-phase-like
//! band) has the same heating branch but a cooling branch only h_R below it (B2↔R hysteresis
//! of a few K): it is what a spring gives back first when it cools from its turning point.
//! Clausius–Clapeyron: the spring's equivalent tensile stress σ (from its last force) raises
//! As, Af by σ/C_A and Ms, Mf by σ/C_M (Brinson 1993 slopes). `Switch`: austenite above
//! (Ms + As)/2, martensite below, no latent heat, no stress shift.
//!
//! Energy: the node's enthalpy H = m·c·T + m·ΔH·(1 − ξ) (austenite formation absorbs ΔH); a step
//! advances the sensible temperature, then settles (T, ξ) on the same H, so energy is conserved
//! exactly and large steps cannot skip the latent heat.

use super::SmaFidelity;
use super::params as p;

/// Martensite fraction on the cooling (forward) branch at `t_k` (unshifted temperatures).
pub fn xi_cooling_branch(t_k: f64) -> f64 {
    if t_k >= p::SMA_MS_K {
        0.0
    } else if t_k <= p::SMA_MF_K {
        1.0
    } else {
        let x = std::f64::consts::PI * (p::SMA_MS_K - t_k) / (p::SMA_MS_K - p::SMA_MF_K);
        0.5 * (1.0 - x.cos())
    }
}

/// Martensite fraction on the heating (reverse) branch at `t_k` (unshifted temperatures).
pub fn xi_heating_branch(t_k: f64) -> f64 {
    if t_k <= p::SMA_AS_K {
        1.0
    } else if t_k >= p::SMA_AF_K {
        0.0
    } else {
        let x = std::f64::consts::PI * (t_k - p::SMA_AS_K) / (p::SMA_AF_K - p::SMA_AS_K);
        0.5 * (1.0 + x.cos())
    }
}

/// Martensite fractions of a spring's two bands, each 0…1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phase {
    /// The wide-hysteresis (B19′ martensite) band's fraction.
    pub wide: f64,
    /// The narrow (R-phase-like) band's fraction.
    pub narrow: f64,
}

impl Phase {
    /// Fully martensite (1) or fully austenite (0) in both bands.
    pub fn uniform(xi: f64) -> Self {
        Phase {
            wide: xi,
            narrow: xi,
        }
    }

    /// The spring's martensite fraction ξ (the bands weighted by their share of the stroke).
    pub fn xi(&self) -> f64 {
        (1.0 - p::SMA_NARROW_SHARE) * self.wide + p::SMA_NARROW_SHARE * self.narrow
    }
}

/// Stress shift of the transformation temperatures, K.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Shift {
    /// Added to As and Af.
    pub austenite_k: f64,
    /// Added to Ms and Mf.
    pub martensite_k: f64,
}

impl Shift {
    /// The Clausius–Clapeyron shift for a spring pulling `force_n` (tension ≥ 0).
    pub fn for_force(force_n: f64) -> Self {
        let sigma = p::SPRING_STRESS_MPA_PER_N * force_n.max(0.0);
        Shift {
            austenite_k: sigma / p::SMA_CA_MPA_PER_K,
            martensite_k: sigma / p::SMA_CM_MPA_PER_K,
        }
    }
}

/// The phase reached at `t_k` from `old` (the clamp between branches), each band in [0, 1].
pub fn kinetics(fidelity: SmaFidelity, t_k: f64, old: Phase, shift: Shift) -> Phase {
    match fidelity {
        SmaFidelity::Hysteretic => {
            let heat = xi_heating_branch(t_k - shift.austenite_k);
            let wide = old
                .wide
                .max(xi_cooling_branch(t_k - shift.martensite_k))
                .min(heat)
                .clamp(0.0, 1.0);
            let narrow_cool =
                xi_heating_branch(t_k - shift.austenite_k + p::SMA_NARROW_HYSTERESIS_K);
            let narrow = old.narrow.max(narrow_cool).min(heat).clamp(0.0, 1.0);
            Phase { wide, narrow }
        }
        SmaFidelity::Switch => Phase::uniform(if t_k >= p::SMA_SWITCH_K { 0.0 } else { 1.0 }),
    }
}

/// Heat capacity of one spring, J/K.
pub fn capacity_j_per_k() -> f64 {
    p::SPRING_MASS_KG * p::NITI_CP_J_PER_KGK
}

/// Latent heat of a full transformation of one spring, J (zero for `Switch`).
pub fn latent_j(fidelity: SmaFidelity) -> f64 {
    match fidelity {
        SmaFidelity::Hysteretic => p::SPRING_MASS_KG * p::NITI_LATENT_J_PER_KG,
        SmaFidelity::Switch => 0.0,
    }
}

/// Conductance of one spring to the still ambient air, W/K.
pub fn ambient_w_per_k() -> f64 {
    p::H_SPRING_W_PER_M2K * p::SPRING_AREA_M2
}

/// Enthalpy of one spring, J (from 0 K, martensite).
pub fn enthalpy_j(fidelity: SmaFidelity, t_k: f64, xi: f64) -> f64 {
    capacity_j_per_k() * t_k + latent_j(fidelity) * (1.0 - xi)
}

/// Settle a spring on enthalpy `h_j` from its previous phase `old`: the (T, phase) with
/// `enthalpy_j(T, ξ) = h_j` and phase = kinetics(T, old). The enthalpy is strictly increasing
/// in T along the kinetics, so bisection finds the unique root.
pub fn settle(fidelity: SmaFidelity, h_j: f64, old: Phase, shift: Shift) -> (f64, Phase) {
    let c = capacity_j_per_k();
    let l = latent_j(fidelity);
    let t_frozen = (h_j - l * (1.0 - old.xi())) / c;
    let frozen = kinetics(fidelity, t_frozen, old, shift);
    if l == 0.0 || frozen == old {
        return (t_frozen, frozen);
    }
    let f = |t: f64| c * t + l * (1.0 - kinetics(fidelity, t, old, shift).xi()) - h_j;
    let span = l / c;
    let (mut lo, mut hi) = (t_frozen - span - 1.0, t_frozen + span + 1.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if f(mid) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
        if hi - lo < 1e-10 {
            break;
        }
    }
    let t = 0.5 * (lo + hi);
    let phase = kinetics(fidelity, t, old, shift);
    // Put the bisection's residual into T so the enthalpy is kept to rounding.
    ((h_j - l * (1.0 - phase.xi())) / c, phase)
}

/// Electrical resistance of one spring's wire (leads excluded) at martensite fraction `xi`, Ω.
pub fn wire_resistance_ohm(xi: f64) -> f64 {
    let rho = xi * p::NITI_RESISTIVITY_M_OHM_M + (1.0 - xi) * p::NITI_RESISTIVITY_A_OHM_M;
    rho * (p::WIRE_LENGTH_MM * 1e-3) / (p::WIRE_AREA_MM2 * 1e-6)
}

/// Natural length of the two-way spring at martensite fraction `xi`, mm.
pub fn free_length_mm(xi: f64) -> f64 {
    p::SPRING_LENGTH_HOT_MM + (p::SPRING_LENGTH_COLD_MM - p::SPRING_LENGTH_HOT_MM) * xi
}

/// Spring rate at martensite fraction `xi` (phases in series), N/mm.
pub fn rate_n_per_mm(xi: f64) -> f64 {
    1.0 / (xi / p::SPRING_K_M_N_PER_MM + (1.0 - xi) / p::SPRING_K_A_N_PER_MM)
}

#[cfg(test)]
mod tests {
    use super::*;

    const NO: Shift = Shift {
        austenite_k: 0.0,
        martensite_k: 0.0,
    };

    #[test]
    fn branches_meet_the_transformation_temperatures() {
        assert_eq!(xi_cooling_branch(p::SMA_MS_K), 0.0);
        assert_eq!(xi_cooling_branch(p::SMA_MF_K), 1.0);
        assert_eq!(xi_heating_branch(p::SMA_AS_K), 1.0);
        assert_eq!(xi_heating_branch(p::SMA_AF_K), 0.0);
        assert!((xi_heating_branch(0.5 * (p::SMA_AS_K + p::SMA_AF_K)) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_partial_cycle_stays_flat_except_for_the_narrow_band() {
        let f = SmaFidelity::Hysteretic;
        // Heat half way, then cool: the narrow band gives back once h_R below the turning
        // point, the wide band holds until the cooling branch.
        let half = kinetics(f, 346.0, Phase::uniform(1.0), NO);
        assert!((half.xi() - 0.5).abs() < 1e-12);
        assert_eq!(
            kinetics(f, 346.0 - 0.5 * p::SMA_NARROW_HYSTERESIS_K, half, NO),
            half
        );
        let cooled = kinetics(f, 340.0, half, NO);
        assert_eq!(cooled.wide, half.wide);
        assert!(cooled.narrow > half.narrow && cooled.narrow <= 1.0);
        assert_eq!(kinetics(f, 321.0, cooled, NO).wide, half.wide);
        assert!(kinetics(f, 318.0, cooled, NO).wide > half.wide);
    }

    #[test]
    fn stress_raises_the_transformation_temperatures() {
        let f = SmaFidelity::Hysteretic;
        let s = Shift::for_force(10.0);
        // 10 N in this coil: ≈80 MPa equivalent, +5.8 K on As (Brinson's C_A).
        assert!((s.austenite_k - 80.0 / 13.8).abs() < 1.0, "{s:?}");
        let mid = 0.5 * (p::SMA_AS_K + p::SMA_AF_K);
        let free = kinetics(f, mid, Phase::uniform(1.0), NO).xi();
        let loaded = kinetics(f, mid, Phase::uniform(1.0), s).xi();
        assert!(loaded > free);
        assert!(
            (kinetics(f, mid + s.austenite_k, Phase::uniform(1.0), s).xi() - free).abs() < 1e-12
        );
    }

    #[test]
    fn settle_keeps_the_enthalpy() {
        let f = SmaFidelity::Hysteretic;
        let h = enthalpy_j(f, 345.0, 1.0);
        let (t, ph) = settle(f, h, Phase::uniform(1.0), NO);
        assert!(ph.xi() < 1.0 && ph.xi() > 0.0);
        assert!(t < 345.0 && t > p::SMA_AS_K);
        assert!((enthalpy_j(f, t, ph.xi()) - h).abs() < 1e-9 * h);
    }
}
