//! `flexarm tree`: every value the board reports, by name (issue 36; tview's left pane): the
//! handshake, the status (each field as the link names it: a field added to the protocol shows
//! here without a change), every parameter with its unit, and one telemetry frame of every
//! channel with its unit and meaning. As TOML, so a script can read it too.

use std::fmt::Write as _;
use std::time::{Duration, Instant};

use flexarm_link::msg::{CHANNELS, Channels, Hello, Status};
use flexarm_link::params::PARAMS;
use flexarm_link::{Command, Reply};
use serde::Serialize;

use crate::client::{Client, ConsoleError};

/// How long `tree` waits for a telemetry frame.
const FRAME_WAIT: Duration = Duration::from_secs(2);

#[derive(Serialize)]
struct Reported<'a> {
    hello: &'a Hello,
    status: &'a Status,
}

/// The tree of the board on `c`.
pub fn tree(c: &mut Client) -> Result<String, ConsoleError> {
    let status = c.status()?;
    let mut out = toml::to_string(&Reported {
        hello: &c.hello,
        status: &status,
    })
    .map_err(|e| ConsoleError::Unexpected(format!("the status as TOML: {e}")))?;
    if status.fault.is_none() {
        // (TOML has no null: a missing key would read as a field the board did not send.)
        out = out.replacen("[status]\n", "[status]\nfault = \"none\"\n", 1);
    }
    out.push_str("\n[parameters]\n");
    for p in PARAMS {
        let v = c.get(p.param)?;
        let _ = writeln!(out, "{} = {v:?} # [{}]", p.name, p.unit);
    }
    out.push_str("\n[telemetry]\n");
    match frame(c)? {
        Ok(t) => {
            let _ = writeln!(out, "tick = {}", t.tick);
            for ch in &CHANNELS {
                let values: Vec<String> = (0..ch.width)
                    .filter_map(|j| t.value(ch.bit, j))
                    .map(|v| format!("{v:?}"))
                    .collect();
                let _ = writeln!(
                    out,
                    "{} = [{}] # [{}] {}",
                    ch.name,
                    values.join(", "),
                    ch.unit,
                    ch.doc
                );
            }
        }
        Err(why) => {
            let _ = writeln!(out, "# no frame: {why}");
        }
    }
    Ok(out)
}

/// One telemetry frame of every channel (subscribed at a frame every `motor_hz` motor periods
/// at most 1000, waited for, unsubscribed), or why there is none.
fn frame(c: &mut Client) -> Result<Result<flexarm_link::msg::Telemetry, String>, ConsoleError> {
    c.take_telemetry();
    let decimation = u16::try_from(c.hello.motor_hz.clamp(1, 1000)).unwrap_or(1000);
    let subscribed = c.ask(Command::Subscribe {
        decimation,
        channels: Channels(Channels::ALL),
    })?;
    if let Reply::Refused(why) = subscribed {
        return Ok(Err(format!(
            "the board refused the subscription ({})",
            crate::client::refusal(why)
        )));
    }
    let start = Instant::now();
    let mut got = None;
    while got.is_none() && start.elapsed() < FRAME_WAIT {
        c.pump(Duration::from_millis(50))?;
        got = c
            .take_telemetry()
            .into_iter()
            .find(|t| t.channels.0 == Channels::ALL);
    }
    c.ask(Command::Unsubscribe)?;
    Ok(got.ok_or_else(|| format!("none came in {} s", FRAME_WAIT.as_secs())))
}
