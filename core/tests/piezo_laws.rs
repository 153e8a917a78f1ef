//! The piezo laws beside the paper's (issue 35): each law runs its linear form, saturates to
//! its window, answers bad input with 0 V, and its design rule does what its docs say.
//! About 0.1 s.

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)] // tests may index and unwrap

use flexarm_core::Vector2;
use flexarm_core::control::cancel::{CancelGains, FeedthroughCancel};
use flexarm_core::control::irc::{Irc, IrcGains};
use flexarm_core::control::linear::{IdentifiedLoop, StateSpace};
use flexarm_core::control::piezo::PiezoGains;
use flexarm_core::control::ppf::{self, Ppf, PpfFilter, PpfGains};
use nalgebra::SVector;
use proptest::prelude::*;

const T: f64 = 1e-4;

/// The 2.5 mm link's two modes as the study identifies them, feedthrough of the perfect bond.
fn identified() -> IdentifiedLoop<f64> {
    IdentifiedLoop {
        omega: Vector2::new(28.553, 161.63),
        zeta: Vector2::new(0.07, 0.03),
        film_gain: Vector2::new(0.5756, 27.216),
        direct: -4.94e-4,
        feedthrough: -1.086e-3,
    }
}

/// `u_k` of the linear form for the inputs `ys`, from rest.
fn run_linear<const S: usize>(ss: &StateSpace<f64, S>, ys: &[f64]) -> Vec<f64> {
    run_linear_from(ss, SVector::zeros(), ys)
}

/// The same from the state `z`.
fn run_linear_from<const S: usize>(
    ss: &StateSpace<f64, S>,
    mut z: SVector<f64, S>,
    ys: &[f64],
) -> Vec<f64> {
    ys.iter()
        .map(|y| {
            let u = ss.c.dot(&z) + ss.d * y;
            z = ss.a * z + ss.b * *y;
            u
        })
        .collect()
}

fn close(a: &[f64], b: &[f64], tol: f64) -> Result<(), TestCaseError> {
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        prop_assert!(
            (x - y).abs() <= tol * (1.0 + y.abs()),
            "k = {k}: {x} vs {y}"
        );
    }
    Ok(())
}

proptest! {
    /// Inside the window every law computes its linear form (what the host's eigen-analysis
    /// studies), sample for sample.
    #[test]
    fn each_law_runs_its_linear_form(ys in prop::collection::vec(-1.0..1.0f64, 2..300)) {
        let id = identified();
        let wide = 1e12;
        let mut ppf = Ppf::new(&PpfGains::design(&id).unwrap(), T, -wide, wide);
        let lin = ppf.linear();
        let got: Vec<f64> = ys.iter().map(|y| ppf.step(*y)).collect();
        close(&got, &run_linear(&lin, &ys), 1e-9)?;
        let mut irc = Irc::new(&IrcGains::design(&id).unwrap(), T, -wide, wide);
        let lin = irc.linear();
        let got: Vec<f64> = ys.iter().map(|y| irc.step(*y)).collect();
        close(&got, &run_linear(&lin, &ys), 1e-9)?;
        for lag in [1, 2] {
            let g = CancelGains { rate: PiezoGains { k_c: 3.0, cutoff_hz: 30.0 }, feedthrough: -1e-3, lag };
            let mut c = FeedthroughCancel::new(&g, T, -wide, wide);
            let lin = c.linear();
            // The law's first sample only primes it: the linear form then runs from the state
            // (u_0, ỹ_0, u_{−1}) = (0, y_0, 0).
            let got: Vec<f64> = ys.iter().map(|y| c.step(*y)).collect();
            prop_assert_eq!(got[0], 0.0);
            let want = run_linear_from(&lin, SVector::<f64, 3>::new(0.0, ys[0], 0.0), &ys[1..]);
            close(&got[1..], &want, 1e-9)?;
        }
    }

    /// Every law stays inside an asymmetric window, and a NaN or infinite sample commands 0 V
    /// and restarts it from rest.
    #[test]
    fn each_law_saturates_and_refuses_bad_samples(ys in prop::collection::vec(-50.0..50.0f32, 1..200)) {
        let id = identified().cast_f32();
        let (lo, hi) = (-30.0f32, 150.0f32);
        let mut ppf = Ppf::new(&PpfGains::design(&id).unwrap(), 1e-4, lo, hi);
        let mut irc = Irc::new(&IrcGains::design(&id).unwrap(), 1e-4, lo, hi);
        let g = CancelGains { rate: PiezoGains { k_c: 30.0f32, cutoff_hz: 100.0 }, feedthrough: -1e-3, lag: 2 };
        let mut can = FeedthroughCancel::new(&g, 1e-4, lo, hi);
        prop_assert!(ppf.is_valid() && irc.is_valid() && can.is_valid());
        let mut steps: [&mut dyn FnMut(f32) -> f32; 3] =
            [&mut |y| ppf.step(y), &mut |y| irc.step(y), &mut |y| can.step(y)];
        for step in steps.iter_mut() {
            for y in &ys {
                let u = step(*y * 1e3);
                prop_assert!((lo..=hi).contains(&u), "{u}");
            }
            for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                prop_assert_eq!(step(bad), 0.0);
            }
        }
        // After a NaN each law is at rest: a zero sample commands 0 V.
        prop_assert_eq!(ppf.step(0.0), 0.0);
        prop_assert_eq!(irc.step(0.0), 0.0);
        prop_assert_eq!(can.step(0.0), 0.0);
    }
}

trait CastF32 {
    fn cast_f32(&self) -> IdentifiedLoop<f32>;
}

impl CastF32 for IdentifiedLoop<f64> {
    fn cast_f32(&self) -> IdentifiedLoop<f32> {
        IdentifiedLoop {
            omega: self.omega.cast(),
            zeta: self.zeta.cast(),
            film_gain: self.film_gain.cast(),
            direct: self.direct as f32,
            feedthrough: self.feedthrough as f32,
        }
    }
}

#[test]
fn the_ppf_rule_spends_its_static_budget_and_tunes_above_the_modes() {
    let id = identified();
    let g = PpfGains::design(&id).unwrap();
    let total: f64 = g.filters.iter().map(|f| f.gain).sum();
    assert!((total * id.static_gain() * ppf::MARGIN - 1.0).abs() < 1e-12);
    // Shared as the modes' static contributions g_j/ω_j².
    let s1 = id.film_gain.x / id.omega.x.powi(2);
    let s2 = id.film_gain.y / id.omega.y.powi(2);
    assert!((g.filters[0].gain / g.filters[1].gain - s1 / s2).abs() < 1e-12);
    for (f, w) in g.filters.iter().zip([id.omega.x, id.omega.y]) {
        assert!((f.freq_hz * std::f64::consts::TAU / w - ppf::TUNING).abs() < 1e-12);
    }
    // The discrete filter keeps the continuous one's DC gain k and its peak k/(2ζ) at ω_f
    // (the prewarped bilinear transform maps ω_f exactly).
    let one = PpfGains {
        filters: [
            PpfFilter {
                gain: 2.0,
                freq_hz: 50.0,
                zeta: 0.3,
            },
            PpfFilter {
                gain: 0.0,
                freq_hz: 200.0,
                zeta: 0.3,
            },
        ],
    };
    let lin = Ppf::new(&one, T, -1.0, 1.0).linear();
    let h = |w: f64| {
        let z = nalgebra::Complex::new((w * T).cos(), (w * T).sin());
        let a = lin.a.map(|x| nalgebra::Complex::new(x, 0.0));
        let m = nalgebra::Matrix4::<nalgebra::Complex<f64>>::identity() * z - a;
        let x = m.try_inverse().unwrap() * lin.b.map(|x| nalgebra::Complex::new(x, 0.0));
        let y = lin.c.map(|x| nalgebra::Complex::new(x, 0.0)).dot(&x) + lin.d;
        y.re.hypot(y.im)
    };
    assert!((h(0.0) - 2.0).abs() < 1e-9, "{}", h(0.0));
    let peak = h(std::f64::consts::TAU * 50.0);
    assert!((peak - 2.0 / 0.6).abs() < 1e-6, "{peak}");
    // A loop the rule cannot serve: a mode with a negative film gain (a reversed film).
    let mut bad = id;
    bad.film_gain.y = -1.0;
    assert!(PpfGains::design(&bad).is_none() && IrcGains::design(&bad).is_none());
    bad = id;
    bad.omega.x = f64::NAN;
    assert!(PpfGains::design(&bad).is_none());
}

#[test]
fn the_irc_rule_adds_a_feedthrough_beyond_the_static_gain_and_integrates() {
    let id = identified();
    let g = IrcGains::design(&id).unwrap();
    assert!((g.feedthrough + 2.5 * id.static_gain()).abs() < 1e-15);
    assert!(
        g.feedthrough + id.static_gain() < 0.0,
        "zeros below the poles"
    );
    assert!((g.gamma * (id.direct + g.feedthrough).abs() - id.omega.x).abs() < 1e-9);
    // Without leak and added feedthrough it is an integrator: a constant film voltage ramps.
    let mut i = Irc::new(
        &IrcGains {
            gamma: 100.0,
            feedthrough: 0.0,
            leak_hz: 0.0,
        },
        T,
        -200.0,
        200.0,
    );
    let mut u = 0.0;
    for _ in 0..1000 {
        u = i.step(0.5);
    }
    assert!((u - 1000.0 * 100.0 * T * 0.5).abs() < 1e-9, "{u}");
    assert!(!Irc::new(&IrcGains { gamma: -1.0, ..g }, T, -200.0, 200.0).is_valid());
}

/// The controller runs the law it was given (`Controller::design_piezo`, issue 35): the PPF law's
/// command exactly, the same film checks and safe state as the rate law (disarmed 0 V, a sample
/// out of range or not finite latches its fault and 0 V), and a law its rule refuses leaves
/// none running with `InvalidConfig` latched.
#[test]
fn the_controller_runs_the_selected_law_with_the_same_checks() {
    use flexarm_core::Fault;
    use flexarm_core::control::motor::MotorLaw;
    use flexarm_core::control::select::{PiezoLawKind, PiezoSelect, PiezoSetup, identified_loop};
    use flexarm_core::controller::Controller;
    use flexarm_core::observer_gains::{GAIN_1KHZ, gain};
    use flexarm_core::trajectory::JointTrajectory;
    let fresh = || {
        Controller::<f32>::paper(
            MotorLaw::Tracking,
            JointTrajectory::Hold(Vector2::zeros()),
            1e-4,
            1e-3,
            gain(&GAIN_1KHZ),
        )
    };
    let mut c = fresh();
    let two_modes = -identified_loop(&c.motor.model.params.modes, &c.patch, 0.0, 0.0).direct;
    let setup = PiezoSetup {
        law: PiezoLawKind::Ppf,
        rate: PiezoGains::default(),
        film_static: two_modes,
        film_feedthrough: 0.0,
    };
    assert_eq!(c.design_piezo(&setup, 1e-4), Ok(()));
    assert_eq!(c.selected(), PiezoLawKind::Ppf);
    let l = &c.motor.limits;
    let mut law = PiezoSelect::design(
        &setup,
        &c.motor.model.params.modes,
        &c.patch,
        1e-4,
        l.v_a_min,
        l.v_a_max,
    )
    .unwrap();
    for k in 0..200 {
        let v_f = 0.01 * (k as f32 * 0.1).sin();
        assert_eq!(c.piezo_step(v_f), law.step(v_f), "step {k}");
    }
    // Disarmed: 0 V and no fault; armed again, the law starts at rest.
    c.set_armed(false);
    assert_eq!(c.piezo_step(0.5), 0.0);
    c.set_armed(true);
    law.reset();
    assert_eq!(c.piezo_step(0.5), law.step(0.5));
    // Out of range, then not finite: the fault and 0 V.
    let mut d = c;
    assert_eq!(d.piezo_step(1e6), 0.0);
    assert_eq!(d.fault(), Some(Fault::OutOfRange));
    assert_eq!(c.piezo_step(f32::NAN), 0.0);
    assert_eq!(c.fault(), Some(Fault::NonFinite));
    // Off: 0 V, no fault.
    let mut off = fresh();
    let setup_off = PiezoSetup {
        law: PiezoLawKind::Off,
        ..setup
    };
    assert_eq!(off.design_piezo(&setup_off, 1e-4), Ok(()));
    assert_eq!(off.piezo_step(0.5), 0.0);
    assert_eq!(off.fault(), None);
    // Refused by its rule (the static gain not measured): none runs, InvalidConfig.
    let mut bad = fresh();
    let unmeasured = PiezoSetup {
        film_static: 0.0,
        ..setup
    };
    assert!(bad.design_piezo(&unmeasured, 1e-4).is_err());
    assert_eq!(bad.selected(), PiezoLawKind::Off);
    assert_eq!(bad.fault(), Some(Fault::InvalidConfig));
    assert_eq!(bad.piezo_step(0.5), 0.0);
}
