//! `live`: a full-screen view of the running arm (ratatui), in the terminal the operator already
//! has open.
//!
//! Four plots over the last [`View::window`] seconds, each titled with its latest values:
//! tracking errors `θ − θ_d` [mrad], the vibration (the estimated modal coordinates `δ̂`
//! [√kg·m ×10⁻³] and the tip deflection `w(l₂)` [mm] computed from them with the paper's model),
//! the piezo command `V_a` and film voltage `V_f` [V], the motor torques `τ` [N·m]; a line with
//! the mode, the brake, the latched fault and the link's counters; the two loops' loads with
//! their deadline misses. Keys, read between every two reads of the line, so they work whatever the firmware
//! streams: `s` stop (category 1), `e` or space the emergency stop (category 0), `q`, Esc or
//! Ctrl-C leave (a running move is stopped first, as on Ctrl-C elsewhere).
//!
//! The screen is redrawn 10 times a second ([`REDRAW`]); telemetry is read in between in slices
//! of at most [`SLICE`], so at the highest rate the link carries the view stays as responsive as
//! at the lowest, and each plot keeps at most [`POINTS`] points however fast frames come.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use flexarm_link::msg::{Channels, Mode, Status, Telemetry};
use flexarm_link::{Command, Reply};
use ratatui::Frame;
use ratatui::crossterm::event::{self, Event, KeyCode, KeyEvent, KeyEventKind, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Style, Stylize};
use ratatui::symbols::Marker;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Axis, Block, Chart, Dataset, Gauge, GraphType, Paragraph};

use crate::client::{Client, ConsoleError};
use crate::record::{Values, values};

/// Screen redraws: 10 a second, readable and light.
pub const REDRAW: Duration = Duration::from_millis(100);
/// The longest the line is read before the keys are looked at again.
pub const SLICE: Duration = Duration::from_millis(20);
/// Status requests (mode, fault, loads' misses), which also feed the link watchdog.
/// The span of arrivals the measured rate and clock are taken over.
const CLOCK_WINDOW: Duration = Duration::from_secs(3);

/// Below this many firmware seconds per host second the header says the firmware is behind.
const SLOW_CLOCK: f64 = 0.9;

const STATUS_EVERY: Duration = Duration::from_millis(250);
/// Points per plotted series, at most.
pub const POINTS: usize = 1500;

/// What a key asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KeyAction {
    /// A controlled stop of the running move.
    Stop,
    /// The safe state now.
    Estop,
    /// Leave the view (a running move is stopped first).
    Quit,
}

/// The action of a key press (`None`: not one of ours, or a release).
pub fn key_action(k: &KeyEvent) -> Option<KeyAction> {
    if k.kind == KeyEventKind::Release {
        return None;
    }
    match k.code {
        KeyCode::Char('c') if k.modifiers.contains(KeyModifiers::CONTROL) => Some(KeyAction::Quit),
        KeyCode::Char('s' | 'S') => Some(KeyAction::Stop),
        KeyCode::Char('e' | 'E' | ' ') => Some(KeyAction::Estop),
        KeyCode::Char('q' | 'Q') | KeyCode::Esc => Some(KeyAction::Quit),
        _ => None,
    }
}

/// The plotted series, in the order of [`View::series`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Series {
    E1,
    E2,
    D1,
    D2,
    Tip,
    Va,
    Vf,
    Tau1,
    Tau2,
}
const SERIES: usize = 9;

/// What the view shows: the latest frames, the status, the last message.
pub struct View {
    /// Seconds shown by the plots.
    pub window: f64,
    motor_hz: f64,
    /// Frames kept per plotted point (1 until the window would hold more than [`POINTS`]).
    every: u64,
    series: [VecDeque<(f64, f64)>; SERIES],
    /// The latest frame.
    latest: Option<Telemetry>,
    /// The latest status.
    status: Option<Status>,
    /// Frames received and lost (sequence gaps).
    frames: u64,
    lost: u64,
    last_seq: Option<u32>,
    /// The first frame's tick (time zero of the plots).
    tick0: Option<u64>,
    /// Frames per second of the firmware's time (the subscription's).
    rate: f64,
    /// Arrivals on the host's clock: when a batch came and the last frame's tick, over the
    /// last [`CLOCK_WINDOW`] (the measured rate and the firmware's clock against the host's).
    arrivals: VecDeque<(Instant, u64, u64)>,
    /// The header: firmware and board.
    title: String,
    /// The last thing done (a key's effect, an error of the line).
    pub message: String,
    model: flexarm_core::model::Model<f64>,
}

impl View {
    /// A view of a firmware whose motor loop runs at `motor_hz`, streaming every `decimation`-th
    /// period, over `window` seconds.
    pub fn new(title: String, motor_hz: u32, decimation: u16, window: f64) -> Self {
        let rate = f64::from(motor_hz) / f64::from(decimation.max(1));
        Self {
            window,
            motor_hz: f64::from(motor_hz.max(1)),
            every: ((rate * window) / POINTS as f64).ceil().max(1.0) as u64,
            series: Default::default(),
            latest: None,
            status: None,
            frames: 0,
            lost: 0,
            last_seq: None,
            tick0: None,
            rate,
            arrivals: VecDeque::new(),
            title,
            message: "ready".into(),
            model: crate::record::paper_model(),
        }
    }

    /// Takes telemetry frames (every channel, [`Channels::ALL`]) received now.
    pub fn ingest(&mut self, frames: &[Telemetry]) {
        self.ingest_at(frames, Instant::now());
    }

    /// [`Self::ingest`] of frames received at `now` on the host's clock.
    pub fn ingest_at(&mut self, frames: &[Telemetry], now: Instant) {
        self.receive(frames);
        if let Some(f) = frames.last() {
            self.arrivals.push_back((now, f.tick, self.frames));
            while self
                .arrivals
                .front()
                .is_some_and(|(t, ..)| now.duration_since(*t) > CLOCK_WINDOW)
            {
                self.arrivals.pop_front();
            }
        }
    }

    /// Over the last [`CLOCK_WINDOW`] of arrivals: frames received per second of the host's
    /// clock, and the firmware's seconds per host second. `None` before a second of it.
    pub fn measured(&self) -> Option<(f64, f64)> {
        let (&(t0, tick0, n0), &(t1, tick1, n1)) = (self.arrivals.front()?, self.arrivals.back()?);
        let wall = t1.duration_since(t0).as_secs_f64();
        if wall < 1.0 {
            return None;
        }
        let firmware = tick1.saturating_sub(tick0) as f64 / self.motor_hz;
        Some(((n1 - n0) as f64 / wall, firmware / wall))
    }

    fn receive(&mut self, frames: &[Telemetry]) {
        for f in frames {
            if f.channels.0 != Channels::ALL {
                continue;
            }
            if let Some(s) = self.last_seq {
                self.lost += u64::from(f.seq.wrapping_sub(s).saturating_sub(1));
            }
            self.last_seq = Some(f.seq);
            self.frames += 1;
            let tick0 = *self.tick0.get_or_insert(f.tick);
            self.latest = Some(f.clone());
            if !self.frames.is_multiple_of(self.every) {
                continue;
            }
            let t = f.tick.saturating_sub(tick0) as f64 / self.motor_hz;
            let v = values(f);
            let values = [
                v.error(0) * 1e3,
                v.error(1) * 1e3,
                v.delta(0) * 1e3,
                v.delta(1) * 1e3,
                self.model.tip_deflection(&v.q()) * 1e3,
                v.v_a(),
                v.v_f(),
                v.tau(0),
                v.tau(1),
            ];
            for (s, y) in self.series.iter_mut().zip(values) {
                s.push_back((t, y));
                while s.front().is_some_and(|&(t0, _)| t0 < t - self.window) || s.len() > POINTS {
                    s.pop_front();
                }
            }
        }
    }

    /// Takes a status.
    pub fn status(&mut self, s: Status) {
        self.status = Some(s);
    }

    /// The most points any plot holds.
    pub fn points_held(&self) -> usize {
        self.series.iter().map(VecDeque::len).max().unwrap_or(0)
    }

    fn points(&self, s: Series) -> Vec<(f64, f64)> {
        self.series[s as usize].iter().copied().collect()
    }

    /// The latest frame's values (NaN before the first).
    fn now(&self) -> Values<'_> {
        Values(self.latest.as_ref())
    }

    /// Draws the whole view into `frame`.
    pub fn render(&self, frame: &mut Frame) {
        let [head, plots, loads, foot] = Layout::vertical([
            Constraint::Length(4),
            Constraint::Min(8),
            Constraint::Length(3),
            Constraint::Length(1),
        ])
        .areas(frame.area());
        self.render_head(frame, head);
        let [top, bottom] =
            Layout::vertical([Constraint::Percentage(50), Constraint::Percentage(50)]).areas(plots);
        let [a, b] =
            Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)]).areas(top);
        let [c, d] = Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)])
            .areas(bottom);
        let now = self.now();
        let e = [now.error(0) * 1e3, now.error(1) * 1e3];
        self.plot(
            frame,
            a,
            format!(" tracking error [mrad]  e1 {:+.3}  e2 {:+.3} ", e[0], e[1]),
            &[
                (Series::E1, "e1", Color::Cyan),
                (Series::E2, "e2", Color::Magenta),
            ],
        );
        self.plot(
            frame,
            b,
            format!(
                " vibration  δ̂1 {:+.3}  δ̂2 {:+.3} [×1e-3]  tip {:+.3} mm ",
                now.delta(0) * 1e3,
                now.delta(1) * 1e3,
                self.model.tip_deflection(&now.q()) * 1e3
            ),
            &[
                (Series::D1, "δ̂1", Color::Cyan),
                (Series::D2, "δ̂2", Color::Magenta),
                (Series::Tip, "tip", Color::Yellow),
            ],
        );
        self.plot(
            frame,
            c,
            format!(" piezo [V]  V_a {:+.2}  V_f {:+.4} ", now.v_a(), now.v_f()),
            &[
                (Series::Va, "V_a", Color::Yellow),
                (Series::Vf, "V_f", Color::Green),
            ],
        );
        self.plot(
            frame,
            d,
            format!(
                " torque [N·m]  τ1 {:+.3}  τ2 {:+.3} ",
                now.tau(0),
                now.tau(1)
            ),
            &[
                (Series::Tau1, "τ1", Color::Cyan),
                (Series::Tau2, "τ2", Color::Magenta),
            ],
        );
        self.render_loads(frame, loads);
        frame.render_widget(
            Paragraph::new(Line::from(vec![
                Span::raw(" keys: "),
                Span::raw("s").bold(),
                Span::raw(" stop · "),
                Span::raw("e").bold(),
                Span::raw("/"),
                Span::raw("space").bold(),
                Span::raw(" emergency stop · "),
                Span::raw("q").bold(),
                Span::raw(" quit   │ "),
                Span::raw(self.message.as_str()),
            ])),
            foot,
        );
    }

    fn render_head(&self, frame: &mut Frame, area: Rect) {
        let (mode, colour) = match self.status.map(|s| s.mode) {
            None => ("…", Color::Gray),
            Some(Mode::Disarmed) => ("DISARMED", Color::Gray),
            Some(Mode::Armed) => ("ARMED, holding", Color::Green),
            Some(Mode::Moving) => ("MOVING", Color::Cyan),
            Some(Mode::Stopping) => ("STOPPING", Color::Yellow),
            Some(Mode::Fault) => ("FAULT (safe state)", Color::Red),
            Some(Mode::Homing) => ("HOMING", Color::Yellow),
        };
        let fault = match self.status.and_then(|s| s.fault) {
            None => "none".to_string(),
            Some(f) => format!("{f} ({})", crate::fault_name(f)),
        };
        let (dropped, stops) = self
            .status
            .map_or((0, 0), |s| (s.telemetry_dropped, s.link_stops));
        let brake = match self.status.map(|s| s.brake_engaged) {
            None => "…",
            Some(true) => "engaged",
            Some(false) => "released",
        };
        let line = Line::from(vec![
            Span::raw(" mode: "),
            Span::styled(mode, Style::new().fg(colour).bold()),
            Span::raw(format!("   brake: {brake}   fault: {fault}")),
            Span::raw(format!(
                "   frames {}, lost {}, dropped {}, watchdog stops {}",
                self.frames, self.lost, dropped, stops
            )),
        ]);
        // The rate received on the host's clock, and the firmware's clock against it: an
        // emulator on a loaded host falls behind real time (its arm's physics runs on its own
        // clock, so nothing is wrong with the arm; the plots are slow).
        let mut stream = vec![Span::raw(format!(" stream: {:.0}/s streamed, ", self.rate))];
        match self.measured() {
            None => stream.push(Span::raw("measuring")),
            Some((r, c)) => {
                stream.push(Span::raw(format!(
                    "{r:.0}/s received; firmware clock {c:.2}× real time"
                )));
                if c < SLOW_CLOCK {
                    stream.push(Span::styled(
                        ": behind (a loaded host?)",
                        Style::new().fg(Color::Yellow).bold(),
                    ));
                }
            }
        }
        let line = vec![line, Line::from(stream)];
        frame.render_widget(
            Paragraph::new(line)
                .block(Block::bordered().title(format!(" flexarm live · {} ", self.title))),
            area,
        );
    }

    fn render_loads(&self, frame: &mut Frame, area: Rect) {
        let [p, m] = Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)])
            .areas(area);
        let misses = self
            .status
            .map_or([0, 0], |s| [s.loads[0].misses, s.loads[1].misses]);
        for (i, (name, area)) in [("piezo loop", p), ("motor loop", m)]
            .into_iter()
            .enumerate()
        {
            let load = self.now().load(i);
            let ratio = if load.is_finite() {
                load.clamp(0.0, 1.0)
            } else {
                0.0
            };
            let colour = if misses[i] > 0 || ratio > 0.8 {
                Color::Red
            } else {
                Color::Green
            };
            frame.render_widget(
                Gauge::default()
                    .block(Block::bordered().title(format!(
                        " {name}: load {:.2} %, {} deadline misses ",
                        load * 100.0,
                        misses[i]
                    )))
                    .gauge_style(Style::new().fg(colour))
                    .ratio(ratio),
                area,
            );
        }
    }

    fn plot(&self, frame: &mut Frame, area: Rect, title: String, lines: &[(Series, &str, Color)]) {
        let data: Vec<Vec<(f64, f64)>> = lines.iter().map(|(s, _, _)| self.points(*s)).collect();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for &(_, y) in data.iter().flatten() {
            if y.is_finite() {
                lo = lo.min(y);
                hi = hi.max(y);
            }
        }
        if !(lo.is_finite() && hi.is_finite()) {
            (lo, hi) = (-1.0, 1.0);
        }
        let pad = ((hi - lo) * 0.1).max(1e-6);
        let (lo, hi) = (lo - pad, hi + pad);
        let t_end = data
            .iter()
            .filter_map(|d| d.last().map(|p| p.0))
            .fold(self.window, f64::max);
        let x = [t_end - self.window, t_end];
        let sets: Vec<Dataset> = data
            .iter()
            .zip(lines)
            .map(|(d, (_, name, colour))| {
                Dataset::default()
                    .name(*name)
                    .marker(Marker::Braille)
                    .graph_type(GraphType::Line)
                    .style(Style::new().fg(*colour))
                    .data(d)
            })
            .collect();
        frame.render_widget(
            Chart::new(sets)
                .block(Block::bordered().title(title))
                .x_axis(
                    Axis::default()
                        .bounds(x)
                        .labels([format!("{:.0} s", x[0]), format!("{:.0} s", x[1])]),
                )
                .y_axis(
                    Axis::default()
                        .bounds([lo, hi])
                        .labels([format!("{lo:.3}"), format!("{hi:.3}")]),
                ),
            area,
        );
    }
}

/// Runs the view on `c` (subscribed to every channel by the caller) until a key leaves it.
/// `start` runs once, after the first frame (a move given on the command line); what it returns
/// (or its error) is shown on the last line. Restores the terminal on every way out.
pub fn run(
    c: &mut Client,
    view: &mut View,
    start: &mut dyn FnMut(&mut Client) -> Result<String, ConsoleError>,
) -> Result<(), ConsoleError> {
    let mut terminal = ratatui::try_init()
        .map_err(|e| ConsoleError::Io(format!("the terminal: {e} (live needs one)")))?;
    let result = event_loop(c, view, &mut terminal, start);
    ratatui::restore();
    result
}

fn event_loop(
    c: &mut Client,
    view: &mut View,
    terminal: &mut ratatui::DefaultTerminal,
    start: &mut dyn FnMut(&mut Client) -> Result<String, ConsoleError>,
) -> Result<(), ConsoleError> {
    let mut started = false;
    let (mut drawn, mut asked) = (Instant::now() - REDRAW, Instant::now() - STATUS_EVERY);
    loop {
        while event::poll(Duration::ZERO).map_err(|e| ConsoleError::Io(format!("keys: {e}")))? {
            if let Event::Key(k) =
                event::read().map_err(|e| ConsoleError::Io(format!("keys: {e}")))?
                && let Some(a) = key_action(&k)
                && act(c, view, a)?
            {
                return Ok(());
            }
        }
        c.pump(SLICE)?;
        view.ingest(&c.take_telemetry());
        if !started && view.frames > 0 {
            started = true;
            view.message = start(c).unwrap_or_else(|e| e.to_string());
        }
        if asked.elapsed() >= STATUS_EVERY {
            asked = Instant::now();
            if let Reply::Status(s) = c.ask(Command::Status)? {
                view.status(s);
            }
        }
        if drawn.elapsed() >= REDRAW {
            drawn = Instant::now();
            terminal
                .draw(|f| view.render(f))
                .map_err(|e| ConsoleError::Io(format!("the terminal: {e}")))?;
        }
    }
}

/// Carries out a key's action; `true` when the view should end.
pub fn act(c: &mut Client, view: &mut View, a: KeyAction) -> Result<bool, ConsoleError> {
    match a {
        KeyAction::Stop => {
            view.message = match c.ask(Command::Stop)? {
                Reply::Done => "stop: sent, decelerating to hold".into(),
                Reply::Refused(r) => format!("stop refused: {}", crate::client::refusal(r)),
                r => format!("stop: unexpected answer {r:?}"),
            };
            Ok(false)
        }
        KeyAction::Estop => {
            view.message = match c.ask(Command::Estop)? {
                Reply::Done => "EMERGENCY STOP: safe state, disarmed (arm to hold again)".into(),
                r => format!("estop: unexpected answer {r:?}"),
            };
            Ok(false)
        }
        KeyAction::Quit => {
            if let Reply::Status(s) = c.ask(Command::Status)?
                && matches!(s.mode, Mode::Moving | Mode::Stopping)
            {
                crate::interrupt::stop_arm(c)?;
            }
            Ok(true)
        }
    }
}
