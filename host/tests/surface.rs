//! The whole input surface of a scenario file, each key with hostile values (NaN, ±∞, negative,
//! zero, tiny, huge, the wrong type): every one is refused with one line naming its key, or runs
//! to a finite result. No panic; no NaN in what a run reports.

use flexarm_host::scenario::parse;
use flexarm_host::sim::simulate;

/// A short run so that every accepted case is cheap.
const HEAD: &str = "name = \"surface\"\nduration = 0.5\ntail_window = 0.2\n";

/// `(table, key, kind)`: kind `s` scalar, `v2`/`v4` arrays, `b` boolean, `i` integer.
const KEYS: &[(&str, &str, &str)] = &[
    ("", "duration", "s"),
    ("", "tail_window", "s"),
    ("trajectory", "move_time", "s"),
    ("trajectory", "ramp_time", "s"),
    ("trajectory", "start", "v2"),
    ("trajectory", "amplitude", "v2"),
    ("controller", "k_c", "s"),
    ("controller", "cutoff_hz", "s"),
    ("controller", "kp", "v4"),
    ("controller", "lambda", "v4"),
    ("controller", "d_delta", "v2"),
    ("controller", "piezo", "b"),
    ("rates", "plant_dt", "s"),
    ("rates", "motor_hz", "s"),
    ("rates", "piezo_hz", "s"),
    ("limits", "tau_max", "v2"),
    ("limits", "v_a_max", "s"),
    ("limits", "v_a_min", "s"),
    ("arm", "a1", "s"),
    ("arm", "a2", "s"),
    ("arm", "m1", "s"),
    ("arm", "m2", "s"),
    ("arm", "m_h2", "s"),
    ("arm", "i_1", "s"),
    ("arm", "i_h1", "s"),
    ("arm", "i_h2", "s"),
    ("arm", "i_2_extra", "s"),
    ("arm", "frequency_hz", "v2"),
    ("arm", "zeta", "v2"),
    ("sensors", "encoder_counts", "s"),
    ("sensors", "adc_bits", "i"),
    ("sensors", "adc_range", "s"),
    ("sensors", "film_noise", "s"),
    ("sensors", "piezo_slew", "s"),
    ("sensors", "seed", "i"),
    ("sensors", "delay", "b"),
];

const CIRCLE_KEYS: &[&str] = &[
    "centre",
    "radius",
    "period",
    "ramp_time",
    "start_phase",
    "margin",
];

const VALUES: &[&str] = &[
    "nan", "inf", "-inf", "-1.0", "0.0", "1e-30", "1e30", "\"text\"",
];

fn value(kind: &str, v: &str) -> String {
    match kind {
        "v2" => format!("[{v}, {v}]"),
        "v4" => format!("[{v}, {v}, {v}, {v}]"),
        "i" => match v {
            "-1.0" => "-1".into(),
            "0.0" => "0".into(),
            "1e30" => "4294967296".into(),
            "\"text\"" => v.into(),
            _ => "1.5".into(),
        },
        "b" => v.into(),
        _ => v.into(),
    }
}

fn scenario(table: &str, key: &str, text: &str, kind: &str) -> String {
    let mut s = String::from(HEAD);
    let line = format!("{key} = {text}\n");
    if table.is_empty() {
        s = s.replace(&format!("{key} = "), "# ") + &line;
    }
    let traj = if kind == "circle" {
        "[trajectory]\nkind = \"circle\"\nperiod = 0.4\nramp_time = 0.1\n"
    } else {
        "[trajectory]\nkind = \"trapezoid\"\nmove_time = 0.4\nramp_time = 0.1\n"
    };
    if table == "trajectory" {
        let t = traj
            .lines()
            .filter(|l| !l.starts_with(&format!("{key} =")))
            .collect::<Vec<_>>()
            .join("\n");
        s += &format!("{t}\n{line}");
    } else {
        s += traj;
        if !table.is_empty() {
            s += &format!("[{table}]\n{line}");
        }
    }
    s
}

fn check(text: &str, key: &str, accepted: &mut usize, refused: &mut usize) {
    match parse(text) {
        Err(e) => {
            *refused += 1;
            assert!(!e.0.contains('\n'), "one line: {e}");
            assert!(
                e.0.contains(key),
                "{key}: the error must name it: {e}\n{text}"
            );
        }
        Ok(sc) => {
            *accepted += 1;
            // A run that starts either completes with finite figures or stops with a clean
            // error (a fault the controller latched, a diverged plant).
            if let Ok((sum, _)) = simulate(&sc.config, &sc.trajectory, false) {
                let all = [
                    sum.l2_delta,
                    sum.l2_error,
                    sum.l2_tip,
                    sum.max_error,
                    sum.max_v_a,
                    sum.max_tip,
                    sum.max_tau[0],
                    sum.max_tau[1],
                ];
                assert!(all.iter().all(|x| x.is_finite()), "{key}: {sum:?}\n{text}");
            }
        }
    }
}

#[test]
fn every_scenario_key_with_hostile_values() {
    let (mut accepted, mut refused) = (0, 0);
    for &(table, key, kind) in KEYS {
        for v in VALUES {
            let text = scenario(table, key, &value(kind, v), kind);
            check(&text, key, &mut accepted, &mut refused);
        }
    }
    for key in CIRCLE_KEYS {
        let kind = if *key == "centre" { "v2" } else { "s" };
        for v in VALUES {
            let text = scenario("trajectory", key, &value(kind, v), "circle")
                .replace("kind = \"trapezoid\"", "kind = \"circle\"");
            check(&text, key, &mut accepted, &mut refused);
        }
    }
    println!("{accepted} accepted and run, {refused} refused naming their key");
    assert!(refused > 5 * accepted, "most hostile values are refused");
}
