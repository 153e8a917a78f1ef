//! The truth plant's actuators and transducers (issue 14, second slice): what stands between
//! the controller's numbers and the arm. Host side, `f64`, SI units; each is a small state
//! machine stepped with the plant's step `dt` [s], its output held between steps.
//!
//! - [`Motor`]: a joint drive in torque mode: the current loop as a first-order lag of time
//!   constant `τ_i` (the torque-constant's scaling is inside the drive: the command is a
//!   torque), the torque limit, viscous and Coulomb friction. The Coulomb term is smoothed
//!   through zero speed as `F_c tanh(θ̇ / v_s)`, so the plant stays a smooth ODE (a stiction model
//!   would need event handling); `v_s` is stated with it. The rotor's inertia through the gear,
//!   `n² J_r`, belongs to the arm's inertia matrix, not here.
//! - [`PiezoAmplifier`]: the high-voltage amplifier driving the patch's capacitance `C_p`: a
//!   first-order lag of bandwidth `f_a`, its voltage window, and its output current limit, which
//!   caps the slew rate at `I_max / C_p`.
//! - [`FilmAmplifier`]: the PVDF film read through a charge (or voltage) amplifier, high-pass with
//!   corner `f_h` (`V_out' = V_f' − ω_h V_out`); the ADC behind it is the simulator's
//!   (`crate::sim::Sensors`: range, resolution, noise, delay).

/// A joint drive in torque mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motor {
    /// Current-loop time constant `τ_i` [s]; 0 for an ideal torque source.
    pub current_tau: f64,
    /// Torque limit at the joint [N·m].
    pub tau_max: f64,
    /// Viscous friction at the joint [N·m·s/rad].
    pub viscous: f64,
    /// Coulomb friction at the joint [N·m].
    pub coulomb: f64,
    /// Speed over which the Coulomb term changes sign, `v_s` [rad/s].
    pub smoothing: f64,
    /// Torque the current loop delivers now [N·m].
    torque: f64,
}

impl Motor {
    /// An ideal torque source with the limit `tau_max`.
    pub fn ideal(tau_max: f64) -> Self {
        Self::new(0.0, tau_max, 0.0, 0.0, 1e-3)
    }

    /// A drive with the given current-loop time constant [s], limit [N·m], viscous [N·m·s/rad]
    /// and Coulomb [N·m] friction, smoothed over `smoothing` [rad/s].
    pub fn new(current_tau: f64, tau_max: f64, viscous: f64, coulomb: f64, smoothing: f64) -> Self {
        Self {
            current_tau,
            tau_max,
            viscous,
            coulomb,
            smoothing,
            torque: 0.0,
        }
    }

    /// Advances the current loop by `dt` toward the command (saturated; NaN commands 0) and
    /// returns the motor's torque at the joint [N·m], before friction.
    pub fn step(&mut self, command: f64, dt: f64) -> f64 {
        let target = if command.is_nan() {
            0.0
        } else {
            command.clamp(-self.tau_max, self.tau_max)
        };
        self.torque = if self.current_tau > 0.0 {
            // Exact step of τ' = (target − τ)/τ_i with the target held.
            target + (self.torque - target) * (-dt / self.current_tau).exp()
        } else {
            target
        };
        self.torque
    }

    /// Friction torque at the joint speed `speed` [rad/s] (opposes the motion).
    pub fn friction(&self, speed: f64) -> f64 {
        self.viscous * speed + self.coulomb * (speed / self.smoothing).tanh()
    }

    /// The torque the current loop delivers [N·m] (before friction).
    pub fn torque(&self) -> f64 {
        self.torque
    }
}

/// The piezo amplifier and the patch's capacitance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PiezoAmplifier {
    /// Small-signal bandwidth `f_a` [Hz]; infinite for an ideal amplifier.
    pub bandwidth_hz: f64,
    /// Output window `[v_min, v_max]` [V].
    pub window: (f64, f64),
    /// Output current limit [A].
    pub current_max: f64,
    /// Capacitance of the patch [F].
    pub capacitance: f64,
    /// Voltage on the patch now [V].
    voltage: f64,
}

impl PiezoAmplifier {
    /// An amplifier of bandwidth `bandwidth_hz` [Hz], window [V], current limit [A] into the
    /// capacitance [F].
    pub fn new(bandwidth_hz: f64, window: (f64, f64), current_max: f64, capacitance: f64) -> Self {
        Self {
            bandwidth_hz,
            window,
            current_max,
            capacitance,
            voltage: 0.0,
        }
    }

    /// The largest slew rate the current limit allows, `I_max / C_p` [V/s].
    pub fn slew_max(&self) -> f64 {
        self.current_max / self.capacitance
    }

    /// Advances the output by `dt` toward the command and returns the patch voltage [V].
    pub fn step(&mut self, command: f64, dt: f64) -> f64 {
        let target = if command.is_nan() {
            0.0
        } else {
            command.clamp(self.window.0, self.window.1)
        };
        let lag = if self.bandwidth_hz.is_finite() {
            let wa = std::f64::consts::TAU * self.bandwidth_hz;
            target + (self.voltage - target) * (-wa * dt).exp()
        } else {
            target
        };
        let slew = self.slew_max() * dt;
        self.voltage += (lag - self.voltage).clamp(-slew, slew);
        self.voltage
    }

    /// The patch voltage now [V].
    pub fn voltage(&self) -> f64 {
        self.voltage
    }
}

/// The film's amplifier: high-pass (the ADC behind it is `crate::sim::Sensors`').
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilmAmplifier {
    /// High-pass corner `f_h` [Hz]; 0 for a DC-coupled amplifier (output = film voltage).
    pub corner_hz: f64,
    /// The amplifier's output now [V].
    output: f64,
    /// The film voltage at the previous step [V].
    previous: f64,
}

impl FilmAmplifier {
    /// A film amplifier with the given high-pass corner [Hz], settled at the film voltage
    /// `v_f` [V] (output 0 when high-pass).
    pub fn new(corner_hz: f64, v_f: f64) -> Self {
        Self {
            corner_hz,
            output: if corner_hz > 0.0 { 0.0 } else { v_f },
            previous: v_f,
        }
    }

    /// Advances the high-pass by `dt` to the film's open-circuit voltage `v_f` [V] and returns
    /// the amplifier's output [V]: `y' = v_f' − ω_h y`, stepped exactly for `v_f` linear over
    /// the step: `y(t+dt) = e^{−ω_h dt} y + (Δv/dt)(1 − e^{−ω_h dt})/ω_h`.
    pub fn step(&mut self, v_f: f64, dt: f64) -> f64 {
        let dv = v_f - self.previous;
        self.previous = v_f;
        self.output = if self.corner_hz > 0.0 {
            let wh = std::f64::consts::TAU * self.corner_hz;
            let decay = (-wh * dt).exp();
            self.output * decay + dv / dt * (1.0 - decay) / wh
        } else {
            v_f
        };
        self.output
    }

    /// The amplifier's output now [V].
    pub fn output(&self) -> f64 {
        self.output
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_current_loop_is_a_first_order_lag_and_friction_opposes_motion() {
        let mut m = Motor::new(1e-3, 5.0, 0.1, 0.2, 0.01);
        let dt = 1e-5;
        let mut t = 0.0;
        let mut out = 0.0;
        while t < 1e-3 - 1e-12 {
            out = m.step(2.0, dt);
            t += dt;
        }
        // One time constant: 1 − 1/e of the step, and no friction at rest.
        assert!(
            (m.torque() - 2.0 * (1.0 - (-1.0f64).exp())).abs() < 1e-9,
            "{}",
            m.torque()
        );
        assert_eq!(out, m.torque());
        // Saturation, NaN → 0, and friction against the motion, smooth through zero.
        let mut m = Motor::new(0.0, 5.0, 0.1, 0.2, 0.01);
        assert_eq!(m.step(50.0, dt), 5.0);
        assert_eq!(m.step(f64::NAN, dt), 0.0);
        assert!((m.friction(1.0) - (0.1 + 0.2 * 100f64.tanh())).abs() < 1e-12);
        assert_eq!(m.friction(-1.0), -m.friction(1.0));
        assert_eq!(m.friction(0.0), 0.0);
    }

    #[test]
    fn the_amplifier_lags_clips_to_its_window_and_slews_at_its_current_limit() {
        // 100 nF and 10 mA: at most 1e5 V/s.
        let mut a = PiezoAmplifier::new(f64::INFINITY, (-30.0, 150.0), 0.01, 100e-9);
        assert_eq!(a.slew_max(), 1e5);
        let dt = 1e-5;
        // A step to 150 V takes 1.5 ms at 1 V per 10 µs.
        assert!((a.step(200.0, dt) - 1.0).abs() < 1e-9, "{}", a.voltage());
        for _ in 0..200 {
            a.step(200.0, dt);
        }
        assert_eq!(a.voltage(), 150.0, "clipped to the window");
        assert_eq!(a.step(-100.0, dt), 149.0);
        // A fast amplifier with plenty of current: the first-order lag alone.
        let mut a = PiezoAmplifier::new(1000.0, (-200.0, 200.0), 1.0, 1e-9);
        let tau = 1.0 / (std::f64::consts::TAU * 1000.0);
        let n = (tau / 1e-7).round() as usize;
        for _ in 0..n {
            a.step(100.0, 1e-7);
        }
        assert!(
            (a.voltage() - 100.0 * (1.0 - (-1.0f64).exp())).abs() < 0.1,
            "{}",
            a.voltage()
        );
    }

    #[test]
    fn the_film_amplifier_is_high_pass() {
        // A step of the film voltage decays with the corner's time constant.
        let mut f = FilmAmplifier::new(1.0, 0.0);
        let dt = 1e-4;
        let y0 = f.step(1.0, dt);
        assert!(y0 > 0.99 && y0 <= 1.0, "{y0}");
        let tau = 1.0 / std::f64::consts::TAU;
        let n = (tau / dt).round() as usize;
        let mut y = y0;
        for _ in 0..n {
            y = f.step(1.0, dt);
        }
        assert!((y / y0 - (-1.0f64).exp()).abs() < 1e-3, "{}", y / y0);
        // Far above the corner a sine passes with its amplitude.
        let mut f = FilmAmplifier::new(0.1, 0.0);
        let w = std::f64::consts::TAU * 20.0;
        let mut peak: f64 = 0.0;
        for k in 1..100_000 {
            let y = f.step((w * k as f64 * 1e-5).sin(), 1e-5);
            if k > 50_000 {
                peak = peak.max(y.abs());
            }
        }
        assert!((peak - 1.0).abs() < 0.01, "{peak}");
        // DC-coupled: the film voltage itself.
        let mut f = FilmAmplifier::new(0.0, 0.3);
        assert_eq!(f.output(), 0.3);
        assert_eq!(f.step(-2.5, dt), -2.5);
    }
}
