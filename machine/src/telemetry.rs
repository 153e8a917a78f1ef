//! The telemetry record: what the motor loop queues for the lowest-priority task, which prints
//! it (ten a second) and streams it on the command link (at the host's decimation, as the
//! channels the host subscribed to: [`values`], `crate::session::Session::telemetry`).
//!
//! Units as in the link (`flexarm_link::msg::Channels`): rad, √kg·m, N·m, V; ticks in motor
//! periods (`flexarm_core::time`).

use flexarm_core::Fault;
use flexarm_link::msg::{Channels, MAX_CHANNELS};

/// One telemetry record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Record {
    /// A sample of the motor loop.
    Sample {
        /// Motor periods since boot: full resolution after any uptime.
        tick: u64,
        /// Move time [s] (`crate::period::Period::t`): since the start of the drive's move,
        /// stop, search or hold, from the integer tick difference (not uptime).
        t: f32,
        /// Joint tracking errors θ̂ − θ_d [rad].
        error: [f32; 2],
        /// Estimated joint angles θ̂ [rad].
        theta: [f32; 2],
        /// Estimated modal coordinates δ̂ [√kg·m].
        delta: [f32; 2],
        /// Motor torques applied [N·m].
        tau: [f32; 2],
        /// Piezo command [V].
        v_a: f32,
        /// Film voltage [V].
        v_f: f32,
        /// The brake output after the period: `true` engaged (the amplifiers cut).
        brake: bool,
        /// Printed to the log (every `BoardConfig::print_every`-th period).
        print: bool,
        /// Streamed on the link (every `Control::stream_every`-th period while subscribed).
        stream: bool,
    },
    /// The controller latched a fault.
    Fault {
        /// Motor periods since boot.
        tick: u64,
        /// Move time [s], as a sample's.
        t: f32,
        /// The cause.
        fault: Fault,
    },
}

/// The values of `channels` in a sample, in the link's order (`Channels`), with the loops'
/// loads `loads` [fraction of their periods] for the load channel.
pub fn values(r: &Record, channels: Channels, loads: [f32; 2]) -> heapless::Vec<f32, MAX_CHANNELS> {
    let mut values = heapless::Vec::new();
    let Record::Sample {
        error,
        theta,
        delta,
        tau,
        v_a,
        v_f,
        ..
    } = *r
    else {
        return values;
    };
    let c = channels.0;
    for (bit, v) in [
        (Channels::ERROR, &error[..]),
        (Channels::THETA, &theta[..]),
        (Channels::DELTA, &delta[..]),
        (Channels::TAU, &tau[..]),
        (Channels::V_A, &[v_a][..]),
        (Channels::V_F, &[v_f][..]),
        (Channels::LOAD, &loads[..]),
    ] {
        if c & bit != 0 {
            let _ = values.extend_from_slice(v);
        }
    }
    values
}
