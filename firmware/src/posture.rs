//! The column's posture: its bend, estimated from the camera and a model together.
//!
//! Two sources see the bend. The camera sees the column: MTTS fits the cylinder's axis in
//! every frame ([`Tilt`]), and for a constant-curvature column fixed at its base the visible
//! middle leans by half the bend's component in the image plane. The image plane holds spring
//! A's direction, so the camera measures `b_x = 2·tilt`, where `b = θ·(cos ψ, sin ψ)` is the bend
//! vector (θ the bend, ψ its plane from spring A). The model knows what pulls: each spring's
//! austenite fraction (the observer's) sets its rate and free length, the wall's frozen
//! fraction (the observer's) the SMP's stiffness and how much of the bend it has locked in.
//!
//! # The model
//!
//! The column's equilibrium minimises `U(b) = ½K(φ)|b − b_s|² + Σ ½k_i·max(0, ℓ_i(b) − ℓ0_i)²`:
//! the SMP (relaxed stiffness `K(φ)` by Liu's series law of the glassy and rubbery moduli,
//! plus the heater film's) about its stored bend `b_s`, and each spring a tension-only chord
//! `ℓ_i = (L − r·c_i·b)·sinc(θ/2)` between the end plates (rate and free length between its
//! martensite and austenite values by its austenite fraction). A few Gauss–Newton iterations a
//! step, from the last step's solution, follow it. The stored bend grows as the wall freezes,
//! `Δb_s = b·Δφ`, and is released in proportion as it softens (`b_s ∝ φ`), with `b` the fused
//! estimate (what the column really was when it locked).
//!
//! # The fusion
//!
//! The estimate is the model's equilibrium plus a correction `e` (a 2-vector, degrees) with
//! covariance `P`. Between frames `e` decays to zero with [`CORRECTION_TAU_S`] and `P` relaxes
//! to the model's own uncertainty: [`MODEL_SD_DEG`] in every direction plus
//! [`MODEL_SD_FRACTION`] of the bend along its plane (the model's error is mostly in how far
//! the springs pull, not where). Each frame's tilt corrects `e` by a Kalman update with the
//! fit's error (at least [`TILT_SD_FLOOR_DEG`]). Because the model's uncertainty lies along the
//! plane, a camera that sees only `b_x` corrects the whole bend along it: `θ ≈ b_x / cos ψ`.
//!
//! Where the plane lies near the camera's line of sight (ψ near ±90°) the camera sees almost
//! nothing of the bend: the update leaves the along-plane part alone, the estimate is the
//! model's, and its uncertainty is the model's (`MODEL_SD_DEG + MODEL_SD_FRACTION·θ`, about
//! 7° at 45°) instead of the camera's (≈ 1°). `docs/posture.md` measures both.

use crate::measurement::Tilt;
use crate::observer::Estimate;
use crate::outputs::{SPRINGS, SpringMask};
use crate::units::Seconds;

/// Column length, mm.
const LENGTH_MM: f32 = crate::block::CYLINDER_LENGTH_MM;
/// The springs' radius from the column's axis, mm.
const RADIUS_MM: f32 = crate::block::SPRING_RADIUS_MM;
/// A spring's rate in austenite, N/mm (G·d⁴/(8·D³·n): 2.3 mm wire, 18 mm coil, 25 turns).
pub const SPRING_RATE_AUSTENITE_N_PER_MM: f32 = 0.6765;
/// A spring's rate in martensite, N/mm.
pub const SPRING_RATE_MARTENSITE_N_PER_MM: f32 = 0.2525;
/// A spring's free length in austenite (its trained, short shape), mm.
pub const SPRING_FREE_AUSTENITE_MM: f32 = 155.0;
/// A spring's free length in martensite (as wound), mm.
pub const SPRING_FREE_MARTENSITE_MM: f32 = 200.0;
/// The glassy lattice's modulus, MPa.
pub const SMP_GLASSY_MPA: f32 = 1000.0;
/// The rubbery lattice's modulus, MPa.
pub const SMP_RUBBERY_MPA: f32 = 200.0;
/// The open lattice's bending stiffness per MPa of modulus, N·mm/(rad·MPa).
pub const LATTICE_NMM_PER_RAD_PER_MPA: f32 = 1.5;
/// The heater film's bending stiffness, N·mm/rad.
pub const FILM_NMM_PER_RAD: f32 = 10.0;
/// The model's uncertainty along the bend's plane at no bend, degrees.
pub const MODEL_SD_DEG: f32 = 1.5;
/// The model's uncertainty across the plane, degrees: the springs define the plane, so the
/// model errs in how far they pull, hardly in where.
pub const PLANE_SD_DEG: f32 = 0.5;
/// The model's uncertainty along the bend's plane, as a fraction of the bend.
pub const MODEL_SD_FRACTION: f32 = 0.15;
/// How long a camera's correction of the model persists without frames, s.
pub const CORRECTION_TAU_S: f32 = 5.0;
/// The least standard error a frame's tilt counts with, degrees (the fit's own error leaves
/// out the renderer's and the lattice's bias on the rows' centroids).
pub const TILT_SD_FLOOR_DEG: f32 = 0.3;
/// Gauss–Newton iterations of the equilibrium a step (from the last step's solution, 20 a
/// second: the column moves far less in a step than one iteration converges).
const ITERATIONS: usize = 1;

/// The bend as the estimate has it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bend {
    /// The bend, degrees (≥ 0).
    pub deg: f32,
    /// Its standard deviation, degrees.
    pub sd_deg: f32,
}

/// The posture estimate's state (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Posture {
    /// The model's equilibrium, rad (the next solve starts here).
    model_rad: [f32; 2],
    /// The SMP's stored bend, rad.
    stored_rad: [f32; 2],
    /// The wall's frozen fraction at the last step (NaN before the first).
    frozen: f32,
    /// The camera's correction of the model, degrees.
    correction_deg: [f32; 2],
    /// The correction's covariance (xx, xy, yy), deg².
    cov: [f32; 3],
}

impl Default for Posture {
    fn default() -> Self {
        Self::new()
    }
}

/// A spring's (rate N/mm, free length mm) at austenite fraction `a`: the phases in series.
fn spring(a: f32) -> (f32, f32) {
    let a = a.clamp(0.0, 1.0);
    let rate =
        1.0 / ((1.0 - a) / SPRING_RATE_MARTENSITE_N_PER_MM + a / SPRING_RATE_AUSTENITE_N_PER_MM);
    let free = SPRING_FREE_AUSTENITE_MM
        + (SPRING_FREE_MARTENSITE_MM - SPRING_FREE_AUSTENITE_MM) * (1.0 - a);
    (rate, free)
}

/// The relaxed SMP's (with the film's) bending stiffness at frozen fraction `phi`, N·mm/rad.
pub fn stiffness_nmm_per_rad(phi: f32) -> f32 {
    let phi = if phi.is_finite() {
        phi.clamp(0.0, 1.0)
    } else {
        1.0
    };
    LATTICE_NMM_PER_RAD_PER_MPA / (phi / SMP_GLASSY_MPA + (1.0 - phi) / SMP_RUBBERY_MPA)
        + FILM_NMM_PER_RAD
}

/// Spring `i`'s direction (A 0°, B 120°, C 240°).
fn direction(i: usize) -> [f32; 2] {
    match i {
        0 => [1.0, 0.0],
        1 => [-0.5, 0.866_025_4],
        _ => [-0.5, -0.866_025_4],
    }
}

/// `sinc(θ/2)` and `(d sinc(θ/2)/dθ)/θ`, by their series in `u = θ/2` to u⁶ (f32 only: libm's
/// `sinf`/`cosf` work in f64, which the Cortex-M4's FPU does not have). θ is taken at most
/// 2 rad (115°), where the next terms are below 3·10⁻⁶.
fn sinc_terms(theta: f32) -> (f32, f32) {
    let u = 0.5 * theta.min(2.0);
    let u2 = u * u;
    (
        1.0 + u2 * (-1.0 / 6.0 + u2 * (1.0 / 120.0 + u2 * (-1.0 / 5040.0))),
        -1.0 / 12.0 + u2 * (1.0 / 120.0 + u2 * (-1.0 / 3360.0 + u2 * (1.0 / 181_440.0))),
    )
}

/// Gauss–Newton iterations towards the equilibrium from `b`, rad.
fn equilibrium(
    austenite: &[f32; SPRINGS],
    k_nmm: f32,
    stored: [f32; 2],
    mut b: [f32; 2],
) -> [f32; 2] {
    let springs = austenite.map(spring);
    for _ in 0..ITERATIONS {
        let theta = crate::fmath::sqrt(b[0] * b[0] + b[1] * b[1]);
        let (s, g) = sinc_terms(theta);
        let mut grad = [k_nmm * (b[0] - stored[0]), k_nmm * (b[1] - stored[1])];
        let mut h = [k_nmm, 0.0, k_nmm];
        for (i, &(rate, free)) in springs.iter().enumerate() {
            let c = direction(i);
            let arm = LENGTH_MM - RADIUS_MM * (c[0] * b[0] + c[1] * b[1]);
            let stretch = arm * s - free;
            if stretch <= 0.0 {
                continue;
            }
            let d = [
                -RADIUS_MM * c[0] * s + arm * g * b[0],
                -RADIUS_MM * c[1] * s + arm * g * b[1],
            ];
            grad[0] += rate * stretch * d[0];
            grad[1] += rate * stretch * d[1];
            h[0] += rate * d[0] * d[0];
            h[1] += rate * d[0] * d[1];
            h[2] += rate * d[1] * d[1];
        }
        let det = h[0] * h[2] - h[1] * h[1];
        if det.is_nan() || det <= 0.0 {
            break;
        }
        let step = [
            (h[2] * grad[0] - h[1] * grad[1]) / det,
            (h[0] * grad[1] - h[1] * grad[0]) / det,
        ];
        // At most 0.2 rad a step: the solve follows the column, it never jumps across.
        let len = crate::fmath::sqrt(step[0] * step[0] + step[1] * step[1]);
        let scale = if len > 0.2 { 0.2 / len } else { 1.0 };
        b = [b[0] - scale * step[0], b[1] - scale * step[1]];
    }
    b
}

/// Fixed-point rounds of [`Posture::form_aim_deg`].
const AIM_ROUNDS: usize = 4;
/// Gauss–Newton iterations of a rest bend (from the stored bend, or the last round's rest).
const REST_ITERATIONS: usize = 8;

/// The rest bend of a wall frozen about `stored_deg` along `u` with every spring martensite
/// ([`Posture::rest_deg`]): (its component along `u`, degrees; the bend vector, rad), solved
/// from `from` or the stored bend.
fn rest_along(u: [f32; 2], stored_deg: f32, from: Option<[f32; 2]>) -> (f32, [f32; 2]) {
    let stored = [
        u[0] * stored_deg.to_radians(),
        u[1] * stored_deg.to_radians(),
    ];
    let k = stiffness_nmm_per_rad(1.0);
    let mut b = from.unwrap_or(stored);
    for _ in 0..REST_ITERATIONS {
        b = equilibrium(&[0.0; SPRINGS], k, stored, b);
    }
    ((b[0] * u[0] + b[1] * u[1]).to_degrees(), b)
}

fn norm(v: [f32; 2]) -> f32 {
    crate::fmath::sqrt(v[0] * v[0] + v[1] * v[1])
}

impl Posture {
    /// Straight and relaxed, nothing yet known of the wall.
    pub const fn new() -> Posture {
        Posture {
            model_rad: [0.0; 2],
            stored_rad: [0.0; 2],
            frozen: f32::NAN,
            correction_deg: [0.0; 2],
            cov: [
                MODEL_SD_DEG * MODEL_SD_DEG,
                0.0,
                MODEL_SD_DEG * MODEL_SD_DEG,
            ],
        }
    }

    /// The estimated bend vector, degrees.
    fn vector_deg(&self) -> [f32; 2] {
        [
            self.model_rad[0].to_degrees() + self.correction_deg[0],
            self.model_rad[1].to_degrees() + self.correction_deg[1],
        ]
    }

    /// Predict over `dt` with the observer's estimate `e` (the springs' austenite fractions,
    /// the wall's frozen fraction).
    pub fn predict(&mut self, e: &Estimate, dt: Seconds) {
        let phi = e.frozen;
        if !phi.is_finite() || !e.austenite.iter().all(|a| a.is_finite()) {
            return;
        }
        // The stored bend: frozen in as the wall freezes, released as it softens.
        let b = self.vector_deg().map(f32::to_radians);
        if self.frozen.is_finite() {
            if phi > self.frozen {
                let d = phi - self.frozen;
                self.stored_rad = [self.stored_rad[0] + b[0] * d, self.stored_rad[1] + b[1] * d];
            } else if self.frozen > 0.0 {
                let r = phi / self.frozen;
                self.stored_rad = self.stored_rad.map(|s| s * r);
            }
        }
        self.frozen = phi;
        let next = equilibrium(
            &e.austenite,
            stiffness_nmm_per_rad(phi),
            self.stored_rad,
            self.model_rad,
        );
        if next.iter().all(|v| v.is_finite()) {
            self.model_rad = next;
        }
        // The correction decays; its covariance relaxes to the model's uncertainty.
        let dt_s = dt.s().max(0.0);
        let rho = libm::expf(-dt_s / CORRECTION_TAU_S);
        let m = self.model_cov();
        self.correction_deg = self.correction_deg.map(|c| c * rho);
        let r2 = rho * rho;
        for (p, q) in self.cov.iter_mut().zip(m) {
            *p = r2 * *p + (1.0 - r2) * q;
        }
    }

    /// The model's covariance (xx, xy, yy), deg²: [`PLANE_SD_DEG`] across the bend's plane,
    /// [`MODEL_SD_DEG`] + [`MODEL_SD_FRACTION`]·θ along it (the plane the model's when it
    /// pulls, else the estimate's; isotropic when straight).
    fn model_cov(&self) -> [f32; 3] {
        let model = self.model_rad.map(f32::to_degrees);
        let v = if norm(model) > 1.0 {
            model
        } else {
            self.vector_deg()
        };
        let theta = norm(v);
        let along = MODEL_SD_DEG + MODEL_SD_FRACTION * theta;
        if theta < 1.0 {
            return [along * along, 0.0, along * along];
        }
        let across = PLANE_SD_DEG * PLANE_SD_DEG;
        let extra = along * along - across;
        let u = [v[0] / theta, v[1] / theta];
        [
            across + extra * u[0] * u[0],
            extra * u[0] * u[1],
            across + extra * u[1] * u[1],
        ]
    }

    /// Correct with a frame's tilt: the camera measures the bend's component along its
    /// image's rows, twice the tilt; the rows lie at `azimuth_deg` from spring A (towards B;
    /// the `cam_azimuth_deg` setting), so the measurement is `b·(cos α, sin α)`.
    pub fn correct(&mut self, tilt: Tilt, azimuth_deg: f32) {
        let sd = (2.0 * tilt.sd_deg).max(2.0 * TILT_SD_FLOOR_DEG);
        let z = 2.0 * tilt.deg;
        if !(z.is_finite() && sd.is_finite() && azimuth_deg.is_finite()) {
            return;
        }
        let (s, c) = crate::fmath::sin_cos_turns(azimuth_deg / 360.0);
        let [pxx, pxy, pyy] = self.cov;
        // P·Hᵀ with H = (c, s); at α = 0 exactly the x-only update (c = 1, s = 0).
        let ph = [pxx * c + pxy * s, pxy * c + pyy * s];
        let innovation_var = c * ph[0] + s * ph[1] + sd * sd;
        let v = self.vector_deg();
        let innovation = z - (c * v[0] + s * v[1]);
        let (kx, ky) = (ph[0] / innovation_var, ph[1] / innovation_var);
        self.correction_deg[0] += kx * innovation;
        self.correction_deg[1] += ky * innovation;
        self.cov = [pxx - kx * ph[0], pxy - kx * ph[1], pyy - ky * ph[1]];
    }

    /// The estimated bend's plane from spring A, degrees (−180…180; 0 when straight).
    pub fn plane_deg_now(&self) -> f32 {
        let v = self.vector_deg();
        if norm(v) > 1e-3 {
            libm::atan2f(v[1], v[0]).to_degrees()
        } else {
            0.0
        }
    }

    /// The bend as estimated now.
    pub fn bend(&self) -> Bend {
        let v = self.vector_deg();
        let deg = norm(v);
        let [pxx, pxy, pyy] = self.cov;
        let var = if deg > 1e-3 {
            let u = [v[0] / deg, v[1] / deg];
            u[0] * u[0] * pxx + 2.0 * u[0] * u[1] * pxy + u[1] * u[1] * pyy
        } else {
            pxx.max(pyy)
        };
        Bend {
            deg,
            sd_deg: crate::fmath::sqrt(var.max(0.0)),
        }
    }

    /// The model's bend alone, degrees (no camera).
    pub fn model_deg(&self) -> f32 {
        norm(self.model_rad).to_degrees()
    }

    /// The bend a formed column comes to rest at once its springs have cooled, degrees (signed
    /// along the plane of `springs`): the wall frozen about `stored_deg` in that plane, every
    /// spring martensite. The springs on the bend's outside are stretched past their free
    /// length even as martensite: their pull springs the glassy wall back from its stored bend
    /// (about 6° at 30° with A and B) once the selected springs no longer pull against it.
    ///
    /// Springs cooled to a room above Mf (318 K) keep part of their austenite, which the
    /// observer's cooling branch would credit with holding some of the bend; measured, the
    /// formed bend springs back nearly as far there (aiming with the observer's rest fraction
    /// left a 20° pose with A and B 4.8° short at 318 K, against 0.2° without), so the rest is
    /// taken as martensite in every room (docs/posture.md).
    pub fn rest_deg(springs: SpringMask, stored_deg: f32) -> f32 {
        let u = Self::plane_unit(springs);
        rest_along(u, stored_deg, None).0
    }

    /// The bend to form `springs`' pose at — hold while the wall freezes, so the wall stores
    /// it — for the column to rest at `target_deg` once the springs have cooled
    /// ([`Posture::rest_deg`]), degrees: `target_deg` plus the spring-back, found by a few
    /// fixed-point rounds (the rest bend moves with the stored one almost one for one).
    pub fn form_aim_deg(springs: SpringMask, target_deg: f32) -> f32 {
        let u = Self::plane_unit(springs);
        let mut stored = target_deg;
        let mut from = None;
        for _ in 0..AIM_ROUNDS {
            let (rest, b) = rest_along(u, stored, from);
            if !rest.is_finite() {
                return target_deg;
            }
            stored += target_deg - rest;
            from = Some(b);
        }
        stored
    }

    /// The unit vector of the plane `springs` pull in (spring A's for none).
    fn plane_unit(springs: SpringMask) -> [f32; 2] {
        let mut v = [0.0f32; 2];
        for i in (0..SPRINGS).filter(|&i| springs.contains(i)) {
            let c = direction(i);
            v = [v[0] + c[0], v[1] + c[1]];
        }
        let n = norm(v);
        if n < 1e-3 {
            [1.0, 0.0]
        } else {
            [v[0] / n, v[1] / n]
        }
    }

    /// How far `springs`, fully austenite, bend the column from straight with the wall at
    /// frozen fraction `phi` and nothing stored, degrees: what a pose with them can reach.
    pub fn reach_deg(springs: SpringMask, phi: f32) -> f32 {
        let a: [f32; SPRINGS] =
            core::array::from_fn(|i| if springs.contains(i) { 1.0 } else { 0.0 });
        Self::reach_with_deg(&a, phi)
    }

    /// How far springs at these austenite fractions bend the column from straight with the
    /// wall at frozen fraction `phi` and nothing stored, degrees ([`Posture::reach_deg`] for
    /// springs that cannot become fully austenite: a supply too weak for it).
    pub fn reach_with_deg(a: &[f32; SPRINGS], phi: f32) -> f32 {
        let a = a.map(|x| {
            if x.is_finite() {
                x.clamp(0.0, 1.0)
            } else {
                0.0
            }
        });
        let k = stiffness_nmm_per_rad(phi);
        // From straight the first step's pull decides the direction; the solve is iterated
        // to convergence here (once per command).
        let mut b = [0.0; 2];
        for _ in 0..24 {
            b = equilibrium(&a, k, [0.0; 2], b);
        }
        norm(b).to_degrees()
    }

    /// The plane `springs` pull in, degrees from spring A (0 for none, or all three).
    pub fn plane_deg(springs: SpringMask) -> f32 {
        let u = Self::plane_unit(springs);
        libm::atan2f(u[1], u[0]).to_degrees()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observer::Observer;

    /// The observer's estimate at rest with these austenite fractions and frozen fraction.
    fn estimate(austenite: [f32; SPRINGS], frozen: f32) -> Estimate {
        let o = Observer::new(&crate::settings::Settings::DEFAULT.observer_params(), 298.0);
        Estimate {
            austenite,
            frozen,
            ..o.estimate()
        }
    }

    fn settle(p: &mut Posture, e: &Estimate) {
        for _ in 0..200 {
            p.predict(e, Seconds::from_ms(50));
        }
    }

    #[test]
    fn the_springs_bend_the_soft_column_in_their_plane() {
        let mut p = Posture::new();
        settle(&mut p, &estimate([1.0, 0.0, 0.0], 0.0));
        let b = p.bend();
        // One austenite spring against the rubbery lattice and the other two: ≈40°.
        assert!((30.0..55.0).contains(&b.deg), "{b:?}");
        assert!(p.plane_deg_now().abs() < 0.5, "{b:?}");
        assert!((Posture::reach_deg(SpringMask::from_bits(1), 0.0) - b.deg).abs() < 0.5);
        let mut p = Posture::new();
        settle(&mut p, &estimate([1.0, 1.0, 0.0], 0.0));
        let two = p.bend();
        assert!((p.plane_deg_now() - 60.0).abs() < 0.5, "{two:?}");
        assert!(two.deg > b.deg, "two springs bend further: {two:?} {b:?}");
        // Three equal pulls hold it straight; a glassy wall barely moves.
        let mut p = Posture::new();
        settle(&mut p, &estimate([1.0; SPRINGS], 0.0));
        assert!(p.bend().deg < 0.5, "{:?}", p.bend());
        let mut p = Posture::new();
        settle(&mut p, &estimate([1.0, 0.0, 0.0], 1.0));
        assert!(p.bend().deg < 0.75 * b.deg, "{:?}", p.bend());
        assert_eq!(Posture::plane_deg(SpringMask::from_bits(0b110)), 180.0);
    }

    #[test]
    fn a_bend_frozen_in_stays_when_the_springs_let_go() {
        let mut p = Posture::new();
        settle(&mut p, &estimate([1.0, 0.0, 0.0], 0.0));
        let bent = p.bend().deg;
        // Cool with the springs on: the wall locks the bend.
        for i in 0..=100 {
            p.predict(
                &estimate([1.0, 0.0, 0.0], i as f32 / 100.0),
                Seconds::from_ms(50),
            );
        }
        settle(&mut p, &estimate([0.0; SPRINGS], 1.0));
        let locked = p.bend().deg;
        assert!(
            locked > 0.6 * bent && locked <= bent + 0.5,
            "{locked} of {bent}"
        );
        // Reheated, the memory takes it back to straight.
        settle(&mut p, &estimate([0.0; SPRINGS], 0.0));
        assert!(p.bend().deg < 1.0, "{:?}", p.bend());
    }

    #[test]
    fn the_camera_corrects_along_the_plane_and_cannot_see_across_the_view() {
        // The model says ≈ 47° in spring A+B's plane (60°); the camera sees a tilt of 10°:
        // b_x = 20°, so the bend is 40° in that plane.
        let e = estimate([1.0, 1.0, 0.0], 0.0);
        let mut p = Posture::new();
        settle(&mut p, &e);
        let model = p.bend();
        for _ in 0..20 {
            p.predict(&e, Seconds::from_ms(250));
            p.correct(
                Tilt {
                    deg: 10.0,
                    sd_deg: 0.2,
                },
                0.0,
            );
        }
        let b = p.bend();
        assert!((b.deg - 40.0).abs() < 1.5, "{b:?} (model {model:?})");
        assert!((p.plane_deg_now() - 60.0).abs() < 2.0, "{b:?}");
        assert!(b.sd_deg < 0.5 * model.sd_deg, "{b:?} {model:?}");
        // A bend locked in a plane along the line of sight (≈90°): the camera sees only the
        // little of it that lies across the view, the estimate stays the model's and its
        // uncertainty near the model's.
        let mut p = Posture::new();
        p.stored_rad = [0.0, 30f32.to_radians()];
        p.frozen = 1.0;
        p.model_rad = p.stored_rad;
        let locked = estimate([0.0; SPRINGS], 1.0);
        settle(&mut p, &locked);
        let before = p.bend();
        let seen_deg = 0.5 * before.deg * p.plane_deg_now().to_radians().cos();
        for _ in 0..20 {
            p.predict(&locked, Seconds::from_ms(250));
            p.correct(
                Tilt {
                    deg: seen_deg,
                    sd_deg: 0.2,
                },
                0.0,
            );
        }
        let after = p.bend();
        assert!((after.deg - before.deg).abs() < 0.5, "{before:?} {after:?}");
        assert!(after.sd_deg > 0.6 * before.sd_deg, "{before:?} {after:?}");
        assert!(after.sd_deg > 2.0 * b.sd_deg, "{after:?} against {b:?}");
    }

    #[test]
    fn a_turned_camera_sees_the_plane_its_rows_lie_in() {
        // Springs A+B pull in the 60° plane; the model says ≈ 47°, the truth is 40°.
        let e = estimate([1.0, 1.0, 0.0], 0.0);
        let seen = |azimuth_deg: f32| {
            let mut p = Posture::new();
            settle(&mut p, &e);
            let model = p.bend();
            for _ in 0..20 {
                p.predict(&e, Seconds::from_ms(250));
                let deg = 0.5 * 40.0 * (60.0 - azimuth_deg).to_radians().cos();
                p.correct(Tilt { deg, sd_deg: 0.2 }, azimuth_deg);
            }
            (model, p.bend())
        };
        // Rows along the plane: the whole bend in view, better than at 0° (half of it).
        let (model, along) = seen(60.0);
        let (_, at_zero) = seen(0.0);
        assert!((along.deg - 40.0).abs() < 1.0, "{along:?}");
        assert!(along.sd_deg < at_zero.sd_deg, "{along:?} {at_zero:?}");
        // Rows across the plane (the plane along the line of sight): the model's bend and
        // about its uncertainty.
        let (_, blind) = seen(150.0);
        assert!((blind.deg - model.deg).abs() < 0.5, "{blind:?} {model:?}");
        assert!(blind.sd_deg > 0.8 * model.sd_deg, "{blind:?} {model:?}");
        // A mount the settings call −300° is the same as 60°.
        let (_, wrapped) = seen(-300.0);
        assert!(
            (wrapped.deg - along.deg).abs() < 1e-3,
            "{wrapped:?} {along:?}"
        );
    }

    #[test]
    fn a_formed_pose_aims_past_its_target_by_the_spring_back() {
        let ab = SpringMask::parse("AB").unwrap();
        let a = SpringMask::parse("A").unwrap();
        // The rest bend, solved to convergence, against the aim's few rounds.
        let converged = |springs: SpringMask, stored_deg: f32| {
            let u = Posture::plane_unit(springs);
            let (mut rest, mut from) = (0.0, None);
            for _ in 0..20 {
                let (r, b) = rest_along(u, stored_deg, from);
                (rest, from) = (r, Some(b));
            }
            rest
        };
        for (springs, target) in [(ab, 30.0), (ab, 10.0), (ab, 55.0), (a, 20.0)] {
            let aim = Posture::form_aim_deg(springs, target);
            let rest = converged(springs, aim);
            assert!(
                (rest - target).abs() < 0.1,
                "{springs}: aim {aim} rests at {rest}"
            );
            // Martensite springs on the outside pull the frozen wall back: a few degrees.
            assert!(
                aim > target + 0.5 && aim < target + 15.0,
                "{springs} {target}: {aim}"
            );
        }
        // Two springs bend in the plane the third opposes head on: more spring-back than one.
        let back = |s: SpringMask| Posture::form_aim_deg(s, 30.0) - 30.0;
        assert!(back(ab) > back(a), "{} {}", back(ab), back(a));
        assert!((Posture::rest_deg(ab, 30.0) - converged(ab, 30.0)).abs() < 0.1);
        assert!(Posture::form_aim_deg(ab, f32::NAN).is_nan());
    }

    #[test]
    fn nonsense_in_leaves_the_estimate_finite() {
        let mut p = Posture::new();
        p.predict(
            &estimate([f32::NAN; SPRINGS], f32::NAN),
            Seconds::from_ms(50),
        );
        p.correct(
            Tilt {
                deg: f32::INFINITY,
                sd_deg: 0.1,
            },
            0.0,
        );
        p.predict(&estimate([2.0, -1.0, 0.5], 3.0), Seconds::from_ms(50));
        let b = p.bend();
        assert!(b.deg.is_finite() && b.sd_deg.is_finite(), "{b:?}");
    }
}
