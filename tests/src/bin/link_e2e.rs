//! End to end over the command link: the QEMU firmware (started by `scripts/qemu-link`, which
//! passes the TCP port of its USART) driven from the host. `cargo fw-link` runs it.
//!
//! Checks, in order: the handshake (and its refusal of another protocol version); the status;
//! garbage, a corrupted frame and an oversized frame on the line, after which a ping is still
//! answered; a command this firmware does not implement yet is refused as such; a telemetry
//! subscription (made first: the run lasts half a second of the host's time) whose frames
//! arrive with no sequence gap until the run ends, with the tracking errors of the boot move
//! within the QEMU run's bound. Prints one line per check; exit status
//! 0 only if all pass.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use flexarm_link::msg::{Board, Channels, Command, Mode, Refusal, Reply, Telemetry};
use flexarm_link::{Decoder, DeviceMsg, MAX_FRAME, Request, VERSION, encode};

/// The QEMU run's bound on |θ − θ_d| (firmware/src/verdict.rs) [rad].
const MAX_ERROR: f32 = 0.015;

struct Link {
    stream: TcpStream,
    decoder: Decoder,
    next_id: u16,
    telemetry: Vec<Telemetry>,
}

impl Link {
    fn send(&mut self, command: Command) -> Result<u16, String> {
        self.next_id = self.next_id.wrapping_add(1);
        let mut buf = [0u8; MAX_FRAME];
        let f = encode(
            &Request {
                id: self.next_id,
                command,
            },
            &mut buf,
        )
        .map_err(|e| e.to_string())?;
        self.stream.write_all(f).map_err(|e| format!("send: {e}"))?;
        Ok(self.next_id)
    }

    /// Reads until a message arrives; `None` when the firmware closed the line.
    fn next(&mut self) -> Result<Option<DeviceMsg>, String> {
        let mut byte = [0u8; 1];
        loop {
            match self.stream.read(&mut byte) {
                Ok(0) => return Ok(None),
                Ok(_) => {}
                Err(e) => return Err(format!("receive: {e}")),
            }
            match self.decoder.push::<DeviceMsg>(byte[0]) {
                Some(Ok(m)) => return Ok(Some(m)),
                Some(Err(e)) => return Err(format!("a bad frame from the firmware: {e}")),
                None => {}
            }
        }
    }

    /// Sends `command` and returns its reply (telemetry arriving meanwhile is kept).
    fn ask(&mut self, command: Command) -> Result<Reply, String> {
        let id = self.send(command)?;
        loop {
            match self.next()? {
                Some(DeviceMsg::Reply { id: got, reply }) if got == id => return Ok(reply),
                Some(DeviceMsg::Reply { id: got, .. }) => {
                    return Err(format!("a reply to request {got} while waiting for {id}"));
                }
                Some(DeviceMsg::Telemetry(t)) => self.telemetry.push(t),
                None => return Err("the firmware closed the line before replying".into()),
            }
        }
    }
}

fn check(ok: bool, what: &str, detail: impl std::fmt::Display) -> Result<(), String> {
    if ok {
        println!("link-e2e: ok   {what}: {detail}");
        Ok(())
    } else {
        Err(format!("{what}: {detail}"))
    }
}

fn connect(port: u16) -> Result<TcpStream, String> {
    let start = Instant::now();
    loop {
        match TcpStream::connect(("127.0.0.1", port)) {
            Ok(s) => return Ok(s),
            Err(e) if start.elapsed() > Duration::from_secs(30) => {
                return Err(format!("cannot connect to QEMU on port {port}: {e}"));
            }
            Err(_) => std::thread::sleep(Duration::from_millis(50)),
        }
    }
}

fn run(port: u16) -> Result<(), String> {
    let stream = connect(port)?;
    stream
        .set_read_timeout(Some(Duration::from_secs(60)))
        .map_err(|e| e.to_string())?;
    let mut link = Link {
        stream,
        decoder: Decoder::new(),
        next_id: 0,
        telemetry: Vec::new(),
    };

    // The handshake, repeated until the firmware answers: bytes that arrive before it has
    // enabled its USART are lost, as on a board that is still booting.
    let start = Instant::now();
    link.stream
        .set_read_timeout(Some(Duration::from_millis(5)))
        .map_err(|e| e.to_string())?;
    let hello = loop {
        if start.elapsed() > Duration::from_secs(30) {
            return Err("no answer to the handshake in 30 s".into());
        }
        let id = link.send(Command::Hello { version: VERSION })?;
        match link.next() {
            Ok(Some(DeviceMsg::Reply { id: got, reply })) if got == id => break reply,
            Ok(Some(_)) | Err(_) => continue,
            Ok(None) => return Err("the firmware closed the line during the handshake".into()),
        }
    };
    link.stream
        .set_read_timeout(Some(Duration::from_secs(60)))
        .map_err(|e| e.to_string())?;
    // Subscribe first: the run is short in the host's time, and the frames that arrive while
    // the other checks run are kept.
    let r = link.ask(Command::Subscribe {
        decimation: 1,
        channels: Channels(Channels::ERROR | Channels::DELTA | Channels::V_A),
    })?;
    check(r == Reply::Done, "subscribed", format!("{r:?}"))?;
    let r = link.ask(Command::Hello {
        version: VERSION.wrapping_add(1),
    })?;
    check(
        r == Reply::Refused(Refusal::Version),
        "another protocol version is refused",
        format!("{r:?}"),
    )?;
    let Reply::Hello(h) = hello else {
        return Err(format!("handshake: {hello:?}"));
    };
    check(
        h.version == VERSION && h.board == Board::Qemu && h.motor_hz == 100 && h.piezo_hz == 1000,
        "handshake",
        format!(
            "{} on {:?}, motor {} Hz, piezo {} Hz, parameters {:08x}",
            h.build, h.board, h.motor_hz, h.piezo_hz, h.params_hash
        ),
    )?;
    let r = link.ask(Command::Status)?;
    let Reply::Status(s) = r else {
        return Err(format!("status: {r:?}"));
    };
    check(
        s.fault.is_none() && matches!(s.mode, Mode::Moving | Mode::Armed | Mode::Disarmed),
        "status",
        format!(
            "{:?}, tick {}, loads piezo {}/{} motor {}/{} counts (mean/worst), misses {} {}",
            s.mode,
            s.ticks,
            s.loads[0].mean_cycles,
            s.loads[0].worst_cycles,
            s.loads[1].mean_cycles,
            s.loads[1].worst_cycles,
            s.loads[0].misses,
            s.loads[1].misses
        ),
    )?;

    // Bad input on the line: garbage, a frame with a flipped bit, an oversized frame.
    let mut bad: Vec<u8> = (0..300u32).map(|i| (i * 37 % 251) as u8 | 1).collect();
    bad.push(0);
    let mut buf = [0u8; MAX_FRAME];
    let mut corrupt = encode(
        &Request {
            id: 999,
            command: Command::Status,
        },
        &mut buf,
    )
    .map_err(|e| e.to_string())?
    .to_vec();
    corrupt[2] ^= 0x10;
    bad.extend(corrupt);
    link.stream.write_all(&bad).map_err(|e| e.to_string())?;
    let r = link.ask(Command::Ping)?;
    check(
        r == Reply::Done,
        "after garbage, a corrupted and an oversized frame, a ping is answered",
        format!("{r:?}"),
    )?;
    let r = link.ask(Command::Arm)?;
    check(
        r == Reply::Refused(Refusal::Unsupported),
        "a command not implemented yet is refused as such",
        format!("{r:?}"),
    )?;
    let r = link.ask(Command::Subscribe {
        decimation: 0,
        channels: Channels(Channels::ERROR),
    })?;
    check(
        r == Reply::Refused(Refusal::OutOfRange),
        "a decimation of 0 is refused",
        format!("{r:?}"),
    )?;
    while let Some(m) = link.next()? {
        if let DeviceMsg::Telemetry(t) = m {
            link.telemetry.push(t);
        }
    }
    let t = &link.telemetry;
    let gaps = t
        .windows(2)
        .filter(|w| w[1].seq != w[0].seq.wrapping_add(1))
        .count();
    let max_error = t
        .iter()
        .flat_map(|f| f.values.iter().take(2))
        .fold(0.0f32, |m, e| m.max(e.abs()));
    check(
        t.len() >= 10 && gaps == 0 && t.iter().all(|f| f.values.len() == 5),
        "telemetry until the run ended",
        format!("{} frames, {gaps} sequence gaps, 5 values each", t.len()),
    )?;
    check(
        max_error <= MAX_ERROR,
        "the boot move's tracking error in the telemetry",
        format!("max |θ − θ_d| {max_error:.2e} rad (bound {MAX_ERROR})"),
    )
}

fn main() -> std::process::ExitCode {
    let port = std::env::args().nth(1).and_then(|p| p.parse::<u16>().ok());
    let Some(port) = port else {
        eprintln!("usage: link-e2e <port>");
        return std::process::ExitCode::FAILURE;
    };
    match run(port) {
        Ok(()) => {
            println!("link-e2e: PASS");
            std::process::ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("link-e2e: FAIL: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
