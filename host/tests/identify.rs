//! Identification (issue 17) on the truth plant, whose parameters are known: the friction
//! experiment and fit recover the drives' Coulomb and viscous friction; bad data is refused
//! with the reason.

use flexarm_core::Vector2;
use flexarm_host::identify::{Cruise, IdentifyError, fit, friction_experiment, moves};
use flexarm_host::sim::{Sensors, SimConfig, StateSource};
use flexarm_host::truth_plant::TruthSpec;

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

/// Within 10 % of the truth plant's friction (the bound), both joints; the same from
/// the experiment's record alone (`identify friction --record`: the cruises found in it),
/// which must find the experiment's 16 cruises, in its order,, each within 2 % of its speed and 5 mN·m of its torque (the windows
/// differ by up to the speed estimate's half-width, 0.25 s, of a 2 s cruise).
#[test]
fn friction_is_recovered_within_ten_percent() {
    let (cfg, spec) = truth();
    let (cruises, record) =
        friction_experiment(&cfg, Vector2::new(-1.2, -1.2), &[0.1, 0.2, 0.3, 0.5], 2.0).unwrap();
    assert_eq!(cruises.len(), 16);
    let found = flexarm_host::identify::find_cruises(&record).unwrap();
    assert_eq!(found.len(), 16);
    for (c, f) in cruises.iter().zip(&found) {
        println!(
            "joint {}: {:+.4} rad/s {:+.5} N·m, found {:+.4} rad/s {:+.5} N·m",
            c.joint + 1,
            c.speed,
            c.torque,
            f.speed,
            f.torque
        );
        assert_eq!(c.joint, f.joint);
        assert!((f.speed / c.speed - 1.0).abs() < 0.02, "{c:?} {f:?}");
        assert!((f.torque - c.torque).abs() < 2e-3, "{c:?} {f:?}");
    }
    let refit = flexarm_host::identify::fit_joints(&found).unwrap();
    for (joint, f) in refit.iter().enumerate() {
        let m = spec.motors[joint];
        let (ec, ev) = (f.coulomb / m.coulomb - 1.0, f.viscous / m.viscous - 1.0);
        println!(
            "joint {} from the record: F_c {:+.1} %, F_v {:+.1} %",
            joint + 1,
            ec * 100.0,
            ev * 100.0
        );
        assert!(ec.abs() < 0.1 && ev.abs() < 0.1, "joint {}", joint + 1);
    }
    // A record without cruises (the joints held) is refused with the gate.
    let held: Vec<_> = record[..3000]
        .iter()
        .map(|s| flexarm_host::sim::Sample {
            x: flexarm_host::plant::State {
                q: nalgebra::Vector4::new(-1.2, -1.2, 0.0, 0.0),
                ..s.x
            },
            ..*s
        })
        .collect();
    let e = flexarm_host::identify::find_cruises(&held).unwrap_err();
    assert!(
        e.to_string()
            .contains("gate `excitation`: joint 1 has no cruise"),
        "{e}"
    );
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
    use flexarm_host::identify::{Friction, plant_fragment};
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
    let s = flexarm_host::scenario::parse(&text).unwrap();
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
    let (cruises, _) =
        friction_experiment(&cfg, Vector2::new(-1.2, -1.2), &[0.1, 0.2, 0.3, 0.5], 2.0).unwrap();
    let fits = flexarm_host::identify::fit_joints(&cruises).unwrap();
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

mod modes_and_model {
    use flexarm_core::params::ArmParams;
    use flexarm_host::identify::IdentifyError;
    use flexarm_host::identify::inertia::{InertiaPlan, Rigid, fit_inertia, inertia_experiment};
    use flexarm_host::identify::modal::{FitSettings, fit_modes};
    use flexarm_host::identify::model::{closed_loop, identified_model, model_fragment};
    use flexarm_host::identify::modes::{ModesPlan, modes_experiment};
    use flexarm_host::identify::record::ModesRecord;
    use flexarm_host::identify::workflow::CHECK_PIEZO;
    use flexarm_host::sim::SimConfig;

    fn record(cfg: &SimConfig, plan: &ModesPlan) -> ModesRecord {
        let trace = modes_experiment(cfg, plan).unwrap();
        ModesRecord::from_trace(&trace, 10.0, (-200.0, 200.0)).unwrap()
    }

    /// A user's record ends wherever the user stopped it: the 30 s experiment's record cut 3,
    /// 11, 20, 29, 40 and 50 ms after each of the last six bias steps of its last patch block
    /// (36 cuts) keeps the base as an input and fits both modes within 0.5 % at every cut, and
    /// no other resonance below mode 2. Without the check against the record's shorter
    /// copies, the cut 40 ms after the step at 24.525 s listed a resonance at 5.79 Hz that the
    /// arm does not have and kept it as mode 2. (Before the Welch probe's segment count was
    /// exact, cuts where the probe fell one segment short of its 20 averages were refused,
    /// "mode 1 not seen": the base's motion counted as all the patch's, the held arm fitted
    /// without it; the cause of the QEMU link session's failures in 2 of 16 runs.)
    #[test]
    fn a_record_cut_anywhere_fits_the_same_modes() {
        use flexarm_host::identify::modes::excitation;
        let (cfg, _) = super::truth();
        let plan = ModesPlan {
            seconds: 30.0,
            ..ModesPlan::default()
        };
        let rec = record(&cfg, &plan);
        let steps: Vec<f64> = excitation(&plan)
            .unwrap()
            .bias
            .iter()
            .map(|b| b.0)
            .filter(|t| *t < 25.0)
            .collect();
        let truth = [0, 1].map(|j| cfg.arm.modes.omega[j]);
        for s in &steps[steps.len() - 6..] {
            for d in [0.003, 0.011, 0.02, 0.029, 0.04, 0.05] {
                let t = s + d;
                let cut = rec.head((t / rec.dt) as usize);
                let fit = fit_modes(&cut, &FitSettings::default())
                    .unwrap_or_else(|e| panic!("cut at {t:.3} s: {e}"));
                assert!(fit.held.is_none(), "cut at {t:.3} s: {:?}", fit.held);
                for (j, m) in fit.modes.iter().enumerate() {
                    assert!(
                        (m.omega / truth[j] - 1.0).abs() < 0.005,
                        "cut at {t:.3} s: mode {} at {:.3} Hz",
                        j + 1,
                        m.hz()
                    );
                }
                assert_eq!(fit.kept, vec![1, 2], "cut at {t:.3} s");
            }
        }
    }

    /// The bounds on the truth plant: frequencies within 0.5 %, damping within 15 %
    /// (the figures in docs/identification.md: −0.03 % and +0.09 %, +5.7 % and +1.1 %), the
    /// piezo→film products within 10 % (+6.2 %, −0.14 %); the inertia combinations within 5 %
    /// (+0.21 %, +0.48 %, +2.7 %); the identified model's closed loop within 10 % of the true
    /// parameters' on Eq. 37 (−1.3 % and −0.48 %), and its prediction of the held arm's free
    /// decay close to the decay measured. The model file reads back as the model.
    #[test]
    fn the_whole_loop_recovers_the_truth() {
        let (cfg, _) = super::truth();
        let fit = fit_modes(
            &record(&cfg, &ModesPlan::default()),
            &FitSettings::default(),
        )
        .unwrap();
        let p = cfg.patch;
        for (j, m) in fit.modes.iter().enumerate() {
            let g = p.k_a * p.k_s * p.slope_diff[j].powi(2);
            let e = [
                m.omega / cfg.arm.modes.omega[j] - 1.0,
                m.zeta / cfg.arm.modes.zeta[j] - 1.0,
                m.piezo_film / g - 1.0,
            ];
            println!(
                "mode {}: errors f {:+.3e}, ζ {:+.3e}, g {:+.3e}",
                j + 1,
                e[0],
                e[1],
                e[2]
            );
            assert!(
                e[0].abs() < 0.005 && e[1].abs() < 0.15 && e[2].abs() < 0.1,
                "mode {}",
                j + 1
            );
        }
        let inertia =
            fit_inertia(&inertia_experiment(&cfg, &InertiaPlan::default()).unwrap()).unwrap();
        let t = Rigid::of(&cfg.arm);
        for (name, x, t) in [
            ("A", inertia.rigid.a, t.a),
            ("J", inertia.rigid.j, t.j),
            ("S", inertia.rigid.s, t.s),
        ] {
            println!("{name}: {:+.3e}", x / t - 1.0);
            assert!((x / t - 1.0).abs() < 0.05, "{name}");
        }
        let (arm, patch, _) = identified_model(
            &flexarm_host::identify::geometry::Geometry::default(),
            &ArmParams::default(),
            &inertia.rigid,
            &fit,
        )
        .unwrap();
        let check = SimConfig {
            piezo: Some(CHECK_PIEZO),
            ..cfg
        };
        let runs = closed_loop(&check, &[("identified", arm, patch)]).unwrap();
        let (truth, id) = (runs[0].summary, runs[1].summary);
        let e = [
            id.l2_error / truth.l2_error - 1.0,
            id.l2_tip / truth.l2_tip - 1.0,
        ];
        println!("closed loop: Eq. 37 error {:+.3e}, tip {:+.3e}", e[0], e[1]);
        assert!(e[0].abs() < 0.1 && e[1].abs() < 0.1);
        // The held arm's free decay, as the identified model predicts it (the record's patch
        // command replayed): the second mode within 1 % in frequency and 15 % in damping, the
        // first within 5 % and 50 % (`FIRST_HELD_MODE`).
        {
            use flexarm_host::identify::decay::{
                DecayPlan, DecaySettings, decay_experiment, fit_decay, predict, replay,
            };
            let (plan, set) = (DecayPlan::default(), DecaySettings::default());
            let trace = decay_experiment(&cfg, &plan).unwrap();
            let rec = ModesRecord::from_trace(&trace, 10.0, (-200.0, 200.0)).unwrap();
            let measured = fit_decay(&rec, &set).unwrap();
            let (ex, seconds) = replay(&trace).unwrap();
            let predicted = predict(&cfg, &arm, &patch, (&ex, seconds), &set).unwrap();
            for (j, m) in measured.strongest(2).iter().enumerate() {
                let q = predicted.nearest(m.omega).unwrap();
                let (ef, ez) = (q.omega / m.omega - 1.0, q.zeta / m.zeta - 1.0);
                println!("decay: identified model {ef:+.3e} in f, {ez:+.3e} in ζ");
                let (bf, bz) = super::decay::bounds(j);
                assert!(ef.abs() < bf && ez.abs() < bz, "mode {}", j + 1);
            }
        }
        // The file the simulator reads gives the same controller model.
        let text = format!(
            "name = \"x\"\n[trajectory]\nkind = \"trapezoid\"\n{}",
            model_fragment(&arm, &patch, 3.162)
        );
        let sc = flexarm_host::scenario::parse(&text).unwrap();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(1.0);
        let (a2, p2) = (sc.config.arm, sc.config.patch);
        for (x, y) in [
            (a2.m2, arm.m2),
            (a2.i_h1, arm.i_h1),
            (a2.i_h2, arm.i_h2),
            (a2.i_2_extra, arm.i_2_extra),
            (a2.modes.omega[1], arm.modes.omega[1]),
            (a2.modes.zeta[0], arm.modes.zeta[0]),
            (a2.modes.moment_integral[0], arm.modes.moment_integral[0]),
            (p2.slope_diff[1], patch.slope_diff[1]),
        ] {
            assert!(close(x, y), "{x} read back as {y}");
        }
    }

    fn data_error(r: Result<impl std::fmt::Debug, IdentifyError>) -> String {
        match r {
            Err(IdentifyError::Data(m)) => m,
            other => panic!("expected a data error, got {other:?}"),
        }
    }

    /// Bad records are refused with what is wrong: clipped, a channel missing, uneven
    /// sampling, a mode the band did not reach, no excitation at all (the family's tests,
    /// `identify_family.rs`, refuse the rest).
    #[test]
    fn bad_records_are_refused_with_the_reason() {
        let (cfg, _) = super::truth();
        let good = record(
            &cfg,
            &ModesPlan {
                seconds: 20.0,
                ..ModesPlan::default()
            },
        );
        let mut clipped = good.clone();
        clipped.v_f_range = 0.05;
        let m = data_error(fit_modes(&clipped, &FitSettings::default()));
        assert!(m.contains("gate `clipping`: `v_f` is clipped"), "{m}");
        let mut saturated = good.clone();
        saturated.v_a_window = (-100.0, 100.0);
        let m = data_error(fit_modes(&saturated, &FitSettings::default()));
        assert!(m.contains("gate `clipping`: `v_a` is clipped"), "{m}");

        let mut reversed = good.clone();
        reversed.v_f.iter_mut().for_each(|v| *v = -*v);
        let m = data_error(fit_modes(&reversed, &FitSettings::default()));
        assert!(m.contains("film's sign is reversed"), "{m}");

        let mut missing = good.clone();
        missing.theta[1].clear();
        let m = data_error(fit_modes(&missing, &FitSettings::default()));
        assert!(m.contains("`theta2` is missing"), "{m}");

        let narrow = FitSettings {
            band: Some((1.5, 15.0)),
            ..FitSettings::default()
        };
        let m = data_error(fit_modes(&good, &narrow));
        assert!(m.contains("mode 2 not seen") && m.contains("4.5"), "{m}");

        let still = record(
            &cfg,
            &ModesPlan {
                seconds: 20.0,
                piezo_volts: 0.0,
                tap: 0.0,
                ..ModesPlan::default()
            },
        );
        let m = data_error(fit_modes(&still, &FitSettings::default()));
        assert!(m.contains("gate `excitation`: no input"), "{m}");

        let mut trace = modes_experiment(
            &cfg,
            &ModesPlan {
                seconds: 20.0,
                ..ModesPlan::default()
            },
        )
        .unwrap();
        trace.drain(5000..5010);
        let m = data_error(ModesRecord::from_trace(&trace, 10.0, (-200.0, 200.0)));
        assert!(
            m.contains("not sampled evenly") && m.contains("4.99"),
            "{m}"
        );
    }
}

mod decay {
    use flexarm_core::control::piezo::PiezoPatch;
    use flexarm_core::params::ArmParams;
    use flexarm_host::identify::IdentifyError;
    use flexarm_host::identify::decay::{
        DecayFit, DecayPlan, DecaySettings, decay_experiment, fit_decay, predict, replay,
    };
    use flexarm_host::identify::modes::{ModesPlan, modes_experiment};
    use flexarm_host::identify::record::ModesRecord;

    fn record(cfg: &flexarm_host::sim::SimConfig, plan: &DecayPlan) -> ModesRecord {
        let trace = decay_experiment(cfg, plan).unwrap();
        ModesRecord::from_trace(&trace, 10.0, (-200.0, 200.0)).unwrap()
    }

    /// The held arm's first mode lies near a mode of the servo holding the joints, whose
    /// quantized, noisy loop rings in it: its prediction moves with the noise's realization
    /// (the sensors' seed). Over seeds 1 to 8 on the truth plant the true parameters' prediction
    /// of it ranged over −0.7 to +3.9 % in frequency and −11 to +26 % in damping (the loop
    /// before the drive ran in it: −2.6 to +1.3 % and −5 to +41 %), the second mode's over
    /// −0.04 to +0.05 % and +1.0 to +2.3 %.
    pub const FIRST_HELD_MODE: (f64, f64) = (0.05, 0.5);

    /// The bounds on mode `j`'s (from 0) predicted frequency and damping, relative: the first
    /// held mode's [`FIRST_HELD_MODE`], the second's 1 % and 15 %.
    pub fn bounds(j: usize) -> (f64, f64) {
        if j == 0 {
            FIRST_HELD_MODE
        } else {
            (0.01, 0.15)
        }
    }

    /// Relative errors of a prediction's frequencies and damping ratios at the measured modes.
    fn errors(measured: &DecayFit, predicted: &DecayFit) -> Vec<(f64, f64)> {
        measured
            .strongest(2)
            .iter()
            .map(|m| {
                let q = predicted.nearest(m.omega).unwrap();
                (q.omega / m.omega - 1.0, q.zeta / m.zeta - 1.0)
            })
            .collect()
    }

    /// A synthetic record of taps of the patch, each followed by the film's decay of two modes
    /// (`(f [Hz], ζ)`), `spacing` [s] apart, sampled at 1 kHz.
    fn tapped(modes: &[(f64, f64)], taps: usize, spacing: f64) -> ModesRecord {
        let dt = 1e-3;
        let (per, width) = ((spacing / dt) as usize, 20);
        let n = taps * per + per / 2;
        let (mut v_a, mut v_f) = (vec![0.0; n], vec![0.0; n]);
        for i in 0..taps {
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            let start = per / 2 + i * per;
            v_a[start..start + width].fill(100.0 * sign);
            for (k, v) in v_f.iter_mut().enumerate().skip(start + width) {
                let t = (k - start - width) as f64 * dt;
                *v += sign
                    * modes
                        .iter()
                        .map(|&(f, z)| {
                            let w = std::f64::consts::TAU * f;
                            0.5 * (-z * w * t).exp() * (w * (1.0 - z * z).sqrt() * t).sin()
                        })
                        .sum::<f64>();
            }
        }
        ModesRecord {
            dt,
            v_a,
            v_f,
            theta: [vec![0.0; n], vec![1.5; n]],
            tau: [vec![0.0; n], vec![0.0; n]],
            v_f_range: 10.0,
            v_a_window: (-200.0, 200.0),
        }
    }

    /// A first mode below the default band's 1.5 Hz (the family's slow arm: 0.5 Hz) is out of
    /// the default fit's reach and found with a band that reaches it (`--band 0.3,40`), the
    /// decays then as long as three of its periods; a band above 0.4 of the record's rate is
    /// refused with `--band` named.
    #[test]
    fn a_band_set_by_the_user_reaches_a_slow_first_mode() {
        let truth = [(0.6, 0.02), (5.0, 0.02)];
        let rec = tapped(&truth, 4, 12.0);
        let default = DecaySettings::for_band(None, rec.dt).unwrap();
        assert_eq!(default, DecaySettings::default());
        let m = data_error(fit_decay(&rec, &default));
        assert!(m.contains("mode 2 not seen in the decay"), "{m}");

        let low = DecaySettings::for_band(Some((0.3, 40.0)), rec.dt).unwrap();
        assert!(low.window >= 10.0, "{low:?}");
        let fit = fit_decay(&rec, &low).unwrap();
        let found = fit.strongest(2);
        assert_eq!(found.len(), 2, "{fit:?}");
        for (m, (f, z)) in found.iter().zip(truth) {
            let ef = m.omega / (std::f64::consts::TAU * f) - 1.0;
            assert!(ef.abs() < 5e-3, "{f} Hz: found {ef:+.2e}");
            assert!((m.zeta / z - 1.0).abs() < 0.15, "{f} Hz: ζ {}", m.zeta);
        }

        let e = DecaySettings::for_band(Some((1.0, 450.0)), rec.dt).unwrap_err();
        assert!(
            e.contains("--band 1,450") && e.contains("400.0 Hz at most"),
            "{e}"
        );
        let e = DecaySettings::for_band(Some((5.0, 2.0)), rec.dt).unwrap_err();
        assert!(e.contains("0 < LOW < HIGH"), "{e}");
    }

    /// The held arm's decay on the truth plant is what the controller built from the true
    /// parameters predicts, its patch command replayed (docs/identification.md), the second
    /// mode within 1 % in frequency and 15 % in damping, the first within 5 % and 50 %
    /// ([`FIRST_HELD_MODE`]); the paper's
    /// nominal model misses the second mode by more than 30 % (−44 %): the check tells the
    /// models apart. (The identified model's prediction is checked in
    /// `the_whole_loop_recovers_the_truth`.)
    #[test]
    fn the_decay_is_what_the_true_model_predicts_and_not_the_nominal() {
        let (cfg, _) = super::truth();
        let plan = DecayPlan::default();
        let set = DecaySettings::default();
        let trace = decay_experiment(&cfg, &plan).unwrap();
        let rec = ModesRecord::from_trace(&trace, 10.0, (-200.0, 200.0)).unwrap();
        let measured = fit_decay(&rec, &set).unwrap();
        assert_eq!(measured.taps, plan.taps);
        let (ex, seconds) = replay(&trace).unwrap();
        let truth = predict(&cfg, &cfg.arm, &cfg.patch, (&ex, seconds), &set).unwrap();
        for (j, (ef, ez)) in errors(&measured, &truth).into_iter().enumerate() {
            println!(
                "mode {}: true parameters {ef:+.3e} in f, {ez:+.3e} in ζ",
                j + 1
            );
            let (bf, bz) = bounds(j);
            assert!(ef.abs() < bf && ez.abs() < bz, "mode {}", j + 1);
        }
        let paper = (ArmParams::default(), PiezoPatch::paper());
        let nominal = predict(&cfg, &paper.0, &paper.1, (&ex, seconds), &set).unwrap();
        let e = errors(&measured, &nominal);
        println!("nominal: {e:?}");
        assert!(e[1].0.abs() > 0.3, "{e:?}");
        // The pencil reproduces the averaged decay it was given.
        let rms = |x: &mut dyn Iterator<Item = f64>| {
            let v: Vec<f64> = x.collect();
            (v.iter().map(|a| a * a).sum::<f64>() / v.len() as f64).sqrt()
        };
        let residual = rms(&mut measured
            .decay
            .iter()
            .zip(&measured.fitted)
            .map(|(a, b)| a - b));
        let size = rms(&mut measured.decay.iter().copied());
        println!("pencil residual {residual:.2e} V of {size:.2e} V");
        assert!(residual < 0.2 * size);
    }

    fn data_error(r: Result<DecayFit, IdentifyError>) -> String {
        match r {
            Err(IdentifyError::Data(m)) => m,
            other => panic!("expected a data error, got {other:?}"),
        }
    }

    /// A record without taps, taps too close for the lowest mode, a band that leaves out the
    /// second mode, a missing channel: each refused with the reason.
    #[test]
    fn bad_decay_records_are_refused_with_the_reason() {
        let (cfg, _) = super::truth();
        let set = DecaySettings::default();
        let steps = modes_experiment(
            &cfg,
            &ModesPlan {
                seconds: 10.0,
                ..ModesPlan::default()
            },
        )
        .unwrap();
        let steps = ModesRecord::from_trace(&steps, 10.0, (-200.0, 200.0)).unwrap();
        let m = data_error(fit_decay(&steps, &set));
        assert!(m.contains("no tap in `v_a`"), "{m}");

        let close = record(
            &cfg,
            &DecayPlan {
                taps: 3,
                spacing: 1.0,
                ..DecayPlan::default()
            },
        );
        let m = data_error(fit_decay(&close, &set));
        assert!(m.contains("too short for modes down to 1.5 Hz"), "{m}");

        let good = record(
            &cfg,
            &DecayPlan {
                taps: 3,
                ..DecayPlan::default()
            },
        );
        let narrow = DecaySettings {
            band: (1.5, 15.0),
            ..set
        };
        let m = data_error(fit_decay(&good, &narrow));
        assert!(m.contains("mode 2 not seen in the decay"), "{m}");

        let mut missing = good.clone();
        missing.v_f.clear();
        let m = data_error(fit_decay(&missing, &set));
        assert!(m.contains("`v_f` is missing"), "{m}");

        let bad_plan = DecayPlan {
            spacing: 0.2,
            ..DecayPlan::default()
        };
        let m = match decay_experiment(&cfg, &bad_plan) {
            Err(IdentifyError::Data(m)) => m,
            other => panic!("{other:?}"),
        };
        assert!(m.contains("taps 0.2 s apart"), "{m}");
    }
}

/// The modes experiment ends at rest (issue 32: a bias step in the record's last samples left
/// the QEMU arm's fit without a mode, about one run in eight): after its last step the patch is
/// at 0 V for `REST` (a tenth of a short record), and no move runs then.
#[test]
fn the_modes_experiment_ends_at_rest() {
    use flexarm_host::identify::modes::{ModesPlan, REST, excitation};
    for seconds in [10.0, 30.0, 60.0] {
        let plan = ModesPlan {
            seconds,
            ..ModesPlan::default()
        };
        let ex = excitation(&plan).unwrap();
        let rest = REST.min(0.1 * seconds);
        let &(last, v) = ex.bias.last().unwrap();
        assert_eq!(v, 0.0, "{seconds} s");
        assert!(
            last <= seconds - rest + 0.5,
            "{seconds} s: the rest from {last} s"
        );
        let (start, _) = ex.moves.last().unwrap();
        assert!(*start < last, "{seconds} s: a move starts in the rest");
        // Steps there were, at the plan's amplitude.
        assert!(ex.bias.iter().any(|(_, v)| v.abs() == plan.piezo_volts));
    }
}

/// The geometry's patched stretch (`patch.mass_ratio`, `patch.stiffness_ratio`) gives the
/// shapes of the truth plant's link, whose ceramic and film are layers of its beam: on the
/// paper's patch at 1 mm and 2.5 mm, each mode's `v = ∫ρφ`, `w = ∫ρxφ` and slope difference
/// over the patch equal to the truth's to round-off (the same first moment about joint 2;
/// 4e-15 and 5e-15), where the uniform link's default is off by 215 % and 53 % (the slope
/// difference). The file's keys read, and a ratio out of range is refused by its key.
#[test]
fn the_geometrys_patched_stretch_gives_the_truth_links_shapes() {
    use flexarm_beam::section::Layers;
    use flexarm_core::control::piezo::PiezoPatch;
    use flexarm_core::params::ArmParams;
    use flexarm_host::identify::geometry::Geometry;
    let (arm, patch) = (ArmParams::<f64>::default(), PiezoPatch::<f64>::paper());
    for thickness in [1.0e-3, 2.5e-3] {
        let spec = TruthSpec {
            thickness,
            ..TruthSpec::default()
        };
        let (body, c) = spec.link(&arm, &patch).unwrap();
        let mut layers = Layers::default();
        layers.material.t_b = thickness;
        let (bare, patched) = (layers.bare(), layers.patched());
        let layered = Geometry {
            mass_ratio: patched.rho_a / bare.rho_a,
            stiffness_ratio: patched.ei / bare.ei,
            ..Geometry::default()
        };
        // The uniform link of the same first moment.
        let m_link = 2.0 * body.first_moment / arm.a2;
        let worst = |g: &Geometry| {
            let shapes = g.shapes(m_link, body.omega[0], 2).unwrap();
            let mut worst: f64 = 0.0;
            for (j, s) in shapes.iter().enumerate() {
                let dphi = s.slope(g.x_a + g.l_a) - s.slope(g.x_a);
                for (ours, truth) in [
                    (s.integrate(|_, p| p), body.v[j]),
                    (s.integrate(|x, p| x * p), body.w[j]),
                    (dphi, c.slope_diff[j]),
                ] {
                    worst = worst.max((ours.abs() / truth.abs() - 1.0).abs());
                }
            }
            worst
        };
        let (w_layered, w_uniform) = (worst(&layered), worst(&Geometry::default()));
        println!(
            "{thickness} m: worst error {:.2e} with the layers, {:.2e} uniform",
            w_layered, w_uniform
        );
        assert!(w_layered < 1e-9, "{thickness}: {w_layered}");
        assert!(w_uniform > 0.5, "{thickness}: {w_uniform}");
    }
    let g = Geometry::parse("[patch]\nmass_ratio = 3.3\nstiffness_ratio = 5.8\n").unwrap();
    assert_eq!((g.mass_ratio, g.stiffness_ratio), (3.3, 5.8));
    for bad in ["mass_ratio = 0.0", "stiffness_ratio = nan"] {
        let e = Geometry::parse(&format!("[patch]\n{bad}\n")).unwrap_err();
        let key = bad.split(' ').next().unwrap();
        assert!(e.contains(&format!("`patch.{key}`")), "{bad}: {e}");
    }
}

/// A 7.1 s modes record of the QEMU arm over the link (modes 4.716 and 14.395 Hz; `flexarm
/// --qemu --arm identify modes OUT --seconds 5`, its columns cut to the fit's). Its whole
/// record's fit finds mode 1 at 5.02 ± 0.03 Hz, 6 % off, and passes every other gate; its
/// first three quarters are refused, and so is it (`host/src/identify/modal.rs`, "Three
/// quarters").
#[test]
fn a_modes_record_too_short_for_its_fit_is_refused() {
    use flexarm_host::identify::modal::{FitSettings, PART, fit_modes};
    use flexarm_host::identify::record::ModesRecord;
    let text = include_str!("data/qemu_modes_7s.csv");
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let column = |i: usize| rows.iter().map(|r| r[i]).collect::<Vec<f64>>();
    let rec = ModesRecord {
        dt: rows[1][0] - rows[0][0],
        v_a: column(5),
        v_f: column(6),
        theta: [column(1), column(2)],
        tau: [column(3), column(4)],
        v_f_range: 10.0,
        v_a_window: (-200.0, 200.0),
    };
    let seconds = rows.len() as f64 * rec.dt;
    assert!((seconds - 7.08).abs() < 0.01, "{seconds}");
    let e = fit_modes(&rec, &FitSettings::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("gate `record length`: its first 75 % (5.3 s) are refused"),
        "{e}"
    );
    // The shortest record the message asks for: four thirds of this one, rounded up.
    let asked = (seconds / PART).ceil();
    assert!(e.ends_with(&format!("record at least {asked:.0} s")), "{e}");
}
