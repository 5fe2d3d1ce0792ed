//! A state observer of the block's hidden temperatures: a linear Kalman filter on the
//! firmware's own reduced thermal model, and the springs as model states beside it.
//!
//! The camera sees surfaces only: region 1 is the heater film through the lattice's gaps
//! (T1), region 2 the lattice's outer surface (T2), region 5 the background (T5 ≈ ambient).
//! The wall's inside, where the shape memory polymer must pass its transition, is never seen.
//! This module owns the estimate of it: the model, its discretisation, the filter's state and
//! covariance, the springs' temperatures and phases ([`springs`]), the wall's softness (its
//! frozen fraction, and the best the heater can make of it, [`Observer::softest`]) and the
//! parameters ([`ObserverParams`]; the ones a user may tune are in the settings table,
//! [`crate::settings::Settings::observer_params`]). The supervisor owns one: it predicts
//! every step with the outputs that ran and corrects with every new valid frame.
//!
//! # State and model
//!
//! The state (K, `f32`) is `[film, layer 0 (inner, next to the film), …, layer LAYERS−1
//! (outer, what the camera sees as T2), ambient]` ([`STATES`] values). It is a reduced RC
//! network of the plant:
//!
//! ```text
//! C_f·dT_f/dt  = P·heater_duty − G_fw·(T_f − T_0) − G_duct(fan)·(T_f − T_a)
//! C_i·dT_i/dt  = G_{i−1,i}·(T_{i−1} − T_i) − G_{i,i+1}·(T_i − T_{i+1})   (layers)
//! C_o·dT_o/dt  = G_{o−1,o}·(T_{o−1} − T_o) − G_out·(T_o − T_a)
//! dT_a/dt      = 0 (+ process noise: a random walk)
//! ```
//!
//! The duct's air is not a state: its capacity (≈0.23 J/K) is 25–300 times smaller than
//! the film's, so it is eliminated quasi-statically and the film → duct wall coefficient and
//! the air flow's advective conductance act in series, `G_duct = G_w·G_flow/(G_w + G_flow)`,
//! both rising with the fan duty ([`ObserverParams::duct_conductance_w_per_k`]).
//!
//! # Discretisation
//!
//! For a control period `dt` and a fan duty the update is the exact zero-order hold
//! `x₊ = Φ·x + Γ·P·duty`, `Φ = e^{A·dt}`, `Γ = ∫₀^dt e^{A·s}ds·B`, both read from the
//! exponential of the augmented matrix `[[A, B], [0, 0]]·dt`. The exponential is computed by
//! scaling and squaring with a Taylor series (scale until the ∞-norm is ≤ ½, 10 terms, then
//! square back): for this network's ∞-norms (≤ 1 s⁻¹, so ≤ 0.25 at 0.25 s) that is exact to
//! `f32` rounding. Φ and Γ are cached and recomputed only when the fan duty, the period or the
//! parameters change (a 5 × 5 exponential: a few thousand flops).
//!
//! `Φ·1 = 1` (the network only moves heat), so Φ is applied to the deviations from the
//! ambient: the rounding of Φ's row sums, times ≈300 K, does not make a block at rest drift.
//!
//! The process noise is added as `Q·dt` (continuous spectral densities per node, diagonal);
//! measurements are fused one at a time (their noises are independent), in Joseph form, so a
//! missing one is simply skipped.
//!
//! # Order
//!
//! The wall's order (its number of layers) is a compile-time parameter: [`ObserverN`]`<L, S,
//! A>` models `L` layers with `S = L + 2` states and an `A = L + 3` augmented matrix (stable
//! Rust cannot compute `L + 2` in a type, so all three are given and checked at compile
//! time). [`Observer`] is the default, [`LAYERS`] = 2: the lattice's inner 4 mm and outer
//! 1.8 mm layers, the parameters' own values. Any other order models the same wall
//! ([`Wall::split`]): the total capacity and the through-wall conductance are kept, each
//! layer lies in one lattice layer, the frozen fraction is weighted by capacity and T2 still
//! measures the outermost layer. `docs/observer.md` measures error against cost by order.
//!
//! # Robustness
//!
//! No input panics: a NaN duty counts as 0, duties are clamped to 0…1, a non-finite or
//! non-positive period skips the prediction, a period above [`MAX_STEP_S`] is clamped, and a
//! non-finite measurement is skipped like a missing one.

pub mod springs;

use nalgebra::{SMatrix, SVector};

use crate::outputs::{SPRINGS, SpringMask};
use crate::units::{Kelvin, Seconds};
pub use springs::{
    SpringFusion, SpringParams, SpringReading, SpringState, Springs, attainable_austenite,
};

/// Number of wall layers through the lattice's thickness (inner = 0, outer = `LAYERS − 1`).
pub const LAYERS: usize = 2;
/// Number of states: the film, the layers, the ambient.
pub const STATES: usize = LAYERS + 2;
/// State index of the heater film.
pub const FILM: usize = 0;
/// State index of the inner wall layer (next to the film).
pub const INNER: usize = 1;
/// State index of the outer wall layer (the surface the camera sees as T2).
pub const OUTER: usize = LAYERS;
/// State index of the ambient.
pub const AMBIENT: usize = LAYERS + 1;
/// Longest period one prediction covers, s: a longer one is clamped (the covariance then
/// under-grows; the board's period is 0.125–0.5 s).
pub const MAX_STEP_S: f32 = 10.0;

/// Size of the augmented matrix of the zero-order hold (state + one input).
pub const AUG: usize = STATES + 1;

/// A state-sized square matrix.
type Mat<const S: usize> = SMatrix<f32, S, S>;
/// A state-sized vector.
type Vec<const S: usize> = SVector<f32, S>;

// The plant's geometry (`crate::block`), in m and m².
const PI: f32 = core::f32::consts::PI;
const LENGTH_M: f32 = crate::block::CYLINDER_LENGTH_MM * 1e-3;
const INNER_DIAMETER_M: f32 = crate::block::CYLINDER_INNER_DIAMETER_MM * 1e-3;
const OUTER_DIAMETER_M: f32 = crate::block::CYLINDER_OUTER_DIAMETER_MM * 1e-3;
/// Heater film (inner) surface, m²: π·d_i·L ≈ 0.02199.
const INNER_AREA_M2: f32 = PI * INNER_DIAMETER_M * LENGTH_M;
/// Outer surface, m²: π·d_o·L ≈ 0.02513.
const OUTER_AREA_M2: f32 = PI * OUTER_DIAMETER_M * LENGTH_M;
/// Mid-wall area, m² (the layer-to-layer path).
const MID_AREA_M2: f32 = 0.5 * (INNER_AREA_M2 + OUTER_AREA_M2);
/// The inner layer's share of the wall's capacity: 4 mm / (4 + 1.8) mm
/// (`block::LATTICE_LOWER_LAYER_MM`, `block::LATTICE_UPPER_LAYER_MM`).
const INNER_SHARE: f32 = crate::block::LATTICE_LOWER_LAYER_MM
    / (crate::block::LATTICE_LOWER_LAYER_MM + crate::block::LATTICE_UPPER_LAYER_MM);
/// The wall's areal capacity, J/(m²·K) (host-sim `WALL_AREAL_CAPACITY_J_PER_M2K`).
const WALL_AREAL_J_PER_M2K: f32 = 1500.0;
/// Heater supply voltage, V (thesis 6.3.2; host-sim `HEATER_SUPPLY_V`).
const HEATER_SUPPLY_V: f32 = 18.0;
/// Heater resistance, Ω (host-sim `HEATER_RESISTANCE_OHM`, fitted).
const HEATER_RESISTANCE_OHM: f32 = 5.5;
/// Heater supply current limit, A (thesis 6.3.2; host-sim `HEATER_SUPPLY_LIMIT_A`).
const HEATER_SUPPLY_LIMIT_A: f32 = 10.0;
/// Full-duty current, A: V/R, capped by the supply's limit.
const HEATER_FULL_A: f32 = if HEATER_SUPPLY_V / HEATER_RESISTANCE_OHM < HEATER_SUPPLY_LIMIT_A {
    HEATER_SUPPLY_V / HEATER_RESISTANCE_OHM
} else {
    HEATER_SUPPLY_LIMIT_A
};
/// One spring's wire length, m: 25 coils of 18 mm mean diameter (host-sim `COIL_COUNT`,
/// `COIL_DIAMETER_MM`).
const SPRING_WIRE_M: f32 = PI * 18.0e-3 * 25.0;
/// The wire's cross-section, m²: Ø 2.3 mm (thesis 6.3.2).
const SPRING_WIRE_AREA_M2: f32 = PI / 4.0 * 2.3e-3 * 2.3e-3;
/// One spring's mass, kg: NiTi at 6450 kg/m³.
const SPRING_MASS_KG: f32 = SPRING_WIRE_AREA_M2 * SPRING_WIRE_M * 6450.0;
/// Advective conductance ρ·c_p of one m³/s of air, W·s/(m³·K): 1.19 kg/m³ × 1005 J/(kg·K).
const AIR_RHO_CP: f32 = 1.19 * 1005.0;

/// The observer's model and noise parameters. Every default comes from the simulator's plant
/// constants (`host-sim/src/plant/params.rs`, assembled as in `thermal::Network::new`) so the
/// reduced model matches the plant; they are the firmware's own copies, not the plant linked
/// in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObserverParams {
    /// Heater power at full duty, W: `min(V/R, I_max)²·R` with 18 V, 5.5 Ω, 10 A (host-sim
    /// `HEATER_SUPPLY_V`, `HEATER_RESISTANCE_OHM`, `HEATER_SUPPLY_LIMIT_A`) ≈ 58.91 W.
    pub heater_full_power_w: f32,
    /// Heater film capacity, J/K: `HEATER_AREAL_CAPACITY_J_PER_M2K` (280) × the inner area
    /// (π·35 mm·200 mm) ≈ 6.16.
    pub film_capacity_j_per_k: f32,
    /// Capacity of each wall layer, inner first, J/K: `WALL_AREAL_CAPACITY_J_PER_M2K` (1500) ×
    /// the inner area, split 4 : 1.8 by the lattice layers' thicknesses ≈ [22.8, 10.2].
    pub layer_capacity_j_per_k: [f32; LAYERS],
    /// Film → inner layer conductance, W/K: `H_HEATER_WALL_W_PER_M2K` (150) × the inner
    /// area ≈ 3.30.
    pub film_layer_w_per_k: f32,
    /// Layer i → layer i+1 conductances, W/K: `H_WALL_W_PER_M2K` (54.6) × the mid-wall area
    /// (π·37.5 mm·200 mm) ≈ [1.29].
    pub layer_layer_w_per_k: [f32; LAYERS - 1],
    /// Outer layer → ambient (natural convection and radiation), W/K: `H_OUTSIDE_W_PER_M2K`
    /// (11) × the outer area (π·40 mm·200 mm) ≈ 0.277.
    pub outer_ambient_w_per_k: f32,
    /// Film → duct air coefficient × inner area with the fan off, W/K:
    /// `H_DUCT_STILL_W_PER_M2K` (4) × 0.02199 ≈ 0.088.
    pub duct_wall_still_w_per_k: f32,
    /// The same with the fan at full duty, W/K: `H_DUCT_FAN_W_PER_M2K` (30) × 0.02199 ≈ 0.660.
    pub duct_wall_fan_w_per_k: f32,
    /// Exponent of the duct wall coefficient on the fan duty (host-sim `DUCT_FLOW_EXPONENT`,
    /// Dittus–Boelter h ∝ Re^0.8): `G_w = still + (fan − still)·duty^exponent`.
    pub duct_exponent: f32,
    /// Advective conductance ṁ·c_p of the duct's natural draught (fan off), W/K:
    /// `DUCT_FLOW_STILL_M3_PER_S` (4·10⁻⁵) × 1.19 kg/m³ × 1005 J/(kg·K) ≈ 0.048.
    pub duct_flow_still_w_per_k: f32,
    /// Added advective conductance at full fan duty (linear in the duty), W/K:
    /// `DUCT_FLOW_FULL_M3_PER_S` (6.6·10⁻³) × 1.19 × 1005 ≈ 7.89.
    pub duct_flow_fan_w_per_k: f32,
    /// Process noise of the film, K²/s (unmodelled power: the PWM, the supply's droop, the
    /// film's contact).
    pub film_process_k2_per_s: f32,
    /// Process noise of each wall layer, K²/s (unmodelled heat paths: plates, springs).
    pub layer_process_k2_per_s: f32,
    /// Process noise of the ambient (its random walk), K²/s.
    pub ambient_process_k2_per_s: f32,
    /// Noise variance of T1 (film), K² (MLX90640 region mean, ≈0.3 K; the film is seen
    /// through the lattice's gaps).
    pub t1_noise_k2: f32,
    /// Noise variance of T2 (outer layer), K².
    pub t2_noise_k2: f32,
    /// Noise variance of T5 (background ≈ ambient), K².
    pub t5_noise_k2: f32,
    /// Initial variance of every state, K² (the initial temperature is a guess).
    pub initial_variance_k2: f32,
    /// Centre of the wall's frozen fraction φ = 1/(1 + e^{(T − centre)/width}), K (thesis
    /// 2.3.2's two-phase model: the glassy share of the SMP; PLA's transition, T_g = 334 K).
    pub frozen_centre_k: f32,
    /// Width of the frozen fraction's logistic, K: its 10–90 % span is 4.4 widths (329–349 K).
    pub frozen_width_k: f32,
    /// The springs' model.
    pub springs: SpringParams,
}

impl ObserverParams {
    /// The defaults: the plant's constants (see each field) and moderate noises.
    pub const DEFAULT: ObserverParams = ObserverParams {
        heater_full_power_w: HEATER_FULL_A * HEATER_FULL_A * HEATER_RESISTANCE_OHM,
        film_capacity_j_per_k: 280.0 * INNER_AREA_M2,
        layer_capacity_j_per_k: [
            WALL_AREAL_J_PER_M2K * INNER_AREA_M2 * INNER_SHARE,
            WALL_AREAL_J_PER_M2K * INNER_AREA_M2 * (1.0 - INNER_SHARE),
        ],
        film_layer_w_per_k: 150.0 * INNER_AREA_M2,
        layer_layer_w_per_k: [54.6 * MID_AREA_M2],
        outer_ambient_w_per_k: 11.0 * OUTER_AREA_M2,
        duct_wall_still_w_per_k: 4.0 * INNER_AREA_M2,
        duct_wall_fan_w_per_k: 30.0 * INNER_AREA_M2,
        duct_exponent: 0.8,
        duct_flow_still_w_per_k: 4.0e-5 * AIR_RHO_CP,
        duct_flow_fan_w_per_k: 6.6e-3 * AIR_RHO_CP,
        film_process_k2_per_s: 0.05,
        layer_process_k2_per_s: 0.01,
        ambient_process_k2_per_s: 1e-4,
        t1_noise_k2: 0.25,
        t2_noise_k2: 0.25,
        t5_noise_k2: 0.25,
        initial_variance_k2: 100.0,
        frozen_centre_k: 335.5,
        frozen_width_k: 3.0,
        springs: SpringParams {
            // 15 A (the channel's limit) through 80 µΩ·cm × 1.414 m / 4.155 mm² = 0.272 Ω.
            power_w: 15.0 * 15.0 * 80e-8 * SPRING_WIRE_M / SPRING_WIRE_AREA_M2,
            // 37.9 g of NiTi (6450 kg/m³) at 480 J/(kg·K).
            capacity_j_per_k: SPRING_MASS_KG * 480.0,
            // 22 J/g (trained two-way wire: 15–35 J/g).
            latent_j: SPRING_MASS_KG * 22_000.0,
            // 13.2 W/(m²·K) over the wire's 0.0102 m² [fitted]: 10 % above the still-air
            // 12 W/(m²·K) the block's wire loses to, because a spring that pulls against the
            // column runs cooler than the model believes (its transformation shifts with the
            // load, which the model does not carry): with 12, recovery's hold kept the loaded
            // springs ≈ 7.5 K under the estimate, 0.97 austenite, and the column came back 10°
            // bent at 298 K (12° at 263 K); with 13.2 they sit 3.8 K under it and the cycle
            // ends within 0.4° at every ambient from 263 to 323 K. An unloaded spring held at
            // the band then runs ≈ 2.9 K above its estimate.
            ambient_w_per_k: 13.2 * PI * 2.3e-3 * SPRING_WIRE_M,
            column_w_per_k: 0.017,
            as_k: 341.0,
            af_k: 351.0,
            ms_k: 325.0,
            mf_k: 315.0,
            // NiTi within a phase: 10⁻⁴–10⁻³ per K; the block's wire 3·10⁻⁴.
            tempco_per_k: 3e-4,
            on_process_k2_per_s: 0.5,
            off_process_k2_per_s: 0.02,
        },
    };

    /// Film → ambient conductance through the duct at a fan duty (0…1), W/K: the wall
    /// coefficient and the air flow in series (the duct air eliminated quasi-statically).
    pub fn duct_conductance_w_per_k(&self, fan_duty: f32) -> f32 {
        let d = sanitize_duty(fan_duty);
        let wall = self.duct_wall_still_w_per_k
            + (self.duct_wall_fan_w_per_k - self.duct_wall_still_w_per_k)
                * libm::powf(d, self.duct_exponent);
        let flow = self.duct_flow_still_w_per_k + self.duct_flow_fan_w_per_k * d;
        let sum = wall + flow;
        if sum > 0.0 { wall * flow / sum } else { 0.0 }
    }

    /// The frozen fraction of one layer at `t_k` (the logistic of [`Self::frozen_centre_k`]).
    pub fn layer_frozen(&self, t_k: f32) -> f32 {
        let w = self.frozen_width_k.max(1e-3);
        let x = ((t_k - self.frozen_centre_k) / w).clamp(-60.0, 60.0);
        1.0 / (1.0 + libm::expf(x))
    }

    /// The wall's frozen fraction: the layers' weighted by their capacities.
    pub fn frozen_fraction(&self, layers_k: &[f32; LAYERS]) -> f32 {
        self.frozen_with_std(layers_k, &[0.0; LAYERS]).0
    }

    /// The frozen fraction ([`Self::frozen_fraction`]) and its standard deviation: each
    /// layer's temperature deviation `std_k` through the logistic's slope (layers taken as
    /// fully correlated: a bound), at most 0.5. Each layer's logistic is evaluated once.
    fn frozen_with_std(&self, layers_k: &[f32; LAYERS], std_k: &[f32; LAYERS]) -> (f32, f32) {
        weighted_frozen(self, &self.layer_capacity_j_per_k, layers_k, std_k)
    }
}

impl Default for ObserverParams {
    /// [`ObserverParams::DEFAULT`].
    fn default() -> Self {
        ObserverParams::DEFAULT
    }
}

/// The frozen fraction of layers at `layers_k` weighted by their capacities `caps`, and its
/// standard deviation: each layer's temperature deviation `std_k` through the logistic's
/// slope (layers taken as fully correlated: a bound), at most 0.5. Each layer's logistic is
/// evaluated once.
fn weighted_frozen<const L: usize>(
    p: &ObserverParams,
    caps: &[f32; L],
    layers_k: &[f32; L],
    std_k: &[f32; L],
) -> (f32, f32) {
    let w = p.frozen_width_k.max(1e-3);
    let (mut sum, mut spread, mut weight) = (0.0f32, 0.0f32, 0.0f32);
    for ((&t, &s), &c) in layers_k.iter().zip(std_k).zip(caps) {
        let f = p.layer_frozen(t);
        sum += c.max(0.0) * f;
        spread += c.max(0.0) * f * (1.0 - f) / w * s;
        weight += c.max(0.0);
    }
    if weight > 0.0 {
        (sum / weight, (spread / weight).min(0.5))
    } else {
        (1.0, 0.5)
    }
}

// `ObserverParams` holds the wall as the lattice's two layers; `Wall::split` reads them so.
const _: () = assert!(
    LAYERS == 2,
    "ObserverParams describes the two lattice layers"
);

/// Thickness of the lattice's inner (lower) layer, mm: `block::LATTICE_LOWER_LAYER_MM`.
const INNER_LAYER_MM: f32 = crate::block::LATTICE_LOWER_LAYER_MM;
/// Thickness of the whole wall (both lattice layers), mm: 4 + 1.8.
const WALL_MM: f32 = crate::block::LATTICE_LOWER_LAYER_MM + crate::block::LATTICE_UPPER_LAYER_MM;

/// The wall through its thickness in `L` layers (nodes): what an [`ObserverN`] of order `L`
/// models. Built from the two-layer [`ObserverParams`] by [`Wall::from_params`]; see
/// [`Wall::split`] for the discretisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wall<const L: usize> {
    /// Capacity of each layer, inner (next to the film) first, J/K.
    pub capacity_j_per_k: [f32; L],
    /// Film → inner layer conductance, W/K.
    pub film_w_per_k: f32,
    /// Each layer's outward conductance, W/K: layer `l` → layer `l + 1`, and the outer layer
    /// → the ambient (natural convection and radiation) last.
    pub outward_w_per_k: [f32; L],
    /// Depth of each layer's centre below the film's surface, mm (the wall is
    /// 4 + 1.8 = 5.8 mm thick, the inner lattice layer the first 4 mm).
    pub centre_mm: [f32; L],
}

impl<const L: usize> Wall<L> {
    /// The wall of the observer of order `L` for `p`: for the default order ([`LAYERS`]) the
    /// parameters' own layers, value for value; for any other, [`Wall::split`].
    pub fn from_params(p: &ObserverParams) -> Wall<L> {
        if L != LAYERS {
            return Wall::split(p);
        }
        let at = |a: &[f32], l: usize| a.get(l).copied().unwrap_or(0.0);
        let mut outward = [0.0f32; L];
        for (l, g) in outward.iter_mut().enumerate() {
            *g = if l + 1 < L {
                at(&p.layer_layer_w_per_k, l)
            } else {
                p.outer_ambient_w_per_k
            };
        }
        Wall {
            capacity_j_per_k: core::array::from_fn(|l| at(&p.layer_capacity_j_per_k, l)),
            film_w_per_k: p.film_layer_w_per_k,
            outward_w_per_k: outward,
            centre_mm: Self::centres().1,
        }
    }

    /// The layers' layout: how many lie in the inner lattice layer, and each one's centre,
    /// mm. The inner 4 mm hold `n = round(L·4/5.8)` (at least 1 and at most `L − 1`: each
    /// lattice layer has at least one node) of equal thickness, the outer 1.8 mm the other
    /// `L − n`: as near to equal thicknesses as the two layers allow (2 layers: 4 | 1.8 mm;
    /// 3: 2, 2 | 1.8; 4: 1.33 ×3 | 1.8; 6: 1 ×4 | 0.9 ×2). One layer spans the whole wall.
    fn centres() -> (usize, [f32; L]) {
        let outer_mm = WALL_MM - INNER_LAYER_MM;
        let n_in = if L < 2 {
            L
        } else {
            // `as usize` saturates: no panic whatever the float.
            ((L as f32 * INNER_LAYER_MM / WALL_MM + 0.5) as usize).clamp(1, L - 1)
        };
        let mut centre = [0.0f32; L];
        for (l, c) in centre.iter_mut().enumerate() {
            *c = if L == 1 {
                0.5 * WALL_MM
            } else if l < n_in {
                (l as f32 + 0.5) * INNER_LAYER_MM / n_in as f32
            } else {
                INNER_LAYER_MM + ((l - n_in) as f32 + 0.5) * outer_mm / (L - n_in) as f32
            };
        }
        (n_in, centre)
    }

    /// The same wall as `p`'s two layers in `L` layers, a cell-centred finite-volume
    /// discretisation of the wall's thickness:
    ///
    /// - the layout: the inner 4 mm hold `n = round(L·4/5.8)` layers of equal thickness (at
    ///   least 1 and at most `L − 1`), the outer 1.8 mm the other `L − n` (2 layers:
    ///   4 | 1.8 mm; 3: 2, 2 | 1.8; 4: 1.33 ×3 | 1.8; 6: 1 ×4 | 0.9 ×2); each layer lies in
    ///   one lattice layer (one layer: the whole wall), its node at its centre
    ///   ([`Wall::centre_mm`]);
    /// - capacities: each lattice layer's (`p.layer_capacity_j_per_k`) shared equally by
    ///   its layers (equal thickness, uniform areal capacity), so the total is conserved;
    /// - conductances: `p`'s two-node chain film →(`R_a`) inner centre →(`R_b`) outer
    ///   centre →(`R_c`) ambient read as a resistance profile through the wall's depth: a
    ///   uniform resistance per mm `r = R_b/2.9 mm` between the two centres (half the wall,
    ///   2.9 mm, apart), a film contact `R_a − r·2 mm` and a surface resistance
    ///   `R_c − r·0.9 mm`; where `R_a` is less than `r·2 mm` (the fitted film link is better
    ///   than the lattice's conduction over that depth) the contact is none and the inner
    ///   half-layer conducts `R_a/2 mm` per mm, and the same at the surface. Each link is the
    ///   profile's rise between its ends: the film → ambient resistance through the wall is
    ///   `R_a + R_b + R_c` for every `L` (the steady state is conserved), and for `L = 2` the
    ///   links are `p`'s (to rounding: [`Wall::from_params`] takes `p`'s values).
    ///
    /// The outer layer is still what T2 measures: as `L` grows its centre nears the surface
    /// (2 layers: 0.9 mm below it, 6: 0.45 mm). A non-positive conductance counts as none.
    pub fn split(p: &ObserverParams) -> Wall<L> {
        let (n_in, centre) = Self::centres();
        let resistance = |g: f32| if g > 0.0 { 1.0 / g } else { f32::INFINITY };
        let conductance = |r: f32| if r.is_nan() { 0.0 } else { 1.0 / r };
        let (r_a, r_b, r_c) = (
            resistance(p.film_layer_w_per_k),
            resistance(p.layer_layer_w_per_k[0]),
            resistance(p.outer_ambient_w_per_k),
        );
        let per_mm = r_b / (0.5 * WALL_MM);
        // The two centres' depths, mm: 2 and 4.9.
        let (c_in, c_out) = (0.5 * INNER_LAYER_MM, 0.5 * (INNER_LAYER_MM + WALL_MM));
        // A film link shorter than `r` over the inner centre's depth (a contact better than the
        // lattice's own conduction there) leaves no contact: the inner half-layer then conducts
        // `R_a`/2 mm per mm. The same on the surface side.
        let per_mm_in = per_mm.min(r_a / c_in);
        let per_mm_out = per_mm.min(r_c / (WALL_MM - c_out));
        // `max` takes 0 over a NaN (∞ − ∞: no path at all, the link is cut below anyway).
        let contact = (r_a - per_mm_in * c_in).max(0.0);
        let surface = (r_c - per_mm_out * (WALL_MM - c_out)).max(0.0);
        // Resistance from the film to depth `x`, mm: through `R_a` at the inner centre,
        // `R_a + R_b` at the outer one.
        let depth = |x: f32| {
            if x <= c_in {
                contact + per_mm_in * x
            } else if x <= c_out {
                r_a + per_mm * (x - c_in)
            } else {
                r_a + r_b + per_mm_out * (x - c_out)
            }
        };
        let (c_in, c_out) = (p.layer_capacity_j_per_k[0], p.layer_capacity_j_per_k[1]);
        let mut capacity = [0.0f32; L];
        for (l, c) in capacity.iter_mut().enumerate() {
            *c = if L == 1 {
                c_in + c_out
            } else if l < n_in {
                c_in / n_in as f32
            } else {
                c_out / (L - n_in) as f32
            };
        }
        let mut outward = [0.0f32; L];
        for (l, g) in outward.iter_mut().enumerate() {
            let r = match centre.get(l + 1) {
                Some(&next) => depth(next) - depth(centre[l]),
                None => depth(WALL_MM) + surface - depth(centre[l]),
            };
            *g = conductance(r);
        }
        Wall {
            capacity_j_per_k: capacity,
            film_w_per_k: conductance(depth(centre.first().copied().unwrap_or(0.0))),
            outward_w_per_k: outward,
            centre_mm: centre,
        }
    }

    /// Whether layer `l` lies in the lattice's inner 4 mm (its centre does; the one layer of
    /// order 1 spans the wall and counts).
    pub fn in_inner_layer(&self, l: usize) -> bool {
        self.centre_mm.get(l).is_some_and(|&c| c < INNER_LAYER_MM)
    }

    /// The inner lattice layer's temperature from the layers' `layers_k`, K: the
    /// capacity-weighted mean of the layers lying in it ([`Wall::in_inner_layer`]); a single
    /// such layer is taken as it is.
    pub fn inner_layer_k(&self, layers_k: &[f32; L]) -> f32 {
        let (mut sum, mut weight, mut count, mut last) = (0.0f32, 0.0f32, 0usize, f32::NAN);
        for (l, (&t, &c)) in layers_k.iter().zip(&self.capacity_j_per_k).enumerate() {
            if self.in_inner_layer(l) {
                sum += c.max(0.0) * t;
                weight += c.max(0.0);
                count += 1;
                last = t;
            }
        }
        if count == 1 || weight <= 0.0 {
            last
        } else {
            sum / weight
        }
    }

    /// Film → ambient conductance through the wall (every link in series), W/K.
    pub fn through_w_per_k(&self) -> f32 {
        let mut resist = if self.film_w_per_k > 0.0 {
            1.0 / self.film_w_per_k
        } else {
            f32::INFINITY
        };
        for &g in &self.outward_w_per_k {
            resist += if g > 0.0 { 1.0 / g } else { f32::INFINITY };
        }
        if resist.is_finite() && resist > 0.0 {
            1.0 / resist
        } else {
            0.0
        }
    }

    /// The wall's frozen fraction at `layers_k` ([`ObserverParams::frozen_fraction`] with
    /// these layers' capacities).
    pub fn frozen_fraction(&self, p: &ObserverParams, layers_k: &[f32; L]) -> f32 {
        weighted_frozen(p, &self.capacity_j_per_k, layers_k, &[0.0; L]).0
    }
}

/// What the observer believes: the temperatures and their standard deviations, K.
pub type Estimate = EstimateN<LAYERS>;

/// What an observer of `L` wall layers ([`ObserverN`]) believes: the temperatures and their
/// standard deviations, K. The default order's is [`Estimate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimateN<const L: usize> {
    /// Heater film, K.
    pub film_k: f32,
    /// Wall layers, inner (next to the film) first, outer (T2's surface) last, K.
    pub layers_k: [f32; L],
    /// Ambient, K.
    pub ambient_k: f32,
    /// Standard deviation of the film's estimate, K.
    pub film_std_k: f32,
    /// Standard deviation of each layer's estimate, K.
    pub layers_std_k: [f32; L],
    /// Standard deviation of the ambient's estimate, K.
    pub ambient_std_k: f32,
    /// The wall's frozen (glassy) fraction, 0…1: the layers' fractions weighted by their
    /// capacities.
    pub frozen: f32,
    /// Standard deviation of the frozen fraction (the layers' deviations through the
    /// logistic's slope, at most 0.5).
    pub frozen_std: f32,
    /// Each spring's temperature, K (A, B, C).
    pub springs_k: [f32; SPRINGS],
    /// Standard deviation of each spring's temperature, K.
    pub springs_std_k: [f32; SPRINGS],
    /// Each spring's austenite fraction, 0…1.
    pub austenite: [f32; SPRINGS],
    /// Standard deviation of each spring's austenite fraction.
    pub austenite_std: [f32; SPRINGS],
    /// Each driven spring's temperature by its resistance, K (NaN: off, or no reference yet;
    /// [`SpringFusion::wire_k`]).
    pub springs_wire_k: [f32; SPRINGS],
    /// Each spring's measured power over the model's in its recent drives (1 before any
    /// drive; [`SpringFusion::share`]).
    pub springs_power_share: [f32; SPRINGS],
}

/// The best the heater can do for the wall ([`ObserverN::softest`]): the steady state with
/// the film at its ceiling (or at what full power holds, if lower) and the fan off.
pub type Softest = SoftestN<LAYERS>;

/// [`Softest`] for an observer of `L` wall layers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SoftestN<const L: usize> {
    /// The film's steady temperature, K.
    pub film_k: f32,
    /// The wall layers' steady temperatures, inner first, K.
    pub layers_k: [f32; L],
    /// The wall's steady frozen fraction, 0…1.
    pub frozen: f32,
}

/// The cached zero-order hold for one (fan duty, period, parameters).
#[derive(Clone, Copy, Debug)]
struct Zoh<const S: usize> {
    fan_duty: f32,
    dt_s: f32,
    phi: Mat<S>,
    gamma: Vec<S>,
}

/// The Kalman filter of the default order ([`LAYERS`] wall layers): the one the supervisor
/// owns.
pub type Observer = ObserverN<LAYERS, STATES, AUG>;

/// The Kalman filter with `L` wall layers: the state, its covariance, the parameters, the
/// wall's layers and the cached discretisation. Allocation-free (fixed-size `nalgebra`
/// matrices).
///
/// `S = L + 2` (the states) and `A = L + 3` (the zero-order hold's augmented matrix) are
/// given beside `L` because stable Rust cannot write `L + 2` in a type; any other pair fails
/// to compile. The default is [`Observer`] (`ObserverN<2, 4, 5>`); the other orders
/// (`ObserverN<1, 3, 4>`, `ObserverN<3, 5, 6>`, …) model the same wall in finer or coarser
/// layers ([`Wall::split`]) and exist to measure the order's cost against its error
/// (`docs/observer.md`).
#[derive(Clone, Debug)]
pub struct ObserverN<const L: usize, const S: usize, const A: usize> {
    params: ObserverParams,
    wall: Wall<L>,
    x: Vec<S>,
    p: Mat<S>,
    zoh: Option<Zoh<S>>,
    springs: Springs,
    /// No measurement has been fused yet: the first one sets the thermal states.
    fresh: bool,
    /// The first measurement places the springs at the ambient, martensite.
    springs_at_ambient: bool,
    /// What the spring channels measured of each spring ([`SpringFusion`]).
    fusion: [SpringFusion; SPRINGS],
}

impl<const L: usize, const S: usize, const A: usize> ObserverN<L, S, A> {
    /// State index of the outer wall layer (T2's).
    const OUTER: usize = L;
    /// State index of the ambient.
    const AMBIENT: usize = L + 1;

    /// A filter with every state at `initial_k` (a non-finite one is taken as 298.15 K) and
    /// the initial variance of `params`; its wall is `params`' in `L` layers
    /// ([`Wall::from_params`]).
    pub fn new(params: &ObserverParams, initial_k: f32) -> ObserverN<L, S, A> {
        const {
            assert!(
                L >= 1 && S == L + 2 && A == L + 3,
                "ObserverN<L, S, A>: S = L + 2 states, A = L + 3"
            )
        };
        let t0 = if initial_k.is_finite() {
            initial_k
        } else {
            298.15
        };
        let var = params.initial_variance_k2.max(0.0);
        ObserverN {
            params: *params,
            wall: Wall::from_params(params),
            x: Vec::<S>::repeat(t0),
            p: Mat::<S>::identity() * var,
            zoh: None,
            springs: [SpringState::at(&params.springs, t0, var); SPRINGS],
            fresh: true,
            springs_at_ambient: false,
            fusion: [SpringFusion::NEW; SPRINGS],
        }
    }

    /// The spring channels' readings of the period that just ended: each driven spring's
    /// measured power ([`SpringFusion`]).
    pub fn measure_springs(&mut self, readings: &[SpringReading; SPRINGS]) {
        for (f, r) in self.fusion.iter_mut().zip(readings) {
            f.fuse(r);
        }
    }

    /// Let the first measurement place the springs at the ambient it shows (T5), martensite:
    /// springs known to be at rest, at a temperature not yet known.
    pub fn rest_springs_at_ambient(&mut self) {
        self.springs_at_ambient = true;
    }

    /// Every spring at rest at `ambient_k`, martensite, as uncertain as T5.
    fn place_springs_at(&mut self, ambient_k: f32) {
        let v = self.params.t5_noise_k2;
        self.springs = [SpringState::at(&self.params.springs, ambient_k, v); SPRINGS];
        for s in self.springs.iter_mut() {
            s.austenite = 0.0;
        }
    }

    /// Return the springs' states (for the memory kept across a reset).
    pub fn springs(&self) -> &Springs {
        &self.springs
    }

    /// Set the springs' states (restored from the memory kept across a reset).
    pub fn set_springs(&mut self, springs: &Springs) {
        self.springs = *springs;
    }

    /// The parameters in use.
    pub fn params(&self) -> &ObserverParams {
        &self.params
    }

    /// The wall's layers in use (the parameters' in `L` layers).
    pub fn wall(&self) -> &Wall<L> {
        &self.wall
    }

    /// Replace the parameters (the wall's layers are rebuilt, the discretisation is
    /// recomputed at the next prediction); the state and covariance are kept.
    pub fn set_params(&mut self, params: &ObserverParams) {
        self.params = *params;
        self.wall = Wall::from_params(params);
        self.zoh = None;
    }

    /// Advance the estimate by `dt` with the heater and fan duties (0…1) held: the model's
    /// zero-order hold, the covariance `Φ·P·Φᵀ + Q·dt`. A NaN duty counts as 0; a
    /// non-finite or non-positive `dt` does nothing; `dt` above [`MAX_STEP_S`] is clamped.
    pub fn predict(&mut self, heater_duty: f32, fan_duty: f32, springs: SpringMask, dt: Seconds) {
        let dt_s = dt.s();
        if !dt_s.is_finite() || dt_s <= 0.0 {
            return;
        }
        let dt_s = dt_s.min(MAX_STEP_S);
        let heater = sanitize_duty(heater_duty);
        let fan = sanitize_duty(fan_duty);
        let zoh = match self.zoh {
            Some(z) if z.fan_duty == fan && z.dt_s == dt_s => z,
            _ => {
                let z = self.discretise(fan, dt_s);
                self.zoh = Some(z);
                z
            }
        };
        // Φ·1 = 1 (heat only moves between the nodes and the ambient), so the update is done
        // on the deviations from the ambient: no f32 rounding of Φ's row sums times ≈300 K
        // creeps into a state at rest.
        let ambient = self.x[Self::AMBIENT];
        let dev = self.x.add_scalar(-ambient);
        self.x = (zoh.phi * dev + zoh.gamma * heater).add_scalar(ambient);
        let mut q = Mat::<S>::zeros();
        q[(FILM, FILM)] = self.params.film_process_k2_per_s.max(0.0) * dt_s;
        for l in INNER..=Self::OUTER {
            q[(l, l)] = self.params.layer_process_k2_per_s.max(0.0) * dt_s;
        }
        q[(Self::AMBIENT, Self::AMBIENT)] = self.params.ambient_process_k2_per_s.max(0.0) * dt_s;
        self.p = zoh.phi * self.p * zoh.phi.transpose() + q;
        self.symmetrise();
        // The springs, from the start-of-step ambient and outer wall (their coupling to the
        // wall is ≈ 0.017 W/K against the wall's ≈ 2 W/K: one-way).
        let outer = ambient + dev[Self::OUTER];
        let p = &self.params.springs;
        if !springs.is_empty() {
            // A driven spring is no longer at the ambient.
            self.springs_at_ambient = false;
        }
        for (i, sp) in self.springs.iter_mut().enumerate() {
            let on = springs.contains(i);
            let f = &mut self.fusion[i];
            if on {
                f.track_share(sp.model_power_w(p));
            }
            let power = f.power_w(p, sp, on);
            sp.predict_powered(p, power, ambient, outer, dt_s);
            // A wire the resistance shows hotter than the estimate: raise the estimate.
            f.temperature(p, power, dt_s, sp.temp_k);
            let low = f.wire_k - springs::WIRE_MARGIN_K;
            if on && low > sp.temp_k {
                // Its enthalpy: a spring the model has still transforming completes first.
                sp.temp_k = low;
            }
        }
    }

    /// Fuse the camera's region temperatures: T1 → the film, T2 → the outer layer, T5 → the
    /// ambient. A missing (`None`) or non-finite one is skipped.
    ///
    /// The first measurement with T1 and T2 sets the thermal states instead (the film at T1,
    /// the layers from T1 to T2, the ambient at T5 or T2) with the measurements' variances:
    /// a block switched on warm is not taken for one at 298 K.
    pub fn correct(&mut self, t1: Option<Kelvin>, t2: Option<Kelvin>, t5: Option<Kelvin>) {
        self.correct_with(t1, t2, t5, 0.0);
    }

    /// [`Observer::correct`] with `extra_k2` added to the noise variances of T1 and T2 (a
    /// frame whose regions were not separated: both are the same mean, within its bound).
    pub fn correct_with(
        &mut self,
        t1: Option<Kelvin>,
        t2: Option<Kelvin>,
        t5: Option<Kelvin>,
        extra_k2: f32,
    ) {
        let extra = if extra_k2.is_finite() {
            extra_k2.max(0.0)
        } else {
            1e6
        };
        let finite = |t: Option<Kelvin>| t.map(Kelvin::k).filter(|z| z.is_finite());
        if self.fresh
            && let (Some(z1), Some(z2)) = (finite(t1), finite(t2))
        {
            self.fresh = false;
            let z5 = finite(t5).unwrap_or(z2);
            self.x[FILM] = z1;
            for l in 0..L {
                let w = (l + 1) as f32 / L as f32;
                self.x[INNER + l] = z1 + (z2 - z1) * w;
            }
            self.x[Self::AMBIENT] = z5;
            if self.springs_at_ambient {
                self.place_springs_at(z5);
                // A frame whose regions were not separated (a first frame holding a subpage
                // from before the power-up) may not show the ambient: the next that does
                // places them again.
                self.springs_at_ambient = extra > 0.0;
            }
            let r = (self.params.t1_noise_k2.max(self.params.t2_noise_k2) + extra).max(1e-3);
            let mut p = Mat::<S>::identity() * r;
            // The inner layers are interpolated: as uncertain as the gap they span.
            for l in 0..L - 1 {
                p[(INNER + l, INNER + l)] += (z1 - z2) * (z1 - z2) * 0.25 + 1.0;
            }
            p[(Self::AMBIENT, Self::AMBIENT)] = self.params.t5_noise_k2.max(1e-3);
            self.p = p;
            return;
        }
        if self.springs_at_ambient
            && extra == 0.0
            && let Some(z5) = finite(t5)
        {
            self.springs_at_ambient = false;
            self.place_springs_at(z5);
        }
        let r = [
            self.params.t1_noise_k2 + extra,
            self.params.t2_noise_k2 + extra,
            self.params.t5_noise_k2,
        ];
        for ((t, idx), r) in [(t1, FILM), (t2, Self::OUTER), (t5, Self::AMBIENT)]
            .into_iter()
            .zip(r)
        {
            if let Some(z) = finite(t) {
                self.fuse(idx, z, r);
            }
        }
    }

    /// The current estimate.
    pub fn estimate(&self) -> EstimateN<L> {
        let std = |i: usize| libm::sqrtf(self.p[(i, i)].max(0.0));
        let layers_k: [f32; L] = core::array::from_fn(|l| self.x[INNER + l]);
        let layers_std_k: [f32; L] = core::array::from_fn(|l| std(INNER + l));
        let sp = &self.params.springs;
        let (frozen, frozen_std) = weighted_frozen(
            &self.params,
            &self.wall.capacity_j_per_k,
            &layers_k,
            &layers_std_k,
        );
        EstimateN {
            film_k: self.x[FILM],
            layers_k,
            ambient_k: self.x[Self::AMBIENT],
            film_std_k: std(FILM),
            layers_std_k,
            ambient_std_k: std(Self::AMBIENT),
            frozen,
            frozen_std,
            springs_k: self.springs.map(|s| s.temp_k),
            springs_std_k: self.springs.map(|s| libm::sqrtf(s.var_k2.max(0.0))),
            austenite: self.springs.map(|s| s.austenite),
            austenite_std: self.springs.map(|s| s.austenite_std(sp)),
            springs_wire_k: self.fusion.map(|f| f.wire_k),
            springs_power_share: self.fusion.map(|f| f.share),
        }
    }

    /// The softest the wall can become from here ([`Softest`]): the steady state of the
    /// model with the film held at `film_ceiling_k` (where the heater cap holds it) — or at
    /// the most full power can hold it at, if lower — the fan off, at the estimated ambient.
    pub fn softest(&self, film_ceiling_k: f32) -> SoftestN<L> {
        let p = &self.params;
        let wall = &self.wall;
        let ambient = self.x[Self::AMBIENT];
        // The wall is a chain film → layers → outside: in the steady state one heat flow q
        // passes every link.
        let g_wall = wall.through_w_per_k();
        let g_all = g_wall + p.duct_conductance_w_per_k(0.0);
        let full = if g_all > 0.0 {
            ambient + p.heater_full_power_w.max(0.0) / g_all
        } else {
            f32::INFINITY
        };
        let film_k = if film_ceiling_k.is_finite() {
            film_ceiling_k.min(full)
        } else {
            full
        };
        let q = g_wall * (film_k - ambient);
        let mut layers_k = [0.0f32; L];
        let mut t = film_k;
        // Layer l is reached through the film's link (l = 0) or the outward link of l − 1.
        let mut g = wall.film_w_per_k;
        for (out, &next) in layers_k.iter_mut().zip(&wall.outward_w_per_k) {
            if g > 0.0 {
                t -= q / g;
            }
            *out = t;
            g = next;
        }
        SoftestN {
            film_k,
            layers_k,
            frozen: wall.frozen_fraction(p, &layers_k),
        }
    }

    /// One scalar measurement `z` of state `idx` with variance `r`, Joseph form.
    fn fuse(&mut self, idx: usize, z: f32, r: f32) {
        let r = if r.is_finite() && r > 0.0 { r } else { 1e-6 };
        let s = self.p[(idx, idx)] + r;
        if !(s.is_finite() && s > 0.0) {
            return;
        }
        let k: Vec<S> = self.p.column(idx) / s;
        let innovation = z - self.x[idx];
        let x = self.x + k * innovation;
        // (I − K·H)·P·(I − K·H)ᵀ + K·r·Kᵀ
        let mut ikh = Mat::<S>::identity();
        for i in 0..S {
            ikh[(i, idx)] -= k[i];
        }
        let p = ikh * self.p * ikh.transpose() + k * k.transpose() * r;
        if x.iter().all(|v| v.is_finite()) && p.iter().all(|v| v.is_finite()) {
            self.x = x;
            self.p = p;
            self.symmetrise();
        }
    }

    fn symmetrise(&mut self) {
        self.p = (self.p + self.p.transpose()) * 0.5;
    }

    /// The continuous system `dx/dt = A·x + b·duty` at a fan duty: `A` (1/s) and `b` (K/s at
    /// full heater duty).
    fn continuous(&self, fan_duty: f32) -> (Mat<S>, Vec<S>) {
        let (p, wall) = (&self.params, &self.wall);
        let mut a = Mat::<S>::zeros();
        let mut link = |i: usize, j: usize, g: f32| {
            a[(i, j)] += g;
            a[(j, i)] += g;
            a[(i, i)] -= g;
            a[(j, j)] -= g;
        };
        link(FILM, INNER, wall.film_w_per_k);
        // Layer l → layer l + 1, and the outer layer (l = L − 1) → the ambient (state L + 1).
        for (l, &g) in wall.outward_w_per_k.iter().enumerate() {
            link(INNER + l, INNER + l + 1, g);
        }
        link(FILM, Self::AMBIENT, p.duct_conductance_w_per_k(fan_duty));
        // The ambient is a random walk: no heat flows into it.
        for j in 0..S {
            a[(Self::AMBIENT, j)] = 0.0;
        }
        let mut caps = [0.0f32; S];
        caps[FILM] = p.film_capacity_j_per_k;
        caps[INNER..=Self::OUTER].copy_from_slice(&wall.capacity_j_per_k);
        for (i, &c) in caps.iter().enumerate().take(Self::AMBIENT) {
            let inv = if c > 0.0 { 1.0 / c } else { 0.0 };
            for j in 0..S {
                a[(i, j)] *= inv;
            }
        }
        let mut b = Vec::<S>::zeros();
        if caps[FILM] > 0.0 {
            b[FILM] = p.heater_full_power_w / caps[FILM];
        }
        (a, b)
    }

    /// Φ and Γ for a fan duty and period: the exponential of `[[A, b], [0, 0]]·dt`.
    fn discretise(&self, fan_duty: f32, dt_s: f32) -> Zoh<S> {
        let (a, b) = self.continuous(fan_duty);
        let mut m = SMatrix::<f32, A, A>::zeros();
        m.fixed_view_mut::<S, S>(0, 0).copy_from(&(a * dt_s));
        m.fixed_view_mut::<S, 1>(0, S).copy_from(&(b * dt_s));
        let e = expm(&m);
        Zoh {
            fan_duty,
            dt_s,
            phi: e.fixed_view::<S, S>(0, 0).into_owned(),
            gamma: e.fixed_view::<S, 1>(0, S).into_owned(),
        }
    }
}

/// A duty in 0…1; NaN counts as 0.
fn sanitize_duty(d: f32) -> f32 {
    if d.is_nan() { 0.0 } else { d.clamp(0.0, 1.0) }
}

/// Matrix exponential by scaling and squaring: scale by 2⁻ˢ until the ∞-norm is ≤ ½, sum
/// 10 Taylor terms (remainder ≤ ½¹¹/11! ≈ 10⁻¹¹), square s times. A non-finite matrix gives
/// the identity (no update rather than a panic or NaN).
fn expm<const A: usize>(m: &SMatrix<f32, A, A>) -> SMatrix<f32, A, A> {
    let norm = m
        .row_iter()
        .map(|r| r.iter().map(|v| v.abs()).sum::<f32>())
        .fold(0.0f32, f32::max);
    if !norm.is_finite() {
        return SMatrix::identity();
    }
    let mut s = 0u32;
    let mut scaled_norm = norm;
    while scaled_norm > 0.5 && s < 40 {
        scaled_norm *= 0.5;
        s += 1;
    }
    let scaled = m * libm::ldexpf(1.0, -(s as i32));
    let mut term = SMatrix::<f32, A, A>::identity();
    let mut sum = SMatrix::<f32, A, A>::identity();
    for k in 1..=10 {
        term = term * scaled / k as f32;
        sum += term;
    }
    for _ in 0..s {
        sum = sum * sum;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    fn secs(s: f32) -> Seconds {
        Seconds::new(s).unwrap()
    }

    fn k(t: f32) -> Option<Kelvin> {
        Kelvin::new(t)
    }

    /// A small xorshift and a sum of uniforms (Irwin–Hall, 12 terms) for Gaussian-ish noise.
    struct Noise(u64);
    impl Noise {
        fn uniform(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
        fn gauss(&mut self, std: f32) -> f32 {
            let s: f32 = (0..12).map(|_| self.uniform()).sum();
            (s - 6.0) * std
        }
    }

    #[test]
    fn defaults_match_the_plant() {
        let p = ObserverParams::DEFAULT;
        // 18 V over 5.5 Ω.
        assert!((p.heater_full_power_w - 58.91).abs() < 0.01);
        assert!((p.film_capacity_j_per_k - 6.158).abs() < 0.01);
        // 1500 J/(m²·K) over the 0.02200 m² inner face, 4 : 1.8 mm.
        assert!((p.layer_capacity_j_per_k[0] - 22.75).abs() < 0.02);
        assert!((p.layer_capacity_j_per_k[1] - 10.24).abs() < 0.02);
        assert!((p.film_layer_w_per_k - 3.299).abs() < 0.002);
        assert!((p.layer_layer_w_per_k[0] - 1.2865).abs() < 0.002);
        assert!((p.outer_ambient_w_per_k - 0.2765).abs() < 0.001);
        // Fan off: 0.088 in series with 0.048; full: 0.660 in series with 7.94.
        assert!((p.duct_conductance_w_per_k(0.0) - 0.0310).abs() < 0.001);
        assert!((p.duct_conductance_w_per_k(1.0) - 0.609).abs() < 0.002);
        assert_eq!(
            p.duct_conductance_w_per_k(f32::NAN),
            p.duct_conductance_w_per_k(0.0)
        );
    }

    /// The film alone (decoupled from the wall, a fixed duct conductance): the prediction is
    /// the analytic first-order step `T_a + P/G·(1 − e^{−t·G/C})`.
    #[test]
    fn single_node_matches_the_first_order_step() {
        let mut p = ObserverParams::DEFAULT;
        p.film_layer_w_per_k = 0.0;
        p.duct_exponent = 1.0;
        p.duct_flow_still_w_per_k = 1e6;
        p.duct_flow_fan_w_per_k = 0.0;
        let g = p.duct_conductance_w_per_k(0.0);
        let c = p.film_capacity_j_per_k;
        let power = p.heater_full_power_w * 0.5;
        let ambient = 298.15;
        let mut obs = Observer::new(&p, ambient);
        let mut worst = 0.0f32;
        for i in 1..=2400 {
            obs.predict(0.5, 0.0, SpringMask::NONE, secs(0.25));
            let t = i as f32 * 0.25;
            let want = ambient + power / g * (1.0 - libm::expf(-t * g / c));
            let e = obs.estimate();
            worst = worst.max((e.film_k - want).abs() / (want - ambient));
            // The wall stays at ambient (no path to it), the ambient does not move.
            assert!((e.layers_k[0] - ambient).abs() < 1e-3);
            assert_eq!(e.ambient_k, ambient);
        }
        println!("single node: worst relative error {worst:e}");
        assert!(worst < 2e-4, "relative error {worst}");
    }

    /// From a state 20 K wrong the filter converges to a truth run by its own model plus
    /// process and measurement noise: the inner layer (never measured) is within 1 K after
    /// 120 s, and stays so.
    #[test]
    fn converges_from_a_wrong_state() {
        let p = ObserverParams::DEFAULT;
        let mut truth = Observer::new(&p, 298.15);
        let mut obs = Observer::new(&p, 318.15);
        let mut noise = Noise(0x9e37_79b9_7f4a_7c15);
        let mut worst_late = 0.0f32;
        for i in 0..2400 {
            let t = i as f32 * 0.25;
            let heater = if (t as u32 / 60).is_multiple_of(2) {
                0.8
            } else {
                0.1
            };
            let fan = if (t as u32 / 90) % 2 == 1 { 1.0 } else { 0.0 };
            truth.predict(heater, fan, SpringMask::NONE, secs(0.25));
            for s in 0..STATES - 1 {
                truth.x[s] += noise.gauss(0.02);
            }
            obs.predict(heater, fan, SpringMask::NONE, secs(0.25));
            let m = truth.x;
            obs.correct(
                k(m[FILM] + noise.gauss(0.5)),
                k(m[OUTER] + noise.gauss(0.5)),
                k(m[AMBIENT] + noise.gauss(0.5)),
            );
            if t >= 120.0 {
                let e = obs.estimate();
                worst_late = worst_late.max((e.layers_k[0] - m[INNER]).abs());
            }
        }
        println!("converge: inner layer max |error| after 120 s {worst_late:.3} K");
        assert!(
            worst_late < 1.0,
            "inner layer error {worst_late} K after 120 s"
        );
    }

    #[test]
    fn a_missing_measurement_grows_the_covariance() {
        let p = ObserverParams::DEFAULT;
        let mut obs = Observer::new(&p, 298.15);
        for _ in 0..200 {
            obs.predict(0.3, 0.0, SpringMask::NONE, secs(0.25));
            obs.correct(k(300.0), k(299.0), k(298.0));
        }
        let settled = obs.estimate();
        for _ in 0..40 {
            obs.predict(0.3, 0.0, SpringMask::NONE, secs(0.25));
            obs.correct(None, k(299.0), None);
        }
        let later = obs.estimate();
        assert!(later.film_std_k > settled.film_std_k);
        assert!(later.ambient_std_k > settled.ambient_std_k);
        let trace = |o: &Observer| o.p.trace();
        let before = trace(&obs);
        obs.predict(0.3, 0.0, SpringMask::NONE, secs(0.25));
        obs.correct(None, None, None);
        assert!(trace(&obs) > before);
    }

    /// A first frame whose regions were not separated (at power-up, half of it a subpage
    /// from before: 288 K in a 273 K room) does not fix the springs' temperature: the first
    /// separated frame places them at its ambient. Once a spring is driven, none is moved.
    #[test]
    fn the_springs_rest_at_the_first_separated_ambient() {
        let p = ObserverParams::DEFAULT;
        let mut obs = Observer::new(&p, 298.15);
        obs.rest_springs_at_ambient();
        obs.predict(0.0, 0.0, SpringMask::NONE, secs(0.25));
        obs.correct_with(k(288.0), k(288.0), k(288.0), 25.0);
        assert!((obs.springs()[0].temp_k - 288.0).abs() < 0.01);
        obs.predict(0.0, 0.0, SpringMask::NONE, secs(0.25));
        obs.correct_with(k(275.0), k(273.2), k(273.2), 0.0);
        for s in obs.springs() {
            assert!(
                (s.temp_k - 273.2).abs() < 0.01 && s.austenite == 0.0,
                "{s:?}"
            );
        }
        // Placed once: a later frame leaves them to the model.
        obs.predict(0.0, 0.0, SpringMask::ALL, secs(0.25));
        let driven = obs.springs()[0].temp_k;
        obs.correct_with(k(275.0), k(273.2), k(280.0), 0.0);
        assert_eq!(obs.springs()[0].temp_k, driven);
        // A spring driven before any separated frame is not placed either.
        let mut obs = Observer::new(&p, 298.15);
        obs.rest_springs_at_ambient();
        obs.correct_with(k(288.0), k(288.0), k(288.0), 25.0);
        obs.predict(0.0, 0.0, SpringMask::from_bits(1), secs(0.25));
        let driven = obs.springs()[0].temp_k;
        obs.correct_with(k(275.0), k(273.2), k(273.2), 0.0);
        assert_eq!(obs.springs()[0].temp_k, driven);
    }

    #[test]
    fn non_finite_inputs_never_panic_nor_poison() {
        let p = ObserverParams::DEFAULT;
        let mut obs = Observer::new(&p, f32::NAN);
        let odd = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -3.0, 7.0, 0.5];
        for &h in &odd {
            for &f in &odd {
                for &dt in &odd {
                    if let Some(dt) = Seconds::new(dt) {
                        obs.predict(h, f, SpringMask::NONE, dt);
                    }
                    for &z in &odd {
                        obs.correct(Kelvin::new(z), Kelvin::new(z * 300.0), Kelvin::new(z));
                    }
                }
            }
        }
        let e = obs.estimate();
        let all = [e.film_k, e.ambient_k, e.film_std_k, e.ambient_std_k]
            .into_iter()
            .chain(e.layers_k)
            .chain(e.layers_std_k);
        for v in all {
            assert!(v.is_finite(), "{e:?}");
        }
        // Zero and negative noises, an infinite period: still finite.
        let mut bad = p;
        bad.t1_noise_k2 = 0.0;
        bad.t2_noise_k2 = -1.0;
        bad.film_capacity_j_per_k = 0.0;
        obs.set_params(&bad);
        obs.predict(
            1.0,
            1.0,
            SpringMask::NONE,
            Seconds::new(f32::INFINITY).unwrap(),
        );
        obs.predict(1.0, 1.0, SpringMask::NONE, secs(1e9));
        obs.correct(k(350.0), k(340.0), k(298.0));
        assert!(obs.estimate().film_k.is_finite());
    }

    /// The general split with two layers is the parameters' own wall, to rounding.
    #[test]
    fn two_layers_split_as_the_parameters() {
        let p = ObserverParams::DEFAULT;
        let (own, split) = (Wall::<2>::from_params(&p), Wall::<2>::split(&p));
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * a.abs().max(b.abs());
        for l in 0..2 {
            assert!(
                close(own.capacity_j_per_k[l], split.capacity_j_per_k[l]),
                "{l}"
            );
            assert!(
                close(own.outward_w_per_k[l], split.outward_w_per_k[l]),
                "{l}"
            );
            assert_eq!(own.centre_mm[l], split.centre_mm[l]);
        }
        assert!(close(own.film_w_per_k, split.film_w_per_k));
        assert_eq!(own.capacity_j_per_k, p.layer_capacity_j_per_k);
        assert_eq!(own.film_w_per_k, p.film_layer_w_per_k);
        assert_eq!(
            own.outward_w_per_k,
            [p.layer_layer_w_per_k[0], p.outer_ambient_w_per_k]
        );
        assert_eq!(own.centre_mm, [2.0, 4.9]);
    }

    /// Every order is the same wall: its capacity, the inner lattice layer's capacity and the
    /// film → ambient conductance through the wall are the default's; the layers lie in
    /// order, each in one lattice layer.
    fn same_wall<const L: usize>(inner_layers: usize) {
        let p = ObserverParams::DEFAULT;
        let two = Wall::<2>::from_params(&p);
        let w = Wall::<L>::from_params(&p);
        let close = |a: f32, b: f32| (a - b).abs() <= 2e-6 * a.abs().max(b.abs());
        let total: f32 = w.capacity_j_per_k.iter().sum();
        assert!(
            close(total, two.capacity_j_per_k.iter().sum()),
            "{L}: {total}"
        );
        assert!(close(w.through_w_per_k(), two.through_w_per_k()), "{L}");
        let inner: usize = (0..L).filter(|&l| w.in_inner_layer(l)).count();
        assert_eq!(inner, inner_layers, "{L}: {w:?}");
        if L > 1 {
            let c: f32 = (0..inner).map(|l| w.capacity_j_per_k[l]).sum();
            assert!(close(c, p.layer_capacity_j_per_k[0]), "{L}: {c}");
        }
        assert!(w.centre_mm.windows(2).all(|c| c[0] < c[1]), "{w:?}");
        assert!(w.film_w_per_k > 0.0 && w.outward_w_per_k.iter().all(|&g| g > 0.0));
        // A uniform wall's inner layer is its temperature; the weights are capacities.
        assert!((w.inner_layer_k(&[330.0; L]) - 330.0).abs() < 1e-4);
    }

    #[test]
    fn every_order_is_the_same_wall() {
        same_wall::<1>(1);
        same_wall::<2>(1);
        same_wall::<3>(2);
        same_wall::<4>(3);
        same_wall::<6>(4);
        let w = Wall::<3>::from_params(&ObserverParams::DEFAULT);
        assert_eq!(w.centre_mm, [1.0, 3.0, 4.9]);
        // 2 mm + 2 mm at 300 and 310 K, equal capacities: 305 K.
        assert!((w.inner_layer_k(&[300.0, 310.0, 400.0]) - 305.0).abs() < 1e-4);
    }

    /// Film after 2000 s of a held heater with no correction, the outer layer's distance
    /// from where the steady heat flow through the wall puts it, and the softest state's
    /// film and frozen fraction, for one order.
    fn held<const L: usize, const S: usize, const A: usize>() -> [f32; 4] {
        let p = ObserverParams::DEFAULT;
        let mut obs = ObserverN::<L, S, A>::new(&p, 298.15);
        for _ in 0..8000 {
            obs.predict(0.3, 0.0, SpringMask::NONE, secs(0.25));
        }
        let e = obs.estimate();
        let w = obs.wall();
        let q = w.through_w_per_k() * (e.film_k - e.ambient_k);
        let outer = e.ambient_k + q / w.outward_w_per_k[L - 1];
        let s = obs.softest(358.0);
        [e.film_k, e.layers_k[L - 1] - outer, s.film_k, s.frozen]
    }

    /// The orders share the steady state through the wall: the film's temperature at a held
    /// duty and the softest film agree, and the outer layer sits where the heat flow through
    /// the wall puts its node (the single layer of order 1 sits mid-wall, warmer than the
    /// default's outer layer).
    #[test]
    fn every_order_has_the_same_steady_film() {
        let two = held::<2, 4, 5>();
        assert!(two[1].abs() < 0.02, "{two:?}");
        for other in [held::<1, 3, 4>(), held::<3, 5, 6>(), held::<6, 8, 9>()] {
            assert!((other[0] - two[0]).abs() < 0.05, "{other:?} {two:?}");
            assert!(other[1].abs() < 0.02, "{other:?}");
            assert!((other[2] - two[2]).abs() < 1e-3, "{other:?} {two:?}");
            assert!((0.0..=1.0).contains(&other[3]));
        }
    }

    /// A filter of any order converges on a truth run by its own model, as the default does.
    fn converges<const L: usize, const S: usize, const A: usize>() -> f32 {
        let p = ObserverParams::DEFAULT;
        let mut truth = ObserverN::<L, S, A>::new(&p, 298.15);
        let mut obs = ObserverN::<L, S, A>::new(&p, 318.15);
        let mut noise = Noise(0x9e37_79b9_7f4a_7c15);
        let mut worst_late = 0.0f32;
        for i in 0..2400 {
            let t = i as f32 * 0.25;
            let heater = if (t as u32 / 60).is_multiple_of(2) {
                0.8
            } else {
                0.1
            };
            truth.predict(heater, 0.0, SpringMask::NONE, secs(0.25));
            obs.predict(heater, 0.0, SpringMask::NONE, secs(0.25));
            let m = truth.x;
            obs.correct(
                k(m[FILM] + noise.gauss(0.5)),
                k(m[L] + noise.gauss(0.5)),
                k(m[L + 1] + noise.gauss(0.5)),
            );
            if t >= 120.0 {
                let (e, w) = (obs.estimate(), obs.wall());
                let truth_layers: [f32; L] = core::array::from_fn(|l| m[INNER + l]);
                let err = w.inner_layer_k(&e.layers_k) - w.inner_layer_k(&truth_layers);
                worst_late = worst_late.max(err.abs());
            }
        }
        worst_late
    }

    #[test]
    fn every_order_converges_on_its_own_model() {
        for (l, worst) in [
            (1, converges::<1, 3, 4>()),
            (3, converges::<3, 5, 6>()),
            (4, converges::<4, 6, 7>()),
            (6, converges::<6, 8, 9>()),
        ] {
            assert!(
                worst < 1.0,
                "{l} layers: inner layer error {worst} K after 120 s"
            );
        }
    }

    /// Non-finite inputs and parameters leave an observer of any order finite.
    fn stays_finite<const L: usize, const S: usize, const A: usize>() {
        let p = ObserverParams::DEFAULT;
        let mut obs = ObserverN::<L, S, A>::new(&p, f32::NAN);
        let odd = [f32::NAN, f32::INFINITY, -3.0, 0.5];
        for &h in &odd {
            for &dt in &odd {
                if let Some(dt) = Seconds::new(dt) {
                    obs.predict(h, h, SpringMask::NONE, dt);
                }
                obs.correct(Kelvin::new(h), Kelvin::new(h * 300.0), Kelvin::new(h));
            }
        }
        // No path from the film, an infinite one through the wall, a negative one outside, a
        // zero film capacity: the split's resistances are 0 and ∞ (the model is then not
        // updated rather than poisoned).
        let mut bad = p;
        bad.film_layer_w_per_k = 0.0;
        bad.layer_layer_w_per_k = [f32::INFINITY];
        bad.outer_ambient_w_per_k = -1.0;
        bad.film_capacity_j_per_k = 0.0;
        obs.set_params(&bad);
        obs.predict(1.0, 1.0, SpringMask::NONE, secs(1e9));
        obs.correct(k(350.0), k(340.0), k(298.0));
        let (e, s) = (obs.estimate(), obs.softest(358.0));
        assert!(e.film_k.is_finite() && e.layers_k.iter().all(|t| t.is_finite()));
        assert!(!s.frozen.is_nan());
    }

    #[test]
    fn no_order_panics_nor_poisons() {
        stays_finite::<1, 3, 4>();
        stays_finite::<3, 5, 6>();
        stays_finite::<6, 8, 9>();
    }

    /// The model alone of `L` layers after 60 s at full heater from 298.15 K: the inner
    /// lattice layer, K.
    fn inner_after_full_heat<const L: usize, const S: usize, const A: usize>() -> f32 {
        let mut obs = ObserverN::<L, S, A>::new(&ObserverParams::DEFAULT, 298.15);
        for _ in 0..240 {
            obs.predict(1.0, 0.0, SpringMask::NONE, secs(0.25));
        }
        obs.wall().inner_layer_k(&obs.estimate().layers_k)
    }

    /// The split is a discretisation that converges: refined, the inner lattice layer's
    /// temperature after a full-power heat nears the 24-layer model's (the two-layer model
    /// lags it by the gradient inside the inner 4 mm it cannot resolve).
    #[test]
    fn finer_orders_converge() {
        let fine = inner_after_full_heat::<24, 26, 27>();
        let gaps = [
            inner_after_full_heat::<2, 4, 5>() - fine,
            inner_after_full_heat::<3, 5, 6>() - fine,
            inner_after_full_heat::<6, 8, 9>() - fine,
            inner_after_full_heat::<12, 14, 15>() - fine,
        ];
        assert!(gaps.windows(2).all(|g| g[1].abs() < g[0].abs()), "{gaps:?}");
        assert!(gaps[3].abs() < 0.05 && gaps[0] < -0.5, "{gaps:?}");
    }
}
