//! The link's decoder on arbitrary byte streams, both directions: it must never panic, every
//! message it delivers must re-encode to a frame within the limit and decode back to itself,
//! and a good frame after the input (and a zero) is always delivered. `cargo fuzz run -s none link`.
#![no_main]

use flexarm_link::frame::{Decoder, MAX_FRAME, encode};
use flexarm_link::{DeviceMsg, Request};
use libfuzzer_sys::fuzz_target;
use serde::Serialize;
use serde::de::DeserializeOwned;

fn check<T: Serialize + DeserializeOwned + core::fmt::Debug>(data: &[u8], good: &T) {
    let mut d = Decoder::new();
    for b in data.iter().copied().chain([0]) {
        if let Some(Ok(msg)) = d.push::<T>(b) {
            let mut buf = [0u8; MAX_FRAME];
            let f = encode(&msg, &mut buf).expect("a delivered message re-encodes");
            let mut again = Decoder::new();
            let back = f.iter().find_map(|b| again.push::<T>(*b));
            assert!(
                matches!(&back, Some(Ok(m)) if format!("{m:?}") == format!("{msg:?}")),
                "{msg:?} came back as {back:?}"
            );
        }
    }
    let mut buf = [0u8; MAX_FRAME];
    let f = encode(good, &mut buf).unwrap();
    let last = f.iter().filter_map(|b| d.push::<T>(*b)).last();
    assert!(matches!(last, Some(Ok(_))), "resync failed: {last:?}");
}

fuzz_target!(|data: &[u8]| {
    check::<Request>(
        data,
        &Request {
            id: 1,
            command: flexarm_link::Command::Status,
        },
    );
    check::<DeviceMsg>(
        data,
        &DeviceMsg::Reply {
            id: 1,
            reply: flexarm_link::Reply::Done,
        },
    );
});
