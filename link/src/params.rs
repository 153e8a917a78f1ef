//! The tunable parameters, each declared once, in [`for_each_param!`]: its wire name (a variant
//! of [`Param`]), the name an operator types and a recording's key, its unit, the range a `Set`
//! must fall in, whether it may change while a move runs, where a board's configuration keeps
//! its boot value (`flexarm_machine::BoardConfig`), where the running board keeps it, and its
//! doc. Everything else follows from the declaration:
//!
//! - here: the [`Param`] enum (the link's `Get`/`Set`), [`PARAMS`] (names, units, ranges,
//!   docs), [`Param::named`];
//! - in `flexarm-machine`: `BoardConfig::param`/`set_param` (the configuration field), the
//!   session's `Get`/`Set` (the running home, the range, the rule while moving);
//! - in the console: `get`/`set` by name, `get list`, a recording's `params` table.
//!
//! Adding a parameter is one more line in the declaration (and, when it is new to the
//! controller, the field its homes name).

use serde::{Deserialize, Serialize};

/// Calls the macro `$m` with every parameter's declaration, in the wire's order. Each is
/// `Variant "name" "unit" (min, max) moving|fixed {config field} home "doc";` where
/// - `(min, max)`: a `Set` outside is refused (`OutOfRange`), whatever else the controller
///   checks (its ceilings, the rules between parameters);
/// - `moving` or `fixed`: whether a `Set` is accepted while a move or a stop runs;
/// - `{config field}`: the field of a `flexarm_machine::BoardConfig` holding its boot value
///   (`{}` when it has none: it boots at 0);
/// - `home`: where the running board keeps it: `tuning(Tunable)` (the controller's, through
///   `flexarm_core::tuning`), `drive(link_timeout)` (the link watchdog, in seconds on the wire,
///   in motor periods in the drive), `drive(stall_speed_error)` (the motion checks' limit) or
///   `bias` (the piezo bias, `flexarm_machine::Control`).
#[macro_export]
macro_rules! for_each_param {
    ($m:ident) => {
        $m! {
            Kp0 "kp0" "N·m·s/rad" (0.0, 1e4) fixed {gains.kp.x} tuning(Kp(0))
                "`K_p` of joint 1 (Eq. 7's proportional term on `s = q̃̇ + Λ q̃`)";
            Kp1 "kp1" "N·m·s/rad" (0.0, 1e4) fixed {gains.kp.y} tuning(Kp(1))
                "`K_p` of joint 2";
            Kp2 "kp2" "(modal row)" (0.0, 1e4) fixed {gains.kp.z} tuning(Kp(2))
                "`K_p` of mode 1's row (no effect on the motors, `docs/model.md`)";
            Kp3 "kp3" "(modal row)" (0.0, 1e4) fixed {gains.kp.w} tuning(Kp(3))
                "`K_p` of mode 2's row (no effect on the motors)";
            Lambda0 "lambda0" "1/s" (1e-3, 1e4) fixed {gains.lambda.x} tuning(Lambda(0))
                "`Λ` of joint 1 (`q̇_r = q̇_d − Λ q̃`)";
            Lambda1 "lambda1" "1/s" (1e-3, 1e4) fixed {gains.lambda.y} tuning(Lambda(1))
                "`Λ` of joint 2";
            Lambda2 "lambda2" "1/s" (1e-3, 1e4) fixed {gains.lambda.z} tuning(Lambda(2))
                "`Λ` of mode 1";
            Lambda3 "lambda3" "1/s" (1e-3, 1e4) fixed {gains.lambda.w} tuning(Lambda(3))
                "`Λ` of mode 2";
            DDelta0 "d_delta0" "1/s" (0.0, 1e4) fixed {gains.d_delta.x} tuning(DDelta(0))
                "`D_Δ` of mode 1 (Eq. 11's robust damping)";
            DDelta1 "d_delta1" "1/s" (0.0, 1e4) fixed {gains.d_delta.y} tuning(DDelta(1))
                "`D_Δ` of mode 2";
            Ki0 "ki0" "1/s" (0.0, 1e3) fixed {gains.ki.x} tuning(Ki(0))
                "integral rate `K_i` of joint 1 (the reference shifted by `K_i ∫ θ̃ dt`, \
`flexarm_core::control::integral`); 0: none, as the paper";
            Ki1 "ki1" "1/s" (0.0, 1e3) fixed {gains.ki.y} tuning(Ki(1))
                "integral rate `K_i` of joint 2";
            Kc "kc" "s" (0.0, 1e3) fixed {piezo.k_c} tuning(Kc)
                "piezo gain `k_c` of `V_a = −k_c V̇_f` (Eq. 17); 0 turns the piezo loop off";
            CutoffHz "cutoff_hz" "Hz" (1e-1, 1e5) fixed {piezo.cutoff_hz} tuning(CutoffHz)
                "corner of the piezo loop's rate filter (below its Nyquist rate)";
            TauMax0 "tau_max0" "N·m" (0.0, 1e3) fixed {limits.tau_max.x} tuning(TauMax(0))
                "torque limit of joint 1 (at most the drive's rating)";
            TauMax1 "tau_max1" "N·m" (0.0, 1e3) fixed {limits.tau_max.y} tuning(TauMax(1))
                "torque limit of joint 2";
            VaMax "va_max" "V" (0.0, 1e3) fixed {limits.v_a_max} tuning(VaMax)
                "top of the piezo amplifier's window (at most the board's output stage's)";
            VaMin "va_min" "V" (-1e3, 0.0) fixed {limits.v_a_min} tuning(VaMin)
                "bottom of the piezo amplifier's window (a patch takes less reverse voltage)";
            LinkTimeout "link_timeout" "s" (0.0, 3600.0) fixed {link_timeout_s} drive(link_timeout)
                "the link watchdog: a move stops when the host is silent this long; 0 turns it off";
            VaBias "va_bias" "V" (-1e3, 1e3) fixed {} bias
                "a constant added to the piezo command, within the amplifier's window, for \
bring-up and identification: written only while armed and holding, back to 0 \
as soon as the drive leaves holding";
            FilmStatic "film_static" "V/V" (0.0, 1.0) fixed {film_static} tuning(FilmStatic)
                "the film's static gain `G(0) = V_f/V_a` measured on the arm (`flexarm bringup`'s \
film step), which the IRC and PPF laws are designed from; 0: not measured";
            FilmFeedthrough "film_feedthrough" "V/V" (-1.0, 1.0) fixed {film_feedthrough}
                tuning(FilmFeedthrough)
                "the film's feedthrough `F̂`: its jump right after a step of `V_a`, per volt \
(`flexarm bringup`'s film step; recorded, no law on the board reads it)";
            PiezoLaw "piezo_law" "code" (0.0, 3.0) fixed {piezo_law} tuning(PiezoLaw)
                "the piezo law (`flexarm_core::control::select`): 0 off, 1 rate (Eq. 17), 2 IRC \
(integral resonant control), 3 PPF (positive position feedback); the console takes the \
names; changed only while disarmed, the new law starting at rest";
            StallSpeedError "stall_speed_error" "rad/s" (1e-4, 10.0) fixed
                {motion.stall_speed_error} drive(stall_speed_error)
                "how far the observer's joint speed may be off the joint's, for the stall check's \
travel bound (`flexarm_core::motion`, docs/safety.md): 0.1 by default (an arm its model does \
not know), 0.005 once the arm's model is identified; smaller catches a frozen encoder sooner \
at low speed";
        }
    };
}

/// A parameter's description, from its declaration ([`for_each_param!`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamInfo {
    /// The wire's name.
    pub param: Param,
    /// The name an operator types (`flexarm get kc`) and a recording's key.
    pub name: &'static str,
    /// Its unit.
    pub unit: &'static str,
    /// The range a `Set` must fall in (the controller checks more).
    pub range: (f32, f32),
    /// Whether a `Set` is accepted while a move or a stop runs.
    pub while_moving: bool,
    /// What it is.
    pub doc: &'static str,
}

macro_rules! declare_params {
    ($($variant:ident $name:literal $unit:literal ($min:expr, $max:expr) $moving:ident
       {$($field:tt)*} $home:ident $(($($h:tt)*))? $doc:literal;)*) => {
        /// The tunable parameters: one variant each, declared in [`for_each_param!`] (each
        /// one's unit and meaning: [`PARAMS`], [`Param::info`]).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
        pub enum Param {
            $(
                #[doc = $doc]
                $variant,
            )*
        }

        /// Every parameter's description, in the wire's order.
        pub const PARAMS: &[ParamInfo] = &[
            $(ParamInfo {
                param: Param::$variant,
                name: $name,
                unit: $unit,
                range: ($min, $max),
                while_moving: declare_params!(@moving $moving),
                doc: $doc,
            },)*
        ];
    };
    (@moving moving) => { true };
    (@moving fixed) => { false };
}

for_each_param!(declare_params);

impl Param {
    /// Its description.
    pub fn info(self) -> &'static ParamInfo {
        // The variants are declared in PARAMS's order.
        &PARAMS[self as usize]
    }

    /// The parameter an operator calls `name`.
    pub fn named(name: &str) -> Option<Self> {
        PARAMS.iter().find(|p| p.name == name).map(|p| p.param)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each parameter's description is its own, and its name finds it.
    #[test]
    fn the_table_is_in_the_enums_order_and_the_names_are_unique() {
        for (i, p) in PARAMS.iter().enumerate() {
            assert_eq!(p.param as usize, i);
            assert_eq!(p.param.info(), p);
            assert_eq!(Param::named(p.name), Some(p.param));
            assert!(p.range.0 <= p.range.1, "{}", p.name);
        }
        assert_eq!(Param::named("kp4"), None);
    }
}
