//! Fault injection on the host: every fault drives the outputs to the safe state within the
//! same control period, latches until an explicit reset, and keeps its first cause.

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)] // tests may index and unwrap

use flexarm_core::control::motor::{MotorController, MotorLaw};
use flexarm_core::control::piezo::{PiezoGains, PiezoLaw, PiezoPatch};
use flexarm_core::controller::Controller;
use flexarm_core::model::Model;
use flexarm_core::observer::{Measurement, Observer, film_map};
use flexarm_core::observer_gains::{GAIN_1KHZ, gain};
use flexarm_core::params::{ArmParams, Gains, Limits};
use flexarm_core::supervisor::{Command, SensorLimits};
use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
use flexarm_core::{Fault, Vector2};
use proptest::prelude::*;

/// `Controller::new` with the given arm, piezo law, patch and observer; the rest as the
/// firmware has it.
fn assemble(
    arm: ArmParams<f32>,
    piezo: PiezoLaw<f32>,
    patch: PiezoPatch<f32>,
    observer: Observer<f32>,
) -> Controller<f32> {
    Controller::new(
        MotorController {
            model: Model::new(arm),
            gains: Gains::default(),
            limits: Limits::default(),
            law: MotorLaw::Robust,
        },
        piezo,
        patch,
        observer,
        SensorLimits::default(),
        JointTrajectory::Trapezoid(Trapezoid::paper()),
        1e-3,
        3,
    )
}

fn piezo_law(gains: &PiezoGains<f32>) -> PiezoLaw<f32> {
    PiezoLaw::new(gains, 1e-4, Limits::<f32>::default().v_a_max)
}

fn observer(patch: &PiezoPatch<f32>) -> Observer<f32> {
    Observer::new(gain(&GAIN_1KHZ), film_map(patch), 1e-3, Vector2::zeros())
}

fn controller_with(arm: ArmParams<f32>) -> Controller<f32> {
    let patch = PiezoPatch::paper();
    assemble(
        arm,
        piezo_law(&PiezoGains::default()),
        patch,
        observer(&patch),
    )
}

fn controller() -> Controller<f32> {
    controller_with(ArmParams::default())
}

fn y(th1: f32, th2: f32, v_f: f32) -> Measurement<f32> {
    Measurement {
        theta: Vector2::new(th1, th2),
        v_f,
    }
}

/// Runs 50 healthy steps, then the faulty one; checks the safe state at once and after.
fn inject(fault_step: impl FnOnce(&mut Controller<f32>) -> Command<f32>, expect: Fault) {
    let mut c = controller();
    for k in 0..50 {
        let r = c.motor_step(k as f32 * 1e-3, Some(&y(0.0, 0.0, 0.0)));
        assert!(r.command.enable, "healthy step {k} must run");
        c.piezo_step(0.0);
    }
    let cmd = fault_step(&mut c);
    assert_eq!(
        cmd,
        Command::safe(),
        "safe within the faulty period for {expect:?}"
    );
    assert_eq!(c.fault(), Some(expect));
    // Latched: healthy samples do not clear it, and the first cause stays.
    for k in 0..10 {
        let r = c.motor_step(0.06 + k as f32 * 1e-3, Some(&y(0.0, 0.0, 0.0)));
        assert_eq!(r.command, Command::safe());
        assert_eq!(c.piezo_step(1.0), 0.0);
    }
    c.trip(Fault::Amplifier);
    assert_eq!(c.fault(), Some(expect), "first cause kept");
    // An explicit reset brings it back, the piezo loop included (its film gate reopens).
    c.reset(Vector2::zeros());
    assert!(c.motor_step(0.1, Some(&y(0.0, 0.0, 0.0))).command.enable);
    assert_eq!(c.piezo_step(0.0), 0.0, "the filter restarts");
    assert!(
        c.piezo_step(1e-3) < 0.0,
        "a rising film voltage is damped again"
    );
}

#[test]
fn nan_encoder() {
    inject(
        |c| c.motor_step(0.05, Some(&y(f32::NAN, 0.0, 0.0))).command,
        Fault::NonFinite,
    );
}

#[test]
fn infinite_film_voltage_in_the_motor_loop() {
    inject(
        |c| {
            c.motor_step(0.05, Some(&y(0.0, 0.0, f32::INFINITY)))
                .command
        },
        Fault::NonFinite,
    );
}

#[test]
fn nan_film_voltage_in_the_piezo_loop() {
    inject(
        |c| {
            assert_eq!(c.piezo_step(f32::NAN), 0.0);
            c.motor_step(0.05, Some(&y(0.0, 0.0, 0.0))).command
        },
        Fault::NonFinite,
    );
}

#[test]
fn angle_out_of_range() {
    inject(
        |c| c.motor_step(0.05, Some(&y(0.0, 3.0, 0.0))).command,
        Fault::OutOfRange,
    );
}

#[test]
fn film_voltage_out_of_range() {
    inject(
        |c| c.motor_step(0.05, Some(&y(0.0, 0.0, 11.0))).command,
        Fault::OutOfRange,
    );
}

#[test]
fn encoder_jump() {
    // 20 rad/s × 1 ms = 0.02 rad per period at most.
    inject(
        |c| c.motor_step(0.05, Some(&y(0.05, 0.0, 0.0))).command,
        Fault::EncoderJump,
    );
}

#[test]
fn stale_samples() {
    inject(
        |c| {
            for k in 0..3 {
                assert!(
                    c.motor_step(0.05 + k as f32 * 1e-3, None).command.enable,
                    "3 missed samples are tolerated"
                );
            }
            c.motor_step(0.053, None).command
        },
        Fault::Stale,
    );
}

#[test]
fn overrun_amplifier_and_watchdog_from_outside() {
    for f in [Fault::Overrun, Fault::Amplifier, Fault::Watchdog] {
        inject(
            |c| {
                c.trip(f);
                c.motor_step(0.05, Some(&y(0.0, 0.0, 0.0))).command
            },
            f,
        );
    }
}

#[test]
fn non_finite_clock() {
    inject(
        |c| c.motor_step(f32::NAN, Some(&y(0.0, 0.0, 0.0))).command,
        Fault::NonFinite,
    );
}

/// The controller keeps its estimate finite: a reset at non-finite encoder angles trips at once
/// and leaves the estimate as it was.
#[test]
fn reset_at_non_finite_angles() {
    let mut c = controller();
    let before = c.estimate();
    c.reset_observer(Vector2::new(0.1, f32::INFINITY));
    assert_eq!(c.fault(), Some(Fault::NonFinite));
    assert_eq!(c.estimate(), before);
    c.reset(Vector2::new(f32::NAN, 0.0));
    assert_eq!(c.fault(), Some(Fault::NonFinite));
    assert_eq!(c.estimate(), before);
    assert_eq!(
        c.motor_step(0.0, Some(&y(0.0, 0.0, 0.0))).command,
        Command::safe()
    );
    c.reset(Vector2::new(0.1, 0.2));
    assert_eq!(c.fault(), None);
    assert_eq!(c.estimate().0.xy(), Vector2::new(0.1, 0.2));
}

#[test]
fn non_finite_observer_is_an_invalid_configuration() {
    let patch = PiezoPatch::paper();
    let mut l = gain(&GAIN_1KHZ);
    l[(5, 2)] = f32::NAN;
    let obs = Observer::new(l, film_map(&patch), 1e-3, Vector2::zeros());
    let c = assemble(
        ArmParams::default(),
        piezo_law(&PiezoGains::default()),
        patch,
        obs,
    );
    assert_eq!(c.fault(), Some(Fault::InvalidConfig));
}

/// A piezo law that does not damp (`k_c ≤ 0`, a corner that is not positive, NaN) is refused by
/// `Controller::new` itself, whatever built it.
#[test]
fn piezo_law_that_does_not_damp_is_an_invalid_configuration() {
    let patch = PiezoPatch::paper();
    let ok = assemble(
        ArmParams::default(),
        piezo_law(&PiezoGains::default()),
        patch,
        observer(&patch),
    );
    assert_eq!(ok.fault(), None);
    for (k_c, cutoff_hz) in [
        (-30.0, 100.0),
        (0.0, 100.0),
        (30.0, 0.0),
        (30.0, -100.0),
        (f32::NAN, 100.0),
        (30.0, f32::INFINITY),
    ] {
        let g = PiezoGains { k_c, cutoff_hz };
        let c = assemble(ArmParams::default(), piezo_law(&g), patch, observer(&patch));
        assert_eq!(
            c.fault(),
            Some(Fault::InvalidConfig),
            "k_c {k_c}, corner {cutoff_hz}"
        );
    }
}

#[test]
fn invalid_configuration_starts_in_the_safe_state() {
    let arm = ArmParams::<f32> {
        m2: -1.0,
        ..Default::default()
    };
    let mut c = controller_with(arm);
    assert_eq!(c.fault(), Some(Fault::InvalidConfig));
    assert_eq!(
        c.motor_step(0.0, Some(&y(0.0, 0.0, 0.0))).command,
        Command::safe()
    );
    assert_eq!(c.piezo_step(1.0), 0.0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(10_000))]
    /// Whatever the inputs (any bit pattern, NaN and ±∞ included), the steps never panic and
    /// their outputs are finite and inside the limits.
    #[test]
    fn outputs_are_always_finite_and_bounded(
        steps in proptest::collection::vec((any::<u32>(), any::<u32>(), any::<u32>(), any::<u32>(), any::<bool>()), 1..8),
        t0 in any::<u32>(),
    ) {
        let mut c = controller();
        let lim = c.motor.limits;
        for (k, (a, b, v, t, fresh)) in steps.into_iter().enumerate() {
            let f = |bits: u32, plausible: bool| if plausible { (bits as f32 / u32::MAX as f32 - 0.5) * 0.01 } else { f32::from_bits(bits) };
            // Half of the samples are plausible (so the laws run), half arbitrary bits.
            let plausible = t % 2 == 0;
            let m = y(f(a, plausible), f(b, plausible), f(v, plausible));
            let time = if plausible { k as f32 * 1e-3 } else { f32::from_bits(t0 ^ t) };
            let r = c.motor_step(time, if fresh { Some(&m) } else { None });
            prop_assert!(r.command.tau.iter().zip(lim.tau_max.iter()).all(|(x, l)| x.is_finite() && x.abs() <= *l));
            prop_assert!(r.command.v_a.is_finite() && r.command.v_a.abs() <= lim.v_a_max);
            let v_a = c.piezo_step(f(v ^ t, plausible));
            prop_assert!(v_a.is_finite() && v_a.abs() <= lim.v_a_max);
        }
    }
}

#[test]
fn patch_off_the_link_is_an_invalid_configuration() {
    let mut patch = PiezoPatch::<f32>::paper();
    patch.l_a = 0.9;
    assert_eq!(
        patch.validate(0.7),
        Err(flexarm_core::ParamError::PatchOutsideLink)
    );
    assert_eq!(PiezoPatch::<f32>::paper().validate(0.7), Ok(()));
    let c = assemble(
        ArmParams::default(),
        piezo_law(&PiezoGains::default()),
        patch,
        observer(&patch),
    );
    assert_eq!(c.fault(), Some(Fault::InvalidConfig));
}

#[test]
fn with_model_is_paper_for_the_papers_arm_and_patch_and_refuses_a_bad_arm_patch_or_gain() {
    let build_on = |arm: ArmParams<f32>, patch: PiezoPatch<f32>, k_c: f32| {
        Controller::with_model(
            arm,
            MotorLaw::Tracking,
            JointTrajectory::Trapezoid(Trapezoid::paper()),
            1e-4,
            1e-3,
            gain(&GAIN_1KHZ),
            patch,
            PiezoGains {
                k_c,
                ..PiezoGains::default()
            },
            Limits::default(),
        )
    };
    let build = |patch, k_c| build_on(ArmParams::default(), patch, k_c);
    let paper = Controller::paper(
        MotorLaw::Tracking,
        JointTrajectory::Trapezoid(Trapezoid::paper()),
        1e-4,
        1e-3,
        gain(&GAIN_1KHZ),
    );
    assert_eq!(build(PiezoPatch::paper(), 30.0), paper);
    assert_eq!(paper.fault(), None);
    // Another patch on the link: runs, and the piezo law uses the given gain.
    let other = PiezoPatch::uniform(&Default::default(), 0.3, 0.7, 0.0, 0.5);
    let mut c = build(other, 100.0);
    assert_eq!(c.fault(), None);
    assert_eq!(c.patch, other);
    let _ = c.piezo_step(0.0);
    let mut p = paper;
    let _ = p.piezo_step(0.0);
    let (v_other, v_paper) = (c.piezo_step(1e-3), p.piezo_step(1e-3));
    assert!(v_paper < 0.0 && v_paper > -200.0, "{v_paper}");
    assert!(
        (v_other / v_paper - 100.0 / 30.0).abs() < 1e-5,
        "{v_other} {v_paper}"
    );
    // Off the link, or a gain that is not positive: the safe state from the start.
    let mut off = other;
    off.x_a = 0.3;
    for c in [build(off, 30.0), build(other, 0.0), build(other, f32::NAN)] {
        assert_eq!(c.fault(), Some(Fault::InvalidConfig));
    }
    // Another arm (an identified one): runs on its own model.
    let mut arm = ArmParams::<f32>::default();
    arm.i_h2 *= 1.1;
    arm.modes.omega *= 0.95;
    let c = build_on(arm, PiezoPatch::paper(), 30.0);
    assert_eq!(c.fault(), None);
    assert_eq!(c.motor.model.params, arm);
    // An arm that fails its own check (modes out of order, a negative inertia), or a patch
    // past the end of a shorter link 2: the safe state from the start.
    let swapped = ArmParams {
        modes: flexarm_core::params::ModalData {
            omega: Vector2::new(arm.modes.omega.y, arm.modes.omega.x),
            ..arm.modes
        },
        ..arm
    };
    let negative = ArmParams { i_1: -0.1, ..arm };
    let short = ArmParams { a2: 0.4, ..arm };
    for bad in [swapped, negative, short] {
        let c = build_on(bad, PiezoPatch::paper(), 30.0);
        assert_eq!(c.fault(), Some(Fault::InvalidConfig), "{bad:?}");
    }
}

#[test]
fn a_railed_film_reading_is_out_of_range() {
    // The ADC's full scale is ±10 V: a reading on the rail is saturated, not a measurement.
    for (v, expect) in [(10.0, Fault::OutOfRange), (-10.0, Fault::OutOfRange)] {
        inject(
            |c| c.motor_step(0.05, Some(&y(0.0, 0.0, v))).command,
            expect,
        );
        let mut c = controller();
        assert_eq!(c.piezo_step(v), 0.0);
        assert_eq!(c.fault(), Some(expect));
    }
    let mut c = controller();
    c.piezo_step(9.99);
    assert_eq!(c.fault(), None, "just inside the rail");
}

#[test]
fn the_amplifier_fault_line_counts_only_while_enabled_settled_and_steady() {
    use flexarm_core::supervisor::AmplifierMonitor;
    let mut m = AmplifierMonitor::new(5, 3);
    // Asserted while disabled (many amplifiers do): ignored, however long.
    for _ in 0..100 {
        assert_eq!(m.update(false, true), Ok(()));
    }
    // Enabled: the first 5 samples settle.
    for _ in 0..5 {
        assert_eq!(m.update(true, true), Ok(()));
    }
    // Glitches shorter than 3 samples never trip.
    for _ in 0..20 {
        assert_eq!(m.update(true, true), Ok(()));
        assert_eq!(m.update(true, true), Ok(()));
        assert_eq!(m.update(true, false), Ok(()));
    }
    // Three in a row do.
    assert_eq!(m.update(true, true), Ok(()));
    assert_eq!(m.update(true, true), Ok(()));
    assert_eq!(m.update(true, true), Err(Fault::Amplifier));
    // Disabling resets it, and the settling starts again.
    assert_eq!(m.update(false, true), Ok(()));
    for _ in 0..5 {
        assert_eq!(m.update(true, true), Ok(()));
    }
    assert_eq!(m.update(true, true), Ok(()));
    assert_eq!(m.update(true, true), Ok(()));
    assert_eq!(m.update(true, true), Err(Fault::Amplifier));
    // A debounce of 0 means 1.
    assert_eq!(
        AmplifierMonitor::new(0, 0).update(true, true),
        Err(Fault::Amplifier)
    );
}

#[test]
fn every_fault_has_its_own_stable_name() {
    let all = [
        Fault::NonFinite,
        Fault::OutOfRange,
        Fault::Stale,
        Fault::EncoderJump,
        Fault::Watchdog,
        Fault::Overrun,
        Fault::Amplifier,
        Fault::InvalidConfig,
        Fault::Singular,
        Fault::Clock,
        Fault::BrownOutDisabled,
    ];
    for (i, a) in all.iter().enumerate() {
        assert_eq!(*a as u8, i as u8 + 1, "codes start at 1, in order");
        for b in &all[i + 1..] {
            assert_ne!(a.as_str(), b.as_str());
        }
    }
}

/// Every fault's stable number round-trips, in order from 1.
#[test]
fn fault_codes_round_trip() {
    for (i, f) in Fault::ALL.iter().enumerate() {
        assert_eq!(*f as u8, i as u8 + 1, "{f:?}");
        assert_eq!(Fault::from_code(*f as u8), Some(*f));
    }
    assert_eq!(Fault::from_code(0), None);
    assert_eq!(Fault::from_code(Fault::ALL.len() as u8 + 1), None);
}
