//! Ctrl-C: the console catches it, so that a running move is stopped (category 1, the drive's
//! controlled stop) before the tool exits, and a QEMU it started is shut down by its guard.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use flexarm_link::msg::{Mode, Status, Telemetry};
use flexarm_link::{Command, Reply};

use crate::client::{Client, ConsoleError};

static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Catches Ctrl-C from now on (a second handler is not installed).
pub fn install() {
    let _ = ctrlc::set_handler(|| INTERRUPTED.store(true, Ordering::SeqCst));
}

/// Whether Ctrl-C was pressed.
pub fn requested() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// Stops the arm: a controlled stop of a running move, waited for until the drive holds (at
/// most 10 s, then the safe state).
pub fn stop_arm(c: &mut Client) -> Result<(), ConsoleError> {
    let _ = c.ask(Command::Stop)?;
    let start = Instant::now();
    loop {
        match c.request("status", Command::Status)? {
            Reply::Status(s) if matches!(s.mode, Mode::Moving | Mode::Stopping) => {}
            Reply::Status(_) => return Ok(()),
            r => return Err(ConsoleError::Unexpected(format!("{r:?}"))),
        }
        if start.elapsed() > Duration::from_secs(10) {
            let _ = c.ask(Command::Estop)?;
            return Err(ConsoleError::Interrupted(
                "the stop did not end within 10 s: emergency stop sent".into(),
            ));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Follows the running move until the drive leaves moving and stopping, keeping the telemetry
/// in `frames`; returns the status it ended in. Ctrl-C stops the arm and ends it with an error
/// saying `what` was cut short; after `limit`, an emergency stop.
pub fn follow_move(
    c: &mut Client,
    what: &str,
    frames: &mut Vec<Telemetry>,
    limit: Duration,
) -> Result<Status, ConsoleError> {
    let start = Instant::now();
    loop {
        if requested() {
            stop_arm(c)?;
            return Err(ConsoleError::Interrupted(format!(
                "{what}: the arm was stopped short (Ctrl-C)"
            )));
        }
        c.pump(Duration::from_millis(20))?;
        let s = c.status()?;
        frames.extend(c.take_telemetry());
        if !matches!(s.mode, Mode::Moving | Mode::Stopping) {
            return Ok(s);
        }
        if start.elapsed() > limit {
            c.ask(Command::Estop)?;
            return Err(ConsoleError::Timeout(format!(
                "{what} to end within {} s (emergency stop sent)",
                limit.as_secs()
            )));
        }
    }
}
