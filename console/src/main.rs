//! `flexarm`: the operator's console (docs/console.md). One command per invocation, one line of
//! error on failure (exit status 1), so it can be scripted.
//!
//! ```text
//! flexarm --tcp 127.0.0.1:4444 status
//! flexarm --port /dev/ttyUSB0 arm
//! flexarm --qemu move trapezoid --to 0.8,-0.5 --time 2 --ramp 0.5
//! ```

use std::process::ExitCode;
use std::time::Duration;

use clap::{Parser, Subcommand};
use flexarm_console::client::{Client, ConsoleError, HANDSHAKE};
use flexarm_console::{params, transport, waypoints};
use flexarm_link::msg::{Mode, Move, Status, WAYPOINTS_PER_CHUNK};
use flexarm_link::{Command, Reply};

/// The operator's console for the flexarm firmware.
#[derive(Parser)]
#[command(name = "flexarm", version)]
struct Cli {
    /// A board's serial port (USART1: PB6 TX, PB7 RX).
    #[arg(long, conflicts_with = "tcp")]
    port: Option<String>,
    /// The port's baud rate.
    #[arg(long, default_value_t = 921_600)]
    baud: u32,
    /// The QEMU firmware's socket, `host:port` (`scripts/qemu-link` starts one).
    #[arg(long)]
    tcp: Option<String>,
    /// How long the handshake waits for the firmware [s].
    #[arg(long, default_value_t = HANDSHAKE.as_secs_f64())]
    wait: f64,
    #[command(subcommand)]
    command: Action,
}

#[derive(Subcommand)]
enum Action {
    /// The handshake and the status: mode, fault, loads, counters.
    Status,
    /// Enable the amplifiers, holding the pose.
    Arm,
    /// Disable the amplifiers (always accepted).
    Disarm,
    /// A controlled stop of the running move (stop category 1).
    Stop,
    /// The safe state now (stop category 0).
    Estop,
    /// Clear the latched fault if its cause is gone.
    Clear,
    /// Read a tunable parameter.
    Get {
        /// Its name (`flexarm get list` lists them).
        name: String,
    },
    /// Write a tunable parameter (at rest).
    Set {
        /// Its name.
        name: String,
        /// The value, in the parameter's unit.
        #[arg(allow_negative_numbers = true)]
        value: f32,
    },
    /// Start a move, validated whole by the firmware.
    #[command(subcommand)]
    Move(MoveKind),
}

#[derive(Subcommand)]
enum MoveKind {
    /// From the held pose to joint targets [rad].
    Trapezoid {
        /// Targets θ1,θ2 [rad].
        #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
        to: Vec<f32>,
        /// Duration [s].
        #[arg(long)]
        time: f32,
        /// Constant-acceleration ramp at each end [s].
        #[arg(long)]
        ramp: f32,
    },
    /// One revolution of the tip from where it is held.
    Circle {
        /// Centre x,y in the base frame [m].
        #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
        centre: Vec<f32>,
        /// Radius [m].
        #[arg(long)]
        radius: f32,
        /// One revolution [s].
        #[arg(long)]
        period: f32,
        /// Ramp of the phase at each end [s].
        #[arg(long)]
        ramp: f32,
        /// Counter-clockwise (default clockwise).
        #[arg(long)]
        ccw: bool,
    },
    /// Through the joint waypoints of a CSV file (`theta1,theta2,dt`; docs/console.md).
    Waypoints {
        /// The file.
        file: String,
    },
}

fn main() -> ExitCode {
    // A usage mistake is one line too, and exit status 1 (help and version print as usual).
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            let text = e.to_string();
            let first = text.lines().next().unwrap_or("bad command line");
            eprintln!(
                "flexarm: {} (flexarm --help)",
                first.trim_start_matches("error: ")
            );
            return ExitCode::FAILURE;
        }
    };
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("flexarm: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<(), ConsoleError> {
    if let Action::Get { name } = &cli.command
        && name == "list"
    {
        for (n, _, unit) in params::NAMES {
            println!("{n} [{unit}]");
        }
        return Ok(());
    }
    // A file's mistakes before any connection.
    let path = match &cli.command {
        Action::Move(MoveKind::Waypoints { file }) => Some(waypoints::read(file)?),
        _ => None,
    };
    let link = match (&cli.port, &cli.tcp) {
        (Some(p), None) => transport::serial(p, cli.baud)?,
        (None, Some(a)) => transport::tcp(a)?,
        _ => {
            return Err(ConsoleError::Usage(
                "say where the firmware is: --port PATH (a board) or --tcp HOST:PORT (QEMU)".into(),
            ));
        }
    };
    if !(cli.wait.is_finite() && cli.wait > 0.0 && cli.wait <= 600.0) {
        return Err(ConsoleError::Usage(format!(
            "--wait {} s: give 0 to 600 s",
            cli.wait
        )));
    }
    let mut c = Client::connect(link, Duration::from_secs_f64(cli.wait))?;
    let done = |c: &mut Client, what: &str, command: Command| -> Result<(), ConsoleError> {
        match c.request(what, command)? {
            Reply::Done => {
                println!("{what}: done");
                Ok(())
            }
            r => Err(ConsoleError::Unexpected(format!("{r:?}"))),
        }
    };
    match cli.command {
        Action::Status => {
            let h = &c.hello;
            println!(
                "{} on {:?} (protocol {}, parameters {:08x}); motor loop {} Hz, piezo loop {} Hz",
                h.build, h.board, h.version, h.params_hash, h.motor_hz, h.piezo_hz
            );
            match c.request("status", Command::Status)? {
                Reply::Status(s) => print_status(&s),
                r => return Err(ConsoleError::Unexpected(format!("{r:?}"))),
            }
        }
        Action::Arm => done(&mut c, "arm", Command::Arm)?,
        Action::Disarm => done(&mut c, "disarm", Command::Disarm)?,
        Action::Stop => done(&mut c, "stop", Command::Stop)?,
        Action::Estop => done(&mut c, "estop", Command::Estop)?,
        Action::Clear => match c.request("clear", Command::Clear)? {
            Reply::Cleared(code) => println!("cleared fault {code}; the drive is disarmed"),
            r => return Err(ConsoleError::Unexpected(format!("{r:?}"))),
        },
        Action::Get { name } => {
            let (p, unit) = params::parse(&name)?;
            match c.request(&format!("get {name}"), Command::Get(p))? {
                Reply::Value(v) => println!("{name} = {v} {unit}"),
                r => return Err(ConsoleError::Unexpected(format!("{r:?}"))),
            }
        }
        Action::Set { name, value } => {
            let (p, unit) = params::parse(&name)?;
            done(
                &mut c,
                &format!("set {name} = {value} {unit}"),
                Command::Set(p, value),
            )?;
        }
        Action::Move(m) => {
            let (what, m) = match m {
                MoveKind::Trapezoid { to, time, ramp } => (
                    "move trapezoid",
                    Move::Trapezoid {
                        target: pair("--to", &to)?,
                        move_time: time,
                        ramp_time: ramp,
                    },
                ),
                MoveKind::Waypoints { .. } => {
                    let points = path.unwrap_or_default();
                    for (k, chunk) in points.chunks(WAYPOINTS_PER_CHUNK).enumerate() {
                        let first = k * WAYPOINTS_PER_CHUNK;
                        let command = Command::Waypoints {
                            first: first as u16,
                            points: heapless::Vec::from_slice(chunk).map_err(|_| {
                                ConsoleError::Usage("a chunk larger than a frame holds".into())
                            })?,
                        };
                        match c.request(&format!("waypoints {first}…"), command)? {
                            Reply::Done => {}
                            r => return Err(ConsoleError::Unexpected(format!("{r:?}"))),
                        }
                    }
                    (
                        "move waypoints",
                        Move::Waypoints {
                            count: points.len() as u16,
                        },
                    )
                }
                MoveKind::Circle {
                    centre,
                    radius,
                    period,
                    ramp,
                    ccw,
                } => (
                    "move circle",
                    Move::Circle {
                        centre: pair("--centre", &centre)?,
                        radius,
                        period,
                        ramp_time: ramp,
                        clockwise: !ccw,
                    },
                ),
            };
            done(&mut c, what, Command::Move(m))?;
            // Stay on the line until the move has ended: the requests feed the link watchdog,
            // which would stop a move whose host went away.
            let ended = loop {
                std::thread::sleep(Duration::from_millis(50));
                match c.request("status", Command::Status)? {
                    Reply::Status(s) if matches!(s.mode, Mode::Moving | Mode::Stopping) => {}
                    Reply::Status(s) => break s,
                    r => return Err(ConsoleError::Unexpected(format!("{r:?}"))),
                }
            };
            match ended.fault {
                None => println!("{what}: ended, holding"),
                Some(f) => {
                    return Err(ConsoleError::Unexpected(format!(
                        "the move ended in fault {f} ({})",
                        fault_name(f)
                    )));
                }
            }
        }
    }
    Ok(())
}

/// Two comma-separated values.
fn pair(flag: &str, v: &[f32]) -> Result<[f32; 2], ConsoleError> {
    match v {
        [a, b] => Ok([*a, *b]),
        _ => Err(ConsoleError::Usage(format!(
            "{flag} takes two values, a,b (got {})",
            v.len()
        ))),
    }
}

fn print_status(s: &Status) {
    let mode = match s.mode {
        Mode::Disarmed => "disarmed",
        Mode::Armed => "armed, holding",
        Mode::Moving => "moving",
        Mode::Stopping => "stopping",
        Mode::Fault => "FAULT (safe state)",
    };
    println!("mode: {mode}");
    if let Some(f) = s.fault {
        println!("fault: {f} ({})", fault_name(f));
    }
    for (name, l) in ["piezo loop", "motor loop"].iter().zip(&s.loads) {
        println!(
            "{name}: mean {} counts, worst {} counts, {} deadline misses",
            l.mean_cycles, l.worst_cycles, l.misses
        );
    }
    println!(
        "motor periods {}, telemetry dropped {}, watchdog stops {}, received {} bytes ({} lost), stack {} bytes",
        s.ticks, s.telemetry_dropped, s.link_stops, s.rx_bytes, s.rx_lost, s.stack_used
    );
}

/// A fault's name from its stable number (docs/safety.md).
fn fault_name(code: u8) -> &'static str {
    flexarm_core::Fault::from_code(code)
        .map_or("unknown to this console", flexarm_core::Fault::as_str)
}
