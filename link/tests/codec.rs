//! The link's codec: every message round-trips through a frame, the largest of each fits the
//! frame limit, and a stream of anything (garbage, corruption, truncation, floods) never panics,
//! yields only checked messages and resynchronizes at the next frame.

use flexarm_link::frame::{Decoder, FrameError, MAX_FRAME, encode};
use flexarm_link::msg::*;
use flexarm_link::{DeviceMsg, Request, VERSION};
use proptest::prelude::*;

fn frame<T: serde::Serialize>(msg: &T) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME];
    encode(msg, &mut buf).expect("fits").to_vec()
}

fn decode_all<T: serde::de::DeserializeOwned>(bytes: &[u8]) -> Vec<Result<T, FrameError>> {
    let mut d = Decoder::new();
    bytes.iter().filter_map(|b| d.push::<T>(*b)).collect()
}

fn f32s() -> impl Strategy<Value = f32> {
    prop_oneof![any::<f32>(), -1e3f32..1e3]
}

fn pair() -> impl Strategy<Value = [f32; 2]> {
    [f32s(), f32s()]
}

fn param() -> impl Strategy<Value = Param> {
    (0..flexarm_link::params::PARAMS.len()).prop_map(|i| flexarm_link::params::PARAMS[i].param)
}

fn command() -> impl Strategy<Value = Command> {
    let waypoint = (pair(), f32s()).prop_map(|(theta, dt)| Waypoint { theta, dt });
    prop_oneof![
        any::<u16>().prop_map(|version| Command::Hello { version }),
        Just(Command::Status),
        Just(Command::Arm),
        Just(Command::Disarm),
        (pair(), f32s(), f32s()).prop_map(|(target, move_time, ramp_time)| Command::Move(
            Move::Trapezoid {
                target,
                move_time,
                ramp_time
            }
        )),
        (pair(), f32s(), f32s(), f32s(), any::<bool>()).prop_map(
            |(centre, radius, period, ramp_time, clockwise)| Command::Move(Move::Circle {
                centre,
                radius,
                period,
                ramp_time,
                clockwise
            })
        ),
        any::<u16>().prop_map(|count| Command::Move(Move::Waypoints { count })),
        (
            any::<u16>(),
            prop::collection::vec(waypoint, 0..=WAYPOINTS_PER_CHUNK)
        )
            .prop_map(|(first, p)| Command::Waypoints {
                first,
                points: heapless::Vec::from_slice(&p).unwrap(),
            }),
        Just(Command::Stop),
        Just(Command::Estop),
        Just(Command::Clear),
        param().prop_map(Command::Get),
        (param(), f32s()).prop_map(|(p, v)| Command::Set(p, v)),
        (any::<u16>(), any::<u16>()).prop_map(|(decimation, c)| Command::Subscribe {
            decimation,
            channels: Channels(c)
        }),
        Just(Command::Unsubscribe),
        any::<u16>().prop_map(|from| Command::Faults { from }),
        Just(Command::Ping),
        any::<bool>().prop_map(Command::TestAmplifierFault),
        Just(Command::Home),
        (-4.0f32..4.0, -4.0f32..4.0).prop_map(|(a, b)| Command::DeclareHome { theta: [a, b] }),
        Just(Command::ConfigSave),
        Just(Command::ConfigErase),
    ]
}

fn sample() -> impl Strategy<Value = RecordedSample> {
    (any::<u64>(), pair(), pair(), pair(), pair(), f32s()).prop_map(
        |(tick, theta, error, delta, tau, v_f)| RecordedSample {
            tick,
            theta,
            error,
            delta,
            tau,
            v_f,
        },
    )
}

fn device() -> impl Strategy<Value = DeviceMsg> {
    let load = (any::<u32>(), any::<u32>(), any::<u32>()).prop_map(|(a, b, c)| Load {
        mean_cycles: a,
        worst_cycles: b,
        misses: c,
    });
    let mode = prop_oneof![
        Just(Mode::Disarmed),
        Just(Mode::Armed),
        Just(Mode::Moving),
        Just(Mode::Stopping),
        Just(Mode::Fault),
        Just(Mode::Homing)
    ];
    let status = (
        mode,
        any::<Option<u8>>(),
        any::<u64>(),
        load.clone(),
        load,
        any::<u32>(),
        any::<u32>(),
        any::<[u32; 3]>(),
    )
        .prop_map(
            |(mode, fault, ticks, a, b, telemetry_dropped, link_stops, [rx, lost, stack])| {
                Reply::Status(Status {
                    mode,
                    fault,
                    ticks,
                    loads: [a, b],
                    telemetry_dropped,
                    link_stops,
                    rx_bytes: rx,
                    rx_lost: lost,
                    rx_malformed: 0,
                    rx_line: Default::default(),
                    stack_used: stack,
                    homing: [HomeState::Declared; 2],
                    homing_failed: false,
                    brake_engaged: true,
                })
            },
        );
    let hello = ("[a-z0-9 .+-]{0,32}", any::<u32>(), any::<u16>()).prop_map(|(b, h, v)| {
        Reply::Hello(Hello {
            version: v,
            board: Board::Qemu,
            build: heapless::String::try_from(b.as_str()).unwrap(),
            params_hash: h,
            motor_hz: 100,
            piezo_hz: 1000,
            settings: Settings::Refused(SettingsRefusal::Value(Param::Kc)),
        })
    });
    let faults = (
        any::<Option<u8>>(),
        any::<u16>(),
        any::<u16>(),
        prop::collection::vec(sample(), 0..=SAMPLES_PER_PAGE),
    )
        .prop_map(|(fault, total, from, s)| {
            Reply::Faults(FaultPage {
                fault,
                total,
                from,
                samples: heapless::Vec::from_slice(&s).unwrap(),
            })
        });
    let reply = prop_oneof![
        status,
        hello,
        faults,
        Just(Reply::Done),
        f32s().prop_map(Reply::Value),
        any::<u8>().prop_map(Reply::Cleared),
        Just(Reply::Refused(Refusal::Moving)),
        Just(Reply::Refused(Refusal::NoRecord)),
    ];
    let telemetry = (
        any::<u32>(),
        any::<u64>(),
        any::<u16>(),
        prop::collection::vec(f32s(), 0..=MAX_CHANNELS),
    )
        .prop_map(|(seq, tick, c, v)| {
            DeviceMsg::Telemetry(Telemetry {
                seq,
                tick,
                brake_engaged: tick % 2 == 0,
                channels: Channels(c),
                values: heapless::Vec::from_slice(&v).unwrap(),
            })
        });
    prop_oneof![
        (any::<u16>(), reply).prop_map(|(id, reply)| DeviceMsg::Reply { id, reply }),
        telemetry,
    ]
}

/// Equality that treats NaN as equal to itself (a NaN must cross the link as a NaN).
fn same<T: std::fmt::Debug>(a: &T, b: &T) -> bool {
    format!("{a:?}") == format!("{b:?}")
}

proptest! {
    #[test]
    fn every_request_round_trips(id in any::<u16>(), command in command()) {
        let req = Request { id, command };
        let f = frame(&req);
        prop_assert!(f.len() <= MAX_FRAME);
        prop_assert_eq!(f.iter().filter(|b| **b == 0).count(), 1, "one zero, at the end");
        let out = decode_all::<Request>(&f);
        prop_assert_eq!(out.len(), 1);
        let got = out[0].clone().unwrap();
        prop_assert!(same(&got, &req), "{:?} vs {:?}", got, req);
    }

    #[test]
    fn every_device_message_round_trips(msg in device()) {
        let f = frame(&msg);
        prop_assert!(f.len() <= MAX_FRAME);
        let out = decode_all::<DeviceMsg>(&f);
        prop_assert_eq!(out.len(), 1);
        let got = out[0].clone().unwrap();
        prop_assert!(same(&got, &msg), "{:?} vs {:?}", got, msg);
    }

    /// Any bytes at all: no panic; whatever decodes passed its CRC; a good frame after the
    /// garbage (and a zero) is always delivered.
    #[test]
    fn any_stream_is_survived_and_resynchronized(garbage in prop::collection::vec(any::<u8>(), 0..2000)) {
        let good = Request { id: 7, command: Command::Status };
        let mut bytes = garbage.clone();
        bytes.push(0);
        bytes.extend(frame(&good));
        let out = decode_all::<Request>(&bytes);
        prop_assert!(matches!(out.last(), Some(Ok(r)) if *r == good), "{:?}", out.last());
    }

    /// One flipped bit anywhere in a frame is caught (CRC-32 detects every single-bit error).
    #[test]
    fn a_flipped_bit_is_refused(command in command(), at in any::<prop::sample::Index>(), bit in 0u8..8) {
        let f = frame(&Request { id: 1, command });
        let mut bad = f.clone();
        let i = at.index(bad.len() - 1); // not the terminator
        bad[i] ^= 1 << bit;
        for r in decode_all::<Request>(&bad) {
            prop_assert!(r.is_err(), "a corrupted frame decoded: {:?}", r);
        }
    }
}

#[test]
fn the_largest_of_every_message_fits_a_frame() {
    let big = [f32::MAX, f32::MIN];
    let s = RecordedSample {
        tick: u64::MAX,
        theta: big,
        error: big,
        delta: big,
        tau: big,
        v_f: f32::MAX,
    };
    let build: heapless::String<BUILD_NAME> =
        heapless::String::try_from("ééééééééééééééé£").unwrap(); // 32 bytes of 2-byte chars
    let load = Load {
        mean_cycles: u32::MAX,
        worst_cycles: u32::MAX,
        misses: u32::MAX,
    };
    let device = [
        DeviceMsg::Telemetry(Telemetry {
            seq: u32::MAX,
            tick: u64::MAX,
            brake_engaged: true,
            channels: Channels(u16::MAX),
            values: heapless::Vec::from_slice(&[f32::MAX; MAX_CHANNELS]).unwrap(),
        }),
        DeviceMsg::Reply {
            id: u16::MAX,
            reply: Reply::Faults(FaultPage {
                fault: Some(u8::MAX),
                total: u16::MAX,
                from: u16::MAX,
                samples: heapless::Vec::from_slice(&[s; SAMPLES_PER_PAGE]).unwrap(),
            }),
        },
        DeviceMsg::Reply {
            id: u16::MAX,
            reply: Reply::Hello(Hello {
                version: u16::MAX,
                board: Board::Hardware,
                build,
                params_hash: u32::MAX,
                motor_hz: u32::MAX,
                piezo_hz: u32::MAX,
                settings: Settings::Refused(SettingsRefusal::Value(Param::PiezoLaw)),
            }),
        },
        DeviceMsg::Reply {
            id: u16::MAX,
            reply: Reply::Status(Status {
                mode: Mode::Fault,
                fault: Some(u8::MAX),
                ticks: u64::MAX,
                loads: [load; 2],
                telemetry_dropped: u32::MAX,
                link_stops: u32::MAX,
                rx_bytes: u32::MAX,
                rx_lost: u32::MAX,
                rx_malformed: u32::MAX,
                rx_line: flexarm_link::msg::LineErrors {
                    overrun: u32::MAX,
                    framing: u32::MAX,
                    noise: u32::MAX,
                },
                stack_used: u32::MAX,
                homing: [HomeState::Declared; 2],
                homing_failed: false,
                brake_engaged: true,
            }),
        },
    ];
    let mut largest = 0;
    for m in &device {
        let n = frame(m).len();
        largest = largest.max(n);
    }
    let chunk = Request {
        id: u16::MAX,
        command: Command::Waypoints {
            first: u16::MAX,
            points: heapless::Vec::from_slice(
                &[Waypoint {
                    theta: big,
                    dt: f32::MAX,
                }; WAYPOINTS_PER_CHUNK],
            )
            .unwrap(),
        },
    };
    largest = largest.max(frame(&chunk).len());
    println!("largest frame: {largest} bytes of {MAX_FRAME}");
    assert!(largest <= MAX_FRAME);
}

/// A message sent by reference is the same frame as the message.
#[test]
fn a_message_by_reference_is_the_same_frame() {
    let reply = Reply::Status(Status {
        mode: Mode::Moving,
        fault: Some(3),
        ticks: 123_456_789,
        loads: [Load::default(); 2],
        telemetry_dropped: 1,
        link_stops: 2,
        rx_bytes: 300,
        rx_lost: 4,
        rx_malformed: 0,
        rx_line: Default::default(),
        stack_used: 1800,
        homing: [HomeState::Declared; 2],
        homing_failed: false,
        brake_engaged: true,
    });
    let t = Telemetry {
        seq: 9,
        tick: 1 << 40,
        brake_engaged: false,
        channels: Channels(Channels::ALL),
        values: heapless::Vec::from_slice(&[1.5; 12]).unwrap(),
    };
    let mut e = flexarm_link::Encoder::new();
    let by_ref = e
        .device(&DeviceMsgRef::Reply {
            id: 7,
            reply: &reply,
        })
        .unwrap()
        .to_vec();
    assert_eq!(by_ref, frame(&DeviceMsg::Reply { id: 7, reply }));
    let by_ref = e.device(&DeviceMsgRef::Telemetry(&t)).unwrap().to_vec();
    assert_eq!(by_ref, frame(&DeviceMsg::Telemetry(t)));
}

/// The telemetry frame's size formula is exact for the largest counters, and what the board's
/// line carries: the figures docs/link.md quotes.
#[test]
fn telemetry_frames_are_the_size_the_firmware_budgets() {
    for bits in [
        Channels::ERROR,
        Channels::ERROR | Channels::THETA,
        Channels::ALL,
    ] {
        let c = Channels(bits);
        let values =
            heapless::Vec::from_slice(&[-1.234_567e-3f32; MAX_CHANNELS][..c.values()]).unwrap();
        let msg = DeviceMsg::Telemetry(Telemetry {
            seq: u32::MAX,
            tick: (1 << 49) - 1,
            brake_engaged: true,
            channels: Channels(u16::MAX),
            values,
        });
        assert_eq!(frame(&msg).len(), c.frame_bytes(), "channels {bits:#x}");
    }
    let all = Channels(Channels::ALL);
    // 921 600 baud, 8N1: 10 bits a byte; 80 % of the line for telemetry.
    let per_second = 0.8 * 92_160.0 / all.frame_bytes() as f64;
    println!(
        "every channel: {} values, {} bytes a frame, {per_second:.0} frames/s in 80 % of 921 600 baud",
        all.values(),
        all.frame_bytes()
    );
    assert_eq!((all.values(), all.frame_bytes()), (12, 72));
    assert!(
        per_second >= 1000.0,
        "every channel at the board's 1 kHz motor loop"
    );
}

#[test]
fn bad_frames_are_named_and_the_next_one_is_delivered() {
    let good = frame(&Request {
        id: 3,
        command: Command::Ping,
    });
    // Truncated: the frame's first half, then its terminator.
    let mut bytes = good[..good.len() / 2].to_vec();
    bytes.push(0);
    // Oversized: more than a frame's worth without a zero.
    bytes.extend(std::iter::repeat_n(0x55, MAX_FRAME + 10));
    bytes.push(0);
    // A message of another protocol: valid CRC, unknown command index.
    let mut raw = vec![2u8, 200];
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&raw);
    raw.extend(crc.to_le_bytes());
    let mut unknown = vec![0u8; 16];
    let n = cobs::encode(&raw, &mut unknown);
    unknown.truncate(n);
    unknown.push(0);
    bytes.extend(&unknown);
    bytes.extend(&good);
    let out = decode_all::<Request>(&bytes);
    assert_eq!(out.len(), 4, "{out:?}");
    assert!(matches!(
        out[0],
        Err(FrameError::Cobs | FrameError::Crc | FrameError::Truncated)
    ));
    assert_eq!(out[1], Err(FrameError::Oversized));
    assert_eq!(out[2], Err(FrameError::Malformed));
    assert_eq!(out[3].as_ref().unwrap().id, 3);
    // Consecutive zeros are nothing.
    assert!(decode_all::<Request>(&[0, 0, 0]).is_empty());
    let _ = VERSION;
}

/// A frame's values are read by name: each channel's place follows from the channels the frame
/// names, so a subset reads right and a channel it lacks reads nothing.
#[test]
fn telemetry_is_read_by_name_whatever_the_subset() {
    use flexarm_link::msg::CHANNELS;
    // Every subset of the channels, each value its channel's bit and index.
    for bits in 0..=Channels::ALL {
        let channels = Channels(bits);
        let mut values = heapless::Vec::new();
        for c in CHANNELS.iter().filter(|c| bits & c.bit != 0) {
            for j in 0..c.width {
                values.push(f32::from(c.bit) + j as f32 / 10.0).unwrap();
            }
        }
        assert_eq!(values.len(), channels.values());
        let t = Telemetry {
            seq: 0,
            tick: 0,
            brake_engaged: true,
            channels,
            values,
        };
        for c in &CHANNELS {
            for j in 0..c.width {
                let want = (bits & c.bit != 0).then_some(f32::from(c.bit) + j as f32 / 10.0);
                assert_eq!(t.value(c.bit, j), want, "{bits:#b} {} {j}", c.name);
            }
            assert_eq!(t.value(c.bit, c.width), None);
        }
    }
    assert_eq!(
        CHANNELS.iter().map(|c| c.width).sum::<usize>(),
        Channels(Channels::ALL).values()
    );
    for (i, c) in CHANNELS.iter().enumerate() {
        assert_eq!(c.bit, 1 << i, "{}", c.name);
    }
}
