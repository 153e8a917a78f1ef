//! The piezo laws a board can select (issue 35, `flexarm_core::control::select`) run on the
//! truth plant through the host's rig (`flexarm_host::rig`: the firmware's controller, drive
//! and link session at the hardware board's rates, 10 kHz and 1 kHz): six modes of the 2.5 mm
//! link, the 5 kHz amplifier, the film amplifier's 0.5 Hz high-pass, the drives' friction, and
//! the film's feedthrough at the bond factor `β` of each case.
//!
//! Each law is chosen over the link as an operator would (`set film_static`, `set piezo_law`,
//! while disarmed), the drive armed and holding at `(0, π/4)` rad, the patch struck by a
//! 0.1 s, 30 V pulse of the link's piezo bias, and the decay of the tip's vibration (the
//! standard deviation of its deflection) measured between the half second after the pulse and
//! the half second one second later. The film's static gain is the truth plant's (an ideal
//! commissioning, as in the spillover study: `spillover_study::identified`). The rate law runs
//! with its design rule's gains (3.16 s, 30 Hz; the shipped 30 s is unstable on this link,
//! docs/results.md). `cargo test -p flexarm-host --test piezo_laws -- --nocapture` prints the
//! figures.

use flexarm_core::Vector2;
use flexarm_core::control::piezo::{PiezoGains, PiezoPatch};
use flexarm_core::control::select::PiezoLawKind;
use flexarm_core::params::ArmParams;
use flexarm_host::rig::{PlantBoard, Rig};
use flexarm_host::sim::SimConfig;
use flexarm_host::spillover::ModalLink;
use flexarm_host::spillover_study::identified;
use flexarm_host::truth_plant::TruthSpec;
use flexarm_link::Command;
use flexarm_link::msg::{Param, Refusal, Reply};

/// The pulse of the piezo bias [V] and its length [s].
const PULSE: (f32, f64) = (30.0, 0.1);

fn spec(bond: f64) -> TruthSpec {
    TruthSpec {
        film_bond: bond,
        ..TruthSpec::default()
    }
}

/// The truth link's static film gain `G(0)` [V/V] at bond factor `bond`: every mode and the
/// feedthrough.
fn static_gain(bond: f64) -> f64 {
    let link =
        ModalLink::from_truth(&spec(bond), &ArmParams::default(), &PiezoPatch::paper()).unwrap();
    identified(&link).static_gain()
}

fn rig(bond: f64) -> Rig<PlantBoard> {
    let mut cfg = SimConfig::default().with_truth(spec(bond)).unwrap();
    cfg.piezo = Some(PiezoGains {
        k_c: 3.16,
        cutoff_hz: 30.0,
    });
    cfg.run_board(Vector2::new(0.0, std::f64::consts::FRAC_PI_4))
        .unwrap()
}

fn set(rig: &mut Rig<PlantBoard>, p: Param, v: f32) -> Reply {
    rig.answer(Command::Set(p, v))
}

/// Runs `seconds` of holding; returns the tip's vibration (its deflection's standard
/// deviation) [m] and the largest `|V_a|` [V] over the periods from `from` [s] on.
fn hold(rig: &mut Rig<PlantBoard>, seconds: f64, from: f64) -> (f64, f64) {
    let (mut sum, mut sum2, mut n, mut v_max) = (0.0, 0.0, 0usize, 0.0f64);
    for i in 0..(seconds * 1e3).round() as usize {
        rig.period();
        assert_eq!(rig.control.ctrl.fault(), None);
        if i as f64 * 1e-3 >= from {
            let tip = rig.board.plant().tip();
            sum += tip;
            sum2 += tip * tip;
            n += 1;
            v_max = v_max.max(rig.board.v_a().abs());
        }
    }
    let n = n.max(1) as f64;
    let mean = sum / n;
    ((sum2 / n - mean * mean).max(0.0).sqrt(), v_max)
}

/// Selects `law` on a board at bond factor `bond`, strikes the patch and returns how much of the
/// tip's vibration is left one second on (its vibration from 1.0 to 1.5 s after the strike over
/// that from 0 to 0.5 s: the decay, whatever the strike's amplitude under each law) and the
/// largest `|V_a|` [V] in the first half second.
fn run(law: PiezoLawKind, bond: f64) -> (f64, f64) {
    let mut r = rig(bond);
    assert_eq!(
        set(&mut r, Param::FilmStatic, static_gain(bond) as f32),
        Reply::Done
    );
    assert_eq!(
        set(&mut r, Param::PiezoLaw, f32::from(law.code())),
        Reply::Done
    );
    assert_eq!(r.control.ctrl.selected(), law);
    r.arm().unwrap();
    // Armed: neither the law nor what it is designed from changes.
    let other = if law == PiezoLawKind::Ppf {
        PiezoLawKind::Irc
    } else {
        PiezoLawKind::Ppf
    };
    assert_eq!(
        set(&mut r, Param::PiezoLaw, f32::from(other.code())),
        Reply::Refused(Refusal::Armed)
    );
    if law.needs_identification() {
        assert_eq!(
            set(&mut r, Param::FilmStatic, 1e-3),
            Reply::Refused(Refusal::Armed)
        );
    }
    assert_eq!(r.control.ctrl.selected(), law);
    hold(&mut r, 0.5, 0.5);
    assert_eq!(set(&mut r, Param::VaBias, PULSE.0), Reply::Done);
    hold(&mut r, PULSE.1, 1.0);
    assert_eq!(set(&mut r, Param::VaBias, 0.0), Reply::Done);
    let (early, v_a) = hold(&mut r, 0.5, 0.0);
    hold(&mut r, 0.5, 1.0);
    let (late, _) = hold(&mut r, 0.5, 0.0);
    (late / early, v_a)
}

/// Every law runs on the truth plant with the feedthrough of no bond and of the perfect one,
/// and each leaves at most half the vibration the loop off leaves one second after a strike.
#[test]
fn each_law_runs_and_damps_on_the_truth_plant() {
    for bond in [0.0, 1.0] {
        let (off, v_off) = run(PiezoLawKind::Off, bond);
        assert_eq!(v_off, 0.0);
        for law in [PiezoLawKind::Rate, PiezoLawKind::Irc, PiezoLawKind::Ppf] {
            let (left, v_a) = run(law, bond);
            println!(
                "β = {bond}: {} leaves {left:.4} of the vibration a second on (off {off:.4}, ratio {:.2}), max |V_a| {v_a:.1} V",
                law.name(),
                left / off
            );
            assert!(left.is_finite() && v_a > 0.0, "{law:?} at β = {bond}");
            assert!(
                left < 0.5 * off,
                "{law:?} at β = {bond}: {left} against {off} off"
            );
        }
    }
}

/// The laws beside the rate law need the film's static gain measured: with 0 (not measured)
/// the board refuses them and keeps the law it runs.
#[test]
fn identification_first() {
    let mut r = rig(0.5);
    assert_eq!(set(&mut r, Param::FilmStatic, 0.0), Reply::Done);
    for law in [PiezoLawKind::Irc, PiezoLawKind::Ppf] {
        assert_eq!(
            set(&mut r, Param::PiezoLaw, f32::from(law.code())),
            Reply::Refused(Refusal::Unidentified)
        );
        assert_eq!(r.control.ctrl.selected(), PiezoLawKind::Rate);
    }
    assert_eq!(set(&mut r, Param::PiezoLaw, 0.0), Reply::Done);
    assert_eq!(r.control.ctrl.selected(), PiezoLawKind::Off);
    // Not a law's code.
    for bad in [1.5, 4.0] {
        assert_ne!(set(&mut r, Param::PiezoLaw, bad), Reply::Done);
    }
    assert_eq!(
        r.answer(Command::Get(Param::PiezoLaw)),
        Reply::Value(f32::from(PiezoLawKind::Off.code()))
    );
}
