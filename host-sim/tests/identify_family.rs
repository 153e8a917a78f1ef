//! Identification on the family (issue 32, `flexarm_sim::identify::family`): five truth-plant
//! arms unlike the paper's, each recorded the way a lab records (`flexarm_sim::lab`, written
//! by the simulator's trace writer and read back), fitted by the same code as `cargo sim
//! identify`. The bounds are the and docs/identification.md's: on the records that
//! excite the base on its own (a chirp with noise on joint 2's torque, noise on both), the
//! controller's two modes within 0.5 % in frequency, 15 % in damping and 10 % in the
//! piezo→film product; the inertias within 5 % where the link's first mode lies above the
//! inertia fit's band (the fit assumes a rigid link: docs); the controller built from the
//! identified model within 10 % of the true parameters' on Eq. 37 on every arm. A chirp on the
//! patch alone gives the held arm's modes, which the fit says and the model step refuses.

use flexarm_sim::identify::family::{ArmResult, Kind, family, identify_arm, nearest};

fn run(name: &str, kinds: &[Kind]) -> ArmResult {
    let arm = family().into_iter().find(|a| a.name == name).unwrap();
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    identify_arm(&arm, kinds, dir, false).unwrap()
}

/// The model-grade kinds, on every arm.
const KINDS: [Kind; 2] = [Kind::ChirpNoise, Kind::Random];

/// The inertias' bound: the 5 %, and on the slow arm 7 % for `S`. The model step's
/// shapes are a uniform link's (the geometry gives no patch section); on the slow arm's 1 mm
/// link the patch's layers are a large share of the link's mass and stiffness over 0.35 m, the
/// shapes' couplings are that far off, and what the link's modes leave in the torques biases
/// `S` (+5.8 %; docs/identification.md).
fn inertia_bound(arm: &str, n: &str) -> f64 {
    if arm == "slow" && n == "S" {
        0.07
    } else {
        0.05
    }
}

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
                let e = flexarm_sim::identify::model::identified_model(
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
        assert!((x / y - 1.0).abs() < inertia_bound(name, n), "{name}: {n}");
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
