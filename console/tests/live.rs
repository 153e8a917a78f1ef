//! The live view on ratatui's test backend: its panels and numbers from known frames, the keys
//! and what they send, and the view's bounds under a flood of frames (a stand-in firmware in
//! process, behind the console's `Link`).

use std::collections::VecDeque;
use std::io::{self, Read, Write};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use flexarm_console::client::{Client, ConsoleError};
use flexarm_console::live::{self, KeyAction, View, key_action};
use flexarm_console::transport::Link;
use flexarm_link::msg::{Board, Channels, Hello, HomeState, Load, Mode, Status, Telemetry};
use flexarm_link::{Command, Decoder, DeviceMsg, MAX_FRAME, Reply, Request, VERSION, encode};
use ratatui::Terminal;
use ratatui::backend::TestBackend;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};

/// A stand-in firmware: answers requests (the drive's mode follows Stop and Estop), and, when
/// flooding, never lets the line fall quiet.
struct Stand {
    decoder: Decoder,
    out: VecDeque<u8>,
    mode: Mode,
    flood: bool,
    seq: u32,
    /// Every command received, for the test to read.
    log: Arc<Mutex<Vec<Command>>>,
}

impl Stand {
    fn new(mode: Mode, flood: bool) -> (Self, Arc<Mutex<Vec<Command>>>) {
        let log = Arc::new(Mutex::new(Vec::new()));
        let s = Self {
            decoder: Decoder::new(),
            out: VecDeque::new(),
            mode,
            flood,
            seq: 0,
            log: log.clone(),
        };
        (s, log)
    }

    fn emit(&mut self, m: &DeviceMsg) {
        let mut buf = [0u8; MAX_FRAME];
        self.out.extend(encode(m, &mut buf).unwrap().iter());
    }

    fn answer(&mut self, command: &Command) -> Reply {
        match command {
            Command::Hello { .. } => Reply::Hello(Hello {
                version: VERSION,
                board: Board::Qemu,
                build: heapless::String::try_from("stand-in").unwrap(),
                params_hash: 0,
                motor_hz: 1000,
                piezo_hz: 10_000,
                settings: flexarm_link::msg::Settings::Defaults,
            }),
            Command::Status => Reply::Status(status(self.mode, None)),
            Command::Stop => {
                // The stop ends at once: the next status holds.
                if self.mode == Mode::Moving {
                    self.mode = Mode::Armed;
                }
                Reply::Done
            }
            Command::Estop => {
                self.mode = Mode::Fault;
                Reply::Done
            }
            _ => Reply::Done,
        }
    }
}

impl Read for Stand {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.out.is_empty() && self.flood {
            self.seq += 1;
            let t = frame(self.seq, u64::from(self.seq), [0.0; 12]);
            self.emit(&DeviceMsg::Telemetry(t));
        }
        if self.out.is_empty() {
            return Err(io::ErrorKind::WouldBlock.into());
        }
        let n = buf.len().min(self.out.len());
        for b in buf.iter_mut().take(n) {
            *b = self.out.pop_front().unwrap();
        }
        Ok(n)
    }
}

impl Write for Stand {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        for &b in buf {
            if let Some(Ok(Request { id, command })) = self.decoder.push::<Request>(b) {
                self.log.lock().unwrap().push(command.clone());
                let reply = self.answer(&command);
                self.emit(&DeviceMsg::Reply { id, reply });
            }
        }
        Ok(buf.len())
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

impl Link for Stand {
    fn set_timeout(&mut self, _: Duration) -> Result<(), ConsoleError> {
        Ok(())
    }
}

fn status(mode: Mode, fault: Option<u8>) -> Status {
    Status {
        mode,
        fault,
        ticks: 1234,
        loads: [
            Load {
                mean_cycles: 100,
                worst_cycles: 200,
                misses: 0,
            },
            Load {
                mean_cycles: 300,
                worst_cycles: 400,
                misses: 2,
            },
        ],
        telemetry_dropped: 5,
        link_stops: 1,
        rx_bytes: 0,
        rx_lost: 0,
        rx_malformed: 0,
        rx_line: Default::default(),
        stack_used: 0,
        homing: [HomeState::Homed; 2],
        homing_failed: false,
        brake_engaged: true,
    }
}

/// A frame of every channel: e1 e2 θ1 θ2 δ1 δ2 τ1 τ2 V_a V_f load_piezo load_motor.
fn frame(seq: u32, tick: u64, v: [f32; 12]) -> Telemetry {
    Telemetry {
        seq,
        tick,
        brake_engaged: false,
        channels: Channels(Channels::ALL),
        values: heapless::Vec::from_slice(&v).unwrap(),
    }
}

fn screen(view: &View) -> String {
    let mut t = Terminal::new(TestBackend::new(140, 40)).unwrap();
    t.draw(|f| view.render(f)).unwrap();
    let buf = t.backend().buffer();
    let mut text = String::new();
    for y in 0..buf.area.height {
        for x in 0..buf.area.width {
            text.push_str(buf[(x, y)].symbol());
        }
        text.push('\n');
    }
    text
}

#[test]
fn the_panels_show_the_latest_values_and_the_state() {
    let mut view = View::new("stand-in on Qemu".into(), 1000, 1, 10.0);
    let mut frames = Vec::new();
    for k in 0..500u32 {
        let a = k as f32 * 1e-3;
        frames.push(frame(
            k,
            u64::from(k),
            [
                a * 1e-3,
                -2e-3,
                0.5,
                0.2,
                1e-4,
                -2e-5,
                1.5,
                -0.25,
                12.5,
                0.0625,
                0.125,
                0.3,
            ],
        ));
    }
    // A gap of three frames: counted lost.
    frames.push(frame(
        503,
        503,
        [
            1.234e-3, -2e-3, 0.5, 0.2, 1e-4, -2e-5, 1.5, -0.25, 12.5, 0.0625, 0.125, 0.3,
        ],
    ));
    view.ingest(&frames);
    view.status(status(Mode::Moving, None));
    let s = screen(&view);
    for expected in [
        "flexarm live · stand-in on Qemu",
        "mode: MOVING",
        "fault: none",
        "frames 501, lost 3, dropped 5, watchdog stops 1",
        "stream: 1000/s streamed, measuring",
        "tracking error [mrad]  e1 +1.234  e2 -2.000",
        "δ̂1 +0.100  δ̂2 -0.020 [×1e-3]",
        "piezo [V]  V_a +12.50  V_f +0.0625",
        "torque [N·m]  τ1 +1.500  τ2 -0.250",
        "piezo loop: load 12.50 %, 0 deadline misses",
        "motor loop: load 30.00 %, 2 deadline misses",
        "s stop · e/space emergency stop · q quit",
    ] {
        assert!(s.contains(expected), "missing {expected:?} in\n{s}");
    }
    // The tip deflection is the model's, from θ and δ̂.
    let model = flexarm_console::record::paper_model();
    let tip = model.tip_deflection(&flexarm_core::Vector4::new(0.5, 0.2, 1e-4, -2e-5)) * 1e3;
    assert!(
        s.contains(&format!("tip {tip:+.3} mm")),
        "tip {tip} in\n{s}"
    );

    view.status(status(
        Mode::Fault,
        Some(flexarm_core::Fault::Runaway as u8),
    ));
    let s = screen(&view);
    assert!(s.contains("mode: FAULT (safe state)"), "{s}");
    assert!(s.contains("brake: engaged"), "{s}");
    assert!(
        s.contains(flexarm_core::Fault::Runaway.as_str()),
        "the fault's name in\n{s}"
    );
}

#[test]
fn the_keys_map_to_stop_estop_and_quit() {
    let press = |code, modifiers| KeyEvent::new(code, modifiers);
    let none = KeyModifiers::NONE;
    assert_eq!(
        key_action(&press(KeyCode::Char('s'), none)),
        Some(KeyAction::Stop)
    );
    assert_eq!(
        key_action(&press(KeyCode::Char('e'), none)),
        Some(KeyAction::Estop)
    );
    assert_eq!(
        key_action(&press(KeyCode::Char(' '), none)),
        Some(KeyAction::Estop)
    );
    assert_eq!(
        key_action(&press(KeyCode::Char('q'), none)),
        Some(KeyAction::Quit)
    );
    assert_eq!(
        key_action(&press(KeyCode::Esc, none)),
        Some(KeyAction::Quit)
    );
    assert_eq!(
        key_action(&press(KeyCode::Char('c'), KeyModifiers::CONTROL)),
        Some(KeyAction::Quit)
    );
    assert_eq!(key_action(&press(KeyCode::Char('c'), none)), None);
    assert_eq!(key_action(&press(KeyCode::Char('x'), none)), None);
    let mut release = press(KeyCode::Char('e'), none);
    release.kind = KeyEventKind::Release;
    assert_eq!(key_action(&release), None);
}

#[test]
fn the_keys_send_their_commands_and_quit_stops_a_move_first() {
    let (stand, log) = Stand::new(Mode::Moving, false);
    let mut c = Client::connect(Box::new(stand), Duration::from_secs(1)).unwrap();
    let mut view = View::new("t".into(), 1000, 1, 10.0);
    log.lock().unwrap().clear();

    // Quit while a move runs: a stop, waited for, then the view ends.
    assert!(live::act(&mut c, &mut view, KeyAction::Quit).unwrap());
    let sent = std::mem::take(&mut *log.lock().unwrap());
    assert_eq!(sent[0], Command::Status);
    assert_eq!(sent[1], Command::Stop);
    assert_eq!(sent.last(), Some(&Command::Status));

    // Stop and emergency stop: one command each, the view goes on and says what happened.
    assert!(!live::act(&mut c, &mut view, KeyAction::Stop).unwrap());
    assert!(view.message.starts_with("stop: sent"));
    assert!(!live::act(&mut c, &mut view, KeyAction::Estop).unwrap());
    // An emergency stop disarms (no fault is latched, so `clear` would be refused): the hint
    // says to arm (issue 36: it said "clear, then arm").
    assert_eq!(
        view.message,
        "EMERGENCY STOP: safe state, disarmed (arm to hold again)"
    );
    assert_eq!(
        std::mem::take(&mut *log.lock().unwrap()),
        [Command::Stop, Command::Estop]
    );

    // Quit at rest sends no stop.
    assert!(live::act(&mut c, &mut view, KeyAction::Quit).unwrap());
    assert_eq!(*log.lock().unwrap(), [Command::Status]);
}

#[test]
fn a_flood_of_frames_neither_holds_the_keys_nor_grows_the_view() {
    let (stand, _) = Stand::new(Mode::Moving, true);
    let mut c = Client::connect(Box::new(stand), Duration::from_secs(1)).unwrap();
    let mut view = View::new("t".into(), 1000, 1, 10.0);
    // The line never falls quiet: each slice still ends, and the keys come round again.
    let mut frames = 0;
    for _ in 0..20 {
        let start = Instant::now();
        c.pump(live::SLICE).unwrap();
        // The slice's budget is 20 ms; a second means it never ended on its own.
        assert!(
            start.elapsed() < Duration::from_secs(1),
            "{:?}",
            start.elapsed()
        );
        let t = c.take_telemetry();
        frames += t.len();
        view.ingest(&t);
    }
    assert!(frames > 0);
    // A long run at the highest rate: at most POINTS points per plot.
    let many: Vec<Telemetry> = (0..200_000u32)
        .map(|k| frame(k, u64::from(k), [1e-3; 12]))
        .collect();
    view.ingest(&many);
    assert!(view.points_held() <= live::POINTS, "{}", view.points_held());
    assert!(view.points_held() >= live::POINTS / 2);
}

/// The header shows the rate that arrives on the host's clock, and says when the firmware's
/// clock runs behind it (an emulator on a loaded host: issue 36's "(100/s)" whatever arrived).
#[test]
fn the_header_shows_the_rate_received_and_a_firmware_clock_behind_real_time() {
    // A firmware streaming every period of its 1 kHz loop, `per_batch` frames (that many ms of
    // its time) every 0.1 s of the host's clock, for 2 s: at half of real time with 50.
    let streamed = |per_batch: u32| {
        let mut view = View::new("stand-in on Qemu".into(), 1000, 1, 10.0);
        let start = Instant::now();
        for k in 0..20u32 {
            let frames: Vec<_> = (1..=per_batch)
                .map(|i| k * per_batch + i)
                .map(|seq| frame(seq, u64::from(seq), [0.0; 12]))
                .collect();
            view.ingest_at(&frames, start + Duration::from_millis(100 * u64::from(k)));
        }
        view
    };
    let slow = streamed(50);
    let (rate, clock) = slow.measured().unwrap();
    assert!(
        (rate - 500.0).abs() < 30.0 && (clock - 0.5).abs() < 0.03,
        "{rate} {clock}"
    );
    let s = screen(&slow);
    assert!(s.contains("500/s received"), "{s}");
    assert!(s.contains("firmware clock 0.50× real time: behind"), "{s}");
    // At full speed: no warning.
    let fast = streamed(100);
    let s = screen(&fast);
    assert!(
        s.contains("1000/s received") && !s.contains("behind"),
        "{s}"
    );
}
