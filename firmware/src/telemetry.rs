//! The queue of telemetry records (`flexarm_machine::Record`) from the motor loop to the
//! lowest-priority task, which prints them (defmt, ten a second) and streams them on the
//! command link (at the host's decimation).

pub use flexarm_machine::Record;

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
