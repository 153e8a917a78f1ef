//! Ctrl-C: the console catches it, so that a running move is stopped (category 1, the drive's
//! controlled stop) before the tool exits, and a QEMU it started is shut down by its guard. And
//! the two ways a command waits on the arm, both Ctrl-C aware: [`collect`] (telemetry over a
//! span of the firmware's time) and [`follow_move`] (a move to its end).

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use flexarm_link::Command;
use flexarm_link::msg::{Mode, Status, Telemetry};

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
        if !matches!(c.status()?.mode, Mode::Moving | Mode::Stopping) {
            return Ok(());
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

/// Telemetry over `seconds` of the firmware's time (its ticks; 0: the first frames), the line
/// kept busy. Ctrl-C stops the arm and ends it with an error; a stream that stops is a timeout,
/// never a hang.
pub fn collect(c: &mut Client, seconds: f64) -> Result<Vec<Telemetry>, ConsoleError> {
    collect_within(c, seconds, Duration::from_millis(20))
}

/// [`collect`] reading the line for at most `budget` between two looks at the ticks: a short
/// wait (a tap's few motor periods) ends on time on a firmware whose clock outruns the host's
/// (QEMU's, where 20 ms of the host's are over half a second of the firmware's).
pub fn collect_within(
    c: &mut Client,
    seconds: f64,
    budget: Duration,
) -> Result<Vec<Telemetry>, ConsoleError> {
    let mut frames: Vec<Telemetry> = Vec::new();
    let periods = (seconds * f64::from(c.hello.motor_hz)).round() as u64;
    let deadline = Instant::now() + Duration::from_secs_f64(seconds * 2.0 + 5.0);
    loop {
        if requested() {
            stop_arm(c)?;
            return Err(ConsoleError::Interrupted(
                "the arm was stopped (Ctrl-C)".into(),
            ));
        }
        c.pump(budget)?;
        frames.extend(c.take_telemetry());
        if let (Some(a), Some(b)) = (frames.first(), frames.last())
            && b.tick >= a.tick + periods
        {
            return Ok(frames);
        }
        if Instant::now() > deadline {
            return Err(ConsoleError::Timeout(format!(
                "{seconds} s of telemetry ({} frames came)",
                frames.len()
            )));
        }
        c.ask(Command::Ping)?;
        frames.extend(c.take_telemetry());
    }
}

/// Follows the running move until the drive leaves moving and stopping, keeping the telemetry
/// in `frames`; returns the status it ended in. Ctrl-C stops the arm and ends it with an error
/// naming `what`; past `limit`, if given, an emergency stop.
pub fn follow_move(
    c: &mut Client,
    what: &str,
    frames: &mut Vec<Telemetry>,
    limit: Option<Duration>,
) -> Result<Status, ConsoleError> {
    let start = Instant::now();
    loop {
        if requested() {
            stop_arm(c)?;
            return Err(ConsoleError::Interrupted(format!(
                "{what}: the arm was stopped short of the move's end"
            )));
        }
        c.pump(Duration::from_millis(20))?;
        let s = c.status()?;
        frames.extend(c.take_telemetry());
        if !matches!(s.mode, Mode::Moving | Mode::Stopping) {
            return Ok(s);
        }
        if let Some(limit) = limit
            && start.elapsed() > limit
        {
            c.ask(Command::Estop)?;
            return Err(ConsoleError::Timeout(format!(
                "{what} to end within {} s (emergency stop sent)",
                limit.as_secs()
            )));
        }
    }
}
