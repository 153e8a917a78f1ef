//! The command line: scenario files run, bad input gets one readable line and a non-zero exit.

use std::process::Command;

fn sim(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_flexarm-sim"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

fn scratch(name: &str, text: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("flexarm-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn shipped_scenarios_run() {
    let out = std::env::temp_dir().join(format!("flexarm-cli-out-{}", std::process::id()));
    for f in ["trapezoid", "circle", "trapezoid_observer"] {
        let path = format!("{}/scenarios/{f}.toml", env!("CARGO_MANIFEST_DIR"));
        let (ok, stdout, stderr) = sim(&[
            "run",
            &path,
            "--out",
            out.to_str().unwrap(),
            "--no-plots",
            "--duration",
            "3.5",
        ]);
        assert!(ok, "{f}: {stderr}");
        assert!(stdout.contains("Eq. 37"), "{stdout}");
        assert!(out.join(format!("{f}_scenario.csv")).exists());
    }
}

#[test]
fn bad_input_is_one_readable_line() {
    let cases = [
        (
            "unknown.toml",
            "[trajectory]\nkind = \"trapezoid\"\nspeed = 3\n",
            "unknown field `speed`",
        ),
        (
            "range.toml",
            "[trajectory]\nkind = \"trapezoid\"\n[sensors]\nadc_bits = 40\n",
            "adc_bits",
        ),
        (
            "mass.toml",
            "[trajectory]\nkind = \"trapezoid\"\n[arm]\nm1 = -2\n",
            "m1",
        ),
        (
            "circle.toml",
            "[trajectory]\nkind = \"circle\"\ncentre = [0.4, 0.0]\nmargin = 0.0\n",
            "unreachable",
        ),
        (
            "rates.toml",
            "[trajectory]\nkind = \"trapezoid\"\n[rates]\npiezo_hz = 7000\n",
            "incompatible rates",
        ),
        (
            "syntax.toml",
            "[trajectory\nkind = 1\n",
            ".toml:1: unclosed table",
        ),
    ];
    for (name, text, expect) in cases {
        let p = scratch(name, text);
        let (ok, _, stderr) = sim(&["run", p.to_str().unwrap(), "--no-plots"]);
        assert!(!ok, "{name} must fail");
        let lines: Vec<&str> = stderr.lines().collect();
        assert_eq!(lines.len(), 1, "{name}: one line, got {stderr:?}");
        assert!(
            lines[0].starts_with("error: ") && lines[0].contains(expect),
            "{name}: {stderr}"
        );
        assert!(!stderr.contains("panicked"));
    }
    // Command-line overrides pass the same checks as the file.
    let path = format!("{}/scenarios/trapezoid.toml", env!("CARGO_MANIFEST_DIR"));
    for (args, expect) in [
        (
            &["--duration", "1"][..],
            "`tail_window`: 3 s is longer than `duration` = 1 s",
        ),
        (
            &["--motor-hz", "0.5", "--duration", "4"][..],
            "fewer than 10 motor periods",
        ),
        (&["--plant-dt", "1e-300"][..], "rates.plant_dt"),
        (&["--duration", "1e5"][..], "at most"),
    ] {
        let mut a = vec!["run", &path, "--no-plots"];
        a.extend_from_slice(args);
        let (ok, _, stderr) = sim(&a);
        assert!(
            !ok && stderr.contains("command-line options") && stderr.contains(expect),
            "{args:?}: {stderr}"
        );
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
    }
    let (ok, _, stderr) = sim(&["run", "/no/such/file.toml"]);
    assert!(
        !ok && stderr.starts_with("error: ") && stderr.lines().count() == 1,
        "{stderr}"
    );
}

#[test]
fn optimized_patch_flows_into_a_scenario() {
    let out = std::env::temp_dir().join(format!("flexarm-cli-opt-{}", std::process::id()));
    // A coarse grid, no sensitivity study: the flow is under test here, not the optimum.
    let config = scratch(
        "coarse.toml",
        "[optimize]\nstep = 0.05\nk_c = [10.0, 30.0, 100.0]\nrefine = false\n[sensitivity]\nenabled = false\n",
    );
    let (ok, stdout, stderr) = sim(&[
        "optimize",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-plots",
    ]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("x_a"), "{stdout}");
    let fragment = std::fs::read_to_string(out.join("piezo.toml")).unwrap();
    let text = format!(
        "name = \"optimized\"\nduration = 1.0\ntail_window = 0.5\n[trajectory]\nkind = \"trapezoid\"\n[controller]\npiezo = true\n\n{fragment}"
    );
    let scenario = scratch("optimized.toml", &text);
    let sc = flexarm_host::scenario::load(&scenario).unwrap();
    let x_a: f64 = fragment
        .lines()
        .find_map(|l| l.strip_prefix("x_a = "))
        .and_then(|v| v.split_whitespace().next())
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(
        sc.config.patch.x_a, x_a,
        "the scenario runs with the optimized patch"
    );
    let (ok, _, stderr) = sim(&[
        "run",
        scenario.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-plots",
    ]);
    assert!(ok, "{stderr}");
}

#[test]
fn firmware_params_writes_the_generated_file() {
    use flexarm_host::firmware_params::{Names, paper_fragment, render};
    let dir = std::env::temp_dir().join(format!("flexarm-cli-fw-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let root = format!("{}/..", env!("CARGO_MANIFEST_DIR"));
    let checked_in = std::fs::read_to_string(format!("{root}/firmware/src/generated.rs")).unwrap();
    // From the checked-in fragment: the checked-in file, up to the paths in its header.
    let fragment = format!("{root}/firmware/piezo.toml");
    let out = dir.join("generated.rs");
    let out_s = out.to_str().unwrap();
    let (ok, stdout, stderr) = sim(&["firmware-params", &fragment, "--out", out_s]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("Wrote"), "{stdout}");
    let written = std::fs::read_to_string(&out).unwrap();
    let text = std::fs::read_to_string(&fragment).unwrap();
    let names = Names {
        fragment: &fragment,
        out: out_s,
    };
    assert_eq!(written, render(&text, &names).unwrap());
    assert_eq!(
        written
            .replace(&fragment, "firmware/piezo.toml")
            .replace(out_s, "firmware/src/generated.rs"),
        checked_in
    );
    // --paper-fragment writes the paper's fragment first, then generates from it.
    let fresh = dir.join("piezo.toml");
    let out2 = dir.join("generated2.rs");
    let (ok, _, stderr) = sim(&[
        "firmware-params",
        fresh.to_str().unwrap(),
        "--paper-fragment",
        "--out",
        out2.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert_eq!(
        std::fs::read_to_string(&fresh).unwrap(),
        paper_fragment().unwrap()
    );
    assert!(
        std::fs::read_to_string(&out2)
            .unwrap()
            .contains("pub const K_C: f32 = 3e1;")
    );
}

#[test]
fn firmware_params_refuses_with_one_error_line() {
    let good = flexarm_host::firmware_params::paper_fragment().unwrap();
    let cases = [
        (
            "neg_kc.toml",
            good.replace("k_c = 30.0", "k_c = -1.0"),
            "`piezo.k_c` = -1 must be > 0",
        ),
        (
            "off.toml",
            good.replace("x_a = 0.09", "x_a = 0.6"),
            "must lie on link 2",
        ),
        (
            "unknown.toml",
            good.replace("[piezo]\n", "[piezo]\nspeed = 1\n"),
            "unknown field `speed`",
        ),
        (
            "controller.toml",
            format!("{good}\n[controller]\nk_c = 1.0\n"),
            "unknown field `controller`",
        ),
        ("syntax.toml", "[piezo\n".to_string(), "unclosed table"),
        (
            "homing.toml",
            format!("{good}\n[homing.joint2]\nmethod = \"switch\"\nspeed = 0.0\n"),
            "`homing.joint2.speed`: must not be 0",
        ),
    ];
    for (name, text, expect) in cases {
        assert_ne!(text, good, "{name}: the edit must change the fragment");
        let p = scratch(name, &text);
        let out = p.with_extension("rs");
        let (ok, _, stderr) = sim(&[
            "firmware-params",
            p.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(!ok, "{name} must fail");
        let lines: Vec<&str> = stderr.lines().collect();
        assert_eq!(lines.len(), 1, "{name}: one line, got {stderr:?}");
        assert!(
            lines[0].starts_with("error: ") && lines[0].contains(name) && lines[0].contains(expect),
            "{name}: {stderr}"
        );
        assert!(!out.exists(), "{name}: nothing written on error");
        // The line of the key it is about.
        for (file, key) in [("off.toml", "x_a"), ("homing.toml", "speed")] {
            if name == file {
                let line = text.lines().position(|l| l.starts_with(key)).unwrap() + 1;
                assert!(lines[0].contains(&format!("{file}:{line}: ")), "{stderr}");
            }
        }
    }
    let (ok, _, stderr) = sim(&[
        "firmware-params",
        "/no/such/piezo.toml",
        "--out",
        "/tmp/x.rs",
    ]);
    assert!(
        !ok && stderr.starts_with("error: cannot read /no/such/piezo.toml")
            && stderr.lines().count() == 1,
        "{stderr}"
    );
    // The exit status is 1, as for every other bad input.
    let status = Command::new(env!("CARGO_BIN_EXE_flexarm-sim"))
        .args(["firmware-params", "/no/such/piezo.toml"])
        .output()
        .unwrap()
        .status;
    assert_eq!(status.code(), Some(1));
}

fn fresh_dir(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("flexarm-cli-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn names_in(dir: &std::path::Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|r| {
            r.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

#[test]
fn output_stays_in_its_folder_and_never_replaces_a_foreign_file() {
    let out = fresh_dir("safety");
    let out_s = out.to_str().unwrap();
    // A scenario name that would leave the folder is refused, naming the key.
    for name in ["../escape", "/tmp/abs", "a/b", ".."] {
        let p = scratch(
            "escape.toml",
            &format!(
                "name = {name:?}\nduration = 0.5\ntail_window = 0.2\n[trajectory]\nkind = \"trapezoid\"\n"
            ),
        );
        let (ok, _, stderr) = sim(&["run", p.to_str().unwrap(), "--out", out_s, "--no-plots"]);
        assert!(!ok && stderr.contains("`name`"), "{name}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(!out.exists(), "{name}: nothing written");
    }
    let scenario = scratch(
        "safe.toml",
        "name = \"safe\"\nduration = 0.5\ntail_window = 0.2\n[trajectory]\nkind = \"trapezoid\"\n",
    );
    let sc = scenario.to_str().unwrap();
    // A file of the same name that flexarm did not write is left alone, and nothing else moves.
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("safe_scenario.csv"), "my data").unwrap();
    let (ok, _, stderr) = sim(&["run", sc, "--out", out_s]);
    assert!(!ok && stderr.contains("not written by flexarm"), "{stderr}");
    assert_eq!(
        std::fs::read_to_string(out.join("safe_scenario.csv")).unwrap(),
        "my data"
    );
    assert_eq!(names_in(&out), ["safe_scenario.csv"], "no partial output");
    // With --force it is replaced; then it is ours.
    let (ok, _, stderr) = sim(&["run", sc, "--out", out_s, "--force"]);
    assert!(ok, "{stderr}");
    assert_eq!(
        names_in(&out),
        [
            ".flexarm-outputs",
            "safe_indices.md",
            "safe_scenario.csv",
            "safe_scenario.svg"
        ]
    );
    // The same run without figures removes its stale figure; the study's files are kept.
    let (ok, _, stderr) = sim(&["paper", "--out", out_s, "--no-plots", "--duration", "3.5"]);
    assert!(ok, "{stderr}");
    let (ok, _, stderr) = sim(&["run", sc, "--out", out_s, "--no-plots"]);
    assert!(ok, "{stderr}");
    let names = names_in(&out);
    assert!(
        !names.contains(&"safe_scenario.svg".to_string()),
        "{names:?}"
    );
    assert!(names.contains(&"indices.md".to_string()), "{names:?}");
    assert!(
        names.contains(&"trapezoid_eq7.csv".to_string()),
        "{names:?}"
    );
    let study = std::fs::read_to_string(out.join("indices.md")).unwrap();
    assert!(study.matches("| trapezoid |").count() >= 5, "{study}");
    assert!(!names.iter().any(|n| n.starts_with(".flexarm-staging")));
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn firmware_params_never_overwrites_its_input_or_a_foreign_file() {
    let dir = fresh_dir("fw-safety");
    std::fs::create_dir_all(&dir).unwrap();
    let fragment = dir.join("piezo.toml");
    std::fs::write(
        &fragment,
        flexarm_host::firmware_params::paper_fragment().unwrap(),
    )
    .unwrap();
    let frag = fragment.to_str().unwrap();
    // The fragment as its own output.
    let before = std::fs::read_to_string(&fragment).unwrap();
    let (ok, _, stderr) = sim(&["firmware-params", frag, "--out", frag]);
    assert!(!ok && stderr.contains("is the fragment itself"), "{stderr}");
    assert_eq!(std::fs::read_to_string(&fragment).unwrap(), before);
    // An unrelated file as the output.
    let notes = dir.join("notes.rs");
    std::fs::write(&notes, "fn mine() {}\n").unwrap();
    let (ok, _, stderr) = sim(&["firmware-params", frag, "--out", notes.to_str().unwrap()]);
    assert!(
        !ok && stderr.contains("not generated by flexarm"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&notes).unwrap(), "fn mine() {}\n");
    // A generated file is replaced; --force replaces the unrelated one.
    let out = dir.join("generated.rs");
    for _ in 0..2 {
        let (ok, _, stderr) = sim(&["firmware-params", frag, "--out", out.to_str().unwrap()]);
        assert!(ok, "{stderr}");
    }
    let (ok, _, stderr) = sim(&[
        "firmware-params",
        frag,
        "--out",
        notes.to_str().unwrap(),
        "--force",
    ]);
    assert!(ok, "{stderr}");
    // --paper-fragment does not replace a fragment that flexarm did not write.
    let hand = dir.join("hand.toml");
    std::fs::write(&hand, "# my own notes\n").unwrap();
    let (ok, _, stderr) = sim(&[
        "firmware-params",
        hand.to_str().unwrap(),
        "--paper-fragment",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        !ok && stderr.contains("not generated by flexarm"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&hand).unwrap(), "# my own notes\n");
    assert!(!names_in(&dir).iter().any(|n| n.contains(".tmp-")));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn errors_name_the_file_the_line_and_the_key() {
    for (name, text, want) in [
        (
            "kc.toml",
            "name = \"x\"\n[trajectory]\nkind = \"trapezoid\"\n\n[controller]\npiezo = true\nk_c = 1e39\n",
            ":7: `controller.k_c`",
        ),
        (
            "radius.toml",
            "[trajectory]\nkind = \"circle\"\nradius = -0.2\n",
            ":3: `trajectory.radius`",
        ),
        (
            "arm.toml",
            "[trajectory]\nkind = \"trapezoid\"\n\n[arm]\nm1 = -2\n",
            ":5: `arm.m1`",
        ),
        (
            "ramp.toml",
            "[trajectory]\nkind = \"trapezoid\"\nmove_time = 1.0\nramp_time = 0.8\n",
            ":4: `trajectory.ramp_time`",
        ),
        (
            "syntax.toml",
            "[trajectory]\nkind = \"trapezoid\"\nmove_time = \n",
            ":3: ",
        ),
        (
            "modes.toml",
            "[trajectory]\nkind = \"trapezoid\"\n\n[plant]\nkind = \"truth\"\nmodes = 11\n",
            ":6: `plant.modes`",
        ),
        (
            "friction.toml",
            "[trajectory]\nkind = \"trapezoid\"\n\n[plant]\nkind = \"truth\"\ncoulomb = [0.1, nan]\n",
            ":6: `plant.coulomb`",
        ),
        (
            "window.toml",
            "[trajectory]\nkind = \"trapezoid\"\n\n[plant]\nkind = \"truth\"\n\namplifier_window = [10, 200]\n",
            ":7: `plant.amplifier_window`",
        ),
        (
            "model.toml",
            "[trajectory]\nkind = \"trapezoid\"\n\n[plant]\nkind = \"model\"\nmodes = 4\n",
            ":5: `plant.kind`",
        ),
        (
            "armlink.toml",
            "[trajectory]\nkind = \"trapezoid\"\n\n[plant]\nkind = \"truth\"\nlink = \"arm\"\nmodes = 6\n",
            ":7: `plant.modes`",
        ),
    ] {
        let p = scratch(name, text);
        let (ok, _, stderr) = sim(&["run", p.to_str().unwrap(), "--no-plots"]);
        let want = format!("error: {}{want}", p.display());
        assert!(
            !ok && stderr.starts_with(&want),
            "{name}: want {want:?}, got {stderr:?}"
        );
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
    }
}

#[test]
fn command_line_mistakes_are_one_line_and_exit_1() {
    for args in [
        &["run", "--durration", "3", "x.toml"][..],
        &["paper", "--duration", "abc"][..],
        &["frobnicate"][..],
        &["montecarlo", "--runs", "-3"][..],
        &["montecarlo", "--runs", "100000000000"][..],
        &["paper", "--modes", "4"][..],
        &["paper", "--plant", "truth", "--modes", "11"][..],
        &["paper", "--plant", "real"][..],
        &["montecarlo", "--plant", "truth", "--modes", "0"][..],
        &["spillover", "--modes", "1"][..],
        &["spillover", "--duration", "nan"][..],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_flexarm-sim"))
            .args(args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{args:?}: {stderr}");
        assert!(stderr.starts_with("error: "), "{stderr}");
    }
    let out = Command::new(env!("CARGO_BIN_EXE_flexarm-sim"))
        .arg("--help")
        .output()
        .unwrap();
    assert!(out.status.success() && String::from_utf8_lossy(&out.stdout).contains("paper"));
}

#[test]
fn every_command_line_value_is_refused_in_one_line_or_runs() {
    let path = format!("{}/scenarios/trapezoid.toml", env!("CARGO_MANIFEST_DIR"));
    let out = fresh_dir("values");
    let out_s = out.to_str().unwrap();
    for opt in ["--duration", "--plant-dt", "--motor-hz", "--piezo-hz"] {
        for v in ["nan", "inf", "-inf", "-1", "0", "1e-30", "1e30", "text", ""] {
            let arg = format!("{opt}={v}");
            let o = Command::new(env!("CARGO_BIN_EXE_flexarm-sim"))
                .args(["run", &path, "--no-plots", "--out", out_s, &arg])
                .output()
                .unwrap();
            let stderr = String::from_utf8_lossy(&o.stderr);
            match o.status.code() {
                Some(0) => {
                    let stdout = String::from_utf8_lossy(&o.stdout).to_lowercase();
                    assert!(
                        !stdout.contains("nan") && !stdout.contains("inf |"),
                        "{arg}: {stdout}"
                    );
                }
                Some(1) => {
                    assert_eq!(stderr.lines().count(), 1, "{arg}: {stderr}");
                    assert!(stderr.starts_with("error: "), "{arg}: {stderr}");
                }
                c => panic!("{arg}: exit status {c:?}: {stderr}"),
            }
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn the_truth_plant_from_the_command_line() {
    // `spillover` writes its report, table and figure; `run --plant truth` on a file that
    // already has a [plant] table is refused, on one without it runs on the truth plant.
    let out = fresh_dir("spillover");
    let (ok, stdout, stderr) = sim(&[
        "spillover",
        "--modes",
        "4",
        "--duration",
        "0.5",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("## 3. The design rule"), "{stdout}");
    assert_eq!(
        names_in(&out),
        [
            ".flexarm-outputs",
            "spillover.csv",
            "spillover.md",
            "spillover.svg"
        ]
    );
    let truth = format!(
        "{}/scenarios/trapezoid_truth.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let (ok, _, stderr) = sim(&["run", &truth, "--plant", "truth", "--no-plots"]);
    assert!(!ok && stderr.contains("drop --plant"), "{stderr}");
    let plain = format!("{}/scenarios/trapezoid.toml", env!("CARGO_MANIFEST_DIR"));
    let out = fresh_dir("run_truth");
    let (ok, stdout, stderr) = sim(&[
        "run",
        &plain,
        "--plant",
        "truth",
        "--modes",
        "3",
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("| trapezoid |"), "{stdout}");
}

/// `identify friction` from the command line: its five files (the record among them), the
/// report's table; the record read back (`--record`) gives the truth plant's friction within
/// the 10 %, as the experiment's own windows do; settings that cannot identify anything are one line, and nothing is written.
#[test]
fn identify_friction_writes_its_files_and_refuses_bad_settings() {
    let out = fresh_dir("identify");
    let o = out.to_str().unwrap();
    let (ok, stdout, stderr) = sim(&[
        "identify", "friction", "--plant", "truth", "--speeds", "0.2,0.5", "--cruise", "2",
        "--out", o,
    ]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("| joint | F_c [N·m] |"), "{stdout}");
    assert_eq!(
        names_in(&out),
        [
            ".flexarm-outputs",
            "friction.csv",
            "friction.md",
            "friction.svg",
            "friction.toml",
            "friction_record.csv"
        ]
    );
    // Four cruises per joint, both ways at each speed.
    let csv = std::fs::read_to_string(out.join("friction.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 8, "{csv}");
    let again = fresh_dir("identify-again");
    let record = out.join("friction_record.csv");
    let (ok, stdout2, stderr) = sim(&[
        "identify",
        "friction",
        "--record",
        record.to_str().unwrap(),
        "--no-plots",
        "--out",
        again.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert!(stdout2.contains("8 cruises found in it"), "{stdout2}");
    // F_c and F_v of each joint against the truth plant's drives (0.05 N·m, 0.02 N·m·s/rad).
    let fits = |s: &str| -> Vec<f64> {
        s.lines()
            .filter(|l| l.starts_with("| 1 |") || l.starts_with("| 2 |"))
            .flat_map(|l| {
                l.split('|')
                    .skip(2)
                    .take(2)
                    .map(|c| c.trim().parse::<f64>().unwrap())
                    .collect::<Vec<_>>()
            })
            .collect()
    };
    let (a, b) = (fits(&stdout), fits(&stdout2));
    assert_eq!((a.len(), b.len()), (4, 4), "{stdout2}");
    for fit in [&a, &b] {
        for (x, t) in fit.iter().zip([0.05, 0.02, 0.05, 0.02]) {
            assert!((x / t - 1.0).abs() < 0.1, "{a:?}, from the record {b:?}");
        }
    }
    for (args, needle) in [
        (
            ["--speeds", "0.2,-1", "--cruise", "2"],
            "each in (0, 3] rad/s",
        ),
        (
            ["--speeds", "0.2,0.5", "--cruise", "0.1"],
            "give at least 0.5 s",
        ),
        (
            ["--speeds", "0.2,0.21", "--cruise", "0.5"],
            "cannot be told apart",
        ),
    ] {
        let bad = fresh_dir("identify-bad");
        let (ok, _, stderr) = sim(&[
            &["identify", "friction", "--out", bad.to_str().unwrap()][..],
            &args[..],
        ]
        .concat());
        assert!(!ok && stderr.lines().count() == 1, "{stderr}");
        assert!(stderr.contains(needle), "{stderr}");
        assert!(
            !bad.exists() || names_in(&bad).is_empty(),
            "wrote {:?}",
            names_in(&bad)
        );
    }
}

/// `identify modes` runs the experiment (its record saved), then fits its own record again
/// through `--record` to the same table; a recording that is not a trace, or too short (1.5 s:
/// the held arm's first mode, 4.6 Hz, needs 4 s), is one line naming the file, and nothing is
/// written.
#[test]
fn identify_modes_fits_a_run_or_a_recording() {
    let out = fresh_dir("identify-modes");
    let o = out.to_str().unwrap();
    let (ok, stdout, stderr) = sim(&[
        "identify",
        "modes",
        "--plant",
        "truth",
        "--seconds",
        "20",
        "--no-plots",
        "--out",
        o,
    ]);
    assert!(ok, "{stderr}");
    assert_eq!(
        names_in(&out),
        [
            ".flexarm-outputs",
            "modes.md",
            "modes_frf.csv",
            "modes_record.csv",
            "modes_stability.csv"
        ]
    );
    // The modes' table (its figures with their spreads), not the errors' below it.
    let table = |s: &str| {
        s.lines()
            .filter(|l| (l.starts_with("| 1 |") || l.starts_with("| 2 |")) && l.contains(" ± "))
            .map(String::from)
            .collect::<Vec<_>>()
    };
    assert_eq!(table(&stdout).len(), 2, "{stdout}");
    let again = fresh_dir("identify-modes-again");
    let record = out.join("modes_record.csv");
    let (ok, stdout2, stderr) = sim(&[
        "identify",
        "modes",
        "--plant",
        "truth",
        "--record",
        record.to_str().unwrap(),
        "--no-plots",
        "--out",
        again.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    // The CSV's rounding moves the fit in the last digits only.
    let freq = |rows: Vec<String>| -> Vec<f64> {
        rows.iter()
            .map(|r| {
                let cell = r.split('|').nth(2).unwrap();
                cell.split_whitespace().next().unwrap().parse().unwrap()
            })
            .collect()
    };
    for (a, b) in freq(table(&stdout)).iter().zip(freq(table(&stdout2))) {
        assert!((a - b).abs() < 0.01 * a, "{a} Hz refitted as {b} Hz");
    }
    let short = scratch(
        "short_record.csv",
        &std::fs::read_to_string(&record)
            .unwrap()
            .lines()
            .take(1500)
            .collect::<Vec<_>>()
            .join("\n"),
    );
    let not_trace = scratch("not_a_trace.csv", "a,b\n1,2\n");
    for (file, needle) in [
        (&short, "gate `record length`: a record of 1.5 s"),
        (&not_trace, "not a flexarm trace"),
    ] {
        let bad = fresh_dir("identify-modes-bad");
        let (ok, _, stderr) = sim(&[
            "identify",
            "modes",
            "--record",
            file.to_str().unwrap(),
            "--out",
            bad.to_str().unwrap(),
        ]);
        assert!(!ok && stderr.lines().count() == 1, "{stderr}");
        assert!(
            stderr.contains(needle) && stderr.contains(file.file_name().unwrap().to_str().unwrap()),
            "{stderr}"
        );
        assert!(
            !bad.exists() || names_in(&bad).is_empty(),
            "wrote {:?}",
            names_in(&bad)
        );
    }
}

/// `identify model` needs both records, and the records' options belong to it alone: one line
/// each, nothing written.
#[test]
fn identify_model_asks_for_both_records() {
    for (args, needle) in [
        (
            &["identify", "model"][..],
            "give both --modes-record and --inertia-record",
        ),
        (
            &["identify", "modes", "--modes-record", "x.csv"][..],
            "are for `identify model`",
        ),
    ] {
        let bad = fresh_dir("identify-model-bad");
        let (ok, _, stderr) = sim(&[args, &["--out", bad.to_str().unwrap()][..]].concat());
        assert!(!ok && stderr.lines().count() == 1, "{stderr}");
        assert!(stderr.contains(needle), "{stderr}");
        assert!(
            !bad.exists() || names_in(&bad).is_empty(),
            "wrote {:?}",
            names_in(&bad)
        );
    }
}

/// `identify decay` runs the experiment and checks a model file's prediction with the
/// nominal model's; a bad model file is one line naming the file, the line and the key, and
/// `--model` belongs to `decay` alone; nothing is written on an error.
#[test]
fn identify_decay_checks_a_model_file() {
    let out = fresh_dir("identify-decay");
    // The folder already holds the modes step's files: each experiment's files are its own,
    // and another's run leaves them (docs/identification.md's steps share `out/identify`).
    let (ok, _, stderr) = sim(&[
        "identify",
        "modes",
        "--seconds",
        "20",
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    let model = scratch(
        "decay_model.toml",
        &flexarm_host::identify::model::model_fragment(
            &flexarm_core::params::ArmParams::default(),
            &flexarm_core::control::piezo::PiezoPatch::paper(),
            3.162,
        ),
    );
    let (ok, stdout, stderr) = sim(&[
        "identify",
        "decay",
        "--model",
        model.to_str().unwrap(),
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert_eq!(
        names_in(&out),
        [
            ".flexarm-outputs",
            "decay.csv",
            "decay.md",
            "decay_record.csv",
            "modes.md",
            "modes_frf.csv",
            "modes_record.csv",
            "modes_stability.csv"
        ]
    );
    // The plant is the paper's model: the model file (the same arm) predicts it as the
    // nominal model does, to the fit's last digits.
    let row = |name: &str| {
        stdout
            .lines()
            .find(|l| l.starts_with(&format!("| {name} |")))
            .map(|l| {
                l.split('|')
                    .skip(2)
                    .take(4)
                    .map(str::trim)
                    .map(String::from)
                    .collect::<Vec<_>>()
            })
    };
    let (file, nominal) = (row("model file"), row("nominal model"));
    assert!(file.is_some() && file == nominal, "{stdout}");
    let bad_model = scratch(
        "bad_model.toml",
        &std::fs::read_to_string(&model)
            .unwrap()
            .replace("m2 = 3e-1", "m2 = -3e-1"),
    );
    let line = std::fs::read_to_string(&bad_model)
        .unwrap()
        .lines()
        .position(|l| l.starts_with("m2 ="))
        .unwrap()
        + 1;
    for (args, needle) in [
        (
            vec!["identify", "decay", "--model", bad_model.to_str().unwrap()],
            format!("bad_model.toml:{line}: "),
        ),
        (
            vec!["identify", "modes", "--model", model.to_str().unwrap()],
            "--model is for `identify decay`".to_string(),
        ),
    ] {
        let bad = fresh_dir("identify-decay-bad");
        let (ok, _, stderr) = sim(&[&args[..], &["--out", bad.to_str().unwrap()][..]].concat());
        assert!(!ok && stderr.lines().count() == 1, "{stderr}");
        assert!(stderr.contains(&needle), "{needle} not in {stderr}");
        assert!(
            !bad.exists() || names_in(&bad).is_empty(),
            "wrote {:?}",
            names_in(&bad)
        );
    }
}

/// `identify decay --record` on a lab's record tapped by joint 2's motor (the light arm of
/// the family, `flexarm_host::lab`): the report says what the record held (five torque pulses
/// 20 s apart, not the plan's ten taps of the patch), lists every mode the pencil found, and
/// says how the models were tapped instead.
#[test]
fn identify_decay_reads_a_torque_tapped_record() {
    use flexarm_host::identify::family::{Kind, family};
    let arm = family().into_iter().find(|a| a.name == "light").unwrap();
    let bench = arm.bench().unwrap();
    let plan = flexarm_host::lab::sized(&Kind::TorqueTaps.plan(&bench), 0.4).unwrap();
    let record = scratch(
        "torque_taps.csv",
        &flexarm_host::output::trace_csv(&flexarm_host::lab::record(&plan).unwrap()),
    );
    let out = fresh_dir("identify-decay-torque");
    let (ok, stdout, stderr) = sim(&[
        "identify",
        "decay",
        "--record",
        record.to_str().unwrap(),
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("The record held 5 torque pulses on joint 2")
            && stdout.contains("20.00 s apart")
            && stdout.contains("the record's taps are not the patch's"),
        "{stdout}"
    );
    let measured = stdout
        .lines()
        .find(|l| l.starts_with("| measured |"))
        .unwrap();
    let head = stdout.lines().find(|l| l.contains("f1 [Hz]")).unwrap();
    let modes = measured.split('|').count() - 4;
    assert!(modes >= 4 && modes % 2 == 0, "{measured}");
    assert!(head.contains(&format!("f{} [Hz]", modes / 2)), "{head}");
    assert_eq!(
        names_in(&out),
        [".flexarm-outputs", "decay.csv", "decay.md"]
    );
}

/// Bad records through the command line: the film at its ADC's range, the patch's command at
/// the amplifier's window, a torque at its drive's limit (each on a bench whose board clips it,
/// the geometry file saying so), a trace without its film column: each refused in one line
/// that names the file and the gate, exit status 1, nothing written.
#[test]
fn identify_refuses_clipped_records_and_missing_channels() {
    use flexarm_host::identify::family::{Kind, family};
    use flexarm_host::lab::Shape;
    let arm = family().into_iter().find(|a| a.name == "light").unwrap();
    // Ten seconds of noise on the patch (100 V) and on joint 2 (2 N·m) on `bench`.
    let record = |name: &str, bench: flexarm_host::sim::SimConfig| {
        let mut plan = Kind::Random.plan(&bench);
        for e in &mut plan.excite {
            if let Shape::Random { seconds, .. } = &mut e.shape {
                *seconds = 10.0;
            }
        }
        let trace = flexarm_host::lab::record(&plan).unwrap();
        scratch(name, &flexarm_host::output::trace_csv(&trace))
    };
    let mut film = arm.bench().unwrap();
    film.sensors.adc_range = 0.05;
    let mut window = arm.bench().unwrap();
    (window.limits.v_a_min, window.limits.v_a_max) = (-30.0, 30.0);
    let mut torque = arm.bench().unwrap();
    torque.limits.tau_max = flexarm_core::Vector2::new(0.5, 0.5);
    let clipped_film = record("clipped_film.csv", film);
    let no_film = scratch(
        "no_film.csv",
        &std::fs::read_to_string(&clipped_film)
            .unwrap()
            .lines()
            .map(|l| l.rsplit_once(',').unwrap().0.to_string() + "\n")
            .collect::<String>(),
    );
    let cases = [
        (
            "modes",
            clipped_film,
            "[board]\nfilm_range = 0.05\n",
            "gate `clipping`: `v_f` is clipped",
        ),
        (
            "modes",
            record("clipped_patch.csv", window),
            "[board]\namplifier_window = [-30.0, 30.0]\n",
            "gate `clipping`: `v_a` is clipped",
        ),
        (
            "inertia",
            record("saturated_torque.csv", torque),
            "[board]\ntorque_limit = [0.5, 0.5]\n",
            "gate `clipping`: `tau2` is saturated",
        ),
        (
            "decay",
            no_film,
            "",
            ":1: gate `channels`: the column(s) `v_f_V` missing",
        ),
    ];
    for (step, file, board, needle) in cases {
        let geometry = scratch("board.toml", board);
        let bad = fresh_dir("identify-clipped");
        let out = Command::new(env!("CARGO_BIN_EXE_flexarm-sim"))
            .args([
                "identify",
                step,
                "--record",
                file.to_str().unwrap(),
                "--arm",
                geometry.to_str().unwrap(),
                "--out",
                bad.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{step}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(
            stderr.contains(needle) && stderr.contains(file.file_name().unwrap().to_str().unwrap()),
            "{needle} not in {stderr}"
        );
        assert!(
            !bad.exists() || names_in(&bad).is_empty(),
            "wrote {:?}",
            names_in(&bad)
        );
    }
}

/// Runs `args` with `{}` replaced by a scratch file of `text`; the error's first words.
fn refusal(name: &str, text: &str, args: &[&str]) -> String {
    let p = scratch(name, text);
    let path = p.to_str().unwrap();
    let args: Vec<&str> = args
        .iter()
        .map(|a| if *a == "{}" { path } else { a })
        .collect();
    let (ok, _, stderr) = sim(&args);
    assert!(!ok, "{name} must be refused");
    assert_eq!(stderr.lines().count(), 1, "{name}: {stderr}");
    stderr.replace(&format!("error: {path}"), "error: FILE")
}

#[test]
fn every_toml_reader_names_the_line_and_the_key() {
    let run = ["run", "{}", "--no-plots"];
    let optimize = ["optimize", "{}", "--no-plots", "--out", "/nonexistent/o"];
    let fragment = flexarm_host::firmware_params::paper_fragment().unwrap();
    let computed = fragment.replace("modes = \"paper\"", "modes = \"computed\"");
    // The computed modes with a mass integral that is not a number.
    let nan = computed
        .lines()
        .map(|l| match l.starts_with("mass_integral") {
            true => "mass_integral = [nan, 0.1]",
            false => l,
        })
        .collect::<Vec<_>>()
        .join("\n");
    let model = |arm: &str| format!("[arm]\n{arm}\n{fragment}");
    let trapezoid = "[trajectory]\nkind = \"trapezoid\"\n";
    let cases: Vec<(&str, String, &[&str], &str)> = vec![
        // A span that starts a line (column 0) is that line's, and its key.
        (
            "duplicate.toml",
            format!("{trapezoid}move_time = 2.0\nmove_time = 3.0\n"),
            &run,
            "FILE:4: `trajectory.move_time`: duplicate key",
        ),
        (
            "column0.toml",
            format!("name = \"x\"\nbogus = 1\n{trapezoid}"),
            &run,
            "FILE:2: `bogus`: unknown field `bogus`",
        ),
        (
            "no_table.toml",
            "name = \"x\"\nduration = 3.0\n".into(),
            &run,
            "FILE:1: `trajectory`: missing field `trajectory`",
        ),
        (
            "plant_key.toml",
            format!("{trapezoid}[plant]\nkind = \"truth\"\nfoo = 1\n"),
            &run,
            "FILE:5: `plant.foo`: unknown field `foo`",
        ),
        (
            "plant_kind.toml",
            format!("{trapezoid}\n[plant]\nmodes = 3\n"),
            &run,
            "FILE:4: `plant.kind`: missing field `kind`",
        ),
        (
            "optimize_key.toml",
            "[beam]\nlength = 0.7\n[optimize]\nstep = 0.05\nbogus = 1\n".into(),
            &optimize,
            "FILE:5: `optimize.bogus`: unknown field `bogus`",
        ),
        // An element names its own line.
        (
            "indexed.toml",
            "[optimize]\nk_c = [\n  10.0,\n  1e-9,\n]\n".into(),
            &optimize,
            "FILE:4: `optimize.k_c[1]` = 1e-9 must lie in",
        ),
        (
            "indexed_type.toml",
            "[optimize]\nk_c = [\n  \"ten\",\n]\n".into(),
            &optimize,
            "FILE:3: `optimize.k_c[0]`: invalid type",
        ),
        // Checks after parsing: the line and the whole key path.
        (
            "plant_dt.toml",
            format!("{trapezoid}\n[rates]\nplant_dt = 1e-9\n"),
            &run,
            "FILE:5: `rates.plant_dt`: ",
        ),
        (
            "zeta.toml",
            format!("{trapezoid}[plant]\nkind = \"truth\"\nzeta = [0.1, 2.0]\n"),
            &run,
            "FILE:5: `plant.zeta`: 2 is outside 0 to 1",
        ),
        (
            "arm_zeta.toml",
            model("zeta = [0.1, 7]"),
            &[
                "identify",
                "decay",
                "--model",
                "{}",
                "--out",
                "/nonexistent/i",
            ],
            "FILE:2: `arm.zeta[1]` = 7 is outside 0 to 1",
        ),
        // A default that fails: the key the file writes that it fails against.
        (
            "default.toml",
            format!("{trapezoid}move_time = 0.8\n"),
            &run,
            "FILE:3: `trajectory.ramp_time` = 0.5 s must be at most half the `move_time`",
        ),
        (
            "default_lambda.toml",
            "# one mode\n[beam]\nzeta = [0.1]\n".into(),
            &optimize,
            "FILE:3: `optimize.lambda` has 2 weights but `beam.zeta` keeps 1",
        ),
        // A 300-digit number is shown short.
        (
            "digits.toml",
            format!("{trapezoid}move_time = 1{}.0\n", "0".repeat(300)),
            &run,
            "FILE:3: `trajectory.move_time` = 1e300 s is outside",
        ),
    ];
    for (name, text, args, want) in cases {
        let got = refusal(name, &text, args);
        assert!(
            got.starts_with(&format!("error: {want}")),
            "{name}: want {want:?}, got {got:?}"
        );
        assert!(got.len() < 400, "{name}: {got}");
    }
    // The mass integral's line, in the fragment as written.
    let text = nan;
    let line = text
        .lines()
        .position(|l| l.starts_with("mass_integral"))
        .unwrap()
        + 1;
    let got = refusal(
        "mass_integral.toml",
        &text,
        &["firmware-params", "{}", "--out", "/nonexistent/g.rs"],
    );
    let want =
        format!("error: FILE:{line}: `piezo.computed.mass_integral`: must be a finite number");
    assert!(got.starts_with(&want), "{got}");
}

#[test]
fn fixed_length_lists_refuse_extra_values_like_missing_ones() {
    let trapezoid = "[trajectory]\nkind = \"trapezoid\"\n";
    let fragment = flexarm_host::firmware_params::paper_fragment().unwrap();
    let run = ["run", "{}", "--no-plots"];
    let model = [
        "identify",
        "decay",
        "--model",
        "{}",
        "--out",
        "/nonexistent/i",
    ];
    for (name, text, args, want) in [
        (
            "kp.toml",
            format!("{trapezoid}[controller]\nkp = [90, 14, 0, 0, 12345]\n"),
            &run[..],
            "FILE:4: `controller.kp`: invalid length 5, expected exactly 4 values",
        ),
        (
            "kp3.toml",
            format!("{trapezoid}[controller]\nkp = [90, 14, 0]\n"),
            &run[..],
            "FILE:4: `controller.kp`: invalid length 3, expected exactly 4 values",
        ),
        (
            "start.toml",
            format!("{trapezoid}start = [0, 0, 7]\n"),
            &run[..],
            "FILE:3: `trajectory.start`: invalid length 3, expected exactly 2 values",
        ),
        (
            "frequency.toml",
            format!("[arm]\nfrequency_hz = [4, 10, 30]\n{fragment}"),
            &model[..],
            "FILE:2: `arm.frequency_hz`: invalid length 3, expected exactly 2 values",
        ),
        (
            "slope.toml",
            fragment.replacen("slope_diff = [", "slope_diff = [1.0, ", 1),
            &model[..],
            "`piezo.slope_diff`: invalid length 3, expected exactly 2 values",
        ),
    ] {
        let got = refusal(name, &text, args);
        assert!(got.contains(want), "{name}: want {want:?}, got {got:?}");
    }
}

#[test]
fn a_pose_outside_the_observers_range_is_refused_up_front() {
    // The observer's controller refuses a measurement outside its encoder range: a hold (or a
    // move's end) there would end at t = 0 with no file or key.
    let observer = "[controller]\nstate = \"observer\"\n";
    for (name, trajectory, want) in [
        (
            "hold.toml",
            "kind = \"hold\"\nangles = [3.5, 0.0]\n",
            "FILE:5: `trajectory.angles[0]`: joint 1 at 3.5 rad is outside -3.14159265 to 3.14159265 rad",
        ),
        (
            "end.toml",
            "kind = \"trapezoid\"\nstart = [0.0, 1.0]\namplitude = [0.0, 2.0]\n",
            "FILE:6: `trajectory.amplitude[1]`: joint 2 at 3 rad is outside -2.8 to 2.8 rad",
        ),
    ] {
        let text = format!("{observer}[trajectory]\n{trajectory}");
        let got = refusal(name, &text, &["run", "{}", "--no-plots"]);
        assert!(got.starts_with(&format!("error: {want}")), "{name}: {got}");
    }
}

#[test]
fn parallel_runs_into_one_folder_keep_every_manifest_entry() {
    let out = fresh_dir("parallel");
    let out_s = out.to_str().unwrap();
    let files: Vec<_> = (0..6)
        .map(|i| {
            scratch(
                &format!("parallel{i}.toml"),
                &format!(
                    "name = \"p{i}\"\nduration = 0.2\ntail_window = 0.1\n[trajectory]\nkind = \"hold\"\nangles = [0.0, 0.5]\n"
                ),
            )
        })
        .collect();
    // Started together, they finish together.
    let children: Vec<_> = files
        .iter()
        .map(|p| {
            Command::new(env!("CARGO_BIN_EXE_flexarm-sim"))
                .args(["run", p.to_str().unwrap(), "--out", out_s, "--no-plots"])
                .stdout(std::process::Stdio::null())
                .spawn()
                .unwrap()
        })
        .collect();
    for mut c in children {
        assert!(c.wait().unwrap().success());
    }
    let manifest = std::fs::read_to_string(out.join(".flexarm-outputs")).unwrap();
    for i in 0..6 {
        for file in [format!("p{i}_indices.md"), format!("p{i}_scenario.csv")] {
            assert!(
                manifest.contains(&format!("run:p{i}\t{file}\n")),
                "{file} lost: {manifest}"
            );
            assert!(out.join(&file).exists(), "{file}");
        }
    }
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn a_failed_command_leaves_no_output_folder_and_names_the_users_path() {
    let out = fresh_dir("failed");
    let (ok, _, stderr) = sim(&[
        "optimize",
        "/nonexistent/optimize.toml",
        "--out",
        out.join("optimize").to_str().unwrap(),
    ]);
    assert!(!ok && stderr.contains("cannot read"), "{stderr}");
    assert!(!out.exists(), "no empty folder left: {:?}", names_in(&out));
    // `--out` in a folder that does not exist: the error names that path.
    let target = out.join("nodir").join("g.rs");
    let fragment = format!("{}/../firmware/piezo.toml", env!("CARGO_MANIFEST_DIR"));
    let (ok, _, stderr) = sim(&[
        "firmware-params",
        &fragment,
        "--out",
        target.to_str().unwrap(),
    ]);
    assert!(
        !ok && stderr.starts_with(&format!("error: cannot write {}: ", target.display())),
        "{stderr}"
    );
    assert!(!stderr.contains(".tmp-"), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
}

#[test]
fn a_study_too_large_to_hold_is_refused_up_front() {
    // 24 runs of 1e6 samples (3.5 GB): refused before any runs, with the size and the bound.
    let out = fresh_dir("study-size");
    let (ok, _, stderr) = sim(&[
        "paper",
        "--plant",
        "truth",
        "--modes",
        "7",
        "--duration",
        "1000",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!ok, "{stderr}");
    assert!(
        stderr.contains("`duration`: 24 runs would hold 2.400e7 motor samples together")
            && stderr.contains("a study holds at most 2e6"),
        "{stderr}"
    );
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(!out.exists());
}

#[test]
fn a_coarse_plant_step_names_the_step_it_needs() {
    // Ten modes at 1 ms: the truth link's fastest mode diverges under RK4. Refused before the
    // runs step, with the step to give, not "the plant state diverged".
    let (ok, _, stderr) = sim(&[
        "paper",
        "--plant",
        "truth",
        "--modes",
        "10",
        "--plant-dt",
        "1e-3",
        "--piezo-hz",
        "1000",
        "--out",
        fresh_dir("coarse").to_str().unwrap(),
    ]);
    assert!(!ok && stderr.lines().count() == 1, "{stderr}");
    assert!(
        stderr.contains("`rates.plant_dt`: 1e-3 s is too coarse for this plant")
            && !stderr.contains("diverged ("),
        "{stderr}"
    );
    let give: f64 = stderr
        .split("give --plant-dt (`rates.plant_dt`) ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or(f64::NAN);
    assert!(give > 1e-4 && give < 1e-3, "{stderr}");
}

/// `--band LOW,HIGH` and `--keep M,N` are one word each, as their help says (issue 32: with
/// `num_args = 2` clap wanted two words and refused `--band 0.3,40`); another count is named.
#[test]
fn band_and_keep_take_one_comma_separated_pair() {
    let missing = "/flexarm-no-such-record.csv";
    let out = std::env::temp_dir().join(format!("flexarm-band-{}", std::process::id()));
    let out = out.to_string_lossy();
    for args in [
        &["identify", "decay", "--band", "0.3,40"][..],
        &["identify", "modes", "--band", "1,30", "--keep", "1,3"],
    ] {
        let (ok, _, err) = sim(&[args, &["--record", missing, "--out", &out]].concat());
        assert!(!ok && err.contains(missing), "{args:?}: {err}");
    }
    let (ok, _, err) = sim(&["identify", "modes", "--band", "1,2,3", "--record", missing]);
    assert!(
        !ok && err.contains("--band: give LOW,HIGH in Hz, not 3 value(s)"),
        "{err}"
    );
    let (ok, _, err) = sim(&["identify", "modes", "--keep", "2", "--record", missing]);
    assert!(
        !ok && err.contains("--keep: give two mode numbers"),
        "{err}"
    );
}
