//! The block's geometry: the one place that states its dimensions (SPEC section 1, thesis
//! 6.2.1). The MTTS region finder, the simulator's camera renderer and its plant read them here.

/// SMP cylinder length, mm.
pub const CYLINDER_LENGTH_MM: f32 = 200.0;
/// SMP cylinder inner diameter, mm.
pub const CYLINDER_INNER_DIAMETER_MM: f32 = 35.0;
/// SMP cylinder wall thickness, mm.
pub const CYLINDER_WALL_MM: f32 = 2.5;
/// SMP cylinder outer diameter, mm.
pub const CYLINDER_OUTER_DIAMETER_MM: f32 = CYLINDER_INNER_DIAMETER_MM + 2.0 * CYLINDER_WALL_MM;
/// Axial length of one lattice unit, mm.
pub const LATTICE_UNIT_MM: f32 = 30.0;
/// Axial length of the gap of a lattice unit, where the PI heater film shows through, mm.
pub const LATTICE_GAP_MM: f32 = 21.35;
/// Fraction of a lattice unit's length that is gap (heater visible).
pub const LATTICE_GAP_FRACTION: f32 = LATTICE_GAP_MM / LATTICE_UNIT_MM;
/// Upper (outer, thin) lattice layer thickness, mm.
pub const LATTICE_UPPER_LAYER_MM: f32 = 1.8;
/// Lower (inner, thick) lattice layer thickness, mm.
pub const LATTICE_LOWER_LAYER_MM: f32 = 4.0;
/// PMMA end plate thickness, mm.
pub const PLATE_THICKNESS_MM: f32 = 3.0;
/// PMMA end plate diameter, mm.
pub const PLATE_DIAMETER_MM: f32 = 106.0;
/// Radius of the circle the three springs sit on, mm.
pub const SPRING_RADIUS_MM: f32 = 45.0;
/// Angle between springs, degrees.
pub const SPRING_SPACING_DEG: f32 = 120.0;
/// Camera distance range to the cylinder, mm.
pub const CAMERA_DISTANCE_MM: (f32, f32) = (50.0, 100.0);
