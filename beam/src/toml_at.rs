//! Where a TOML file says something, for errors of one line, `<file>:<line>: `<key>`: <what is
//! wrong>`: the line and the key path at a byte offset (what a `toml` error's span gives), and
//! the line of a key path (what a check after parsing names). Every flexarm reader of a TOML
//! file reports through it: scenario files, the optimizer's configuration, `[piezo]`
//! fragments, model files, a recording's description.
//!
//! Key paths are dotted, an array element by its index: `plant.zeta`, `optimize.k_c[1]`,
//! `piezo.computed.mass_integral[0]`; `name[]` stands for some element of `name`. A check after
//! parsing starts its message with the path of the key it is about, in backticks, or with
//! `[table]: ` (the line of that key or table is found here); a key the file does not write
//! (a default that fails) is placed at another key the message names that the file writes
//! (the one it fails against), else at its table's header.

use std::ops::Range;
use std::path::Path;

use serde::{Deserialize, Deserializer, de::Error as _};
use toml::de::{DeTable, DeValue};

/// A TOML text and, when it parses, the spans of its keys and values.
pub struct Doc<'a> {
    text: &'a str,
    root: Option<DeTable<'a>>,
}

impl<'a> Doc<'a> {
    /// The document `text` (a text that does not parse has lines but no keys).
    pub fn new(text: &'a str) -> Self {
        let root = DeTable::parse(text).ok().map(toml::Spanned::into_inner);
        Self { text, root }
    }

    /// The 1-based line of the byte `offset`.
    pub fn line(&self, offset: usize) -> usize {
        let end = offset.min(self.text.len());
        1 + self.text.as_bytes()[..end]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
    }

    /// The path of the innermost key or value at the byte `offset` (an array element by its
    /// index); for a text that does not parse, the key written on that line under the table
    /// header above it.
    pub fn path_at(&self, offset: usize) -> Option<String> {
        match &self.root {
            Some(root) => find_in_table(root, offset, ""),
            None => self.written_at(offset),
        }
    }

    /// The line of the key path `path` and whether the file writes it: the key's own line, or
    /// that of the deepest table (or array) of the path that the file writes.
    pub fn line_of(&self, path: &str) -> Option<(usize, bool)> {
        let root = self.root.as_ref()?;
        let segments = segments(path);
        let mut table = Some(root);
        let mut array: Option<&toml::de::DeArray<'_>> = None;
        let mut deepest = None;
        for (n, seg) in segments.iter().enumerate() {
            let (span, value) = match (seg, table, array) {
                (Segment::Key(k), Some(t), _) => {
                    match t.iter().find(|(key, _)| key.get_ref() == k) {
                        Some((key, v)) => (key.span(), v.get_ref()),
                        None => break,
                    }
                }
                (Segment::Index(i), _, Some(a)) => match a.get(*i) {
                    Some(v) => (v.span(), v.get_ref()),
                    None => break,
                },
                _ => break,
            };
            deepest = Some((self.line(span.start), n + 1 == segments.len()));
            (table, array) = match value {
                DeValue::Table(t) => (Some(t), None),
                DeValue::Array(a) => (None, Some(a)),
                _ => (None, None),
            };
        }
        deepest
    }

    /// The key written on the line of `offset` (`key = …`, or a `[table]` header), under the
    /// last table header above it: for a text whose tree is not there.
    fn written_at(&self, offset: usize) -> Option<String> {
        let line = self.line(offset);
        let mut table = String::new();
        for (i, raw) in self.text.lines().enumerate().take(line) {
            let t = raw.trim();
            if let Some(h) = header(t) {
                table = h.to_string();
                if i + 1 == line {
                    return Some(table);
                }
            } else if i + 1 == line {
                let key = t.split_once('=').map(|(k, _)| k.trim())?;
                return (!key.is_empty()).then(|| join(&table, key));
            }
        }
        None
    }

    /// The line of a message's subject and the message to show: `` `key` … `` (its key's
    /// line), `[table]: …` (the table's, or that of `` `key` `` when the message goes on with
    /// one of that table's keys). A key the file does not write gives way to another key the
    /// message names that it does write (`` `a.x` must be below `y` ``: `a.y`, relative to the
    /// first key's table), then to the first key's table.
    fn subject<'m>(&self, msg: &'m str) -> Option<(usize, &'m str)> {
        let (table, rest) = match msg.strip_prefix('[').and_then(|r| r.split_once("]: ")) {
            Some((t, r)) => (Some(t), r),
            None => (None, msg),
        };
        // The keys the message names, in order: `key`, `key = …`, `key[1]`.
        let keys: Vec<&str> = rest
            .split('`')
            .skip(1)
            .step_by(2)
            .filter_map(|k| k.split([' ', '=']).next())
            .filter(|k| !k.is_empty())
            .collect();
        let first = rest.starts_with('`').then(|| keys.first()).flatten();
        let first_table = first.and_then(|k| k.rsplit_once('.')).map(|(t, _)| t);
        let candidates = keys.iter().flat_map(|k| {
            [
                Some(k.to_string()),
                table.map(|t| join(t, k)),
                first_table.map(|t| join(t, k)),
            ]
        });
        let exact = candidates
            .filter_map(|c| self.line_of(&c?))
            .find(|(_, exact)| *exact);
        let line = exact
            .or_else(|| first.and_then(|k| self.line_of(k)))
            .or_else(|| table.and_then(|t| self.line_of(t)))
            .map(|(l, _)| l)?;
        // "[rates]: `rates.plant_dt`: …" reads as "`rates.plant_dt`: …".
        Some((line, if first.is_some() { rest } else { msg }))
    }
}

fn covers(span: &Range<usize>, offset: usize) -> bool {
    span.start <= offset && offset < span.end
}

fn join(table: &str, key: &str) -> String {
    if table.is_empty() {
        key.to_string()
    } else {
        format!("{table}.{key}")
    }
}

/// The innermost entry of `t` (whose path is `path`) at `offset`.
fn find_in_table(t: &DeTable, offset: usize, path: &str) -> Option<String> {
    t.iter().find_map(|(k, v)| {
        let p = join(path, k.get_ref());
        find_in_value(v.get_ref(), offset, &p)
            .or_else(|| (covers(&k.span(), offset) || covers(&v.span(), offset)).then_some(p))
    })
}

fn find_in_value(v: &DeValue, offset: usize, path: &str) -> Option<String> {
    match v {
        DeValue::Table(t) => find_in_table(t, offset, path),
        DeValue::Array(a) => a.iter().enumerate().find_map(|(i, e)| {
            let p = format!("{path}[{i}]");
            find_in_value(e.get_ref(), offset, &p)
                .or_else(|| covers(&e.span(), offset).then_some(p))
        }),
        _ => None,
    }
}

/// The name of a `[table]` or `[[array]]` header line.
fn header(line: &str) -> Option<&str> {
    let inner = line.strip_prefix('[')?.split(']').next()?;
    Some(inner.trim_start_matches('[').trim())
}

enum Segment<'p> {
    Key(&'p str),
    Index(usize),
}

/// `a.b[1].c` as `a`, `b`, `1`, `c`; `b[]` as `b`.
fn segments(path: &str) -> Vec<Segment<'_>> {
    let mut out = Vec::new();
    for part in path.split('.') {
        let mut pieces = part.split('[');
        if let Some(k) = pieces.next() {
            out.push(Segment::Key(k.trim()));
        }
        for index in pieces {
            if let Ok(i) = index.trim_end_matches(']').parse() {
                out.push(Segment::Index(i));
            }
        }
    }
    out
}

/// One line from a `toml` error of the text `text`: `line N: `key`: message`, the key being the
/// one at the error's place (the one a `missing field` names, under its table).
pub fn de_error(text: &str, e: &toml::de::Error) -> String {
    let msg = shorten_numbers(&e.message().trim().replace('\n', " "));
    let Some(span) = e.span() else {
        return msg;
    };
    let doc = Doc::new(text);
    // An empty span is the document's (a missing key of the top level).
    let at = (!span.is_empty())
        .then(|| doc.path_at(span.start))
        .flatten();
    let key = match msg
        .strip_prefix("missing field `")
        .and_then(|r| r.split('`').next())
    {
        Some(field) => Some(join(at.as_deref().unwrap_or(""), field)),
        None => at,
    };
    let line = doc.line(span.start);
    let out = match key {
        Some(k) => format!("line {line}: `{k}`: {msg}"),
        None => format!("line {line}: {msg}"),
    };
    printable(&out)
}

/// `s` with its control characters escaped (`\n`, `\u{7}`): a key may be a quoted string
/// holding any of them, and an error stays one line (found by `cargo fuzz run scenario`).
fn printable(s: &str) -> String {
    s.chars()
        .flat_map(|c| {
            let escaped = c.is_control().then(|| c.escape_default());
            escaped
                .into_iter()
                .flatten()
                .chain((!c.is_control()).then_some(c))
        })
        .collect()
}

/// An error about the TOML file `file` (of content `text`) as `<file>:<line>: <message>`: the
/// line a `line N: ` prefix gives (from [`de_error`]), else that of the key or table the
/// message starts with (module docs); without either, `<file>: <message>`.
pub fn at_line(file: &Path, text: &str, msg: &str) -> String {
    let numbered = msg.strip_prefix("line ").and_then(|rest| {
        let (n, m) = rest.split_once(": ")?;
        Some((n.parse::<usize>().ok()?, m))
    });
    let shown = file.display();
    let msg = shorten_numbers(msg);
    match numbered.or_else(|| Doc::new(text).subject(&msg)) {
        Some((line, m)) => format!("{shown}:{line}: {}", shorten_numbers(m)),
        None => format!("{shown}: {msg}"),
    }
}

/// A number as a person reads it in a message: plain, or in exponent form when very large or
/// small (`1e300`, not three hundred digits), to nine significant digits (`3.14159265`, not
/// the seventeen of `f64::consts::PI`).
pub fn number(v: f64) -> String {
    let v = format!("{v:.8e}").parse().unwrap_or(v);
    if v != 0.0 && v.is_finite() && !(1e-4..1e7).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// `` `key` = v unit is outside lo to hi unit ``: the message of a value outside its range.
pub fn outside(key: &str, v: f64, lo: f64, hi: f64, unit: &str) -> String {
    format!("`{key}` = {}", outside_range(v, lo, hi, unit))
}

/// `v unit is outside lo to hi unit`, for a message that names its key apart.
pub fn outside_range(v: f64, lo: f64, hi: f64, unit: &str) -> String {
    let unit = if unit.is_empty() {
        String::new()
    } else {
        format!(" {unit}")
    };
    format!(
        "{}{unit} is outside {} to {}{unit}",
        number(v),
        number(lo),
        number(hi)
    )
}

/// A list of exactly `N` values, for `#[serde(deserialize_with = "…")]`: serde's `[T; N]` reads
/// the first `N` of a longer TOML list and drops the rest without a word; here a list of any
/// other length is refused, naming its length (the error keeps the list's place).
pub fn array<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    let list = Vec::<T>::deserialize(d)?;
    let n = list.len();
    list.try_into()
        .map_err(|_| D::Error::invalid_length(n, &format!("exactly {N} values").as_str()))
}

/// [`array`] for an optional key (with `#[serde(default)]`).
pub fn option_array<'de, D, T, const N: usize>(d: D) -> Result<Option<[T; N]>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    array(d).map(Some)
}

/// Longest number a message shows as written; a longer one is shown by [`number`].
const LONGEST_NUMBER: usize = 20;

/// Length of the number `s` starts with: digits, `.` and `_`, then an exponent if one follows.
fn number_len(s: &str) -> usize {
    let mantissa = s
        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '_'))
        .unwrap_or(s.len());
    let exponent = s[mantissa..].strip_prefix(['e', 'E']).map_or(0, |t| {
        let sign = usize::from(t.starts_with(['+', '-']));
        let digits = t[sign..]
            .find(|c: char| !c.is_ascii_digit())
            .unwrap_or(t.len() - sign);
        if digits > 0 { 1 + sign + digits } else { 0 }
    });
    mantissa + exponent
}

/// `msg` with every number longer than [`LONGEST_NUMBER`] characters (a value echoed as the
/// file wrote it, `1000…0`) in exponent form.
pub fn shorten_numbers(msg: &str) -> String {
    let mut out = String::with_capacity(msg.len());
    let mut rest = msg;
    while let Some(start) = rest.find(|c: char| c.is_ascii_digit()) {
        let (before, from) = rest.split_at(start);
        out.push_str(before);
        let token = &from[..number_len(from)];
        match token.replace('_', "").parse::<f64>() {
            Ok(v) if token.len() > LONGEST_NUMBER => out.push_str(&number(v)),
            _ => out.push_str(token),
        }
        rest = &from[token.len()..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "name = \"x\"\n\n[plant]\nkind = \"truth\"\nzeta = [\n  0.1,\n  0.2,\n]\n\n[plant.sub]\na.b = 1\nw = { x = 2 }\n";

    /// A quoted key may hold a newline: the error escapes it and stays one line (the scenario
    /// fuzz target found it).
    #[test]
    #[allow(clippy::panic)]
    fn a_key_with_a_newline_gives_a_one_line_error() {
        #[derive(Debug, serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)]
        struct Only {
            name: String,
        }
        let text = "name = \"x\"\n\"a\\nb\" = 1\n";
        let Err(e) = toml::from_str::<Only>(text) else {
            panic!("an unknown key is refused");
        };
        let msg = de_error(text, &e);
        assert!(!msg.contains('\n') && msg.contains("a\\nb"), "{msg}");
        assert!(msg.starts_with("line 2: "), "{msg}");
    }

    #[test]
    fn a_line_starts_after_its_newline() {
        let d = Doc::new(TEXT);
        assert_eq!(d.line(0), 1);
        // `[plant]` starts line 3, at column 0: the line of its first byte is 3.
        let at = TEXT.find("[plant]").unwrap_or(0);
        assert_eq!(d.line(at), 3);
        assert_eq!(d.line(at - 1), 2);
    }

    #[test]
    fn offsets_name_their_innermost_key() {
        let d = Doc::new(TEXT);
        let at = |s: &str| d.path_at(TEXT.find(s).unwrap_or(0));
        assert_eq!(at("kind").as_deref(), Some("plant.kind"));
        assert_eq!(at("\"truth\"").as_deref(), Some("plant.kind"));
        assert_eq!(at("[plant]").as_deref(), Some("plant"));
        assert_eq!(at("0.2").as_deref(), Some("plant.zeta[1]"));
        assert_eq!(at("[plant.sub]").as_deref(), Some("plant.sub"));
        assert_eq!(at("b = 1").as_deref(), Some("plant.sub.a.b"));
        assert_eq!(at("x = 2").as_deref(), Some("plant.sub.w.x"));
        assert_eq!(at("\n\n[plant]"), None);
    }

    #[test]
    fn paths_name_their_line_or_their_table() {
        let d = Doc::new(TEXT);
        assert_eq!(d.line_of("name"), Some((1, true)));
        assert_eq!(d.line_of("plant"), Some((3, true)));
        assert_eq!(d.line_of("plant.zeta"), Some((5, true)));
        assert_eq!(d.line_of("plant.zeta[1]"), Some((7, true)));
        assert_eq!(d.line_of("plant.zeta[]"), Some((5, true)));
        assert_eq!(d.line_of("plant.zeta[5]"), Some((5, false)));
        assert_eq!(d.line_of("plant.modes"), Some((3, false)));
        assert_eq!(d.line_of("plant.sub.w.x"), Some((12, true)));
        assert_eq!(d.line_of("rates.plant_dt"), None);
    }

    #[test]
    fn messages_find_their_subject() {
        let f = Path::new("f.toml");
        for (msg, want) in [
            (
                "`plant.zeta[1]` = 2 is out",
                "f.toml:7: `plant.zeta[1]` = 2 is out",
            ),
            ("`plant.modes`: must be", "f.toml:3: `plant.modes`: must be"),
            ("[plant]: `kind`: bad", "f.toml:4: `kind`: bad"),
            ("[plant]: cannot", "f.toml:3: [plant]: cannot"),
            ("line 9: `x`: y", "f.toml:9: `x`: y"),
            ("no such thing", "f.toml: no such thing"),
        ] {
            assert_eq!(at_line(f, TEXT, msg), want);
        }
    }

    #[test]
    fn long_numbers_are_shortened() {
        let big = format!("`k` = 1{} s is outside 0 to 100000 s", "0".repeat(300));
        assert_eq!(
            shorten_numbers(&big),
            "`k` = 1e300 s is outside 0 to 100000 s"
        );
        assert_eq!(shorten_numbers("1.5e-7 and 2"), "1.5e-7 and 2");
        let small = format!("0.{}1", "0".repeat(40));
        assert_eq!(shorten_numbers(&small), "1e-41");
        assert_eq!(shorten_numbers("line 12, k_c[3]"), "line 12, k_c[3]");
    }
}
