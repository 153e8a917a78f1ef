//! The firmware's boot move on the host, with the code the firmware runs: the host's rig
//! (`flexarm_host::rig`) of each board's generated configuration on the QEMU board's simulated
//! arm, the drive armed at boot and the paper's trapezoid started, as the QEMU verdict run does.
//! These runs justify the bounds the QEMU run checks (`firmware/src/config.rs`, `bounds`;
//! `docs/firmware.md`): `cargo test -p flexarm-tests --test firmware_loop -- --nocapture`.

use flexarm_core::Vector2;
use flexarm_core::control::motor::MotorLaw;
use flexarm_core::drive::MoveRequest;
use flexarm_core::trajectory::Trapezoid;
use flexarm_link::msg::Board;
use flexarm_machine::BoardConfig;

struct Outcome {
    max_error: f32,
    tail_error: f32,
    max_tip: f32,
    final_tip: f32,
    enabled_to_the_end: bool,
}

/// `seconds` of the boot move of `board`'s firmware under `law`, measured on the plant (the true
/// arm, not the controller's estimate) against the move, as the QEMU verdict run measures it.
fn run(board: Board, law: MotorLaw, seconds: f32) -> Outcome {
    let cfg = BoardConfig {
        law,
        ..flexarm_tests::firmware(board)
    };
    let mut rig = flexarm_tests::rig(cfg, [0.0, 0.0]);
    let half_pi = core::f32::consts::FRAC_PI_2;
    rig.arm().unwrap();
    rig.start(&MoveRequest::Trapezoid {
        target: Vector2::new(half_pi, half_pi),
        move_time: 2.0,
        ramp_time: 0.5,
    })
    .unwrap();
    let paper = Trapezoid::<f32>::paper();
    let mut out = Outcome {
        max_error: 0.0,
        tail_error: 0.0,
        max_tip: 0.0,
        final_tip: 0.0,
        enabled_to_the_end: true,
    };
    let (mut tail_sum, mut tail_n) = (0.0f32, 0u32);
    let periods = (seconds * cfg.motor_hz() as f32).round() as u32;
    for k in 0..periods {
        let p = rig.period();
        let t = k as f32 / cfg.motor_hz() as f32;
        out.enabled_to_the_end &= p.command.enable;
        let arm = &rig.board.arm;
        let e = (arm.x.q.xy() - paper.sample(t).q).abs().max();
        out.max_error = out.max_error.max(e);
        if t >= seconds - 3.0 {
            tail_sum += e;
            tail_n += 1;
        }
        let tip = arm.model.tip_deflection(&arm.x.q).abs();
        out.max_tip = out.max_tip.max(tip);
        out.final_tip = tip;
    }
    out.tail_error = tail_sum / tail_n as f32;
    out
}

#[test]
fn qemu_rates_track_and_damp() {
    for (name, board) in [
        ("QEMU (piezo 1 kHz, motor 100 Hz)", Board::Qemu),
        ("hardware (10 kHz, 1 kHz)", Board::Hardware),
    ] {
        for law in [MotorLaw::Tracking, MotorLaw::Robust] {
            let o = run(board, law, 6.0);
            println!(
                "{name}, {law:?}: max |θ − θ_d| {:.3e} rad, mean over the last 3 s {:.3e} rad, max |tip| {:.3e} m, final |tip| {:.3e} m",
                o.max_error, o.tail_error, o.max_tip, o.final_tip
            );
            assert!(o.enabled_to_the_end, "no fault in a healthy run");
            assert!(o.max_error < 0.05, "tracks the move within 0.05 rad");
            assert!(o.tail_error < 2e-3, "settles within 2 mrad");
            assert!(
                o.max_tip < 0.02 && o.final_tip < 1e-3,
                "vibration bounded and damped"
            );
        }
    }
}
