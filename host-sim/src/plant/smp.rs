//! The SMP lattice reduced to the bending degrees of freedom: frozen fraction, modulus, WLF
//! shift, shape fixing and recovery (Liu et al. 2006, thesis eq. 2.13–2.14) and the Maxwell
//! branch that delays recovery (thesis eq. 6.7–6.10, 6.4.3).
//!
//! - Frozen fraction: logistic φ_f(T) = 1/(1 + e^{(T − T_c)/w}).
//! - Relaxed modulus: Liu's series law 1/E = φ_f/E_g + (1 − φ_f)/E_r; bending stiffness
//!   K(T) = k_lat·E(T) (k_lat the open lattice's I_eff/L).
//! - Stored bend b_s (a 2-vector, rad): grows on cooling, db_s = b·dφ_f, and releases on
//!   heating, db_s = (b_s/φ_f)·dφ_f (so b_s ∝ φ_f while φ_f falls, exactly).
//! - Maxwell branch: moment K₁·(b − q) with dq/dt = (b − q)/(τ₁·a_T); updated exactly for b held
//!   over a step. a_T from WLF at and above Tg, Arrhenius below with matched value and slope,
//!   |log10 a_T| ≤ 8, so the WLF pole is never reached.

use super::params as p;

/// Frozen (glassy) fraction at `t_k`, in [0, 1].
pub fn frozen_fraction(t_k: f64) -> f64 {
    let z = ((t_k - p::SMP_PHI_CENTRE_K) / p::SMP_PHI_WIDTH_K).clamp(-700.0, 700.0);
    1.0 / (1.0 + z.exp())
}

/// Relaxed modulus for frozen fraction `phi`, MPa.
pub fn modulus_mpa(phi: f64) -> f64 {
    1.0 / (phi / p::SMP_E_GLASSY_MPA + (1.0 - phi) / p::SMP_E_RUBBERY_MPA)
}

/// Relaxed bending stiffness of the lattice at frozen fraction `phi`, N·mm/rad.
pub fn bending_nmm_per_rad(phi: f64) -> f64 {
    p::SMP_BENDING_PER_MPA_NMM_PER_RAD * modulus_mpa(phi)
}

/// Bending stiffness of the Maxwell branch, N·mm/rad.
pub fn branch_nmm_per_rad() -> f64 {
    p::SMP_BENDING_PER_MPA_NMM_PER_RAD * p::SMP_BRANCH_E_MPA
}

/// log10 of the shift factor a_T at `t_k` (guarded WLF).
pub fn log10_shift(t_k: f64) -> f64 {
    let dt = t_k - p::SMP_TG_K;
    let v = if dt >= 0.0 {
        -p::WLF_C1 * dt / (p::WLF_C2_K + dt)
    } else {
        // Arrhenius with the WLF value (0) and slope (−C1/C2) at Tg.
        let b = p::WLF_C1 * p::SMP_TG_K * p::SMP_TG_K / p::WLF_C2_K;
        b * (1.0 / t_k.max(1.0) - 1.0 / p::SMP_TG_K)
    };
    v.clamp(-p::WLF_LOG10_LIMIT, p::WLF_LOG10_LIMIT)
}

/// Relaxation time of the Maxwell branch at `t_k`, s.
pub fn branch_tau_s(t_k: f64) -> f64 {
    p::SMP_BRANCH_TAU_S * 10f64.powf(log10_shift(t_k))
}

/// The SMP's internal state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmpState {
    /// Frozen fraction, 0…1.
    pub phi: f64,
    /// Stored (frozen) bend vector, rad.
    pub stored_rad: [f64; 2],
    /// Maxwell branch dashpot position, rad.
    pub branch_rad: [f64; 2],
}

impl SmpState {
    /// A straight, relaxed state at frozen fraction `phi`.
    pub fn relaxed(phi: f64, bend_rad: [f64; 2]) -> Self {
        SmpState {
            phi,
            stored_rad: [0.0; 2],
            branch_rad: bend_rad,
        }
    }

    /// Move the frozen fraction to `phi_new` with the column at `bend_rad` (Liu's rule).
    pub fn freeze(&mut self, phi_new: f64, bend_rad: [f64; 2]) {
        let phi_new = phi_new.clamp(0.0, 1.0);
        if phi_new > self.phi {
            let d = phi_new - self.phi;
            for k in 0..2 {
                self.stored_rad[k] += bend_rad[k] * d;
            }
        } else if phi_new < self.phi {
            let r = if self.phi > 0.0 {
                phi_new / self.phi
            } else {
                0.0
            };
            for k in 0..2 {
                self.stored_rad[k] *= r;
            }
        }
        self.phi = phi_new;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modulus_meets_the_thesis_values() {
        let e298 = modulus_mpa(frozen_fraction(298.0));
        let e_tg = modulus_mpa(frozen_fraction(p::SMP_TG_K));
        assert!((e298 - 1000.0).abs() < 5.0, "{e298}");
        assert!((e_tg - 400.0).abs() < 4.0, "{e_tg}");
    }

    #[test]
    fn wlf_is_guarded_and_continuous() {
        assert!(
            (log10_shift(323.0) - 0.2387).abs() < 0.01,
            "{}",
            log10_shift(323.0)
        );
        assert!((log10_shift(358.0) + 0.4653).abs() < 0.01);
        for t in [1.0, 41.0, 100.0, 200.0, 260.0, 333.999, 334.0, 1e6] {
            let v = log10_shift(t);
            assert!(v.is_finite() && v.abs() <= p::WLF_LOG10_LIMIT);
        }
        let slope_lo = (log10_shift(p::SMP_TG_K) - log10_shift(p::SMP_TG_K - 1e-4)) / 1e-4;
        let slope_hi = (log10_shift(p::SMP_TG_K + 1e-4) - log10_shift(p::SMP_TG_K)) / 1e-4;
        assert!((slope_lo - slope_hi).abs() < 1e-3);
    }

    #[test]
    fn stored_bend_grows_on_cooling_and_releases_on_heating() {
        let mut s = SmpState::relaxed(frozen_fraction(358.0), [0.0; 2]);
        let bend = [0.8, 0.0];
        for t in (323..=358).rev() {
            s.freeze(frozen_fraction(t as f64), bend);
        }
        let stored = s.stored_rad[0];
        let want = 0.8 * (frozen_fraction(323.0) - frozen_fraction(358.0));
        assert!((stored - want).abs() < 1e-12);
        s.freeze(frozen_fraction(358.0), bend);
        assert!(s.stored_rad[0] < 0.2 * stored);
    }
}
