//! `flexarm shell`: an interactive session on one connection (issue 36), as `moteus_tool` and
//! `odrivetool` offer. Each line is one command as on the command line, without `flexarm` and
//! its connection options; the caller parses and runs it on the connected client. History is
//! the session's own (kept in memory: the shell writes no file); Tab completes command names,
//! their options and subcommands, and parameter names after `get` and `set`.

use rustyline::completion::{Completer, Pair};
use rustyline::error::ReadlineError;
use rustyline::highlight::Highlighter;
use rustyline::hint::Hinter;
use rustyline::history::DefaultHistory;
use rustyline::validate::Validator;
use rustyline::{Context, Editor, Helper};

use crate::client::{Client, ConsoleError};

/// Runs one line's words on the connected client.
pub type RunLine<'a> = dyn FnMut(&mut Client, &[String]) -> Result<(), ConsoleError> + 'a;

/// The words that end a session.
pub const QUIT: &[&str] = &["quit", "exit"];

/// Runs the session: reads lines until `quit`, `exit` or the end of input, and hands each
/// line's words to `run`. A command that fails prints its one line (`flexarm: …`) and the
/// session goes on; Ctrl-C at the prompt clears the line (during a move the console's
/// interrupt handling stops the move, as on the command line).
pub fn run(
    c: &mut Client,
    commands: clap::Command,
    run: &mut RunLine<'_>,
) -> Result<(), ConsoleError> {
    let mut editor: Editor<Completion, DefaultHistory> =
        Editor::new().map_err(|e| ConsoleError::Usage(format!("shell: {e}")))?;
    editor.set_helper(Some(Completion::new(&commands)));
    loop {
        let line = match editor.readline("flexarm> ") {
            Ok(line) => line,
            Err(ReadlineError::Interrupted) => continue,
            Err(ReadlineError::Eof) => return Ok(()),
            Err(e) => return Err(ConsoleError::Usage(format!("shell: {e}"))),
        };
        let Some(words) = shlex::split(&line) else {
            eprintln!("flexarm: shell: unbalanced quotes in {line:?}");
            continue;
        };
        match words.first().map(String::as_str) {
            None => continue,
            Some(w) if QUIT.contains(&w) => return Ok(()),
            Some(_) => {}
        }
        let _ = editor.add_history_entry(line.as_str());
        if let Err(e) = run(c, &words) {
            eprintln!("flexarm: {e}");
        }
    }
}

/// Tab completion from the command line's own definition.
pub struct Completion {
    /// Each command's name with its subcommands' names and its long options.
    commands: Vec<(String, Vec<String>)>,
}

impl Completion {
    /// The completions of `commands` (the console's `clap` definition).
    pub fn new(commands: &clap::Command) -> Self {
        let words = |c: &clap::Command| {
            let subcommands = c.get_subcommands().map(|s| s.get_name().to_string());
            let options = c
                .get_arguments()
                .filter_map(|a| a.get_long().map(|l| format!("--{l}")));
            subcommands.chain(options).collect()
        };
        let mut list: Vec<(String, Vec<String>)> = commands
            .get_subcommands()
            .filter(|c| !c.is_hide_set())
            .map(|c| (c.get_name().to_string(), words(c)))
            .collect();
        list.extend(QUIT.iter().map(|q| (q.to_string(), Vec::new())));
        Self { commands: list }
    }

    /// The candidates for the word that ends `line` (the text before the cursor).
    pub fn candidates(&self, line: &str) -> (usize, Vec<String>) {
        let start = line.rfind(char::is_whitespace).map_or(0, |i| i + 1);
        let (before, word) = line.split_at(start);
        let words: Vec<&str> = before.split_whitespace().collect();
        let names: Vec<String> = match words.as_slice() {
            [] => self.commands.iter().map(|(c, _)| c.clone()).collect(),
            ["get" | "set"] => flexarm_link::params::PARAMS
                .iter()
                .map(|p| p.name)
                .chain(words.first().filter(|w| **w == "get").map(|_| "list"))
                .map(str::to_string)
                .collect(),
            [command, ..] => self
                .commands
                .iter()
                .find(|(c, _)| c == command)
                .map(|(_, w)| w.clone())
                .unwrap_or_default(),
        };
        let mut found: Vec<String> = names.into_iter().filter(|n| n.starts_with(word)).collect();
        found.sort();
        found.dedup();
        (start, found)
    }
}

impl Completer for Completion {
    type Candidate = Pair;

    fn complete(
        &self,
        line: &str,
        pos: usize,
        _: &Context<'_>,
    ) -> rustyline::Result<(usize, Vec<Pair>)> {
        let (start, found) = self.candidates(line.get(..pos).unwrap_or(line));
        let pairs = found
            .into_iter()
            .map(|n| Pair {
                display: n.clone(),
                replacement: n,
            })
            .collect();
        Ok((start, pairs))
    }
}

impl Hinter for Completion {
    type Hint = String;
}
impl Highlighter for Completion {}
impl Validator for Completion {}
impl Helper for Completion {}

#[cfg(test)]
mod tests {
    use super::*;

    fn completion() -> Completion {
        let cli = clap::Command::new("flexarm")
            .subcommand(clap::Command::new("get").arg(clap::Arg::new("name")))
            .subcommand(clap::Command::new("set"))
            .subcommand(
                clap::Command::new("record")
                    .arg(clap::Arg::new("seconds").long("seconds"))
                    .subcommand(clap::Command::new("trapezoid")),
            )
            .subcommand(clap::Command::new("secret").hide(true));
        Completion::new(&cli)
    }

    #[test]
    fn completes_commands_options_and_parameter_names() {
        let c = completion();
        assert_eq!(
            c.candidates(""),
            (
                0,
                vec!["exit", "get", "quit", "record", "set"]
                    .into_iter()
                    .map(String::from)
                    .collect()
            )
        );
        assert_eq!(
            c.candidates("se").1,
            vec!["set"],
            "hidden commands are not offered"
        );
        assert_eq!(
            c.candidates("get k"),
            (
                4,
                vec!["kc", "ki0", "ki1", "kp0", "kp1", "kp2", "kp3"]
                    .into_iter()
                    .map(String::from)
                    .collect()
            )
        );
        assert!(c.candidates("get l").1.contains(&"list".to_string()));
        assert!(!c.candidates("set l").1.contains(&"list".to_string()));
        assert_eq!(c.candidates("set stall").1, vec!["stall_speed_error"]);
        assert_eq!(c.candidates("record --s").1, vec!["--seconds"]);
        assert_eq!(c.candidates("record t").1, vec!["trapezoid"]);
        assert!(c.candidates("nosuch x").1.is_empty());
    }
}
