//! The fault recorder: keeps the last N samples oldest first, freezes at the fault with the
//! faulting sample last, and starts empty again after a restart.

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use flexarm_core::Fault;
use flexarm_core::recorder::{Recorder, Sample};

fn sample(tick: u64) -> Sample {
    Sample {
        tick,
        theta: [tick as f32, 0.0],
        ..Sample::default()
    }
}

#[test]
fn it_keeps_the_last_samples_and_freezes_at_the_fault() {
    let mut r = Recorder::<5>::new();
    assert!(r.is_empty() && r.get(0).is_none());
    for t in 0..3 {
        r.record(&sample(t), None);
    }
    assert_eq!(r.len(), 3);
    assert_eq!({ r.get(0).unwrap().tick }, 0);
    for t in 3..12 {
        r.record(&sample(t), None);
    }
    // The last five, oldest first.
    let ticks: Vec<u64> = (0..r.len()).map(|i| r.get(i).unwrap().tick).collect();
    assert_eq!(ticks, [7, 8, 9, 10, 11]);
    assert!(r.get(5).is_none());
    r.record(&sample(12), Some(Fault::Amplifier));
    assert_eq!(r.fault(), Some(Fault::Amplifier));
    for t in 13..20 {
        r.record(&sample(t), Some(Fault::Amplifier));
    }
    let ticks: Vec<u64> = (0..r.len()).map(|i| r.get(i).unwrap().tick).collect();
    assert_eq!(
        ticks,
        [8, 9, 10, 11, 12],
        "frozen with the faulting sample last"
    );
    r.restart();
    assert!(r.is_empty() && r.fault().is_none());
    r.record(&sample(30), None);
    assert_eq!({ r.get(0).unwrap().tick }, 30);
}
