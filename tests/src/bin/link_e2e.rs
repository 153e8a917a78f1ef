//! The host side of `cargo fw-link`: a session with the QEMU firmware (`link-session` build,
//! started by `scripts/qemu-link`, which passes the TCP port of its USART), judged here.
//!
//! In order: the handshake (repeated until the firmware answers, then its refusal of another
//! protocol version); a telemetry subscription; the status (disarmed at boot); garbage, a
//! corrupted frame and an oversized frame on the line, after which a ping is still answered; a
//! move refused while disarmed; arm; moves refused whole with their reasons (out of reach, too
//! fast); a trapezoid move, its end awaited, and its tracking error within three times what the
//! host simulation of the same move shows; the session so far replayed on the host's rig to the
//! bit (`replay`); parameters read, written and refused at rest; a long
//! move (another move and a parameter change refused while it runs) stopped on its way, which
//! decelerates and holds short of its target; a move stopped by the link watchdog while the host
//! is silent; the paper's circle, refused where the tip is not on it, then run from its start
//! within three times the host simulation's error; a waypoint path uploaded in chunks (a gap and
//! an incomplete list refused) and tracked within three times the host's run of the same path;
//! disarm, estop; a clear refused with no fault latched; an amplifier fault injected
//! (the test build's command) and read from the fault recorder, its clear refused until the line
//! is released; and the telemetry of the whole session without a sequence gap. Prints one line per check; exit
//! status 0 only if all pass.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use flexarm_core::trajectory::{Circle, JointTrajectory, Profile, Trapezoid};
use flexarm_host::sim::{SimConfig, simulate};
use flexarm_link::msg::{
    Board, Channels, Command, Mode, Move, Param, Refusal, Reply, Telemetry, Waypoint,
};
use flexarm_link::{Decoder, DeviceMsg, MAX_FRAME, Request, VERSION, encode};

/// Telemetry channels of the session: every one: errors (2), θ̂ (2), δ̂ (2), τ (2), V_a (1),
/// V_f (1), loads (2).
const CHANNELS: u16 = Channels::ALL;
/// Values per frame of the session's channels.
const VALUES: usize = Channels(CHANNELS).values();

/// The `j`-th value of the channel `bit` in `f`, by name (NaN when the frame lacks it).
fn v(f: &Telemetry, bit: u16, j: usize) -> f32 {
    f.value(bit, j).unwrap_or(f32::NAN)
}

struct Link {
    stream: TcpStream,
    decoder: Decoder,
    next_id: u16,
    /// Replies to requests below this id are the handshake's repeats, late: ignored.
    handshake_ids: u16,
    telemetry: Vec<Telemetry>,
    /// Replies to the flood's requests.
    flood_replies: u32,
}

/// Request ids of the flood's frames.
const FLOOD_IDS: u16 = 50_000;

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
                Some(DeviceMsg::Reply { id: got, .. }) if got < self.handshake_ids => {}
                Some(DeviceMsg::Reply { id: got, .. }) if got >= FLOOD_IDS => {
                    self.flood_replies += 1
                }
                Some(DeviceMsg::Reply { id: got, .. }) => {
                    return Err(format!("a reply to request {got} while waiting for {id}"));
                }
                Some(DeviceMsg::Telemetry(t)) => self.telemetry.push(t),
                None => return Err("the firmware closed the line before replying".into()),
            }
        }
    }

    fn mode(&mut self) -> Result<Mode, String> {
        match self.ask(Command::Status)? {
            Reply::Status(s) if s.fault.is_none() => Ok(s.mode),
            r => Err(format!("status: {r:?}")),
        }
    }

    /// Polls the status until `want`, for at most 30 s of the host's time.
    fn await_mode(&mut self, want: Mode) -> Result<(), String> {
        let start = Instant::now();
        while self.mode()? != want {
            if start.elapsed() > Duration::from_secs(30) {
                return Err(format!("the drive never reached {want:?}"));
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        Ok(())
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

fn trapezoid(target: [f32; 2], move_time: f32, ramp_time: f32) -> Command {
    Command::Move(Move::Trapezoid {
        target,
        move_time,
        ramp_time,
    })
}

/// The largest |θ − θ_d| of `traj` from rest at its start on the host, with the piezo gain
/// `k_c` [s]: the QEMU board's firmware (the generated `QEMU` configuration: motor 100 Hz, piezo
/// 1 kHz, its controller, observer and drive) on the host's rig, on the controller's model in
/// `f64` (plant step 1 ms) through the QEMU board's sensors (16384-count encoders, 12-bit film
/// ADC, no noise or delay). A motion check that trips on the host is an error: the firmware
/// would fault.
fn simulated_error(traj: &JointTrajectory<f32>, k_c: f32) -> Result<f64, String> {
    let move_time = match traj {
        JointTrajectory::Hold(_) => 1.0,
        moving => moving.duration(),
    };
    let mut qemu = flexarm_tests::firmware(flexarm_link::msg::Board::Qemu);
    qemu.piezo.k_c = k_c;
    let cfg = SimConfig {
        duration: f64::from(move_time) + 1.0,
        tail_window: 1.0,
        machine: Some(qemu),
        ..SimConfig::board(100.0, 1000.0)
    };
    let (s, _) = simulate(&cfg, traj, false).map_err(|e| e.to_string())?;
    if let Some((fault, t)) = s.motion_trip {
        return Err(format!(
            "the host simulation of the move trips a motion check: {fault:?} at {t:.2} s"
        ));
    }
    Ok(s.max_error)
}

/// The paper's circle (Eq. 36 made reachable) over the link: refused where the tip is not on
/// it, then run from its start pose, tracked within three times the host simulation's error.
fn circle(link: &mut Link) -> Result<(), String> {
    let c = Circle::<f32>::paper(0.3, 0.7).map_err(|e| e.to_string())?;
    let circle = |centre: [f32; 2]| {
        Command::Move(Move::Circle {
            centre,
            radius: 0.2,
            period: 4.0,
            ramp_time: 0.5,
            clockwise: true,
        })
    };
    let r = link.ask(circle([0.65, 0.0]))?;
    check(
        r == Reply::Refused(Refusal::Unreachable),
        "a circle that does not pass through the held tip is refused",
        format!("{r:?}"),
    )?;
    let r = link.ask(trapezoid([c.start.x, c.start.y], 4.0, 1.0))?;
    check(
        r == Reply::Done,
        "a move to the circle's start",
        format!("{r:?}"),
    )?;
    link.await_mode(Mode::Armed)?;
    let first = link.telemetry.len();
    let r = link.ask(circle([0.65, 0.0]))?;
    check(
        r == Reply::Done,
        "the paper's circle starts",
        format!("{r:?}"),
    )?;
    link.await_mode(Mode::Armed)?;
    let during = &link.telemetry[first..];
    let max_error = during
        .iter()
        .flat_map(|f| [v(f, Channels::ERROR, 0), v(f, Channels::ERROR, 1)])
        .fold(0.0f32, |m, e| m.max(e.abs()));
    let host = simulated_error(&JointTrajectory::Circle(c), 3.162)?;
    let bound = 3.0 * host as f32;
    check(
        during.len() >= 35 && max_error <= bound,
        "the circle's tracking error against the host simulation of the same circle",
        format!(
            "max |θ − θ_d| {max_error:.2e} rad over {} frames; host {host:.2e} rad, bound 3× = {bound:.2e}",
            during.len()
        ),
    )
}

/// The bits of the values of `f` the replay compares, by name: every channel but the loads
/// (errors, θ̂, δ̂, τ, V_a, V_f).
fn replayed(f: &Telemetry) -> Vec<u32> {
    flexarm_link::msg::CHANNELS
        .iter()
        .filter(|c| c.bit != Channels::LOAD)
        .flat_map(|c| (0..c.width).map(move |j| v(f, c.bit, j).to_bits()))
        .collect()
}

/// Bit-identical replay: the session's frames from its subscription to the end of its first
/// move, every motor period of them, reproduced by the host's rig (`flexarm_host::rig`) running the
/// QEMU board's firmware (its generated configuration, whose hash must be the handshake's
/// `params_hash`) on the QEMU board's simulated arm, both from boot: every compared value
/// (`replayed`) of every frame equal to the bit. The commands that acted before the move's end:
/// arm and the move (the subscription, the refused moves, the ping and the status acted on
/// nothing). The arm rests exactly at its boot pose until the move (every value of every frame
/// before it 0, checked), so the tick of the arm does not matter, and the move's tick is the
/// first frame with a torque (its first period's feed-forward; its reference still the held
/// pose).
fn replay(link: &Link, params_hash: u32, mv: Command) -> Result<(), String> {
    let cfg = flexarm_tests::firmware(Board::Qemu);
    check(
        cfg.hash() == params_hash,
        "the replay's configuration is the firmware's",
        format!("{:08x}", cfg.hash()),
    )?;
    let frames = &link.telemetry;
    let moved = frames
        .iter()
        .position(|f| v(f, Channels::TAU, 0) != 0.0 || v(f, Channels::TAU, 1) != 0.0)
        .ok_or("no torque in the session's first move")?;
    let at_rest = frames[..moved]
        .iter()
        .all(|f| replayed(f).iter().all(|b| f32::from_bits(*b) == 0.0));
    let (first, last, begin) = (
        frames[0].tick,
        frames[frames.len() - 1].tick,
        frames[moved].tick,
    );
    let contiguous = frames.windows(2).all(|w| w[1].tick == w[0].tick + 1);
    check(
        at_rest && contiguous,
        "the recording: every period from the subscription, the arm at rest until the move",
        format!("ticks {first}–{last}, the move from {begin}"),
    )?;
    let mut rig = flexarm_tests::rig(cfg, [0.0, 0.0]);
    for command in [
        Command::Subscribe {
            decimation: 1,
            channels: Channels(CHANNELS),
        },
        Command::Arm,
    ] {
        rig.answer(command);
    }
    let mut host = std::collections::BTreeMap::new();
    while rig.now().0 <= last {
        if rig.now().0 == begin {
            let r = rig.answer(mv.clone());
            if r != Reply::Done {
                return Err(format!("the replay's move: {r:?}"));
            }
        }
        rig.period();
        for f in rig.take().into_iter().filter_map(|(_, f)| f) {
            host.insert(f.tick, replayed(&f));
        }
    }
    let differ = frames
        .iter()
        .filter(|f| host.get(&f.tick).is_none_or(|bits| *bits != replayed(f)))
        .count();
    check(
        differ == 0,
        "the host's rig replays the firmware's first move bit for bit (errors, estimates, torques, piezo and film voltages)",
        format!(
            "{} frames (ticks {first}–{last}, the move from {begin}), {differ} differ",
            frames.len()
        ),
    )
}

/// The waypoint path of the session: 12 joint waypoints from (0, 0), out on a detour and back.
const PATH: [(f32, f32, f32); 12] = [
    (0.2, 0.1, 0.4),
    (0.4, 0.3, 0.4),
    (0.7, 0.4, 0.5),
    (0.9, 0.4, 0.3),
    (1.0, 0.2, 0.3),
    (1.0, 0.0, 0.4),
    (0.8, -0.3, 0.5),
    (0.5, -0.5, 0.5),
    (0.3, -0.4, 0.4),
    (0.2, -0.2, 0.3),
    (0.1, 0.0, 0.3),
    (0.1, 0.0, 0.2),
];

/// The largest |θ̂ − θ_d| of [`PATH`] from rest at (0, 0) on the host, as the QEMU board runs it:
/// its firmware (the generated `QEMU` configuration) on the host's rig (`flexarm_host::rig`) with
/// the QEMU board's simulated arm, given the session's own commands (`k_c` = 3.162 s, arm, the
/// waypoints in chunks, the move).
fn path_simulation() -> Result<f32, String> {
    let mut rig = flexarm_tests::rig(
        flexarm_tests::firmware(flexarm_link::msg::Board::Qemu),
        [0.0, 0.0],
    );
    let ask = |rig: &mut flexarm_host::rig::Rig<_>, command: Command| match rig.answer(command) {
        Reply::Done => Ok(()),
        r => Err(format!("the host's rig refused the path: {r:?}")),
    };
    ask(&mut rig, Command::Set(Param::Kc, 3.162))?;
    ask(&mut rig, Command::Arm)?;
    for (k, chunk) in PATH
        .chunks(flexarm_link::msg::WAYPOINTS_PER_CHUNK)
        .enumerate()
    {
        ask(
            &mut rig,
            waypoints_chunk((k * flexarm_link::msg::WAYPOINTS_PER_CHUNK) as u16, chunk),
        )?;
    }
    ask(
        &mut rig,
        Command::Move(Move::Waypoints {
            count: PATH.len() as u16,
        }),
    )?;
    let total: f32 = PATH.iter().map(|p| p.2).sum();
    let mut worst = 0.0f32;
    for _ in 0..(total * 100.0) as usize + 50 {
        let p = rig.period();
        worst = worst.max(p.error.abs().max());
    }
    Ok(worst)
}

/// A chunk of waypoints of the link from `first`.
fn waypoints_chunk(first: u16, pts: &[(f32, f32, f32)]) -> Command {
    Command::Waypoints {
        first,
        points: pts
            .iter()
            .map(|&(a, b, dt)| Waypoint { theta: [a, b], dt })
            .collect(),
    }
}

/// A waypoint path over the link, from (0, 0): uploaded in two chunks (a chunk that leaves a
/// gap and a move that names more waypoints than were uploaded are refused), then run and
/// tracked within three times the host's run of the same path on the host's rig (4.5 s:
/// at least 40 telemetry frames at the QEMU board's 10 records a second).
fn waypoints(link: &mut Link) -> Result<(), String> {
    let chunk = waypoints_chunk;
    let go = Command::Move(Move::Waypoints { count: 12 });
    let r = link.ask(chunk(1, &PATH[..8]))?;
    check(
        r == Reply::Refused(Refusal::Waypoints),
        "a waypoint chunk that leaves a gap is refused",
        format!("{r:?}"),
    )?;
    let r = link.ask(chunk(0, &PATH[..8]))?;
    check(r == Reply::Done, "waypoints 0-7 uploaded", format!("{r:?}"))?;
    let r = link.ask(go.clone())?;
    check(
        r == Reply::Refused(Refusal::Waypoints),
        "a path of 12 with 8 uploaded is refused",
        format!("{r:?}"),
    )?;
    let r = link.ask(chunk(8, &PATH[8..]))?;
    check(
        r == Reply::Done,
        "waypoints 8-11 uploaded",
        format!("{r:?}"),
    )?;
    let first = link.telemetry.len();
    let r = link.ask(go)?;
    check(
        r == Reply::Done,
        "the waypoint path starts",
        format!("{r:?}"),
    )?;
    link.await_mode(Mode::Armed)?;
    let during = &link.telemetry[first..];
    let max_error = during
        .iter()
        .flat_map(|f| [v(f, Channels::ERROR, 0), v(f, Channels::ERROR, 1)])
        .fold(0.0f32, |m, e| m.max(e.abs()));
    let end = during.last().map_or([9.0; 2], |f| {
        [v(f, Channels::THETA, 0), v(f, Channels::THETA, 1)]
    });
    let host = path_simulation()?;
    let bound = 3.0 * host;
    check(
        during.len() >= 40
            && max_error <= bound
            && (end[0] - 0.1).abs() < 0.01
            && end[1].abs() < 0.01,
        "the path's tracking error against the host's run of the same path, and its end",
        format!(
            "max |θ − θ_d| {max_error:.2e} rad over {} frames; host {host:.2e} rad, bound 3× = {bound:.2e}; ends at θ̂ = ({:.3}, {:.3}) rad",
            during.len(),
            end[0],
            end[1]
        ),
    )
}

/// One block of the flood: garbage, an oversized frame, a corrupted frame, a frame whose CRC is
/// right but whose message id is unknown, a request out of range, and valid pings and status
/// requests (ids from [`FLOOD_IDS`]).
fn flood_block(k: u16) -> Result<Vec<u8>, String> {
    let mut out: Vec<u8> = (0..64u32).map(|i| (i * 73 % 251) as u8 | 1).collect();
    out.push(0);
    out.extend(std::iter::repeat_n(0x55u8, 300));
    out.push(0);
    let mut buf = [0u8; MAX_FRAME];
    let mut frame = |msg: &dyn Fn(&mut [u8]) -> Result<usize, String>| -> Result<Vec<u8>, String> {
        let n = msg(&mut buf)?;
        Ok(buf[..n].to_vec())
    };
    let request = |command: Command, id: u16| {
        move |b: &mut [u8]| {
            encode(
                &Request {
                    id,
                    command: command.clone(),
                },
                b,
            )
            .map(<[u8]>::len)
            .map_err(|e| e.to_string())
        }
    };
    let mut corrupt = frame(&request(Command::Arm, FLOOD_IDS))?;
    corrupt[1] ^= 0x04;
    out.extend(corrupt);
    // Valid postcard and CRC, but command number 200.
    out.extend(frame(&|b: &mut [u8]| {
        encode(&(FLOOD_IDS, 200u8), b)
            .map(<[u8]>::len)
            .map_err(|e| e.to_string())
    })?);
    out.extend(frame(&request(
        Command::Set(Param::Kc, -1.0),
        FLOOD_IDS + 3 * k,
    ))?);
    out.extend(frame(&request(Command::Ping, FLOOD_IDS + 3 * k + 1))?);
    out.extend(frame(&request(Command::Status, FLOOD_IDS + 3 * k + 2))?);
    Ok(out)
}

/// The flood session (`link-e2e PORT flood`): arm, start a 1 s move, and from a second thread
/// write blocks of [`flood_block`] as fast as the firmware takes them (kept at most 64 blocks,
/// 33 kB, ahead of its replies) until the move has ended in the telemetry. The move completes at
/// its target without a motion fault (its error within the following-error limit), no loop
/// misses a deadline, and the firmware answers throughout. (Its tracking error is not held to
/// the host simulation's, as the full session's moves are: with `sleep=on` QEMU's timers follow
/// the host's clock and drop interrupts under its load, by a varying amount, and the QEMU
/// board's plant catches up on the lost periods in bursts: 2.5e-3 to 3.5e-3 rad from run to run.)
///
/// The rate: QEMU's USART model takes one byte per turn of QEMU's main loop, a pace set by the
/// host's speed (38 kB per second of the host's time on the machine of docs/link.md, 29 kB/s on
/// a slower CI machine), and this session's QEMU (`-icount sleep=on`) keeps the idle guest's
/// clock on the host's, so the flood arrives at that pace in the firmware's time too: 30 to 45 %
/// of the board's 921 600 baud. The board's full line rate is covered by the receive path's
/// cost per byte (`cargo fw-bench`, docs/link.md), not by this session. The check is on the
/// session itself and on the firmware: at least 10 kB/s arrived, ten times what the full
/// session's `sleep=off` clock lets through (a flood that stalled or turned into a trickle fails
/// it), and not a byte of it was lost to a full receive queue.
fn flood(link: &mut Link) -> Result<(), String> {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
    let status = |link: &mut Link| match link.ask(Command::Status)? {
        Reply::Status(s) => Ok(s),
        r => Err(format!("status: {r:?}")),
    };
    let r = link.ask(Command::Arm)?;
    check(r == Reply::Done, "armed", format!("{r:?}"))?;
    let (target, move_time, ramp) = ([0.4f32, -0.25], 1.0f32, 0.25f32);
    let before = status(link)?;
    let first = link.telemetry.len();
    let r = link.ask(trapezoid(target, move_time, ramp))?;
    check(
        r == Reply::Done,
        "a move for the flood starts",
        format!("{r:?}"),
    )?;
    let move_end = before.ticks + (f64::from(move_time) * 100.0) as u64;
    let stop = Arc::new(AtomicBool::new(false));
    // Flood replies read so far: the flood stays at most 64 blocks (3 requests each) ahead of
    // them, so the line is always full but the socket holds no backlog the firmware would need
    // minutes to drain after the move.
    let answered = Arc::new(AtomicU32::new(0));
    let mut writer = link.stream.try_clone().map_err(|e| e.to_string())?;
    let (flag, seen) = (Arc::clone(&stop), Arc::clone(&answered));
    let flooder = std::thread::spawn(move || -> Result<u64, String> {
        let mut sent = 0u64;
        let mut k = 0u16;
        let mut blocks = 0u32;
        while !flag.load(Ordering::Relaxed) {
            if blocks > seen.load(Ordering::Relaxed) / 3 + 64 {
                std::thread::sleep(Duration::from_micros(100));
                continue;
            }
            blocks += 1;
            let block = flood_block(k % 1000)?;
            writer
                .write_all(&block)
                .map_err(|e| format!("flood: {e}"))?;
            sent += block.len() as u64;
            k = k.wrapping_add(1);
        }
        Ok(sent)
    });
    // Read (telemetry, the flood's replies) until the move is over in the telemetry.
    let deadline = Instant::now() + Duration::from_secs(60);
    while link.telemetry.last().is_none_or(|f| f.tick < move_end + 20) {
        if Instant::now() > deadline {
            stop.store(true, Ordering::Relaxed);
            return Err(format!(
                "the move under the flood did not end in 60 s: {} telemetry frames (last tick {:?}, the move ends at {move_end}), {} flood replies",
                link.telemetry.len() - first,
                link.telemetry.last().map(|f| f.tick),
                link.flood_replies
            ));
        }
        match link.next()? {
            Some(DeviceMsg::Telemetry(t)) => link.telemetry.push(t),
            Some(DeviceMsg::Reply { id, .. }) if id >= FLOOD_IDS => {
                link.flood_replies += 1;
                answered.fetch_add(1, Ordering::Relaxed);
            }
            Some(m) => return Err(format!("unexpected during the flood: {m:?}")),
            None => return Err("the firmware closed the line during the flood".into()),
        }
    }
    // Stop the flood, reading on meanwhile: the firmware's replies must keep flowing, or QEMU
    // blocks on its full socket and stops taking the flood's last bytes.
    stop.store(true, Ordering::Relaxed);
    link.stream
        .set_read_timeout(Some(Duration::from_millis(20)))
        .map_err(|e| e.to_string())?;
    while !flooder.is_finished() {
        match link.next() {
            Ok(Some(DeviceMsg::Telemetry(t))) => link.telemetry.push(t),
            Ok(Some(DeviceMsg::Reply { id, .. })) if id >= FLOOD_IDS => link.flood_replies += 1,
            Ok(Some(m)) => return Err(format!("unexpected during the flood: {m:?}")),
            Ok(None) => return Err("the firmware closed the line during the flood".into()),
            Err(_) => {}
        }
    }
    link.stream
        .set_read_timeout(Some(Duration::from_secs(60)))
        .map_err(|e| e.to_string())?;
    let sent = flooder
        .join()
        .map_err(|_| "the flood thread panicked".to_string())??;
    // A terminator ends whatever partial frame the flood left.
    link.stream.write_all(&[0]).map_err(|e| e.to_string())?;
    let after = status(link)?;
    let seconds = (after.ticks - before.ticks) as f64 / 100.0;
    let rate = f64::from(after.rx_bytes - before.rx_bytes) / seconds;
    let during = &link.telemetry[first..];
    let max_error = during
        .iter()
        .filter(|f| f.tick <= move_end)
        .flat_map(|f| [v(f, Channels::ERROR, 0), v(f, Channels::ERROR, 1)])
        .fold(0.0f32, |m, e| m.max(e.abs()));
    let misses = |s: &flexarm_link::msg::Status| s.loads[0].misses + s.loads[1].misses;
    let end = during.last().map_or([9.0; 2], |f| {
        [v(f, Channels::THETA, 0), v(f, Channels::THETA, 1)]
    });
    check(
        rate >= 10_000.0 && after.rx_lost == before.rx_lost,
        "the flood kept the line full at QEMU's pace, none of it lost",
        format!(
            "{} kB sent; {:.0} bytes/s received over {seconds:.1} s of the firmware's time (the board's 921 600 baud: 92 160 bytes/s); {} bytes lost to a full queue",
            sent / 1000,
            rate,
            after.rx_lost - before.rx_lost
        ),
    )?;
    check(
        after.mode == Mode::Armed
            && after.fault.is_none()
            && misses(&after) == misses(&before)
            && link.flood_replies > 0
            && max_error < 0.05
            && (end[0] - target[0]).abs() < 0.01
            && (end[1] - target[1]).abs() < 0.01,
        "the move under the flood",
        format!(
            "{} flood requests answered; ended {:?} at θ̂ = ({:.3}, {:.3}) rad, max |θ − θ_d| \
             {max_error:.2e} rad (within the following-error limit, 0.05); deadline misses {}; \
             telemetry records dropped {}",
            link.flood_replies,
            after.mode,
            end[0],
            end[1],
            misses(&after) - misses(&before),
            after.telemetry_dropped - before.telemetry_dropped
        ),
    )
}

/// A fault injected on the amplifiers' fault line (the link-session build's test command): the
/// drive faults, the recorder holds the samples before it, `clear` waits for the cause to go.
fn fault_recorder(link: &mut Link) -> Result<(), String> {
    const AMPLIFIER: u8 = 7; // flexarm_core::Fault::Amplifier
    let r = link.ask(Command::Arm)?;
    check(r == Reply::Done, "armed again", format!("{r:?}"))?;
    // Let the arm come to rest in its hold first, so that the fault finds it still.
    let start = Instant::now();
    loop {
        let n = link.telemetry.len();
        let still = n > 3
            && link.telemetry[n - 3..].windows(2).all(|w| {
                (v(&w[1], Channels::THETA, 0) - v(&w[0], Channels::THETA, 0)).abs() < 1e-4
                    && (v(&w[1], Channels::THETA, 1) - v(&w[0], Channels::THETA, 1)).abs() < 1e-4
            });
        if still {
            break;
        }
        if start.elapsed() > Duration::from_secs(30) {
            return Err("the arm never came to rest in its hold".into());
        }
        link.ask(Command::Ping)?;
        std::thread::sleep(Duration::from_millis(2));
    }
    let r = link.ask(Command::TestAmplifierFault(true))?;
    check(
        r == Reply::Done,
        "amplifier fault line asserted",
        format!("{r:?}"),
    )?;
    let start = Instant::now();
    let status = loop {
        match link.ask(Command::Status)? {
            Reply::Status(s) if s.fault.is_some() => break s,
            Reply::Status(_) if start.elapsed() < Duration::from_secs(30) => {
                std::thread::sleep(Duration::from_millis(2));
            }
            r => return Err(format!("no fault latched: {r:?}")),
        }
    };
    check(
        status.mode == Mode::Fault && status.fault == Some(AMPLIFIER),
        "the fault latches",
        format!("{:?}, fault {:?}", status.mode, status.fault),
    )?;
    // Read the recorder page by page.
    let mut samples = Vec::new();
    let (fault, total) = loop {
        let from = samples.len() as u16;
        match link.ask(Command::Faults { from })? {
            Reply::Faults(p) => {
                let done =
                    p.samples.is_empty() || usize::from(p.total) <= samples.len() + p.samples.len();
                samples.extend(p.samples.iter().copied());
                if done {
                    break (p.fault, usize::from(p.total));
                }
            }
            r => return Err(format!("faults page {from}: {r:?}")),
        }
    };
    let contiguous = samples.windows(2).all(|w| w[1].tick == w[0].tick + 1);
    let seconds = samples.len() as f64 / 100.0;
    check(
        fault == Some(AMPLIFIER)
            && samples.len() == total
            && total >= 100
            && contiguous
            && status.ticks
                >= samples
                    .last()
                    .map_or(u64::MAX, |s| s.tick)
                    .saturating_sub(10),
        "the fault recorder holds the samples before the fault",
        format!(
            "{total} samples ({seconds:.1} s at the QEMU board's 100 Hz), ticks {}..{}, contiguous",
            samples.first().map_or(0, |s| s.tick),
            samples.last().map_or(0, |s| s.tick)
        ),
    )?;
    let r = link.ask(Command::Clear)?;
    check(
        r == Reply::Refused(Refusal::CauseActive),
        "clear while the fault line is still asserted is refused",
        format!("{r:?}"),
    )?;
    link.ask(Command::TestAmplifierFault(false))?;
    let r = link.ask(Command::Clear)?;
    let after = link.ask(Command::Faults { from: 0 })?;
    check(
        r == Reply::Cleared(AMPLIFIER)
            && link.mode()? == Mode::Disarmed
            && matches!(after, Reply::Faults(ref p) if p.fault.is_none()),
        "cleared once the line is released, disarmed, the recorder recording again",
        format!("{r:?}"),
    )
}

fn connect(port: u16) -> Result<TcpStream, String> {
    let start = Instant::now();
    loop {
        match TcpStream::connect(("127.0.0.1", port)) {
            // Small frames go out at once (no Nagle delay): the session waits on replies.
            Ok(s) => return s.set_nodelay(true).map(|()| s).map_err(|e| e.to_string()),
            Err(e) if start.elapsed() > Duration::from_secs(30) => {
                return Err(format!("cannot connect to QEMU on port {port}: {e}"));
            }
            Err(_) => std::thread::sleep(Duration::from_millis(50)),
        }
    }
}

fn run(port: u16, flood_session: bool) -> Result<(), String> {
    let mut link = Link {
        stream: connect(port)?,
        decoder: Decoder::new(),
        next_id: 0,
        handshake_ids: 0,
        telemetry: Vec::new(),
        flood_replies: 0,
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
        link.send(Command::Hello { version: VERSION })?;
        match link.next() {
            // Any of the repeated hellos' answers will do.
            Ok(Some(DeviceMsg::Reply { reply, .. })) => break reply,
            Ok(Some(DeviceMsg::Telemetry(_))) | Err(_) => continue,
            Ok(None) => return Err("the firmware closed the line during the handshake".into()),
        }
    };
    link.handshake_ids = link.next_id.wrapping_add(1);
    link.stream
        .set_read_timeout(Some(Duration::from_secs(60)))
        .map_err(|e| e.to_string())?;
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
    // The round trip of a request on the host's clock, before any stream: QEMU's socket
    // with `nodelay=on` and the host's `set_nodelay` (Nagle's algorithm held each reply back
    // 40-48 ms: issue 36). The median of 100 pings under 10 ms.
    let mut trips = Vec::with_capacity(100);
    for _ in 0..100 {
        let t = std::time::Instant::now();
        link.ask(Command::Ping)?;
        trips.push(t.elapsed().as_secs_f64() * 1e3);
    }
    trips.sort_by(f64::total_cmp);
    check(
        trips[50] < 10.0,
        "a request's round trip on the host's clock",
        format!(
            "median {:.2} ms, 90th percentile {:.2} ms, largest {:.2} ms over 100 pings (bound: median 10 ms)",
            trips[50], trips[90], trips[99]
        ),
    )?;
    let r = link.ask(Command::Subscribe {
        decimation: 1,
        channels: Channels(CHANNELS),
    })?;
    check(r == Reply::Done, "subscribed", format!("{r:?}"))?;
    if flood_session {
        return flood(&mut link);
    }
    let r = link.ask(Command::Subscribe {
        decimation: 0,
        channels: Channels(CHANNELS),
    })?;
    check(
        r == Reply::Refused(Refusal::OutOfRange),
        "a subscription with decimation 0 is refused",
        format!("{r:?}"),
    )?;
    let r = link.ask(Command::Hello {
        version: VERSION.wrapping_add(1),
    })?;
    check(
        r == Reply::Refused(Refusal::Version),
        "another protocol version is refused",
        format!("{r:?}"),
    )?;
    let r = link.ask(Command::Status)?;
    let Reply::Status(s) = r else {
        return Err(format!("status: {r:?}"));
    };
    check(
        s.fault.is_none() && s.mode == Mode::Disarmed,
        "status at boot",
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
            command: Command::Arm,
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
        r == Reply::Done && link.mode()? == Mode::Disarmed,
        "after garbage, a corrupted (arm) and an oversized frame: a ping is answered, nothing armed",
        format!("{r:?}"),
    )?;

    let (target, move_time, ramp) = ([0.8f32, -0.5], 2.0f32, 0.5f32);
    let r = link.ask(trapezoid(target, move_time, ramp))?;
    check(
        r == Reply::Refused(Refusal::NotArmed),
        "a move while disarmed is refused",
        format!("{r:?}"),
    )?;
    let r = link.ask(Command::Arm)?;
    check(
        r == Reply::Done && link.mode()? == Mode::Armed,
        "armed",
        format!("{r:?}"),
    )?;
    for (cmd, why, what) in [
        (
            trapezoid([3.5, 0.0], 4.0, 1.0),
            Refusal::Unreachable,
            "a move past the joint range",
        ),
        (
            trapezoid([2.0, 0.0], 0.5, 0.125),
            Refusal::TooFast,
            "a move at 5.3 rad/s",
        ),
        (
            trapezoid([0.5, 0.0], 2.0, 1.5),
            Refusal::OutOfRange,
            "ramps longer than half the move",
        ),
    ] {
        let r = link.ask(cmd)?;
        check(
            r == Reply::Refused(why),
            &format!("{what} is refused"),
            format!("{r:?}"),
        )?;
    }
    check(
        link.mode()? == Mode::Armed,
        "nothing of a refused move applied",
        "still holding",
    )?;

    let first = link.telemetry.len();
    let r = link.ask(trapezoid(target, move_time, ramp))?;
    check(
        r == Reply::Done,
        "a trapezoid move starts",
        format!("{r:?}"),
    )?;
    link.await_mode(Mode::Armed)?;
    let during = &link.telemetry[first..];
    let max_error = during
        .iter()
        .flat_map(|f| [v(f, Channels::ERROR, 0), v(f, Channels::ERROR, 1)])
        .fold(0.0f32, |m, e| m.max(e.abs()));
    let traj = JointTrajectory::Trapezoid(Trapezoid {
        start: nalgebra::Vector2::zeros(),
        amplitude: nalgebra::Vector2::new(target[0], target[1]),
        profile: Profile::new(move_time, ramp).map_err(|e| e.to_string())?,
    });
    let host = simulated_error(&traj, 30.0)?;
    let bound = 3.0 * host as f32;
    check(
        during.len() >= 15 && max_error <= bound,
        "the move's tracking error against the host simulation of the same move",
        format!(
            "max |θ − θ_d| {max_error:.2e} rad over {} frames; host {host:.2e} rad, bound 3× = {bound:.2e}",
            during.len()
        ),
    )?;

    replay(&link, h.params_hash, trapezoid(target, move_time, ramp))?;

    // Parameters at rest: read, written, read back; refused out of range or unknown.
    let k_c = link.ask(Command::Get(Param::Kc))?;
    let r = link.ask(Command::Set(Param::Kc, 3.162))?;
    let back = link.ask(Command::Get(Param::Kc))?;
    check(
        matches!(k_c, Reply::Value(v) if v > 0.0)
            && r == Reply::Done
            && back == Reply::Value(3.162),
        "get and set k_c at rest",
        format!("{k_c:?} → set {r:?} → {back:?}"),
    )?;
    for (p, v, why) in [
        (Param::VaMax, 1e6, Refusal::OutOfRange),
        (Param::Kp0, -1.0, Refusal::OutOfRange),
        (Param::CutoffHz, f32::NAN, Refusal::OutOfRange),
        (Param::LinkTimeout, 1e5, Refusal::OutOfRange),
    ] {
        let r = link.ask(Command::Set(p, v))?;
        check(
            r == Reply::Refused(why),
            "a bad parameter value is refused",
            format!("{p:?} = {v}: {r:?}"),
        )?;
    }
    let r = link.ask(Command::Set(Param::LinkTimeout, 5.0))?;
    let back = link.ask(Command::Get(Param::LinkTimeout))?;
    check(
        r == Reply::Done && back == Reply::Value(5.0),
        "the link watchdog's timeout",
        format!("set {r:?} → {back:?} s"),
    )?;

    // A long move back, stopped once joint 1 has passed 0.75 rad: it decelerates and holds
    // short of 0.
    let r = link.ask(trapezoid([0.0, 0.0], 8.0, 2.0))?;
    check(
        r == Reply::Done,
        "an 8 s move back starts",
        format!("{r:?}"),
    )?;
    let r = link.ask(trapezoid([0.0, 0.0], 2.0, 0.5))?;
    check(
        r == Reply::Refused(Refusal::Moving),
        "another move while it runs is refused",
        format!("{r:?}"),
    )?;
    let r = link.ask(Command::Set(Param::Kc, 10.0))?;
    check(
        r == Reply::Refused(Refusal::Moving),
        "a parameter change while it runs is refused",
        format!("{r:?}"),
    )?;
    let theta1 = |l: &Link| l.telemetry.last().map_or(1.0, |f| v(f, Channels::THETA, 0));
    let start = Instant::now();
    while theta1(&link) > 0.75 {
        if start.elapsed() > Duration::from_secs(30) {
            return Err("the move back never passed 0.75 rad".into());
        }
        link.ask(Command::Ping)?;
        std::thread::sleep(Duration::from_millis(1));
    }
    let r = link.ask(Command::Stop)?;
    let m = link.mode()?;
    check(
        r == Reply::Done && matches!(m, Mode::Stopping | Mode::Armed),
        "stop",
        format!("{r:?}, then {m:?}"),
    )?;
    link.await_mode(Mode::Armed)?;
    // Let a few frames of the hold arrive, then read where it holds.
    let from = link.telemetry.len();
    while link.telemetry.len() < from + 3 {
        link.ask(Command::Ping)?;
        std::thread::sleep(Duration::from_millis(2));
    }
    let held = link.telemetry.last().map_or([0.0; 2], |f| {
        [v(f, Channels::THETA, 0), v(f, Channels::THETA, 1)]
    });
    check(
        held[0] > 0.1 && held[0] < 0.75 && held[1] < -0.05,
        "the stop holds short of the move's target (0, 0), past 0.75 rad where it was given",
        format!("θ̂ = ({:.3}, {:.3}) rad", held[0], held[1]),
    )?;
    let r = link.ask(trapezoid([0.0, 0.0], 4.0, 1.0))?;
    check(
        r == Reply::Done,
        "after the stop it holds, and takes a new move",
        format!("{r:?}"),
    )?;
    link.await_mode(Mode::Armed)?;

    // The link watchdog: a host that falls silent during an 8 s move (QEMU's watchdog: 5 s of
    // virtual time, a few hundred milliseconds of the host's) has it stopped short of its end.
    let r = link.ask(trapezoid([0.8, -0.5], 8.0, 2.0))?;
    check(r == Reply::Done, "an 8 s move starts", format!("{r:?}"))?;
    std::thread::sleep(Duration::from_millis(1500));
    let r = link.ask(Command::Status)?;
    let Reply::Status(s) = r else {
        return Err(format!("status: {r:?}"));
    };
    let reached = link.telemetry.last().map_or([0.0; 2], |f| {
        [v(f, Channels::THETA, 0), v(f, Channels::THETA, 1)]
    });
    check(
        s.mode == Mode::Armed && s.link_stops == 1 && reached[0] > 0.05 && reached[0] < 0.75,
        "the link watchdog stops a move whose host fell silent",
        format!(
            "{:?}, {} watchdog stop, holding at θ̂ = ({:.3}, {:.3}) rad short of (0.8, -0.5)",
            s.mode, s.link_stops, reached[0], reached[1]
        ),
    )?;
    circle(&mut link)?;
    let r = link.ask(trapezoid([0.0, 0.0], 4.0, 1.0))?;
    check(r == Reply::Done, "a new move after it", format!("{r:?}"))?;
    link.await_mode(Mode::Armed)?;
    waypoints(&mut link)?;
    let r = link.ask(trapezoid([0.0, 0.0], 4.0, 1.0))?;
    check(r == Reply::Done, "a move back", format!("{r:?}"))?;
    let r = link.ask(Command::Disarm)?;
    check(
        r == Reply::Done && link.mode()? == Mode::Disarmed,
        "disarm during a move",
        format!("{r:?}"),
    )?;
    let r = link.ask(Command::Estop)?;
    check(
        r == Reply::Done && link.mode()? == Mode::Disarmed,
        "estop",
        format!("{r:?}"),
    )?;
    let r = link.ask(Command::Clear)?;
    check(
        r == Reply::Refused(Refusal::CauseActive),
        "clear with no fault latched is refused",
        format!("{r:?}"),
    )?;
    fault_recorder(&mut link)?;
    let r = link.ask(Command::Unsubscribe)?;
    check(r == Reply::Done, "unsubscribed", format!("{r:?}"))?;
    let t = &link.telemetry;
    let gaps = t
        .windows(2)
        .filter(|w| w[1].seq != w[0].seq.wrapping_add(1))
        .count();
    let (mut load, mut v_f) = ([0.0f32; 2], 0.0f32);
    for f in t {
        load[0] = load[0].max(v(f, Channels::LOAD, 0));
        load[1] = load[1].max(v(f, Channels::LOAD, 1));
        v_f = v_f.max(v(f, Channels::V_F, 0).abs());
    }
    check(
        gaps == 0
            && t.iter().all(|f| f.values.len() == VALUES)
            && load.iter().all(|l| *l > 0.0 && *l < 0.01)
            && v_f > 0.0
            && v_f < 10.0,
        "telemetry of the whole session",
        format!(
            "{} frames, {gaps} sequence gaps, {VALUES} values each; largest loads piezo {:.2e} motor {:.2e} of the period, largest |V_f| {v_f:.3} V",
            t.len(),
            load[0],
            load[1]
        ),
    )?;
    let r = link.ask(Command::Status)?;
    let Reply::Status(s) = r else {
        return Err(format!("status: {r:?}"));
    };
    let budget = stack_budget()?;
    check(
        s.stack_used > 0 && s.stack_used <= budget && s.rx_lost == 0,
        "the stack after the whole session, and the receive queue",
        format!(
            "{} bytes used (budget {budget}, firmware/budgets.txt); {} bytes received, {} lost",
            s.stack_used, s.rx_bytes, s.rx_lost
        ),
    )
}

/// The stack budget of the QEMU board, `stack_qemu` in firmware/budgets.txt [bytes].
fn stack_budget() -> Result<u32, String> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../firmware/budgets.txt");
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    text.lines()
        .find_map(|l| l.strip_prefix("stack_qemu"))
        .and_then(|v| v.trim().trim_start_matches('=').trim().parse().ok())
        .ok_or_else(|| format!("{path}: no stack_qemu"))
}

fn main() -> std::process::ExitCode {
    let port = std::env::args().nth(1).and_then(|p| p.parse::<u16>().ok());
    let flood = std::env::args().nth(2).as_deref() == Some("flood");
    let Some(port) = port else {
        eprintln!("usage: link-e2e <port> [flood]");
        return std::process::ExitCode::FAILURE;
    };
    match run(port, flood) {
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
