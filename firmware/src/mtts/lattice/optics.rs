//! The optics' transfer function: a pixel's footprint (two boxes along a tilted axis)
//! through a Gaussian spread, and the lattice core's extent.

use super::*;

/// The next harmonic's (cos, sin): (`c`, `s`) of an angle kθ turned by θ, whose (cos, sin) is
/// (`c1`, `s1`) — the angle-sum formulas, so a profile's harmonics cost one `sin_cos_turns`.
#[inline(always)]
pub(super) fn turn((c, s): (f32, f32), (c1, s1): (f32, f32)) -> (f32, f32) {
    (c * c1 - s * s1, s * c1 + c * s1)
}

/// sin(πx)/(πx).
pub(super) fn sinc(x: f32) -> f32 {
    sinc_of(sin_cos_turns(0.5 * x).0, x)
}

/// sin(πx)/(πx) given sin(πx) (`sin_pi_x`).
pub(super) fn sinc_of(sin_pi_x: f32, x: f32) -> f32 {
    if libm::fabsf(x) < 1e-4 {
        1.0
    } else {
        sin_pi_x / (core::f32::consts::PI * x)
    }
}

/// Transfer function of pixel footprint and optics at `nu` cycles per pixel along an axis of
/// slope `slope` (columns per row), through a Gaussian point-spread function of standard
/// deviation `sigma_px`.
pub fn transfer(nu: f32, slope: f32, sigma_px: f32) -> f32 {
    let inv = 1.0 / crate::fmath::sqrt(1.0 + slope * slope);
    let (ca, sa) = (inv, libm::fabsf(slope) * inv);
    let g = core::f32::consts::PI * sigma_px * nu;
    sinc(nu * ca) * sinc(nu * sa) * libm::expf(-2.0 * g * g)
}

/// Distance ratio below which a pixel belongs to the lattice core: the core less about one
/// pixel (the footprint and the optics' spread reach the edges), at least the axis pixels.
pub fn lattice_core_u(half_width_px: f32) -> f32 {
    let w = max(0.5, half_width_px);
    min(max(CORE_U - 0.75 / w, 0.6 / w), CORE_U)
}
