//! The board's settings as a file: `config dump` writes every tunable parameter's value (with its
//! unit, range and the build's default when the console can reproduce the build), `config diff
//! FILE` compares a board with a dump, `config restore FILE` writes a dump's values back (at rest,
//! validated by the firmware one by one). The file is TOML, one key per parameter under
//! `[params]`, by the names of `get` (`docs/console.md`). Saving to the board's flash is not
//! implemented: a board boots with its build's values.

use std::collections::BTreeMap;
use std::path::Path;

use flexarm_beam::toml_at::{at_line, de_error};
use flexarm_link::msg::{Hello, Param};
use flexarm_link::params::PARAMS;
use flexarm_machine::BoardConfig;
use serde::{Deserialize, Serialize};

use crate::client::{Client, ConsoleError};

/// A dump: who it was read from, and the values.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Dump {
    /// The firmware's build and board.
    pub firmware: String,
    /// The build's parameters' hash (`BoardConfig::hash`), hexadecimal.
    pub params_hash: String,
    /// Every parameter's value, by its name.
    pub params: BTreeMap<String, f32>,
}

/// The build's configuration when the console can reproduce it: the paper's fragment's for the
/// board (`firmware/piezo.toml`), or `model`'s text, when it gives the handshake's hash.
pub fn build_config(hello: &Hello, model: Option<&str>) -> Option<BoardConfig> {
    let config = match model {
        Some(text) => flexarm_host::firmware_params::design(text)
            .ok()?
            .board(hello.board),
        None => flexarm_host::firmware_params::paper_board(hello.board).ok()?,
    };
    (config.hash() == hello.params_hash).then_some(config)
}

/// Every parameter's value on the board, in the declaration's order.
pub fn read(c: &mut Client) -> Result<Vec<(Param, f32)>, ConsoleError> {
    PARAMS
        .iter()
        .map(|p| c.get(p.param).map(|v| (p.param, v)))
        .collect()
}

/// The dump's text: a header naming the firmware, then `[params]`, each line its value and, as
/// a comment, its unit, range and the build's default (`?` when the build is not reproduced;
/// `*` marks a value that differs from it).
pub fn text(hello: &Hello, values: &[(Param, f32)], build: Option<&BoardConfig>) -> String {
    let mut out = format!(
        "# flexarm config dump (flexarm config restore FILE writes it back)\nfirmware = \"{} on {:?}\"\nparams_hash = \"{:08x}\"\n\n[params]\n",
        hello.build, hello.board, hello.params_hash
    );
    for &(p, v) in values {
        let info = p.info();
        let default = build.and_then(|b| b.param(p));
        let (mark, default) = match default {
            Some(d) if d.to_bits() != v.to_bits() => ("*", format!("{d}")),
            Some(d) => ("", format!("{d}")),
            None => ("", "?".into()),
        };
        out.push_str(&format!(
            "{} = {v:?} # {mark}[{}] {} … {}, build default {default}\n",
            info.name, info.unit, info.range.0, info.range.1
        ));
    }
    out
}

/// Reads a dump file: every key a parameter, every value finite and within its declared range;
/// an error names the file, the line and the key.
pub fn parse(path: &Path) -> Result<Vec<(Param, f32)>, ConsoleError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| ConsoleError::Usage(format!("{}: {e}", path.display())))?;
    let bad = |msg: String| ConsoleError::Usage(at_line(path, &text, &msg));
    let dump: Dump = toml::from_str(&text).map_err(|e| bad(de_error(&text, &e)))?;
    let mut out = Vec::new();
    for (name, v) in &dump.params {
        let p = Param::named(name).ok_or_else(|| {
            bad(format!(
                "`params.{name}`: no such parameter (flexarm get list)"
            ))
        })?;
        let (lo, hi) = p.info().range;
        if !(lo..=hi).contains(v) {
            return Err(bad(format!(
                "`params.{name}`: {v} is outside its range {lo} … {hi} {}",
                p.info().unit
            )));
        }
        out.push((p, *v));
    }
    Ok(out)
}

/// The parameters whose values differ between `a` (the board's) and `b` (a file's), with both;
/// a parameter the file does not hold is not compared.
pub fn diff(board: &[(Param, f32)], file: &[(Param, f32)]) -> Vec<(Param, f32, f32)> {
    file.iter()
        .filter_map(|&(p, f)| {
            let (_, b) = board.iter().find(|(q, _)| *q == p)?;
            (b.to_bits() != f.to_bits()).then_some((p, *b, f))
        })
        .collect()
}

/// Writes `values` to the board at rest, in passes: a value refused as out of range while the
/// others are still the old ones (a `K_p` pair that is stable only together) is tried again
/// after the rest; stops at a refusal that no pass clears, naming the parameter. `va_bias` is
/// not restored (a holding's transient, 0 once the drive leaves holding). Returns the names
/// written.
pub fn restore(c: &mut Client, values: &[(Param, f32)]) -> Result<Vec<&'static str>, ConsoleError> {
    let mut left: Vec<(Param, f32)> = values
        .iter()
        .copied()
        .filter(|(p, _)| *p != Param::VaBias)
        .collect();
    let mut written = Vec::new();
    while !left.is_empty() {
        let before = left.len();
        let mut refused = Vec::new();
        let mut first = None;
        for (p, v) in left {
            match c.set(p, v) {
                Ok(()) => written.push(p.info().name),
                Err(e @ ConsoleError::Refused { .. }) => {
                    first.get_or_insert(e);
                    refused.push((p, v));
                }
                Err(e) => return Err(e),
            }
        }
        if let Some(e) = first.filter(|_| refused.len() == before) {
            return Err(e);
        }
        left = refused;
    }
    Ok(written)
}
