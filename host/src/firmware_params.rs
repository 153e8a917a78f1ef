//! `flexarm-sim firmware-params`: the firmware's generated parameters from a model file.
//!
//! The firmware runs the arm model, piezo patch and gain of a model file: the `[piezo]`
//! fragment `firmware/piezo.toml` (the paper's arm and patch, or the optimizer's patch), or the
//! `model.toml` that `cargo sim identify` writes (an `[arm]` table and a `[piezo]` table with
//! the identified `[piezo.computed]` modes, `docs/identification.md`). [`render`] reads it
//! ([`crate::scenario::read_model`]: the readers `flexarm-sim run` uses), refuses what the
//! firmware cannot run, designs the observer gain for that arm and the patch's film map
//! `c_f = k_s Δφ'` at the two motor periods the firmware has (0.001 s on the hardware board,
//! 0.01 s under QEMU) and returns the Rust source of `firmware/src/generated.rs`: the model,
//! and each board's whole configuration (`flexarm_machine::BoardConfig::for_board`, the same
//! function the host runs on the same model: [`FirmwareParams::board`]) with its hash, so the
//! firmware computes neither.
//!
//! The joints' homing: the file's `[homing]` ([`crate::board_homing`]; none: both joints by
//! their index marks at 0 rad), in both boards' configurations.
//!
//! The arm: the file's `[arm]` (the paper's values where it has none), with the modes of
//! `[piezo.computed]` when `piezo.modes = "computed"`, else the paper's frequencies on the
//! uniform link's shapes. The QEMU board's simulated arm stays the paper's arm whatever the
//! model (it plays the physical arm the model describes); the file also carries the patch's
//! slope differences on it ([`qemu_slope_diff`]).
//!
//! What the firmware cannot run, refused with a readable error:
//! - anything `read_model` refuses (syntax, unknown table or key, values out of range, patch
//!   off link 2, non-positive `k_c`, `k_a`, `k_s`, inconsistent derived keys, modes out of
//!   order);
//! - a patch that leaves link 2 once rounded to `f32` (the firmware validates it in `f32` and
//!   would start in the safe state), or values that are not finite in `f32`;
//! - a patch that does not fit on the QEMU board's link 2 (the paper's, 0.7 m);
//! - an observer design that fails, or whose constant gain does not give contracting error
//!   dynamics over the arm's range `θ2 ∈ [−3, 3] rad`.
//!
//! The piezo gain follows `flexarm-sim run`: with `modes = "paper"`, `k_c_paper_modes` when the
//! fragment has it (the gain that gives the paper's mode 1 the damping ratio the optimized `k_c`
//! gives the design beam), else `k_c` ([`flexarm_beam::fragment::PiezoChoice::controller_k_c`]).

use std::fmt::{self, Write as _};

use flexarm_beam::design::{DesignModel, Weights};
use flexarm_beam::fragment::{ModesChoice, PiezoChoice, piezo_fragment};
use flexarm_beam::point::evaluate;
use flexarm_core::Vector2;
use flexarm_core::control::piezo::{PiezoGains, PiezoPatch};
use flexarm_core::model::Model;
use flexarm_core::observer::{self, Gain, NoiseModel, film_map};
use flexarm_core::observer_gains::THETA_NOMINAL;
use flexarm_core::params::ArmParams;
use flexarm_core::tuning::{RATE_CEILING_ROWS, RateCeiling};
use flexarm_link::msg::Board;
use flexarm_machine::BoardConfig;

use crate::spillover::{ModalLink, PiezoLoop, gain_margin};
use crate::spillover_study::realistic;
use crate::truth_plant::TruthSpec;

/// The fragment the firmware is built from, relative to the repository root.
pub const DEFAULT_FRAGMENT: &str = "firmware/piezo.toml";
/// The generated file, relative to the repository root.
pub const DEFAULT_OUT: &str = "firmware/src/generated.rs";

/// Motor periods the gains are designed for [s], with the names of their tables: the hardware
/// board's 1 kHz motor loop and the QEMU board's 100 Hz.
pub const PERIODS: [(&str, f64); 2] = [("GAIN_1KHZ", 1e-3), ("GAIN_100HZ", 1e-2)];

/// Why the fragment cannot be turned into firmware parameters (one readable line).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error(pub String);

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Error {}

/// Where the generated file says it came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Names<'a> {
    /// The fragment, as given on the command line.
    pub fragment: &'a str,
    /// The generated file, as given on the command line.
    pub out: &'a str,
}

impl Default for Names<'static> {
    fn default() -> Self {
        Self {
            fragment: DEFAULT_FRAGMENT,
            out: DEFAULT_OUT,
        }
    }
}

/// What the firmware runs, in `f64` as designed (the generated file rounds to `f32`).
#[derive(Clone, Debug, PartialEq)]
pub struct FirmwareParams {
    /// The fragment as read.
    pub choice: PiezoChoice,
    /// The controller's model of the arm.
    pub arm: ArmParams<f64>,
    /// The patch on that arm's modes.
    pub patch: PiezoPatch<f64>,
    /// The patch's slope differences `Δφ'_j` on the QEMU board's simulated arm.
    pub qemu_slope_diff: Vector2<f64>,
    /// The piezo gain the controller uses [s].
    pub k_c: f64,
    /// Observer gains, one per entry of [`PERIODS`].
    pub gains: [Gain<f64>; 2],
    /// The rate law's gain ceiling on the hardware board and on the QEMU board
    /// ([`rate_ceilings`]).
    pub ceilings: [RateCeiling<f32>; 2],
    /// How the joints home: the source's `[homing]` ([`crate::board_homing`]), both boards.
    pub homing: flexarm_core::homing::Config<f32>,
}

impl FirmwareParams {
    /// The configuration `board` boots with, in the firmware's `f32` (the generated file's
    /// `HARDWARE` or `QEMU`, bit for bit).
    pub fn board(&self, board: Board) -> BoardConfig {
        let period = match board {
            Board::Hardware => 0,
            Board::Qemu => 1,
        };
        let g = &self.gains[period];
        let mut c = BoardConfig::for_board(
            board,
            self.arm.cast::<f32>(),
            self.patch.to_f32(),
            self.k_c as f32,
            interned(self.ceilings[period]),
            core::array::from_fn(|i| core::array::from_fn(|j| g[(i, j)] as f32)),
        );
        c.homing = self.homing;
        c
    }
}

/// The configuration `board` boots with when the firmware is built from the paper's fragment
/// (the default `firmware/piezo.toml`): the generated file's `HARDWARE` or `QEMU`, bit for bit.
pub fn paper_board(board: Board) -> Result<BoardConfig, Error> {
    Ok(design(&paper_fragment()?)?.board(board))
}

/// Reads `fragment_text`, checks that the firmware can run it and designs the observer gains.
pub fn design(fragment_text: &str) -> Result<FirmwareParams, Error> {
    let (arm, choice) =
        crate::scenario::read_model(fragment_text).map_err(|e| Error(one_line(&e.0)))?;
    let homing = crate::board_homing::read(fragment_text).map_err(Error)?;
    let patch = choice.patch;
    let k_c = choice.controller_k_c();
    // The firmware validates the patch in f32 (Controller::new); refuse here what it would
    // latch as an invalid configuration at boot.
    let p32 = patch.to_f32();
    let a32 = arm.cast::<f32>();
    a32.validate().map_err(|e| {
        Error(format!(
            "rounded to f32 the arm fails the firmware's check: {e}"
        ))
    })?;
    // (name, value in f32, must stay > 0 once rounded)
    let values = [
        ("x_a", p32.x_a, false),
        ("l_a", p32.l_a, true),
        ("k_a", p32.k_a, true),
        ("k_s", p32.k_s, true),
        ("slope_diff[0]", p32.slope_diff.x, false),
        ("slope_diff[1]", p32.slope_diff.y, false),
        ("k_c", k_c as f32, true),
    ];
    for (name, v, positive) in values {
        if !v.is_finite() || (positive && v <= 0.0) {
            return Err(Error(format!(
                "`piezo.{name}` is {v} in f32: the firmware cannot use it"
            )));
        }
    }
    p32.validate(a32.a2).map_err(|e| {
        Error(format!(
            "rounded to f32 the patch [{}, {} + {}] m fails the firmware's check: {e}",
            p32.x_a, p32.x_a, p32.l_a
        ))
    })?;

    let qemu_slope_diff = qemu_slope_diff(&patch)?;
    let model = Model::new(arm);
    let c_f = film_map(&patch);
    let theta = Vector2::new(THETA_NOMINAL[0] as f64, THETA_NOMINAL[1] as f64);
    let noise = NoiseModel::default();
    let mut gains = [Gain::<f64>::zeros(); 2];
    for (g, (_, period)) in gains.iter_mut().zip(PERIODS) {
        *g = observer::design(&model, &c_f, &theta, period, &noise).map_err(|e| {
            Error(format!(
                "observer design for the motor period {period} s failed: {e:?}"
            ))
        })?;
        check_contraction(&model, &c_f, g, period)?;
        if g.iter().any(|x| !(*x as f32).is_finite()) {
            return Err(Error(format!(
                "the observer gain for {period} s does not fit in f32"
            )));
        }
    }
    let ceilings = rate_ceilings(&arm, &patch)?;
    // The QEMU board boots running the rate law: its own gain must be within its ceiling.
    let shipped = PiezoGains {
        k_c: k_c as f32,
        ..PiezoGains::default()
    };
    if !ceilings[1].allows(&shipped) {
        let (cutoff, qemu_max) = (shipped.cutoff_hz, ceilings[1].k_c_max(shipped.cutoff_hz));
        return Err(Error(format!(
            "`piezo.k_c` = {k_c} s is above the {qemu_max} s the model's modes allow the rate \
             law at its {cutoff} Hz corner on the QEMU board's piezo loop (a stability factor \
             of 2: docs/console.md, \"Stability\")"
        )));
    }
    Ok(FirmwareParams {
        choice,
        arm,
        patch,
        qemu_slope_diff,
        k_c,
        gains,
        ceilings,
        homing,
    })
}

/// Corners sampled in each row's interval of a [`RateCeiling`].
pub const SAMPLES: u32 = 16;
/// The share a row gives up for the margin's variation between its samples: `B(f) f` has dips
/// a few per cent deep between the modes' resonances on the physical link (the ceiling's test,
/// `cargo test -p flexarm-host --test firmware_params rate_ceiling`).
pub const GUARD: f64 = 0.03;

/// The rate law's gain ceilings ([`RateCeiling`]) of the two boards, `[hardware, QEMU]`,
/// each on the link its loop drives:
/// - the QEMU board's simulated arm is the model: its two modes (`arm`'s `ω_j`, `ζ_j`, the
///   patch's `Δφ'_j`, `k_a`, `k_s`), the film read in the same period, an ideal amplifier;
/// - the hardware board drives a physical link, which has more modes than the model: the
///   truth plant's link for this arm's length and this patch's place with ten modes (the
///   spillover study's, `docs/results.md`), its 5 kHz amplifier and the film one period late.
///
/// Rows at corners spaced evenly in log from 1 Hz to the Nyquist rate, and at the shipped
/// corner; each the least `B(f) f` over [`SAMPLES`] corners spaced evenly in log between the
/// previous row's corner and its own (the first row's from a quarter of its corner), `B` half
/// the [`gain_margin`] at `k_c = 1 s`, less [`GUARD`] for what varies between the samples. A
/// loop stable at every gain (none that the bisection finds below 1e6) is held to nothing
/// there; one the eigen-solver cannot settle is allowed nothing.
pub fn rate_ceilings(
    arm: &ArmParams<f64>,
    patch: &PiezoPatch<f64>,
) -> Result<[RateCeiling<f32>; 2], Error> {
    let ceiling = |board: Board| -> Result<RateCeiling<f32>, Error> {
        let (link, law) = ceiling_loop(arm, patch, board)?;
        let nyquist = 0.5 / law.period;
        let shipped = f64::from(PiezoGains::<f32>::default().cutoff_hz);
        let last = (RATE_CEILING_ROWS - 2) as f64;
        let mut corners: Vec<f64> = (0..RATE_CEILING_ROWS - 1)
            .map(|k| nyquist.powf(k as f64 / last))
            .chain([shipped])
            .collect();
        corners.sort_by(f64::total_cmp);
        let product = |f: f64| {
            let at = PiezoLoop {
                cutoff_hz: f,
                ..law
            };
            match gain_margin(&link, &at, 1e6) {
                Ok(Some(m)) => m / 2.0 * f,
                Ok(None) => f64::INFINITY,
                Err(_) => 0.0,
            }
        };
        let mut rows = [[0.0f32; 2]; RATE_CEILING_ROWS];
        let mut below = corners[0] / 4.0;
        for (row, &f) in rows.iter_mut().zip(&corners) {
            let least = (1..=SAMPLES)
                .map(|i| below * (f / below).powf(f64::from(i) / f64::from(SAMPLES)))
                .map(product)
                .fold(f64::INFINITY, f64::min);
            *row = [f as f32, (least * (1.0 - GUARD)) as f32];
            below = f;
        }
        Ok(RateCeiling { rows })
    };
    Ok([ceiling(Board::Hardware)?, ceiling(Board::Qemu)?])
}

/// The link and the rate law's loop (at `k_c = 1 s`, the shipped corner) that
/// [`rate_ceilings`] computes `board`'s ceiling on.
pub fn ceiling_loop(
    arm: &ArmParams<f64>,
    patch: &PiezoPatch<f64>,
    board: Board,
) -> Result<(ModalLink, PiezoLoop), Error> {
    let law = PiezoLoop {
        k_c: 1.0,
        cutoff_hz: f64::from(PiezoGains::<f32>::default().cutoff_hz),
        period: 1.0 / f64::from(flexarm_machine::config::piezo_hz(board)),
        delay: false,
        amplifier_hz: None,
    };
    Ok(match board {
        Board::Hardware => {
            let spec = TruthSpec {
                modes: 10,
                ..TruthSpec::default()
            };
            let link = ModalLink::from_truth(&spec, arm, patch)
                .map_err(|e| Error(format!("the hardware board's rate-law ceiling: {e}")))?;
            (link, realistic(&spec, law))
        }
        Board::Qemu => {
            let link = ModalLink {
                omega: arm.modes.omega.iter().copied().collect(),
                zeta: arm.modes.zeta.iter().copied().collect(),
                slope_diff: patch.slope_diff.iter().copied().collect(),
                k_a: patch.k_a,
                k_s: patch.k_s,
                feedthrough: 0.0,
            };
            (link, law)
        }
    })
}

/// `c` kept for the rest of the process, one copy of each distinct ceiling (a board's
/// configuration refers to its ceiling, as the firmware's refers to a constant).
fn interned(c: RateCeiling<f32>) -> &'static RateCeiling<f32> {
    static KEPT: std::sync::Mutex<Vec<&'static RateCeiling<f32>>> =
        std::sync::Mutex::new(Vec::new());
    let mut kept = KEPT
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some(k) = kept.iter().find(|k| ***k == c) {
        return k;
    }
    let k: &'static RateCeiling<f32> = Box::leak(Box::new(c));
    kept.push(k);
    k
}

/// The slope differences `Δφ'_j` of `patch` on the QEMU board's simulated arm: the paper's
/// link 2 (uniform, 0.3 kg, 0.7 m), the shapes of [`PiezoPatch::uniform`].
pub fn qemu_slope_diff(patch: &PiezoPatch<f64>) -> Result<Vector2<f64>, Error> {
    let paper = ArmParams::<f64>::default();
    let on_paper = PiezoPatch::uniform(
        &Default::default(),
        paper.m2,
        paper.a2,
        patch.x_a,
        patch.l_a,
    );
    on_paper.to_f32().validate(paper.a2 as f32).map_err(|e| {
        Error(format!(
            "the patch [{}, {}] m does not fit on the QEMU board's arm (the paper's link 2, {} m): {e}",
            patch.x_a,
            patch.x_a + patch.l_a,
            paper.a2
        ))
    })?;
    Ok(on_paper.slope_diff)
}

/// A message on one line (TOML syntax errors span several, with a caret under the column).
fn one_line(msg: &str) -> String {
    msg.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(" ")
}

/// The estimation error `x⁺ = (I − LC) A x` must contract over the arm's range (the gain is
/// constant, designed at the nominal configuration).
fn check_contraction(
    model: &Model<f64>,
    c_f: &Vector2<f64>,
    gain: &Gain<f64>,
    period: f64,
) -> Result<(), Error> {
    for k in 0..=20 {
        let th2 = -3.0 + 6.0 * f64::from(k) / 20.0;
        let (a, c) = observer::linearization(model, c_f, &Vector2::new(0.0, th2), period)
            .map_err(|e| Error(format!("observer linearization at θ2 = {th2} rad: {e:?}")))?;
        let e = (nalgebra::SMatrix::<f64, 8, 8>::identity() - gain * c) * a;
        let radii: Vec<f64> = e.complex_eigenvalues().iter().map(|z| z.norm()).collect();
        // `all` with `<` also refuses a NaN radius.
        if !radii.iter().all(|r| *r < 1.0 - 1e-6) {
            let rho = radii.iter().copied().fold(f64::NAN, f64::max);
            return Err(Error(format!(
                "the observer gain for {period} s does not converge at θ2 = {th2} rad \
                 (spectral radius {rho:.6}, film map c_f = [{:e}, {:e}] V/(√kg·m))",
                c_f.x, c_f.y
            )));
        }
    }
    Ok(())
}

/// The Rust source of the firmware's generated parameters for `fragment_text`; `names` goes
/// into the doc comments (source and the command that regenerates the file).
pub fn render(fragment_text: &str, names: &Names<'_>) -> Result<String, Error> {
    Ok(source(&design(fragment_text)?, names))
}

/// The first line of every generated parameter file.
pub const GENERATED_FIRST_LINE: &str = "//! The arm model, piezo patch and observer gains the firmware runs, in each board's configuration.";

/// The first lines files generated before had: before the boards' configurations joined them,
/// and before the arm model did.
const GENERATED_FIRST_LINES_BEFORE: [&str; 2] = [
    "//! The arm model, piezo patch and observer gains the firmware runs.",
    "//! The piezo patch and observer gains the firmware runs (paper's arm, modes = \"paper\").",
];

/// The Rust source for parameters already designed ([`design`]).
pub fn source(p: &FirmwareParams, names: &Names<'_>) -> String {
    let f = |x: f64| format!("{:e}", x as f32);
    let v = |x: Vector2<f64>| format!("Vector2::new({}, {})", f(x.x), f(x.y));
    let c_f = film_map(&p.patch);
    let k_c_source = if p.choice.k_c_paper_modes.is_some() {
        "`piezo.k_c_paper_modes`"
    } else {
        "`piezo.k_c`"
    };
    let modes_source = match p.choice.modes {
        ModesChoice::Paper => "the paper's frequencies and damping, a uniform link's shapes",
        ModesChoice::Computed => "the source's `[piezo.computed]`",
    };
    let (a, md) = (&p.arm, &p.arm.modes);
    let mut s = format!(
        "{GENERATED_FIRST_LINE}\n\
         //!\n\
         //! Generated: do not edit. Source: `{frag}`. Regenerate with\n\
         //! `cargo sim firmware-params {frag} --out {out}`\n\
         //! (host/src/firmware_params.rs). `cargo test -p flexarm-host --test firmware_params`\n\
         //! checks that `firmware/src/generated.rs` is what `firmware/piezo.toml` gives.\n\
         //!\n\
         //! Observer gains: steady-state Kalman gains (`flexarm_core::observer::design`,\n\
         //! `NoiseModel::default()`) of [`ARM`] at rest at `THETA_NOMINAL`, for this patch's\n\
         //! film map `c_f = k_s Δφ' = [{cf0}, {cf1}]` V/(√kg·m).\n\
         \n\
         use flexarm_core::control::motor::MotorLaw;\n\
         use flexarm_core::control::piezo::{{PiezoGains, PiezoPatch}};\n\
         use flexarm_core::control::select::PiezoLawKind;\n\
         use flexarm_core::drive::MoveLimits;\n\
         use flexarm_core::homing::{{Config as HomingConfig, JointHoming, Method}};\n\
         use flexarm_core::motion::{{MotionLimits, Thermal}};\n\
         use flexarm_core::tuning::RateCeiling;\n\
         use flexarm_core::params::{{ArmParams, Gains, Limits, ModalData}};\n\
         use flexarm_core::{{Vector2, Vector4}};\n\
         use flexarm_link::msg::Board;\n\
         use flexarm_machine::BoardConfig;\n\
         \n\
         /// The controller's model of the arm (SI; `flexarm_core::params::ArmParams`): the\n\
         /// source's `[arm]` (the paper's values where it has none); its modes:\n\
         /// {modes_source}.\n\
         pub const ARM: ArmParams<f32> = ArmParams {{\n\
         \x20   a1: {a1},\n\
         \x20   a2: {a2},\n\
         \x20   m1: {m1},\n\
         \x20   m2: {m2},\n\
         \x20   m_h2: {m_h2},\n\
         \x20   i_1: {i_1},\n\
         \x20   i_h1: {i_h1},\n\
         \x20   i_h2: {i_h2},\n\
         \x20   i_2_extra: {i_2_extra},\n\
         \x20   modes: ModalData {{\n\
         \x20       omega: {omega},\n\
         \x20       zeta: {zeta},\n\
         \x20       mass_integral: {mass},\n\
         \x20       moment_integral: {moment},\n\
         \x20       tip: {tip},\n\
         \x20   }},\n\
         }};\n\
         \n\
         /// The piezo patch on link 2 (`flexarm_core::control::piezo::PiezoPatch`): its start\n\
         /// from joint 2 `x_a` [m], its length `l_a` [m], the slope differences `Δφ'_j` across it\n\
         /// on the modes of [`ARM`] [1/(m·√kg)], the actuator's moment per volt `k_a` [N·m/V] and\n\
         /// the film's volts per radian of slope difference `k_s` [V/rad].\n\
         pub const PATCH: PiezoPatch<f32> = PiezoPatch {{\n\
         \x20   x_a: {x_a},\n\
         \x20   l_a: {l_a},\n\
         \x20   slope_diff: Vector2::new({sd0}, {sd1}),\n\
         \x20   k_a: {k_a},\n\
         \x20   k_s: {k_s},\n\
         }};\n\
         /// Slope differences across the patch on the QEMU board's simulated arm (the paper's\n\
         /// arm, uniform link 2, whatever [`ARM`] is) [1/(m·√kg)].\n\
         pub const QEMU_SLOPE_DIFF: [f32; 2] = [{qd0}, {qd1}];\n\
         /// Rate-feedback gain `k_c` of `V_a = −k_c V̇_f` [s] (the fragment's {k_c_source}).\n\
         pub const K_C: f32 = {k_c};\n",
        frag = names.fragment,
        out = names.out,
        cf0 = f(c_f.x),
        cf1 = f(c_f.y),
        a1 = f(a.a1),
        a2 = f(a.a2),
        m1 = f(a.m1),
        m2 = f(a.m2),
        m_h2 = f(a.m_h2),
        i_1 = f(a.i_1),
        i_h1 = f(a.i_h1),
        i_h2 = f(a.i_h2),
        i_2_extra = f(a.i_2_extra),
        omega = v(md.omega),
        zeta = v(md.zeta),
        mass = v(md.mass_integral),
        moment = v(md.moment_integral),
        tip = v(md.tip),
        x_a = f(p.patch.x_a),
        l_a = f(p.patch.l_a),
        sd0 = f(p.patch.slope_diff.x),
        sd1 = f(p.patch.slope_diff.y),
        qd0 = f(p.qemu_slope_diff.x),
        qd1 = f(p.qemu_slope_diff.y),
        k_a = f(p.patch.k_a),
        k_s = f(p.patch.k_s),
        k_c = f(p.k_c),
    );
    for (g, (name, period)) in p.gains.iter().zip(PERIODS) {
        let _ = write!(
            s,
            "\n/// Observer gain `L` (8×3, row-major; rows `(q, q̇)`, columns `(θ1, θ2, V_f)`) for a\n\
             /// motor period of {period} s.\n\
             pub const {name}: [[f32; 3]; 8] = [\n"
        );
        for i in 0..8 {
            let _ = writeln!(
                s,
                "    [{}, {}, {}],",
                f(g[(i, 0)]),
                f(g[(i, 1)]),
                f(g[(i, 2)])
            );
        }
        s += "];\n";
    }
    for (board, name, gain) in [
        (Board::Hardware, "HARDWARE", "GAIN_1KHZ"),
        (Board::Qemu, "QEMU", "GAIN_100HZ"),
    ] {
        let c = p.board(board);
        let rows: Vec<String> = c
            .rate_ceiling
            .rows
            .iter()
            .map(|[f, k]| format!("[{f:e}, {k:e}]"))
            .collect();
        let _ = write!(
            s,
            "\n/// The rate law's `k_c` ceiling by filter corner on the {which} (`[f_c [Hz], k_c,max [s]]`,\n\
             /// `flexarm_core::tuning::RateCeiling`; `firmware_params::rate_ceilings`).\n\
             pub const {name}_RATE_CEILING: RateCeiling<f32> = RateCeiling {{\n    rows: [{rows}],\n}};\n",
            which = match board {
                Board::Hardware => "hardware board",
                Board::Qemu => "QEMU board",
            },
            rows = rows.join(", "),
        );
        let _ = write!(
            s,
            "\n/// Everything the {which} boots with (`flexarm_machine::BoardConfig::for_board` on this\n\
             /// model): its hash is [`{name}_HASH`].\n\
             pub const {name}: BoardConfig = {lit};\n\
             /// `BoardConfig::hash` of [`{name}`], the handshake's `params_hash`.\n\
             pub const {name}_HASH: u32 = {hash:#010x};\n",
            which = match board {
                Board::Hardware => "hardware board",
                Board::Qemu => "QEMU board",
            },
            lit = config_literal(&c, gain, name),
            hash = c.hash(),
        );
    }
    s
}

/// `c` as a Rust expression, its arm, patch and observer gain the constants [`source`] wrote
/// (`ARM`, `PATCH`, `gain`).
fn config_literal(c: &BoardConfig, gain: &str, name: &str) -> String {
    let f = |x: f32| format!("{x:e}");
    let v2 = |x: Vector2<f32>| format!("Vector2::new({}, {})", f(x.x), f(x.y));
    let v4 = |x: flexarm_core::Vector4<f32>| {
        format!(
            "Vector4::new({}, {}, {}, {})",
            f(x.x),
            f(x.y),
            f(x.z),
            f(x.w)
        )
    };
    let (g, m, t, mv, l) = (&c.gains, &c.motion, &c.motion.thermal, &c.moves, &c.limits);
    format!(
        "BoardConfig {{
    board: Board::{board:?},
    arm: ARM,
    patch: PATCH,
    law: MotorLaw::{law:?},
    gains: Gains {{
        lambda: {lambda},
        kp: {kp},
        d_delta: {d_delta},
        epsilon: {epsilon},
        phi: {phi},
        epsilon_floor: {epsilon_floor},
        mu: {mu},
        ki: {ki},
        integral_limit: {integral_limit},
    }},
    piezo: PiezoGains {{
        k_c: K_C,
        cutoff_hz: {cutoff_hz},
    }},
    piezo_law: PiezoLawKind::{piezo_law:?},
    rate_ceiling: &{name}_RATE_CEILING,
    film_static: {film_static},
    film_feedthrough: {film_feedthrough},
    limits: Limits {{
        tau_max: {tau_max},
        v_a_max: {v_a_max},
        v_a_min: {v_a_min},
    }},
    motion: MotionLimits {{
        following: {following},
        speed: {speed},
        runaway_speed: {runaway_speed},
        runaway_torque: {runaway_torque},
        runaway_error: {runaway_error},
        runaway_periods: {runaway_periods},
        count: {count},
        stall_friction: {stall_friction},
        stall_margin: {stall_margin},
        stall_accel: {stall_accel},
        stall_speed_error: {stall_speed_error},
        range_min: {range_min},
        range_max: {range_max},
        stop_accel: {stop_accel},
        range_margin: {range_margin},
        thermal: Thermal {{
            continuous: {continuous},
            time_constant: {time_constant},
            derate: {derate},
            floor: {floor},
            trip: {trip},
        }},
        brake_travel: {brake_travel},
        brake_settle_periods: {brake_settle_periods},
    }},
    moves: MoveLimits {{
        speed_max: {speed_max},
        accel_max: {accel_max},
        theta_max: {theta_max},
        theta_min: {theta_min},
        torque_share: {torque_share},
    }},
    observer_gain: {gain},
    piezo_hz: {piezo_hz},
    motor_divider: {motor_divider},
    print_every: {print_every},
    record_every: {record_every},
    link_timeout_s: {link_timeout_s},
    amplifier_settle: {amplifier_settle},
    amplifier_debounce: {amplifier_debounce},
    homing: HomingConfig {{
        joints: [{joint0}, {joint1}],
        stall_travel: {stall_travel},
        stall_time: {stall_time},
        stall_share: {stall_share},
        tolerance: {tolerance},
    }},
}}",
        board = c.board,
        law = c.law,
        lambda = v4(g.lambda),
        kp = v4(g.kp),
        d_delta = v2(g.d_delta),
        epsilon = v2(g.epsilon),
        phi = v2(g.phi),
        epsilon_floor = f(g.epsilon_floor),
        mu = f(g.mu),
        ki = v2(g.ki),
        integral_limit = v2(g.integral_limit),
        cutoff_hz = f(c.piezo.cutoff_hz),
        piezo_law = c.piezo_law,
        film_static = f(c.film_static),
        film_feedthrough = f(c.film_feedthrough),
        tau_max = v2(l.tau_max),
        v_a_max = f(l.v_a_max),
        v_a_min = f(l.v_a_min),
        following = v2(m.following),
        speed = v2(m.speed),
        runaway_speed = f(m.runaway_speed),
        runaway_torque = v2(m.runaway_torque),
        runaway_error = f(m.runaway_error),
        runaway_periods = m.runaway_periods,
        count = f(m.count),
        stall_friction = v2(m.stall_friction),
        stall_margin = f(m.stall_margin),
        stall_accel = f(m.stall_accel),
        stall_speed_error = f(m.stall_speed_error),
        range_min = v2(m.range_min),
        range_max = v2(m.range_max),
        stop_accel = v2(m.stop_accel),
        range_margin = f(m.range_margin),
        continuous = v2(t.continuous),
        time_constant = f(t.time_constant),
        derate = f(t.derate),
        floor = f(t.floor),
        trip = f(t.trip),
        brake_travel = f(m.brake_travel),
        brake_settle_periods = m.brake_settle_periods,
        speed_max = v2(mv.speed_max),
        accel_max = v2(mv.accel_max),
        theta_max = v2(mv.theta_max),
        theta_min = v2(mv.theta_min),
        torque_share = f(mv.torque_share),
        piezo_hz = c.piezo_hz,
        motor_divider = c.motor_divider,
        print_every = c.print_every,
        record_every = c.record_every,
        link_timeout_s = c.link_timeout_s,
        amplifier_settle = c.amplifier_settle,
        amplifier_debounce = c.amplifier_debounce,
        joint0 = joint(&c.homing.joints[0]),
        joint1 = joint(&c.homing.joints[1]),
        stall_travel = f(c.homing.stall_travel),
        stall_time = f(c.homing.stall_time),
        stall_share = f(c.homing.stall_share),
        tolerance = f(c.homing.tolerance),
    )
}

/// A joint's homing configuration as a Rust expression.
fn joint(j: &flexarm_core::homing::JointHoming<f32>) -> String {
    let f = |x: f32| format!("{x:e}");
    format!(
        "JointHoming {{ method: Method::{:?}, angle: {}, speed: {}, torque: {}, travel: {} }}",
        j.method,
        f(j.angle),
        f(j.speed),
        f(j.torque),
        f(j.travel)
    )
}

/// The paper's patch (`x_a = 0.09 m`, `l_a = 0.35 m`) with `k_c = 30 s` on the paper's modes as a
/// `[piezo]` fragment, written by the optimizer's own code path
/// ([`flexarm_beam::fragment::piezo_fragment`]): the default `firmware/piezo.toml`.
///
/// `k_c = 30 s` is the core's default gain on the paper's modes (`PiezoGains::default()`), so the
/// fragment leaves out `k_c_paper_modes` (the optimizer's conversion from the design beam).
pub fn paper_fragment() -> Result<String, Error> {
    let model = DesignModel::default();
    let arm = ArmParams::<f64>::default();
    let opt = evaluate(&model, &Weights::default(), 0.09, 0.35, 30.0)
        .ok_or_else(|| Error("the paper's patch could not be evaluated".into()))?;
    let text = piezo_fragment(&model, &opt, &arm);
    let body: String = text
        .lines()
        .filter(|l| !l.starts_with("k_c_paper_modes =") && !l.starts_with("# Piezo patch chosen"))
        .map(|l| format!("{l}\n"))
        .collect();
    Ok(format!(
        "# The patch the firmware runs: `cargo sim firmware-params` turns this file into\n\
         # firmware/src/generated.rs (docs/firmware.md). Default: the paper's patch, written by\n\
         # `cargo sim firmware-params --paper-fragment`; replace it with the optimizer's\n\
         # out/optimize/piezo.toml to run that patch. Keys and units: docs/optimization.md.\n\
         # k_c applies to the paper's modes as written (no k_c_paper_modes: the core's default 30 s).\n\
         {body}"
    ))
}

/// Whether `text` is a generated parameter file (its first line is the one [`source`] writes),
/// which `firmware-params` may replace without `--force`.
pub fn is_generated_source(text: &str) -> bool {
    let first = text.lines().next().unwrap_or("");
    first == GENERATED_FIRST_LINE || GENERATED_FIRST_LINES_BEFORE.contains(&first)
}

/// Whether `text` is a `[piezo]` fragment a flexarm command wrote (the paper's, by
/// `--paper-fragment`, or the optimizer's), which `--paper-fragment` may replace without
/// `--force`.
pub fn is_generated_fragment(text: &str) -> bool {
    let first = text.lines().next().unwrap_or("");
    first.starts_with("# The patch the firmware runs:")
        || first.starts_with("# Piezo patch chosen by `flexarm-sim optimize`")
}
