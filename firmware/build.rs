//! Links with cortex-m-rt's `link.x` and defmt's `defmt.x` when building for a Cortex-M target,
//! with the root `memory.x`; host builds of the workspace stay untouched.

use std::{env, fs, path::PathBuf};

fn main() {
    let target = env::var("TARGET").unwrap_or_default();
    println!("cargo:rerun-if-changed=../memory.x");
    println!("cargo:rerun-if-changed=budgets.txt");
    budgets();
    if !target.starts_with("thumb") {
        return;
    }
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::copy("../memory.x", out.join("memory.x")).expect("memory.x at the repository root");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg=-Tlink.x");
    println!("cargo:rustc-link-arg=-Tdefmt.x");
}

/// `budgets.txt` (`key = value` lines) as constants `BUDGET_<KEY>: u32` for the benchmark build.
fn budgets() {
    let text = fs::read_to_string("budgets.txt").expect("firmware/budgets.txt");
    let mut out = String::from("// Generated from firmware/budgets.txt by build.rs.\n");
    for line in text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
    {
        let (key, value) = line
            .split_once('=')
            .expect("budgets.txt: `key = value` lines");
        let value: u32 = value
            .trim()
            .parse()
            .expect("budgets.txt: values are whole numbers");
        out += &format!(
            "#[allow(dead_code)]\npub const BUDGET_{}: u32 = {value};\n",
            key.trim().to_uppercase()
        );
    }
    let path =
        PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR")).join("budgets.rs");
    fs::write(path, out).expect("write budgets.rs");
}
