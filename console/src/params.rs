//! The tunable parameters by name, as the operator types them (`get kc`, `set tau_max1 8`).

use flexarm_link::msg::Param;

use crate::client::ConsoleError;

/// Every name with its parameter and unit.
pub const NAMES: [(&str, Param, &str); 18] = [
    ("kp0", Param::Kp(0), "N·m·s/rad"),
    ("kp1", Param::Kp(1), "N·m·s/rad"),
    ("kp2", Param::Kp(2), "(modal row)"),
    ("kp3", Param::Kp(3), "(modal row)"),
    ("lambda0", Param::Lambda(0), "1/s"),
    ("lambda1", Param::Lambda(1), "1/s"),
    ("lambda2", Param::Lambda(2), "1/s"),
    ("lambda3", Param::Lambda(3), "1/s"),
    ("d_delta0", Param::DDelta(0), "1/s"),
    ("d_delta1", Param::DDelta(1), "1/s"),
    ("kc", Param::Kc, "s"),
    ("cutoff_hz", Param::CutoffHz, "Hz"),
    ("tau_max0", Param::TauMax(0), "N·m"),
    ("tau_max1", Param::TauMax(1), "N·m"),
    ("va_max", Param::VaMax, "V"),
    ("va_min", Param::VaMin, "V"),
    ("link_timeout", Param::LinkTimeout, "s"),
    ("va_bias", Param::VaBias, "V"),
];

/// The parameter named `name`, and its unit.
pub fn parse(name: &str) -> Result<(Param, &'static str), ConsoleError> {
    NAMES
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|(_, p, u)| (*p, *u))
        .ok_or_else(|| {
            let all: Vec<&str> = NAMES.iter().map(|(n, _, _)| *n).collect();
            ConsoleError::Usage(format!(
                "no parameter `{name}`; the parameters: {}",
                all.join(", ")
            ))
        })
}
