//! The holding brakes' watch (`flexarm_core::brake`) on its own.

use flexarm_core::Vector2;
use flexarm_core::brake::BrakeWatch;

const SETTLE: u32 = 3;
const TRAVEL: f32 = 0.02;

/// Settles for `SETTLE` engaged periods, takes the held pose, then trips on a joint more than
/// `TRAVEL` from it and stays tripped; a released brake restarts the settling; `reset` forgets.
#[test]
fn the_watch_settles_holds_trips_and_resets() {
    let mut w = BrakeWatch::<f32>::new();
    let at = |x: f32| Vector2::new(x, -x);
    // Moving while it settles (the brake gripping): nothing.
    for k in 0..SETTLE {
        assert!(!w.update(true, at(0.1 * k as f32), SETTLE, TRAVEL));
    }
    // The held pose, then within the travel: nothing.
    assert!(!w.update(true, at(0.5), SETTLE, TRAVEL));
    assert!(!w.update(true, at(0.5 + 0.019), SETTLE, TRAVEL));
    // Joint 2 past it (the other way): tripped, and it stays.
    assert!(w.update(true, Vector2::new(0.5, -0.5 - 0.021), SETTLE, TRAVEL));
    assert!(w.update(true, Vector2::new(0.5, -0.5 - 0.021), SETTLE, TRAVEL));
    // Released (armed), engaged again: still tripped until reset.
    assert!(w.update(false, at(3.0), SETTLE, TRAVEL));
    assert!(w.slipped());
    w.reset();
    assert!(!w.slipped());
    // After a release the settling starts again: a move during it is not a slip.
    assert!(!w.update(false, at(0.0), SETTLE, TRAVEL));
    for k in 0..SETTLE {
        assert!(!w.update(true, at(0.2 * k as f32), SETTLE, TRAVEL));
    }
    assert!(!w.update(true, at(1.0), SETTLE, TRAVEL));
    assert!(w.update(true, at(1.03), SETTLE, TRAVEL));
}

/// A board without brakes (`brake_travel` 0): never a slip, whatever the joints do.
#[test]
fn no_brakes_no_watch() {
    let mut w = BrakeWatch::<f32>::new();
    for k in 0..100 {
        assert!(!w.update(true, Vector2::new(k as f32, 0.0), SETTLE, 0.0));
    }
}
