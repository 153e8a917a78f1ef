//! The `flexarm` tool against stand-ins for the firmware on a local socket: a firmware that
//! answers like ours, one of another protocol version, a peer that sends random bytes, a silent
//! one; and a port that does not exist. Every failure is one line on stderr and exit status 1.

use std::io::{Read, Write};
use std::net::TcpListener;
use std::process::{Command as Process, Output};
use std::thread;

use flexarm_link::msg::{Board, Hello, HomeState, Load, Mode, Param, Refusal, Status};
use flexarm_link::{Command, Decoder, DeviceMsg, MAX_FRAME, Reply, Request, VERSION, encode};

/// A stand-in firmware on a fresh local port: answers each request with `answer`, until the
/// client hangs up. Returns the port.
fn firmware(answer: fn(&Command) -> Option<Reply>) -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    thread::spawn(move || {
        let Ok((mut s, _)) = listener.accept() else {
            return;
        };
        let mut d = Decoder::new();
        let mut byte = [0u8; 1];
        while let Ok(1) = s.read(&mut byte) {
            if let Some(Ok(Request { id, command })) = d.push::<Request>(byte[0])
                && let Some(reply) = answer(&command)
            {
                let mut buf = [0u8; MAX_FRAME];
                let f = encode(&DeviceMsg::Reply { id, reply }, &mut buf).unwrap();
                if s.write_all(f).is_err() {
                    return;
                }
            }
        }
    });
    port
}

/// A peer that sends `bytes` after every byte it receives, or nothing.
fn peer(bytes: &'static [u8]) -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    thread::spawn(move || {
        let Ok((mut s, _)) = listener.accept() else {
            return;
        };
        let mut byte = [0u8; 64];
        while let Ok(n) = s.read(&mut byte) {
            if n == 0 || (!bytes.is_empty() && s.write_all(bytes).is_err()) {
                return;
            }
        }
    });
    port
}

fn ours(c: &Command) -> Option<Reply> {
    Some(match c {
        Command::Hello { version } if *version == VERSION => Reply::Hello(Hello {
            version: VERSION,
            board: Board::Qemu,
            build: heapless::String::try_from("stand-in").unwrap(),
            params_hash: 0x1234_5678,
            motor_hz: 100,
            piezo_hz: 1000,
            settings: flexarm_link::msg::Settings::Defaults,
        }),
        Command::Hello { .. } => Reply::Refused(Refusal::Version),
        Command::Status => Reply::Status(Status {
            mode: Mode::Fault,
            fault: Some(13),
            ticks: 4200,
            loads: [Load::default(); 2],
            telemetry_dropped: 0,
            link_stops: 0,
            rx_bytes: 99,
            rx_lost: 0,
            rx_malformed: 0,
            rx_line: Default::default(),
            stack_used: 1700,
            homing: [HomeState::Homed; 2],
            homing_failed: false,
            brake_engaged: true,
        }),
        Command::Arm => Reply::Done,
        Command::Get(_) => Reply::Value(30.0),
        Command::Set(Param::Kc, v) if *v <= 0.0 => Reply::Refused(Refusal::OutOfRange),
        Command::Set(..) => Reply::Done,
        Command::Move(_) => Reply::Refused(Refusal::TooFast),
        _ => Reply::Refused(Refusal::Unsupported),
    })
}

/// A status in `mode`, no fault, with `link_stops` watchdog stops and every other counter 0.
fn status_in(mode: Mode, link_stops: u32) -> Status {
    Status {
        mode,
        fault: None,
        ticks: 1,
        loads: [Load::default(); 2],
        telemetry_dropped: 0,
        link_stops,
        rx_bytes: 0,
        rx_lost: 0,
        rx_malformed: 0,
        rx_line: Default::default(),
        stack_used: 0,
        homing: [HomeState::Homed; 2],
        homing_failed: false,
        brake_engaged: !matches!(
            mode,
            Mode::Armed | Mode::Moving | Mode::Stopping | Mode::Homing
        ),
    }
}

fn flexarm(args: &[&str]) -> Output {
    Process::new(env!("CARGO_BIN_EXE_flexarm"))
        .args(args)
        .output()
        .unwrap()
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// A failure: exit status 1, one line on stderr containing `needle`, nothing on stdout.
fn fails_with(args: &[&str], needle: &str) {
    let o = flexarm(args);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{args:?}: {out}{err}");
    assert_eq!(err.lines().count(), 1, "{args:?}: one line: {err}");
    assert!(
        err.starts_with("flexarm: ") && err.contains(needle),
        "{args:?}: {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn status_names_the_fault_and_the_counters() {
    let port = firmware(ours).to_string();
    let o = flexarm(&["--tcp", &format!("127.0.0.1:{port}"), "status"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("stand-in on Qemu") && out.contains("12345678"),
        "{out}"
    );
    assert!(out.contains("mode: FAULT"), "{out}");
    assert!(out.contains("fault: 13 (joint runaway"), "{out}");
    assert!(out.contains("brake: engaged"), "{out}");
    assert!(out.contains("stack 1700 bytes"), "{out}");
}

#[test]
fn commands_answer_in_one_line_each() {
    let at = |port: u16| format!("127.0.0.1:{port}");
    let o = flexarm(&["--tcp", &at(firmware(ours)), "arm"]);
    assert_eq!(text(&o).0, "arm: done\n");
    let o = flexarm(&["--tcp", &at(firmware(ours)), "get", "kc"]);
    assert_eq!(text(&o).0, "kc = 30 s\n");
    let o = flexarm(&["--tcp", &at(firmware(ours)), "set", "va_min", "-30"]);
    assert!(o.status.success(), "{}", text(&o).1);
    let o = flexarm(&["get", "list"]);
    assert!(text(&o).0.contains("va_min [V]"));
}

#[test]
fn refusals_and_bad_input_are_one_line_and_exit_1() {
    let at = |port: u16| format!("127.0.0.1:{port}");
    fails_with(
        &[
            "--tcp",
            &at(firmware(ours)),
            "move",
            "trapezoid",
            "--to",
            "3,0",
            "--time",
            "0.5",
            "--ramp",
            "0.1",
        ],
        "move trapezoid refused: the move asks more speed",
    );
    fails_with(
        &["--tcp", &at(firmware(ours)), "set", "kc", "-1"],
        "out of its range",
    );
    fails_with(
        &["--tcp", &at(firmware(ours)), "get", "nope"],
        "no parameter `nope`",
    );
    fails_with(&["status"], "--port PATH");
    fails_with(
        &[
            "--tcp",
            &at(firmware(ours)),
            "move",
            "trapezoid",
            "--to",
            "1",
            "--time",
            "2",
            "--ramp",
            "0.5",
        ],
        "--to takes two values",
    );
    fails_with(&["frobnicate"], "unrecognized subcommand");
    fails_with(
        &["--tcp", &at(firmware(ours)), "--wait", "nan", "status"],
        "--wait",
    );
}

#[test]
fn a_firmware_of_another_protocol_version_is_named() {
    fn other(c: &Command) -> Option<Reply> {
        match c {
            Command::Hello { .. } => Some(Reply::Refused(Refusal::Version)),
            _ => None,
        }
    }
    let port = firmware(other);
    fails_with(
        &["--tcp", &format!("127.0.0.1:{port}"), "status"],
        &format!("refused protocol version {VERSION}"),
    );
}

/// `flexarm status` on the local `port` with a handshake of one second fails with `expect`.
fn status_fails_within_a_second(port: u16, expect: &str) {
    let at = format!("127.0.0.1:{port}");
    fails_with(&["--tcp", &at, "--wait", "1", "status"], expect);
}

/// A firmware still draining an earlier session's traffic (issue 36: after a flood the console
/// asked whether the board was powered): it answers, but never the handshake. The error says
/// the line is busy, not that the board is dead or foreign.
#[test]
fn a_backlogged_line_is_named_as_such() {
    fn draining(_: &Command) -> Option<Reply> {
        Some(Reply::Status(status_in(Mode::Armed, 0)))
    }
    let port = firmware(draining);
    status_fails_within_a_second(port, "the line is still busy with earlier traffic");
}

#[test]
fn a_peer_that_is_not_our_firmware_is_named_not_hung_on() {
    let port = peer(b"\x13\x37garbage\x00\xff\xfe\x00noise");
    status_fails_within_a_second(port, "not one frame of the flexarm firmware");
    let port = peer(b"");
    status_fails_within_a_second(port, "no answer from the firmware");
}

#[test]
fn a_port_that_does_not_exist_is_named() {
    fails_with(
        &["--port", "/dev/flexarm-does-not-exist", "status"],
        "/dev/flexarm-does-not-exist",
    );
    // Nothing listens on port 1.
    fails_with(&["--tcp", "127.0.0.1:1", "status"], "127.0.0.1:1");
}

/// A waypoint file's mistakes are named by file, line and column, before any connection.
#[test]
fn a_waypoint_file_with_errors_is_named_by_line() {
    let dir = std::env::temp_dir().join(format!("flexarm-console-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p.to_string_lossy().into_owned()
    };
    let cases = [
        ("empty.csv", "", "empty.csv:1: no header"),
        (
            "header.csv",
            "a,b,c\n",
            "header.csv:1: the header is `a,b,c`",
        ),
        (
            "nan.csv",
            "theta1,theta2,dt\n0.1,0.2,0.5\n# a comment\n0.3,nan,0.5\n",
            "nan.csv:4: column `theta2`: `nan`",
        ),
        (
            "short.csv",
            "theta1,theta2,dt\n0.1,0.2\n",
            "short.csv:2: 2 values, not 3",
        ),
        (
            "dt.csv",
            "theta1,theta2,dt\n0.1,0.2,0\n",
            "dt.csv:2: column `dt`: 0 s, not positive",
        ),
        (
            "none.csv",
            "theta1,theta2,dt\n\n",
            "none.csv:1: a header and no waypoint",
        ),
        // The drive's own rules that do not depend on the held pose.
        (
            "far.csv",
            "theta1,theta2,dt\n0.1,0.2,0.5\n1e30,0,0.5\n",
            "far.csv:3: column `theta1`: 1e30 rad is outside the drive's range -3 to 3 rad",
        ),
        (
            "short_dt.csv",
            "theta1,theta2,dt\n0.1,0.2,1e-30\n",
            "short_dt.csv:2: column `dt`: 1e-30 s is shorter than one motor period (0.001 s)",
        ),
        (
            "fast.csv",
            "theta1,theta2,dt\n0.1,0.2,0.5\n# a comment\n0.1,2.2,0.1\n",
            "fast.csv:4: θ2 moves 20 rad/s on average from the waypoint before: more than the drive's 3 rad/s",
        ),
    ];
    for (name, text, needle) in cases {
        // No firmware listens: the file is refused before any connection is tried.
        fails_with(
            &[
                "--tcp",
                "127.0.0.1:1",
                "move",
                "waypoints",
                &file(name, text),
            ],
            needle,
        );
    }
    let many: String = std::iter::once("theta1,theta2,dt\n".to_string())
        .chain((0..33).map(|k| format!("{},0,0.1\n", f64::from(k) * 0.01)))
        .collect();
    fails_with(
        &[
            "--tcp",
            "127.0.0.1:1",
            "move",
            "waypoints",
            &file("many.csv", &many),
        ],
        "many.csv:34: more than 32 waypoints",
    );
    fails_with(
        &[
            "--tcp",
            "127.0.0.1:1",
            "move",
            "waypoints",
            "/no/such/file.csv",
        ],
        "/no/such/file.csv: No such file",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn every_argument_is_checked_before_connecting() {
    // Nothing listens on port 1: each mistake must be named, not "no answer" or a refused
    // connection, and nothing connects, starts or arms.
    let closed = ["--tcp", "127.0.0.1:1"];
    for (args, needle) in [
        (
            &["record", "--seconds", "nan", "out"][..],
            "--seconds NaN: give more than 0",
        ),
        (
            &["identify", "decay", "out", "--band", "5,2"],
            "--band 5,2: give LOW,HIGH in Hz with 0 < LOW < HIGH",
        ),
        (
            &["identify", "decay", "out", "--band", "0.3,40"],
            "--spacing 3 s: decays down to 0.3 Hz need the taps 11.02 s apart or more",
        ),
        (
            &["identify", "decay", "out", "--spacing", "nan"],
            "--spacing NaN s: decays down to 1.5 Hz need",
        ),
        (
            &["record", "--seconds", "2", "--decimation", "0", "out"],
            "--decimation 0",
        ),
        (
            &[
                "move",
                "trapezoid",
                "--to",
                "nan,0",
                "--time",
                "2",
                "--ramp",
                "0.5",
            ],
            "--to NaN,0: θ1 = NaN rad is outside the drive's range -3 to 3 rad",
        ),
        (
            &[
                "move",
                "trapezoid",
                "--to",
                "0.5,2.9",
                "--time",
                "2",
                "--ramp",
                "0.5",
            ],
            "θ2 = 2.9 rad is outside the drive's range -2.7 to 2.7 rad",
        ),
        (
            &[
                "move",
                "trapezoid",
                "--to",
                "0.5,0",
                "--time",
                "2",
                "--ramp",
                "1.5",
            ],
            "--time 2 --ramp 1.5: give finite times with 0 < ramp <= time / 2",
        ),
        (
            &[
                "move",
                "trapezoid",
                "--to",
                "0.5,0",
                "--time",
                "1e30",
                "--ramp",
                "1",
            ],
            "--time 1e30: a move lasts at most 3600 s",
        ),
        // A negative first value after a space (`--to -1,0`) is the flag's value, not a flag.
        (
            &[
                "move",
                "trapezoid",
                "--to",
                "-3.5,0",
                "--time",
                "2",
                "--ramp",
                "0.5",
            ],
            "θ1 = -3.5 rad is outside the drive's range",
        ),
        (
            &[
                "live",
                "circle",
                "--centre",
                "0.5,0.5",
                "--radius=-0.1",
                "--period",
                "4",
                "--ramp",
                "1",
            ],
            "--radius -0.1",
        ),
        (&["set", "kp1", "nan"], "set kp1 NaN: out of its range"),
        (&["set", "lambda0", "0"], "set lambda0 0: out of its range"),
        (&["set", "va_min", "5"], "set va_min 5: out of its range"),
        (&["set", "link_timeout", "inf"], "set link_timeout inf"),
        (&["get", "nope"], "no parameter `nope`"),
        (&["--wait=-1", "status"], "--wait -1"),
        (&["live", "--window", "0"], "--window 0"),
        (&["compare", "--within=-1", "x.csv"], "--within -1"),
        (&["identify", "modes", "out", "--seconds", "nan"], "NaN s"),
        (
            &["identify", "friction", "out", "--cruise=-1"],
            "--cruise -1",
        ),
        (&["bringup", "--nudge", "2"], "--nudge in (0, 0.5] rad"),
    ] {
        let mut all = closed.to_vec();
        all.extend_from_slice(args);
        fails_with(&all, needle);
    }
    // A value the core accepts goes on to the connection (and fails there).
    let o = flexarm(&["--tcp", "127.0.0.1:1", "set", "va_min", "-30"]);
    assert!(!text(&o).1.contains("out of its range"), "{}", text(&o).1);
}

/// A waypoint file is uploaded in chunks of 8, in order, then run; the tool waits for its end.
#[test]
fn a_waypoint_file_is_uploaded_in_chunks_and_run() {
    fn path_firmware(c: &Command) -> Option<Reply> {
        use std::sync::atomic::{AtomicU16, Ordering};
        static NEXT: AtomicU16 = AtomicU16::new(0);
        match c {
            Command::Waypoints { first, points } => {
                // Chunks in order, each full but the last.
                let ok = *first == NEXT.load(Ordering::Relaxed);
                NEXT.store(first + points.len() as u16, Ordering::Relaxed);
                Some(if ok {
                    Reply::Done
                } else {
                    Reply::Refused(Refusal::Waypoints)
                })
            }
            Command::Move(flexarm_link::msg::Move::Waypoints { count }) => {
                Some(if *count == NEXT.load(Ordering::Relaxed) && *count == 20 {
                    Reply::Done
                } else {
                    Reply::Refused(Refusal::Waypoints)
                })
            }
            Command::Status => Some(Reply::Status(status_in(Mode::Armed, 0))),
            other => ours(other),
        }
    }
    let dir = std::env::temp_dir().join(format!("flexarm-path-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("path.csv");
    let csv: String = std::iter::once("theta1,theta2,dt\n".to_string())
        .chain((0..20).map(|k| format!("{},{},0.2\n", f64::from(k) * 0.02, -f64::from(k) * 0.01)))
        .collect();
    std::fs::write(&p, csv).unwrap();
    let port = firmware(path_firmware);
    let o = flexarm(&[
        "--tcp",
        &format!("127.0.0.1:{port}"),
        "move",
        "waypoints",
        &p.to_string_lossy(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(
        out,
        "move waypoints: started\nmove waypoints: ended, holding\n"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `bringup` on a drive with a latched fault: the first check fails, nothing is moved, the
/// table says what to do, exit status 1; nonsense settings are refused before any request.
#[test]
fn bringup_refuses_a_faulted_drive_and_bad_settings() {
    let port = firmware(ours).to_string();
    let at = format!("127.0.0.1:{port}");
    let o = flexarm(&["--tcp", &at, "bringup"]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{out}{err}");
    assert!(
        out.contains("state                  FAIL    fault 13"),
        "{out}"
    );
    assert!(out.contains("encoder 1 direction    not run"), "{out}");
    assert!(
        out.contains("fix (state): fix the fault's cause, then `flexarm clear`"),
        "{out}"
    );
    assert_eq!(
        err.trim(),
        "flexarm: bringup: failed at state; fix it as above and run it again"
    );
    let port = firmware(ours).to_string();
    fails_with(
        &[
            "--tcp",
            &format!("127.0.0.1:{port}"),
            "bringup",
            "--nudge",
            "2",
        ],
        "bringup takes --torque in (0, 100] N·m, --nudge in (0, 0.5] rad",
    );
}

/// A closed stdout (`flexarm … | head` once head has had its lines) ends the tool quietly,
/// status 141 as SIGPIPE would, not with a panic's trace.
#[test]
fn a_closed_stdout_ends_quietly() {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let o = Process::new(env!("CARGO_BIN_EXE_flexarm"))
        .args(["get", "list"])
        .stdout(writer)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(141), "{err}");
    assert!(err.is_empty(), "{err}");
}

/// SIGTERM during a move (what `kill`, a service manager or a closed terminal's SIGHUP sends)
/// stops the arm before the tool exits, as Ctrl-C does; it used to end the tool at once, the arm
/// still moving and a `--qemu` child still running (issue 36).
#[test]
fn a_terminate_signal_stops_the_move_before_the_tool_exits() {
    use std::io::BufRead;
    use std::process::Stdio;
    use std::sync::atomic::{AtomicBool, Ordering::SeqCst};
    use std::time::{Duration, Instant};
    static MOVING: AtomicBool = AtomicBool::new(false);
    static STOPPED: AtomicBool = AtomicBool::new(false);
    fn moving(c: &Command) -> Option<Reply> {
        match c {
            Command::Move(_) => MOVING.store(true, SeqCst),
            Command::Stop => STOPPED.store(true, SeqCst),
            Command::Status => {
                let mode = match MOVING.load(SeqCst) && !STOPPED.load(SeqCst) {
                    true => Mode::Moving,
                    false => Mode::Armed,
                };
                return Some(Reply::Status(status_in(mode, 0)));
            }
            _ => return ours(c),
        }
        Some(Reply::Done)
    }
    let at = format!("127.0.0.1:{}", firmware(moving));
    let args = [
        "--tcp",
        &at,
        "move",
        "trapezoid",
        "--to",
        "0.3,0.1",
        "--time",
        "600",
        "--ramp",
        "1",
    ];
    let mut child = Process::new(env!("CARGO_BIN_EXE_flexarm"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut out = std::io::BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    out.read_line(&mut line).unwrap();
    assert!(line.contains("move trapezoid: started"), "{line}");
    assert!(!STOPPED.load(SeqCst));
    let kill = Process::new("sh")
        .args(["-c", &format!("kill -TERM {}", child.id())])
        .status()
        .unwrap();
    assert!(kill.success());
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "still running after SIGTERM"
        );
        thread::sleep(Duration::from_millis(20));
    };
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert!(STOPPED.load(SeqCst), "no Stop sent: {err}");
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(
        err.contains("interrupted") && err.contains("stopped"),
        "{err}"
    );
}

/// A move the link watchdog cut short is reported as such, exit 1, not as "ended, holding"
/// (issue 36: after a console pause it printed `ended, holding` and exited 0).
#[test]
fn a_move_the_watchdog_stopped_is_not_reported_as_ended() {
    use std::sync::atomic::{AtomicU32, Ordering::SeqCst};
    static STATUS_AFTER_MOVE: AtomicU32 = AtomicU32::new(0);
    fn cut_short(c: &Command) -> Option<Reply> {
        let moving = match c {
            Command::Move(_) => {
                STATUS_AFTER_MOVE.store(1, SeqCst);
                return Some(Reply::Done);
            }
            Command::Status => match STATUS_AFTER_MOVE.load(SeqCst) {
                0 => None,
                n => {
                    STATUS_AFTER_MOVE.store(n + 1, SeqCst);
                    Some(n < 3)
                }
            },
            _ => return ours(c),
        };
        // Moving for two polls, then holding with one watchdog stop counted.
        Some(Reply::Status(status_in(
            if moving == Some(true) {
                Mode::Moving
            } else {
                Mode::Armed
            },
            u32::from(moving == Some(false)),
        )))
    }
    let at = format!("127.0.0.1:{}", firmware(cut_short));
    let o = flexarm(&[
        "--tcp",
        &at,
        "move",
        "trapezoid",
        "--to",
        "0.3,0.1",
        "--time",
        "2",
        "--ramp",
        "0.5",
    ]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{out}{err}");
    assert!(out.contains("move trapezoid: started"), "{out}");
    assert!(!out.contains("ended, holding"), "{out}");
    assert!(
        err.contains("stopped short of its end by the link watchdog"),
        "{err}"
    );
}

/// `plot` draws a trace file already written, without a board; a file that is not a trace is
/// one line naming it; `completions` prints a shell's script that knows the subcommands.
#[test]
fn plot_and_completions_need_no_board() {
    let dir = std::env::temp_dir().join(format!("flexarm-plot-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // A short trace in the simulator's format, written by the simulator's own writer.
    let traj = flexarm_core::trajectory::JointTrajectory::Trapezoid(
        flexarm_core::trajectory::Trapezoid::paper(),
    );
    let cfg = flexarm_host::sim::SimConfig {
        duration: 0.5,
        tail_window: 0.25,
        ..flexarm_host::sim::SimConfig::default()
    };
    let (summary, trace) = flexarm_host::sim::simulate(&cfg, &traj, true).unwrap();
    let o = flexarm_host::study::Outcome {
        case: flexarm_host::study::Case {
            scenario: "short",
            controller: "paper",
            config: cfg,
            trajectory: traj,
        },
        summary,
        trace,
    };
    flexarm_host::output::write_csv(&dir, &o).unwrap();
    let csv = dir.join("short_paper.csv");
    let out = dir.join("figures");
    let o = flexarm(&["plot", csv.to_str().unwrap(), out.to_str().unwrap()]);
    let (stdout, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{stdout}{err}");
    assert!(stdout.contains("plot: wrote plot_trace.svg"), "{stdout}");
    let svg = std::fs::read_to_string(out.join("plot_trace.svg")).unwrap();
    assert!(
        svg.starts_with("<svg") && svg.len() > 10_000,
        "{}",
        svg.len()
    );
    // Not a trace: named, nothing written.
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, "a,b\n1,2\n").unwrap();
    fails_with(
        &[
            "plot",
            bad.to_str().unwrap(),
            dir.join("none").to_str().unwrap(),
        ],
        "bad.csv",
    );
    assert!(!dir.join("none").join("plot_trace.svg").exists());
    // Completions.
    let o = flexarm(&["completions", "bash"]);
    let (script, _) = text(&o);
    assert_eq!(o.status.code(), Some(0));
    for word in ["flexarm", "move", "record", "plot", "completions", "--tcp"] {
        assert!(script.contains(word), "{word}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `config dump` writes every parameter as a file that `config diff` and `config restore` read
/// back; a dump with a mistake is named by file, line and key before any connection.
#[test]
fn config_dump_diff_and_restore() {
    let dir = std::env::temp_dir().join(format!("flexarm-config-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let at = |port: u16| format!("127.0.0.1:{port}");
    let o = flexarm(&["--tcp", &at(firmware(ours)), "config", "dump"]);
    let (dump, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    // Every parameter, its unit and range; the stand-in's build is not one the console
    // reproduces: its defaults are unknown.
    for p in flexarm_link::params::PARAMS {
        assert!(
            dump.contains(&format!("\n{} = 30.0 # [{}]", p.name, p.unit)),
            "{} in\n{dump}",
            p.name
        );
    }
    assert!(dump.contains("params_hash = \"12345678\"") && dump.contains("build default ?"));
    // (The stand-in answers 30 to every get; a board's va_min is negative, its piezo law a
    // code 0–3, the film's gains fractions of a volt per volt and the stall check's speed
    // error a fraction of a rad/s.)
    let dump = dump
        .replace("\nva_min = 30.0", "\nva_min = -30.0")
        .replace("\npiezo_law = 30.0", "\npiezo_law = 1.0")
        .replace("\nfilm_static = 30.0", "\nfilm_static = 0.0")
        .replace("\nfilm_feedthrough = 30.0", "\nfilm_feedthrough = 0.0")
        .replace("\nstall_speed_error = 30.0", "\nstall_speed_error = 0.1");
    let file = dir.join("dump.toml");
    std::fs::write(&file, dump.replace("\nkc = 30.0", "\nkc = 3.0")).unwrap();
    let config = |what: &str, file: &std::path::Path| {
        flexarm(&[
            "--tcp",
            &at(firmware(ours)),
            "config",
            what,
            file.to_str().unwrap(),
        ])
    };
    let o = config("diff", &file);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(out.contains("kc: board 30 s, file 3 s"), "{out}");
    assert!(out.contains("va_min: board 30 V, file -30 V"), "{out}");
    assert!(
        out.contains(&format!(
            "config diff: 6 of {} differ",
            flexarm_link::params::PARAMS.len()
        )),
        "{out}"
    );
    let o = config("restore", &file);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(
        out.contains("config restore: wrote") && out.contains("kc") && !out.contains("va_bias"),
        "{out}"
    );
    // Mistakes, before connecting (nothing listens on port 1).
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, dump.replace("\nkc = 30.0", "\nnope = 1.0")).unwrap();
    let line = dump.lines().position(|l| l.starts_with("kc = ")).unwrap() + 1;
    fails_with(
        &[
            "--tcp",
            "127.0.0.1:1",
            "config",
            "restore",
            bad.to_str().unwrap(),
        ],
        &format!("bad.toml:{line}: `params.nope`: no such parameter"),
    );
    std::fs::write(&bad, dump.replace("\nkc = 30.0", "\nkc = -5.0")).unwrap();
    fails_with(
        &[
            "--tcp",
            "127.0.0.1:1",
            "config",
            "diff",
            bad.to_str().unwrap(),
        ],
        "`params.kc`: -5 is outside its range",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `faults` with no fault latched refuses, writing nothing: the recorder is still recording,
/// and pages read one after the other would be torn.
#[test]
fn faults_without_a_fault_refuses() {
    fn recording(c: &Command) -> Option<Reply> {
        match c {
            Command::Faults { from } => Some(Reply::Faults(flexarm_link::msg::FaultPage {
                fault: None,
                total: 500,
                from: *from,
                samples: heapless::Vec::new(),
            })),
            _ => ours(c),
        }
    }
    let dir = std::env::temp_dir().join(format!("flexarm-faults-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let at = format!("127.0.0.1:{}", firmware(recording));
    fails_with(
        &["--tcp", &at, "faults", dir.to_str().unwrap()],
        "no fault is latched",
    );
    assert!(!dir.exists(), "nothing written");
}

/// Homing's stand-in: refuses `arm` as not homed until `Home`, answers the first two status
/// requests after it as homing, then holding with both joints homed.
fn homing_firmware(c: &Command) -> Option<Reply> {
    use std::sync::atomic::{AtomicU32, Ordering};
    static POLLS: AtomicU32 = AtomicU32::new(0);
    Some(match c {
        Command::Arm => Reply::Refused(Refusal::NotHomed),
        Command::Home => {
            POLLS.store(1, Ordering::SeqCst);
            Reply::Done
        }
        Command::Status => {
            let n = POLLS.fetch_add(1, Ordering::SeqCst);
            let mut s = status_in(Mode::Homing, 0);
            s.homing = [HomeState::Searching, HomeState::Unhomed];
            if n == 0 {
                s.mode = Mode::Disarmed;
                s.homing = [HomeState::Unhomed; 2];
            } else if n >= 3 {
                s.mode = Mode::Armed;
                s.homing = [HomeState::Homed; 2];
            }
            Reply::Status(s)
        }
        c => return ours(c),
    })
}

/// A stand-in on which a declared pose is shown declared.
fn declared_firmware(c: &Command) -> Option<Reply> {
    Some(match c {
        Command::DeclareHome { theta } if theta.iter().all(|t| t.is_finite()) => Reply::Done,
        Command::Status => {
            let mut s = status_in(Mode::Disarmed, 0);
            s.homing = [HomeState::Declared; 2];
            Reply::Status(s)
        }
        c => return ours(c),
    })
}

#[test]
fn arm_is_refused_until_homed_and_home_waits_for_the_searches() {
    let at = |port: u16| format!("127.0.0.1:{port}");
    let port = firmware(homing_firmware);
    fails_with(&["--tcp", &at(port), "arm"], "a joint is not homed");
    let o = flexarm(&["--tcp", &at(firmware(homing_firmware)), "home"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(
        out, "home: done, holding (joint 1 homed, joint 2 homed)\n",
        "{err}"
    );
    // The status names each joint's state; an unhomed one loudly.
    let o = flexarm(&["--tcp", &at(firmware(ours)), "status"]);
    assert!(text(&o).0.contains("homing: joint 1 homed, joint 2 homed"));
}

#[test]
fn a_declared_pose_is_warned_about_and_shown_declared() {
    let at = |port: u16| format!("127.0.0.1:{port}");
    let o = flexarm(&[
        "--tcp",
        &at(firmware(declared_firmware)),
        "home",
        "--declare",
        "2.0,-0.3",
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.starts_with("WARNING: declaring the pose without homing"),
        "{err}"
    );
    assert!(
        out.contains("(2, -0.3) rad by the operator's word")
            && out.contains("DECLARED by the operator (not homed)"),
        "{out}"
    );
    fails_with(
        &[
            "--tcp",
            &at(firmware(declared_firmware)),
            "home",
            "--declare",
            "1",
        ],
        "--declare takes two values",
    );
}

/// `flexarm shell` on one connection: commands as on the command line, read from its input
/// (here a pipe: no terminal); a mistake prints its line and the session goes on; `quit` ends
/// it with status 0. Completion comes from the command line's own definition (the unit tests
/// of `flexarm_console::shell`).
#[test]
fn the_shell_runs_commands_on_one_connection() {
    use std::io::Write as _;
    let port = firmware(ours);
    let mut child = Process::new(env!("CARGO_BIN_EXE_flexarm"))
        .args(["--tcp", &format!("127.0.0.1:{port}"), "shell"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let script = "get kc\nset kc nan\nfrobnicate\nget nosuch\n\nset kc 3\nget list\nquit\nget kc\n";
    child
        .stdin
        .take()
        .unwrap()
        .write_all(script.as_bytes())
        .unwrap();
    let o = child.wait_with_output().unwrap();
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{out}{err}");
    // One connection: the stand-in firmware accepts one; every command after the first got an
    // answer on it.
    assert_eq!(out.matches("kc = 30 s").count(), 1, "{out}");
    assert!(out.contains("set kc = 3 s: done"), "{out}");
    assert!(out.contains("stall_speed_error"), "the list: {out}");
    // Three mistakes, one line each, named as on the command line; nothing after `quit` ran.
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 3, "{err}");
    assert!(lines.iter().all(|l| l.starts_with("flexarm: ")), "{err}");
    assert!(
        lines[0].contains("kc") && lines[1].contains("frobnicate"),
        "{err}"
    );
    assert!(lines[2].contains("nosuch"), "{err}");
}

/// `flexarm tree`: every value by name, as TOML a script can read: the handshake, each status
/// field the link carries, every parameter, and the telemetry (here refused by the stand-in,
/// which says so in a comment).
#[test]
fn the_tree_names_every_value() {
    let port = firmware(ours);
    let o = flexarm(&["--tcp", &format!("127.0.0.1:{port}"), "tree"]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let tree: toml::Table = toml::from_str(&out).unwrap();
    assert_eq!(tree["hello"]["build"].as_str(), Some("stand-in"));
    let status = tree["status"].as_table().unwrap();
    for key in [
        "mode",
        "fault",
        "ticks",
        "loads",
        "rx_line",
        "homing",
        "brake_engaged",
    ] {
        assert!(status.contains_key(key), "{key} in {out}");
    }
    let params = tree["parameters"].as_table().unwrap();
    assert_eq!(params.len(), flexarm_link::params::PARAMS.len());
    assert!(
        out.contains("# no frame: the board refused the subscription"),
        "{out}"
    );
}
