//! The arm's geometry: what the model step takes as given, because no record of the film and
//! the encoders measures it (`cargo sim identify model --arm FILE`, docs/identification.md).
//!
//! ```toml
//! [arm]
//! a1 = 0.3          # m, joint 1 to joint 2
//! a2 = 0.7          # m, joint 2 to the tip
//! [link]
//! tip_mass = 0.0    # kg, a payload at the tip
//! tip_inertia = 0.0 # kg m^2, its rotary inertia
//! [patch]
//! x_a = 0.09        # m, the patch's start from joint 2
//! l_a = 0.35        # m, its length
//! k_a = 1.0e-3      # N m/V, the actuator's moment per volt (its data sheet)
//! k_s = 1.0e3       # V/rad, the film's volts per radian (its data sheet)
//! mass_ratio = 1.0       # the patched section's mass per length over the bare link's
//! stiffness_ratio = 1.0  # its bending stiffness EI over the bare link's
//! [board]
//! film_range = 10.0                   # V, the film ADC's ±range
//! amplifier_window = [-200.0, 200.0]  # V
//! torque_limit = [10.0, 10.0]         # N m, each drive's largest torque
//! ```
//!
//! Every key is optional; the defaults are the paper's arm and patch (`ArmParams::default`,
//! `PiezoPatch::paper`) on the project's board. The link's mode shapes follow from it: the
//! link clamped at joint 2 with the payload as a tip body, bare but for the patch's stretch
//! `[x_a, x_a + l_a]`, where the ceramic and the film bonded to it multiply its mass per length
//! by `mass_ratio` and its bending stiffness by `stiffness_ratio` (a lab computes both from its
//! layers' thicknesses, moduli and densities: `flexarm_beam::section::Layers` does it for the
//! paper's stack; on its 2.5 mm link 1.92 and 2.29, on a 1 mm link 3.30 and 5.80). The bare
//! link's mass per length is what the inertia fit's `S` leaves it: `S/a1` is the link's first
//! moment about joint 2 with the payload's (`M a2`). The defaults (both 1) leave the layers
//! out, a uniform link. What is assumed, said plainly: the link is uniform outside the patch
//! (a link that tapers is not this one); the shapes' frequencies are not used, the identified
//! ones are.

use flexarm_beam::segmented::{Mode, Segment, SegmentedBeam};
use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::params::ArmParams;
use serde::Deserialize;

use super::IdentifyError;

/// The geometry (module docs). SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// Link 1's length `a1` [m].
    pub a1: f64,
    /// Link 2's length `a2` [m].
    pub a2: f64,
    /// The payload at the tip [kg].
    pub tip_mass: f64,
    /// Its rotary inertia [kg·m²].
    pub tip_inertia: f64,
    /// The patch's start `x_a` [m].
    pub x_a: f64,
    /// Its length `l_a` [m].
    pub l_a: f64,
    /// The patched section's mass per length over the bare link's [-].
    pub mass_ratio: f64,
    /// The patched section's bending stiffness over the bare link's [-].
    pub stiffness_ratio: f64,
    /// The actuator's moment per volt `k_a` [N·m/V].
    pub k_a: f64,
    /// The film's volts per radian `k_s` [V/rad].
    pub k_s: f64,
    /// The film ADC's range `±film_range` [V].
    pub film_range: f64,
    /// The amplifier's window [V].
    pub amplifier_window: (f64, f64),
    /// Each drive's largest torque `±torque_limit` [N·m].
    pub torque_limit: [f64; 2],
}

impl Default for Geometry {
    /// The paper's arm and patch, a ±10 V film ADC, a ±200 V amplifier, the project's drives'
    /// torque limits (`flexarm_core::params::Limits`: ±10 N·m).
    fn default() -> Self {
        let (arm, p) = (ArmParams::<f64>::default(), PiezoPatch::<f64>::paper());
        let tau_max = flexarm_core::params::Limits::<f64>::default().tau_max;
        Self {
            a1: arm.a1,
            a2: arm.a2,
            tip_mass: 0.0,
            tip_inertia: 0.0,
            x_a: p.x_a,
            l_a: p.l_a,
            mass_ratio: 1.0,
            stiffness_ratio: 1.0,
            k_a: p.k_a,
            k_s: p.k_s,
            film_range: 10.0,
            amplifier_window: (-200.0, 200.0),
            torque_limit: [tau_max.x, tau_max.y],
        }
    }
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct File {
    #[serde(default)]
    arm: ArmTable,
    #[serde(default)]
    link: LinkTable,
    #[serde(default)]
    patch: PatchTable,
    #[serde(default)]
    board: BoardTable,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct ArmTable {
    a1: Option<f64>,
    a2: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct LinkTable {
    tip_mass: Option<f64>,
    tip_inertia: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct PatchTable {
    x_a: Option<f64>,
    l_a: Option<f64>,
    mass_ratio: Option<f64>,
    stiffness_ratio: Option<f64>,
    k_a: Option<f64>,
    k_s: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct BoardTable {
    film_range: Option<f64>,
    #[serde(default, deserialize_with = "flexarm_beam::toml_at::option_array")]
    amplifier_window: Option<[f64; 2]>,
    #[serde(default, deserialize_with = "flexarm_beam::toml_at::option_array")]
    torque_limit: Option<[f64; 2]>,
}

impl Geometry {
    /// Reads a geometry file; an error names the key (`` `table.key` ``, which
    /// `flexarm_beam::toml_at::at_line` turns into its line) and what is allowed.
    pub fn parse(text: &str) -> Result<Self, String> {
        let f: File =
            toml::from_str(text).map_err(|e| flexarm_beam::toml_at::de_error(text, &e))?;
        let d = Self::default();
        let g = Self {
            a1: f.arm.a1.unwrap_or(d.a1),
            a2: f.arm.a2.unwrap_or(d.a2),
            tip_mass: f.link.tip_mass.unwrap_or(d.tip_mass),
            tip_inertia: f.link.tip_inertia.unwrap_or(d.tip_inertia),
            x_a: f.patch.x_a.unwrap_or(d.x_a),
            l_a: f.patch.l_a.unwrap_or(d.l_a),
            mass_ratio: f.patch.mass_ratio.unwrap_or(d.mass_ratio),
            stiffness_ratio: f.patch.stiffness_ratio.unwrap_or(d.stiffness_ratio),
            k_a: f.patch.k_a.unwrap_or(d.k_a),
            k_s: f.patch.k_s.unwrap_or(d.k_s),
            film_range: f.board.film_range.unwrap_or(d.film_range),
            amplifier_window: f
                .board
                .amplifier_window
                .map_or(d.amplifier_window, |[a, b]| (a, b)),
            torque_limit: f.board.torque_limit.unwrap_or(d.torque_limit),
        };
        g.validate()?;
        Ok(g)
    }

    /// Every value finite and in its physical range; the patch on the link.
    pub fn validate(&self) -> Result<(), String> {
        let within = |key: &str, v: f64, lo: f64, hi: f64, unit: &str| {
            if v.is_finite() && v >= lo && v <= hi {
                Ok(())
            } else {
                Err(format!(
                    "`{key}`: {v} {unit} is outside {lo:e} to {hi:e} {unit}"
                ))
            }
        };
        within("arm.a1", self.a1, 1e-3, 100.0, "m")?;
        within("arm.a2", self.a2, 1e-3, 100.0, "m")?;
        within("link.tip_mass", self.tip_mass, 0.0, 1e3, "kg")?;
        within("link.tip_inertia", self.tip_inertia, 0.0, 1e3, "kg m^2")?;
        within("patch.x_a", self.x_a, 0.0, self.a2, "m")?;
        within("patch.l_a", self.l_a, 1e-4, self.a2 - self.x_a, "m")?;
        within("patch.mass_ratio", self.mass_ratio, 0.1, 1e3, "")?;
        within("patch.stiffness_ratio", self.stiffness_ratio, 0.1, 1e4, "")?;
        within("patch.k_a", self.k_a, 1e-12, 1e6, "N m/V")?;
        within("patch.k_s", self.k_s, 1e-12, 1e12, "V/rad")?;
        within("board.film_range", self.film_range, 1e-6, 1e6, "V")?;
        for l in self.torque_limit {
            within("board.torque_limit", l, 1e-6, 1e6, "N m")?;
        }
        let (lo, hi) = self.amplifier_window;
        if !(lo.is_finite() && hi.is_finite() && lo < 0.0 && hi > 0.0) {
            return Err(format!(
                "`board.amplifier_window`: [{lo}, {hi}] V must hold 0 strictly inside"
            ));
        }
        Ok(())
    }

    /// The coupling `S = a1 m2 a2/2` a link of no mass but the payload would give, plus a
    /// tenth [kg·m²]: where the flexible inertia fit's passes start at least
    /// (`super::inertia::fit_inertia_flexible`).
    pub fn s_floor(&self) -> f64 {
        1.1 * self.a1 * self.a2 * self.tip_mass
    }

    /// `nominal` with this geometry's lengths.
    pub fn arm(&self, nominal: &ArmParams<f64>) -> ArmParams<f64> {
        ArmParams {
            a1: self.a1,
            a2: self.a2,
            ..*nominal
        }
    }

    /// The patch of this geometry with the slope differences `slope_diff`.
    pub fn patch(&self, slope_diff: flexarm_core::Vector2<f64>) -> PiezoPatch<f64> {
        PiezoPatch {
            x_a: self.x_a,
            l_a: self.l_a,
            slope_diff,
            k_a: self.k_a,
            k_s: self.k_s,
        }
    }

    /// The first `count` modes of the link clamped at joint 2, the patched stretch's ratios
    /// and the payload as a tip body (module docs), whose own first moment about joint 2 is a
    /// uniform link's of mass `m_link` [kg] (`m_link a2/2`); the first one near `omega1`
    /// [rad/s] (the shapes do not depend on it).
    pub fn shapes(
        &self,
        m_link: f64,
        omega1: f64,
        count: usize,
    ) -> Result<Vec<Mode>, IdentifyError> {
        let bad = |m: String| IdentifyError::Data(format!("gate `physical consistency`: {m}"));
        if !(m_link.is_finite() && m_link > 0.0) {
            return Err(bad(format!(
                "the link's own mass comes out {m_link:.3e} kg (the inertia fit's S, less the geometry's payload of {} kg counted twice): the payload given is more than the arm's inertias allow",
                self.tip_mass
            )));
        }
        // The bare link's ρA from the first moment: ρA (a2²/2 + (r_m − 1)(x_a l_a + l_a²/2)).
        let (x_a, l_a, l) = (self.x_a, self.l_a, self.a2);
        let moment = l * l / 2.0 + (self.mass_ratio - 1.0) * (x_a * l_a + l_a * l_a / 2.0);
        let rho_a = m_link * l / 2.0 / moment;
        // A uniform cantilever's first mode: ω1 = 1.875² √(EI/(ρA L⁴)); a tip body and the
        // patch move it, and the root finder brackets from there.
        let ei = rho_a * l.powi(4) * (omega1 / 3.516).powi(2);
        let bare = |length: f64| Segment { length, ei, rho_a };
        let patched = Segment {
            length: l_a,
            ei: ei * self.stiffness_ratio,
            rho_a: rho_a * self.mass_ratio,
        };
        let segments: Vec<Segment> = [bare(x_a), patched, bare(l - x_a - l_a)]
            .into_iter()
            .filter(|s| s.length > 1e-9 * l)
            .collect();
        let beam = SegmentedBeam::new(&segments, self.tip_mass, self.tip_inertia)
            .map_err(|e| bad(format!("the link's shapes: {e}")))?;
        beam.modes(count)
            .map_err(|e| bad(format!("the link's shapes: {e}")))
    }
}
