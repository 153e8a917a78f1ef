use flexarm_core::control::piezo::PiezoGains;
use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
use flexarm_sim::sim::{SimConfig, simulate};
use flexarm_sim::truth_plant::TruthSpec;

#[test]
fn scratch() {
    for t in [0.8e-3, 1.5e-3, 2.0e-3, 2.5e-3, 3.0e-3] {
        let spec = TruthSpec {
            thickness: t,
            ..TruthSpec::default()
        };
        let base = SimConfig {
            piezo: Some(PiezoGains::default()),
            ..SimConfig::default()
        };
        let (body, c) = spec.link(&base.arm, &base.patch).unwrap();
        let f: Vec<String> = body
            .omega
            .iter()
            .map(|w| format!("{:.1}", w / std::f64::consts::TAU))
            .collect();
        println!(
            "t = {:.1} mm: mass {:.3} kg, f = {:?}, k_a {:.3e} k_s {:.3e}",
            t * 1e3,
            body.mass,
            f,
            c.k_a,
            c.k_s
        );
        for (label, sp, piezo) in [
            ("ideal act, no piezo", spec.ideal_actuators(), None),
            (
                "ideal act, piezo",
                spec.ideal_actuators(),
                Some(PiezoGains::default()),
            ),
            ("real, piezo", spec, Some(PiezoGains::default())),
        ] {
            let cfg = SimConfig {
                piezo,
                ..SimConfig::default()
            }
            .with_truth(sp)
            .unwrap();
            let tr = JointTrajectory::Trapezoid(Trapezoid::paper());
            let t0 = std::time::Instant::now();
            match simulate(&cfg, &tr, false) {
                Ok((s, _)) => println!(
                    "   {label}: max tip {:.4} m, l2 err {:.3e}, l2 delta {:.3e}, tail |e| {:.2e} {:.2e}, max V {:.1}, max err {:.2e}  ({:?})",
                    s.max_tip,
                    s.l2_error,
                    s.l2_delta,
                    s.tail_error_abs[0],
                    s.tail_error_abs[1],
                    s.max_v_a,
                    s.max_error,
                    t0.elapsed()
                ),
                Err(e) => println!("   {label}: {e}"),
            }
        }
    }
    let cfg = SimConfig {
        piezo: Some(PiezoGains::default()),
        ..SimConfig::default()
    };
    let (s, _) = simulate(&cfg, &JointTrajectory::Trapezoid(Trapezoid::paper()), false).unwrap();
    println!(
        "model plant: max tip {:.4}, l2 err {:.3e}, l2 delta {:.3e}",
        s.max_tip, s.l2_error, s.l2_delta
    );
}
