//! Small dense linear algebra for the thermal network (at most [`N`] nodes): a pivoted
//! Gaussian solve and the matrix exponential (scaling and squaring of a Taylor series) used for
//! the exact zero-order-hold update.

/// Largest network size.
pub const N: usize = 5;
/// A network matrix (only the leading `n × n` block is used).
pub type Mat = [[f64; N]; N];
/// A network vector (only the leading `n` entries are used).
pub type Vector = [f64; N];

const N2: usize = 2 * N;
type Mat2 = [[f64; N2]; N2];

/// Solve `a·x = b` in place (`b` becomes `x`) for the leading `n × n` block, with partial
/// pivoting. The network matrices (I − c·h·A) are strictly diagonally dominant, so no pivot is
/// ever zero; a zero pivot leaves that unknown at zero rather than dividing by it.
pub fn solve(a: &Mat, b: &mut Vector, n: usize) {
    let mut m = *a;
    for k in 0..n {
        let mut p = k;
        for i in k + 1..n {
            if m[i][k].abs() > m[p][k].abs() {
                p = i;
            }
        }
        if p != k {
            m.swap(p, k);
            b.swap(p, k);
        }
        let pivot = m[k][k];
        if pivot == 0.0 {
            continue;
        }
        for i in k + 1..n {
            let f = m[i][k] / pivot;
            if f != 0.0 {
                for j in k..n {
                    m[i][j] -= f * m[k][j];
                }
                b[i] -= f * b[k];
            }
        }
    }
    for k in (0..n).rev() {
        let mut s = b[k];
        for j in k + 1..n {
            s -= m[k][j] * b[j];
        }
        b[k] = if m[k][k] == 0.0 { 0.0 } else { s / m[k][k] };
    }
}

fn matmul(a: &Mat2, b: &Mat2, n: usize) -> Mat2 {
    let mut c = [[0.0; N2]; N2];
    for i in 0..n {
        for k in 0..n {
            let aik = a[i][k];
            if aik != 0.0 {
                for j in 0..n {
                    c[i][j] += aik * b[k][j];
                }
            }
        }
    }
    c
}

/// The exact zero-order-hold matrices of `dx/dt = A·x + u` over `h`: `Φ = e^{A·h}` and
/// `Γ = ∫₀ʰ e^{A·s} ds`, so that `x(h) = Φ·x(0) + Γ·u` for constant `u`. Computed as the
/// exponential of the augmented matrix `[[A·h, I·h], [0, 0]]` by scaling to norm ≤ 1/2, a
/// degree-14 Taylor series (truncation < 1e-17) and squaring.
pub fn zoh(a: &Mat, n: usize, h: f64) -> (Mat, Mat) {
    let m = 2 * n;
    let mut x = [[0.0; N2]; N2];
    for i in 0..n {
        for j in 0..n {
            x[i][j] = a[i][j] * h;
        }
        x[i][n + i] = h;
    }
    let norm = (0..m)
        .map(|i| (0..m).map(|j| x[i][j].abs()).sum::<f64>())
        .fold(0.0, f64::max);
    let mut squarings = 0u32;
    let mut scale = 1.0;
    while norm * scale > 0.5 && squarings < 60 {
        scale *= 0.5;
        squarings += 1;
    }
    for row in x.iter_mut().take(m) {
        for v in row.iter_mut().take(m) {
            *v *= scale;
        }
    }
    // Horner: e^X ≈ I + X(I + X/2(I + X/3(...))).
    let mut e = [[0.0; N2]; N2];
    for (i, row) in e.iter_mut().enumerate().take(m) {
        row[i] = 1.0;
    }
    for k in (1..=14).rev() {
        let mut t = matmul(&x, &e, m);
        for (i, row) in t.iter_mut().enumerate().take(m) {
            for v in row.iter_mut().take(m) {
                *v /= k as f64;
            }
            row[i] += 1.0;
        }
        e = t;
    }
    for _ in 0..squarings {
        e = matmul(&e, &e, m);
    }
    let mut phi = [[0.0; N]; N];
    let mut gamma = [[0.0; N]; N];
    for i in 0..n {
        for j in 0..n {
            phi[i][j] = e[i][j];
            gamma[i][j] = e[i][n + j];
        }
    }
    (phi, gamma)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solve_matches_a_known_system() {
        let mut a = [[0.0; N]; N];
        a[0] = [0.0, 2.0, 1.0, 0.0, 0.0];
        a[1] = [1.0, 1.0, 0.0, 0.0, 0.0];
        a[2] = [3.0, 0.0, 1.0, 0.0, 0.0];
        // x = (1, 2, 3)
        let mut b = [7.0, 3.0, 6.0, 0.0, 0.0];
        solve(&a, &mut b, 3);
        for (got, want) in b.iter().zip([1.0, 2.0, 3.0]) {
            assert!((got - want).abs() < 1e-12, "{b:?}");
        }
    }

    #[test]
    fn zoh_of_a_scalar_is_the_exponential() {
        let mut a = [[0.0; N]; N];
        a[0][0] = -40.0;
        let (phi, gamma) = zoh(&a, 1, 0.5);
        assert!((phi[0][0] - (-20.0f64).exp()).abs() < 1e-15);
        let want = (1.0 - (-20.0f64).exp()) / 40.0;
        assert!((gamma[0][0] - want).abs() < 1e-14 * want.abs().max(1.0));
    }

    #[test]
    fn zoh_of_a_rotation_is_cos_sin() {
        let mut a = [[0.0; N]; N];
        a[0][1] = 1.0;
        a[1][0] = -1.0;
        let (phi, _) = zoh(&a, 2, 1.3);
        assert!((phi[0][0] - 1.3f64.cos()).abs() < 1e-13);
        assert!((phi[0][1] - 1.3f64.sin()).abs() < 1e-13);
    }
}
