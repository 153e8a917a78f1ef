//! The whole input surface of the optimizer's configuration and of a `[piezo]` fragment, each key
//! with hostile values (NaN, ±∞, negative, zero, tiny, huge, the wrong type): every one is
//! refused with one line naming its key, or accepted within its physical range.

use flexarm_beam::config::Config;
use flexarm_beam::fragment::read_piezo;

const VALUES: &[&str] = &[
    "nan", "inf", "-inf", "-1.0", "0.0", "1e-30", "1e30", "\"text\"",
];

/// `(table, key, is_list)` of every numeric key of `beam/examples/optimize.toml`.
const CONFIG_KEYS: &[(&str, &str, bool)] = &[
    ("beam", "length", false),
    ("beam", "e_b", false),
    ("beam", "t_b", false),
    ("beam", "width", false),
    ("beam", "rho_b", false),
    ("beam", "tip_mass", false),
    ("beam", "tip_inertia", false),
    ("beam", "zeta", true),
    ("piezo", "e_c", false),
    ("piezo", "t_c", false),
    ("piezo", "rho_c", false),
    ("piezo", "d31", false),
    ("piezo", "e_f", false),
    ("piezo", "t_f", false),
    ("piezo", "rho_f", false),
    ("piezo", "g31", false),
    ("piezo", "c_area", false),
    ("optimize", "alpha", false),
    ("optimize", "beta_c", false),
    ("optimize", "lambda", true),
    ("optimize", "step", false),
    ("optimize", "k_c", true),
    ("optimize", "k_max", false),
    ("optimize", "min_length", false),
    ("amplifier", "v_max", false),
    ("amplifier", "reference_tip_speed", true),
    ("sensitivity", "alpha", true),
    ("sensitivity", "beta_c", true),
    ("sensitivity", "rho_b", true),
    ("sensitivity", "k_max", true),
    ("sensitivity", "tip_mass", true),
];

fn value(v: &str, list: bool) -> String {
    if list {
        format!("[{v}, {v}]")
    } else {
        v.to_string()
    }
}

#[test]
fn every_optimizer_key_with_hostile_values() {
    let (mut accepted, mut refused) = (0, 0);
    for &(table, key, list) in CONFIG_KEYS {
        for v in VALUES {
            let text = format!("[{table}]\n{key} = {}\n", value(v, list));
            match Config::from_toml(&text) {
                Err(e) => {
                    refused += 1;
                    let msg = e.to_string();
                    assert!(!msg.contains('\n'), "one line: {msg}");
                    assert!(msg.contains(key), "{table}.{key} = {v}: {msg}");
                }
                Ok(c) => {
                    accepted += 1;
                    // Whatever is accepted describes a physical beam: finite sections.
                    let m = c.model();
                    let (b, p) = (m.layers.bare(), m.layers.patched());
                    assert!(
                        [b.ei, b.rho_a, p.ei, p.rho_a]
                            .iter()
                            .all(|x| x.is_finite() && *x > 0.0),
                        "{table}.{key} = {v}"
                    );
                }
            }
        }
    }
    println!("optimizer: {accepted} accepted, {refused} refused naming their key");
    assert!(refused > 4 * accepted);
}

#[test]
fn every_fragment_key_with_hostile_values() {
    let good = "[piezo]\nx_a = 0.09\nl_a = 0.35\nk_c = 30.0\nk_a = 1.9e-4\nk_s = 28.0\nslope_diff = [4.55, -22.98]\n";
    assert!(read_piezo(good, 0.7).is_ok());
    let (mut accepted, mut refused) = (0, 0);
    for (key, list) in [
        ("x_a", false),
        ("l_a", false),
        ("k_c", false),
        ("k_a", false),
        ("k_s", false),
        ("k_c_paper_modes", false),
        ("slope_diff", true),
    ] {
        for v in VALUES {
            let line = format!("{key} = {}", value(v, list));
            let text = if good.contains(&format!("\n{key} = ")) {
                good.lines()
                    .map(|l| {
                        if l.starts_with(&format!("{key} = ")) {
                            line.clone()
                        } else {
                            l.to_string()
                        }
                    })
                    .collect::<Vec<_>>()
                    .join("\n")
            } else {
                format!("{good}{line}\n")
            };
            match read_piezo(&text, 0.7) {
                Err(e) => {
                    refused += 1;
                    let msg = e.to_string();
                    assert!(!msg.contains('\n'), "one line: {msg}");
                    assert!(msg.contains(key), "{key} = {v}: {msg}");
                }
                Ok(c) => {
                    accepted += 1;
                    let p = c.patch.to_f32();
                    assert!(
                        p.validate(0.7).is_ok() && c.controller_k_c().is_finite(),
                        "{key} = {v}: accepted but not runnable: {c:?}"
                    );
                }
            }
        }
    }
    println!("fragment: {accepted} accepted, {refused} refused naming their key");
}
