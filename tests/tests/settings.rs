//! The settings saved on the board (issue 36) on the host's rig: the QEMU board's firmware
//! configuration, its running values saved (`Session::values`) and applied at a new boot
//! (`Session::apply`, each value through a `Set`'s checks), and a record with a value the
//! board's checks refuse: refused whole, every value applied before it set back, the build's
//! defaults running.

use flexarm_host::rig::Rig;
use flexarm_link::msg::{Board, Command, Param, Reply};
use flexarm_machine::simulated::SimulatedArm;
use flexarm_machine::store::Values;
use flexarm_tests::{firmware, rig};
use rtic_core::Exclusive;

fn qemu() -> Rig<SimulatedArm> {
    rig(firmware(Board::Qemu), [0.0, 0.0])
}

fn periods(r: &mut Rig<SimulatedArm>, n: usize) {
    for _ in 0..n {
        r.period();
    }
}

fn values(r: &Rig<SimulatedArm>) -> Values {
    r.session.values(&r.control, &r.drive)
}

fn apply(r: &mut Rig<SimulatedArm>, v: &Values) -> Result<(), Param> {
    r.session.apply(
        v,
        &mut Exclusive(&mut r.control),
        &mut Exclusive(&mut r.drive),
    )
}

/// What a save keeps: every parameter but the piezo bias, at its running value.
#[test]
fn a_save_keeps_the_running_values_and_a_new_boot_applies_them() {
    let mut a = qemu();
    assert_eq!(a.answer(Command::Set(Param::Kc, 12.0)), Reply::Done);
    assert_eq!(a.answer(Command::Set(Param::LinkTimeout, 2.0)), Reply::Done);
    assert_eq!(a.answer(Command::Set(Param::TauMax1, 4.0)), Reply::Done);
    // The drive takes the rated torque from the controller at its next period.
    periods(&mut a, 10);
    let saved = values(&a);
    assert_eq!(saved.get(Param::VaBias as usize), None);
    assert_eq!(saved.get(Param::Kc as usize), Some(12.0));
    // A new boot: the build's defaults, then the saved values.
    let mut b = qemu();
    assert_eq!(b.answer(Command::Get(Param::Kc)), Reply::Value(30.0));
    assert_eq!(apply(&mut b, &saved), Ok(()));
    periods(&mut b, 10);
    assert_eq!(values(&b), saved);
    assert_eq!(b.answer(Command::Get(Param::Kc)), Reply::Value(12.0));
    assert_eq!(
        b.answer(Command::Get(Param::LinkTimeout)),
        Reply::Value(2.0)
    );
    assert_eq!(b.answer(Command::Get(Param::TauMax1)), Reply::Value(4.0));
}

/// A record whose value the board's checks refuse (a `K_p` far outside the sampled loop's
/// stable region, within the declared range): refused whole, the values before it set back.
#[test]
fn a_refused_value_leaves_the_builds_defaults() {
    let defaults = values(&qemu());
    let mut bad = defaults;
    // Applied before the refused one (the wire's order: kp0 first, kc later).
    bad.0[Param::Kp1 as usize] = 5.0;
    bad.0[Param::Kc as usize] = 12.0;
    bad.0[Param::Lambda0 as usize] = 9000.0;
    let mut r = qemu();
    assert_eq!(apply(&mut r, &bad), Err(Param::Lambda0));
    periods(&mut r, 10);
    assert_eq!(values(&r), defaults);
    // Out of the declared range, and NaN-free: refused too.
    let mut out = defaults;
    out.0[Param::Kc as usize] = 1e9;
    assert_eq!(apply(&mut r, &out), Err(Param::Kc));
    assert_eq!(values(&r), defaults);
}
