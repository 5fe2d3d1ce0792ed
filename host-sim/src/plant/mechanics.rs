//! Bending of the column: a constant-curvature column of length L with the three springs as
//! straight chords between the end plates, at radius r, 120° apart.
//!
//! The state is the bend vector b = θ·(cos ψ, sin ψ) (θ the bending angle, ψ the plane from
//! spring A). Spring i (direction c_i) has length ℓ_i = (L − r·c_i·b)·sinc(θ/2): the chord of an
//! arc at offset r·c_i·b/θ from the neutral axis. The equilibrium minimises
//! U(b) = ½K_f|b − p|² + ½K(T)|b − b_s|² + ½K₁'|b − q|² + Σ ½k_i·max(0, ℓ_i − ℓ0_i)²
//! (PI film about its plastic set p, relaxed SMP about its stored bend, Maxwell branch,
//! tension-only springs): the moment balance ∇U = 0. The film is elastic–perfectly plastic:
//! after a solve, `yield_film` moves p so that |b − p| ≤ θ_y (its 3 % yield strain). The chords' sinc term is the springs' axial load acting on the bent column
//! (its P-δ softening), which is what lets two springs bend further than one.

use super::params as p;
use super::sma;

/// The elastic parts the balance needs, frozen over one solve.
#[derive(Clone, Copy, Debug)]
pub struct Balance {
    /// PI heater film's elastic stiffness, N·mm/rad, about `film_set_rad`.
    pub film_nmm_per_rad: f64,
    /// PI heater film's plastic set, rad.
    pub film_set_rad: [f64; 2],
    /// SMP relaxed stiffness, N·mm/rad, about `stored_rad`.
    pub smp_nmm_per_rad: f64,
    /// SMP stored bend, rad.
    pub stored_rad: [f64; 2],
    /// Maxwell branch effective stiffness over the step, N·mm/rad, about `branch_rad`.
    pub branch_nmm_per_rad: f64,
    /// Maxwell branch dashpot position, rad.
    pub branch_rad: [f64; 2],
    /// Spring rates, N/mm.
    pub spring_k_n_per_mm: [f64; 3],
    /// Spring natural lengths, mm.
    pub spring_free_mm: [f64; 3],
}

/// Unit vector of spring `i` (A = 0°, B = 120°, C = 240°).
pub fn spring_direction(i: usize) -> [f64; 2] {
    let a = (i as f64 * p::SPRING_SPACING_DEG).to_radians();
    [a.cos(), a.sin()]
}

/// sinc(θ/2) and g(θ) = (d sinc(θ/2)/dθ)/θ, both smooth at θ = 0.
fn sinc_terms(theta: f64) -> (f64, f64) {
    let u = 0.5 * theta;
    if u < 1e-3 {
        let u2 = u * u;
        (1.0 - u2 / 6.0 + u2 * u2 / 120.0, -1.0 / 12.0 + u2 / 120.0)
    } else {
        let (s, c) = u.sin_cos();
        (s / u, (u * c - s) / (4.0 * u * u * u))
    }
}

/// Length of spring `i` at bend `b`, mm.
pub fn spring_length_mm(i: usize, b: [f64; 2]) -> f64 {
    let c = spring_direction(i);
    let theta = (b[0] * b[0] + b[1] * b[1]).sqrt();
    let (s, _) = sinc_terms(theta);
    (p::LENGTH_MM - p::SPRING_RADIUS_MM * (c[0] * b[0] + c[1] * b[1])) * s
}

impl Balance {
    /// Total elastic energy U(b), N·mm.
    pub fn energy(&self, b: [f64; 2]) -> f64 {
        let sq = |x: [f64; 2], y: [f64; 2]| (x[0] - y[0]).powi(2) + (x[1] - y[1]).powi(2);
        let mut u = 0.5 * self.film_nmm_per_rad * sq(b, self.film_set_rad)
            + 0.5 * self.smp_nmm_per_rad * sq(b, self.stored_rad)
            + 0.5 * self.branch_nmm_per_rad * sq(b, self.branch_rad);
        for i in 0..3 {
            let stretch = (spring_length_mm(i, b) - self.spring_free_mm[i]).max(0.0);
            u += 0.5 * self.spring_k_n_per_mm[i] * stretch * stretch;
        }
        u
    }

    /// Gradient ∇U(b) (the out-of-balance moment), N·mm.
    pub fn gradient(&self, b: [f64; 2]) -> [f64; 2] {
        let mut g = [0.0; 2];
        for k in 0..2 {
            g[k] = self.film_nmm_per_rad * (b[k] - self.film_set_rad[k])
                + self.smp_nmm_per_rad * (b[k] - self.stored_rad[k])
                + self.branch_nmm_per_rad * (b[k] - self.branch_rad[k]);
        }
        let theta = (b[0] * b[0] + b[1] * b[1]).sqrt();
        let (s, gs) = sinc_terms(theta);
        for i in 0..3 {
            let c = spring_direction(i);
            let arm = p::LENGTH_MM - p::SPRING_RADIUS_MM * (c[0] * b[0] + c[1] * b[1]);
            let stretch = (arm * s - self.spring_free_mm[i]).max(0.0);
            let force = self.spring_k_n_per_mm[i] * stretch;
            if force > 0.0 {
                for k in 0..2 {
                    g[k] += force * (-p::SPRING_RADIUS_MM * c[k] * s + arm * gs * b[k]);
                }
            }
        }
        g
    }

    /// The equilibrium bend nearest `start` (damped Newton on U with a finite-difference
    /// Hessian and a backtracking line search), rad.
    pub fn solve(&self, start: [f64; 2]) -> [f64; 2] {
        let mut b = start;
        let scale = self.film_nmm_per_rad + self.smp_nmm_per_rad + self.branch_nmm_per_rad;
        let mut u = self.energy(b);
        for _ in 0..50 {
            let g = self.gradient(b);
            let gn = (g[0] * g[0] + g[1] * g[1]).sqrt();
            if gn < 1e-10 * scale {
                break;
            }
            let eps = 1e-6;
            let mut h = [[0.0; 2]; 2];
            for j in 0..2 {
                let mut bp = b;
                let mut bm = b;
                bp[j] += eps;
                bm[j] -= eps;
                let gp = self.gradient(bp);
                let gm = self.gradient(bm);
                for i in 0..2 {
                    h[i][j] = (gp[i] - gm[i]) / (2.0 * eps);
                }
            }
            let sym = 0.5 * (h[0][1] + h[1][0]);
            h[0][1] = sym;
            h[1][0] = sym;
            // Make the Hessian positive definite if the straight column is at a saddle.
            let tr = h[0][0] + h[1][1];
            let det = h[0][0] * h[1][1] - sym * sym;
            let disc = (0.25 * tr * tr - det).max(0.0).sqrt();
            let lmin = 0.5 * tr - disc;
            let shift = if lmin < 0.05 * scale {
                0.05 * scale - lmin
            } else {
                0.0
            };
            h[0][0] += shift;
            h[1][1] += shift;
            let det = h[0][0] * h[1][1] - h[0][1] * h[1][0];
            let mut d = [
                -(h[1][1] * g[0] - h[0][1] * g[1]) / det,
                -(-h[1][0] * g[0] + h[0][0] * g[1]) / det,
            ];
            // Keep Newton steps within a quarter turn.
            let dn = (d[0] * d[0] + d[1] * d[1]).sqrt();
            if dn > 0.5 {
                d = [d[0] * 0.5 / dn, d[1] * 0.5 / dn];
            }
            let mut step = 1.0;
            let mut accepted = false;
            for _ in 0..30 {
                let trial = [b[0] + step * d[0], b[1] + step * d[1]];
                let ut = self.energy(trial);
                if ut <= u + 1e-4 * step * (g[0] * d[0] + g[1] * d[1]) {
                    b = trial;
                    u = ut;
                    accepted = true;
                    break;
                }
                step *= 0.5;
            }
            if !accepted || step * dn < 1e-13 {
                break;
            }
        }
        b
    }
}

/// Tension of each spring at bend `b`, N.
pub fn spring_forces_n(b: [f64; 2], k: [f64; 3], free_mm: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| k[i] * (spring_length_mm(i, b) - free_mm[i]).max(0.0))
}

/// The film's plastic set after the column reached `b`: p moves with b once |b − p| exceeds
/// the yield bend `yield_rad` (radial return), else it stays.
pub fn yield_film(set: [f64; 2], b: [f64; 2], yield_rad: f64) -> [f64; 2] {
    let d = [b[0] - set[0], b[1] - set[1]];
    let n = d[0].hypot(d[1]);
    if n <= yield_rad {
        set
    } else {
        let f = 1.0 - yield_rad / n;
        [set[0] + f * d[0], set[1] + f * d[1]]
    }
}

/// Spring rates and natural lengths for martensite fractions `xi`.
pub fn spring_state(xi: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let mut k = [0.0; 3];
    let mut l = [0.0; 3];
    for i in 0..3 {
        k[i] = sma::rate_n_per_mm(xi[i]);
        l[i] = sma::free_length_mm(xi[i]);
    }
    (k, l)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hot_column(xi: [f64; 3]) -> Balance {
        let (k, l) = spring_state(xi);
        Balance {
            film_nmm_per_rad: 20.0,
            film_set_rad: [0.0; 2],
            smp_nmm_per_rad: 290.0,
            stored_rad: [0.0; 2],
            branch_nmm_per_rad: 0.0,
            branch_rad: [0.0; 2],
            spring_k_n_per_mm: k,
            spring_free_mm: l,
        }
    }

    #[test]
    fn the_film_yields_past_its_yield_bend_and_keeps_the_set() {
        let p = yield_film([0.0; 2], [0.2, 0.0], 0.34);
        assert_eq!(p, [0.0; 2]);
        let p = yield_film([0.0; 2], [1.0, 0.0], 0.34);
        assert!((p[0] - 0.66).abs() < 1e-12 && p[1] == 0.0);
        // Back towards straight: elastic until the reverse yield.
        assert_eq!(yield_film(p, [0.4, 0.0], 0.34), p);
        let back = yield_film(p, [0.0, 0.0], 0.34);
        assert!((back[0] - 0.34).abs() < 1e-12);
    }

    #[test]
    fn cold_springs_leave_the_column_straight() {
        let b = hot_column([1.0; 3]).solve([0.0; 2]);
        assert!(b[0].abs() < 1e-9 && b[1].abs() < 1e-9);
    }

    #[test]
    fn a_hot_spring_bends_towards_itself_and_balances() {
        let bal = hot_column([1.0, 0.0, 1.0]);
        let b = bal.solve([0.0; 2]);
        let plane = b[1].atan2(b[0]).to_degrees();
        assert!((plane - 120.0).abs() < 1e-6, "{plane}");
        let g = bal.gradient(b);
        assert!(g[0].abs() < 1e-6 && g[1].abs() < 1e-6);
    }

    #[test]
    fn gradient_matches_finite_differences_of_energy() {
        let bal = hot_column([0.0, 0.3, 1.0]);
        let b = [0.4, -0.2];
        let g = bal.gradient(b);
        for k in 0..2 {
            let mut bp = b;
            let mut bm = b;
            bp[k] += 1e-6;
            bm[k] -= 1e-6;
            let fd = (bal.energy(bp) - bal.energy(bm)) / 2e-6;
            assert!(
                (fd - g[k]).abs() < 1e-5 * g[k].abs().max(1.0),
                "{fd} {}",
                g[k]
            );
        }
    }
}
