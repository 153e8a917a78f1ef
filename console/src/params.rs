//! The tunable parameters by name, as the operator types them (`get kc`, `set tau_max1 8`): the
//! link's declaration (`flexarm_link::params`) gives the names, units, ranges and docs.

use flexarm_core::control::select::{LAWS, PiezoLawKind};
use flexarm_link::msg::Param;
use flexarm_link::params::PARAMS;

use crate::client::ConsoleError;

/// The parameter named `name`, and its unit.
pub fn parse(name: &str) -> Result<(Param, &'static str), ConsoleError> {
    Param::named(name)
        .map(|p| (p, p.info().unit))
        .ok_or_else(|| {
            let all: Vec<&str> = PARAMS.iter().map(|p| p.name).collect();
            ConsoleError::Usage(format!(
                "no parameter `{name}`; the parameters: {}",
                all.join(", ")
            ))
        })
}

/// `get list`: every parameter, one a line: its name, unit, range, whether it may change while
/// a move runs, and what it is.
pub fn list() -> String {
    PARAMS
        .iter()
        .map(|p| {
            format!(
                "{} [{}] {} … {}{}: {}\n",
                p.name,
                p.unit,
                p.range.0,
                p.range.1,
                if p.while_moving {
                    ""
                } else {
                    ", not while moving"
                },
                p.doc
            )
        })
        .collect()
}

/// The value an operator typed for `p`: a number in its unit, or, for `piezo_law`, a law's name
/// (`off`, `rate`, `irc`, `ppf`: its code).
pub fn value(p: Param, text: &str) -> Result<f32, ConsoleError> {
    if p == Param::PiezoLaw
        && let Some(k) = PiezoLawKind::named(text)
    {
        return Ok(f32::from(k.code()));
    }
    text.parse::<f32>().map_err(|_| {
        let laws: Vec<&str> = LAWS.iter().map(|k| k.name()).collect();
        ConsoleError::Usage(if p == Param::PiezoLaw {
            format!("`{text}`: give a law's code or name ({})", laws.join(", "))
        } else {
            format!("`{text}` is not a number")
        })
    })
}

/// What a value of `p` means beyond its number: the law's name for `piezo_law`.
pub fn meaning(p: Param, v: f32) -> String {
    match (p, PiezoLawKind::from_code(v)) {
        (Param::PiezoLaw, Some(k)) => format!(" ({})", k.name()),
        _ => String::new(),
    }
}
