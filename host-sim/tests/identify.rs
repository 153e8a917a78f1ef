//! Identification (issue 17) on the truth plant, whose parameters are known: the friction
//! experiment and fit recover the drives' Coulomb and viscous friction; bad data is refused
//! with the reason.

use flexarm_core::Vector2;
use flexarm_sim::identify::{Cruise, IdentifyError, fit, friction_experiment, moves};
use flexarm_sim::sim::{Sensors, SimConfig, StateSource};
use flexarm_sim::truth_plant::TruthSpec;

/// The truth plant of the study (six modes, geared drives with friction, real amplifiers), the
/// observer-based controller on a realistic board, as `cargo sim identify friction` runs it.
fn truth() -> (SimConfig, TruthSpec) {
    let spec = TruthSpec::default();
    let cfg = SimConfig {
        state: StateSource::Observer,
        sensors: Sensors::realistic(),
        piezo: None,
        ..SimConfig::default()
    }
    .with_truth(spec)
    .unwrap();
    (cfg, spec)
}

/// Within 10 % of the truth plant's friction (the bound), both joints.
#[test]
fn friction_is_recovered_within_ten_percent() {
    let (cfg, spec) = truth();
    let cruises =
        friction_experiment(&cfg, Vector2::new(-1.2, -1.2), &[0.1, 0.2, 0.3, 0.5], 2.0).unwrap();
    assert_eq!(cruises.len(), 16);
    for joint in 0..2 {
        let mine: Vec<Cruise> = cruises
            .iter()
            .copied()
            .filter(|c| c.joint == joint)
            .collect();
        let f = fit(&mine).unwrap();
        let m = spec.motors[joint];
        let (ec, ev) = (f.coulomb / m.coulomb - 1.0, f.viscous / m.viscous - 1.0);
        println!(
            "joint {}: F_c {:.4} N·m (truth {}, {:+.1} %), F_v {:.4} N·m·s/rad (truth {}, {:+.1} %), residual {:.1e} N·m",
            joint + 1,
            f.coulomb,
            m.coulomb,
            ec * 100.0,
            f.viscous,
            m.viscous,
            ev * 100.0,
            f.residual
        );
        assert!(ec.abs() < 0.1 && ev.abs() < 0.1, "joint {}", joint + 1);
    }
}

#[test]
fn data_that_cannot_determine_the_friction_is_refused() {
    let c = |speed: f64, torque: f64| Cruise {
        joint: 0,
        speed,
        torque,
        samples: 100,
    };
    let one_way = fit(&[c(0.1, 0.05), c(0.4, 0.06)]).unwrap_err();
    assert!(
        matches!(&one_way, IdentifyError::Data(m) if m.contains("one direction")),
        "{one_way}"
    );
    let one_speed = fit(&[c(0.2, 0.05), c(-0.2, -0.05)]).unwrap_err();
    assert!(
        matches!(&one_speed, IdentifyError::Data(m) if m.contains("same speed")),
        "{one_speed}"
    );
    // Exact data: the fit is exact.
    let f = fit(&[c(0.1, 0.052), c(-0.1, -0.052), c(0.5, 0.06), c(-0.5, -0.06)]).unwrap();
    assert!(
        (f.coulomb - 0.05).abs() < 1e-12 && (f.viscous - 0.02).abs() < 1e-12,
        "{f:?}"
    );
    let short = moves(Vector2::zeros(), 0, 0.5, 0.3).unwrap_err();
    assert!(short.to_string().contains("give at least 0.5 s"), "{short}");
    let far = moves(Vector2::new(0.0, 1.5), 1, 0.5, 2.0).unwrap_err();
    assert!(far.to_string().contains("outside ±2.7 rad"), "{far}");
}

/// The fragment `identify friction` writes is a `[plant]` table the scenarios read: a scenario
/// with it runs a truth plant with the identified friction.
#[test]
fn the_identified_friction_is_a_plant_the_simulator_reads() {
    use flexarm_sim::identify::{Friction, plant_fragment};
    let f = |coulomb, viscous| Friction {
        coulomb,
        viscous,
        residual: 0.0,
    };
    let fragment = plant_fragment(&[f(0.0501, 0.0192), f(0.0503, 0.0195)]);
    let text = format!(
        "name = \"identified\"\n[trajectory]\nkind = \"trapezoid\"\n{}kind = \"truth\"\nmodes = 2\n",
        fragment
    );
    let s = flexarm_sim::scenario::parse(&text).unwrap();
    let truth = s.config.truth.expect("a truth plant");
    assert_eq!(
        [truth.motors[0].coulomb, truth.motors[1].coulomb],
        [0.0501, 0.0503]
    );
    assert_eq!(
        [truth.motors[0].viscous, truth.motors[1].viscous],
        [0.0192, 0.0195]
    );
}

/// On the controller's own model, which has no friction, the method finds almost none: its own
/// bias, within a tenth of the truth plant's friction (the validation's bound).
#[test]
fn no_friction_is_found_where_there_is_none() {
    let cfg = SimConfig {
        state: StateSource::Observer,
        sensors: Sensors::realistic(),
        ..SimConfig::default()
    };
    let cruises =
        friction_experiment(&cfg, Vector2::new(-1.2, -1.2), &[0.1, 0.2, 0.3, 0.5], 2.0).unwrap();
    let fits = flexarm_sim::identify::fit_joints(&cruises).unwrap();
    let drive = TruthSpec::default().motors[0];
    for (j, f) in fits.iter().enumerate() {
        println!(
            "joint {}: F_c {:+.1e} N·m, F_v {:+.1e} N·m·s/rad",
            j + 1,
            f.coulomb,
            f.viscous
        );
        assert!(
            f.coulomb.abs() < 0.1 * drive.coulomb && f.viscous.abs() < 0.1 * drive.viscous,
            "joint {}",
            j + 1
        );
    }
}
