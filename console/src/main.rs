//! `flexarm`: the operator's console (docs/console.md). One command per invocation, one line of
//! error on failure (exit status 1), so it can be scripted.
//!
//! ```text
//! flexarm --tcp 127.0.0.1:4444 status
//! flexarm --port /dev/ttyUSB0 arm
//! flexarm --qemu --arm record --seconds 4 out/ trapezoid --to 0.8,-0.5 --time 2 --ramp 0.5
//! flexarm compare out/recording_firmware.csv
//! flexarm --qemu --arm live circle --centre 0.5,0.5 --radius 0.1 --period 4 --ramp 1
//! ```

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::{Parser, Subcommand};
use flexarm_console::client::{Client, ConsoleError, HANDSHAKE};
use flexarm_console::qemu::Qemu;
use flexarm_console::{fault_name, interrupt, live, params, record, transport, waypoints};
use flexarm_link::msg::{Mode, Move, Status, Waypoint};
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
    /// The QEMU firmware's socket, `host:port` (`scripts/qemu-serve` starts one).
    #[arg(long, conflicts_with = "port")]
    tcp: Option<String>,
    /// A QEMU firmware of this checkout for this invocation alone: built if needed, started,
    /// and stopped at the end (Ctrl-C included).
    #[arg(long, conflicts_with_all = ["port", "tcp"])]
    qemu: bool,
    /// Test builds: more features of the `--qemu` firmware (`inject-reversed-encoder`, …).
    #[arg(long, hide = true, requires = "qemu")]
    qemu_features: Option<String>,
    /// Arm before the command (the firmware boots disarmed: `--qemu --arm move …`).
    #[arg(long)]
    arm: bool,
    /// How long the handshake waits for the firmware [s].
    #[arg(long, default_value_t = HANDSHAKE.as_secs_f64())]
    wait: f64,
    #[command(subcommand)]
    command: Action,
}

#[derive(Subcommand)]
enum ConfigAction {
    /// Every parameter's value on stdout as a TOML file, with its unit, range and the build's
    /// default (`*` where the value differs from it; `?` when the build is not reproduced).
    Dump {
        /// The model file the firmware was built from (default: the paper's fragment), for the
        /// build's defaults.
        #[arg(long)]
        model: Option<PathBuf>,
    },
    /// The parameters whose values on the board differ from FILE's.
    Diff {
        /// A dump.
        file: PathBuf,
    },
    /// Writes FILE's values to the board (at rest; each validated by the firmware).
    Restore {
        /// A dump.
        file: PathBuf,
    },
    /// Saves the board's running values in its flash (disarmed only): it boots with them.
    Save,
    /// Marks the settings saved on the board erased: the next boot runs the build's defaults.
    Erase,
}

#[derive(Subcommand)]
enum Action {
    /// The handshake and the status: mode, fault, loads, counters.
    Status,
    /// Every value the board reports, by name, as TOML: the handshake, each status field,
    /// every parameter with its unit, one telemetry frame of every channel with its unit and
    /// meaning (tview's left pane; `flexarm live` plots them).
    Tree,
    /// Enable the amplifiers, holding the pose (refused until every joint is homed or
    /// declared: `home`).
    Arm,
    /// Home every joint (index pulse, end stop or limit switch, as the board is configured):
    /// the drive searches at a low torque, one joint at a time, and then holds, armed, in the
    /// arm's frame. The first thing to do after a power-on or a reset.
    Home {
        /// Instead of homing, declare the pose now to be θ1,θ2 [rad] in the arm's frame
        /// (disarmed): the drive trusts it. Only when the pose is known for certain.
        #[arg(
            long,
            value_name = "THETA1,THETA2",
            value_delimiter = ',',
            allow_hyphen_values = true
        )]
        declare: Option<Vec<f32>>,
    },
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
        /// The value, in the parameter's unit (`piezo_law` also takes the law's name: off,
        /// rate, irc, ppf).
        #[arg(allow_negative_numbers = true)]
        value: String,
    },
    /// Start a move, validated whole by the firmware, and wait for its end (Ctrl-C stops it).
    #[command(subcommand)]
    Move(MoveKind),
    /// Record telemetry (every channel) to OUT: the simulator's CSV and figure, and the
    /// description `compare` reads; optionally starting a move first.
    Record {
        /// How long [s].
        #[arg(long)]
        seconds: f64,
        /// Motor periods per frame.
        #[arg(long, default_value_t = 1)]
        decimation: u16,
        /// Replace files of the same name that no flexarm command wrote.
        #[arg(long)]
        force: bool,
        /// The model file the firmware was built from (`cargo sim firmware-params`'s source),
        /// which the recording carries for `compare`.
        #[arg(long, default_value = "firmware/piezo.toml")]
        model: PathBuf,
        /// The output folder.
        out: PathBuf,
        /// A move to start once the recording runs.
        #[command(subcommand)]
        then: Option<MoveKind>,
    },
    /// A full-screen live view: tracking errors, vibration, piezo, torques, loads and faults;
    /// keys s (stop), e or space (emergency stop), q (quit). Optionally starts a move.
    Live {
        /// Motor periods per frame (1: every period; raised until the link accepts the rate).
        #[arg(long, default_value_t = 1)]
        decimation: u16,
        /// Seconds the plots show.
        #[arg(long, default_value_t = 10.0)]
        window: f64,
        /// A move to start once the view runs.
        #[command(subcommand)]
        then: Option<MoveKind>,
    },
    /// A recording (`record … MOVE`) against the simulator's run of the same move: the Eq. 37/38
    /// indices of both, and `compare.svg` beside the recording.
    Compare {
        /// The recording's CSV (its `.toml` beside it).
        recording: PathBuf,
        /// Fail unless the recording's tracking indices (Eq. 37 ‖θ̃‖, max |θ̃|) are within this
        /// factor of the simulation's.
        #[arg(long)]
        within: Option<f64>,
        /// Replace a `compare.svg` that no flexarm command wrote.
        #[arg(long)]
        force: bool,
    },
    /// The board's settings as a file: dump, diff against a dump, restore a dump.
    #[command(subcommand)]
    Config(ConfigAction),
    /// The figure of a trace file already written (a recording, `faults`', a simulator's run)
    /// as `plot_trace.svg` in OUT (no board needed).
    Plot {
        /// The trace's CSV.
        file: PathBuf,
        /// The folder to write into (created; a file there no flexarm command wrote is kept
        /// unless --force).
        out: PathBuf,
        /// Replace a `plot_trace.svg` that no flexarm command wrote.
        #[arg(long)]
        force: bool,
    },
    /// The shell's completion script for flexarm (bash, zsh, fish, elvish, powershell) on
    /// stdout, for example `flexarm completions bash > ~/.local/share/bash-completion/completions/flexarm`
    /// (no board needed).
    Completions {
        /// The shell.
        shell: clap_complete::Shell,
    },
    /// A guided first power-on: loop loads, each encoder's direction and scale (a nudge under
    /// a low torque limit), the film's sign and gain (a step of the patch's voltage); a
    /// pass/fail table, and the configuration line to change at the first failure.
    Bringup {
        /// Torque limit of both joints meanwhile [N·m].
        #[arg(long, default_value_t = 3.0)]
        torque: f32,
        /// Joint nudge [rad].
        #[arg(long, default_value_t = 0.1)]
        nudge: f32,
        /// Step of the patch's voltage [V].
        #[arg(long, default_value_t = 40.0, allow_negative_numbers = true)]
        bias: f32,
    },
    /// Identification (docs/identification.md). `friction`: each joint's Coulomb and viscous
    /// friction from constant-speed moves out and back from where the arm holds; writes
    /// friction.md, .csv, .svg and a [plant] fragment the simulator reads into OUT. `modes`: the
    /// link's modes with the joints held at (0, π/2) (the patch's bias steps, joint 2's small
    /// moves); writes modes.md, modes_frf.csv, modes.svg and the record. `decay`: the held
    /// arm's free decay after taps of the patch at (0, π/2), against the paper's model's
    /// prediction; writes decay.md, .csv, .svg and the record. `inertia`: the rigid inertias
    /// from random trapezoids of both joints about (0, 0.5); writes inertia.md and the record.
    Identify {
        /// The experiment: `friction`, `modes`, `decay` or `inertia`.
        #[arg(value_parser = ["friction", "modes", "decay", "inertia"])]
        experiment: String,
        /// The decay experiment's taps.
        #[arg(long, default_value_t = 10)]
        taps: usize,
        /// The inertia experiment's moves.
        #[arg(long, default_value_t = 30)]
        moves: usize,
        /// Length of the modes experiment [s].
        #[arg(long, default_value_t = 60.0)]
        seconds: f64,
        /// The modes experiment's bias steps, the decay experiment's taps [V].
        #[arg(long, default_value_t = 100.0)]
        volts: f64,
        /// The modes experiment's moves of joint 2 about the pose [rad].
        #[arg(long, default_value_t = 0.05)]
        tap: f64,
        /// The decay experiment's time between taps [s] (at least three periods of the band's
        /// LOW: 3 s for the default 1.5 Hz).
        #[arg(long, default_value_t = 3.0)]
        spacing: f64,
        /// `decay`: the band the decay's modes are read in, `LOW,HIGH` [Hz] (default 1.5,40).
        #[arg(long, value_delimiter = ',')]
        band: Option<Vec<f64>>,
        /// The output folder.
        out: PathBuf,
        /// Cruise speeds [rad/s], both directions each.
        #[arg(long, value_delimiter = ',', default_values_t = flexarm_host::identify::SPEEDS)]
        speeds: Vec<f64>,
        /// Seconds of each cruise averaged.
        #[arg(long, default_value_t = flexarm_host::identify::CRUISE)]
        cruise: f64,
        /// Replace files of the same name that no flexarm command wrote.
        #[arg(long)]
        force: bool,
    },
    /// Test builds (the QEMU `link-session` firmware): assert (`on`) or release (`off`) the
    /// simulated amplifiers' fault line.
    #[command(hide = true)]
    TestAmplifierFault {
        /// `on` or `off`.
        #[arg(value_parser = ["on", "off"])]
        state: String,
    },
    /// The fault recorder (the motor periods before the latched fault) to OUT as CSV and figure.
    Faults {
        /// The output folder.
        out: PathBuf,
        /// Replace files of the same name that no flexarm command wrote.
        #[arg(long)]
        force: bool,
    },
    /// An interactive session on one connection: the commands above, typed without `flexarm`
    /// and its connection options, with history (this session's) and completion of commands,
    /// options and parameter names (Tab); `help` lists them, `quit` or end of input ends it.
    /// Each command is checked before it is sent, as on the command line; a failed one prints
    /// its line and the session goes on.
    Shell,
}

#[derive(Subcommand, Clone)]
enum MoveKind {
    /// From the held pose to joint targets [rad].
    Trapezoid {
        /// Targets θ1,θ2 [rad].
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
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
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
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
    flexarm_host::cli::one_line_panics("flexarm");
    // A usage mistake is one line too, and exit status 1 (help and version print as usual).
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("flexarm: {}", usage_line(&e));
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

/// A usage mistake's first line, with where help is.
fn usage_line(e: &clap::Error) -> String {
    let text = e.to_string();
    let first = text.lines().next().unwrap_or("bad command line");
    format!("{} (flexarm --help)", first.trim_start_matches("error: "))
}

/// One line of `flexarm shell`: a command without `flexarm` and the connection's options.
#[derive(Parser)]
#[command(name = "flexarm", no_binary_name = false, disable_version_flag = true)]
struct Line {
    #[command(subcommand)]
    command: Action,
}

fn run(cli: Cli) -> Result<(), ConsoleError> {
    flexarm_console::check::up_to("--wait", cli.wait, 600.0, "s")?;
    check_arguments(&cli.command)?;
    if let Some(done) = offline(&cli.command) {
        return done;
    }
    let prepared = prepare(&cli.command)?;
    interrupt::install();
    // Dropped last: QEMU outlives the session's last request.
    let mut qemu = None;
    let link = match (&cli.port, &cli.tcp, cli.qemu) {
        (Some(p), None, false) => transport::serial(p, cli.baud)?,
        (None, Some(a), false) => transport::tcp(a)?,
        // The live view follows the host's clock; every other command the firmware's own.
        (None, None, true) => qemu
            .insert(Qemu::start(
                matches!(cli.command, Action::Live { .. }),
                cli.qemu_features.as_deref(),
            )?)
            .connect()?,
        _ => {
            return Err(ConsoleError::Usage(
                "say where the firmware is: --port PATH (a board), --tcp HOST:PORT or --qemu"
                    .into(),
            ));
        }
    };
    let mut c = Client::connect(link, Duration::from_secs_f64(cli.wait))?;
    if cli.arm {
        c.done("arm", Command::Arm)?;
        println!("arm: done");
    }
    match cli.command {
        Action::Shell => {
            println!(
                "shell: {} on {:?}; commands as on the command line, Tab completes, `help` lists them, `quit` ends",
                c.hello.build, c.hello.board
            );
            flexarm_console::shell::run(
                &mut c,
                <Line as clap::CommandFactory>::command(),
                &mut |c, words| {
                    let words = std::iter::once("flexarm").chain(words.iter().map(String::as_str));
                    let command = match Line::try_parse_from(words) {
                        Ok(line) => line.command,
                        // `help`, `--help`: printed, not an error.
                        Err(e) if !e.use_stderr() => {
                            let _ = e.print();
                            return Ok(());
                        }
                        Err(e) => return Err(ConsoleError::Usage(usage_line(&e))),
                    };
                    check_arguments(&command)?;
                    match offline(&command) {
                        Some(done) => done,
                        None => {
                            let prepared = prepare(&command)?;
                            execute(c, command, prepared)
                        }
                    }
                },
            )
        }
        command => execute(&mut c, command, prepared),
    }
}

/// The commands that need no board (a parameter list, a trace's figure, the shell's
/// completions, a recording against the simulator): their outcome, or `None` for the others.
fn offline(command: &Action) -> Option<Result<(), ConsoleError>> {
    match command {
        Action::Get { name } if name == "list" => {
            print!("{}", params::list());
            Some(Ok(()))
        }
        Action::Plot { file, out, force } => Some(record::plot(file, out, *force).map(|names| {
            println!("plot: wrote {} in {}", names.join(", "), out.display());
        })),
        Action::Completions { shell } => {
            clap_complete::generate(
                *shell,
                &mut <Cli as clap::CommandFactory>::command(),
                "flexarm",
                &mut std::io::stdout(),
            );
            Some(Ok(()))
        }
        Action::Compare {
            recording,
            within,
            force,
        } => Some(compare(recording, *within, *force)),
        _ => None,
    }
}

/// What a command reads from files, read (and its mistakes reported) before any connection.
struct Prepared {
    /// A waypoint file's points.
    path: Option<Vec<flexarm_link::msg::Waypoint>>,
    /// A dump's values (`config diff`, `config restore`).
    dump: Option<Vec<(flexarm_link::params::Param, f32)>>,
    /// A model file's text (`config dump --model`).
    model: Option<String>,
}

fn prepare(command: &Action) -> Result<Prepared, ConsoleError> {
    let dump = match command {
        Action::Config(ConfigAction::Diff { file } | ConfigAction::Restore { file }) => {
            Some(flexarm_console::config::parse(file)?)
        }
        _ => None,
    };
    let model = match command {
        Action::Config(ConfigAction::Dump { model: Some(m) }) => Some(
            std::fs::read_to_string(m)
                .map_err(|e| ConsoleError::Usage(format!("{}: {e}", m.display())))?,
        ),
        _ => None,
    };
    let path = match command {
        Action::Move(MoveKind::Waypoints { file })
        | Action::Record {
            then: Some(MoveKind::Waypoints { file }),
            ..
        }
        | Action::Live {
            then: Some(MoveKind::Waypoints { file }),
            ..
        } => Some(waypoints::read(file)?),
        _ => None,
    };
    Ok(Prepared { path, dump, model })
}

/// One command on a connected board.
fn execute(c: &mut Client, command: Action, prepared: Prepared) -> Result<(), ConsoleError> {
    let Prepared { path, dump, model } = prepared;
    let done = |c: &mut Client, what: &str, command: Command| {
        c.done(what, command).map(|()| println!("{what}: done"))
    };
    match command {
        Action::Shell => {
            return Err(ConsoleError::Usage("shell: already in the shell".into()));
        }
        Action::Status => {
            let h = &c.hello;
            println!(
                "{} on {:?} (protocol {}, parameters {:08x}); motor loop {} Hz, piezo loop {} Hz",
                h.build, h.board, h.version, h.params_hash, h.motor_hz, h.piezo_hz
            );
            println!(
                "settings: {}",
                flexarm_console::client::settings(h.settings)
            );
            print_status(&c.status()?);
        }
        Action::Tree => print!("{}", flexarm_console::tree::tree(c)?),
        Action::Arm => done(c, "arm", Command::Arm)?,
        Action::Home { declare: None } => {
            let s = flexarm_console::home::home(c)?;
            println!(
                "home: done, holding (joint 1 {}, joint 2 {})",
                home_state(s.homing[0]),
                home_state(s.homing[1])
            );
        }
        Action::Home {
            declare: Some(theta),
        } => {
            let theta = pair("--declare", &theta)?;
            if !theta.iter().all(|t| t.is_finite()) {
                return Err(ConsoleError::Usage(
                    "--declare takes finite angles [rad]".into(),
                ));
            }
            eprintln!("{}", flexarm_console::home::DECLARE_WARNING);
            let s = flexarm_console::home::declare(c, theta)?;
            println!(
                "home --declare: the pose is ({}, {}) rad by the operator's word (joint 1 {}, joint 2 {})",
                theta[0],
                theta[1],
                home_state(s.homing[0]),
                home_state(s.homing[1])
            );
        }
        Action::Disarm => done(c, "disarm", Command::Disarm)?,
        Action::Stop => done(c, "stop", Command::Stop)?,
        Action::Estop => done(c, "estop", Command::Estop)?,
        Action::Clear => match c.request("clear", Command::Clear)? {
            Reply::Cleared(code) => println!("cleared fault {code}; the drive is disarmed"),
            r => return Err(ConsoleError::Unexpected(format!("{r:?}"))),
        },
        Action::Get { name } => {
            let (p, unit) = params::parse(&name)?;
            match c.request(&format!("get {name}"), Command::Get(p))? {
                Reply::Value(v) => println!("{name} = {v} {unit}{}", params::meaning(p, v)),
                r => return Err(ConsoleError::Unexpected(format!("{r:?}"))),
            }
        }
        Action::Set { name, value } => {
            let (p, unit) = params::parse(&name)?;
            let value = params::value(p, &value)?;
            done(
                c,
                &format!("set {name} = {value} {unit}"),
                Command::Set(p, value),
            )?;
        }
        Action::Move(m) => {
            let (what, m) = to_move(m, path.as_deref())?;
            let before = c.status()?;
            start_move(c, what, m, path.as_deref())?;
            println!("{what}: started");
            // Stay on the line until the move has ended: the requests feed the link watchdog,
            // which would stop a move whose host went away.
            let ended = interrupt::follow_move(c, what, &mut Vec::new(), None)?;
            move_outcome(what, &before, &ended)?;
            println!("{what}: ended, holding");
        }
        Action::Record {
            seconds,
            decimation,
            force,
            model,
            out,
            then,
        } => {
            let mv = then.map(|m| to_move(m, path.as_deref())).transpose()?;
            let mut r = record::record(
                c,
                seconds,
                decimation,
                &model,
                mv.map(|(_, m)| m),
                &mut |c: &mut Client| match mv {
                    Some((what, m)) => {
                        start_move(c, what, m, path.as_deref())?;
                        println!("{what}: started");
                        Ok(())
                    }
                    None => Ok(()),
                },
            )?;
            // A path's points, for `compare`.
            if let Some((_, Move::Waypoints { .. })) = mv {
                r.info.waypoints = path
                    .as_deref()
                    .map(|p| p.iter().map(|w| [w.theta[0], w.theta[1], w.dt]).collect());
            }
            let (frames, lost) = (r.info.frames, r.info.lost);
            let names = record::save(r, &out, force)?;
            println!(
                "record: {frames} frames, {lost} lost; wrote {} in {}",
                names.join(", "),
                out.display()
            );
        }
        Action::Live {
            decimation,
            window,
            then,
        } => {
            let mv = then.map(|m| to_move(m, path.as_deref())).transpose()?;
            let decimation = c.subscribe_fastest(decimation)?;
            let mut view = live::View::new(
                format!("{} on {:?}", c.hello.build, c.hello.board),
                c.hello.motor_hz,
                decimation,
                window,
            );
            let shown = live::run(c, &mut view, &mut |c: &mut Client| match mv {
                Some((what, m)) => {
                    start_move(c, what, m, path.as_deref()).map(|()| format!("{what}: started"))
                }
                None => Ok("ready".into()),
            });
            let _ = c.ask(Command::Unsubscribe);
            shown?;
            println!("live: {}", view.message);
        }
        Action::Faults { out, force } => faults(c, &out, force)?,
        Action::Identify {
            experiment,
            taps,
            moves,
            seconds,
            volts,
            tap,
            spacing,
            band,
            out,
            speeds,
            cruise,
            force,
        } => {
            // The folder first: a folder the tool may not write is named before the arm moves.
            let dir =
                flexarm_host::outdir::OutDir::open(&out, &format!("identify:{experiment}"), force)
                    .map_err(ConsoleError::Io)?;
            use flexarm_host::identify::{self, workflow};
            let staging = dir.staging();
            // The record is written first, whatever ended the experiment; a failed experiment
            // or a fit that refuses the record keeps it (`recorded`, `keep_record`).
            use flexarm_console::identify::{self as run, recorded};
            let mut trace = Vec::new();
            let film_range =
                f64::from(flexarm_core::supervisor::SensorLimits::<f32>::default().v_f_max);
            let fitted: Result<String, String> = match experiment.as_str() {
                "inertia" => {
                    let outcome = run::inertia(c, &inertia_plan(moves), &mut trace);
                    recorded(staging, "inertia", outcome, &trace)?.and_then(|()| {
                        let geometry = identify::geometry::Geometry::default();
                        workflow::save_inertia(staging, &trace, None, &geometry, None).map(|f| f.1)
                    })
                }
                "modes" => {
                    let outcome = run::modes(c, &modes_plan(seconds, volts, tap), &mut trace);
                    recorded(staging, "modes", outcome, &trace)?.and_then(|window| {
                        workflow::save_modes(
                            staging,
                            ("The modes experiment over the link", &trace),
                            (film_range, window),
                            &flexarm_host::identify::modal::FitSettings::default(),
                            None,
                            true,
                        )
                        .map(|f| f.1)
                    })
                }
                "decay" => {
                    let plan = decay_plan(taps, volts, spacing);
                    let band = decay_band(band.as_deref(), spacing)?;
                    let outcome = run::decay(c, &plan, &mut trace);
                    let paper = (
                        "paper's model",
                        flexarm_core::params::ArmParams::default(),
                        flexarm_core::control::piezo::PiezoPatch::paper(),
                    );
                    recorded(staging, "decay", outcome, &trace)?.and_then(|window| {
                        workflow::save_decay(
                            staging,
                            &trace,
                            (film_range, window),
                            (&plan, band),
                            &flexarm_host::sim::SimConfig::board(
                                f64::from(c.hello.motor_hz),
                                f64::from(c.hello.piezo_hz),
                            ),
                            &[paper],
                            true,
                        )
                        .map(|f| f.1)
                    })
                }
                _ => {
                    let outcome = run::friction(c, &speeds, cruise, &mut trace);
                    let heading = format!(
                        "Identified on {} over the link: each joint at {} rad/s, both ways, {cruise} s of cruise averaged (`flexarm identify friction`, docs/identification.md).",
                        c.hello.build,
                        speeds
                            .iter()
                            .map(|v| v.to_string())
                            .collect::<Vec<_>>()
                            .join(", ")
                    );
                    recorded(staging, "friction", outcome, &trace)?.and_then(|cruises| {
                        let fits = identify::fit_joints(&cruises).map_err(|e| e.to_string())?;
                        identify::save_friction(staging, &heading, &cruises, &fits, None, true)
                    })
                }
            };
            let report = match fitted {
                Ok(report) => report,
                Err(e) => return Err(keep_record(dir, &experiment, &out, &e)),
            };
            let files = dir.commit().map_err(ConsoleError::Io)?;
            print!("{report}");
            println!("identify: wrote {} in {}", files.join(", "), out.display());
        }
        Action::Bringup {
            torque,
            nudge,
            bias,
        } => {
            let o = flexarm_console::bringup::Options {
                torque,
                nudge,
                bias,
            };
            let report = flexarm_console::bringup::run(c, &o)?;
            print!("{}", report.table());
            if let Some(f) = report.failed() {
                return Err(ConsoleError::Failed(format!(
                    "bringup: failed at {}; fix it as above and run it again",
                    f.name
                )));
            }
            println!("bringup: every check passed");
        }
        Action::TestAmplifierFault { state } => done(
            c,
            &format!("test-amplifier-fault {state}"),
            Command::TestAmplifierFault(state == "on"),
        )?,
        // Offline, handled before connecting.
        Action::Compare { .. } | Action::Plot { .. } | Action::Completions { .. } => {}
        Action::Config(action) => config(c, action, model.as_deref(), dump)?,
    }
    Ok(())
}

/// A fit that refused its record: the record alone goes into the output folder (an experiment
/// on the arm is not to be run again for a fit's sake), and the error says where it is and how
/// to fit it again (`cargo sim identify EXPERIMENT --record`, with other settings).
fn keep_record(
    dir: flexarm_host::outdir::OutDir,
    experiment: &str,
    out: &std::path::Path,
    e: &str,
) -> ConsoleError {
    let record = format!("{experiment}_record.csv");
    let kept = out.join(&record);
    ConsoleError::Failed(match dir.commit_only(&[&record]) {
        Ok(_) => format!(
            "identify {experiment}: {e}; the record is kept as {} (`cargo sim identify {experiment} --record {}` fits it again)",
            kept.display(),
            kept.display()
        ),
        Err(c) => format!("identify {experiment}: {e}; the record was not kept: {c}"),
    })
}

/// Every argument against its rule before anything connects, starts QEMU or arms
/// (`flexarm_console::check`): a mistake is one line and exit status 1 whether or not a
/// firmware answers. A waypoint file is checked as it is read.
fn check_arguments(command: &Action) -> Result<(), ConsoleError> {
    use flexarm_console::check;
    use flexarm_host::identify::{self, inertia, modes};
    let decimation = |d: u16| match d {
        0 => Err(ConsoleError::Usage(
            "--decimation 0: give 1 or more motor periods a frame".into(),
        )),
        _ => Ok(()),
    };
    let then = match command {
        Action::Get { name } if name != "list" => params::parse(name).map(|_| None)?,
        Action::Set { name, value } => {
            let (p, _) = params::parse(name)?;
            check::set_value(name, p, params::value(p, value)?).map(|()| None)?
        }
        Action::Move(m) => Some(m),
        Action::Record {
            seconds,
            decimation: d,
            then,
            ..
        } => {
            check::up_to("--seconds", *seconds, 3600.0, "s")?;
            decimation(*d)?;
            then.as_ref()
        }
        Action::Live {
            decimation: d,
            window,
            then,
        } => {
            check::within("--window", *window, 1.0, 600.0, "s")?;
            decimation(*d)?;
            then.as_ref()
        }
        Action::Compare {
            within: Some(f), ..
        } => check::positive("--within", *f, "(a factor)").map(|()| None)?,
        Action::Bringup {
            torque,
            nudge,
            bias,
        } => flexarm_console::bringup::Options {
            torque: *torque,
            nudge: *nudge,
            bias: *bias,
        }
        .check()
        .map(|()| None)?,
        Action::Identify {
            experiment,
            taps,
            moves,
            seconds,
            volts,
            tap,
            spacing,
            band,
            speeds,
            cruise,
            ..
        } => {
            let usage = |e: identify::IdentifyError| ConsoleError::Usage(e.to_string());
            match experiment.as_str() {
                "inertia" => inertia::moves(&inertia_plan(*moves)).map(drop),
                "modes" => modes::excitation(&modes_plan(*seconds, *volts, *tap)).map(drop),
                "decay" => {
                    decay_band(band.as_deref(), *spacing)?;
                    decay_plan(*taps, *volts, *spacing).excitation().map(drop)
                }
                _ => identify::check_speeds(speeds).map(drop),
            }
            .map_err(usage)?;
            check::positive("--cruise", *cruise, "s").map(|()| None)?
        }
        _ => None,
    };
    match then {
        Some(m) => check::movement(&to_move(m.clone(), None)?.1),
        None => Ok(()),
    }
}

/// The inertia experiment of `moves` moves.
fn inertia_plan(moves: usize) -> flexarm_host::identify::inertia::InertiaPlan {
    flexarm_host::identify::inertia::InertiaPlan {
        moves,
        ..Default::default()
    }
}

/// The modes experiment: `seconds` long, bias steps of `volts`, joint 2's moves of `tap`.
fn modes_plan(seconds: f64, volts: f64, tap: f64) -> flexarm_host::identify::modes::ModesPlan {
    flexarm_host::identify::modes::ModesPlan {
        seconds,
        piezo_volts: volts,
        tap,
        ..Default::default()
    }
}

/// The decay experiment: `taps` taps of `volts`, `spacing` [s] apart.
fn decay_plan(taps: usize, volts: f64, spacing: f64) -> flexarm_host::identify::decay::DecayPlan {
    flexarm_host::identify::decay::DecayPlan {
        taps,
        volts,
        spacing,
        ..Default::default()
    }
}

/// The decay's band (`--band`), checked before connecting: `0 < LOW < HIGH`, and taps far
/// enough apart (`--spacing`) for decays three periods of LOW long (the fit's `record length`
/// gate would refuse the record after the experiment otherwise). The band's top against the
/// record's rate is the fit's check (`DecaySettings::for_band`).
fn decay_band(band: Option<&[f64]>, spacing: f64) -> Result<Option<(f64, f64)>, ConsoleError> {
    let band = match band {
        None => None,
        Some(&[low, high]) => Some((low, high)),
        Some(b) => {
            return Err(ConsoleError::Usage(format!(
                "--band: give LOW,HIGH in Hz, not {} value(s)",
                b.len()
            )));
        }
    };
    let low = match band {
        Some((low, high)) if low.is_finite() && high.is_finite() && low > 0.0 && high > low => low,
        Some((low, high)) => {
            return Err(ConsoleError::Usage(format!(
                "--band {low},{high}: give LOW,HIGH in Hz with 0 < LOW < HIGH"
            )));
        }
        None => {
            flexarm_host::identify::decay::DecaySettings::default()
                .band
                .0
        }
    };
    let need = 3.3 / low + flexarm_host::identify::decay::DecayPlan::default().width;
    if spacing.is_nan() || spacing < need {
        return Err(ConsoleError::Usage(format!(
            "--spacing {spacing} s: decays down to {low} Hz need the taps {need:.2} s apart or more"
        )));
    }
    Ok(band)
}

/// The move a subcommand names (a waypoint path's points come from `path`, read before).
fn to_move(m: MoveKind, path: Option<&[Waypoint]>) -> Result<(&'static str, Move), ConsoleError> {
    Ok(match m {
        MoveKind::Trapezoid { to, time, ramp } => (
            "move trapezoid",
            Move::Trapezoid {
                target: pair("--to", &to)?,
                move_time: time,
                ramp_time: ramp,
            },
        ),
        MoveKind::Waypoints { .. } => (
            "move waypoints",
            Move::Waypoints {
                count: path.map_or(0, <[Waypoint]>::len) as u16,
            },
        ),
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
    })
}

/// `config dump`, `diff` and `restore` (`flexarm_console::config`); `dump` is the file's
/// values, read before connecting.
fn config(
    c: &mut Client,
    action: ConfigAction,
    model: Option<&str>,
    dump: Option<Vec<(flexarm_link::msg::Param, f32)>>,
) -> Result<(), ConsoleError> {
    use flexarm_console::config;
    let dump = dump.unwrap_or_default();
    match action {
        ConfigAction::Dump { .. } => {
            let values = config::read(c)?;
            let build = config::build_config(&c.hello, model);
            print!("{}", config::text(&c.hello, &values, build.as_ref()));
        }
        ConfigAction::Diff { file } => {
            let differ = config::diff(&config::read(c)?, &dump);
            for (p, board, f) in &differ {
                println!(
                    "{}: board {board} {unit}, file {f} {unit}",
                    p.info().name,
                    unit = p.info().unit
                );
            }
            println!(
                "config diff: {} of {} differ from {}",
                differ.len(),
                dump.len(),
                file.display()
            );
        }
        ConfigAction::Save => {
            c.done("config save", Command::ConfigSave)?;
            println!("config save: done; the board boots with its values now running");
        }
        ConfigAction::Erase => {
            c.done("config erase", Command::ConfigErase)?;
            println!(
                "config erase: done; the values running now stay until the board resets, then the build's defaults"
            );
        }
        ConfigAction::Restore { file } => {
            let written = config::restore(c, &dump)?;
            println!(
                "config restore: wrote {} from {}",
                written.join(", "),
                file.display()
            );
        }
    }
    Ok(())
}

/// How a move that is no longer running ended, from the drive's status before it started and
/// after: `Ok` only when it ran to its end and holds there; a fault, a stop by the link watchdog
/// (the host fell silent for the link timeout) or a disarm is an error that says which.
fn move_outcome(what: &str, before: &Status, after: &Status) -> Result<(), ConsoleError> {
    if let Some(f) = after.fault {
        return Err(ConsoleError::Unexpected(format!(
            "{what}: the move ended in fault {f} ({})",
            fault_name(f)
        )));
    }
    if after.link_stops > before.link_stops {
        return Err(ConsoleError::Unexpected(format!(
            "{what}: stopped short of its end by the link watchdog (no request reached the board for its link timeout); the arm holds where it stopped"
        )));
    }
    if after.mode != Mode::Armed {
        return Err(ConsoleError::Unexpected(format!(
            "{what}: the drive left the move {:?}, not holding its end",
            after.mode
        )));
    }
    Ok(())
}

/// Uploads a path's waypoints in chunks, then starts the move (the caller says so: the live
/// view draws its own screen).
fn start_move(
    c: &mut Client,
    what: &str,
    m: Move,
    path: Option<&[Waypoint]>,
) -> Result<(), ConsoleError> {
    if let (Move::Waypoints { .. }, Some(points)) = (m, path) {
        waypoints::upload(c, points)?;
    }
    c.done(what, Command::Move(m))
}

/// `compare`: the table, the figure, and the verdict of `--within`.
fn compare(
    recording: &std::path::Path,
    within: Option<f64>,
    force: bool,
) -> Result<(), ConsoleError> {
    let c = record::compare(recording)?;
    print!("{}", record::table(&c));
    println!(
        "aligned on the reference: mean |θ_d,recording − θ_d,simulation| {:.1e} rad",
        c.reference_gap
    );
    let dir = recording
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    let figure = record::save_comparison(&c, dir, force)?;
    println!("compare: wrote {}", figure.display());
    if let Some(f) = within {
        let (r, s) = (&c.recorded, &c.simulated);
        let worst = (r.l2_error / s.l2_error).max(r.max_error / s.max_error);
        // A NaN ratio (a simulation without error) fails too.
        if !matches!(
            worst.partial_cmp(&f),
            Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
        ) {
            return Err(ConsoleError::Unexpected(format!(
                "the recording tracks {worst:.2} times worse than the simulation (allowed {f})"
            )));
        }
        println!("compare: within {f} times the simulation's tracking ({worst:.2})");
    }
    Ok(())
}

/// `faults`: every page of the recorder, to `faults_firmware.csv` and `.svg`.
fn faults(c: &mut Client, out: &std::path::Path, force: bool) -> Result<(), ConsoleError> {
    let mut samples = Vec::new();
    let mut fault = None;
    loop {
        let page = match c.request(
            "faults",
            Command::Faults {
                from: samples.len() as u16,
            },
        )? {
            Reply::Faults(p) => p,
            r => return Err(ConsoleError::Unexpected(format!("{r:?}"))),
        };
        // Without a latched fault the ring is still being written: pages read one after the
        // other would be torn (issue 36 wrote one as "500 motor periods").
        if page.fault.is_none() {
            return Err(ConsoleError::Usage(
                "faults: no fault is latched, so the recorder is still recording (it freezes at a fault); nothing written".into(),
            ));
        }
        fault = fault.or(page.fault);
        let done = page.samples.is_empty();
        samples.extend(page.samples.iter().copied());
        if done || samples.len() >= usize::from(page.total) {
            break;
        }
    }
    let names = record::save_faults(&samples, c.hello.motor_hz, out, force)?;
    let name = fault.map_or("none".to_string(), |f| format!("{f} ({})", fault_name(f)));
    println!(
        "faults: fault {name}, {} motor periods recorded; wrote {} in {}",
        samples.len(),
        names.join(", "),
        out.display()
    );
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
        Mode::Homing => "homing (a search runs)",
    };
    println!("mode: {mode}");
    println!(
        "brake: {}",
        if s.brake_engaged {
            "engaged (the joints held)"
        } else {
            "released (the amplifiers drive the joints)"
        }
    );
    println!(
        "homing: joint 1 {}, joint 2 {}{}",
        home_state(s.homing[0]),
        home_state(s.homing[1]),
        if s.homing_failed {
            " (the last search failed: it travelled its limit without finding its reference)"
        } else {
            ""
        }
    );
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
        "motor periods {}, telemetry dropped {}, watchdog stops {}, received {} bytes ({} lost, {} malformed requests; line: {} overruns, {} framing, {} noise), stack {} bytes",
        s.ticks,
        s.telemetry_dropped,
        s.link_stops,
        s.rx_bytes,
        s.rx_lost,
        s.rx_malformed,
        s.rx_line.overrun,
        s.rx_line.framing,
        s.rx_line.noise,
        s.stack_used
    );
}

/// A joint's homing state in words: a declared pose is the operator's word, never "homed".
fn home_state(s: flexarm_link::msg::HomeState) -> &'static str {
    use flexarm_link::msg::HomeState;
    match s {
        HomeState::Unhomed => "NOT HOMED",
        HomeState::Searching => "searching",
        HomeState::Homed => "homed",
        HomeState::Declared => "DECLARED by the operator (not homed)",
    }
}
