//! The console's requests over a damaged line: the console's client (`flexarm_console::client`)
//! talks to the QEMU board's firmware on the host's rig through a byte stream that drops, flips
//! (one bit) and duplicates bytes at random in both directions, from a seeded generator. Every
//! request is answered or reported failed, none is applied twice (a retried `move` never starts
//! twice, a retried `arm` or `clear` is not refused for having been done), and every loss is
//! counted: the client's retries, the firmware's malformed requests.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use flexarm_console::client::{Client, ConsoleError, Timing};
use flexarm_console::transport::Link;
use flexarm_host::rig::Rig;
use flexarm_link::msg::{Board, Command, Mode, Move, Param, Reply};
use flexarm_link::{DeviceMsg, MAX_FRAME, encode};
use flexarm_machine::simulated::SimulatedArm;
use flexarm_tests::{firmware, rig};

/// What the line did to the bytes, and what the rig saw.
#[derive(Default, Debug)]
struct Counts {
    dropped: u32,
    flipped: u32,
    doubled: u32,
    /// Moves the drive began (its mode went from holding to moving).
    moves_started: u32,
}

struct Line {
    rig: Rig<SimulatedArm>,
    to_host: VecDeque<u8>,
    seed: u64,
    /// Each of drop, flip and double, per byte.
    p: f64,
    counts: Counts,
    moving: bool,
}

impl Line {
    fn uniform(&mut self) -> f64 {
        // xorshift64*: reproducible, no dependency.
        self.seed ^= self.seed >> 12;
        self.seed ^= self.seed << 25;
        self.seed ^= self.seed >> 27;
        (self.seed.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// `byte` as the damaged line delivers it: nothing, flipped, once or twice.
    fn pass(&mut self, byte: u8) -> Vec<u8> {
        let u = self.uniform();
        if u < self.p {
            self.counts.dropped += 1;
            vec![]
        } else if u < 2.0 * self.p {
            self.counts.flipped += 1;
            let bit = (self.uniform() * 8.0) as u32;
            vec![byte ^ (1 << bit)]
        } else if u < 3.0 * self.p {
            self.counts.doubled += 1;
            vec![byte, byte]
        } else {
            vec![byte]
        }
    }

    /// One motor period of the board, watching for a move's start.
    fn period(&mut self) {
        self.rig.period();
        let moving = self.rig.mode() == flexarm_core::drive::Mode::Moving;
        if moving && !self.moving {
            self.counts.moves_started += 1;
        }
        self.moving = moving;
    }
}

/// The client's end of the line (the state shared with the test).
struct Host(Arc<Mutex<Line>>);

impl Read for Host {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let mut l = self.0.lock().unwrap();
        if l.to_host.is_empty() {
            // Time passes on the board while the host waits.
            l.period();
            drop(l);
            std::thread::sleep(Duration::from_micros(200));
            return Err(std::io::ErrorKind::WouldBlock.into());
        }
        let n = buf.len().min(l.to_host.len());
        for b in buf.iter_mut().take(n) {
            *b = l.to_host.pop_front().unwrap_or(0);
        }
        Ok(n)
    }
}

impl Write for Host {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        let mut l = self.0.lock().unwrap();
        for &b in bytes {
            for b in l.pass(b) {
                let Some(Ok(request)) = l.rig.session.receive(b) else {
                    continue;
                };
                let reply = l.rig.request(&request);
                let mut buf = [0u8; MAX_FRAME];
                let frame = encode(
                    &DeviceMsg::Reply {
                        id: request.id,
                        reply,
                    },
                    &mut buf,
                )
                .unwrap()
                .to_vec();
                for b in frame {
                    let out = l.pass(b);
                    l.to_host.extend(out);
                }
            }
        }
        Ok(bytes.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Link for Host {
    fn set_timeout(&mut self, _: Duration) -> Result<(), ConsoleError> {
        Ok(())
    }
}

/// The drive's mode, or `None` when the status request failed.
fn mode(c: &mut Client) -> Option<Mode> {
    c.status().ok().map(|s| s.mode)
}

#[test]
fn requests_over_a_damaged_line_are_answered_once_or_reported_failed() {
    let line = Arc::new(Mutex::new(Line {
        rig: rig(firmware(Board::Qemu), [0.0, 0.0]),
        to_host: VecDeque::new(),
        seed: 0x005e_ed0f_11e5,
        p: 0.004,
        counts: Counts::default(),
        moving: false,
    }));
    let mut c = Client::connect(Box::new(Host(line.clone())), Duration::from_secs(3)).unwrap();
    c.timing = Timing {
        first: Duration::from_millis(20),
        attempts: 5,
    };
    let (mut answered, mut failed, mut moves_done) = (0u32, 0u32, 0u32);
    let mut tally = |r: &Result<Reply, ConsoleError>| match r {
        Ok(_) => answered += 1,
        Err(ConsoleError::Timeout(_)) => failed += 1,
        Err(e) => panic!("neither answered nor reported failed: {e}"),
    };
    for k in 0..12 {
        // Each request that acts, answered as done once: a repeat that had been applied again
        // would be refused (a second move while moving, ...).
        let r = c.ask(Command::Arm);
        tally(&r);
        assert!(matches!(r, Ok(Reply::Done) | Err(_)), "arm: {r:?}");
        let target = if k % 2 == 0 { [0.2, 0.1] } else { [0.0, 0.0] };
        let r = c.ask(Command::Move(Move::Trapezoid {
            target,
            move_time: 0.5,
            ramp_time: 0.125,
        }));
        tally(&r);
        match r {
            Ok(Reply::Done) => moves_done += 1,
            Err(_) => {}
            other => panic!("move {k}: {other:?}"),
        }
        // Until the drive holds again (a status that fails is asked again).
        for _ in 0..2000 {
            if mode(&mut c) == Some(Mode::Armed) {
                break;
            }
        }
        let r = c.ask(Command::Set(Param::Kc, 3.0 + k as f32));
        tally(&r);
        assert!(matches!(r, Ok(Reply::Done) | Err(_)), "set: {r:?}");
        let r = c.ask(Command::Disarm);
        tally(&r);
        assert!(matches!(r, Ok(Reply::Done) | Err(_)), "disarm: {r:?}");
    }
    let status = loop {
        if let Ok(s) = c.status() {
            break s;
        }
    };
    let l = line.lock().unwrap();
    let n = &l.counts;
    eprintln!(
        "{answered} answered, {failed} reported failed, {} retries; line: {} dropped, {} flipped, {} doubled; firmware: {} malformed requests; moves: {moves_done} done, {} started",
        c.retries, n.dropped, n.flipped, n.doubled, status.rx_malformed, n.moves_started
    );
    // The line did damage, and both ends counted it.
    assert!(n.dropped > 0 && n.flipped > 0 && n.doubled > 0, "{n:?}");
    assert!(c.retries > 0 && status.rx_malformed > 0);
    // Nothing applied twice: a move started for each one answered done, none for a repeat
    // (a move whose every answer was lost may still have started: at most one each).
    assert!(n.moves_started >= moves_done, "{n:?}, {moves_done} done");
    assert!(n.moves_started <= 12, "{n:?}");
    assert!(answered >= 40, "{answered} of 48 answered");
}
