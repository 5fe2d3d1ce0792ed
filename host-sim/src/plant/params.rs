//! Every constant of the plant, with its unit and its source: the one place they live.
//!
//! Sources: \[T\] the thesis (`/work/shared/seed/000_05d5a5c9fd66e5b4.txt`, section given);
//! \[S\] a handbook or paper value (cited, via `PLANT-REFERENCE.md`); \[F\] fitted once to the
//! thesis figures by the open-loop calibration (`tests/plant_calibration.rs` measures them,
//! `docs/PLANT-API.md` lists fit against thesis); \[D\] derived here from the others.
//! The block's dimensions are not repeated here: they come from `thermorph::block`.

use thermorph::block;

// ---------------------------------------------------------------- geometry [T 6.2.1]

/// Column (SMP cylinder) length, mm [T 6.2.1, `thermorph::block`].
pub const LENGTH_MM: f64 = block::CYLINDER_LENGTH_MM as f64;
/// Inner diameter (heater film and air duct), mm [T 6.2.1].
pub const INNER_DIAMETER_MM: f64 = block::CYLINDER_INNER_DIAMETER_MM as f64;
/// Outer diameter, mm [T 6.2.1].
pub const OUTER_DIAMETER_MM: f64 = block::CYLINDER_OUTER_DIAMETER_MM as f64;
/// Radius of the spring circle, mm [T 6.2.1].
pub const SPRING_RADIUS_MM: f64 = block::SPRING_RADIUS_MM as f64;
/// Angle between springs, degrees [T 6.2.1].
pub const SPRING_SPACING_DEG: f64 = block::SPRING_SPACING_DEG as f64;
/// Thick inner lattice layer, mm [T 6.2.1].
pub const INNER_LAYER_MM: f64 = block::LATTICE_LOWER_LAYER_MM as f64;
/// Thin outer lattice layer, mm [T 6.2.1].
pub const OUTER_LAYER_MM: f64 = block::LATTICE_UPPER_LAYER_MM as f64;
/// PMMA end plate thickness, mm [T 6.2.1].
pub const PLATE_THICKNESS_MM: f64 = block::PLATE_THICKNESS_MM as f64;
/// PMMA end plate diameter, mm [T 6.2.1].
pub const PLATE_DIAMETER_MM: f64 = block::PLATE_DIAMETER_MM as f64;

/// Inner (heater film) surface area, m² \[D\]: π·d_i·L.
pub const INNER_AREA_M2: f64 = std::f64::consts::PI * INNER_DIAMETER_MM * LENGTH_MM * 1e-6;
/// Outer surface area, m² \[D\]: π·d_o·L.
pub const OUTER_AREA_M2: f64 = std::f64::consts::PI * OUTER_DIAMETER_MM * LENGTH_MM * 1e-6;
/// Air volume of the duct, m³ \[D\]: π/4·d_i²·L.
pub const DUCT_VOLUME_M3: f64 =
    std::f64::consts::PI / 4.0 * INNER_DIAMETER_MM * INNER_DIAMETER_MM * LENGTH_MM * 1e-9;

// ---------------------------------------------------------------- electrical [T 6.3.2]

/// Heater supply voltage, V [T 6.3.2: 18.0 V, 10.0 A supply].
pub const HEATER_SUPPLY_V: f64 = 18.0;
/// Heater supply current limit, A [T 6.3.2].
pub const HEATER_SUPPLY_LIMIT_A: f64 = 10.0;
/// Heater (PI film group) resistance, Ω \[F\]: full duty is 18 V / 5.5 Ω = 3.3 A, 58.9 W
/// (PLANT-REFERENCE: ≈50–75 W fits both of the thesis's heat-ups). Refitted with the wall's
/// capacity and contact below (issue 19) so that, in the closed loop, the wall softens as fast
/// as fig. 6.10(d) shows — stepping's soak from standby to a soft wall 38.75 s (thesis ≈25 s,
/// pass ≤ 40 s), k_b 25 s into recovery 1.05× the heated k_b (thesis ≈1) — while the standby
/// preheat stays 8.5 s to 323 K [T 6.4.2: ≈10 s] with 0.94 K overshoot (< 1 K). The earlier
/// 7.89 Ω (41 W) with a 1900 J/(m²·K) wall soaked 69.5 s and gave 1.96× at 25 s.
pub const HEATER_RESISTANCE_OHM: f64 = 5.5;
/// Spring supply voltage, V [T 6.3.2: "each SMA spring is connected to a single power supply,
/// with a maximum output of 5.0 V and 15.0 A"; SPEC section 2: one channel per spring].
pub const SPRING_SUPPLY_V: f64 = 5.0;
/// Spring supply current limit, A, per channel (or for all three with
/// `ModelOptions::shared_spring_supply`) [T 6.3.2].
pub const SPRING_SUPPLY_LIMIT_A: f64 = 15.0;
/// NiTi resistivity, martensite, Ω·m [S Dynalloy: 76–80 µΩ·cm].
pub const NITI_RESISTIVITY_M_OHM_M: f64 = 80e-8;
/// NiTi resistivity, austenite, Ω·m [S Dynalloy: 82–100 µΩ·cm].
pub const NITI_RESISTIVITY_A_OHM_M: f64 = 90e-8;
/// Wiring and MOSFET resistance per spring, Ω [E PLANT-REFERENCE: 20–50 mΩ]. It limits the
/// current but its I²R is not heat in the wire.
pub const SPRING_LEAD_RESISTANCE_OHM: f64 = 0.03;

// ---------------------------------------------------------------- spring channels [S/E]

/// The supply's output resistance, Ω [E PLANT-REFERENCE: bench or DC-DC module 10–50 mΩ].
pub const SUPPLY_OHM: f64 = 0.010;
/// The spring power enable's high-side switch on-resistance, Ω [S datasheet class: a
/// logic-level P-MOSFET or a high-side switch such as the BTS50015, 1.5–5 mΩ].
pub const ENABLE_SWITCH_OHM: f64 = 0.003;
/// The MOSFET's on-resistance at a 3.3 V gate, Ω [S datasheet class: logic-level N-MOSFETs
/// (IRLB8721, PSMN2R0-30YLE) 2–10 mΩ].
pub const MOSFET_OHM: f64 = 0.005;
/// The current shunt, Ω [S: 2 mΩ, 1 % (SPEC section 2)].
pub const SHUNT_OHM: f64 = 0.002;
/// The leads and connectors, Ω [E PLANT-REFERENCE 20–50 mΩ with the rest of the channel].
pub const LEADS_OHM: f64 =
    SPRING_LEAD_RESISTANCE_OHM - SUPPLY_OHM - ENABLE_SWITCH_OHM - MOSFET_OHM - SHUNT_OHM;
/// The resistance from the supply's sense point to ground outside the wire, Ω (what the
/// firmware subtracts: its `FRONT_END.series_ohm`).
pub const SERIES_OHM: f64 = ENABLE_SWITCH_OHM + LEADS_OHM + MOSFET_OHM + SHUNT_OHM;
/// What is left of a wire bypassed by a short (leads touching, the wire against the frame), Ω.
pub const BYPASSED_WIRE_OHM: f64 = 0.005;
/// The wire's temperature coefficient of resistance within a phase, 1/K [E PLANT-REFERENCE:
/// order 10⁻⁴–10⁻³ /K, small next to the phase change]; off with
/// [`ModelOptions::constant_wire_resistance`](super::ModelOptions::constant_wire_resistance).
/// It moves the thesis figures a little (a hotter wire draws more power at the channel's
/// current limit: forming's angle loss 3.9° → 2.9°, every `host-sim paper` row passes) and is
/// what lets the firmware read a spring's temperature within austenite.
pub const WIRE_TEMPCO_PER_K: f64 = 3e-4;
/// The temperature at which the resistivities of `params` are the wire's, K.
pub const WIRE_REFERENCE_K: f64 = 298.15;

// ---------------------------------------------------------------- thermal network

/// PI heater film areal heat capacity (film, adhesive, foil), J/(m²·K) [S/E PLANT-REFERENCE:
/// Kapton 1420 kg/m³, 1.09 J/g·K → 280 (150–400)].
pub const HEATER_AREAL_CAPACITY_J_PER_M2K: f64 = 280.0;
/// SMP wall (both lattice layers) areal heat capacity, J/(m²·K) [F; PLANT-REFERENCE suggests
/// ≈2.3 k for a solid fraction ≈0.5 (printed lattices lower): the waved lattice is mostly gap
/// (21.35 of each 30 mm unit, T 6.2), so ≈0.33 solid. Fitted with the heater and the contact to
/// fig. 6.10(d)'s softening in recovery and the ≈25 s soak (`HEATER_RESISTANCE_OHM`), keeping
/// the thesis's 50 s forming (T 6.4.3) within its ±10 s: 49.0 s in the closed loop (1900 gave
/// the old fit's 47.25 s but softened twice as slowly)].
pub const WALL_AREAL_CAPACITY_J_PER_M2K: f64 = 1500.0;
/// Share of the wall's capacity in the thick inner layer \[D\]: 4 mm / (4 + 1.8) mm.
pub const INNER_LAYER_SHARE: f64 = INNER_LAYER_MM / (INNER_LAYER_MM + OUTER_LAYER_MM);
/// Heater film → SMP inner layer contact conductance, W/(m²·K) [F with the wall's capacity and
/// the heater (above); bounded by physics: 0.1 mm of adhesive at ≈0.2 W/(m·K) conducts
/// ≈2000 W/(m²·K) over full contact, so 150 is ≈7.5 % effective contact — the film touches the
/// lattice's struts only. 84.2, the earlier fit, softened the wall too slowly].
pub const H_HEATER_WALL_W_PER_M2K: f64 = 150.0;
/// SMP inner → outer layer conductance through the lattice, W/(m²·K) [F; a solid 2.5 mm PLA
/// wall would give k/t = 0.13/0.0025 = 52, S Zmeskal 2020].
pub const H_WALL_W_PER_M2K: f64 = 54.6;
/// Outer surface → ambient (natural convection + radiation), W/(m²·K) [F within
/// PLANT-REFERENCE's 11–14 from Churchill–Chu plus ε≈0.93 radiation: the low end, which the
/// soak and forming fit together (13.4 before the issue-19 refit)].
pub const H_OUTSIDE_W_PER_M2K: f64 = 11.0;
/// Heater film → duct air, fan full on, W/(m²·K) [S/F PLANT-REFERENCE: Gnielinski with the
/// entrance correction 27–49, and suggests ≈32]. Fitted to the forming time from the stepping
/// state with the refitted wall (issue 19): 30 gives 49.0 s in the closed loop (the slower
/// wall needed 49).
pub const H_DUCT_FAN_W_PER_M2K: f64 = 30.0;
/// Heater film → duct air, fan off (natural convection), W/(m²·K) [S/E PLANT-REFERENCE: 2–5].
pub const H_DUCT_STILL_W_PER_M2K: f64 = 4.0;
/// Exponent of the duct coefficient on the fan duty (flow ∝ duty; turbulent h ∝ Re^0.8,
/// Dittus–Boelter) \[S\].
pub const DUCT_FLOW_EXPONENT: f64 = 0.8;
/// Air flow through the duct at full fan duty, m³/s [S/E PLANT-REFERENCE: Delta AFB0912HH,
/// 58 CFM free air, ≈14 CFM through the 35 mm duct].
pub const DUCT_FLOW_FULL_M3_PER_S: f64 = 6.6e-3;
/// Natural (stack) draught through the duct with the fan off, m³/s \[E\].
pub const DUCT_FLOW_STILL_M3_PER_S: f64 = 4.0e-5;
/// Air density, kg/m³ [S at 298 K].
pub const AIR_DENSITY_KG_PER_M3: f64 = 1.19;
/// Air specific heat, J/(kg·K) \[S\].
pub const AIR_CP_J_PER_KGK: f64 = 1005.0;
/// PMMA density, kg/m³ [S material databases].
pub const PMMA_DENSITY_KG_PER_M3: f64 = 1185.0;
/// PMMA specific heat, J/(kg·K) [S: 1260–1450].
pub const PMMA_CP_J_PER_KGK: f64 = 1350.0;
/// Plate → ambient coefficient (both faces), W/(m²·K) [S/E as the outside coefficient].
pub const H_PLATE_W_PER_M2K: f64 = 12.0;
/// Column ends → plates contact conductance (both ends, through the PLA end rings), W/K [E:
/// 0.13 W/m·K over 2 × 295 mm² and ≈5 mm].
pub const G_COLUMN_PLATES_W_PER_K: f64 = 0.015;

// ---------------------------------------------------------------- SMA springs

/// Martensite start, K [T 6.3.1].
pub const SMA_MS_K: f64 = 325.0;
/// Martensite finish, K [T 6.3.1].
pub const SMA_MF_K: f64 = 315.0;
/// Austenite start, K [T 6.3.1].
pub const SMA_AS_K: f64 = 341.0;
/// Austenite finish, K [T 6.3.1].
pub const SMA_AF_K: f64 = 351.0;
/// Switching temperature of the `Switch` fidelity, K [T 6.3.1: τ_T = (Ms + As)/2].
pub const SMA_SWITCH_K: f64 = 0.5 * (SMA_MS_K + SMA_AS_K);
/// Young's modulus, martensite, MPa [T 6.3.1].
pub const SMA_E_M_MPA: f64 = 28_000.0;
/// Young's modulus, austenite, MPa [T 6.3.1].
pub const SMA_E_A_MPA: f64 = 75_000.0;
/// Poisson's ratio [S PLANT-REFERENCE].
pub const SMA_POISSON: f64 = 0.33;
/// Wire diameter, mm [T 6.3.2].
pub const WIRE_DIAMETER_MM: f64 = 2.3;
/// Mean coil diameter, mm [E; the thesis is silent]: spring index D/d ≈ 7.8 (SMA springs are
/// wound at 6–10); the coil (Ø 20.3 mm outside) fits between the column (r 20 mm) and the
/// plate's rim (r 53 mm) on the 45 mm spring circle.
pub const COIL_DIAMETER_MM: f64 = 18.0;
/// Active coils [E; the thesis is silent]: 25 coils make 1.41 m of wire, 0.27–0.31 Ω, so one
/// 5 V channel with 0.03 Ω of leads is held at its 15 A limit in both phases (a longer wire
/// would draw less than 15 A and heat slower per metre); solid length 58 mm < 100 mm.
pub const COIL_COUNT: f64 = 25.0;
/// Natural length cold (martensite), mm [T 6.3.2: "extend to 200 mm upon cooling"]: the
/// plates' spacing, so a cold spring is just slack on the straight column.
pub const SPRING_LENGTH_COLD_MM: f64 = 200.0;
/// Natural length hot (austenite) under the column's load, mm [F: one spring bends the hot
/// column ≈42°, two ≈65°, T 6.4.1]. The thesis's "contract to 100 mm when heated" is the
/// spring's unloaded training target; with the coil above (k_A ≈ 0.68 N/mm) a 100 mm natural
/// length would pull ≈40 N and fold the column, so the two-way stroke that acts here is the
/// 200 → 155 mm one (a trained two-way strain is well below the one-way strain).
pub const SPRING_LENGTH_HOT_MM: f64 = 155.0;
/// NiTi density, kg/m³ [S Dynalloy].
pub const NITI_DENSITY_KG_PER_M3: f64 = 6450.0;
/// NiTi specific heat, J/(kg·K) [S DSC: 450–550 (Dulong–Petit ≈470), PLANT-REFERENCE; not
/// Dynalloy's catalogue 837].
pub const NITI_CP_J_PER_KGK: f64 = 480.0;
/// NiTi latent heat of transformation of a trained two-way spring, J/kg [S: Resnina 2015
/// reports 15–35 J/g, the low end for trained/cycled wire; PLANT-REFERENCE ≈15 J/g].
pub const NITI_LATENT_J_PER_KG: f64 = 22_000.0;
/// Spring wire → still air (natural convection with coil self-shielding + radiation at
/// ε≈0.3), W/(m²·K) [S/E PLANT-REFERENCE: 8–15 + 2–5]. The fan's air stays in the duct
/// [T 6.3.2: "minimizes any cooling interference between the SMP and SMA"], so the fan duty
/// does not cool the springs.
pub const H_SPRING_W_PER_M2K: f64 = 12.0;
/// Heat path from the hot column's outer surface to each spring (radiation at view factor
/// ≈0.2 and ε≈0.3, ≈0.005 W/K, plus the warm edge of the column's natural-convection
/// boundary layer, ≤ 10 % of the spring's still-air conductance, ≈0.012 W/K), W/K [E bound].
/// A 300 s soak at 358 K warms a spring by only ≈6 K: the springs start stepping cold unless
/// they are pre-warmed electrically (see `docs/PLANT-API.md`).
pub const G_COLUMN_SPRING_W_PER_K: f64 = 0.017;
/// Share of the transformation (of the spring's stroke) in a narrow, nearly reversible
/// R-phase-like band [S: R-phase strain 0.5–1 % against a trained two-way strain of 2–4 %,
/// Otsuka & Ren 2005, Prog. Mater. Sci. 50:511 → 0.15–0.35].
pub const SMA_NARROW_SHARE: f64 = 0.25;
/// Hysteresis of the narrow band, K [S: B2↔R hysteresis 1–5 K, Otsuka & Ren 2005].
pub const SMA_NARROW_HYSTERESIS_K: f64 = 2.0;
/// Clausius–Clapeyron slope of the martensite temperatures (tension), MPa/K [S Brinson 1993,
/// J. Intell. Mater. Syst. Struct. 4:229: C_M = 8].
pub const SMA_CM_MPA_PER_K: f64 = 8.0;
/// Clausius–Clapeyron slope of the austenite temperatures (tension), MPa/K [S Brinson 1993:
/// C_A = 13.8].
pub const SMA_CA_MPA_PER_K: f64 = 13.8;

/// Shear modulus from E and ν, MPa \[D\].
pub const fn shear_mpa(e_mpa: f64) -> f64 {
    e_mpa / (2.0 * (1.0 + SMA_POISSON))
}
/// Wire cross-section, mm² \[D\].
pub const WIRE_AREA_MM2: f64 = std::f64::consts::PI / 4.0 * WIRE_DIAMETER_MM * WIRE_DIAMETER_MM;
/// Wire length of one spring, mm \[D\]: π·D·n.
pub const WIRE_LENGTH_MM: f64 = std::f64::consts::PI * COIL_DIAMETER_MM * COIL_COUNT;
/// Wire mass of one spring, kg \[D\].
pub const SPRING_MASS_KG: f64 = WIRE_AREA_MM2 * WIRE_LENGTH_MM * 1e-9 * NITI_DENSITY_KG_PER_M3;
/// Wahl correction of the coil's shear stress, (4C − 1)/(4C − 4) + 0.615/C with C = D/d \[D\].
pub const WAHL_FACTOR: f64 = {
    let c = COIL_DIAMETER_MM / WIRE_DIAMETER_MM;
    (4.0 * c - 1.0) / (4.0 * c - 4.0) + 0.615 / c
};
/// Equivalent tensile stress (√3·τ, von Mises) per newton of spring force, MPa/N \[D\]:
/// τ = 8·F·D·K_w/(π·d³).
pub const SPRING_STRESS_MPA_PER_N: f64 =
    1.732_050_807_568_877_2 * 8.0 * COIL_DIAMETER_MM * WAHL_FACTOR
        / (std::f64::consts::PI * WIRE_DIAMETER_MM * WIRE_DIAMETER_MM * WIRE_DIAMETER_MM);
/// Wire surface area of one spring, m² \[D\].
pub const SPRING_AREA_M2: f64 = std::f64::consts::PI * WIRE_DIAMETER_MM * WIRE_LENGTH_MM * 1e-6;
/// Spring rate k = G·d⁴/(8·D³·n), N/mm [D, S Wahl] for shear modulus `g_mpa`.
pub const fn spring_rate_n_per_mm(g_mpa: f64) -> f64 {
    let d2 = WIRE_DIAMETER_MM * WIRE_DIAMETER_MM;
    let c3 = COIL_DIAMETER_MM * COIL_DIAMETER_MM * COIL_DIAMETER_MM;
    g_mpa * d2 * d2 / (8.0 * c3 * COIL_COUNT)
}
/// Spring rate, austenite, N/mm \[D\] (≈0.68).
pub const SPRING_K_A_N_PER_MM: f64 = spring_rate_n_per_mm(shear_mpa(SMA_E_A_MPA));
/// Spring rate, martensite, N/mm \[D\] (≈0.25).
pub const SPRING_K_M_N_PER_MM: f64 = spring_rate_n_per_mm(shear_mpa(SMA_E_M_MPA));

// ---------------------------------------------------------------- SMP (PLA lattice)

/// Glass transition (and WLF reference) temperature, K [T 6.3.1].
pub const SMP_TG_K: f64 = 334.0;
/// WLF C1 [T 6.3.1].
pub const WLF_C1: f64 = 6.14;
/// WLF C2, K [T 6.3.1].
pub const WLF_C2_K: f64 = 293.0;
/// Guard on the shift factor: |log10 a_T| ≤ this [PLANT-REFERENCE].
pub const WLF_LOG10_LIMIT: f64 = 8.0;
/// Glassy (frozen phase) modulus, MPa [T 6.3.1: 1000 MPa at 298 K].
pub const SMP_E_GLASSY_MPA: f64 = 1000.0;
/// Rubbery (active phase) modulus of the printed lattice above its transition, MPa [F: the
/// thesis's contrast ×4.5 (T 6.4.3) is E(≈323 K)/E_r once the lattice is fully rubbery at
/// 358 K, so the hot column's k_b ≈ 1400/4.5 ≈ 311 N·mm/rad comes from the lattice, not from
/// the heater film (see `FILM_BENDING_NMM_PER_RAD`)].
pub const SMP_E_RUBBERY_MPA: f64 = 200.0;
/// Width of the logistic frozen fraction φ_f = 1/(1 + e^{(T − T_c)/w}), K [F: the recovery is
/// slow for its first ≈15 s and then linear (T 6.4.3, "triggered only after the SMP core is
/// fully heated above its transition"): the stored bend must stay frozen until a layer is well
/// above Tg. 3 K puts the 10–90 % span at 13 K (329–349 K), about where printed PLA's storage
/// modulus falls (DMA, ≈55–70 °C); the 5.5 K of the first round (span 24 K) released the bend
/// from ≈325 K on, as soon as the reheat began, and φ_f(358 K) is now ≈0.001].
pub const SMP_PHI_WIDTH_K: f64 = 3.0;
/// Centre of the logistic frozen fraction, K \[D\]: T_g − w·ln(1/φ_g − 1) with
/// φ_g = (1/400 − 1/E_r)/(1/E_g − 1/E_r), so that Liu's series law
/// 1/E = φ_f/E_g + (1 − φ_f)/E_r gives E(Tg) = 400 MPa (−60 %, T 6.3.1); checked by a test.
pub const SMP_PHI_CENTRE_K: f64 = 335.532_5;
/// Bending stiffness of the lattice per MPa of modulus (open-lattice I_eff/L), N·mm/(rad·MPa)
/// [F: k_b(323 K) ≈ 1400 N·mm/rad, T 6.4.3; a solid tube would give ≈260, PLANT-REFERENCE].
pub const SMP_BENDING_PER_MPA_NMM_PER_RAD: f64 = 1.5;
/// Elastic bending stiffness of the PI heater film group, N·mm/rad [E: T 6.3.2 "very low
/// stiffness ... negligible impact on the structure's bending motion"]. As a bonded closed tube
/// (≈0.1 mm, 2.5 GPa, r 17.5 mm) it would give EI/L ≈ 2·10⁴ N·mm/rad, so the pads cannot carry
/// axial strain that way (separate pads, wrinkling on the compression side); and any elastic
/// share must yield (below) and would then hold the column bent against recovery, which the
/// thesis shows complete. The heated k_b is therefore the lattice's; the film keeps a small
/// share.
pub const FILM_BENDING_NMM_PER_RAD: f64 = 10.0;
/// Yield strain of the polyimide film [S DuPont Kapton HN: yield at ≈3 % (69 MPa at 23 °C,
/// lower at 85 °C)].
pub const FILM_YIELD_STRAIN: f64 = 0.03;
/// Bend at which the film's outer fibre (r = d_i/2) reaches its yield strain, rad \[D\]:
/// ε = r·θ/L → θ_y = ε_y·L/r (≈0.34 rad ≈ 20°; at 65° the film would be strained ≈10 %).
pub const FILM_YIELD_BEND_RAD: f64 = FILM_YIELD_STRAIN * LENGTH_MM / (0.5 * INNER_DIAMETER_MM);
/// Maxwell branch modulus (generalised Maxwell, eq. 6.7), MPa [F: 100 first fitted the
/// recovery's slow start, which the frozen fraction's 3 K width now gives; the branch's creep
/// makes the angle rise in each 2 s pulse, against the thesis's drop (T 6.4.3), so it is kept
/// small: 30 MPa, creep ≤ 0.2° per pulse].
pub const SMP_BRANCH_E_MPA: f64 = 30.0;
/// Maxwell branch relaxation time at Tg, s [F: the recovery lag, T 6.4.3].
pub const SMP_BRANCH_TAU_S: f64 = 10.0;

// ---------------------------------------------------------------- numerics

/// Default largest internal step, s (the control period).
pub const DEFAULT_MAX_STEP_S: f64 = 0.5;
/// Lowest accepted ambient/initial temperature, K.
pub const MIN_CONFIG_K: f64 = 200.0;
/// Highest accepted ambient/initial temperature, K.
pub const MAX_CONFIG_K: f64 = 450.0;
