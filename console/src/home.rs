//! `home` and `home --declare` (issue 33, `docs/safety.md`, "Frames and homing"): every joint's
//! encoder counts from where it was at power-up, so no limit holds in the arm's frame until the
//! drive has homed (or the operator declared the pose); the drive refuses `arm` until then.

use std::time::{Duration, Instant};

use flexarm_link::Command;
use flexarm_link::msg::{HomeState, Mode, Status};

use crate::client::{Client, ConsoleError};
use crate::interrupt;

/// The longest a homing may take before the console disarms [s]: each joint's search travels
/// at most 6.5 rad at 0.2 rad/s by default (33 s), two joints one after the other.
pub const HOMING_TIMEOUT: Duration = Duration::from_secs(90);

/// What an operator reads before the firmware trusts a declared pose.
pub const DECLARE_WARNING: &str = "WARNING: declaring the pose without homing. The drive \
will trust these angles as the arm's own: the soft limits, the sensors' range and the move \
validation then hold only if they are true. A wrong angle lets a move run into an end stop. \
Status shows the joints as DECLARED, not homed.";

/// Whether every joint is homed or declared in `s`.
pub fn known(s: &Status) -> bool {
    s.homing
        .iter()
        .all(|h| matches!(h, HomeState::Homed | HomeState::Declared))
}

/// Homes every joint (`Home`) and waits for the searches to end, polling the status (which
/// also feeds the link watchdog). Returns the status once the drive holds, homed; a failed
/// search, a fault, Ctrl-C (the drive is then disarmed) or [`HOMING_TIMEOUT`] is an error.
pub fn home(c: &mut Client) -> Result<Status, ConsoleError> {
    c.done("home", Command::Home)?;
    let start = Instant::now();
    loop {
        let s = c.status()?;
        match s.mode {
            Mode::Homing => {}
            Mode::Armed if known(&s) => return Ok(s),
            Mode::Fault => {
                return Err(ConsoleError::Failed(format!(
                    "homing: fault {} latched during the search ({}); the safe state holds",
                    s.fault.unwrap_or(0),
                    s.fault.map_or("?", crate::fault_name)
                )));
            }
            _ if s.homing_failed => {
                return Err(ConsoleError::Failed(
                    "homing failed: a joint's search travelled its limit without finding its \
                     reference (index pulse, end stop or switch: check its wiring and the \
                     search direction); the drive is disarmed"
                        .into(),
                ));
            }
            m => {
                return Err(ConsoleError::Failed(format!(
                    "homing ended {m:?} with the joints {:?}",
                    s.homing
                )));
            }
        }
        if interrupt::requested() || start.elapsed() > HOMING_TIMEOUT {
            let _ = c.ask(Command::Disarm)?;
            return Err(ConsoleError::Interrupted(if interrupt::requested() {
                "homing stopped (Ctrl-C); the drive is disarmed, the joints unhomed".into()
            } else {
                format!(
                    "homing did not end within {} s; the drive is disarmed",
                    HOMING_TIMEOUT.as_secs()
                )
            }));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Declares the pose now to be `theta` [rad] in the arm's frame (`DeclareHome`), disarmed.
pub fn declare(c: &mut Client, theta: [f32; 2]) -> Result<Status, ConsoleError> {
    c.done("declare the pose", Command::DeclareHome { theta })?;
    c.status()
}
