//! The like-for-like comparison with C: the Rust hot paths and the same work written in C
//! (`firmware/c/steps.c`, built by `build.rs` at -O2 and -O3), each called as a whole function
//! and counted from its entry to its return.
//!
//! Both sides are called the same way: through the C calling convention, with pointers to their
//! state and their inputs in `r0`–`r3`, writing the result through a pointer (the store the
//! firmware does), by a `BL` between the two counter reads ([`timed_call`]). The count is
//! everything from the callee's first instruction to its return, inclusive: the region less
//! the counter reads' overhead and the `BL`. A call of an empty function must count exactly 1
//! (its return), which [`calibrate`] checks. On the same states, both sides must give the
//! same torques and voltages within round-off ([`agree`]): the C does the same work.

use core::hint::black_box;

use flexarm_core::control::piezo::PiezoGains;
use flexarm_core::control::tracking::eq7_torques;
use flexarm_core::controller::Controller;
use flexarm_core::model::Model;
use flexarm_core::observer::{Measurement, film_map};
use flexarm_core::observer_gains::{GAIN_1KHZ, gain};
use flexarm_core::params::Gains;
use flexarm_core::trajectory::{JointTarget, JointTrajectory};
use flexarm_core::{Vector2, Vector4};

use super::{N, PIEZO_PERIOD, Stat, State, report};

/// One state in the layout both sides read (`struct fc_state` in steps.c; `JointTarget` and
/// `Measurement` are `repr(C)`).
#[repr(C)]
#[derive(Clone, Copy)]
pub struct CState {
    t: f32,
    q: Vector4<f32>,
    qd: Vector4<f32>,
    target: JointTarget<f32>,
    y: Measurement<f32>,
}

impl CState {
    fn new(s: &State, t: f32) -> Self {
        Self {
            t,
            q: s.q,
            qd: s.qd,
            target: s.target,
            y: s.y,
        }
    }
}

/// The parameters the C controller is built from (`struct fc_params`, field for field): the
/// values the Rust controller of the bench is built from.
#[repr(C)]
struct CParams {
    a1: f32,
    a2: f32,
    m1: f32,
    m2: f32,
    m_h2: f32,
    i_1: f32,
    i_h1: f32,
    i_h2: f32,
    i_2_extra: f32,
    omega: Vector2<f32>,
    zeta: Vector2<f32>,
    mass_integral: Vector2<f32>,
    moment_integral: Vector2<f32>,
    lambda: Vector4<f32>,
    kp: Vector4<f32>,
    d_delta: Vector2<f32>,
    epsilon: Vector2<f32>,
    phi: Vector2<f32>,
    epsilon_floor: f32,
    mu: f32,
    tau_max: Vector2<f32>,
    v_a_min: f32,
    v_a_max: f32,
    k_c: f32,
    cutoff_hz: f32,
    piezo_period: f32,
    c_a: Vector2<f32>,
    gain_t: [[f32; 3]; 8],
    c_f: Vector2<f32>,
    period: f32,
    theta_min: Vector2<f32>,
    theta_max: Vector2<f32>,
    speed_max: f32,
    v_f_max: f32,
    start: Vector2<f32>,
    amplitude: Vector2<f32>,
    duration: f32,
    ramp: f32,
    stale_limit: u32,
    robust: u32,
    ki: Vector2<f32>,
    integral_limit: Vector2<f32>,
}

impl CParams {
    /// The parameters of `c`, a controller of the paper's arm on the paper's trapezoid.
    fn of(c: &Controller<f32>) -> Option<Self> {
        let JointTrajectory::Trapezoid(tr) = c.trajectory else {
            return None;
        };
        let (p, g, l, s) = (
            &c.motor.model.params,
            &c.motor.gains,
            &c.motor.limits,
            c.sensor_limits(),
        );
        let pg = PiezoGains::<f32>::default();
        let l_gain = gain(&GAIN_1KHZ);
        Some(Self {
            a1: p.a1,
            a2: p.a2,
            m1: p.m1,
            m2: p.m2,
            m_h2: p.m_h2,
            i_1: p.i_1,
            i_h1: p.i_h1,
            i_h2: p.i_h2,
            i_2_extra: p.i_2_extra,
            omega: p.modes.omega,
            zeta: p.modes.zeta,
            mass_integral: p.modes.mass_integral,
            moment_integral: p.modes.moment_integral,
            lambda: g.lambda,
            kp: g.kp,
            d_delta: g.d_delta,
            epsilon: g.epsilon,
            phi: g.phi,
            epsilon_floor: g.epsilon_floor,
            mu: g.mu,
            tau_max: l.tau_max,
            v_a_min: l.v_a_min,
            v_a_max: l.v_a_max,
            k_c: pg.k_c,
            cutoff_hz: pg.cutoff_hz,
            piezo_period: PIEZO_PERIOD,
            c_a: c.patch.c_a(),
            gain_t: core::array::from_fn(|i| core::array::from_fn(|j| l_gain[(i, j)])),
            c_f: film_map(&c.patch),
            period: c.motor_period,
            theta_min: s.theta_min,
            theta_max: s.theta_max,
            speed_max: s.speed_max,
            v_f_max: s.v_f_max,
            start: tr.start,
            amplitude: tr.amplitude,
            duration: tr.profile.duration(),
            ramp: tr.profile.ramp(),
            stale_limit: 3,
            robust: u32::from(c.motor.law == flexarm_core::control::motor::MotorLaw::Robust),
            ki: g.ki,
            integral_limit: g.integral_limit,
        })
    }
}

/// The C controller's state: an opaque block `struct fc_ctrl` fits in (steps.c asserts it).
#[repr(C, align(8))]
#[derive(Clone, Copy)]
pub struct CCtrl([u8; 512]);

unsafe extern "C" {
    fn flexarm_c_init_o2(c: *mut CCtrl, p: *const CParams);
    fn flexarm_c_reset_o2(c: *mut CCtrl, theta: *const Vector2<f32>);
    fn flexarm_c_eq7_o2(c: *const CCtrl, s: *const CState, tau: *mut Vector2<f32>);
    fn flexarm_c_piezo_step_o2(c: *mut CCtrl, v_f: *const f32, v_a: *mut f32);
    fn flexarm_c_motor_step_o2(c: *mut CCtrl, s: *const CState, tau: *mut Vector2<f32>) -> u32;
    fn flexarm_c_init_o3(c: *mut CCtrl, p: *const CParams);
    fn flexarm_c_reset_o3(c: *mut CCtrl, theta: *const Vector2<f32>);
    fn flexarm_c_eq7_o3(c: *const CCtrl, s: *const CState, tau: *mut Vector2<f32>);
    fn flexarm_c_piezo_step_o3(c: *mut CCtrl, v_f: *const f32, v_a: *mut f32);
    fn flexarm_c_motor_step_o3(c: *mut CCtrl, s: *const CState, tau: *mut Vector2<f32>) -> u32;
}

// The Rust side, in the same calling convention as the C.

/// Eq. 7 as a function, `eq7_torques`.
#[allow(improper_ctypes_definitions)] // called from `asm!` only, by these Rust types' layout
#[inline(never)]
extern "C" fn rust_eq7(m: &Model<f32>, g: &Gains<f32>, s: &CState, tau: &mut Vector2<f32>) {
    *tau = eq7_torques(m, g, &s.q, &s.qd, &s.target);
}

/// The complete piezo step, `Controller::piezo_step`.
#[allow(improper_ctypes_definitions)]
#[inline(never)]
extern "C" fn rust_piezo_step(c: &mut Controller<f32>, v_f: &f32, v_a: &mut f32) {
    *v_a = c.piezo_step(*v_f);
}

/// The complete motor step, `Controller::motor_step`; returns the amplifiers' enable.
#[allow(improper_ctypes_definitions)]
#[inline(never)]
extern "C" fn rust_motor_step(c: &mut Controller<f32>, s: &CState, tau: &mut Vector2<f32>) -> u32 {
    let r = c.motor_step(s.t, Some(&s.y));
    *tau = r.command.tau;
    u32::from(r.command.enable)
}

/// An empty function, its return only: the calibration of a call.
#[unsafe(naked)]
extern "C" fn nothing() {
    core::arch::naked_asm!("bx lr")
}

/// Defines `$name(args) -> u32`: a call of `$f(args)` by a `BL` between two reads of TIM5's
/// counter (the same `LDREX` reads as the bench's other regions, `super::now`), returning the
/// count of the region, the `BL` included. Written out in assembly (a naked function) so that
/// nothing but the call sits between the reads: the arguments arrive in `r0`–`r3` and go on to
/// `$f` untouched, the counter values wait in callee-saved registers.
macro_rules! timed_call {
    ($name:ident => $f:path, ($($arg:ident: $ty:ty),*)) => {
        #[allow(improper_ctypes_definitions)] // pointers to the bench's types, by reference
        #[unsafe(naked)]
        extern "C" fn $name($($arg: $ty),*) -> u32 {
            core::arch::naked_asm!(
                "push {{r4, r5, r8, lr}}",
                "movw r8, #0x0c24",
                "movt r8, #0x4000",
                "ldrex r4, [r8]",
                "bl {f}",
                "movw r8, #0x0c24",
                "movt r8, #0x4000",
                "ldrex r5, [r8]",
                "subs r0, r5, r4",
                "pop {{r4, r5, r8, pc}}",
                f = sym $f,
            )
        }
    };
}

// The measured calls, one per row (`scripts/fw-cycles` finds each by its name `call_<row>`, and
// the callee by the `BL`).
timed_call!(call_fn_nothing => nothing, ());
timed_call!(call_fn_eq7_rust => rust_eq7,
    (m: &Model<f32>, g: &Gains<f32>, s: &CState, tau: &mut Vector2<f32>));
timed_call!(call_fn_eq7_c_o2 => flexarm_c_eq7_o2, (c: &CCtrl, s: &CState, tau: &mut Vector2<f32>));
timed_call!(call_fn_eq7_c_o3 => flexarm_c_eq7_o3, (c: &CCtrl, s: &CState, tau: &mut Vector2<f32>));
timed_call!(call_fn_piezo_step_rust => rust_piezo_step,
    (c: &mut Controller<f32>, v_f: &f32, v_a: &mut f32));
timed_call!(call_fn_piezo_step_c_o2 => flexarm_c_piezo_step_o2, (c: &mut CCtrl, v_f: &f32, v_a: &mut f32));
timed_call!(call_fn_piezo_step_c_o3 => flexarm_c_piezo_step_o3, (c: &mut CCtrl, v_f: &f32, v_a: &mut f32));
timed_call!(call_fn_controller_motor_rust => rust_motor_step,
    (c: &mut Controller<f32>, s: &CState, tau: &mut Vector2<f32>));
timed_call!(call_fn_controller_motor_c_o2 => flexarm_c_motor_step_o2,
    (c: &mut CCtrl, s: &CState, tau: &mut Vector2<f32>));
timed_call!(call_fn_controller_motor_c_o3 => flexarm_c_motor_step_o3,
    (c: &mut CCtrl, s: &CState, tau: &mut Vector2<f32>));

/// The C functions of one build (-O2 or -O3): its rows' names and its measured calls.
struct CBuild {
    rows: [&'static str; 3],
    /// The row of its motor step with the integral action (agreement only).
    integral: &'static str,
    init: unsafe extern "C" fn(*mut CCtrl, *const CParams),
    reset: unsafe extern "C" fn(*mut CCtrl, *const Vector2<f32>),
    motor_step: unsafe extern "C" fn(*mut CCtrl, *const CState, *mut Vector2<f32>) -> u32,
    timed_eq7: extern "C" fn(&CCtrl, &CState, &mut Vector2<f32>) -> u32,
    timed_piezo_step: extern "C" fn(&mut CCtrl, &f32, &mut f32) -> u32,
    timed_motor_step: extern "C" fn(&mut CCtrl, &CState, &mut Vector2<f32>) -> u32,
}

const BUILDS: [CBuild; 2] = [
    CBuild {
        rows: [
            "fn_eq7_c_o2",
            "fn_piezo_step_c_o2",
            "fn_controller_motor_c_o2",
        ],
        integral: "fn_controller_motor_c_o2 with K_i",
        init: flexarm_c_init_o2,
        reset: flexarm_c_reset_o2,
        motor_step: flexarm_c_motor_step_o2,
        timed_eq7: call_fn_eq7_c_o2,
        timed_piezo_step: call_fn_piezo_step_c_o2,
        timed_motor_step: call_fn_controller_motor_c_o2,
    },
    CBuild {
        rows: [
            "fn_eq7_c_o3",
            "fn_piezo_step_c_o3",
            "fn_controller_motor_c_o3",
        ],
        integral: "fn_controller_motor_c_o3 with K_i",
        init: flexarm_c_init_o3,
        reset: flexarm_c_reset_o3,
        motor_step: flexarm_c_motor_step_o3,
        timed_eq7: call_fn_eq7_c_o3,
        timed_piezo_step: call_fn_piezo_step_c_o3,
        timed_motor_step: call_fn_controller_motor_c_o3,
    },
];

/// The count of a call of an empty function less the overhead: must be 1, its return.
pub fn calibrate(overhead: u32) -> bool {
    let n = (0..8)
        .map(|_| call_fn_nothing().wrapping_sub(overhead + 1))
        .min()
        .unwrap_or(0);
    defmt::info!(
        "calibration: a call of an empty function counts {=u32} (must be 1: its return)",
        n
    );
    n == 1
}

/// The largest difference between the Rust's and the C's results, relative to their size
/// (at least 1): round-off, when both do the same work.
struct Agreement {
    worst: f32,
}

impl Agreement {
    fn add(&mut self, rust: &[f32], c: &[f32]) {
        for (a, b) in rust.iter().zip(c) {
            let d = (a - b).abs() / a.abs().max(b.abs()).max(1.0);
            // NaN on one side only is the worst disagreement.
            self.worst = if d.is_nan() && !(a.is_nan() && b.is_nan()) {
                f32::INFINITY
            } else if d > self.worst {
                d
            } else {
                self.worst
            };
        }
    }
}

/// Relative round-off allowed between the two sides' results (f32: an ulp is 1.2e-7; the
/// complete step's observer and its constants computed in another order differ in the last
/// bits, which the saturation and the law's gains may amplify).
const AGREE: f32 = 1e-4;

/// Whether `a` holds, printing the outcome.
fn agree(set: &str, name: &str, a: &Agreement) -> bool {
    let ok = a.worst <= AGREE;
    if ok {
        defmt::info!(
            "AGREE {=str} {=str}: Rust and C within {=f32} (relative) on every state",
            set,
            name,
            a.worst
        );
    } else {
        defmt::error!(
            "AGREE {=str} {=str}: Rust and C differ by {=f32} (relative): not the same work",
            set,
            name,
            a.worst
        );
    }
    ok
}

/// One state set's results of one side: Eq. 7's torques, the piezo commands, the complete
/// motor step's torques.
struct Results {
    eq7: [Vector2<f32>; N],
    piezo: [f32; N],
    motor: [Vector2<f32>; N],
}

impl Results {
    fn new() -> Self {
        Self {
            eq7: [Vector2::zeros(); N],
            piezo: [0.0; N],
            motor: [Vector2::zeros(); N],
        }
    }
}

/// Every function row of one state set: Eq. 7, the piezo step (one controller through the
/// states, as the 10 kHz loop runs it) and the complete motor step in steady state (a reset at
/// the state's angles, a first step, then the measured one a period later), in Rust and in
/// both C builds. Prints each row; `false` unless the two sides agree on every state.
pub fn run(
    set: &str,
    states: &[State; N],
    overhead: u32,
    model: &Model<f32>,
    gains: &Gains<f32>,
    base: &Controller<f32>,
) -> bool {
    let Some(params) = CParams::of(base) else {
        defmt::error!("the C comparison needs the trapezoid's controller");
        return false;
    };
    let counted = |n: u32| n.wrapping_sub(overhead + 1);
    let first: [CState; N] = core::array::from_fn(|i| CState::new(&states[i], states[i].t));
    let steady: [CState; N] =
        core::array::from_fn(|i| CState::new(&states[i], states[i].t + base.motor_period));

    let mut rust = Results::new();
    let mut stat = [Stat::new(), Stat::new(), Stat::new()];
    let mut c = *base;
    for (i, s) in first.iter().enumerate() {
        stat[0].add(counted(call_fn_eq7_rust(
            black_box(model),
            black_box(gains),
            s,
            &mut rust.eq7[i],
        )));
        stat[1].add(counted(call_fn_piezo_step_rust(
            black_box(&mut c),
            &s.y.v_f,
            &mut rust.piezo[i],
        )));
        let mut m = *base;
        m.reset_observer(s.y.theta);
        rust_motor_step(&mut m, s, &mut rust.motor[i]);
        stat[2].add(counted(call_fn_controller_motor_rust(
            black_box(&mut m),
            &steady[i],
            &mut rust.motor[i],
        )));
    }
    for (row, s) in [
        "fn_eq7_rust",
        "fn_piezo_step_rust",
        "fn_controller_motor_rust",
    ]
    .iter()
    .zip(&stat)
    {
        report(set, row, s, None);
    }

    let mut ok = true;
    for b in &BUILDS {
        let mut template = CCtrl([0; 512]);
        // SAFETY: `template` is the block steps.c's controller fits in, `params` its
        // parameters, and every call below gets pointers to live values of the declared types.
        unsafe { (b.init)(&mut template, &params) };
        let mut mine = Results::new();
        let mut stat = [Stat::new(), Stat::new(), Stat::new()];
        let mut c = template;
        for (i, s) in first.iter().enumerate() {
            stat[0].add(counted((b.timed_eq7)(
                black_box(&template),
                s,
                &mut mine.eq7[i],
            )));
            stat[1].add(counted((b.timed_piezo_step)(
                black_box(&mut c),
                &s.y.v_f,
                &mut mine.piezo[i],
            )));
            let mut m = template;
            // SAFETY: as above.
            unsafe {
                (b.reset)(&mut m, &s.y.theta);
                (b.motor_step)(&mut m, s, &mut mine.motor[i]);
            }
            stat[2].add(counted((b.timed_motor_step)(
                black_box(&mut m),
                &steady[i],
                &mut mine.motor[i],
            )));
        }
        for (row, s) in b.rows.iter().zip(&stat) {
            report(set, row, s, None);
        }
        let mut same = [
            Agreement { worst: 0.0 },
            Agreement { worst: 0.0 },
            Agreement { worst: 0.0 },
        ];
        for i in 0..N {
            same[0].add(rust.eq7[i].as_slice(), mine.eq7[i].as_slice());
            same[1].add(&[rust.piezo[i]], &[mine.piezo[i]]);
            same[2].add(rust.motor[i].as_slice(), mine.motor[i].as_slice());
        }
        for (row, a) in b.rows.iter().zip(&same) {
            ok &= agree(set, row, a);
        }
    }
    ok & integral_agrees(set, base, &first, &steady)
}

/// The integral action's path, which the paper's gains (`K_i = 0`) leave to its test: the
/// motor step's two periods with the boards' `K_i = 5/s` on both joints (the first shifts the
/// target, the second integrates too), Rust against each C build; agreement only.
fn integral_agrees(
    set: &str,
    base: &Controller<f32>,
    first: &[CState; N],
    steady: &[CState; N],
) -> bool {
    let mut with_ki = *base;
    with_ki.motor.gains.ki = Vector2::new(5.0, 5.0);
    let Some(params) = CParams::of(&with_ki) else {
        return false;
    };
    let mut rust = [Vector2::zeros(); N];
    for (i, s) in first.iter().enumerate() {
        let mut m = with_ki;
        m.reset_observer(s.y.theta);
        rust_motor_step(&mut m, s, &mut rust[i]);
        rust_motor_step(&mut m, &steady[i], &mut rust[i]);
    }
    let mut ok = true;
    for b in &BUILDS {
        let mut m = CCtrl([0; 512]);
        let mut a = Agreement { worst: 0.0 };
        for (i, s) in first.iter().enumerate() {
            let mut tau = Vector2::zeros();
            // SAFETY: as in `run`.
            unsafe {
                (b.init)(&mut m, &params);
                (b.reset)(&mut m, &s.y.theta);
                (b.motor_step)(&mut m, s, &mut tau);
                (b.motor_step)(&mut m, &steady[i], &mut tau);
            }
            a.add(rust[i].as_slice(), tau.as_slice());
        }
        ok &= agree(set, b.integral, &a);
    }
    ok
}
