//! What the command-line tools (`flexarm-sim`, the console's `flexarm`) share about failing.

/// Makes any panic one line on stderr, `TOOL: internal error at FILE:LINE: MESSAGE`, instead
/// of a trace; and a closed stdout (`… | head`) end the tool quietly with status 141, as
/// SIGPIPE ends other Unix tools (Rust ignores SIGPIPE, so `println!` panics instead).
pub fn one_line_panics(tool: &'static str) {
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let msg = payload
            .downcast_ref::<&str>()
            .map(|s| (*s).to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        if msg.contains("Broken pipe") {
            std::process::exit(141);
        }
        let at = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        eprintln!("{tool}: internal error{at}: {msg} (a bug: please report it)");
    }));
}
