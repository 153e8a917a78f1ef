//! Spillover of the sampled piezo loop into modes the controller does not know
//! (`flexarm_host::spillover`). `cargo test -p flexarm-host --test spillover -- --nocapture`
//! prints the margins.

use flexarm_beam::design::DesignModel;
use flexarm_core::control::piezo::PiezoPatch;
use flexarm_host::spillover::{ModalLink, PiezoLoop, gain_margin, spectral_radius};

/// The design beam (the paper's section, aluminium) with the paper's patch, `n` modes.
fn link(n: usize) -> ModalLink {
    let model = DesignModel {
        zeta: [0.07, 0.03]
            .into_iter()
            .chain(std::iter::repeat(0.02))
            .take(n)
            .collect(),
        lambda: vec![1.0; n],
        ..Default::default()
    };
    let pm = model.patch_modes(0.09, 0.35).unwrap();
    ModalLink {
        omega: pm.omega(),
        zeta: model.zeta.clone(),
        slope_diff: pm.slope_diff.clone(),
        k_a: pm.k_a,
        k_s: pm.k_s,
        feedthrough: 0.0,
    }
}

/// The firmware's piezo loop on the hardware board: k_c = 30 s, 100 Hz corner, 10 kHz.
const FIRMWARE: PiezoLoop = PiezoLoop {
    k_c: 30.0,
    cutoff_hz: 100.0,
    period: 1e-4,
    delay: false,
    amplifier_hz: None,
};

#[test]
fn without_gain_the_loop_has_the_beams_own_decay() {
    let l = link(4);
    let off = PiezoLoop {
        k_c: 0.0,
        ..FIRMWARE
    };
    let wc_t = std::f64::consts::TAU * 100.0 * 1e-4;
    let filter = (2.0 - wc_t) / (2.0 + wc_t);
    let slowest = l
        .omega
        .iter()
        .zip(&l.zeta)
        .map(|(w, z)| (-z * w * 1e-4).exp())
        .fold(0.0, f64::max);
    let rho = spectral_radius(&l, &off).unwrap();
    assert!(
        (rho - slowest.max(filter)).abs() < 1e-9,
        "{rho} vs {slowest}, {filter}"
    );
}

#[test]
fn the_margin_scales_with_the_sample_rate_and_shrinks_with_the_modes() {
    let (two, six) = (link(2), link(6));
    let m =
        |l: &ModalLink, law: &PiezoLoop| gain_margin(l, law, 1e6).unwrap().unwrap_or(f64::INFINITY);
    let fast = PiezoLoop {
        period: 5e-5,
        ..FIRMWARE
    };
    let (m6, m6_fast) = (m(&six, &FIRMWARE), m(&six, &fast));
    // Notes §13: the limit behaves like 2/(T cᵀc): halving T about doubles it.
    let ratio = m6_fast / m6;
    assert!(ratio > 1.6 && ratio < 2.5, "{m6_fast} / {m6} = {ratio}");
    // Modes the controller does not know can only cost margin.
    let m2 = m(&two, &FIRMWARE);
    assert!(m6 <= m2 * (1.0 + 1e-3), "{m6} vs {m2}");
    // And the shipped gain is stable on the six-mode beam.
    assert!(m6 > 1.0, "{m6}");
}

#[test]
fn margins_of_the_shipped_piezo_loop() {
    println!(
        "factor on k_c = 30 s before the sampled piezo loop goes unstable (design beam, paper's patch, joints held):"
    );
    for (label, law) in [
        ("10 kHz", FIRMWARE),
        (
            "10 kHz, one-sample delay",
            PiezoLoop {
                delay: true,
                ..FIRMWARE
            },
        ),
        (
            "1 kHz (QEMU board)",
            PiezoLoop {
                period: 1e-3,
                ..FIRMWARE
            },
        ),
    ] {
        let row: Vec<String> = [2, 4, 6, 8, 10]
            .iter()
            .map(|&n| {
                let f = link(n).omega.last().copied().unwrap_or(0.0) / std::f64::consts::TAU;
                match gain_margin(&link(n), &law, 1e6).unwrap() {
                    Some(g) => format!("N = {n} (to {f:.0} Hz): {g:.1}"),
                    None => format!("N = {n} (to {f:.0} Hz): > 1e6"),
                }
            })
            .collect();
        println!("  {label}: {}", row.join("; "));
    }
    // Where the ten-mode loop goes unstable at the shipped gain.
    let m = flexarm_host::spillover::closed_loop(&link(10), &FIRMWARE);
    for l in flexarm_host::eigen::eigenvalues(&m)
        .unwrap()
        .iter()
        .filter(|l| l.norm() > 1.0)
    {
        println!(
            "  ten modes, 10 kHz: unstable pair |λ| = {:.4} at {:.0} Hz",
            l.norm(),
            l.arg().abs() / (std::f64::consts::TAU * FIRMWARE.period)
        );
    }
}

#[test]
fn an_unstable_margin_is_a_growing_vibration() {
    // The eigenvalue verdict checked by iterating the loop: with ten modes and no physical
    // roll-off the shipped gain makes a vibration grow; with two modes it decays.
    use flexarm_host::spillover::closed_loop;
    for (n, grows) in [(10, true), (2, false)] {
        let l = link(n);
        let m = closed_loop(&l, &FIRMWARE);
        let mut z = nalgebra::DVector::<f64>::zeros(m.nrows());
        for j in 0..n {
            z[j] = 1e-4; // every mode deflected a little
        }
        // The filter primed with the first sample, as the firmware's is (no start-up kick).
        // State (x, u_{k−1}, (u_{k−1}, y_{k−1})): the law's previous film sample is at 2n + 2.
        z[2 * n + 2] = (0..n).map(|j| l.k_s * l.slope_diff[j] * z[j]).sum::<f64>();
        let mut at_1s = 0.0;
        for k in 0..50_000 {
            z = &m * z;
            if k == 10_000 {
                at_1s = z.norm();
            }
        }
        let ratio = z.norm() / at_1s;
        assert_eq!(
            ratio > 1.0,
            grows,
            "N = {n}: |z| changed by {ratio:e} from 1 s to 5 s"
        );
    }
}

#[test]
fn margins_against_the_filter_corner() {
    // A lower corner of the rate filter lowers its high-frequency gain k_c ω_c, the gain the
    // unknown modes see, at the cost of phase at the second mode (atan(f2/f_c)).
    println!("factor on k_c = 30 s at 10 kHz, ten modes, against the rate filter's corner:");
    let mut margins = Vec::new();
    for fc in [100.0, 50.0, 30.0, 20.0, 10.0] {
        let law = PiezoLoop {
            cutoff_hz: fc,
            ..FIRMWARE
        };
        let g = gain_margin(&link(10), &law, 1e6)
            .unwrap()
            .unwrap_or(f64::INFINITY);
        println!("  corner {fc} Hz: {g:.2}");
        margins.push(g);
    }
    // The shipped 100 Hz corner is unstable with ten modes; a 10 Hz corner is stable.
    assert!(margins[0] < 1.0 && margins[4] > 1.0, "{margins:?}");
}

#[test]
fn margins_with_a_real_amplifier() {
    // A piezo amplifier driving the patch's capacitance has a bandwidth: a first-order lag that
    // rolls the loop off above it. Ten modes, 10 kHz, the shipped gain and corner.
    println!("factor on k_c = 30 s at 10 kHz, ten modes, against the amplifier's bandwidth:");
    let mut margins = Vec::new();
    for f in [None, Some(5000.0), Some(2000.0), Some(1000.0), Some(500.0)] {
        let law = PiezoLoop {
            amplifier_hz: f,
            ..FIRMWARE
        };
        let g = gain_margin(&link(10), &law, 1e6)
            .unwrap()
            .unwrap_or(f64::INFINITY);
        println!(
            "  amplifier {}: {g:.2}",
            f.map_or("ideal".into(), |f| format!("{f} Hz"))
        );
        margins.push(g);
    }
    // Measured: 0.85 (ideal), 0.47, 0.30, 0.16, 0.05. The lag adds phase without taking
    // enough gain away where the loop goes unstable: every slower amplifier costs margin.
    assert!(margins.windows(2).all(|w| w[1] < w[0]), "{margins:?}");
}

/// The study on the truth plant's ten modes (`flexarm-sim spillover`): the shipped gain is not
/// robust, the design rule's gain is, and the closed loop shows it.
#[test]
fn the_study_finds_the_shipped_gain_unstable_and_the_rule_robust() {
    use flexarm_host::spillover_study::{MARGIN, run};
    use flexarm_host::truth_plant::TruthSpec;
    let r = run(
        &TruthSpec {
            modes: 10,
            ..TruthSpec::default()
        },
        &[],
        5.0,
    )
    .unwrap();
    // Question 1: the realistic board (amplifier, one-period delay) with ten modes.
    let board = &r.margins[2].1;
    assert!(board[9] < 1.0, "{board:?}");
    // Fewer modes, more margin: two modes alone are stable.
    assert!(board[1] > 1.0, "{board:?}");
    // Question 3: the rule keeps its margin and damps both modes beyond their structural ζ.
    let p = r.recommended.expect("a robust gain exists");
    assert!(p.margin >= MARGIN, "{p:?}");
    assert!(
        p.zeta[0] > 1.3 * r.spec.zeta[0] && p.zeta[1] > 3.0 * r.spec.zeta[1],
        "{p:?}"
    );
    // Question 4: with the full state, the shipped gain saturates the amplifier (the unstable
    // loop's limit cycle) and leaves the link vibrating; the rule's gain settles it.
    let (shipped, rule) = (
        r.runs[0].summary.as_ref().unwrap(),
        r.runs[4].summary.as_ref().unwrap(),
    );
    assert!(shipped.max_v_a >= 199.9, "{shipped:?}");
    assert!(rule.max_v_a < 100.0, "{rule:?}");
    assert!(
        rule.tail_delta_abs[0] * 100.0 < shipped.tail_delta_abs[0],
        "{rule:?}\n{shipped:?}"
    );
    println!("{}", flexarm_host::spillover_study::markdown(&r));
}

/// Question 5 (issue 35): the laws on the realistic board with ten modes, across the film's
/// feedthrough (bond 0, 0.5, 1), `N = 2 … 10`. About 5 s (30 closed-loop runs of 5 s on the
/// ten-mode truth plant and 135 margins).
#[test]
fn only_positive_position_feedback_keeps_its_margin_and_damping_at_every_bond() {
    use flexarm_host::spillover_study::{
        BONDS, MARGIN, compare, meeting_the_goal, recommend, scan,
    };
    use flexarm_host::truth_plant::TruthSpec;
    let spec = TruthSpec {
        modes: 10,
        ..TruthSpec::default()
    };
    let full = ModalLink::from_truth(&spec, &Default::default(), &PiezoPatch::paper()).unwrap();
    let board = flexarm_host::spillover_study::realistic(&spec, FIRMWARE);
    // The rate law's design rule (question 3), from the 30 Hz column of its scan.
    let rule = recommend(
        &scan(
            &full,
            &board,
            &flexarm_host::spillover_study::gains(),
            &[30.0],
        )
        .unwrap(),
    )
    .unwrap();
    let rows = compare(&spec, &BONDS, rule, 5.0).unwrap();
    let row = |kind: &str, bond: f64| {
        rows.iter()
            .find(|r| r.kind == kind && r.bond == bond)
            .unwrap()
    };
    assert_eq!(meeting_the_goal(&rows), vec!["ppf"]);
    let base = row("rate rule", 0.0).zeta;
    for &b in &BONDS {
        let ppf = row("ppf", b);
        // The rule's static budget: a factor of 2.5 (the DC limit), kept at every N.
        assert!(ppf.worst_margin() >= MARGIN, "{b}: {:?}", ppf.margins);
        assert!(
            ppf.zeta[0] > 1.5 * base[0] && ppf.zeta[1] > 1.2 * base[1],
            "{b}: {:?}",
            ppf.zeta
        );
        // Settled: with a noise-free film, below the rate rule's residual on mode 1.
        let clean = ppf.clean.as_ref().unwrap();
        assert!(clean.tail_delta_abs[0] < 1.0e-6 * 0.2, "{b}: {clean:?}");
        // IRC keeps its margin but not mode 2's damping.
        let irc = row("irc", b);
        assert!(
            irc.worst_margin() >= MARGIN && irc.zeta[1] < base[1],
            "{b}: {irc:?}"
        );
    }
    // The rate rule loses its margin to the feedthrough; cancelling F̂ recovers only part.
    assert!(row("rate rule", 1.0).worst_margin() < 1.0);
    assert!(row("cancel", 1.0).worst_margin() < MARGIN && row("cancel", 1.0).worst_margin() > 1.0);
    // The shipped gain is unstable at every N once the film sees half the perfect bond.
    assert!(row("rate shipped", 0.5).margins.iter().all(|m| m.1 < 0.2));
}

/// The simulator runs the laws of issue 35 with the full state only, and refuses an invalid one
/// with its key.
#[test]
fn the_simulator_refuses_a_law_it_cannot_run() {
    use flexarm_core::control::irc::IrcGains;
    use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
    use flexarm_host::sim::{PiezoLawChoice, SimConfig, SimError, StateSource, simulate};
    let irc = IrcGains {
        gamma: 1e3f32,
        feedthrough: -5e-3,
        leak_hz: 0.5,
    };
    let traj = JointTrajectory::Trapezoid(Trapezoid::paper());
    let key = |r: Result<_, SimError>| match r {
        Err(SimError::Input { key, .. }) => key,
        other => panic!("{other:?}"),
    };
    let observer = SimConfig {
        piezo_law: Some(PiezoLawChoice::Irc(irc)),
        state: StateSource::Observer,
        duration: 0.01,
        tail_window: 0.005,
        ..SimConfig::default()
    };
    assert_eq!(
        key(simulate(&observer, &traj, false).map(|_| ())),
        "piezo_law"
    );
    let negative = SimConfig {
        piezo_law: Some(PiezoLawChoice::Irc(IrcGains { gamma: -1.0, ..irc })),
        duration: 0.01,
        tail_window: 0.005,
        ..SimConfig::default()
    };
    assert_eq!(
        key(simulate(&negative, &traj, false).map(|_| ())),
        "piezo_law"
    );
    let fine = SimConfig {
        piezo_law: Some(PiezoLawChoice::Irc(irc)),
        duration: 0.01,
        tail_window: 0.005,
        ..SimConfig::default()
    };
    assert!(simulate(&fine, &traj, false).is_ok());
}
