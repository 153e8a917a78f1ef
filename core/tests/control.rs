//! Properties of the control laws: Eq. 7, the robust term, the piezo law and saturation.

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)] // tests may index and unwrap

use flexarm_core::control::motor::{MotorController, MotorLaw};
use flexarm_core::control::piezo::{PiezoGains, PiezoLaw, PiezoMaterial, PiezoPatch, RateFilter};
use flexarm_core::control::robust::{joint_torque_for_modal_accel, modal_damping_accel};
use flexarm_core::control::tracking::{Reference, eq7, eq7_joints, eq7_torques};
use flexarm_core::limits::{lower, saturate, upper};
use flexarm_core::model::Model;
use flexarm_core::params::{ArmParams, Gains, Limits};
use flexarm_core::real::all_finite;
use flexarm_core::trajectory::JointTarget;
use flexarm_core::{Fault, Vector2, Vector4};
use proptest::prelude::*;

fn v2() -> impl Strategy<Value = Vector2<f64>> {
    (-10.0..10.0, -10.0..10.0f64).prop_map(|(a, b)| Vector2::new(a, b))
}

proptest! {
    /// With zero tracking error Eq. 7 is the inverse dynamics: the plant driven by the full
    /// 4-vector `u` accelerates exactly as desired (the modal rows included).
    #[test]
    fn eq7_without_error_is_inverse_dynamics(th in v2(), thd in v2(), thdd in v2()) {
        let m = Model::new(ArmParams::<f64>::default());
        let target = JointTarget { q: th, qd: thd, qdd: thdd };
        let (q, qd, qdd_d) = target.generalized();
        let u = eq7(&m, &Gains::default(), &q, &qd, &target);
        let qdd = m.acceleration(&q, &qd, &u).unwrap();
        prop_assert!((qdd - qdd_d).abs().max() < 1e-9, "q̈ = {}, want {}", qdd, qdd_d);
    }

    /// `eq7_torques`, Eq. 7 written out flat in the order LLVM compiles fastest, is the motor
    /// law's `eq7_joints` on the same terms and reference to the bit, in `f32` as the firmware
    /// runs it: the reordering changed no rounding.
    #[test]
    fn eq7_torques_is_the_motor_laws_eq7_to_the_bit(
        x in prop::array::uniform16(-1.0..1.0f32),
        k in prop::array::uniform3(0.0..1.0f32),
    ) {
        let m = Model::new(ArmParams::<f32>::default());
        let g = Gains::<f32> {
            lambda: Vector4::new(1.0 + 9.0 * k[0], 2.0 + 9.0 * k[1], 3.0 + 9.0 * k[2], 4.0),
            ..Gains::default()
        };
        let q = Vector4::new(3.0 * x[0], 3.0 * x[1], 0.02 * x[2], 0.005 * x[3]);
        let qd = Vector4::new(4.0 * x[4], 4.0 * x[5], 2.0 * x[6], 1.0 * x[7]);
        let target = JointTarget {
            q: Vector2::new(3.0 * x[8], 3.0 * x[9]),
            qd: Vector2::new(4.0 * x[10], 4.0 * x[11]),
            qdd: Vector2::new(20.0 * x[12], 20.0 * x[13]),
        };
        let flat = eq7_torques(&m, &g, &q, &qd, &target);
        let r = Reference::new(&g.lambda, &q, &qd, &target);
        let law = eq7_joints(&m.terms(&q), &qd, &g.kp, &r);
        prop_assert!(flat.x.to_bits() == law.x.to_bits() && flat.y.to_bits() == law.y.to_bits(), "{flat} against {law}");
    }

    /// The robust modal term never injects energy into the modes, and its damping lies in
    /// `[D_Δ, 2 D_Δ)`.
    #[test]
    fn robust_term_is_dissipative(dd in v2(), s in v2(), t in 0.0..1e6f64) {
        let g = Gains::<f64>::default();
        let a = modal_damping_accel(&g, t, &dd, &s);
        prop_assert!(dd.dot(&a) <= 0.0);
        for i in 0..2 {
            if dd[i] != 0.0 {
                let d = -a[i] / dd[i];
                prop_assert!(d >= g.d_delta[i] - 1e-12 && d < 2.0 * g.d_delta[i] + 1e-12, "D' = {}", d);
            }
        }
    }

    /// The same in `f32`, as the firmware runs it, over magnitudes of `δ̇_j s_j` from 1e-12 to
    /// 1e18: the one division for both modes (`f_j = p_j n_k / (n_1 n_2)`) neither overflows
    /// nor leaves `[D_Δ, 2 D_Δ)`, and agrees with `p_j / n_j` to a few ulps.
    #[test]
    fn robust_term_in_f32_over_magnitudes(
        e in prop::array::uniform4(-6.0..9.0f64),
        sign in prop::array::uniform4(prop::bool::ANY),
        t in 0.0..1e3f32,
    ) {
        let m = |k: usize| (if sign[k] { 1.0 } else { -1.0 }) * 10f64.powf(e[k]) as f32;
        let (dd, s) = (Vector2::new(m(0), m(1)), Vector2::new(m(2), m(3)));
        let g = Gains::<f32>::default();
        let a = modal_damping_accel(&g, t, &dd, &s);
        for i in 0..2 {
            let d = -a[i] / dd[i];
            // The bounds up to the rounding of `−a/δ̇` (a few ulps).
            let ulps = 1.0 + 4.0 * f32::EPSILON;
            prop_assert!(d.is_finite() && d * ulps >= g.d_delta[i] && d <= 2.0 * g.d_delta[i] * ulps, "D' = {}", d);
            let layer = (g.epsilon[i] * (-g.phi[i] * t).exp()).max(g.epsilon_floor);
            let p = (dd[i] * s[i]).abs();
            let f = p / (p + layer);
            let want = -g.d_delta[i] * (1.0 + f) * dd[i];
            prop_assert!((a[i] - want).abs() <= 4.0 * f32::EPSILON * want.abs(), "{} vs {}", a[i], want);
        }
    }

    /// Sign convention: with an ideal derivative the law, the actuator and the film are wired
    /// so that `δ̇ᵀ C_a V_a = −k_c k_s k_a (Δφ'ᵀ δ̇)² ≤ 0`. This holds by construction for any
    /// magnitudes and catches only a sign mismatch; how much energy the sampled, filtered loop
    /// removes is checked against the Lyapunov prediction in `tests/tests/damping.rs`.
    #[test]
    fn piezo_law_sign_makes_the_ideal_power_non_positive(dd in v2(), k_c in 0.0..100.0f64) {
        let patch = PiezoPatch::<f64>::paper();
        let v_f_dot = patch.film_voltage(&Vector4::new(0.0, 0.0, dd.x, dd.y));
        let v_a = -k_c * v_f_dot;
        prop_assert!(dd.dot(&patch.c_a()) * v_a <= 0.0);
    }

    /// Saturation is total: any f32 including NaN and ±∞ lands inside the limits.
    #[test]
    fn saturation_holds_for_any_input(bits in any::<u32>(), lim in 1e-3..1e3f32) {
        let x = f32::from_bits(bits);
        let y = saturate(x, lim);
        prop_assert!(y.is_finite() && y.abs() <= lim);
        if x.is_nan() { prop_assert_eq!(y, 0.0); }
        if x.is_finite() && x.abs() <= lim { prop_assert_eq!(y, x); }
    }

    /// `lower` and `upper` are `min` and `max` for ordered pairs, and give `b` when `a` is NaN
    /// (where `min` and `max` drop the NaN too): what the derating, the search torque and the
    /// boundary layer's floor rely on.
    #[test]
    fn lower_and_upper_are_min_and_max_with_a_nan_first_giving_the_second(a in any::<u32>(), b in any::<u32>()) {
        let (a, b) = (f32::from_bits(a), f32::from_bits(b));
        prop_assume!(!b.is_nan());
        let same = |x: f32, y: f32| x.to_bits() == y.to_bits() || (x == 0.0 && y == 0.0);
        prop_assert!(same(lower(a, b), a.min(b)), "lower({a}, {b}) = {}", lower(a, b));
        prop_assert!(same(upper(a, b), a.max(b)), "upper({a}, {b}) = {}", upper(a, b));
        prop_assert_eq!(lower(f32::NAN, b).to_bits(), b.to_bits());
        prop_assert_eq!(upper(f32::NAN, b).to_bits(), b.to_bits());
    }

    /// `all_finite` never passes a NaN or ±∞, and passes every group of physical magnitude.
    #[test]
    fn all_finite_rejects_every_non_finite_value(bits in any::<[u32; 4]>(), small in any::<[i16; 4]>()) {
        let xs = bits.map(f32::from_bits);
        if all_finite(xs) {
            prop_assert!(xs.iter().all(|x| x.is_finite()));
        }
        prop_assert!(all_finite(small.map(f32::from)));
        let with = |v: f32| { let mut ys = small.map(f32::from); ys[2] = v; ys };
        prop_assert!(!all_finite(with(f32::NAN)));
        prop_assert!(!all_finite(with(f32::INFINITY)));
        prop_assert!(!all_finite(with(f32::NEG_INFINITY)));
    }

    /// The motor step's torques are finite and inside their limits for any finite state.
    #[test]
    fn motor_step_respects_limits(
        q in (-7.0..7.0f32, -7.0..7.0f32, -0.5..0.5f32, -0.5..0.5f32),
        qd in (-50.0..50.0f32, -50.0..50.0f32, -50.0..50.0f32, -50.0..50.0f32),
        robust in any::<bool>(),
    ) {
        let ctrl = controller(if robust { MotorLaw::Robust } else { MotorLaw::Tracking });
        let q = Vector4::new(q.0, q.1, q.2, q.3);
        let qd = Vector4::new(qd.0, qd.1, qd.2, qd.3);
        let out = ctrl.step(1.0, &q, &qd, &JointTarget::rest(Vector2::new(1.0, -1.0))).unwrap();
        prop_assert!(out.tau.iter().zip(ctrl.limits.tau_max.iter()).all(|(t, l)| t.is_finite() && t.abs() <= *l));
    }
}

fn controller(law: MotorLaw) -> MotorController<f32> {
    MotorController {
        model: Model::new(ArmParams::default()),
        gains: Gains::default(),
        limits: Limits::default(),
        law,
    }
}

#[test]
fn motor_step_rejects_non_finite_input() {
    let ctrl = controller(MotorLaw::Robust);
    let target = JointTarget::rest(Vector2::zeros());
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let q = Vector4::new(0.0, bad, 0.0, 0.0);
        assert_eq!(
            ctrl.step(0.0, &q, &Vector4::zeros(), &target),
            Err(Fault::NonFinite)
        );
        assert_eq!(
            ctrl.step(0.0, &Vector4::zeros(), &q, &target),
            Err(Fault::NonFinite)
        );
        assert_eq!(
            ctrl.step(bad, &Vector4::zeros(), &Vector4::zeros(), &target),
            Err(Fault::NonFinite)
        );
    }
}

#[test]
fn robust_torque_delivers_the_requested_modal_acceleration() {
    // Away from θ2 = ±π/2 the map M = (B⁻¹)_δθ has full rank; with a small μ the damped
    // least-squares torque reproduces the request.
    let m = Model::new(ArmParams::<f64>::default());
    let q = Vector4::new(0.3, 0.4, 0.01, -0.002);
    let terms = m.terms(&q);
    let a = Vector2::new(-0.7, 0.3);
    let tau = joint_torque_for_modal_accel(&terms, &a, 1e-4);
    let mm = terms.modal_input_map().unwrap();
    assert!((mm * tau - a).abs().max() < 1e-6, "M τ = {}", mm * tau);
    // The modal accelerations of the plant under that torque alone (at rest) are M τ.
    let acc = m
        .acceleration(&q, &Vector4::zeros(), &Vector4::new(tau.x, tau.y, 0.0, 0.0))
        .unwrap();
    let acc0 = m
        .acceleration(&q, &Vector4::zeros(), &Vector4::zeros())
        .unwrap();
    assert!(((acc - acc0).fixed_rows::<2>(2) - a).abs().max() < 1e-6);
    // Where M loses rank (θ2 = π/2) the torque stays bounded.
    let t90 = m.terms(&Vector4::new(0.0, core::f64::consts::FRAC_PI_2, 0.0, 0.0));
    let tau90 = joint_torque_for_modal_accel(&t90, &a, 0.1);
    assert!(tau90.norm() < 10.0 * tau.norm(), "{tau90} vs {tau}");
}

#[test]
fn rate_filter_tracks_a_slow_sine_and_the_law_dissipates() {
    // A 4.716 Hz oscillation of mode 1 sampled at 10 kHz: the filtered film-voltage rate
    // lags by a few degrees only, so the average power of the law over whole cycles is < 0.
    let patch = PiezoPatch::<f32>::paper();
    let period = 1e-4f32;
    let mut law = PiezoLaw::new(
        &PiezoGains {
            k_c: 5.0,
            cutoff_hz: 100.0,
        },
        period,
        200.0,
    );
    let w = core::f32::consts::TAU * 4.716;
    let c_a = patch.c_a();
    let (mut energy, mut max_err) = (0.0f32, 0.0f32);
    for k in 0..20_000 {
        let t = k as f32 * period;
        let q = Vector4::new(0.0, 0.0, 0.01 * (w * t).sin(), 0.0);
        let delta_dot = 0.01 * w * (w * t).cos();
        let v_a = law.step(patch.film_voltage(&q));
        if k > 1000 {
            energy += c_a.x * v_a * delta_dot * period;
            let ideal = -5.0 * patch.k_s * patch.slope_diff.x * delta_dot;
            max_err = max_err.max((v_a - ideal).abs());
        }
    }
    assert!(energy < 0.0, "work done on the mode {energy} J");
    // A 100 Hz corner at 4.7 Hz: gain error < 0.2 %, phase 2.7°, so |error| < 5 % of the peak.
    let peak = 5.0 * patch.k_s * patch.slope_diff.x.abs() * 0.01 * w;
    assert!(
        peak < 200.0,
        "the amplitude keeps the law off its limit: {peak} V"
    );
    assert!(max_err < 0.05 * peak, "max error {max_err} V of {peak} V");
}

#[test]
fn rate_filter_first_sample_gives_no_spike_and_nan_resets() {
    let mut f = RateFilter::new(100.0f32, 1e-3);
    assert_eq!(f.update(50.0), 0.0);
    // A ramp of 2 V/s settles to 2 V/s.
    let mut y = 0.0;
    for k in 1..200 {
        y = f.update(50.0 + 2.0 * k as f32 * 1e-3);
    }
    assert!((y - 2.0).abs() < 1e-2, "{y}");
    let mut law = PiezoLaw::new(&PiezoGains::default(), 1e-3, 200.0);
    law.step(1.0);
    assert_eq!(law.step(f32::NAN), 0.0);
    assert_eq!(
        law.step(123.0),
        0.0,
        "restarted filter: no spike after a NaN"
    );
}

/// The first sample after construction or a reset gives 0 V (no spike), however far it is from
/// the previous one, and the law then runs exactly as a new one fed the same samples.
#[test]
fn piezo_law_restarts_without_a_spike() {
    let samples = [9.0f32, 8.99, 8.95, 9.2, -3.0, -3.01];
    let run = |law: &mut PiezoLaw<f32>| samples.map(|v| law.step_finite(v));
    let fresh = run(&mut PiezoLaw::new(&PiezoGains::default(), 1e-4, 200.0));
    assert_eq!(fresh[0], 0.0);
    assert!(fresh[1] > 0.0 && fresh[1] < 200.0, "{fresh:?}");
    assert_eq!(fresh[3], -200.0, "a fast rise saturates: {fresh:?}");
    let mut law = PiezoLaw::new(&PiezoGains::default(), 1e-4, 200.0);
    law.step_finite(-9.0);
    law.step_finite(5.0);
    law.reset();
    assert_eq!(run(&mut law), fresh);
}

/// The transducers' lever arms are taken about the neutral axis of the composite section they
/// are bonded to (`docs/model.md`, Eqs. 17–19).
#[test]
fn transducer_lever_arms_come_from_the_composite_section() {
    let m = PiezoMaterial::<f64>::default();
    // Paper's data: z_n = Σ E t z / Σ E t = 0.8245 mm above the film's bottom face; the film's
    // mid-plane 14 µm above that face, the ceramic's at 1.228 mm.
    let zn = (2e9 * 28e-6 * 14e-6 + 65e9 * 0.8e-3 * 0.428e-3 + 64e9 * 0.8e-3 * 1.228e-3)
        / (2e9 * 28e-6 + 65e9 * 0.8e-3 + 64e9 * 0.8e-3);
    assert!((m.neutral_axis() - zn).abs() < 1e-15);
    assert!(
        (m.film_lever_arm() - 0.8105e-3).abs() < 1e-7,
        "{}",
        m.film_lever_arm()
    );
    assert!((m.actuator_lever_arm() - 0.4035e-3).abs() < 1e-7);
    // Three equal layers: a solid strip of thickness 3t, axis at 1.5 t, both arms t.
    let t = 1e-3;
    let solid = PiezoMaterial::<f64> {
        e_c: 70e9,
        e_f: 70e9,
        e_b: 70e9,
        t_b: t,
        t_c: t,
        t_f: t,
        ..m
    };
    assert!((solid.neutral_axis() - 1.5 * t).abs() < 1e-18);
    assert!((solid.film_lever_arm() - t).abs() < 1e-18);
    assert!((solid.actuator_lever_arm() - t).abs() < 1e-18);
    // A thin actuator on a bare beam: the Crawley–de Luis single-patch pin force,
    // k_a = E_b E_c b t_b² |d31| / (2 (E_b t_b + 4 E_c t_c)), agrees as E_c t_c / E_b t_b → 0.
    let thin = PiezoMaterial::<f64> {
        t_c: 1e-7,
        t_f: 1e-9,
        ..m
    };
    let pin = thin.e_b * thin.e_c * thin.b * thin.t_b.powi(2) * thin.d31.abs()
        / (2.0 * (thin.e_b * thin.t_b + 4.0 * thin.e_c * thin.t_c));
    assert!((thin.moment_per_volt() / pin - 1.0).abs() < 1e-3);
    // The film's voltage per slope, with the arm above: g31 E_f t_f (z_n − z_f) / l_a.
    let k_s = m.film_volts_per_slope(0.35);
    assert!((k_s - 0.216 * 2e9 * 28e-6 * m.film_lever_arm() / 0.35).abs() < 1e-12 * k_s);
}

/// The film's feedthrough and the bending path together are the free patch's laminate solution.
/// Independently of the composite axis: with the axis at the film's bottom face, the laminate
/// `[[A, B], [B, D]] (ε₀, κ) = (N^Λ, M^Λ)` (no load; `B ≠ 0` there) gives the strain at the
/// film's mid-plane `ε₀ + κ z_f`. A patch clamped at one end bends by the same curvature (no
/// moment from the free tip), so its film reads `g31 E_f t_f (ε₀ + κ z_f)`: the bending path's
/// static `−k_s k_a l_a / EI` (curvature at the film's lever arm; `EI` about the composite axis)
/// plus the feedthrough. The sign convention of the module (`k_a, k_s > 0`) flips the film's
/// reading.
#[test]
fn the_feedthrough_and_the_bending_path_make_the_free_patchs_strain() {
    for t_b in [0.8e-3, 2.5e-3, 5e-3] {
        let m = PiezoMaterial::<f64> {
            t_b,
            ..Default::default()
        };
        let layers = [
            (m.e_f, 0.0, m.t_f),
            (m.e_b, m.t_f, m.t_f + m.t_b),
            (m.e_c, m.t_f + m.t_b, m.t_f + m.t_b + m.t_c),
        ];
        let (mut a, mut b, mut d) = (0.0, 0.0, 0.0);
        for (e, z0, z1) in layers {
            a += e * m.b * (z1 - z0);
            b += e * m.b * (z1 * z1 - z0 * z0) / 2.0;
            d += e * m.b * (z1.powi(3) - z0.powi(3)) / 3.0;
        }
        // The ceramic's free strain per volt, |d31|/t_c, restrained by its own stiffness.
        let (c0, c1) = (layers[2].1, layers[2].2);
        let n_l = m.e_c * m.b * m.d31.abs();
        let m_l = m.e_c * m.b * m.d31.abs() / m.t_c * (c1 * c1 - c0 * c0) / 2.0;
        let det = a * d - b * b;
        let (eps0, kappa) = ((d * n_l - b * m_l) / det, (a * m_l - b * n_l) / det);
        let film = m.g31 * m.e_f * m.t_f * (eps0 + kappa * m.t_f / 2.0);
        // EI about the composite axis, and the bending path's static gain per volt.
        let ei = d - b * b / a;
        let l_a = 0.35;
        let bending = m.film_volts_per_slope(l_a) * m.moment_per_volt() * l_a / ei;
        let f = m.film_feedthrough();
        assert!(
            (-film - (bending + f)).abs() < 1e-9 * bending,
            "t_b {t_b}: {film} vs {bending} + {f}"
        );
        assert!(f < 0.0 && bending > 0.0);
        println!(
            "t_b = {:.1} mm: bending path's static gain {bending:.3e} V/V, feedthrough {f:.3e} V/V ({:.0} %)",
            t_b * 1e3,
            -100.0 * f / bending
        );
    }
    // The 2.5 mm link (docs/results.md, docs/model.md).
    let m = PiezoMaterial::<f64> {
        t_b: 2.5e-3,
        ..Default::default()
    };
    let f = m.film_feedthrough();
    assert!((f + 1.086e-3).abs() < 1e-6, "{f}");
}

proptest! {
    /// The piezo law saturates at an asymmetric window: a patch rated −30 V … +150 V never sees
    /// more, and inside the window the law is the symmetric one's.
    #[test]
    fn the_piezo_law_keeps_an_asymmetric_window(
        samples in prop::collection::vec(-9.0f32..9.0, 1..200),
    ) {
        let g = PiezoGains::default();
        let mut asym = PiezoLaw::with_window(&g, 1e-4, -30.0, 150.0);
        let mut wide = PiezoLaw::new(&g, 1e-4, 1e6);
        prop_assert!(asym.is_valid());
        for v in samples {
            let (a, w) = (asym.step_finite(v), wide.step_finite(v));
            prop_assert!((-30.0..=150.0).contains(&a), "{a}");
            prop_assert_eq!(a, w.clamp(-30.0, 150.0));
        }
    }
}

/// A window that does not hold 0 V (the safe state) is an invalid configuration.
#[test]
fn a_piezo_window_without_zero_is_refused() {
    use flexarm_core::controller::Controller;
    use flexarm_core::observer_gains::{GAIN_1KHZ, gain};
    use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
    let g = PiezoGains::<f32>::default();
    assert!(!PiezoLaw::with_window(&g, 1e-4, 10.0, 150.0).is_valid());
    assert!(!PiezoLaw::with_window(&g, 1e-4, -30.0, -5.0).is_valid());
    assert!(!PiezoLaw::with_window(&g, 1e-4, f32::NEG_INFINITY, 150.0).is_valid());
    for v_a_min in [10.0f32, 0.0, f32::NAN] {
        let limits = Limits {
            v_a_min,
            ..Limits::default()
        };
        assert!(limits.validate().is_err(), "{v_a_min}");
        let c = Controller::with_model(
            ArmParams::default(),
            MotorLaw::Tracking,
            JointTrajectory::Trapezoid(Trapezoid::paper()),
            1e-4,
            1e-3,
            gain(&GAIN_1KHZ),
            PiezoPatch::paper(),
            g,
            limits,
        );
        assert_eq!(c.fault(), Some(Fault::InvalidConfig), "{v_a_min}");
    }
    let ok = Limits::<f32> {
        v_a_max: 150.0,
        v_a_min: -30.0,
        ..Limits::default()
    };
    assert!(ok.validate().is_ok());
}
