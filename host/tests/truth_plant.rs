//! The truth plant behind the simulator's loop (`flexarm_host::truth_plant`): today's plant
//! when it has the controller's two modes and ideal actuators, the beam's frequencies, energy
//! balanced with friction and damping, convergence in the number of modes, RK4 adequate at the
//! default step, and a closed loop within bounds derived from the friction.
//! `cargo test -p flexarm-host --test truth_plant -- --nocapture` prints the figures.

use flexarm_core::Vector2;
use flexarm_core::control::piezo::{PiezoGains, PiezoPatch};
use flexarm_core::params::ArmParams;
use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
use flexarm_host::plant::Plant;
use flexarm_host::sim::{Sensors, SimConfig, StateSource, simulate};
use flexarm_host::truth::Coords;
use flexarm_host::truth_plant::{MotorSpec, TruthPlant, TruthSpec};

fn paper() -> JointTrajectory<f32> {
    JointTrajectory::Trapezoid(Trapezoid::paper())
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

/// A plant of `spec` with `N = D − 2` modes on the paper's arm and patch, at rest at θ = 0.
fn plant<const D: usize>(spec: &TruthSpec) -> TruthPlant<D> {
    TruthPlant::<D>::new(
        spec,
        &ArmParams::default(),
        &PiezoPatch::paper(),
        Vector2::new(10.0, 10.0),
        Vector2::zeros(),
    )
    .unwrap()
}

#[test]
fn two_modes_with_ideal_actuators_are_todays_plant() {
    // The scenario's own arm as a truth plant, through the whole loop: full state and the
    // firmware's observer with realistic sensors.
    for (state, sensors) in [
        (StateSource::Full, Sensors::default()),
        (StateSource::Observer, Sensors::realistic()),
    ] {
        let cfg = SimConfig {
            piezo: Some(PiezoGains::default()),
            state,
            sensors,
            ..SimConfig::default()
        };
        let truth = cfg.with_truth(TruthSpec::model()).unwrap();
        let (a, ta) = simulate(&cfg, &paper(), true).unwrap();
        let (b, tb) = simulate(&truth, &paper(), true).unwrap();
        let worst = ta
            .iter()
            .zip(&tb)
            .map(|(x, y)| (x.x.q - y.x.q).abs().max())
            .fold(0.0, f64::max);
        println!("{state:?}: largest difference of q over the run {worst:.1e}");
        assert!(worst < 1e-12, "{worst:e}");
        assert!(rel(b.l2_error, a.l2_error) < 1e-9, "{a:?}\n{b:?}");
        assert!(rel(b.l2_delta, a.l2_delta) < 1e-9, "{a:?}\n{b:?}");
    }
}

#[test]
fn the_controllers_model_is_the_truncation_of_the_beam() {
    // Two modes of the beam with ideal actuators against the core's model built from the
    // controller's parameters (`controller_model`): the same run.
    let spec = TruthSpec {
        modes: 2,
        ..TruthSpec::default().ideal_actuators()
    };
    let cfg = SimConfig {
        piezo: Some(PiezoGains::default()),
        ..SimConfig::default()
    }
    .with_truth(spec)
    .unwrap();
    let model = SimConfig {
        truth: None,
        plant: None,
        ..cfg
    };
    let (a, _) = simulate(&model, &paper(), false).unwrap();
    let (b, _) = simulate(&cfg, &paper(), false).unwrap();
    println!(
        "beam, 2 modes: Eq. 37 θ̃ {:.6e} vs the controller's model {:.6e}",
        b.l2_error, a.l2_error
    );
    assert!(rel(b.l2_error, a.l2_error) < 1e-9, "{a:?}\n{b:?}");
    assert!(rel(b.l2_delta, a.l2_delta) < 1e-9, "{a:?}\n{b:?}");
    assert!(rel(b.max_tip, a.max_tip) < 1e-9, "{a:?}\n{b:?}");
}

#[test]
fn with_the_joints_held_the_plant_has_the_beams_frequencies() {
    // Linearize the plant's restoring forces at rest by central differences of B(q) q̈(q):
    // with θ held the modal block gives K_δδ, whose eigenvalues against B_δδ are ω_j².
    const D: usize = 12;
    let spec = TruthSpec {
        modes: 10,
        ..TruthSpec::default()
    };
    let p = plant::<D>(&spec);
    let arm = p.arm();
    let q0 = Coords::<D>::zeros();
    let zero = Coords::<D>::zeros();
    let force = |q: &Coords<D>| arm.inertia(q) * arm.acceleration(q, &zero, &zero).unwrap();
    let h = 1e-7;
    let n = D - 2;
    let mut k = nalgebra::DMatrix::<f64>::zeros(n, n);
    for j in 0..n {
        let mut e = Coords::<D>::zeros();
        e[2 + j] = h;
        let col = (force(&(q0 + e)) - force(&(q0 - e))) / (2.0 * h);
        for i in 0..n {
            k[(i, j)] = -col[2 + i];
        }
    }
    let b = arm.inertia(&q0).view((2, 2), (n, n)).into_owned();
    let chol = b.cholesky().unwrap();
    let l_inv = chol.l().try_inverse().unwrap();
    let sym = &l_inv * k * l_inv.transpose();
    let mut w: Vec<f64> = sym
        .symmetric_eigenvalues()
        .iter()
        .map(|l| l.sqrt())
        .collect();
    w.sort_by(f64::total_cmp);
    // The beam's own eigen-solution (a root search of its transfer-matrix determinant).
    let mut model = flexarm_beam::design::DesignModel {
        zeta: vec![0.0; n],
        lambda: vec![1.0; n],
        ..Default::default()
    };
    model.layers.material.t_b = spec.thickness;
    let beam = model.beam(0.09, 0.35).unwrap().frequencies(n).unwrap();
    for (j, (a, b)) in w.iter().zip(&beam).enumerate() {
        assert!(rel(*a, *b) < 1e-6, "mode {}: {a} vs {b}", j + 1);
    }
    println!(
        "joints held, ten modes: {:?} Hz",
        w.iter()
            .map(|x| format!("{:.2}", x / std::f64::consts::TAU))
            .collect::<Vec<_>>()
    );
}

/// Tip deflection after a 20 ms, 2 N·m pulse on joint 2, motors otherwise off, ideal
/// actuators: one sample per millisecond over 1 s.
fn pulse_response<const D: usize>(dt: f64) -> Vec<f64> {
    let spec = TruthSpec {
        modes: D - 2,
        ..TruthSpec::default().ideal_actuators()
    };
    let mut p = plant::<D>(&spec);
    let steps = (1.0 / dt).round() as usize;
    let every = (1e-3 / dt).round() as usize;
    let mut out = Vec::new();
    for k in 0..steps {
        let tau = if (k as f64) * dt < 0.02 { 2.0 } else { 0.0 };
        p.step(&Vector2::new(0.0, tau), 0.0, dt).unwrap();
        if (k + 1) % every == 0 {
            out.push(p.tip());
        }
    }
    out
}

fn largest_difference(a: &[f64], b: &[f64]) -> f64 {
    let peak = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
        / peak
}

#[test]
fn the_tip_response_converges_in_the_number_of_modes() {
    let ten = pulse_response::<12>(1e-4);
    let six = largest_difference(&pulse_response::<8>(1e-4), &ten);
    let two = largest_difference(&pulse_response::<4>(1e-4), &ten);
    println!(
        "torque pulse on joint 2, tip over 1 s, largest difference to N = 10 relative to its peak: N = 6 {six:.2e}, N = 2 {two:.2e}"
    );
    assert!(six < 3e-5, "{six:e}");
    // The test can fail: two modes are visibly different.
    assert!(two > 30.0 * six, "{two:e} vs {six:e}");
}

#[test]
fn rk4_at_the_default_step_is_adequate_with_ten_modes() {
    let coarse = pulse_response::<12>(1e-4);
    let fine = pulse_response::<12>(1e-5);
    let d = largest_difference(&coarse, &fine);
    println!("ten modes, tip: RK4 at 0.1 ms against 0.01 ms: {d:.2e} of the peak");
    assert!(d < 2e-7, "{d:e}");
}

#[test]
fn energy_balances_the_work_of_the_motors_friction_and_damping() {
    // Six modes, damped, motors with friction (instant current loops so the torque is the
    // command), a torque pulse on both joints: E(t) − E(0) = ∫ τᵀθ̇ − ∫ F(θ̇)ᵀθ̇ − ∫ q̇ᵀDq̇.
    const D: usize = 8;
    let spec = TruthSpec {
        motors: [MotorSpec {
            current_tau: 0.0,
            ..MotorSpec::DRIVE
        }; 2],
        ..TruthSpec::default().ideal_actuators()
    };
    let mut p = plant::<D>(&spec);
    let dt = 1e-5;
    let power = |p: &TruthPlant<D>, tau: &Vector2<f64>| {
        let (_, qd) = p.coordinates();
        let f = p.friction(&qd);
        let joints = Vector2::new(qd[0], qd[1]);
        (
            tau.dot(&joints),
            f.dot(&joints) + p.arm().damping_power(&qd),
        )
    };
    let energy = |p: &TruthPlant<D>| {
        let (q, qd) = p.coordinates();
        p.arm().energy(&q, &qd)
    };
    let e0 = energy(&p);
    let (mut work, mut lost) = (0.0, 0.0);
    for k in 0..100_000 {
        let tau = if k < 10_000 {
            Vector2::new(1.0, -0.5)
        } else {
            Vector2::zeros()
        };
        let (w0, l0) = power(&p, &tau);
        p.step(&tau, 0.0, dt).unwrap();
        let (w1, l1) = power(&p, &tau);
        work += 0.5 * (w0 + w1) * dt;
        lost += 0.5 * (l0 + l1) * dt;
    }
    let gap = (energy(&p) - e0 - work + lost).abs();
    println!(
        "1 s: motors' work {work:.4e} J, friction and damping {lost:.4e} J, balance off by {gap:.1e} J"
    );
    assert!(
        lost > 0.5 * work,
        "the test must dissipate: {lost} of {work}"
    );
    assert!(gap < 1e-8 * work, "{gap:e} of {work:e}");
}

#[test]
fn the_paper_move_on_the_truth_plant_stays_within_the_friction_bound() {
    // Eq. 7 + piezo, six modes, real drives and amplifiers. At rest Eq. 7 pushes back with
    // K_p Λ θ̃ only, so Coulomb friction F_c can hold a joint anywhere within
    // |θ̃| ≤ F_c / (K_p Λ): the settled error's bound. The vibration: within 10 % of the same
    // run with ideal actuators, and the modes past the second hold a small share of δ.
    let spec = TruthSpec::default();
    let cfg = SimConfig {
        piezo: Some(PiezoGains::default()),
        ..SimConfig::default()
    };
    let real = cfg.with_truth(spec).unwrap();
    let ideal = cfg.with_truth(spec.ideal_actuators()).unwrap();
    let (s, _) = simulate(&real, &paper(), false).unwrap();
    let (si, _) = simulate(&ideal, &paper(), false).unwrap();
    let g = &real.gains;
    for i in 0..2 {
        let bound = spec.motors[i].coulomb / f64::from(g.kp[i] * g.lambda[i]);
        println!(
            "joint {}: Eq. 38 mean |θ̃| {:.2e} rad, friction bound {bound:.2e} rad",
            i + 1,
            s.tail_error_abs[i]
        );
        assert!(s.tail_error_abs[i] <= bound, "{s:?}");
    }
    println!(
        "Eq. 37 δ: real drives {:.3e}, ideal {:.3e}; max tip {:.4} m vs {:.4} m",
        s.l2_delta, si.l2_delta, s.max_tip, si.max_tip
    );
    assert!(rel(s.l2_delta, si.l2_delta) < 0.1, "{s:?}\n{si:?}");
    assert!(rel(s.max_tip, si.max_tip) < 0.1, "{s:?}\n{si:?}");
    assert!(s.max_v_a <= 200.0);
}

#[test]
fn the_consistent_arm_keeps_the_deflections_small() {
    // Notes §12: the printed 0.8 mm section bends far outside the small-deflection model under
    // the paper's trapezoid; the default thickness keeps the tip within 2 % of the link.
    let cfg = SimConfig::default();
    let mut tips = Vec::new();
    for t in [0.8e-3, 1.5e-3, flexarm_host::truth_plant::DEFAULT_THICKNESS] {
        let spec = TruthSpec {
            thickness: t,
            ..TruthSpec::default().ideal_actuators()
        };
        let (body, _) = spec.link(&cfg.arm, &cfg.patch).unwrap();
        let (s, _) = simulate(&cfg.with_truth(spec).unwrap(), &paper(), false).unwrap();
        println!(
            "{:.1} mm: modes 1, 2 at {:.1}, {:.1} Hz, link {:.3} kg; Eq. 7: max tip {:.1} mm = {:.1} % of the link",
            t * 1e3,
            body.omega[0] / std::f64::consts::TAU,
            body.omega[1] / std::f64::consts::TAU,
            body.mass,
            s.max_tip * 1e3,
            100.0 * s.max_tip / cfg.arm.a2
        );
        tips.push(s.max_tip / cfg.arm.a2);
    }
    assert!(tips[0] > 0.1, "{tips:?}");
    assert!(tips[2] < 0.02, "{tips:?}");
}

#[test]
fn a_scenario_can_give_the_controller_another_model_on_purpose() {
    let text = |controller: &str| {
        format!(
            "[trajectory]\nkind = \"trapezoid\"\n[controller]\npiezo = true\n[plant]\nkind = \"truth\"\n{controller}\n"
        )
    };
    let truncation = flexarm_host::scenario::parse(&text("")).unwrap().config;
    let given = flexarm_host::scenario::parse(&text("controller = \"arm\""))
        .unwrap()
        .config;
    // The same truth plant under both; the controller's model is the beam's truncation, or the
    // scenario's own arm (the paper's) as given.
    assert_eq!(truncation.truth, given.truth);
    assert_eq!(truncation.plant, given.plant);
    assert_eq!(given.arm, ArmParams::default());
    assert_eq!(given.patch, PiezoPatch::paper());
    assert_ne!(truncation.arm, given.arm);
    let f1 = truncation.arm.modes.omega.x / std::f64::consts::TAU;
    assert!((f1 - 4.54).abs() < 0.01, "{f1}");
}

/// The film's feedthrough (`plant.film_bond`): right after a step of the patch voltage the film
/// jumps by `β F ΔV` before any mode has moved, and without it there is no jump; the jump is
/// opposite in sign to the slow (bending) response that follows.
#[test]
fn the_film_jumps_by_the_bonds_share_of_the_feedthrough() {
    let f = flexarm_core::control::piezo::PiezoMaterial::<f64> {
        t_b: flexarm_host::truth_plant::DEFAULT_THICKNESS,
        ..Default::default()
    }
    .film_feedthrough();
    let dt = 1e-5;
    for bond in [0.0, 0.5, 1.0] {
        let spec = TruthSpec {
            modes: 4,
            film_bond: bond,
            ..TruthSpec::default().ideal_actuators()
        };
        let mut p = plant::<6>(&spec);
        p.step(&Vector2::zeros(), 10.0, dt).unwrap();
        let jump = p.film();
        // The modes move by t²/2 · Σ g_j ΔV in the first step: 6.6e-8 V here, 6e-6 of the jump.
        assert!(
            (jump - bond * f * 10.0).abs() < 1e-5 * (f * 10.0).abs(),
            "bond {bond}: {jump} vs {}",
            bond * f * 10.0
        );
        // 0.2 s later the bending path has taken over, with the other sign.
        for _ in 0..20_000 {
            p.step(&Vector2::zeros(), 10.0, dt).unwrap();
        }
        assert!(p.film() > 0.0, "bond {bond}: {}", p.film());
    }
}

/// Steps the plant `p` at `dt` [s] after a torque pulse: whether its rates stay within twice
/// what the pulse gave them (the damped mechanics' decay, a joint without friction coasts).
fn stays_put(p: &mut dyn Plant, dt: f64) -> bool {
    let pulse = Vector2::new(0.5, 0.3);
    let mut after_pulse = 0.0;
    for k in 0..20_000 {
        let tau = if k < 5 { pulse } else { Vector2::zeros() };
        if p.step(&tau, 0.0, dt).is_err() {
            return false;
        }
        if k == 5 {
            after_pulse = p.state().qd.abs().max();
        }
    }
    p.state().qd.abs().max() <= 2.0 * after_pulse
}

#[test]
fn the_stable_step_is_where_rk4_stops_diverging() {
    // A family of links: stiffer, softer, more modes, a payload, stiff viscous joints; and the
    // controller's own model with fast modes. Just inside the stable step each stays put after
    // a torque pulse; just outside it does not (its fastest rate grows by |R(λ h)| > 1 a step,
    // until it diverges or the nonlinear terms hold it in a motion of their own).
    let spec = |modes, thickness, tip_mass, viscous| {
        let mut s = TruthSpec {
            modes,
            thickness,
            tip_mass,
            ..TruthSpec::default()
        };
        for m in &mut s.motors {
            m.viscous = viscous;
        }
        s
    };
    let mut checked = String::new();
    for s in [
        spec(10, 2.5e-3, 0.0, 0.02),
        spec(6, 4e-3, 0.0, 0.02),
        spec(3, 1.5e-3, 0.1, 0.02),
        spec(2, 2.5e-3, 0.0, 500.0),
    ] {
        let cfg = SimConfig::default().with_truth(s).unwrap();
        let stable = cfg.plant_at(Vector2::zeros()).unwrap().stable_step();
        // At the pose where it is fastest.
        let pose = Vector2::new(0.0, stable.theta2);
        for (factor, put) in [(0.95, true), (1.05, false)] {
            let mut p = cfg.plant_at(pose).unwrap();
            assert_eq!(
                stays_put(p.as_mut(), factor * stable.dt),
                put,
                "{} modes, t_b {}, viscous {}: {factor} x {:.3e} s",
                s.modes,
                s.thickness,
                s.motors[0].viscous,
                stable.dt
            );
        }
        checked += &format!(" {:.3e}", stable.dt);
    }
    // The controller's model with fast modes (a scenario's `[arm] frequency_hz` up to 1 kHz).
    let mut arm = ArmParams::<f64>::default();
    arm.modes = flexarm_core::params::ModalData::uniform(
        arm.m2,
        arm.a2,
        flexarm_core::Vector2::new(200.0, 900.0) * std::f64::consts::TAU,
        arm.modes.zeta,
    );
    let cfg = SimConfig {
        arm,
        ..SimConfig::default()
    };
    let stable = cfg.plant_at(Vector2::zeros()).unwrap().stable_step();
    for (factor, put) in [(0.95, true), (1.05, false)] {
        let mut p = cfg.plant_at(Vector2::new(0.0, stable.theta2)).unwrap();
        assert_eq!(
            stays_put(p.as_mut(), factor * stable.dt),
            put,
            "model plant"
        );
    }
    println!(
        "stable steps [s]: {checked}, model plant with 900 Hz: {:.3e}",
        stable.dt
    );
}
