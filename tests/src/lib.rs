//! Integration tests live in `tests/`; here, what they share: the firmware's boards on the
//! host (`flexarm_host::rig::Rig`) with the QEMU board's simulated arm.

use flexarm_core::Vector4;
use flexarm_host::firmware_params::paper_board;
use flexarm_host::rig::Rig;
use flexarm_link::msg::Board;
use flexarm_machine::BoardConfig;
use flexarm_machine::simulated::SimulatedArm;

/// The configuration a board of kind `board` boots with from the default model file (the
/// paper's arm and patch, `k_c = 30 s`): the firmware's generated `HARDWARE` (piezo 10 kHz,
/// motor 1 kHz) or `QEMU` (1 kHz, 100 Hz).
pub fn firmware(board: Board) -> BoardConfig {
    paper_board(board).unwrap_or_else(|e| panic!("the paper's fragment: {e}"))
}

/// A rig of `cfg` on the QEMU board's simulated arm (the paper's arm with `cfg`'s patch) at rest
/// at the joint angles `theta` [rad], stepped at `cfg`'s piezo period, booted at tick 0.
pub fn rig(cfg: BoardConfig, theta: [f32; 2]) -> Rig<SimulatedArm> {
    let q = Vector4::new(theta[0], theta[1], 0.0, 0.0);
    let mut rig = Rig::new(
        cfg,
        SimulatedArm::paper(cfg.patch, q, cfg.piezo_period()),
        flexarm_core::time::Ticks(0),
    );
    // The simulated arm's encoders read its own angles: the arm's frame, declared (as the
    // QEMU board's boot does).
    declared(&mut rig);
    rig
}

/// Declares the encoders' frame the arm's (`Drive::declare_zero`): a simulated arm whose
/// encoders count from the plant's zero.
pub fn declared<B: flexarm_machine::Board>(rig: &mut Rig<B>) {
    if let Err(e) = rig.declare_encoders() {
        panic!("declare: {e:?}");
    }
}

/// What a test injects between the simulated arm and the controller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Injection {
    /// Nothing.
    None,
    /// Joint 1's encoder counts the other way.
    Reversed,
    /// Joint 2's encoder stops at its reading from this time [s] of the arm's.
    FrozenFrom(f32),
    /// Joint 1 stops at this angle [rad] (a rigid obstacle: its speed is zeroed there).
    Wall(f32),
}

/// The QEMU board's simulated arm with a test's injection, and the largest piezo command it
/// was given.
pub struct TestArm {
    /// The arm.
    pub sim: SimulatedArm,
    /// What is injected.
    pub injection: Injection,
    /// Joint 2's frozen reading.
    frozen: Option<f32>,
    /// Plant steps so far.
    steps: u32,
    /// The largest |V_a| commanded since the last [`TestArm::take_peak`] [V].
    peak: f32,
    /// A torque from outside added to the motors' [N·m] (a tap on the arm).
    pub push: flexarm_core::Vector2<f32>,
}

impl TestArm {
    /// The largest |V_a| commanded since the last call [V].
    pub fn take_peak(&mut self) -> f32 {
        std::mem::take(&mut self.peak)
    }

    /// The arm's own time [s]: its steps times its step.
    pub fn time(&self) -> f32 {
        self.steps as f32 * self.sim.dt
    }
}

impl flexarm_machine::Board for TestArm {
    fn encoders(&mut self) -> flexarm_core::Vector2<f32> {
        let mut th = self.sim.arm.encoders();
        match self.injection {
            Injection::Reversed => th.x = -th.x,
            Injection::FrozenFrom(t0) if self.time() >= t0 => {
                th.y = *self.frozen.get_or_insert(th.y);
            }
            _ => {}
        }
        th
    }
    fn film_voltage(&mut self) -> f32 {
        self.sim.arm.film_voltage()
    }
    fn set_torques(&mut self, tau: flexarm_core::Vector2<f32>) {
        flexarm_machine::Board::set_torques(&mut self.sim, tau + self.push);
    }
    fn set_piezo(&mut self, v_a: f32) {
        self.peak = self.peak.max(v_a.abs());
        flexarm_machine::Board::set_piezo(&mut self.sim, v_a);
    }
    fn set_enable(&mut self, on: bool) {
        flexarm_machine::Board::set_enable(&mut self.sim, on);
    }
    fn set_brake(&mut self, engaged: bool) {
        flexarm_machine::Board::set_brake(&mut self.sim, engaged);
    }
    fn brake_engaged(&mut self) -> bool {
        flexarm_machine::Board::brake_engaged(&mut self.sim)
    }
    fn amplifier_fault(&mut self) -> bool {
        false
    }
    fn tick(&mut self) {
        self.sim.step();
        self.steps += 1;
        assert!(!self.sim.diverged, "the plant diverged");
        if let Injection::Wall(at) = self.injection
            && self.sim.arm.x.q.x >= at
        {
            self.sim.arm.x.q.x = at;
            self.sim.arm.x.qd.x = self.sim.arm.x.qd.x.min(0.0);
        }
    }
}

/// A rig of `cfg` on a [`TestArm`] at rest at `theta` [rad] with `injection`.
pub fn test_rig(cfg: BoardConfig, theta: [f32; 2], injection: Injection) -> Rig<TestArm> {
    let q = Vector4::new(theta[0], theta[1], 0.0, 0.0);
    let arm = TestArm {
        sim: SimulatedArm::paper(cfg.patch, q, cfg.piezo_period()),
        injection,
        frozen: None,
        steps: 0,
        peak: 0.0,
        push: flexarm_core::Vector2::zeros(),
    };
    let mut rig = Rig::new(cfg, arm, flexarm_core::time::Ticks(0));
    declared(&mut rig);
    rig
}
