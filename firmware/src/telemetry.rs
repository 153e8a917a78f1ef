//! Telemetry records, queued by the motor loop for the lowest-priority task, which prints them
//! (defmt, ten a second) and streams them on the command link (at the host's decimation).

use flexarm_core::Fault;

/// One telemetry record.
#[derive(Clone, Copy, Debug)]
pub enum Record {
    /// A periodic sample of the motor loop.
    Sample {
        /// Motor periods since boot (`flexarm_core::time`): full resolution after any uptime.
        tick: u64,
        /// Time since the move started [s], from the integer tick difference.
        t: f32,
        /// Joint tracking errors θ − θ_d [rad].
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
        /// Printed with defmt (every `config::TELEMETRY_EVERY`-th period).
        print: bool,
        /// Streamed on the link (every `link::STREAM_EVERY`-th period while subscribed).
        stream: bool,
    },
    /// The controller latched a fault.
    Fault {
        /// Motor periods since boot.
        tick: u64,
        /// Time since the move started [s].
        t: f32,
        /// The cause.
        fault: Fault,
    },
}

/// Capacity of the queue (records): 64 motor periods of a stream at decimation 1.
pub const CAPACITY: usize = 64;
/// The queue between the control loops and the telemetry task.
pub type Queue = heapless::spsc::Queue<Record, CAPACITY>;

/// Prints one record with defmt.
pub fn print(r: &Record) {
    match *r {
        Record::Sample {
            tick,
            t,
            error,
            delta,
            tau,
            v_a,
            ..
        } => defmt::info!(
            "tick={=u64} t={=f32} s err=({=f32},{=f32}) rad delta=({=f32},{=f32}) tau=({=f32},{=f32}) N*m V_a={=f32} V",
            tick,
            t,
            error[0],
            error[1],
            delta[0],
            delta[1],
            tau[0],
            tau[1],
            v_a
        ),
        Record::Fault { tick, t, fault } => defmt::error!(
            "tick={=u64} t={=f32} s FAULT: {=str}",
            tick,
            t,
            fault.as_str()
        ),
    }
}
