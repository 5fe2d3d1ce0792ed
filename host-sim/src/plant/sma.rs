//! The SMA springs: phase kinetics, latent heat as an enthalpy state, electrical supply and the
//! two-way spring's force law.
//!
//! Kinetics (`Hysteretic`): Liang & Rogers (1990) cosine branches — the cooling branch
//! ξ_M(T) = ½[1 − cos(π(Ms − T)/(Ms − Mf))] on (Mf, Ms) and the heating branch
//! ξ_A(T) = ½[1 + cos(π(T − As)/(Af − As))] on (As, Af), ξ the martensite fraction — with
//! partial cycles by the clamp between branches, ξ ← min(ξ_A(T), max(ξ_M(T), ξ)): inner loops
//! are flat until they meet the major loop, there is no sign(dT/dt) detection and no chatter.
//! The transformation temperatures are taken at the springs' operating load (no C_M, C_A stress
//! shift). `Switch`: austenite above (Ms + As)/2, martensite below, no latent heat.
//!
//! Energy: the node's enthalpy H = m·c·T + m·ΔH·(1 − ξ) (austenite formation absorbs ΔH); a step
//! advances the sensible temperature, then settles (T, ξ) on the same H, so energy is conserved
//! exactly and large steps cannot skip the latent heat.

use super::SmaFidelity;
use super::params as p;

/// Martensite fraction on the cooling (forward) branch at `t_k`.
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

/// Martensite fraction on the heating (reverse) branch at `t_k`.
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

/// The martensite fraction reached at `t_k` from `xi` (the clamp between branches), in [0, 1].
pub fn kinetics(fidelity: SmaFidelity, t_k: f64, xi: f64) -> f64 {
    match fidelity {
        SmaFidelity::Hysteretic => xi
            .max(xi_cooling_branch(t_k))
            .min(xi_heating_branch(t_k))
            .clamp(0.0, 1.0),
        SmaFidelity::Switch => {
            if t_k >= p::SMA_SWITCH_K {
                0.0
            } else {
                1.0
            }
        }
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

/// Conductance of one spring to ambient at fan duty `fan` (0…1), W/K.
pub fn ambient_w_per_k(fan: f64) -> f64 {
    (p::H_SPRING_W_PER_M2K + fan * p::H_SPRING_FAN_FULL_W_PER_M2K) * p::SPRING_AREA_M2
}

/// Enthalpy of one spring, J (from 0 K, martensite).
pub fn enthalpy_j(fidelity: SmaFidelity, t_k: f64, xi: f64) -> f64 {
    capacity_j_per_k() * t_k + latent_j(fidelity) * (1.0 - xi)
}

/// Settle a spring on enthalpy `h_j` from its previous fraction `xi_old`: the (T, ξ) with
/// `enthalpy_j(T, ξ) = h_j` and ξ = kinetics(T, ξ_old). The enthalpy is strictly increasing in T
/// along the kinetics, so bisection finds the unique root.
pub fn settle(fidelity: SmaFidelity, h_j: f64, xi_old: f64) -> (f64, f64) {
    let c = capacity_j_per_k();
    let l = latent_j(fidelity);
    let t_frozen = (h_j - l * (1.0 - xi_old)) / c;
    let xi_frozen = kinetics(fidelity, t_frozen, xi_old);
    if l == 0.0 || xi_frozen == xi_old {
        return (t_frozen, xi_frozen);
    }
    let f = |t: f64| c * t + l * (1.0 - kinetics(fidelity, t, xi_old)) - h_j;
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
    let xi = kinetics(fidelity, t, xi_old);
    // Put the bisection's residual into T so the enthalpy is kept to rounding.
    ((h_j - l * (1.0 - xi)) / c, xi)
}

/// Electrical resistance of one spring (wire plus leads) at martensite fraction `xi`, Ω.
pub fn resistance_ohm(xi: f64) -> f64 {
    let rho = xi * p::NITI_RESISTIVITY_M_OHM_M + (1.0 - xi) * p::NITI_RESISTIVITY_A_OHM_M;
    rho * (p::WIRE_LENGTH_MM * 1e-3) / (p::WIRE_AREA_MM2 * 1e-6) + p::SPRING_LEAD_RESISTANCE_OHM
}

/// Power into each spring's wire, W, for the switched-on set and their fractions: the 5 V
/// supply feeds them in parallel and folds back to its 15 A limit when they draw more.
pub fn powers_w(on: [bool; 3], xi: [f64; 3]) -> [f64; 3] {
    let mut r = [0.0; 3];
    let mut g_total = 0.0;
    for i in 0..3 {
        r[i] = resistance_ohm(xi[i]);
        if on[i] {
            g_total += 1.0 / r[i];
        }
    }
    if g_total == 0.0 {
        return [0.0; 3];
    }
    let v = p::SPRING_SUPPLY_V.min(p::SPRING_SUPPLY_LIMIT_A / g_total);
    let mut out = [0.0; 3];
    for i in 0..3 {
        if on[i] {
            out[i] = v * v / r[i];
        }
    }
    out
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

    #[test]
    fn branches_meet_the_transformation_temperatures() {
        assert_eq!(xi_cooling_branch(p::SMA_MS_K), 0.0);
        assert_eq!(xi_cooling_branch(p::SMA_MF_K), 1.0);
        assert_eq!(xi_heating_branch(p::SMA_AS_K), 1.0);
        assert_eq!(xi_heating_branch(p::SMA_AF_K), 0.0);
        assert!((xi_heating_branch(0.5 * (p::SMA_AS_K + p::SMA_AF_K)) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_partial_cycle_stays_flat_inside_the_loop() {
        let f = SmaFidelity::Hysteretic;
        // Heat half way, then cool to 335 K (between Ms and As): the fraction holds.
        let xi = kinetics(f, 346.0, 1.0);
        assert!((xi - 0.5).abs() < 1e-12);
        assert_eq!(kinetics(f, 335.0, xi), xi);
        // Further cooling joins the cooling branch only once it is reached.
        assert_eq!(kinetics(f, 321.0, xi), xi);
        assert!(kinetics(f, 318.0, xi) > xi);
    }

    #[test]
    fn settle_keeps_the_enthalpy() {
        let f = SmaFidelity::Hysteretic;
        let h = enthalpy_j(f, 345.0, 1.0);
        let (t, xi) = settle(f, h, 1.0);
        assert!(xi < 1.0 && xi > 0.0);
        assert!(t < 345.0 && t > p::SMA_AS_K);
        assert!((enthalpy_j(f, t, xi) - h).abs() < 1e-9 * h);
    }

    #[test]
    fn two_springs_share_the_current_limit() {
        let one = powers_w([true, false, false], [1.0; 3]);
        let two = powers_w([true, true, false], [1.0; 3]);
        let r = resistance_ohm(1.0);
        assert!((one[0] - 25.0 / r).abs() < 1e-9);
        let i_each = (two[0] / r).sqrt();
        assert!((2.0 * i_each - p::SPRING_SUPPLY_LIMIT_A).abs() < 1e-9);
    }
}
