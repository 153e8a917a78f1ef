//! Homing (issue 33, "No absolute reference"): the relation between a joint's encoder reading
//! and the arm's own frame.
//!
//! An incremental encoder counts from 0 wherever the joint rests at power-up (and again after
//! every reset). Until a joint is homed, its reading `θ_enc` says nothing about where the joint
//! is in the arm's frame, so every limit that refers to that frame (the sensors' range, the
//! soft limits, the move validation's joint ranges) would hold around the power-up pose instead
//! of around the arm's zero. Homing finds the offset `θ = θ_enc + offset_j` per joint, from a
//! reference whose angle in the arm's frame is known ([`JointHoming::angle`]):
//!
//! | [`Method`] | the reference | found when | `offset_j` |
//! |---|---|---|---|
//! | [`Method::Index`] | the encoder's index mark (one per joint revolution) | the board latches the count at the index pulse ([`Inputs::latched`]) | `angle − θ_enc(index)` |
//! | [`Method::EndStop`] | a mechanical end stop | the joint has not moved by `stall_travel` for `stall_time` while its torque is at the search limit, pushing towards the stop | `angle − θ_enc` |
//! | [`Method::Switch`] | a limit switch | the board latches the count at the switch's active edge ([`Inputs::latched`], as for an index) | `angle − θ_enc(edge)` |
//!
//! Each is a search: the joint moves at `speed` [rad/s] (its sign is the direction) with the
//! torque limit lowered to `torque` [N·m], at most `travel` [rad] from where the search
//! started; the search fails, and the drive disarms, when it travels that far without finding
//! its reference. The drive ([`crate::drive::Drive::home`]) runs the searches one joint at a
//! time, joint 1 first.
//!
//! The state of each joint ([`State`]): `Unhomed` at power-up and after a reset (the drive is
//! built afresh), `Searching` while its search runs, `Homed` once found, `Declared` when a host
//! asserted the pose with the explicit declare command ([`crate::drive::Drive::declare`]):
//! the drive then trusts the host's word, and status shows it as declared, never as homed.
//! The drive refuses `arm` and moves ([`crate::drive::Refused::NotHomed`]) until every joint is
//! homed or declared.
//!
//! Units SI: rad, rad/s, N·m, s.

use crate::Vector2;
use crate::real::Real;

/// How a joint finds its reference (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The encoder's index pulse: the count latched at the index mark.
    Index,
    /// A search at a low torque limit into a mechanical end stop.
    EndStop,
    /// A limit-switch input.
    Switch,
}

/// A joint's homing configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointHoming<T> {
    /// The method.
    pub method: Method,
    /// The reference's angle in the arm's frame [rad]: the index mark's, the end stop's, or
    /// the switch's edge in the search direction.
    pub angle: T,
    /// The search speed [rad/s]; its sign is the search direction.
    pub speed: T,
    /// The torque limit during the search [N·m] (every joint's, while any joint searches).
    pub torque: T,
    /// The farthest a search travels before it fails [rad].
    pub travel: T,
}

/// The homing configuration of both joints.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config<T> {
    /// Per joint.
    pub joints: [JointHoming<T>; 2],
    /// End-stop search: the joint counts as stalled while it stays within this of where the
    /// stall began [rad].
    pub stall_travel: T,
    /// End-stop search: how long a stall lasts before the stop is taken as found [s].
    pub stall_time: T,
    /// End-stop search: the share of the search torque that counts as "at the limit".
    pub stall_share: T,
    /// After homing: how far from its angle a joint's index or switch may be seen again before
    /// the drive latches `ReferenceMismatch` ([`Homing::mismatch`]) [rad]. Above the edge's
    /// repeatability and a switch's hysteresis.
    pub tolerance: T,
}

impl<T: Real> Default for Config<T> {
    /// Both joints by their index marks at 0 rad, searching at +0.2 rad/s with 1 N·m for at
    /// most 6.5 rad (a little over one revolution: the mark is met once in any revolution);
    /// an end stop counts as found after 0.2 s within 2 mrad (5 counts of a 16384-count
    /// encoder) at 90 % of the search torque; a reference seen again within 10 mrad (26 counts)
    /// of its angle.
    fn default() -> Self {
        let joint = JointHoming {
            method: Method::Index,
            angle: T::zero(),
            speed: T::c(0.2),
            torque: T::c(1.0),
            travel: T::c(6.5),
        };
        Self {
            joints: [joint, joint],
            stall_travel: T::c(0.002),
            stall_time: T::c(0.2),
            stall_share: T::c(0.9),
            tolerance: T::c(0.01),
        }
    }
}

/// A joint's homing state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    /// The encoder's frame is the power-up pose's: not known in the arm's frame.
    Unhomed,
    /// Its search runs.
    Searching,
    /// Its reference was found: the offset is measured.
    Homed,
    /// A host declared the pose known (an explicit command): trusted, not measured.
    Declared,
}

impl State {
    /// Whether the joint's offset may be used to arm (homed or declared).
    pub fn known(self) -> bool {
        matches!(self, State::Homed | State::Declared)
    }

    /// A one-byte code for the wire and the logs: 0 unhomed, 1 searching, 2 homed,
    /// 3 declared.
    pub fn code(self) -> u8 {
        match self {
            State::Unhomed => 0,
            State::Searching => 1,
            State::Homed => 2,
            State::Declared => 3,
        }
    }

    /// The state of a [`Self::code`] (unknown codes: `Unhomed`).
    pub fn from_code(code: u8) -> Self {
        match code {
            1 => State::Searching,
            2 => State::Homed,
            3 => State::Declared,
            _ => State::Unhomed,
        }
    }
}

/// The board's homing inputs of one motor period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inputs<T> {
    /// Per joint: the encoder reading [rad] the board latched at the reference's edge (an
    /// index pulse, or a limit switch's active edge) since the last period's inputs; NaN when
    /// none came. (One number a joint: the motor loop carries these every period, on a stack
    /// whose bound is budgeted.)
    pub latched: [T; 2],
}

impl<T: Real> Default for Inputs<T> {
    /// Nothing latched.
    fn default() -> Self {
        Self {
            latched: [T::c(f64::NAN); 2],
        }
    }
}

/// What one period of a search found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Search<T> {
    /// Still searching.
    Running,
    /// Found: the joint's offset [rad].
    Found(T),
    /// Travelled [`JointHoming::travel`] without finding the reference.
    Failed,
}

/// The homing state of both joints and the offsets from the encoders to the arm's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Homing<T> {
    /// The configuration.
    pub config: Config<T>,
    state: [State; 2],
    /// `θ − θ_enc` per joint [rad].
    offset: Vector2<T>,
    /// The running search: where it started and where the stall began (encoder frame) [rad],
    /// and how long the stall has lasted [s].
    start: T,
    anchor: T,
    stalled: T,
    /// The last search failed (cleared when one starts or succeeds).
    failed: bool,
}

impl<T: Real> Homing<T> {
    /// Both joints unhomed, offsets 0.
    pub fn new(config: Config<T>) -> Self {
        Self {
            config,
            state: [State::Unhomed; 2],
            offset: Vector2::zeros(),
            start: T::zero(),
            anchor: T::zero(),
            stalled: T::zero(),
            failed: false,
        }
    }

    /// Joint `j`'s state (`Unhomed` for a joint that does not exist).
    pub fn state(&self, j: usize) -> State {
        self.state.get(j).copied().unwrap_or(State::Unhomed)
    }

    /// Both joints' states.
    pub fn states(&self) -> [State; 2] {
        self.state
    }

    /// Whether every joint is homed or declared.
    pub fn known(&self) -> bool {
        self.state.iter().all(|s| s.known())
    }

    /// Whether any joint's pose is only declared.
    pub fn declared(&self) -> bool {
        self.state.contains(&State::Declared)
    }

    /// The joint whose search runs, if any.
    pub fn searching(&self) -> Option<usize> {
        self.state.iter().position(|s| *s == State::Searching)
    }

    /// Whether the last search failed.
    pub fn failed(&self) -> bool {
        self.failed
    }

    /// `θ − θ_enc` per joint [rad].
    pub fn offset(&self) -> Vector2<T> {
        self.offset
    }

    /// The encoder reading `theta_enc` in the arm's frame [rad].
    #[inline(always)]
    pub fn to_arm(&self, theta_enc: Vector2<T>) -> Vector2<T> {
        theta_enc + self.offset
    }

    /// Every joint unhomed (a cause that may have lost counts), offsets 0.
    pub fn forget(&mut self) {
        self.state = [State::Unhomed; 2];
        self.offset = Vector2::zeros();
    }

    /// A host declares the pose whose encoder reading is `theta_enc` to be `theta` in the
    /// arm's frame [rad] (both finite, else refused with `false`).
    pub fn declare(&mut self, theta_enc: Vector2<T>, theta: Vector2<T>) -> bool {
        let offset = theta - theta_enc;
        if !(offset.x.finite() && offset.y.finite()) {
            return false;
        }
        self.offset = offset;
        self.state = [State::Declared; 2];
        self.failed = false;
        true
    }

    /// Starts joint `j`'s search from the encoder reading `theta_enc` [rad] of that joint:
    /// its offset goes back to 0 (its frame is the encoder's while it searches).
    pub fn begin(&mut self, j: usize, theta_enc: T) {
        if let Some(s) = self.state.get_mut(j) {
            *s = State::Searching;
        }
        if j == 0 {
            self.offset.x = T::zero();
        } else {
            self.offset.y = T::zero();
        }
        self.start = theta_enc;
        self.anchor = theta_enc;
        self.stalled = T::zero();
        self.failed = false;
    }

    /// One motor period of joint `j`'s search: its encoder reading `theta_enc` [rad], its
    /// commanded torque `tau` [N·m], the board's `inputs`, the period `dt` [s]. A found
    /// reference homes the joint with its offset; a failed search leaves it unhomed.
    pub fn search(
        &mut self,
        j: usize,
        theta_enc: T,
        tau: T,
        inputs: &Inputs<T>,
        dt: T,
    ) -> Search<T> {
        let Some(cfg) = self.config.joints.get(j).copied() else {
            return Search::Failed;
        };
        let found = match cfg.method {
            Method::Index | Method::Switch => inputs
                .latched
                .get(j)
                .copied()
                .filter(|at| at.finite())
                .map(|at| cfg.angle - at),
            Method::EndStop => self.stall(&cfg, theta_enc, tau, dt),
        };
        let result = match found {
            Some(offset) if offset.finite() => Search::Found(offset),
            _ if (theta_enc - self.start).abs() > cfg.travel || !theta_enc.finite() => {
                Search::Failed
            }
            _ => Search::Running,
        };
        let state = match result {
            Search::Running => State::Searching,
            Search::Found(offset) => {
                if j == 0 {
                    self.offset.x = offset;
                } else {
                    self.offset.y = offset;
                }
                State::Homed
            }
            Search::Failed => {
                self.failed = true;
                State::Unhomed
            }
        };
        if let Some(s) = self.state.get_mut(j) {
            *s = state;
        }
        result
    }

    /// The running search failed from outside (its reference's trajectory ended): the joint is
    /// unhomed, [`Self::failed`] set.
    pub fn fail(&mut self) {
        self.abort();
        self.failed = true;
    }

    /// Ends a search that did not finish (a stop, a disarm, a fault): the joint is unhomed.
    pub fn abort(&mut self) {
        for s in self.state.iter_mut() {
            if *s == State::Searching {
                *s = State::Unhomed;
            }
        }
    }

    /// The first homed joint whose reference the board saw in `inputs` (a latched encoder
    /// reading) off its angle by more than [`Config::tolerance`]: an index mark at `angle`
    /// plus a whole number of turns, a switch's edge at `angle` (an end stop gives no input).
    /// The reference is on the joint's side of what can fail: a switch on the joint sees a
    /// coupling that slipped under the encoder; an index on the encoder's disk sees counts lost
    /// between the disk and the counter. A declared joint is not checked: its frame is the
    /// host's word, not measured against the reference.
    pub fn mismatch(&self, inputs: &Inputs<T>) -> Option<usize> {
        (0..2).find(|&j| {
            let (Some(cfg), Some(&at), Some(&state)) = (
                self.config.joints.get(j),
                inputs.latched.get(j),
                self.state.get(j),
            ) else {
                return false;
            };
            if state != State::Homed || !at.finite() {
                return false;
            }
            let off = at + if j == 0 { self.offset.x } else { self.offset.y } - cfg.angle;
            let off = match cfg.method {
                Method::Index => {
                    let (sin, cos) = off.lsin_cos();
                    sin.latan2(cos)
                }
                Method::Switch => off,
                Method::EndStop => return false,
            };
            // Not `off.abs() > tolerance`: a tolerance that is not a number trips.
            let within = off.abs() <= self.config.tolerance;
            !within
        })
    }

    /// The end-stop's stall: the joint within `stall_travel` of where the stall began for
    /// `stall_time`, its torque at the search limit towards the stop. The stop's offset then.
    fn stall(&mut self, cfg: &JointHoming<T>, theta_enc: T, tau: T, dt: T) -> Option<T> {
        let c = &self.config;
        let pushing = tau * cfg.speed.signum() >= c.stall_share * cfg.torque;
        if pushing && (theta_enc - self.anchor).abs() <= c.stall_travel {
            self.stalled += dt;
        } else {
            self.anchor = theta_enc;
            self.stalled = T::zero();
        }
        (self.stalled >= c.stall_time).then(|| cfg.angle - theta_enc)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
mod tests {
    use super::*;

    fn config(method: Method) -> Config<f64> {
        let mut c = Config::default();
        c.joints[0].method = method;
        c.joints[0].angle = 3.0;
        c
    }

    #[test]
    fn an_index_pulse_gives_the_offset_from_the_latched_count() {
        let mut h = Homing::new(config(Method::Index));
        h.begin(0, 0.0);
        let none = Inputs::default();
        assert_eq!(h.search(0, 0.1, 0.2, &none, 1e-3), Search::Running);
        assert_eq!(h.state(0), State::Searching);
        let pulse = Inputs {
            latched: [0.25, f64::NAN],
        };
        assert_eq!(h.search(0, 0.26, 0.2, &pulse, 1e-3), Search::Found(2.75));
        assert_eq!(h.state(0), State::Homed);
        assert_eq!(h.to_arm(Vector2::new(0.25, 0.0)).x, 3.0);
        // Joint 2 is not homed by joint 1's search.
        assert!(!h.known());
    }

    #[test]
    fn a_switch_homes_at_its_latched_edge() {
        let mut h = Homing::new(config(Method::Switch));
        h.begin(0, -1.0);
        let on = Inputs {
            latched: [-0.5, f64::NAN],
        };
        assert_eq!(h.search(0, -0.5, 0.0, &on, 1e-3), Search::Found(3.5));
    }

    #[test]
    fn an_end_stop_needs_the_torque_at_the_limit_and_no_motion_for_the_stall_time() {
        let mut h = Homing::new(config(Method::EndStop));
        h.begin(0, 0.0);
        let none = Inputs::default();
        let dt = 1e-3;
        // Still, but pushing with less than 90 % of the search torque: not a stop.
        for _ in 0..1000 {
            assert_eq!(h.search(0, 0.5, 0.8, &none, dt), Search::Running);
        }
        // At the limit but pushing away from the stop (negative torque): not a stop.
        for _ in 0..1000 {
            assert_eq!(h.search(0, 0.5, -1.0, &none, dt), Search::Running);
        }
        // At the limit and still: found after the stall time (0.2 s), not before.
        let mut periods = 0;
        loop {
            periods += 1;
            match h.search(0, 0.5, 1.0, &none, dt) {
                Search::Running => assert!(periods < 250),
                Search::Found(o) => {
                    assert!((o - 2.5).abs() < 1e-12);
                    break;
                }
                Search::Failed => panic!("failed"),
            }
        }
        assert!((199..=202).contains(&periods), "{periods}");
    }

    #[test]
    fn a_search_that_travels_too_far_fails_unhomed() {
        let mut h = Homing::new(config(Method::Index));
        h.begin(0, 0.0);
        assert_eq!(
            h.search(0, 6.6, 0.2, &Inputs::default(), 1e-3),
            Search::Failed
        );
        assert_eq!(h.state(0), State::Unhomed);
        assert!(h.failed());
    }

    /// Joint 1 homed on its reference at 3 rad, its encoder then reading 0.25 rad there.
    fn homed(method: Method) -> Homing<f64> {
        let mut h = Homing::new(config(method));
        h.begin(0, 0.0);
        let at = Inputs {
            latched: [0.25, f64::NAN],
        };
        assert_eq!(h.search(0, 0.25, 0.2, &at, 1e-3), Search::Found(2.75));
        h
    }

    fn seen(at: f64) -> Inputs<f64> {
        Inputs {
            latched: [at, f64::NAN],
        }
    }

    #[test]
    fn a_switch_seen_again_off_its_angle_is_a_mismatch() {
        let h = homed(Method::Switch);
        assert_eq!(h.mismatch(&Inputs::default()), None);
        // Within the 10 mrad tolerance on either side: the edge's repeatability.
        assert_eq!(h.mismatch(&seen(0.25 + 0.009)), None);
        assert_eq!(h.mismatch(&seen(0.25 - 0.009)), None);
        // A coupling that slipped by 11 mrad either way, or by a turn: the switch has no turns.
        assert_eq!(h.mismatch(&seen(0.25 + 0.011)), Some(0));
        assert_eq!(h.mismatch(&seen(0.25 - 0.011)), Some(0));
        assert_eq!(h.mismatch(&seen(0.25 + core::f64::consts::TAU)), Some(0));
        // A reading that is not a number is not a reference seen.
        assert_eq!(h.mismatch(&seen(f64::INFINITY)), None);
    }

    #[test]
    fn an_index_seen_again_a_turn_on_is_not_a_mismatch_and_lost_counts_are() {
        let h = homed(Method::Index);
        for turns in [-2.0, -1.0, 1.0, 3.0] {
            let at = 0.25 + turns * core::f64::consts::TAU;
            assert_eq!(h.mismatch(&seen(at)), None, "{turns} turns");
            assert_eq!(h.mismatch(&seen(at + 0.02)), Some(0), "{turns} turns");
        }
    }

    #[test]
    fn only_homed_joints_are_checked() {
        // Joint 2 unhomed, joint 1 declared, an end stop homed: none has a reference to see.
        let mut h = homed(Method::Switch);
        let other = Inputs {
            latched: [f64::NAN, 9.0],
        };
        assert_eq!(h.mismatch(&other), None);
        h.declare(Vector2::zeros(), Vector2::zeros());
        assert_eq!(h.mismatch(&seen(1.0)), None);
        let mut stop = Homing::new(config(Method::EndStop));
        stop.begin(0, 0.0);
        while stop.search(0, 0.25, 1.0, &Inputs::default(), 1e-3) == Search::Running {}
        assert_eq!(stop.state(0), State::Homed);
        assert_eq!(stop.mismatch(&seen(1.0)), None);
    }

    #[test]
    fn declared_is_known_and_not_homed() {
        let mut h = Homing::<f64>::new(Config::default());
        assert!(!h.known());
        assert!(!h.declare(Vector2::zeros(), Vector2::new(f64::NAN, 0.0)));
        assert!(!h.known());
        assert!(h.declare(Vector2::new(0.1, 0.2), Vector2::new(1.0, 0.0)));
        assert!(h.known() && h.declared());
        assert_eq!(h.states(), [State::Declared; 2]);
        assert_eq!(h.to_arm(Vector2::new(0.1, 0.2)), Vector2::new(1.0, 0.0));
        for s in [
            State::Unhomed,
            State::Searching,
            State::Homed,
            State::Declared,
        ] {
            assert_eq!(State::from_code(s.code()), s);
        }
    }
}
