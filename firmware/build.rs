//! Links with cortex-m-rt's `link.x` and defmt's `defmt.x` when building for a Cortex-M target,
//! with the root `memory.x`; host builds of the workspace stay untouched.

use std::{env, fs, path::PathBuf};

fn main() {
    let target = env::var("TARGET").unwrap_or_default();
    println!("cargo:rerun-if-changed=../memory.x");
    println!("cargo:rerun-if-changed=budgets.txt");
    budgets();
    generated();
    if !target.starts_with("thumb") {
        return;
    }
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::copy("../memory.x", out.join("memory.x")).expect("memory.x at the repository root");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg=-Tlink.x");
    println!("cargo:rustc-link-arg=-Tdefmt.x");
    #[cfg(feature = "c-compare")]
    c_compare();
}

/// The bench's C comparison (feature `c-compare`): `c/steps.c` built with arm-none-eabi-gcc
/// for the Cortex-M4F at -O2 and at -O3, each build's symbols suffixed `_o2` / `_o3`, the same
/// arithmetic as the Rust (`-ffp-contract=off`: rustc never fuses a multiply and an add).
#[cfg(feature = "c-compare")]
fn c_compare() {
    const GCC: &str = "arm-none-eabi-gcc";
    println!("cargo:rerun-if-changed=c/steps.c");
    let found = std::process::Command::new(GCC).arg("--version").output();
    if !found.is_ok_and(|o| o.status.success()) {
        panic!(
            "{GCC} not found: the bench's C comparison needs it (Debian/Ubuntu: apt-get install gcc-arm-none-eabi)"
        );
    }
    for level in [2, 3] {
        cc::Build::new()
            .compiler(GCC)
            .file("c/steps.c")
            .opt_level(level)
            .define("SUFFIX", format!("_o{level}").as_str())
            .flag("-std=c11")
            .flag("-mthumb")
            .flag("-mcpu=cortex-m4")
            .flag("-mfpu=fpv4-sp-d16")
            .flag("-mfloat-abi=hard")
            .flag("-ffp-contract=off")
            .flag("-ffreestanding")
            .warnings_into_errors(true)
            .compile(&format!("flexarm_c_o{level}"));
    }
}

/// The generated parameters the firmware builds with, as `OUT_DIR/generated.rs` (included by
/// `mod generated` in main.rs): `src/generated.rs`, or the file `FLEXARM_PARAMS` names (a path
/// relative to the repository root, or absolute), for example the parameters of a model that
/// `cargo sim identify` measured (`cargo sim firmware-params out/model/model.toml --out
/// target/identified.rs`, then `FLEXARM_PARAMS=target/identified.rs cargo fw-qemu`). Only a
/// file `cargo sim firmware-params` wrote is taken; its inner doc comments become plain
/// comments (`include!` takes items only).
fn generated() {
    const FIRST_LINE: &str = "//! The arm model, piezo patch and observer gains the firmware runs, in each board's configuration.";
    println!("cargo:rerun-if-env-changed=FLEXARM_PARAMS");
    let root = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it")).join("..");
    let (path, name) = match env::var_os("FLEXARM_PARAMS") {
        Some(p) if !p.is_empty() => (root.join(&p), p.to_string_lossy().into_owned()),
        _ => (
            PathBuf::from("src/generated.rs"),
            "firmware/src/generated.rs".into(),
        ),
    };
    println!("cargo:rerun-if-changed={}", path.display());
    let text = fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("FLEXARM_PARAMS: cannot read {name}: {e}"));
    if text.lines().next() != Some(FIRST_LINE) {
        panic!(
            "FLEXARM_PARAMS: {name} is not a file `cargo sim firmware-params` wrote (regenerate it)"
        );
    }
    let body: String = text
        .lines()
        .map(|l| {
            l.strip_prefix("//!")
                .map_or(l.to_string(), |rest| format!("//{rest}"))
        })
        .map(|l| l + "\n")
        .collect();
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::write(out.join("generated.rs"), body).expect("OUT_DIR is writable");
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
            "/// `{key}` of firmware/budgets.txt.\n#[allow(dead_code)]\npub const BUDGET_{}: u32 = {value};\n",
            key.trim().to_uppercase(),
            key = key.trim()
        );
    }
    let path =
        PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR")).join("budgets.rs");
    fs::write(path, out).expect("write budgets.rs");
}
