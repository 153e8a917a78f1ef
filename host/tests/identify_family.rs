//! Identification on the family (issue 32, `flexarm_host::identify::family`): five truth-plant
//! arms unlike the paper's, each recorded the way a lab records (`flexarm_host::lab`, written
//! by the simulator's trace writer and read back), fitted by the same code as `cargo sim
//! identify`. The bounds are the and docs/identification.md's: on the records that
//! excite the base on its own (a chirp with noise on joint 2's torque, noise on both), the
//! controller's two modes within 0.5 % in frequency, 15 % in damping and 10 % in the
//! piezo→film product; the inertias within 5 % where the link's first mode lies above the
//! inertia fit's band (the fit assumes a rigid link: docs); the controller built from the
//! identified model within 10 % of the true parameters' on Eq. 37 on every arm. A chirp on the
//! patch alone gives the held arm's modes, which the fit says and the model step refuses.

use flexarm_host::identify::family::{ArmResult, Kind, family, identify_arm, nearest};

fn run(name: &str, kinds: &[Kind]) -> ArmResult {
    let arm = family().into_iter().find(|a| a.name == name).unwrap();
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    identify_arm(&arm, kinds, dir, false).unwrap()
}

/// The model-grade kinds, on every arm.
const KINDS: [Kind; 2] = [Kind::ChirpNoise, Kind::Random];

/// The inertias' bound: the 5 %.
const INERTIA_BOUND: f64 = 0.05;

fn check(r: &ArmResult) {
    let name = r.arm.name;
    for (kind, fit) in &r.modes {
        let fit = fit
            .as_ref()
            .unwrap_or_else(|e| panic!("{name} {}: {e}", kind.name()));
        match kind {
            Kind::ChirpLog => {
                // The patch alone: the held arm's modes, said so.
                assert!(
                    fit.held.is_some(),
                    "{name}: a chirp alone took the base as an input"
                );
                let e = flexarm_host::identify::model::identified_model(
                    &r.arm.geometry().unwrap(),
                    &r.arm.bench().unwrap().arm,
                    &r.inertia.1,
                    fit,
                )
                .unwrap_err();
                assert!(
                    e.to_string().contains("gate `clamped modes`"),
                    "{name}: {e}"
                );
            }
            _ => {
                assert!(fit.held.is_none(), "{name} {}: {:?}", kind.name(), fit.held);
                for (j, m) in fit.modes.iter().enumerate() {
                    let t = r.truth[j];
                    let e = [
                        m.hz() / t.hz - 1.0,
                        m.zeta / t.zeta - 1.0,
                        m.piezo_film / t.gain - 1.0,
                    ];
                    println!(
                        "{name} {}: mode {}: f {:+.3} %, ζ {:+.1} %, g {:+.1} %",
                        kind.name(),
                        j + 1,
                        e[0] * 100.0,
                        e[1] * 100.0,
                        e[2] * 100.0
                    );
                    assert!(
                        e[0].abs() < 0.005 && e[1].abs() < 0.15 && e[2].abs() < 0.1,
                        "{name} {}: mode {}: {e:?}",
                        kind.name(),
                        j + 1
                    );
                }
                // Every resonance listed is one of the arm's.
                for m in &fit.all {
                    let (_, t) = nearest(&r.truth, m.hz()).unwrap();
                    assert!((m.hz() / t.hz - 1.0).abs() < 0.01, "{name}: {} Hz", m.hz());
                }
            }
        }
    }
    let (fit, t) = &r.inertia;
    let f = fit.as_ref().unwrap_or_else(|e| panic!("{name}: {e}"));
    for (x, y, n) in [
        (f.rigid.a, t.a, "A"),
        (f.rigid.j, t.j, "J"),
        (f.rigid.s, t.s, "S"),
    ] {
        println!("{name}: {n} {:+.2} %", (x / y - 1.0) * 100.0);
        assert!((x / y - 1.0).abs() < INERTIA_BOUND, "{name}: {n}");
    }
    let (_, runs) = r.check.as_ref().unwrap_or_else(|e| panic!("{name}: {e}"));
    let (t, m) = (runs[0].summary, runs[1].summary);
    let e = [m.l2_error / t.l2_error - 1.0, m.l2_tip / t.l2_tip - 1.0];
    println!(
        "{name}: closed loop Eq. 37 {:+.2} %, tip {:+.2} %",
        e[0] * 100.0,
        e[1] * 100.0
    );
    assert!(e[0].abs() < 0.1 && e[1].abs() < 0.1, "{name}: {e:?}");
}

#[test]
fn slow_arm() {
    check(&run("slow", &KINDS));
}

#[test]
fn payload_arm() {
    check(&run("payload", &KINDS));
}

#[test]
fn patch_elsewhere_arm() {
    check(&run("patch", &KINDS));
}

/// With a chirp on the patch alone besides: the held arm's modes, which the model step refuses.
#[test]
fn lightly_damped_arm() {
    check(&run("light", &[KINDS[0], KINDS[1], Kind::ChirpLog]));
}

#[test]
fn long_arm() {
    check(&run("long", &KINDS));
}

/// Bad records refused with the gate's name: too short for the lowest mode, no excitation
/// where a mode is, zero torque, constant angles, negated torques, a clipped film, a film that
/// never moves, a missing channel.
#[test]
fn bad_records_are_refused_with_the_gate() {
    use flexarm_host::identify::family::swing;
    use flexarm_host::identify::inertia::fit_inertia;
    use flexarm_host::identify::modal::{FitSettings, fit_modes};
    use flexarm_host::identify::record::ModesRecord;
    use flexarm_host::lab::{self, Actuator, Excite, Shape};
    let bench_of = |name: &str| {
        family()
            .into_iter()
            .find(|a| a.name == name)
            .unwrap()
            .bench()
            .unwrap()
    };
    let (bench, light) = (bench_of("slow"), bench_of("light"));
    let modes_error =
        |trace: &[flexarm_host::sim::Sample], range: f64| match ModesRecord::from_trace(
            trace,
            range,
            (-200.0, 200.0),
        )
        .and_then(|r| fit_modes(&r, &FitSettings::default()))
        {
            Ok(f) => panic!(
                "fitted: {:?}",
                f.all.iter().map(|m| m.hz()).collect::<Vec<_>>()
            ),
            Err(e) => e.to_string(),
        };
    let noise = |from: f64, seconds: f64, seed: u64| Shape::Random {
        from,
        to: 60.0,
        seconds,
        seed,
    };
    let record = |bench: &flexarm_host::sim::SimConfig, from: f64, seconds: f64| {
        let mut plan = Kind::Random.plan(bench);
        plan.excite = vec![
            Excite {
                actuator: Actuator::Patch,
                shape: noise(from, seconds, 3),
                amplitude: 60.0,
            },
            Excite {
                actuator: Actuator::Motor(1),
                shape: noise(from, seconds, 5),
                amplitude: 1.0,
            },
        ];
        lab::record(&plan).unwrap()
    };
    // Five seconds resolve modes down to 2 Hz only: too short for the light arm's 4.5 Hz
    // first mode (found there it could not be vouched for as the first; missed, the second is
    // missing too).
    let m = modes_error(&record(&light, 0.1, 4.0), 10.0);
    assert!(
        m.contains("gate `record length`")
            || (m.contains("gate `modes`") && m.contains("resolves modes from 2.00 Hz up")),
        "{m}"
    );
    // The patch excited at 1 V instead of 100 (the base's torque noise as usual): on the
    // payload arm its products come out 1.7 times the truth's, known to 18 % (modal.rs, "A
    // faint patch").
    let mut faint = Kind::Random.plan(&bench_of("payload"));
    faint.excite[0].amplitude = 1.0;
    let m = modes_error(&lab::record(&faint).unwrap(), 10.0);
    assert!(
        m.contains("gate `uncertainty`") && m.contains("piezo→film product"),
        "{m}"
    );
    // Excited from 5 Hz up: the slow arm's 0.5 Hz mode is not there to see.
    let high = record(&bench, 5.0, 40.0);
    let m = modes_error(&high, 10.0);
    assert!(m.contains("gate `excitation band`"), "{m}");
    // The film at the ADC's ends, or never moving.
    let m = modes_error(&high, 0.05);
    assert!(m.contains("gate `clipping`: `v_f` is clipped"), "{m}");
    let mut still = high.clone();
    still.iter_mut().for_each(|s| s.v_f = 0.0);
    let m = modes_error(&still, 10.0);
    assert!(
        m.contains("gate `channels`") && m.contains("never changes"),
        "{m}"
    );
    // The inertia record: zero torque, constant angles, negated torques.
    let swing = lab::record(&swing(&bench, 0.5)).unwrap();
    let inertia_error = |t: &[flexarm_host::sim::Sample]| fit_inertia(t).unwrap_err().to_string();
    let mut zero = swing.clone();
    zero.iter_mut()
        .for_each(|s| s.tau = flexarm_core::Vector2::zeros());
    let m = inertia_error(&zero);
    assert!(
        m.contains("gate `excitation`") && m.contains("never changes"),
        "{m}"
    );
    let mut frozen = swing.clone();
    frozen.iter_mut().for_each(|s| {
        s.x.q.x = 0.0;
        s.x.q.y = 0.5;
    });
    let m = inertia_error(&frozen);
    assert!(
        m.contains("gate `excitation`") && m.contains("moved 0 encoder steps"),
        "{m}"
    );
    let mut negated = swing.clone();
    negated.iter_mut().for_each(|s| s.tau = -s.tau);
    let m = inertia_error(&negated);
    assert!(m.contains("gate `physical consistency`"), "{m}");
    // A trace without its film column is no trace.
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    let path = dir.join("missing_film.csv");
    let text = flexarm_host::output::trace_csv(&swing[..2000]);
    let cut: String = text
        .lines()
        .map(|l| l.rsplit_once(',').map_or(l, |(a, _)| a).to_string() + "\n")
        .collect();
    std::fs::write(&path, cut).unwrap();
    let m = flexarm_host::output::read_csv(&path).unwrap_err();
    assert!(m.contains(":1: not a flexarm trace"), "{m}");
    let mut rec = ModesRecord::from_trace(&high, 10.0, (-200.0, 200.0)).unwrap();
    rec.tau[1].clear();
    let m = fit_modes(&rec, &FitSettings::default())
        .unwrap_err()
        .to_string();
    assert!(
        m.contains("gate `channels`: the channel `tau2` is missing"),
        "{m}"
    );
}

/// The decay fit on the lab's tap records of every arm (`Kind::PatchTaps`, `TorqueTaps`,
/// `HammerTaps`: five taps 20 s apart, 20 ms wide but the hammer's): each record's taps found
/// as what made them, counted, spaced and sized as the record holds them. What rings is the
/// held arm (the link coupled with the lab's PD): its first mode shares itself with the
/// hold's (near 2 Hz) and is not the clamped link's, but the modes above it are the link's
/// (the hub's inertia clamps the link there): every mode found from three quarters of the
/// truth's second mode up is one of the truth's, within the 0.5 % in frequency
/// (0.40 % at most on this family).
/// A hammer's strikes reach every one of those modes inside the band and find their damping
/// within the 15 % (3.7 % at most). The modes fit of the same records refuses with a
/// gate or lists only the arm's modes (within 1 %; the held arm's first mode aside).
#[test]
fn decays_of_every_tap() {
    use flexarm_host::identify::decay::{DecaySettings, Tapper, fit_decay};
    use flexarm_host::identify::family::{HELD_BELOW, lab_record};
    use flexarm_host::identify::modal::{FitSettings, fit_modes};
    use flexarm_host::identify::record::ModesRecord;
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    let set = DecaySettings::default();
    for arm in family() {
        let bench = arm.bench().unwrap();
        let g = arm.geometry().unwrap();
        let truth = arm.modes().unwrap();
        for (kind, tapper) in [
            (Kind::PatchTaps, Tapper::Patch),
            (Kind::TorqueTaps, Tapper::Motor(1)),
            (Kind::HammerTaps, Tapper::Hammer),
        ] {
            let name = format!("{} {}", arm.name, kind.name());
            let trace =
                lab_record(dir, (arm.name, kind.name()), &kind.plan(&bench), false).unwrap();
            let rec = ModesRecord::from_trace(&trace, g.film_range, g.amplifier_window).unwrap();
            // The modes fit of a tap record refuses with a gate or lists the arm's modes only
            // (a held arm's first mode aside): never a resonance the arm does not have.
            match fit_modes(&rec, &FitSettings::default()) {
                Ok(m) => {
                    for x in &m.all {
                        let (_, t) = nearest(&truth, x.hz()).unwrap();
                        let first_held = m.held.is_some() && x.hz() < HELD_BELOW * truth[1].hz;
                        assert!(
                            first_held || (x.hz() / t.hz - 1.0).abs() < 0.01,
                            "{name}: modes fit: {} Hz",
                            x.hz()
                        );
                    }
                }
                Err(e) => assert!(e.to_string().contains("gate `"), "{name}: {e}"),
            }
            let f = match fit_decay(&rec, &set) {
                Ok(f) => f,
                // The patch elsewhere sees its second mode too weakly in a patch tap's decay.
                Err(e) if (arm.name, kind) == ("patch", Kind::PatchTaps) => {
                    println!("{name}: {e}");
                    assert!(e.to_string().contains("mode 2 not seen"), "{e}");
                    continue;
                }
                Err(e) => panic!("{name}: {e}"),
            };
            println!("{name}: {}", f.held);
            let h = f.held;
            assert_eq!(h.tapper, tapper, "{name}");
            assert_eq!((h.count, f.taps), (5, 5), "{name}");
            assert!((h.spacing - 20.0).abs() < 0.01, "{name}: {}", h.spacing);
            if tapper != Tapper::Hammer {
                assert!((h.width - 0.02).abs() < 0.0025, "{name}: {}", h.width);
            }
            let mut found = Vec::new();
            for m in &f.modes {
                let hz = m.omega / std::f64::consts::TAU;
                let (j, t) = nearest(&truth, hz).unwrap();
                let e = (hz / t.hz - 1.0, m.zeta / t.zeta - 1.0);
                println!(
                    "  {hz:.4} Hz, ζ {:.4}: the truth's mode {j} {:+.2} %, ζ {:+.1} %",
                    m.zeta,
                    e.0 * 100.0,
                    e.1 * 100.0
                );
                // Below the link's second mode the held first mode and the hold's ring.
                if hz >= HELD_BELOW * truth[1].hz {
                    assert!(j >= 2 && e.0.abs() < 0.005, "{name}: mode {j}: {e:?}");
                    if tapper == Tapper::Hammer {
                        assert!(e.1.abs() < 0.15, "{name}: mode {j}: {e:?}");
                    }
                    found.push(j);
                }
            }
            if tapper == Tapper::Hammer {
                let inside = truth[1..]
                    .iter()
                    .filter(|t| t.hz >= set.band.0 && t.hz <= set.band.1)
                    .count();
                assert_eq!(found, (2..2 + inside).collect::<Vec<_>>(), "{name}");
            }
        }
    }
}

/// The inertia fit on the arm whose swing moves its link most (the slow arm: a 0.5 Hz first
/// mode, a 0.22 kg tip body), with the truth link's own six modes (no modes fit, no shapes):
/// `S` within 3 % at the swing's reach and at half and a quarter of it (−1.76, +1.41,
/// +2.56 %), and with ideal drives (−1.41 %). Before the fit took the deflection's first
/// moment `V = vᵀδ` into the coupling (`flexarm_host::identify::inertia`, module docs), the
/// same swings gave +5.50, +4.01, +3.27 and +5.89 %: the slow arm's `S` bias.
#[test]
fn the_slow_arms_s_with_its_own_modes() {
    use flexarm_host::identify::family::{lab_record, swing};
    use flexarm_host::identify::inertia::{FlexMode, Rigid, fit_inertia_with};
    use flexarm_host::truth_plant::MotorSpec;
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    for ideal in [false, true] {
        let mut arm = family().into_iter().next().unwrap();
        if ideal {
            arm.spec.motors = [MotorSpec::IDEAL; 2];
        }
        let bench = arm.bench().unwrap();
        let (body, _) = arm.spec.link(&arm.rigid, &arm.patch).unwrap();
        let flex: Vec<FlexMode> = (0..body.omega.len())
            .map(|j| FlexMode {
                omega: body.omega[j],
                zeta: body.zeta[j],
                v: body.v[j],
                w: body.w[j],
            })
            .collect();
        let truth = Rigid::of(&bench.arm);
        for reach in if ideal {
            vec![1.0]
        } else {
            vec![1.0, 0.5, 0.25]
        } {
            let mut plan = swing(&bench, body.omega[0] / std::f64::consts::TAU);
            if let Some(t) = plan.track.as_mut() {
                t.reach *= reach;
            }
            // A file of its own: `slow_arm` records its swing beside it at the same time.
            let name = format!("swing-own-modes-{ideal}-{reach}");
            let trace = lab_record(dir, (arm.name, &name), &plan, false).unwrap();
            let fit = fit_inertia_with(&trace, bench.arm.a1, &flex).unwrap();
            let e = fit.rigid.s / truth.s - 1.0;
            println!(
                "slow, ideal drives {ideal}, reach ×{reach}: S {:+.2} %",
                e * 100.0
            );
            assert!(e.abs() < 0.03, "reach ×{reach}: {e}");
        }
    }
}
