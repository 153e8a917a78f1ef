//! The Lyapunov equation of the closed modal loop (Eqs. 26–33).
//!
//! For `ż = H z` the quadratic cost `∫₀^∞ zᵀ Q z dt = z₀ᵀ P z₀` holds with
//! `Hᵀ P + P H = −Q` (the paper prints `H P + P H = −Q`, which is a different equation unless
//! `H` is symmetric: notes §3). Solved here as a dense linear system: the Kronecker form
//! `(I ⊗ Hᵀ + Hᵀ ⊗ I) vec(P) = −vec(Q)` restricted to the `n(n+1)/2` unknowns `p_ij, i ≤ j` of
//! the symmetric `P` (valid for symmetric `Q`, which makes `P` symmetric), one equation per
//! `i ≤ j`: a 10 × 10 LU solve for two modes instead of 16 × 16.

use nalgebra::DMatrix;

/// Solves `Hᵀ P + P H = −Q` for symmetric `Q` (an asymmetric `Q` is replaced by its symmetric
/// part, which gives the same quadratic form). `None` if the operator is singular, which
/// happens exactly when `H` has two eigenvalues summing to zero (for instance an undamped mode).
pub fn solve_lyapunov(h: &DMatrix<f64>, q: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let n = h.nrows();
    if h.ncols() != n || q.nrows() != n || q.ncols() != n {
        return None;
    }
    // Unknown p_ij (i ≤ j) at index idx(i, j); P[(k, l)] = p[idx(min, max)].
    let idx = |i: usize, j: usize| {
        let (a, b) = if i <= j { (i, j) } else { (j, i) };
        a * n - a * (a + 1) / 2 + b
    };
    let m = n * (n + 1) / 2;
    let mut a = DMatrix::<f64>::zeros(m, m);
    let mut rhs = DMatrix::<f64>::zeros(m, 1);
    // (Hᵀ P + P H)[(i, j)] = Σ_k H[(k, i)] P[(k, j)] + Σ_k P[(i, k)] H[(k, j)] = −Q[(i, j)].
    for i in 0..n {
        for j in i..n {
            let row = idx(i, j);
            for k in 0..n {
                a[(row, idx(k, j))] += h[(k, i)];
                a[(row, idx(i, k))] += h[(k, j)];
            }
            rhs[(row, 0)] = -0.5 * (q[(i, j)] + q[(j, i)]);
        }
    }
    let x = a.lu().solve(&rhs)?;
    let p = DMatrix::from_fn(n, n, |i, j| x[(idx(i, j), 0)]);
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

    #[test]
    fn larger_system_residual() {
        // 6 × 6 (three modes): a stable, non-normal H and a semidefinite Q.
        let n = 6;
        let h = DMatrix::from_fn(n, n, |i, j| {
            if i == j {
                -1.0 - 0.3 * i as f64
            } else {
                (((i * 7 + j * 3) % 5) as f64 - 2.0) * 0.4
            }
        });
        let c = DMatrix::from_fn(n, 1, |i, _| (i as f64 - 2.5) * 0.7);
        let q = &c * c.transpose();
        let Some(p) = solve_lyapunov(&h, &q) else {
            unreachable!("stable H")
        };
        assert!(residual(&h, &p, &q) < 1e-12, "{}", residual(&h, &p, &q));
        // P is positive semidefinite: zᵀ P z = ∫ (cᵀ z)² ≥ 0.
        let eig = p.clone().symmetric_eigen();
        assert!(eig.eigenvalues.iter().all(|&l| l > -1e-12));
    }
}
