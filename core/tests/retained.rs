//! State that survives a reset (`flexarm_core::retained`): the motors' heat restored from its
//! store, or assumed hot when the store is not valid (zeroed or random RAM, a checksum that does
//! not match, a write torn by the reset); and a category-1 fault while holding, which stops
//! under control and latches with the safe command in the period the stop ends.

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use flexarm_core::control::motor::{MotorController, MotorLaw};
use flexarm_core::control::piezo::{PiezoGains, PiezoLaw, PiezoPatch};
use flexarm_core::controller::Controller;
use flexarm_core::drive::{Drive, Mode, MoveLimits};
use flexarm_core::model::Model;
use flexarm_core::motion::MotionLimits;
use flexarm_core::observer::{Measurement, Observer, film_map};
use flexarm_core::observer_gains::{GAIN_1KHZ, gain};
use flexarm_core::params::{ArmParams, Gains, Limits};
use flexarm_core::retained::{HEAT_MAGIC, HeatStore};
use flexarm_core::supervisor::{Command, SensorLimits};
use flexarm_core::time::Ticks;
use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
use flexarm_core::{Fault, Vector2};

/// The controller as the hardware board has it (1 kHz), on the paper's arm.
fn controller() -> Controller<f32> {
    let patch = PiezoPatch::paper();
    Controller::new(
        MotorController {
            model: Model::new(ArmParams::default()),
            gains: Gains::default(),
            limits: Limits::default(),
            law: MotorLaw::Robust,
        },
        PiezoLaw::new(
            &PiezoGains::default(),
            1e-4,
            Limits::<f32>::default().v_a_max,
        ),
        patch,
        Observer::new(gain(&GAIN_1KHZ), film_map(&patch), 1e-3, Vector2::zeros()),
        SensorLimits::default(),
        JointTrajectory::Trapezoid(Trapezoid::paper()),
        1e-3,
        3,
    )
}

fn y(th1: f32, th2: f32) -> Measurement<f32> {
    Measurement {
        theta: Vector2::new(th1, th2),
        v_f: 0.0,
    }
}

/// A drive armed and holding at rest at (0, 0) for 50 periods; the next tick.
fn holding() -> (Controller<f32>, Drive<f32>, u64) {
    let mut ctrl = controller();
    let mut d = Drive::new(&mut ctrl, 1000, Ticks(0), MoveLimits::default());
    // The encoders' frame declared the arm's (issue 33's homing: no arm before it).
    d.declare_zero(&mut ctrl).unwrap();
    d.arm(&mut ctrl, Ticks(0)).unwrap();
    for k in 0..50 {
        let r = d.step(&mut ctrl, Ticks(k), Some(&y(0.0, 0.0)));
        assert!(r.command.enable);
    }
    (ctrl, d, 50)
}

#[test]
fn a_valid_store_gives_the_heat_back_to_the_bit() {
    let heat = Vector2::new(0.731_234_5_f32, 0.012_5);
    let mut store = HeatStore::invalid();
    store.store(heat);
    assert_eq!(store.magic, HEAT_MAGIC);
    let mut ctrl = controller();
    let mut d = Drive::new(&mut ctrl, 1000, Ticks(0), MoveLimits::default());
    assert!(d.restore_heat(&store));
    assert_eq!(d.monitor().heat, heat);
    // Hot from the first step: derated above 0.6 (`MotionMonitor::torque_limit`).
    let expected = d
        .monitor()
        .torque_limit(&d.motion, Vector2::new(10.0, 10.0));
    d.step(&mut ctrl, Ticks(0), Some(&y(0.0, 0.0)));
    assert_eq!(ctrl.motor.limits.tau_max.x, expected.x);
    assert!(ctrl.motor.limits.tau_max.x < 10.0 && ctrl.motor.limits.tau_max.y == 10.0);
}

/// Every invalid store: the motors assumed hot (the floor of the derating), and the torque
/// limit is the continuous rating from the first step.
#[test]
fn an_invalid_store_assumes_the_motors_hot() {
    let thermal = MotionLimits::<f32>::default_for(1000).thermal;
    let mut valid = HeatStore::invalid();
    valid.store(Vector2::new(0.2, 0.3));
    let flipped = HeatStore {
        heat: [valid.heat[0] ^ 1, valid.heat[1]],
        ..valid
    };
    // A reset in the middle of the next write: the magic and the first heat written, the
    // second and the checksum still the previous write's.
    let mut torn = valid;
    torn.magic = HEAT_MAGIC;
    torn.heat[0] = 0.25_f32.to_bits();
    // Values no model gives, under a matching checksum.
    let mut nan = HeatStore::invalid();
    nan.store(Vector2::new(f32::NAN, 0.0));
    let mut negative = HeatStore::invalid();
    negative.store(Vector2::new(-0.1, 0.0));
    let mut huge = HeatStore::invalid();
    huge.store(Vector2::new(7.0, 0.0)); // (10/4)² = 6.25 is the most a 10 N·m limit gives
    let wrong_magic = HeatStore {
        magic: HEAT_MAGIC ^ 0x100,
        ..valid
    };
    let cases = [
        ("zeroed RAM", HeatStore::invalid()),
        ("a flipped bit", flipped),
        ("a torn write", torn),
        ("NaN", nan),
        ("negative", negative),
        ("beyond the torque limit's reach", huge),
        ("a wrong magic", wrong_magic),
    ];
    for (what, store) in cases {
        assert_eq!(store.load(6.25), None, "{what}");
        let mut ctrl = controller();
        let mut d = Drive::new(&mut ctrl, 1000, Ticks(0), MoveLimits::default());
        assert!(!d.restore_heat(&store), "{what}");
        let hot = thermal.assumed_hot();
        assert_eq!(d.monitor().heat, Vector2::new(hot, hot), "{what}");
        d.step(&mut ctrl, Ticks(0), Some(&y(0.0, 0.0)));
        assert_eq!(ctrl.motor.limits.tau_max, thermal.continuous, "{what}");
    }
    // The previous write itself was whole.
    assert_eq!(valid.load(6.25), Some(Vector2::new(0.2, 0.3)));
}

/// A motor that reaches its trip level while the drive holds at rest: the controlled stop is
/// done at once, so the fault latches and this period's command is already the safe one (it
/// was the law's, amplifiers on, one period late, before).
#[test]
fn a_category_1_fault_while_holding_at_rest_is_safe_in_the_same_period() {
    let (mut ctrl, mut d, k) = holding();
    d.heat_for_test(Vector2::new(0.96, 0.0));
    let r = d.step(&mut ctrl, Ticks(k), Some(&y(0.0, 0.0)));
    assert_eq!(ctrl.fault(), Some(Fault::Overload));
    assert_eq!(r.command, Command::safe());
    assert_eq!(d.mode(&ctrl), Mode::Fault);
}

/// Holding while a joint moves (knocked): a category-1 fault holds on under control, amplifiers
/// on, for the time the move limits' deceleration needs to bring the joint's estimated speed to
/// rest, then latches with the safe command in that period (it cut the power at once before,
/// a category 0).
#[test]
fn a_category_1_fault_while_holding_and_moving_stops_under_control() {
    let (mut ctrl, mut d, mut k) = holding();
    // Joint 1 knocked away at 1 rad/s for 8 ms (the reading moves, the hold stays at 0; under
    // the runaway check's error).
    for i in 1..=8 {
        d.step(&mut ctrl, Ticks(k), Some(&y(1e-3 * i as f32, 0.0)));
        k += 1;
    }
    let speed = ctrl.estimate().1.x.abs();
    assert!(speed > 0.05, "the observer sees the knock: {speed} rad/s");
    let theta = y(0.008, 0.0);
    d.heat_for_test(Vector2::new(0.96, 0.0));
    let r = d.step(&mut ctrl, Ticks(k), Some(&theta));
    k += 1;
    let speed = ctrl.estimate().1.x.abs().max(ctrl.estimate().1.y.abs());
    assert_eq!(ctrl.fault(), None, "no safe state while it stops");
    assert_eq!(d.pending(), Some(Fault::Overload));
    assert_eq!(d.mode(&ctrl), Mode::Stopping);
    assert!(r.command.enable);
    // The stop's length, from the speed the drive saw (`accel_max` 10 rad/s²), within a period
    // of the estimate's change since.
    let expected = (speed / 10.0 * 1000.0).round() as u64;
    let mut periods: u64 = 1;
    loop {
        let r = d.step(&mut ctrl, Ticks(k), Some(&theta));
        k += 1;
        if ctrl.fault().is_some() {
            assert_eq!(ctrl.fault(), Some(Fault::Overload));
            assert_eq!(r.command, Command::safe(), "safe in the period it latches");
            break;
        }
        assert!(r.command.enable, "amplifiers on while it stops");
        periods += 1;
        assert!(periods < 1000, "the stop ends");
    }
    println!("stopped in {periods} periods, {expected} expected from {speed} rad/s");
    assert!(periods >= 2 && periods.abs_diff(expected) <= 2);
}

/// A torque limit set while the motors are (assumed) hot, as a bring-up sets 3 N·m in the first
/// seconds after a power-on: it holds while they cool and stays once they are cool (the old
/// derating went on from the previous rated 10 N·m, 8 N·m at a state of 0.7, and restored
/// 10 N·m once cool).
#[test]
fn a_torque_limit_set_while_hot_is_kept() {
    let mut ctrl = controller();
    let mut d = Drive::new(&mut ctrl, 1000, Ticks(0), MoveLimits::default());
    assert!(!d.restore_heat(&HeatStore::invalid()));
    d.step(&mut ctrl, Ticks(0), Some(&y(0.0, 0.0)));
    assert_eq!(ctrl.motor.limits.tau_max, Vector2::new(4.0, 4.0));
    // The link's `Set (TauMax0/1, 3)` at rest.
    ctrl.motor.limits.tau_max = Vector2::new(3.0, 3.0);
    for (k, heat) in [(1, 0.85), (2, 0.7), (3, 0.62), (4, 0.3), (5, 0.0)] {
        d.heat_for_test(Vector2::new(heat, heat));
        d.step(&mut ctrl, Ticks(k), Some(&y(0.0, 0.0)));
        let limit = ctrl.motor.limits.tau_max;
        assert!(limit.x <= 3.0 && limit.y <= 3.0, "at {heat}: {limit:?}");
    }
    assert_eq!(
        ctrl.motor.limits.tau_max,
        Vector2::new(3.0, 3.0),
        "kept once cool"
    );
    assert_eq!(d.rated_torque(), Vector2::new(3.0, 3.0));
    // One joint set while hot (the link's `Set` writes the other's derated value back with
    // it): the other keeps its rated limit.
    d.heat_for_test(Vector2::new(0.9, 0.9));
    d.step(&mut ctrl, Ticks(6), Some(&y(0.0, 0.0)));
    ctrl.motor.limits.tau_max.x = 2.5;
    d.heat_for_test(Vector2::new(0.0, 0.0));
    d.step(&mut ctrl, Ticks(7), Some(&y(0.0, 0.0)));
    d.step(&mut ctrl, Ticks(8), Some(&y(0.0, 0.0)));
    assert_eq!(ctrl.motor.limits.tau_max, Vector2::new(2.5, 3.0));
}
