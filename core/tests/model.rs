//! Physics invariants of the arm model (f64 and f32).

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)] // tests may index and unwrap

use flexarm_core::model::Model;
use flexarm_core::modes::UniformMode;
use flexarm_core::params::ArmParams;
use flexarm_core::{Matrix4, Vector4};
use proptest::prelude::*;

fn model() -> Model<f64> {
    Model::new(ArmParams::default())
}

/// States over the whole joint range and deflections well beyond what the arm sees
/// (|δ| = 0.2 √kg·m is a tip deflection of about 0.7 m).
fn state() -> impl Strategy<Value = (Vector4<f64>, Vector4<f64>)> {
    let q = (-6.3..6.3, -6.3..6.3, -0.2..0.2, -0.2..0.2f64);
    let qd = (-10.0..10.0, -10.0..10.0, -5.0..5.0, -5.0..5.0f64);
    (q, qd).prop_map(|(q, qd)| {
        (
            Vector4::new(q.0, q.1, q.2, q.3),
            Vector4::new(qd.0, qd.1, qd.2, qd.3),
        )
    })
}

/// Composite Simpson's rule of `f` over `[0, b]` with `n` (even) intervals.
fn simpson(f: &dyn Fn(f64) -> f64, b: f64, n: usize) -> f64 {
    let h = b / n as f64;
    let weight = |i: usize| {
        if i == 0 || i == n {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        }
    };
    (0..=n).map(|i| weight(i) * f(i as f64 * h)).sum::<f64>() * h / 3.0
}

/// `Ḃ = dB(q + h q̇)/dh` by central differences.
fn b_dot(m: &Model<f64>, q: &Vector4<f64>, qd: &Vector4<f64>) -> Matrix4<f64> {
    let h = 1e-6;
    (m.inertia(&(q + qd * h)) - m.inertia(&(q - qd * h))) / (2.0 * h)
}

#[test]
fn inertia_at_rest_matches_hand_derivation() {
    // With the paper's parameters and uniform clamped-free unit-modal-mass modes:
    //   A  = I_h1 + I_1 + m1 a1²/4 + (m_h2 + m2) a1² = 0.23 + 0.17 + 0.0045 + 0.117 = 0.5215
    //   J0 = I_h2 + m2 a2²/3 = 0.198 + 0.049 = 0.247
    //   h0 = a1 m2 a2/2 = 0.0315
    //   v_j = √m2 · 2σ_j/β_j = (0.428862, 0.237676),  w_j = √m2 a2 · 2/β_j² = (0.218091, 0.034801)
    // so b11 = A + J0 + 2 h0 = 0.8315, b12 = J0 + h0 = 0.2785, b22 = 0.247,
    //    b13 = a1 v1 + w1 = 0.346750, b14 = a1 v2 + w2 = 0.106103, b23 = w1, b24 = w2, B_δδ = I.
    let b = model().inertia(&Vector4::zeros());
    let expect = Matrix4::new(
        0.8315, 0.2785, 0.346750, 0.106103, //
        0.2785, 0.247, 0.218091, 0.034801, //
        0.346750, 0.218091, 1.0, 0.0, //
        0.106103, 0.034801, 0.0, 1.0,
    );
    assert!((b - expect).abs().max() < 2e-6, "B(0) = {b}");
}

#[test]
fn uniform_modes_have_unit_modal_mass_and_closed_form_integrals() {
    let (m2, a2) = (0.3, 0.7);
    let rho = m2 / a2;
    let modes = [UniformMode::new(0, m2, a2), UniformMode::new(1, m2, a2)];
    let simpson = |f: &dyn Fn(f64) -> f64| simpson(f, a2, 2000);
    for (j, m) in modes.iter().enumerate() {
        assert!(
            m.phi(0.0).abs() < 1e-12 && m.slope(0.0).abs() < 1e-12,
            "clamped at the hub"
        );
        let mass = simpson(&|x| rho * m.phi(x) * m.phi(x));
        assert!((mass - 1.0).abs() < 1e-8, "mode {j}: modal mass {mass}");
        assert!((simpson(&|x| rho * m.phi(x)) - m.mass_integral()).abs() < 1e-8);
        assert!((simpson(&|x| rho * x * m.phi(x)) - m.moment_integral()).abs() < 1e-8);
        // Slope is the derivative of the shape.
        let x = 0.41;
        let fd = (m.phi(x + 1e-6) - m.phi(x - 1e-6)) / 2e-6;
        assert!((fd - m.slope(x)).abs() < 1e-6 * m.slope(x).abs().max(1.0));
    }
    let cross = simpson(&|x| rho * modes[0].phi(x) * modes[1].phi(x));
    assert!(cross.abs() < 1e-8, "modes orthogonal, got {cross}");
}

/// Kinetic energy computed from the velocity field of the arm, independently of `B`: every
/// point's velocity by central differences of its position along `q + h q̇`, link 2 integrated
/// by Simpson's rule.
fn kinetic_energy_by_quadrature(p: &ArmParams<f64>, q: &Vector4<f64>, qd: &Vector4<f64>) -> f64 {
    let modes = [
        UniformMode::new(0, p.m2, p.a2),
        UniformMode::new(1, p.m2, p.a2),
    ];
    let h = 1e-6;
    let point = |q: &Vector4<f64>, x: f64| {
        let (th1, alpha) = (q[0], q[0] + q[1]);
        let w = modes[0].phi(x) * q[2] + modes[1].phi(x) * q[3];
        let (s, c) = alpha.sin_cos();
        [
            p.a1 * th1.cos() + c * x - s * w,
            p.a1 * th1.sin() + s * x + c * w,
        ]
    };
    let speed2 = |x: f64| {
        let (a, b) = (point(&(q + qd * h), x), point(&(q - qd * h), x));
        ((a[0] - b[0]) / (2.0 * h)).powi(2) + ((a[1] - b[1]) / (2.0 * h)).powi(2)
    };
    let link2 = simpson(&speed2, p.a2, 400) * (p.m2 / p.a2);
    let hub1 = p.i_h1 + p.i_1 + p.m1 * p.a1 * p.a1 / 4.0 + p.m_h2 * p.a1 * p.a1;
    0.5 * (hub1 * qd[0] * qd[0] + (p.i_h2 + p.i_2_extra) * (qd[0] + qd[1]).powi(2) + link2)
}

proptest! {
    #[test]
    fn inertia_matches_the_kinetic_energy_of_the_velocity_field((q, qd) in state()) {
        let p = ArmParams::default();
        let t_b = Model::new(p).kinetic_energy(&q, &qd);
        let t_q = kinetic_energy_by_quadrature(&p, &q, &qd);
        prop_assert!((t_b - t_q).abs() < 1e-6 * (1.0 + t_q), "{} vs {}", t_b, t_q);
    }

    #[test]
    fn inertia_is_symmetric_positive_definite((q, _qd) in state()) {
        let b = model().inertia(&q);
        prop_assert_eq!(b, b.transpose());
        let eig = b.symmetric_eigenvalues();
        prop_assert!(eig.min() > 1e-3, "eigenvalues {}", eig);
    }

    #[test]
    fn b_dot_minus_two_c_is_skew_symmetric((q, qd) in state()) {
        let m = model();
        let n = b_dot(&m, &q, &qd) - m.coriolis(&q, &qd) * 2.0;
        // Central differences of B are exact to ~1e-9 here; B is O(1).
        prop_assert!((n + n.transpose()).abs().max() < 1e-6, "N + Nᵀ = {}", n + n.transpose());
    }

    /// `C q̇` is the Lagrangian's velocity term: `d/dt(∂T/∂q̇) − ∂T/∂q = B q̈ + Ḃ q̇ − ½ ∇_q(q̇ᵀBq̇)`.
    /// (Skew symmetry alone would also accept the wrong `C = ½Ḃ`.)
    #[test]
    fn coriolis_vector_follows_euler_lagrange((q, qd) in state()) {
        let m = model();
        let h = 1e-6;
        let mut grad = Vector4::zeros();
        for k in 0..4 {
            let mut e = Vector4::zeros();
            e[k] = h;
            let t = |q: &Vector4<f64>| qd.dot(&(m.inertia(q) * qd));
            grad[k] = (t(&(q + e)) - t(&(q - e))) / (2.0 * h);
        }
        let expect = b_dot(&m, &q, &qd) * qd - grad * 0.5;
        let got = m.coriolis(&q, &qd) * qd;
        prop_assert!((got - expect).abs().max() < 1e-6 * (1.0 + expect.abs().max()), "{} vs {}", got, expect);
    }

    #[test]
    fn sparse_coriolis_product_equals_the_matrix((q, qd) in state(), v in state()) {
        let m = model();
        let full = m.coriolis(&q, &qd) * v.1;
        let sparse = m.coriolis_times(&q, &qd, &v.1);
        prop_assert!((full - sparse).abs().max() < 1e-12 * (1.0 + full.abs().max()), "{} vs {}", full, sparse);
    }

    /// The forward dynamics' `C(q, q̇) q̇` (the `v = q̇` specialization) equals the matrix product.
    #[test]
    fn coriolis_vector_equals_the_matrix((q, qd) in state()) {
        let m = model();
        let full = m.coriolis(&q, &qd) * qd;
        let fast = m.terms(&q).coriolis_vector(&qd);
        prop_assert!((full - fast).abs().max() < 1e-12 * (1.0 + full.abs().max()), "{} vs {}", full, fast);
    }

    /// The structured products and the Schur-complement solve agree with the dense matrices.
    #[test]
    fn structured_terms_agree_with_dense_algebra((q, qd) in state(), v in state()) {
        let m = model();
        let t = m.terms(&q);
        let b = m.inertia(&q);
        let tol = |x: f64| 1e-10 * (1.0 + x.abs());
        prop_assert!((t.b_times(&v.0) - b * v.0).abs().max() < tol((b * v.0).abs().max()));
        let cv = m.coriolis(&q, &qd) * v.1;
        let cj = t.c_times_joints(&qd, &v.1);
        prop_assert!((cj.x - cv.x).abs() < tol(cv.x) && (cj.y - cv.y).abs() < tol(cv.y), "{} vs {}", cj, cv);
        let b_inv = b.try_inverse().unwrap();
        let x = t.solve(&v.0).unwrap();
        prop_assert!((x - b_inv * v.0).abs().max() < 1e-9 * (1.0 + x.abs().max()));
        let mm = t.modal_input_map().unwrap();
        prop_assert!((mm - b_inv.fixed_view::<2, 2>(2, 0)).abs().max() < 1e-9);
    }

    #[test]
    fn power_balance_holds(
        (q, qd) in state(),
        u in (-5.0..5.0, -5.0..5.0, -1.0..1.0, -1.0..1.0f64),
    ) {
        // dE/dt = q̇ᵀ(u − D q̇) for E = ½ q̇ᵀBq̇ + ½ δᵀKδ, with q̈ from the forward dynamics.
        let m = model();
        let u = Vector4::new(u.0, u.1, u.2, u.3);
        let qdd = m.acceleration(&q, &qd, &u).unwrap();
        let e_dot = qd.dot(&(m.inertia(&q) * qdd)) + 0.5 * qd.dot(&(b_dot(&m, &q, &qd) * qd))
            + qd.dot(&m.elastic_force(&q));
        let supplied = qd.dot(&(u - m.damping_force(&qd)));
        prop_assert!((e_dot - supplied).abs() < 1e-6 * (1.0 + supplied.abs()), "{} vs {}", e_dot, supplied);
    }

    #[test]
    fn f32_model_agrees_with_f64((q, qd) in state()) {
        let m64 = model();
        let m32 = Model::new(ArmParams::<f32>::default());
        let (q32, qd32) = (q.cast::<f32>(), qd.cast::<f32>());
        let db = m32.inertia(&q32).cast::<f64>() - m64.inertia(&q);
        let dc = m32.coriolis(&q32, &qd32).cast::<f64>() - m64.coriolis(&q, &qd);
        prop_assert!(db.abs().max() < 1e-5 && dc.abs().max() < 1e-4);
    }
}

#[test]
fn non_finite_state_has_no_acceleration() {
    let m = model();
    let q = Vector4::new(0.0, f64::NAN, 0.0, 0.0);
    assert!(
        m.acceleration(&q, &Vector4::zeros(), &Vector4::zeros())
            .is_none_or(|a| a.iter().any(|x| x.is_nan()))
    );
}

/// The largest eigenvalue of `M_θθ⁻¹ K` (real and positive: similar to `K^½ M⁻¹ K^½`).
fn velocity_loop_rate(m: &Model<f64>, kp: (f64, f64), theta2: f64) -> f64 {
    let t = m.terms(&flexarm_core::Vector4::new(0.0, theta2, 0.0, 0.0));
    let det = t.b11 * t.b22 - t.b12 * t.b12;
    let inv = [[t.b22 / det, -t.b12 / det], [-t.b12 / det, t.b11 / det]];
    let a = [
        [inv[0][0] * kp.0, inv[0][1] * kp.1],
        [inv[1][0] * kp.0, inv[1][1] * kp.1],
    ];
    let (tr, d) = (a[0][0] + a[1][1], a[0][0] * a[1][1] - a[0][1] * a[1][0]);
    (tr + (tr * tr - 4.0 * d).sqrt()) / 2.0
}

/// `PAPER_VELOCITY_LOOP_RATE` is the model's, within 0.5 /s, over every θ2; the gains
/// `Gains::default_for` gives keep `λT ≤ 1` at every motor rate, and are the paper's at 1 kHz.
#[test]
fn the_velocity_loop_rate_is_the_models() {
    use flexarm_core::params::{Gains, PAPER_VELOCITY_LOOP_RATE};
    let m = Model::<f64>::new(ArmParams::default());
    let worst = |g: &Gains<f64>| {
        (0..=360)
            .map(|k| velocity_loop_rate(&m, (g.kp.x, g.kp.y), (f64::from(k) - 180.0).to_radians()))
            .fold(0.0, f64::max)
    };
    let paper = worst(&Gains::default());
    // The core's routine (17 poses) against this scan of 361, each pose by the matrix product.
    let core = m.velocity_loop_rate(flexarm_core::Vector2::new(90.0, 14.0));
    assert!((core - paper).abs() < 1e-9 * paper, "{core} {paper}");
    assert!(
        paper <= PAPER_VELOCITY_LOOP_RATE && paper > PAPER_VELOCITY_LOOP_RATE - 0.5,
        "{paper}"
    );
    // The paper's gains on the QEMU board's 100 Hz loop: past the sampled loop's bound of 2.
    assert!(paper / 100.0 > 2.0);
    for hz in [50, 100, 200, 221, 500, 1000, 10_000] {
        let g = Gains::<f64>::default_for(hz);
        assert!(worst(&g) / f64::from(hz) <= 1.0 + 1e-9, "{hz} Hz");
    }
    assert_eq!(Gains::<f64>::default_for(1000), Gains::default());
}
