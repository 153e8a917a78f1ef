//! An independent check of [`crate::segmented`]: Hermite-cubic Euler–Bernoulli finite elements
//! (consistent mass), clamped at the hub, tip mass and rotary inertia lumped on the tip node.
//! The mesh follows the segment boundaries. Used by the tests; also handy to cross-check a
//! design from the command line.

use crate::segmented::{BeamError, Segment};
use nalgebra::{DMatrix, SymmetricEigen};

/// Result of a finite-element modal analysis.
#[derive(Clone, Debug)]
pub struct FemModes {
    /// Angular frequencies [rad/s], ascending.
    pub omega: Vec<f64>,
    /// Node positions [m] (hub excluded: it is clamped).
    pub nodes: Vec<f64>,
    /// Per mode, `(w, w')` at every node, unit modal mass, sign `w'` at the first node > 0.
    pub shapes: Vec<Vec<(f64, f64)>>,
}

impl FemModes {
    /// `w'` of mode `j` at the node nearest `x`.
    pub fn slope_at(&self, j: usize, x: f64) -> f64 {
        if x <= 0.0 {
            return 0.0;
        }
        let i = self
            .nodes
            .iter()
            .enumerate()
            .fold((0, f64::INFINITY), |(bi, bd), (i, n)| {
                let d = (n - x).abs();
                if d < bd { (i, d) } else { (bi, bd) }
            })
            .0;
        self.shapes
            .get(j)
            .and_then(|s| s.get(i))
            .map_or(f64::NAN, |p| p.1)
    }
}

/// Modes of the beam `segments` with about `elements` elements in all.
pub fn fem_modes(
    segments: &[Segment],
    tip_mass: f64,
    tip_inertia: f64,
    elements: usize,
    count: usize,
) -> Result<FemModes, BeamError> {
    let total: f64 = segments.iter().map(|s| s.length).sum();
    let mut els: Vec<(f64, Segment)> = Vec::new();
    for s in segments.iter().filter(|s| s.length > 1e-9) {
        let n = ((s.length / total) * elements as f64).round().max(1.0) as usize;
        for _ in 0..n {
            els.push((s.length / n as f64, *s));
        }
    }
    let nn = els.len(); // free nodes
    let dof = 2 * nn;
    let mut k = DMatrix::<f64>::zeros(dof, dof);
    let mut m = DMatrix::<f64>::zeros(dof, dof);
    for (e, (h, s)) in els.iter().enumerate() {
        let h = *h;
        let ke = [
            [12.0, 6.0 * h, -12.0, 6.0 * h],
            [6.0 * h, 4.0 * h * h, -6.0 * h, 2.0 * h * h],
            [-12.0, -6.0 * h, 12.0, -6.0 * h],
            [6.0 * h, 2.0 * h * h, -6.0 * h, 4.0 * h * h],
        ];
        let me = [
            [156.0, 22.0 * h, 54.0, -13.0 * h],
            [22.0 * h, 4.0 * h * h, 13.0 * h, -3.0 * h * h],
            [54.0, 13.0 * h, 156.0, -22.0 * h],
            [-13.0 * h, -3.0 * h * h, -22.0 * h, 4.0 * h * h],
        ];
        let (kf, mf) = (s.ei / h.powi(3), s.rho_a * h / 420.0);
        // Global dof of local dof a: node e (left) and e+1 (right); node 0 is clamped.
        let g = |a: usize| -> Option<usize> { (2 * e + a).checked_sub(2) };
        for a in 0..4 {
            for b in 0..4 {
                if let (Some(i), Some(j)) = (g(a), g(b)) {
                    k[(i, j)] += kf * ke[a][b];
                    m[(i, j)] += mf * me[a][b];
                }
            }
        }
    }
    m[(dof - 2, dof - 2)] += tip_mass;
    m[(dof - 1, dof - 1)] += tip_inertia;
    // Flexibility form: with K = L Lᵀ, the eigenvalues of L⁻¹ M L⁻ᵀ are 1/ω², the largest
    // for the lowest modes, so those are resolved to full precision however fine the mesh
    // (the stiffness form loses them to round-off as the mesh is refined).
    let chol = k
        .clone()
        .cholesky()
        .ok_or_else(|| BeamError::InvalidData("stiffness matrix not positive definite".into()))?;
    let linv = chol
        .l()
        .try_inverse()
        .ok_or_else(|| BeamError::InvalidData("singular stiffness factor".into()))?;
    let a = &linv * &m * linv.transpose();
    let a = (&a + a.transpose()) * 0.5;
    let eig = SymmetricEigen::new(a);
    let mut order: Vec<usize> = (0..dof).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
    let mut nodes = Vec::with_capacity(nn);
    let mut x = 0.0;
    for (h, _) in &els {
        x += h;
        nodes.push(x);
    }
    let mut omega = Vec::new();
    let mut shapes = Vec::new();
    for &i in order.iter().take(count) {
        omega.push(1.0 / eig.eigenvalues[i].max(f64::MIN_POSITIVE).sqrt());
        let y = eig.eigenvectors.column(i);
        let v = linv.transpose() * y;
        let mm = (v.transpose() * &m * &v)[(0, 0)];
        let sign = if v[1] >= 0.0 { 1.0 } else { -1.0 } / mm.sqrt();
        shapes.push(
            (0..nn)
                .map(|n| (sign * v[2 * n], sign * v[2 * n + 1]))
                .collect(),
        );
    }
    Ok(FemModes {
        omega,
        nodes,
        shapes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::section::Layers;
    use crate::segmented::SegmentedBeam;

    fn patched(x_a: f64, l_a: f64) -> Vec<Segment> {
        let l = Layers::default();
        let (b, p) = (l.bare(), l.patched());
        let seg = |len: f64, s: crate::section::Section| Segment {
            length: len,
            ei: s.ei,
            rho_a: s.rho_a,
        };
        vec![seg(x_a, b), seg(l_a, p), seg(0.7 - x_a - l_a, b)]
    }

    #[test]
    #[allow(clippy::needless_range_loop)]
    fn fem_agrees_with_exact_segmented_modes() {
        for (x_a, l_a, tip_m, tip_j) in [
            (0.09, 0.35, 0.0, 0.0),
            (0.0, 0.2, 0.0, 0.0),
            (0.5, 0.2, 0.01, 0.0),
            (0.2, 0.1, 0.02, 1e-5),
        ] {
            let segs = patched(x_a, l_a);
            let exact = SegmentedBeam::new(&segs, tip_m, tip_j)
                .and_then(|b| b.modes(3))
                .unwrap_or_default();
            let fem = fem_modes(&segs, tip_m, tip_j, 70, 3);
            let Ok(fem) = fem else {
                unreachable!("FEM failed")
            };
            assert_eq!(exact.len(), 3);
            for j in 0..3 {
                let rel = (fem.omega[j] / exact[j].omega - 1.0).abs();
                assert!(rel < 2e-7, "case ({x_a},{l_a}) mode {j}: rel {rel}");
                // Slopes at the patch ends (mesh nodes), and the slope difference.
                for x in [x_a, x_a + l_a, 0.7] {
                    let (e, f) = (exact[j].slope(x), fem.slope_at(j, x));
                    assert!(
                        (e - f).abs() < 1e-5 * exact[j].slope(0.7).abs().max(1.0),
                        "case ({x_a},{l_a}) mode {j} x {x}: {e} vs {f}"
                    );
                }
            }
        }
    }

    #[test]
    fn bracketing_never_skips_a_root() {
        // High-contrast patches (a 3 mm ceramic: EI × 60, ρA × 13), a tip mass ten times the
        // beam's and a rotary inertia, over a spread of patches: the exact solver's first four
        // frequencies must be the FEM's first four, in order (a skipped pair of roots would
        // shift the list).
        let mut layers = Layers::default();
        layers.material.t_c = 3e-3;
        let (b, p) = (layers.bare(), layers.patched());
        let seg = |len: f64, s: crate::section::Section| Segment {
            length: len,
            ei: s.ei,
            rho_a: s.rho_a,
        };
        let beam_mass = b.rho_a * 0.7;
        for (k, &(x_a, l_a)) in [
            (0.0, 0.05),
            (0.0, 0.7),
            (0.3, 0.01),
            (0.1, 0.5),
            (0.6, 0.1),
            (0.33, 0.21),
        ]
        .iter()
        .enumerate()
        {
            let (tm, tj) = if k % 2 == 0 {
                (10.0 * beam_mass, 0.0)
            } else {
                (0.0, 1e-4)
            };
            let segs = [seg(x_a, b), seg(l_a, p), seg(0.7 - x_a - l_a, b)];
            let exact = SegmentedBeam::new(&segs, tm, tj)
                .and_then(|bm| bm.frequencies(4))
                .unwrap_or_default();
            let Ok(fem) = fem_modes(&segs, tm, tj, 56, 4) else {
                unreachable!("FEM failed")
            };
            assert_eq!(exact.len(), 4);
            for (e, f) in exact.iter().zip(&fem.omega) {
                assert!((f / e - 1.0).abs() < 1e-4, "({x_a}, {l_a}): {e} vs {f}");
            }
        }
    }
}

#[cfg(test)]
mod payload_range {
    use super::*;
    use crate::config::{MAX_TIP_INERTIA_RATIO, MAX_TIP_MASS_RATIO};
    use crate::section::Layers;
    use crate::segmented::SegmentedBeam;

    /// The exact solution's root bracketing holds up to the largest payload the configuration
    /// accepts (`config::MAX_TIP_MASS_RATIO` times the bare beam's mass, and a rotary inertia
    /// up to `MAX_TIP_INERTIA_RATIO` times its `m L²`): the same first four frequencies, in
    /// order, as the finite elements, with the patch at several places.
    #[test]
    fn the_largest_accepted_payload_keeps_every_root() {
        let layers = Layers::default();
        let (b, p) = (layers.bare(), layers.patched());
        let seg = |len: f64, s: crate::section::Section| Segment {
            length: len,
            ei: s.ei,
            rho_a: s.rho_a,
        };
        let m = b.rho_a * 0.7;
        for (tm, tj) in [
            (MAX_TIP_MASS_RATIO * m, 0.0),
            (0.0, MAX_TIP_INERTIA_RATIO * m * 0.49),
            (MAX_TIP_MASS_RATIO * m, MAX_TIP_INERTIA_RATIO * m * 0.49),
        ] {
            for &(x_a, l_a) in &[(0.0, 0.3), (0.2, 0.3), (0.5, 0.2)] {
                let segs = [seg(x_a, b), seg(l_a, p), seg(0.7 - x_a - l_a, b)];
                let exact = SegmentedBeam::new(&segs, tm, tj)
                    .and_then(|bm| bm.frequencies(4))
                    .unwrap_or_default();
                let Ok(fem) = fem_modes(&segs, tm, tj, 70, 4) else {
                    unreachable!("FEM failed")
                };
                assert_eq!(exact.len(), 4, "tip {tm} kg, {tj} kg m²");
                for (e, f) in exact.iter().zip(&fem.omega) {
                    assert!(
                        (f / e - 1.0).abs() < 1e-4,
                        "tip {tm} kg, {tj} kg m², patch ({x_a}, {l_a}): {e} vs {f}"
                    );
                }
            }
        }
    }
}
