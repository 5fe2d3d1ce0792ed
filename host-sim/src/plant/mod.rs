//! The simulated block (the plant): a lumped thermal network of the heater film, the SMP wall,
//! the inner air duct and the three SMA springs, the SMA phase kinetics, the SMP's frozen
//! fraction and viscoelastic lag, and the bending of the column.
//!
//! Submodules: [`params`] (every constant, unit and source), [`thermal`] (network and
//! integrators), [`sma`] (spring kinetics, enthalpy, supply, force law), [`smp`] (frozen
//! fraction, modulus, WLF, Maxwell branch), [`mechanics`] (bending balance), [`linalg`] (small
//! dense solves and the matrix exponential), [`wp`] (the work-precision table).
//!
//! Each [`Plant::step`] call sub-steps at most [`PlantConfig::max_step_s`]; per sub-step, with
//! the inputs held (duty-averaged power): the cylinder network and the spring nodes advance with
//! the chosen [`Integrator`] (the springs exchange a little heat with the column's outer
//! surface, taken from that node), the springs settle their phase on their enthalpy with their
//! transformation temperatures shifted by their last force, the SMP's frozen fraction moves
//! (storing or releasing bend), and the column's moment balance is solved with the Maxwell
//! branch updated exactly and the PI film yielding past its yield bend. See `docs/PLANT-API.md`.
//!
//! This module owns the plant's error type, [`PlantError`] (a configuration the model refuses).

pub mod circuit;
pub mod linalg;
pub mod mechanics;
pub mod params;
pub mod sma;
pub mod smp;
pub mod thermal;
pub mod wp;

use mechanics::Balance;
use smp::SmpState;
use thermal::{Network, ZohCache};

/// How much of the physics a scene computes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fidelity {
    /// Thermal network resolution.
    pub thermal: ThermalFidelity,
    /// SMA phase model.
    pub sma: SmaFidelity,
    /// SMP model.
    pub smp: SmpFidelity,
    /// Compute the bending (angle, plane, k_b); off: they stay at their initial values.
    pub mechanics: bool,
}

/// Thermal network resolution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ThermalFidelity {
    /// One lumped node for the cylinder (heater film = SMP = air), springs separate.
    Lumped,
    /// The full network.
    Full,
}

/// SMA phase model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SmaFidelity {
    /// Austenite above a single switching temperature, martensite below; no latent heat.
    Switch,
    /// Hysteretic phase kinetics with partial cycles and latent heat.
    Hysteretic,
}

/// SMP model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SmpFidelity {
    /// Temperature-dependent modulus only; no shape fixing.
    Elastic,
    /// Frozen fraction, shape fixing and recovery, WLF-shifted viscous lag.
    Viscoelastic,
}

impl Default for Fidelity {
    /// Full fidelity.
    fn default() -> Self {
        Fidelity {
            thermal: ThermalFidelity::Full,
            sma: SmaFidelity::Hysteretic,
            smp: SmpFidelity::Viscoelastic,
            mechanics: true,
        }
    }
}

/// Time integrator of the thermal network.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Integrator {
    /// Backward Euler.
    BackwardEuler,
    /// TR-BDF2.
    TrBdf2,
    /// Exact zero-order-hold update of the linear network (the default).
    #[default]
    ExponentialZoh,
}

/// Everything a plant is built from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantConfig {
    /// Ambient (and background) temperature, K.
    pub ambient_k: f64,
    /// Initial temperature of every node, K.
    pub initial_k: f64,
    /// Fidelity levels.
    pub fidelity: Fidelity,
    /// Integrator.
    pub integrator: Integrator,
    /// Largest internal step, s (`Plant::step` sub-steps longer calls).
    pub max_step_s: f64,
}

impl Default for PlantConfig {
    /// 298.15 K ambient and start, full fidelity, the default integrator and step.
    fn default() -> Self {
        PlantConfig {
            ambient_k: 298.15,
            initial_k: 298.15,
            fidelity: Fidelity::default(),
            integrator: Integrator::default(),
            max_step_s: params::DEFAULT_MAX_STEP_S,
        }
    }
}

/// Actuator inputs held constant over one `Plant::step` call.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Inputs {
    /// Heater PWM duty, 0…1 (clamped).
    pub heater_duty: f64,
    /// Fan PWM duty, 0…1 (clamped).
    pub fan_duty: f64,
    /// Spring MOSFETs A, B, C on (their gates as driven, or a MOSFET stuck on or off).
    pub springs_on: [bool; 3],
    /// Fault: the heater is open-circuit (no power whatever the duty).
    pub heater_open: bool,
    /// The spring power enable is off: no spring channel conducts, whatever its MOSFET.
    pub spring_power_off: bool,
    /// Faults of each spring channel's circuit (an open or bypassed wire, a MOSFET failed).
    pub channel_faults: [circuit::ChannelFaults; 3],
}

/// What the plant shows at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observation {
    /// Simulated time since start, s.
    pub time_s: f64,
    /// Heater film surface (what region 1 shows), K.
    pub heater_k: f64,
    /// SMP inner layer, K.
    pub smp_inner_k: f64,
    /// SMP outer surface (region 2), K.
    pub smp_outer_k: f64,
    /// Air in the inner duct, K.
    pub duct_air_k: f64,
    /// Ambient, K.
    pub ambient_k: f64,
    /// Spring wire temperatures A, B, C, K.
    pub springs_k: [f64; 3],
    /// Spring austenite fractions A, B, C, 0…1.
    pub austenite: [f64; 3],
    /// SMP frozen fraction, 0…1 (1 glassy).
    pub frozen_fraction: f64,
    /// Bending angle, degrees (≥ 0).
    pub bend_deg: f64,
    /// Bending plane, degrees from spring A, (−180, 180].
    pub bend_plane_deg: f64,
    /// Bending stiffness k_b = M/θ for a small probe moment, N·mm/rad.
    pub k_b_nmm_per_rad: f64,
    /// Heater electrical power, W.
    pub heater_power_w: f64,
    /// Joule heat in each spring's wire (I²·R_wire; the leads' loss excluded), W.
    pub spring_power_w: [f64; 3],
    /// Current through each spring, A.
    pub spring_current_a: [f64; 3],
    /// Each spring supply's voltage at its sense point (ahead of the enable switch), V.
    pub spring_supply_v: [f64; 3],
    /// Tension of each spring, N.
    pub spring_force_n: [f64; 3],
    /// The coldest SMP layer (the lower of inner and outer), K: stepping stores only bend added
    /// while this is soft, so a controller should start stepping once it is ≥ 358 K.
    pub smp_coldest_k: f64,
    /// Bend stored by the SMP's frozen fraction (the shape it is locked in), degrees.
    pub stored_bend_deg: f64,
    /// The PI film's plastic set (the bend it has yielded to), degrees.
    pub film_set_deg: f64,
}

/// Dimensionless factors on four of the block's quantities, for a plant that differs from the
/// one the firmware's observer and controller were tuned on (a block built or supplied a little
/// differently). Each multiplies the constant of `params` it names; 1.0 (the default) is the
/// fitted block, and [`Plant::with_options`] accepts 0.5–2.0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantScale {
    /// Multiplies the heater's electrical power at every duty (`HEATER_SUPPLY_V`² /
    /// `HEATER_RESISTANCE_OHM`, as if the film's supply voltage were √factor times: the 10 A
    /// supply limit is far above the film's 2.3 A, so the power scales exactly).
    pub heater_power: f64,
    /// Multiplies the SMP wall's heat capacity (`WALL_AREAL_CAPACITY_J_PER_M2K`), both layers
    /// (and the wall's share of the Lumped node); the heater film and the duct air keep theirs.
    pub wall_capacity: f64,
    /// Multiplies each spring's loss conductance to the still ambient air
    /// (`H_SPRING_W_PER_M2K` × `SPRING_AREA_M2`); the column→spring path
    /// (`G_COLUMN_SPRING_W_PER_K`) keeps its value.
    pub spring_cooling: f64,
    /// Multiplies the spring channels' supply voltage (`SPRING_SUPPLY_V`); the 15 A current
    /// limit (`SPRING_SUPPLY_LIMIT_A`) stays, so above ≈1.0 a martensite spring's current stays
    /// at the limit and only an austenite spring's (≈14.9 A unscaled) can rise, to 15 A.
    pub spring_supply: f64,
}

/// The range [`Plant::with_options`] accepts for each factor of [`PlantScale`].
pub const PLANT_SCALE_RANGE: (f64, f64) = (0.5, 2.0);

impl Default for PlantScale {
    /// Every factor 1.0: the fitted block.
    fn default() -> Self {
        PlantScale::UNIT
    }
}

impl PlantScale {
    /// Every factor 1.0: the fitted block.
    pub const UNIT: PlantScale = PlantScale {
        heater_power: 1.0,
        wall_capacity: 1.0,
        spring_cooling: 1.0,
        spring_supply: 1.0,
    };

    /// The factors' names, in declaration order.
    pub const NAMES: [&'static str; 4] = [
        "heater_power",
        "wall_capacity",
        "spring_cooling",
        "spring_supply",
    ];

    /// The factors by name, in declaration order ([`PlantScale::NAMES`]).
    pub fn named(&self) -> [(&'static str, f64); 4] {
        let f = [
            self.heater_power,
            self.wall_capacity,
            self.spring_cooling,
            self.spring_supply,
        ];
        core::array::from_fn(|i| (Self::NAMES[i], f[i]))
    }

    /// The factor called `name` (one of [`PlantScale::NAMES`]), to set it; `None` for any
    /// other name.
    pub fn get_mut(&mut self, name: &str) -> Option<&mut f64> {
        match name {
            "heater_power" => Some(&mut self.heater_power),
            "wall_capacity" => Some(&mut self.wall_capacity),
            "spring_cooling" => Some(&mut self.spring_cooling),
            "spring_supply" => Some(&mut self.spring_supply),
            _ => None,
        }
    }
}

/// Model options beyond the contract's [`PlantConfig`] (defaults: no plates, not adiabatic, one
/// supply channel per spring, the fitted block's scale).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ModelOptions {
    /// Add the two PMMA end plates as a thermal node (Full thermal fidelity only).
    pub pmma_plates: bool,
    /// Cut every path to ambient (cylinder and springs): for energy-conservation checks.
    pub adiabatic: bool,
    /// One 5 V / 15 A supply shared by the three springs instead of one channel each (the cost:
    /// two springs get 7.5 A each and heat ≈4× slower; see `docs/PLANT-API.md`).
    pub shared_spring_supply: bool,
    /// Factors on the heater power, wall capacity, spring cooling and spring supply (default:
    /// all 1.0).
    pub scale: PlantScale,
    /// The wires' resistance does not drift with their temperature within a phase (default:
    /// it does, by [`params::WIRE_TEMPCO_PER_K`]).
    pub constant_wire_resistance: bool,
}

/// One spring's thermal and phase state.
#[derive(Clone, Copy, Debug, PartialEq)]
struct SpringState {
    t_k: f64,
    /// Martensite fractions of the two bands.
    phase: sma::Phase,
    /// Tension at the last balance, N (sets the stress shift).
    force_n: f64,
}

/// The plant.
pub struct Plant {
    config: PlantConfig,
    options: ModelOptions,
    time_s: f64,
    /// Cylinder node temperatures (see `thermal` for the indices), K.
    nodes_k: linalg::Vector,
    n_nodes: usize,
    springs: [SpringState; 3],
    smp: SmpState,
    bend_rad: [f64; 2],
    film_set_rad: [f64; 2],
    k_b_nmm_per_rad: f64,
    heater_power_w: f64,
    flows: [circuit::Flow; 3],
    electrical_energy_j: f64,
    lead_energy_j: f64,
    /// Network matrices for the last fan duty (key, A, network).
    net_cache: Option<(u64, linalg::Mat, Network)>,
    zoh_cache: Option<ZohCache>,
}

/// A plant configuration the model refuses; `Display` names the field.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum PlantError {
    /// A temperature is not finite or outside the model's range.
    #[error(
        "{field}: {value_k} K is outside {}–{} K",
        params::MIN_CONFIG_K,
        params::MAX_CONFIG_K
    )]
    Temperature {
        /// The field (`ambient_k`, `initial_k`).
        field: &'static str,
        /// Its value, K.
        value_k: f64,
    },
    /// The largest internal step is not positive and finite.
    #[error("max_step_s: {0} s must be positive and finite")]
    MaxStep(f64),
    /// A factor of [`PlantScale`] is not finite or outside [`PLANT_SCALE_RANGE`].
    #[error(
        "scale.{field}: {value} is outside {}–{} (a dimensionless factor on the fitted block)",
        PLANT_SCALE_RANGE.0,
        PLANT_SCALE_RANGE.1
    )]
    Scale {
        /// The factor (`heater_power`, `wall_capacity`, `spring_cooling`, `spring_supply`).
        field: &'static str,
        /// Its value.
        value: f64,
    },
}

fn check_k(field: &'static str, value_k: f64) -> Result<(), PlantError> {
    if !value_k.is_finite() || !(params::MIN_CONFIG_K..=params::MAX_CONFIG_K).contains(&value_k) {
        return Err(PlantError::Temperature { field, value_k });
    }
    Ok(())
}

fn duty(v: f64) -> f64 {
    if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) }
}

impl Plant {
    /// Build a plant in its initial state; a bad config (non-finite or out-of-range
    /// temperature, non-positive step) is an error naming the field.
    pub fn new(config: &PlantConfig) -> Result<Plant, PlantError> {
        Plant::with_options(config, ModelOptions::default())
    }

    /// [`Plant::new`] with model options.
    pub fn with_options(config: &PlantConfig, options: ModelOptions) -> Result<Plant, PlantError> {
        check_k("ambient_k", config.ambient_k)?;
        check_k("initial_k", config.initial_k)?;
        if !config.max_step_s.is_finite() || config.max_step_s <= 0.0 {
            return Err(PlantError::MaxStep(config.max_step_s));
        }
        for (field, value) in options.scale.named() {
            if !value.is_finite() || !(PLANT_SCALE_RANGE.0..=PLANT_SCALE_RANGE.1).contains(&value) {
                return Err(PlantError::Scale { field, value });
            }
        }
        let plates = options.pmma_plates && config.fidelity.thermal == ThermalFidelity::Full;
        let net = Network::scaled(
            config.fidelity.thermal,
            0.0,
            plates,
            options.adiabatic,
            options.scale.wall_capacity,
        );
        let t0 = config.initial_k;
        let phase0 = sma::kinetics(
            config.fidelity.sma,
            t0,
            sma::Phase::uniform(1.0),
            sma::Shift::default(),
        );
        let phi0 = match config.fidelity.smp {
            SmpFidelity::Viscoelastic | SmpFidelity::Elastic => smp::frozen_fraction(t0),
        };
        let mut plant = Plant {
            config: *config,
            options: ModelOptions {
                pmma_plates: plates,
                ..options
            },
            time_s: 0.0,
            nodes_k: [t0; linalg::N],
            n_nodes: net.n,
            springs: [SpringState {
                t_k: t0,
                phase: phase0,
                force_n: 0.0,
            }; 3],
            smp: SmpState::relaxed(phi0, [0.0; 2]),
            bend_rad: [0.0; 2],
            film_set_rad: [0.0; 2],
            k_b_nmm_per_rad: 0.0,
            heater_power_w: 0.0,
            flows: [circuit::Flow::default(); 3],
            electrical_energy_j: 0.0,
            lead_energy_j: 0.0,
            net_cache: None,
            zoh_cache: None,
        };
        plant.k_b_nmm_per_rad = plant.column_k_b();
        if config.fidelity.mechanics {
            plant.solve_bend(0.0);
        }
        Ok(plant)
    }

    /// Advance by `dt_s` (> 0) with `inputs` held, in internal steps of at most `max_step_s`.
    /// A non-positive or non-finite `dt_s` does nothing.
    pub fn step(&mut self, inputs: &Inputs, dt_s: f64) {
        if !dt_s.is_finite() || dt_s <= 0.0 {
            return;
        }
        let n = (dt_s / self.config.max_step_s).ceil().max(1.0);
        let h = dt_s / n;
        for _ in 0..n as u64 {
            self.substep(inputs, h);
        }
    }

    /// The current observation.
    pub fn observe(&self) -> Observation {
        let (heater, inner, outer, air) = self.region_temps();
        Observation {
            time_s: self.time_s,
            heater_k: heater,
            smp_inner_k: inner,
            smp_outer_k: outer,
            duct_air_k: air,
            ambient_k: self.config.ambient_k,
            springs_k: self.springs.map(|s| s.t_k),
            austenite: self.springs.map(|s| 1.0 - s.phase.xi()),
            frozen_fraction: self.smp.phi,
            bend_deg: self.bend_deg(),
            bend_plane_deg: self.bend_plane_deg(),
            k_b_nmm_per_rad: self.k_b_nmm_per_rad,
            heater_power_w: self.heater_power_w,
            spring_power_w: self.flows.map(|f| f.wire_w),
            spring_current_a: self.flows.map(|f| f.current_a),
            spring_supply_v: self.flows.map(|f| f.supply_v),
            spring_force_n: self.springs.map(|s| s.force_n),
            smp_coldest_k: inner.min(outer),
            stored_bend_deg: self.stored_bend_deg(),
            film_set_deg: self.film_set_rad[0]
                .hypot(self.film_set_rad[1])
                .to_degrees(),
        }
    }

    /// Simulated time, s.
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// The configuration the plant was built from.
    pub fn config(&self) -> &PlantConfig {
        &self.config
    }

    /// The model options in force.
    pub fn options(&self) -> ModelOptions {
        self.options
    }

    /// Heat stored in the cylinder network and the springs (sensible from 0 K plus the
    /// springs' latent heat of austenite), J.
    pub fn stored_energy_j(&self) -> f64 {
        let net = self.network(0.0);
        net.energy_j(&self.nodes_k)
            + self
                .springs
                .iter()
                .map(|s| sma::enthalpy_j(self.config.fidelity.sma, s.t_k, s.phase.xi()))
                .sum::<f64>()
    }

    /// Electrical energy turned into heat in the heater and the spring wires since the start,
    /// J (the spring leads' loss is [`Plant::lead_energy_j`]).
    pub fn electrical_energy_j(&self) -> f64 {
        self.electrical_energy_j
    }

    /// Energy lost in the spring leads and MOSFETs since the start (not heat in the plant), J.
    pub fn lead_energy_j(&self) -> f64 {
        self.lead_energy_j
    }

    /// Heat flowing to the ambient now, W, with the fan at `fan_duty` (0…1): the cylinder's
    /// outside surface, the duct air's outflow and the plates, plus the springs' still air.
    /// Integrated over a run it closes the energy balance with [`Plant::stored_energy_j`] and
    /// [`Plant::electrical_energy_j`] (zero for an adiabatic plant).
    pub fn ambient_loss_w(&self, fan_duty: f64) -> f64 {
        let amb = self.config.ambient_k;
        let net = self.network(duty(fan_duty));
        let cylinder: f64 = (0..net.n)
            .map(|i| net.g_amb_w_per_k[i] * (self.nodes_k[i] - amb))
            .sum();
        let g_spring = self.spring_ambient_w_per_k();
        cylinder
            + self
                .springs
                .iter()
                .map(|s| g_spring * (s.t_k - amb))
                .sum::<f64>()
    }

    /// PMMA plate temperature, K, if the plates are modelled.
    pub fn plates_k(&self) -> Option<f64> {
        self.options
            .pmma_plates
            .then_some(self.nodes_k[thermal::PLATES])
    }

    /// Lengths of springs A, B, C (chords between the plates' anchor points), mm.
    pub fn spring_lengths_mm(&self) -> [f64; 3] {
        [0, 1, 2].map(|i| mechanics::spring_length_mm(i, self.bend_rad))
    }

    /// Stored (frozen) bending angle of the SMP, degrees.
    pub fn stored_bend_deg(&self) -> f64 {
        let s = self.smp.stored_rad;
        (s[0] * s[0] + s[1] * s[1]).sqrt().to_degrees()
    }

    /// The cylinder's network at `fan_duty` (0…1) with this plant's options and scale.
    fn network(&self, fan_duty: f64) -> Network {
        Network::scaled(
            self.config.fidelity.thermal,
            fan_duty,
            self.options.pmma_plates,
            self.options.adiabatic,
            self.options.scale.wall_capacity,
        )
    }

    /// One spring's loss conductance to the ambient with this plant's options and scale, W/K.
    fn spring_ambient_w_per_k(&self) -> f64 {
        if self.options.adiabatic {
            0.0
        } else {
            sma::ambient_w_per_k() * self.options.scale.spring_cooling
        }
    }

    fn region_temps(&self) -> (f64, f64, f64, f64) {
        let x = &self.nodes_k;
        match self.config.fidelity.thermal {
            ThermalFidelity::Lumped => (x[0], x[0], x[0], x[0]),
            ThermalFidelity::Full => (
                x[thermal::HEATER],
                x[thermal::INNER],
                x[thermal::OUTER],
                x[thermal::AIR],
            ),
        }
    }

    fn bend_deg(&self) -> f64 {
        let b = self.bend_rad;
        (b[0] * b[0] + b[1] * b[1]).sqrt().to_degrees()
    }

    fn bend_plane_deg(&self) -> f64 {
        let b = self.bend_rad;
        if b[0].hypot(b[1]) < 1e-12 {
            return 0.0;
        }
        let d = b[1].atan2(b[0]).to_degrees();
        if d <= -180.0 { d + 360.0 } else { d }
    }

    /// Frozen fraction of the wall: the layers' fractions weighted by thickness.
    fn wall_phi(&self) -> f64 {
        let (_, inner, outer, _) = self.region_temps();
        params::INNER_LAYER_SHARE * smp::frozen_fraction(inner)
            + (1.0 - params::INNER_LAYER_SHARE) * smp::frozen_fraction(outer)
    }

    /// Relaxed SMP bending stiffness: the layers' stiffnesses weighted by thickness.
    fn smp_stiffness(&self) -> f64 {
        let (_, inner, outer, _) = self.region_temps();
        params::INNER_LAYER_SHARE * smp::bending_nmm_per_rad(smp::frozen_fraction(inner))
            + (1.0 - params::INNER_LAYER_SHARE)
                * smp::bending_nmm_per_rad(smp::frozen_fraction(outer))
    }

    /// k_b = M/θ of the column (PI film + relaxed SMP) for a small probe moment, N·mm/rad.
    fn column_k_b(&self) -> f64 {
        params::FILM_BENDING_NMM_PER_RAD + self.smp_stiffness()
    }

    /// The spring channels' flows for `inputs` at the present state, without stepping: what
    /// the board's ADC reads at once when its outputs change (a probe of the channels).
    pub fn channel_flows(&self, inputs: &Inputs) -> [circuit::Flow; 3] {
        let tempco = if self.options.constant_wire_resistance {
            0.0
        } else {
            params::WIRE_TEMPCO_PER_K
        };
        let wire_ohm = self
            .springs
            .map(|s| circuit::wire_ohm(s.phase.xi(), s.t_k, tempco));
        circuit::channels(
            inputs.springs_on,
            !inputs.spring_power_off,
            wire_ohm,
            params::SPRING_SUPPLY_V * self.options.scale.spring_supply,
            self.options.shared_spring_supply,
            inputs.channel_faults,
        )
    }

    fn substep(&mut self, inputs: &Inputs, h: f64) {
        let fid = self.config.fidelity;
        let integrator = self.config.integrator;
        let amb = self.config.ambient_k;
        // Electrical inputs, held over the step (duty-averaged).
        let heater_duty = duty(inputs.heater_duty);
        let fan = duty(inputs.fan_duty);
        let heater_w = if inputs.heater_open {
            0.0
        } else {
            let full = (params::HEATER_SUPPLY_V / params::HEATER_RESISTANCE_OHM)
                .min(params::HEATER_SUPPLY_LIMIT_A);
            heater_duty
                * full
                * full
                * params::HEATER_RESISTANCE_OHM
                * self.options.scale.heater_power
        };
        let flows = self.channel_flows(inputs);
        let spring_w = flows.map(|f| f.wire_w);
        self.heater_power_w = heater_w;
        self.flows = flows;
        self.electrical_energy_j += h * (heater_w + spring_w.iter().sum::<f64>());
        self.lead_energy_j += h * flows.iter().map(|f| f.lead_w).sum::<f64>();
        // Heat from the column's outer surface to each spring, held over the step and taken
        // from that node, so the exchange conserves energy exactly.
        // (Full thermal fidelity only: the Lumped level keeps its one-node analytic response.)
        let surface = thermal::OUTER;
        let exchange_w = match fid.thermal {
            ThermalFidelity::Lumped => [0.0; 3],
            ThermalFidelity::Full => {
                let t_surface = self.nodes_k[surface];
                self.springs
                    .map(|s| params::G_COLUMN_SPRING_W_PER_K * (t_surface - s.t_k))
            }
        };

        // Cylinder network.
        let key = fan.to_bits();
        let fresh = !matches!(&self.net_cache, Some((k, _, _)) if *k == key);
        if fresh {
            let net = self.network(fan);
            self.net_cache = Some((key, net.system_matrix(), net));
        }
        let (_, a, net) = self.net_cache.as_ref().expect("filled above");
        let mut power = [0.0; linalg::N];
        power[thermal::HEATER] = heater_w;
        if fid.thermal == ThermalFidelity::Full {
            power[surface] -= exchange_w.iter().sum::<f64>();
        }
        let u = net.forcing(&power, amb);
        let sys = thermal::System {
            a,
            n: self.n_nodes,
            u: &u,
            key,
        };
        thermal::advance(integrator, &sys, &mut self.nodes_k, h, &mut self.zoh_cache);

        // Springs: sensible update, then settle the phase on the enthalpy.
        let c = sma::capacity_j_per_k();
        let g = self.spring_ambient_w_per_k();
        for (i, s) in self.springs.iter_mut().enumerate() {
            let source = spring_w[i] + exchange_w[i];
            let t_sens = if g > 0.0 {
                thermal::advance_scalar(integrator, g / c, (source + g * amb) / c, s.t_k, h)
            } else {
                s.t_k + h * source / c
            };
            let enthalpy = sma::enthalpy_j(fid.sma, t_sens, s.phase.xi());
            let shift = sma::Shift::for_force(s.force_n);
            let (t, phase) = sma::settle(fid.sma, enthalpy, s.phase, shift);
            s.t_k = t;
            s.phase = phase;
        }

        // SMP: frozen fraction (store or release bend), stiffness.
        let phi = self.wall_phi();
        match fid.smp {
            SmpFidelity::Viscoelastic => self.smp.freeze(phi, self.bend_rad),
            SmpFidelity::Elastic => {
                self.smp.phi = phi.clamp(0.0, 1.0);
                self.smp.stored_rad = [0.0; 2];
            }
        }
        self.time_s += h;
        if fid.mechanics {
            self.k_b_nmm_per_rad = self.column_k_b();
            self.solve_bend(h);
        }
    }

    /// Solve the moment balance at the end of a step of `h` (0: instantaneous) and relax the
    /// Maxwell branch exactly over it.
    fn solve_bend(&mut self, h: f64) {
        let (k, l) = mechanics::spring_state(self.springs.map(|s| s.phase.xi()));
        let visco = self.config.fidelity.smp == SmpFidelity::Viscoelastic;
        let (_, inner, outer, _) = self.region_temps();
        let t_wall = params::INNER_LAYER_SHARE * inner + (1.0 - params::INNER_LAYER_SHARE) * outer;
        let decay = if visco {
            (-h / smp::branch_tau_s(t_wall)).exp()
        } else {
            0.0
        };
        let mut bal = Balance {
            film_nmm_per_rad: params::FILM_BENDING_NMM_PER_RAD,
            film_set_rad: self.film_set_rad,
            smp_nmm_per_rad: self.smp_stiffness(),
            stored_rad: self.smp.stored_rad,
            branch_nmm_per_rad: smp::branch_nmm_per_rad() * decay,
            branch_rad: self.smp.branch_rad,
            spring_k_n_per_mm: k,
            spring_free_mm: l,
        };
        let mut b = bal.solve(self.bend_rad);
        // The film yields: move its set and re-balance until the set stops moving.
        for _ in 0..20 {
            let set = mechanics::yield_film(bal.film_set_rad, b, params::FILM_YIELD_BEND_RAD);
            if (set[0] - bal.film_set_rad[0]).hypot(set[1] - bal.film_set_rad[1]) < 1e-12 {
                break;
            }
            bal.film_set_rad = set;
            b = bal.solve(b);
        }
        self.film_set_rad = bal.film_set_rad;
        let forces = mechanics::spring_forces_n(b, k, l);
        for (s, f) in self.springs.iter_mut().zip(forces) {
            s.force_n = f;
        }
        if visco {
            for j in 0..2 {
                self.smp.branch_rad[j] = b[j] + (self.smp.branch_rad[j] - b[j]) * decay;
            }
        } else {
            self.smp.branch_rad = b;
        }
        self.bend_rad = b;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plant(config: &PlantConfig, scale: PlantScale) -> Plant {
        Plant::with_options(
            config,
            ModelOptions {
                scale,
                ..ModelOptions::default()
            },
        )
        .expect("valid")
    }

    /// Heater, fan and springs through a short cycle; the observation after each step.
    fn trace(mut plant: Plant) -> Vec<Observation> {
        let mut out = Vec::new();
        for (heater_duty, fan_duty, springs_on, secs) in [
            (1.0, 0.0, [false; 3], 40),
            (0.4, 0.0, [true, true, false], 20),
            (0.0, 1.0, [false, false, true], 20),
            (0.0, 0.3, [false; 3], 30),
        ] {
            let inputs = Inputs {
                heater_duty,
                fan_duty,
                springs_on,
                ..Inputs::default()
            };
            for _ in 0..secs * 2 {
                plant.step(&inputs, 0.5);
                out.push(plant.observe());
            }
        }
        out
    }

    #[test]
    fn factors_of_one_are_the_default_plant_exactly() {
        let config = PlantConfig::default();
        let ones = PlantScale {
            heater_power: 1.0,
            wall_capacity: 1.0,
            spring_cooling: 1.0,
            spring_supply: 1.0,
        };
        let a = Plant::new(&config).expect("valid");
        let b = plant(&config, ones);
        assert_eq!(a.stored_energy_j(), b.stored_energy_j());
        assert_eq!(trace(a), trace(b));
        // And a factor that is not 1 changes the trace (the comparison can fail).
        let c = plant(
            &config,
            PlantScale {
                spring_cooling: 1.01,
                ..ones
            },
        );
        assert_ne!(trace(Plant::new(&config).expect("valid")), trace(c));
    }

    #[test]
    fn scale_factors_out_of_range_are_refused() {
        let config = PlantConfig::default();
        for (scale, field) in [
            (
                PlantScale {
                    heater_power: 0.49,
                    ..PlantScale::UNIT
                },
                "heater_power",
            ),
            (
                PlantScale {
                    wall_capacity: 2.01,
                    ..PlantScale::UNIT
                },
                "wall_capacity",
            ),
            (
                PlantScale {
                    spring_cooling: f64::NAN,
                    ..PlantScale::UNIT
                },
                "spring_cooling",
            ),
            (
                PlantScale {
                    spring_supply: f64::INFINITY,
                    ..PlantScale::UNIT
                },
                "spring_supply",
            ),
        ] {
            let options = ModelOptions {
                scale,
                ..ModelOptions::default()
            };
            let e = Plant::with_options(&config, options)
                .err()
                .expect("refused")
                .to_string();
            assert!(e.starts_with(&format!("scale.{field}: ")), "{e}");
            assert!(e.contains("outside 0.5–2"), "{e}");
        }
        for edge in [0.5, 2.0] {
            let scale = PlantScale {
                heater_power: edge,
                wall_capacity: edge,
                spring_cooling: edge,
                spring_supply: edge,
            };
            plant(&config, scale);
        }
    }

    #[test]
    fn heater_power_multiplies_the_heaters_power_at_any_duty() {
        let config = PlantConfig::default();
        for duty in [0.35, 1.0] {
            let inputs = Inputs {
                heater_duty: duty,
                ..Inputs::default()
            };
            let mut a = Plant::new(&config).expect("valid");
            let mut b = plant(
                &config,
                PlantScale {
                    heater_power: 1.2,
                    ..PlantScale::UNIT
                },
            );
            a.step(&inputs, 10.0);
            b.step(&inputs, 10.0);
            let (oa, ob) = (a.observe(), b.observe());
            assert!(oa.heater_power_w > 10.0 * duty, "{}", oa.heater_power_w);
            assert!(
                (ob.heater_power_w / oa.heater_power_w - 1.2).abs() < 1e-12,
                "{} vs {}",
                ob.heater_power_w,
                oa.heater_power_w
            );
            assert!((b.electrical_energy_j() / a.electrical_energy_j() - 1.2).abs() < 1e-12);
            assert!(ob.heater_k - 298.15 > 1.1 * (oa.heater_k - 298.15));
        }
    }

    #[test]
    fn wall_capacity_slows_the_walls_warm_up_and_holds_its_heat() {
        let config = PlantConfig::default();
        let full = Inputs {
            heater_duty: 1.0,
            ..Inputs::default()
        };
        let warm = |scale: f64| {
            let mut p = plant(
                &config,
                PlantScale {
                    wall_capacity: scale,
                    ..PlantScale::UNIT
                },
            );
            p.step(&full, 60.0);
            let o = p.observe();
            (o.smp_inner_k - 298.15, o.smp_outer_k - 298.15)
        };
        let (inner, outer) = warm(1.0);
        let (inner_big, outer_big) = warm(1.2);
        let (inner_small, _) = warm(0.8);
        assert!(inner > 10.0, "{inner}");
        assert!(inner_big < 0.9 * inner, "{inner_big} vs {inner}");
        assert!(outer_big < 0.9 * outer, "{outer_big} vs {outer}");
        assert!(inner_small > 1.1 * inner, "{inner_small} vs {inner}");
        // The capacity is the plant's own: adiabatic, the stored heat rises by exactly the
        // electrical energy delivered (it would not if the store used the fitted capacity).
        let mut p = Plant::with_options(
            &config,
            ModelOptions {
                adiabatic: true,
                scale: PlantScale {
                    wall_capacity: 1.2,
                    ..PlantScale::UNIT
                },
                ..ModelOptions::default()
            },
        )
        .expect("valid");
        let e0 = p.stored_energy_j();
        p.step(&full, 60.0);
        let gained = p.stored_energy_j() - e0;
        let delivered = p.electrical_energy_j();
        assert!(
            (gained - delivered).abs() < 1e-9 * e0,
            "{gained} J stored, {delivered} J delivered"
        );
    }

    #[test]
    fn spring_cooling_multiplies_the_springs_loss_to_ambient() {
        // Lumped: no column→spring path, so a spring cools as one exponential to the ambient
        // and its decay exponent is its loss conductance over its capacity. From 330 K (below
        // A_s: martensite, no transformation on the way down).
        let config = PlantConfig {
            initial_k: 330.0,
            fidelity: Fidelity {
                thermal: ThermalFidelity::Lumped,
                ..Fidelity::default()
            },
            ..PlantConfig::default()
        };
        let cool = |scale: f64| {
            let mut p = plant(
                &config,
                PlantScale {
                    spring_cooling: scale,
                    ..PlantScale::UNIT
                },
            );
            let loss_w = p.ambient_loss_w(0.0);
            p.step(&Inputs::default(), 60.0);
            let o = p.observe();
            assert_eq!(o.austenite, [0.0; 3]);
            let excess = o.springs_k[0] - config.ambient_k;
            (-(excess / (330.0 - config.ambient_k)).ln(), loss_w)
        };
        let (decay, loss_w) = cool(1.0);
        let (decay_fast, loss_fast_w) = cool(1.2);
        assert!(decay > 0.2, "{decay}");
        assert!(
            (decay_fast / decay - 1.2).abs() < 1e-6,
            "{decay_fast} vs {decay}"
        );
        // The ambient loss counts the springs' scaled conductance (three springs, 31.85 K up).
        let springs_w = 3.0 * sma::ambient_w_per_k() * (330.0 - config.ambient_k);
        assert!(
            ((loss_fast_w - loss_w) - 0.2 * springs_w).abs() < 1e-9,
            "{loss_fast_w} vs {loss_w}"
        );
    }

    #[test]
    fn spring_supply_scales_the_channel_voltage_under_its_current_limit() {
        let config = PlantConfig::default();
        let on = Inputs {
            springs_on: [true, false, false],
            ..Inputs::default()
        };
        let drive = |scale: f64| {
            let mut p = plant(
                &config,
                PlantScale {
                    spring_supply: scale,
                    ..PlantScale::UNIT
                },
            );
            p.step(&on, 0.01);
            let o = p.observe();
            (o.spring_current_a[0], o.spring_power_w[0])
        };
        let r_wire = sma::wire_resistance_ohm(1.0);
        let r = r_wire + params::SPRING_LEAD_RESISTANCE_OHM;
        // Martensite, unscaled: 5 V over ≈0.30 Ω asks for more than 15 A; the limit holds.
        let (amps, watts) = drive(1.0);
        assert!(params::SPRING_SUPPLY_V / r > params::SPRING_SUPPLY_LIMIT_A);
        assert_eq!(amps, params::SPRING_SUPPLY_LIMIT_A);
        // 0.8: 4 V over the same resistance is below the limit; the current is V/R.
        let (amps_low, watts_low) = drive(0.8);
        let expected = 0.8 * params::SPRING_SUPPLY_V / r;
        assert!(expected < params::SPRING_SUPPLY_LIMIT_A);
        assert!(
            (amps_low - expected).abs() < 1e-12,
            "{amps_low} vs {expected}"
        );
        assert!((watts_low - expected * expected * r_wire).abs() < 1e-9);
        assert!(watts_low < 0.8 * watts, "{watts_low} vs {watts}");
        // 1.2: still at the limit.
        assert_eq!(drive(1.2), (amps, watts));
    }
}
