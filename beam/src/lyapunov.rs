//! The Lyapunov equation of the closed modal loop (Eqs. 26–33).
//!
//! For `ż = H z` the quadratic cost `∫₀^∞ zᵀ Q z dt = z₀ᵀ P z₀` holds with
//! `Hᵀ P + P H = −Q` (the paper prints `H P + P H = −Q`, which is a different equation unless
//! `H` is symmetric: notes §3). Solved here as a dense linear system in `vec(P)`:
//! `(I ⊗ Hᵀ + Hᵀ ⊗ I) vec(P) = −vec(Q)` (column-major `vec`), an `n² × n²` LU solve, 16 × 16
//! for two modes. The result is symmetrized (it is symmetric in exact arithmetic).

use nalgebra::DMatrix;

/// Solves `Hᵀ P + P H = −Q`. `None` if the Kronecker operator is singular, which happens
/// exactly when `H` has two eigenvalues summing to zero (for instance an undamped mode).
pub fn solve_lyapunov(h: &DMatrix<f64>, q: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let n = h.nrows();
    if h.ncols() != n || q.nrows() != n || q.ncols() != n {
        return None;
    }
    let nn = n * n;
    let mut a = DMatrix::<f64>::zeros(nn, nn);
    // vec index of P[(i, j)] is i + n j.
    // (Hᵀ P)[(i, j)] = Σ_k H[(k, i)] P[(k, j)];  (P H)[(i, j)] = Σ_k P[(i, k)] H[(k, j)].
    for j in 0..n {
        for i in 0..n {
            let row = i + n * j;
            for k in 0..n {
                a[(row, k + n * j)] += h[(k, i)];
                a[(row, i + n * k)] += h[(k, j)];
            }
        }
    }
    let b = DMatrix::from_iterator(nn, 1, q.iter().map(|x| -x));
    let x = a.lu().solve(&b)?;
    let p = DMatrix::from_iterator(n, n, x.iter().copied());
    let p = (&p + p.transpose()) * 0.5;
    p.iter().all(|v| v.is_finite()).then_some(p)
}

/// `‖Hᵀ P + P H + Q‖_F / ‖Q‖_F`.
pub fn residual(h: &DMatrix<f64>, p: &DMatrix<f64>, q: &DMatrix<f64>) -> f64 {
    let r = h.transpose() * p + p * h + q;
    r.norm() / q.norm().max(f64::MIN_POSITIVE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalar_case() {
        // ẋ = −a x, cost ∫ q x² = q x₀² / (2a).
        let h = DMatrix::from_element(1, 1, -3.0);
        let q = DMatrix::from_element(1, 1, 2.0);
        let p = solve_lyapunov(&h, &q).unwrap_or_else(|| DMatrix::zeros(1, 1));
        assert!((p[(0, 0)] - 2.0 / 6.0).abs() < 1e-15);
    }

    #[test]
    fn nonsymmetric_h_solves_the_transposed_equation() {
        let h = DMatrix::from_row_slice(3, 3, &[-1.0, 4.0, 0.0, -2.0, -0.5, 1.0, 0.3, 0.0, -2.0]);
        let q = DMatrix::from_row_slice(3, 3, &[2.0, 0.5, 0.0, 0.5, 1.0, 0.1, 0.0, 0.1, 3.0]);
        let Some(p) = solve_lyapunov(&h, &q) else {
            unreachable!("stable H")
        };
        assert!(residual(&h, &p, &q) < 1e-13);
        // The untransposed equation is not satisfied by the same P.
        let wrong = (&h * &p + &p * &h + &q).norm() / q.norm();
        assert!(wrong > 1e-2, "{wrong}");
    }

    #[test]
    fn undamped_is_singular() {
        let h = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -4.0, 0.0]);
        let q = DMatrix::identity(2, 2);
        assert!(solve_lyapunov(&h, &q).is_none());
    }
}
