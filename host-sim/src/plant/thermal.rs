//! The thermal network of the cylinder (heater film, SMP inner and outer layers, duct air,
//! optional PMMA plates) and its three integrators, plus the scalar node update the springs use.
//!
//! The network is linear: `C·dT/dt = −L(fan)·T + G_amb·T_amb + P`, with `L` the conductance
//! Laplacian plus the ambient couplings; only the fan duty changes `L`. Inputs are held over a
//! step (duty-averaged power, no PWM resolution), so the zero-order-hold update is exact.

use super::linalg::{self, Mat, N, Vector};
use super::params as p;
use super::{Integrator, ThermalFidelity};

/// Node index of the heater film (Full), or of the whole cylinder (Lumped).
pub const HEATER: usize = 0;
/// Node index of the SMP inner layer (Full).
pub const INNER: usize = 1;
/// Node index of the SMP outer layer (Full).
pub const OUTER: usize = 2;
/// Node index of the duct air (Full).
pub const AIR: usize = 3;
/// Node index of the PMMA plates (Full with plates).
pub const PLATES: usize = 4;

/// TR-BDF2's stage fraction γ = 2 − √2 (Hosea & Shampine 1996).
const GAMMA: f64 = 2.0 - std::f64::consts::SQRT_2;

/// One assembled network: capacities, conductances and ambient couplings.
#[derive(Clone, Copy, Debug)]
pub struct Network {
    /// Number of nodes.
    pub n: usize,
    /// Heat capacity of each node, J/K.
    pub c_j_per_k: Vector,
    /// Symmetric node-to-node conductances, W/K (diagonal unused).
    pub g_w_per_k: Mat,
    /// Node-to-ambient conductances, W/K.
    pub g_amb_w_per_k: Vector,
}

/// Duct wall coefficient at a fan duty, W/(m²·K).
pub fn duct_h_w_per_m2k(fan_duty: f64) -> f64 {
    p::H_DUCT_STILL_W_PER_M2K
        + (p::H_DUCT_FAN_W_PER_M2K - p::H_DUCT_STILL_W_PER_M2K)
            * fan_duty.powf(p::DUCT_FLOW_EXPONENT)
}

/// Advective conductance of the duct's air flow (ṁ·c_p) at a fan duty, W/K.
pub fn duct_flow_w_per_k(fan_duty: f64) -> f64 {
    let flow = p::DUCT_FLOW_STILL_M3_PER_S + p::DUCT_FLOW_FULL_M3_PER_S * fan_duty;
    flow * p::AIR_DENSITY_KG_PER_M3 * p::AIR_CP_J_PER_KGK
}

impl Network {
    /// Assemble the network for a resolution and fan duty (0…1). `plates` adds the PMMA end
    /// plates (Full only); `adiabatic` cuts every path to ambient (for the energy test).
    pub fn new(fidelity: ThermalFidelity, fan_duty: f64, plates: bool, adiabatic: bool) -> Self {
        Network::scaled(fidelity, fan_duty, plates, adiabatic, 1.0)
    }

    /// [`Network::new`] with the SMP wall's heat capacity multiplied by `wall_capacity` (both
    /// layers; in the Lumped node only the wall's share).
    pub fn scaled(
        fidelity: ThermalFidelity,
        fan_duty: f64,
        plates: bool,
        adiabatic: bool,
        wall_capacity: f64,
    ) -> Self {
        let mut net = Network {
            n: 0,
            c_j_per_k: [0.0; N],
            g_w_per_k: [[0.0; N]; N],
            g_amb_w_per_k: [0.0; N],
        };
        let c_heater = p::HEATER_AREAL_CAPACITY_J_PER_M2K * p::INNER_AREA_M2;
        let c_wall = p::WALL_AREAL_CAPACITY_J_PER_M2K * p::INNER_AREA_M2 * wall_capacity;
        let c_air = p::DUCT_VOLUME_M3 * p::AIR_DENSITY_KG_PER_M3 * p::AIR_CP_J_PER_KGK;
        let g_heater_air = duct_h_w_per_m2k(fan_duty) * p::INNER_AREA_M2;
        let g_flow = duct_flow_w_per_k(fan_duty);
        let g_out = p::H_OUTSIDE_W_PER_M2K * p::OUTER_AREA_M2;
        let amb = if adiabatic { 0.0 } else { 1.0 };
        match fidelity {
            ThermalFidelity::Lumped => {
                net.n = 1;
                net.c_j_per_k[HEATER] = c_heater + c_wall + c_air;
                // Duct film and air flow in series, plus the outside surface.
                let g_duct = g_heater_air * g_flow / (g_heater_air + g_flow);
                net.g_amb_w_per_k[HEATER] = amb * (g_duct + g_out);
            }
            ThermalFidelity::Full => {
                net.n = if plates { 5 } else { 4 };
                net.c_j_per_k[HEATER] = c_heater;
                net.c_j_per_k[INNER] = c_wall * p::INNER_LAYER_SHARE;
                net.c_j_per_k[OUTER] = c_wall * (1.0 - p::INNER_LAYER_SHARE);
                net.c_j_per_k[AIR] = c_air;
                net.link(HEATER, INNER, p::H_HEATER_WALL_W_PER_M2K * p::INNER_AREA_M2);
                let mid_area = 0.5 * (p::INNER_AREA_M2 + p::OUTER_AREA_M2);
                net.link(INNER, OUTER, p::H_WALL_W_PER_M2K * mid_area);
                net.link(HEATER, AIR, g_heater_air);
                net.g_amb_w_per_k[OUTER] = amb * g_out;
                net.g_amb_w_per_k[AIR] = amb * g_flow;
                if plates {
                    let r_m = 0.5 * p::PLATE_DIAMETER_MM * 1e-3;
                    let vol = 2.0 * std::f64::consts::PI * r_m * r_m * p::PLATE_THICKNESS_MM * 1e-3;
                    net.c_j_per_k[PLATES] = vol * p::PMMA_DENSITY_KG_PER_M3 * p::PMMA_CP_J_PER_KGK;
                    net.link(INNER, PLATES, 0.5 * p::G_COLUMN_PLATES_W_PER_K);
                    net.link(OUTER, PLATES, 0.5 * p::G_COLUMN_PLATES_W_PER_K);
                    // Both faces of both plates.
                    let area = 4.0 * std::f64::consts::PI * r_m * r_m;
                    net.g_amb_w_per_k[PLATES] = amb * p::H_PLATE_W_PER_M2K * area;
                }
            }
        }
        net
    }

    fn link(&mut self, i: usize, j: usize, g: f64) {
        self.g_w_per_k[i][j] += g;
        self.g_w_per_k[j][i] += g;
    }

    /// The system matrix `A = −C⁻¹·L` (1/s).
    pub fn system_matrix(&self) -> Mat {
        let mut a = [[0.0; N]; N];
        for i in 0..self.n {
            let mut diag = self.g_amb_w_per_k[i];
            for j in 0..self.n {
                if j != i {
                    a[i][j] = self.g_w_per_k[i][j] / self.c_j_per_k[i];
                    diag += self.g_w_per_k[i][j];
                }
            }
            a[i][i] = -diag / self.c_j_per_k[i];
        }
        a
    }

    /// The forcing `u = C⁻¹·(P + G_amb·T_amb)` (K/s) for node powers `power_w`.
    pub fn forcing(&self, power_w: &Vector, ambient_k: f64) -> Vector {
        let mut u = [0.0; N];
        for i in 0..self.n {
            u[i] = (power_w[i] + self.g_amb_w_per_k[i] * ambient_k) / self.c_j_per_k[i];
        }
        u
    }

    /// Stored sensible heat Σ C·T, J (from 0 K).
    pub fn energy_j(&self, t: &Vector) -> f64 {
        (0..self.n).map(|i| self.c_j_per_k[i] * t[i]).sum()
    }
}

/// Cached zero-order-hold matrices for one (network, step) pair.
#[derive(Clone, Debug)]
pub struct ZohCache {
    key: (u64, u64),
    phi: Mat,
    gamma: Mat,
}

/// A linear system `x' = A·x + u` to advance.
#[derive(Clone, Copy, Debug)]
pub struct System<'a> {
    /// The system matrix, 1/s.
    pub a: &'a Mat,
    /// Its size.
    pub n: usize,
    /// The forcing, K/s.
    pub u: &'a Vector,
    /// A key that identifies `a` (for the ZOH cache).
    pub key: u64,
}

/// Advance `sys` by `h` with the chosen integrator. `cache` holds the last ZOH matrices,
/// keyed by the system's key and `h`.
pub fn advance(
    integrator: Integrator,
    sys: &System<'_>,
    x: &mut Vector,
    h: f64,
    cache: &mut Option<ZohCache>,
) {
    let System { a, n, u, key } = *sys;
    match integrator {
        Integrator::ExponentialZoh => {
            let k = (key, h.to_bits());
            let hit = matches!(cache, Some(c) if c.key == k);
            if !hit {
                let (phi, gamma) = linalg::zoh(a, n, h);
                *cache = Some(ZohCache { key: k, phi, gamma });
            }
            let c = cache.as_ref().expect("filled above");
            let mut y = [0.0; N];
            for i in 0..n {
                let mut s = 0.0;
                for j in 0..n {
                    s += c.phi[i][j] * x[j] + c.gamma[i][j] * u[j];
                }
                y[i] = s;
            }
            *x = y;
        }
        Integrator::BackwardEuler => {
            // (I − hA)·x₁ = x₀ + h·u
            let m = shifted(a, n, h);
            let mut b = [0.0; N];
            for i in 0..n {
                b[i] = x[i] + h * u[i];
            }
            linalg::solve(&m, &mut b, n);
            *x = b;
        }
        Integrator::TrBdf2 => {
            // Trapezoid to t + γh, then BDF2 over (t, t + γh, t + h).
            let hg = GAMMA * h;
            let m1 = shifted(a, n, 0.5 * hg);
            let mut xg = [0.0; N];
            for i in 0..n {
                let mut ax = 0.0;
                for j in 0..n {
                    ax += a[i][j] * x[j];
                }
                xg[i] = x[i] + 0.5 * hg * ax + hg * u[i];
            }
            linalg::solve(&m1, &mut xg, n);
            let c = (1.0 - GAMMA) / (2.0 - GAMMA);
            let wa = 1.0 / (GAMMA * (2.0 - GAMMA));
            let wb = (1.0 - GAMMA) * (1.0 - GAMMA) / (GAMMA * (2.0 - GAMMA));
            let m2 = shifted(a, n, c * h);
            let mut x1 = [0.0; N];
            for i in 0..n {
                x1[i] = wa * xg[i] - wb * x[i] + c * h * u[i];
            }
            linalg::solve(&m2, &mut x1, n);
            *x = x1;
        }
    }
}

/// `I − s·A`.
fn shifted(a: &Mat, n: usize, s: f64) -> Mat {
    let mut m = [[0.0; N]; N];
    for i in 0..n {
        for j in 0..n {
            m[i][j] = -s * a[i][j];
        }
        m[i][i] += 1.0;
    }
    m
}

/// Advance one scalar node `x' = −a·x + s` (a ≥ 0) by `h` with the chosen integrator.
pub fn advance_scalar(integrator: Integrator, a: f64, s: f64, x: f64, h: f64) -> f64 {
    match integrator {
        Integrator::ExponentialZoh => {
            let z = a * h;
            if z < 1e-12 {
                x + s * h
            } else {
                let e = (-z).exp();
                // (1 − e)/a written to stay exact for small a·h.
                x * e + s * (-(-z).exp_m1()) / a
            }
        }
        Integrator::BackwardEuler => (x + h * s) / (1.0 + a * h),
        Integrator::TrBdf2 => {
            let hg = GAMMA * h;
            let xg = (x * (1.0 - 0.5 * hg * a) + hg * s) / (1.0 + 0.5 * hg * a);
            let c = (1.0 - GAMMA) / (2.0 - GAMMA);
            let wa = 1.0 / (GAMMA * (2.0 - GAMMA));
            let wb = (1.0 - GAMMA) * (1.0 - GAMMA) / (GAMMA * (2.0 - GAMMA));
            (wa * xg - wb * x + c * h * s) / (1.0 + c * h * a)
        }
    }
}
