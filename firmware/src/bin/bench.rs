//! Instruction counts of the hot-path functions on the Cortex-M4F, under QEMU
//! (`cargo fw-bench`).
//!
//! With `-icount shift=0` QEMU advances TIM5 (clocked at 1 GHz) by one count per executed
//! instruction, so a count difference around a call is the number of instructions it executed:
//! exact and repeatable. Each function is called through a wrapper that is never inlined, with
//! its state in memory, the way an interrupt handler calls it: the count is the function's own
//! work, the loads and stores of its state included. The cost of the measurement itself, the
//! two reads around a call of an empty wrapper of the same shape, is subtracted. On hardware,
//! the same code would read the DWT cycle counter instead.
//!
//! States: 200 recorded along the paper's trapezoid move (the simulated arm under the complete
//! controller, the same code as the QEMU board) and 200 random ones. Each mean is checked
//! against `firmware/budgets.txt`; the run exits non-zero on a regression.
#![no_std]
#![no_main]

use core::hint::black_box;
use core::sync::atomic::Ordering::SeqCst;
use core::sync::atomic::compiler_fence;

use cortex_m_semihosting::debug::{EXIT_FAILURE, EXIT_SUCCESS, exit};
use defmt_semihosting as _;
use flexarm_core::control::motor::{MotorController, MotorLaw};
use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::control::tracking::eq7_torques;
use flexarm_core::controller::Controller;
use flexarm_core::model::Model;
use flexarm_core::observer::Measurement;
use flexarm_core::observer_gains::{GAIN_1KHZ, gain};
use flexarm_core::params::{ArmParams, Gains, Limits};
use flexarm_core::simarm::{SensorModel, SimArm};
use flexarm_core::trajectory::{JointTarget, JointTrajectory, Trapezoid};
use flexarm_core::{Vector2, Vector4};

include!(concat!(env!("OUT_DIR"), "/budgets.rs"));

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    exit(EXIT_FAILURE);
    loop {
        cortex_m::asm::bkpt();
    }
}

fn now() -> u32 {
    // SAFETY: a side-effect-free read of TIM5's counter, configured once in `main`.
    unsafe { (*stm32f4::stm32f405::TIM5::ptr()).cnt().read().bits() }
}

/// One benchmark state.
#[derive(Clone, Copy)]
struct State {
    t: f32,
    q: Vector4<f32>,
    qd: Vector4<f32>,
    target: JointTarget<f32>,
    y: Measurement<f32>,
}

const N: usize = 200;

/// Min, mean and max of a set of counts.
struct Stat {
    min: u32,
    max: u32,
    sum: u32,
    n: u32,
}

impl Stat {
    fn new() -> Self {
        Self {
            min: u32::MAX,
            max: 0,
            sum: 0,
            n: 0,
        }
    }
    fn add(&mut self, c: u32) {
        self.min = self.min.min(c);
        self.max = self.max.max(c);
        self.sum += c;
        self.n += 1;
    }
    fn mean(&self) -> u32 {
        self.sum / self.n.max(1)
    }
}

// The measured calls. Each wrapper is never inlined and reads the counter itself, around the
// call, with compiler fences so that no load or computation moves across the reads; the state
// (controller, model, sample) stays in memory as in the firmware.

/// Runs `f` between two counter reads; returns its result and the count.
#[inline(always)]
fn timed<R>(f: impl FnOnce() -> R) -> (R, u32) {
    let t0 = now();
    compiler_fence(SeqCst);
    let r = f();
    compiler_fence(SeqCst);
    let t1 = now();
    (r, t1.wrapping_sub(t0))
}

#[inline(never)]
fn call_empty(c: &mut Controller<f32>, v_f: f32) -> (f32, u32) {
    timed(|| black_box((c, v_f)).1)
}

#[inline(never)]
fn call_eq7(model: &Model<f32>, gains: &Gains<f32>, s: &State) -> (Vector2<f32>, u32) {
    timed(|| eq7_torques(model, gains, &s.q, &s.qd, &s.target))
}

#[inline(never)]
fn call_motor_law(motor: &MotorController<f32>, s: &State) -> (Option<Vector2<f32>>, u32) {
    timed(|| motor.step(s.t, &s.q, &s.qd, &s.target).ok().map(|o| o.tau))
}

#[inline(never)]
fn call_motor_step(c: &mut Controller<f32>, s: &State) -> (Vector2<f32>, u32) {
    timed(|| c.motor_step(s.t, Some(&s.y)).command.tau)
}

#[inline(never)]
fn call_piezo_step(c: &mut Controller<f32>, v_f: f32) -> (f32, u32) {
    timed(|| c.piezo_step(v_f))
}

/// Counts of `f` (a timed call) over `states`, overhead subtracted.
fn measure<R>(states: &[State], overhead: u32, mut f: impl FnMut(&State) -> (R, u32)) -> Stat {
    let mut s = Stat::new();
    for st in states {
        let (r, n) = f(black_box(st));
        black_box(r);
        s.add(n.saturating_sub(overhead));
    }
    s
}

fn controller(law: MotorLaw) -> Controller<f32> {
    Controller::paper(
        law,
        JointTrajectory::Trapezoid(Trapezoid::paper()),
        1e-4,
        1e-3,
        gain(&GAIN_1KHZ),
    )
}

/// 200 states along the paper's move: the simulated arm (1 kHz motor, 10 kHz piezo) under the
/// complete controller, one state every 25 ms.
fn recorded() -> [State; N] {
    let mut out = [State {
        t: 0.0,
        q: Vector4::zeros(),
        qd: Vector4::zeros(),
        target: JointTarget::rest(Vector2::zeros()),
        y: Measurement {
            theta: Vector2::zeros(),
            v_f: 0.0,
        },
    }; N];
    let mut ctrl = controller(MotorLaw::Tracking);
    let patch = PiezoPatch::<f32>::paper();
    let mut arm = SimArm::new(
        Model::new(ArmParams::default()),
        patch,
        Vector4::zeros(),
        SensorModel::default(),
    );
    let traj = Trapezoid::<f32>::paper();
    let mut i = 0;
    for k in 0..5000u32 {
        let t = k as f32 * 1e-3;
        for _ in 0..10 {
            let v_a = ctrl.piezo_step(arm.film_voltage());
            arm.set_piezo(v_a);
            arm.step(1e-4);
        }
        let y = Measurement {
            theta: arm.encoders(),
            v_f: arm.film_voltage(),
        };
        let rep = ctrl.motor_step(t, Some(&y));
        arm.set_torques(rep.command.tau);
        arm.set_enable(rep.command.enable);
        if k % 25 == 0 && i < N {
            let (q, qd) = ctrl.estimate();
            out[i] = State {
                t,
                q,
                qd,
                target: traj.sample(t),
                y,
            };
            i += 1;
        }
    }
    out
}

/// 200 random states over the workspace (a fixed LCG).
fn random() -> [State; N] {
    let mut seed = 0x2545_f491u32;
    let mut r = move |s: f32| {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        ((seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0) * s
    };
    core::array::from_fn(|_| {
        let q = Vector4::new(r(3.0), r(2.5), r(0.01), r(0.001));
        State {
            t: 1.0 + r(0.5),
            q,
            qd: Vector4::new(r(2.0), r(2.0), r(0.3), r(0.1)),
            target: JointTarget {
                q: Vector2::new(q.x + r(0.01), q.y + r(0.01)),
                qd: Vector2::new(r(1.0), r(1.0)),
                qdd: Vector2::new(r(2.0), r(2.0)),
            },
            y: Measurement {
                theta: Vector2::new(q.x, q.y),
                v_f: r(1.0),
            },
        }
    })
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let dp = stm32f4::stm32f405::Peripherals::take()
        .unwrap_or_else(|| panic!("peripherals taken twice"));
    dp.RCC.apb1enr().modify(|_, w| w.tim5en().set_bit());
    dp.TIM5.psc().write(|w| w.psc().set(0));
    dp.TIM5.arr().write(|w| w.arr().set(u32::MAX));
    dp.TIM5.cr1().write(|w| w.cen().set_bit());
    dp.TIM5.cnt().write(|w| w.cnt().set(0));

    let sets = [("recorded", recorded()), ("random", random())];
    let overhead = {
        let mut c = controller(MotorLaw::Robust);
        measure(&sets[0].1, 0, |s| call_empty(black_box(&mut c), s.y.v_f)).min
    };
    defmt::info!(
        "measurement overhead: {=u32} instructions (subtracted)",
        overhead
    );

    let model = Model::new(ArmParams::<f32>::default());
    let gains = Gains::default();
    let motor = MotorController {
        model,
        gains,
        limits: Limits::default(),
        law: MotorLaw::Robust,
    };
    let mut ok = true;
    for (name, states) in &sets {
        let rows = [
            (
                "eq7",
                measure(states, overhead, |s| {
                    call_eq7(black_box(&model), black_box(&gains), s)
                }),
            ),
            (
                "motor_step",
                measure(states, overhead, |s| call_motor_law(black_box(&motor), s)),
            ),
            ("controller_motor", {
                let base = controller(MotorLaw::Robust);
                let mut stat = Stat::new();
                for s in states.iter() {
                    let mut c = base;
                    c.reset_observer(s.y.theta);
                    let (tau, n) = call_motor_step(black_box(&mut c), s);
                    black_box(tau);
                    stat.add(n.saturating_sub(overhead));
                }
                stat
            }),
            ("piezo_step", {
                let mut c = controller(MotorLaw::Robust);
                measure(states, overhead, |s| {
                    call_piezo_step(black_box(&mut c), s.y.v_f)
                })
            }),
        ];
        for (fname, s) in &rows {
            let budget = match *fname {
                "eq7" => BUDGET_EQ7_MEAN,
                "motor_step" => BUDGET_MOTOR_STEP_MEAN,
                "controller_motor" => BUDGET_CONTROLLER_MOTOR_MEAN,
                _ => BUDGET_PIEZO_STEP_MEAN,
            };
            let within = *name != "random" || s.mean() <= budget;
            ok &= within;
            defmt::info!(
                "BENCH {=str} {=str}: min {=u32} mean {=u32} max {=u32} instructions{=str}",
                *name,
                *fname,
                s.min,
                s.mean(),
                s.max,
                if *name == "random" {
                    if within {
                        " (within budget)"
                    } else {
                        " OVER BUDGET"
                    }
                } else {
                    ""
                }
            );
        }
    }
    exit(if ok { EXIT_SUCCESS } else { EXIT_FAILURE });
    loop {
        cortex_m::asm::wfi();
    }
}
