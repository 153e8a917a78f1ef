//! `--qemu`: the QEMU firmware as a private board for one invocation. Builds the `link-session`
//! firmware of this checkout if needed (it boots disarmed and waits for a host), starts it on
//! QEMU's `netduinoplus2` with its USART1 on a free local TCP port, and stops it when the
//! [`Qemu`] is dropped: at the end of the command, on an error, and after Ctrl-C (the console
//! catches it, stops the arm first and returns normally; QEMU runs in its own process group, so
//! the terminal's Ctrl-C does not kill it before the console has done so).
//!
//! QEMU counts time in instructions (`-icount shift=0,sleep=off`, as the test sessions): the
//! firmware's timeline is its own, deterministic, and skips idle time, so a 4 s move passes in
//! well under a second of the host's; the console waits for the drive's states, not for times.
//! (QEMU's real-time mode, `sleep=on`, which `scripts/qemu-serve` uses for watching, lets the
//! host's load delay the firmware's timer interrupts: recorded there, the paper's trapezoid
//! tracked 4 to 5 times worse than the simulator, against 0.86 times here.) The firmware's defmt
//! log (binary) goes to `target/qemu-console.defmt`; `defmt-print -e target/qemu-console.elf <
//! target/qemu-console.defmt` decodes it.

use std::fs::File;
use std::net::TcpListener;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::client::ConsoleError;
use crate::transport::{self, Link};

/// A running QEMU firmware, stopped on drop.
pub struct Qemu {
    child: Child,
    /// Its USART's address, `127.0.0.1:PORT`.
    pub addr: String,
}

/// The workspace this console was built from.
fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

fn found(program: &str) -> bool {
    Command::new(program)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok()
}

impl Qemu {
    /// Builds the firmware (cargo's no-op when it is current) and starts it: on the host's
    /// clock when `realtime` (the live view: a 2 s move takes 2 s to watch), otherwise on its
    /// own instruction count (module docs).
    /// `features`: more firmware features, for test builds.
    pub fn start(realtime: bool, features: Option<&str>) -> Result<Self, ConsoleError> {
        if !found("qemu-system-arm") {
            return Err(ConsoleError::Usage(
                "--qemu needs qemu-system-arm (Debian: apt-get install qemu-system-arm)".into(),
            ));
        }
        let root = workspace();
        let target =
            std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root.join("target"), PathBuf::from);
        let features = match features {
            Some(f) => format!("link-session,{f}"),
            None => "link-session".into(),
        };
        eprintln!("flexarm: building the QEMU firmware ({features})…");
        let built = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()))
            .current_dir(&root)
            .args([
                "build",
                "-q",
                "--release",
                "-p",
                "flexarm-firmware",
                "--target",
                "thumbv7em-none-eabihf",
                "--no-default-features",
                "--features",
                &features,
            ])
            .stdout(Stdio::null())
            .status()
            .map_err(|e| ConsoleError::Io(format!("cargo: {e}")))?;
        if !built.success() {
            return Err(ConsoleError::Io(format!(
                "the firmware did not build (cargo build -p flexarm-firmware in {})",
                root.display()
            )));
        }
        // A copy of its own: a later build of another firmware variant replaces the original.
        let elf = target.join("qemu-console.elf");
        let original = target.join("thumbv7em-none-eabihf/release/flexarm-firmware");
        std::fs::copy(&original, &elf)
            .map_err(|e| ConsoleError::Io(format!("{}: {e}", original.display())))?;
        let port = TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .map_err(|e| ConsoleError::Io(format!("a free local port: {e}")))?
            .port();
        let log = target.join("qemu-console.defmt");
        let out =
            File::create(&log).map_err(|e| ConsoleError::Io(format!("{}: {e}", log.display())))?;
        let child = Command::new("qemu-system-arm")
            .args([
                "-machine",
                "netduinoplus2",
                "-nographic",
                "-monitor",
                "none",
            ])
            .arg("-serial")
            .arg(format!("tcp:127.0.0.1:{port},server=on,wait=on,nodelay=on"))
            .args(["-semihosting-config", "enable=on,target=native"])
            .arg("-icount")
            .arg(if realtime {
                "shift=0,sleep=on"
            } else {
                "shift=0,sleep=off"
            })
            .arg("-kernel")
            .arg(&elf)
            .stdin(Stdio::null())
            .stdout(out)
            .stderr(Stdio::null())
            .process_group(0)
            .spawn()
            .map_err(|e| ConsoleError::Io(format!("qemu-system-arm: {e}")))?;
        Ok(Self {
            child,
            addr: format!("127.0.0.1:{port}"),
        })
    }

    /// Connects to the firmware's USART: QEMU opens its socket a moment after it starts.
    pub fn connect(&mut self) -> Result<Box<dyn Link>, ConsoleError> {
        let start = Instant::now();
        loop {
            match transport::tcp(&self.addr) {
                Ok(link) => return Ok(link),
                Err(e) if start.elapsed() > Duration::from_secs(10) => return Err(e),
                Err(_) => {}
            }
            if let Ok(Some(status)) = self.child.try_wait() {
                return Err(ConsoleError::Io(format!(
                    "QEMU ended before the firmware's port opened ({status})"
                )));
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
