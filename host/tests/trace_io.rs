//! A trace's indices computed afterwards (`sim::summarize`, what `flexarm compare` runs on a
//! recording) equal those the simulator computes as it runs; a trace's CSV reads back what was
//! written, and a damaged one is refused naming the file, the line and the column.

use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
use flexarm_host::output::{read_csv, write_csv};
use flexarm_host::sim::{SimConfig, simulate, summarize};
use flexarm_host::study::{Case, Outcome};

fn paper_run() -> (flexarm_host::sim::Summary, Vec<flexarm_host::sim::Sample>) {
    let cfg = SimConfig::default();
    simulate(&cfg, &JointTrajectory::Trapezoid(Trapezoid::paper()), true).unwrap()
}

#[test]
fn a_traces_indices_are_the_simulators() {
    let (sum, trace) = paper_run();
    let again = summarize(&trace, SimConfig::default().tail_window);
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(1e-12);
    for (a, b) in [
        (sum.l2_error, again.l2_error),
        (sum.l2_delta, again.l2_delta),
        (sum.l2_tip, again.l2_tip),
        (sum.tail_error_abs[0], again.tail_error_abs[0]),
        (sum.tail_error_abs[1], again.tail_error_abs[1]),
        (sum.tail_delta_abs[0], again.tail_delta_abs[0]),
        (sum.tail_delta_abs[1], again.tail_delta_abs[1]),
        (sum.max_error, again.max_error),
        (sum.max_tip, again.max_tip),
        (sum.max_v_a, again.max_v_a),
    ] {
        assert!(close(a, b), "{a} against {b}");
    }
}

#[test]
fn a_trace_csv_reads_back_and_a_damaged_one_is_named() {
    let (summary, trace) = paper_run();
    let dir = std::env::temp_dir().join(format!("flexarm-trace-io-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let o = Outcome {
        case: Case {
            scenario: "trace",
            controller: "io",
            config: SimConfig::default(),
            trajectory: JointTrajectory::Trapezoid(Trapezoid::paper()),
        },
        summary,
        trace,
    };
    write_csv(&dir, &o).unwrap();
    let path = dir.join("trace_io.csv");
    let back = read_csv(&path).unwrap();
    assert_eq!(back.len(), o.trace.len());
    for (a, b) in back.iter().zip(&o.trace) {
        // Written with 8 significant digits.
        assert!((a.x.q - b.x.q).abs().max() <= 1e-7 * b.x.q.abs().max().max(1e-3));
        assert!((a.tau - b.tau).abs().max() <= 1e-7 * b.tau.abs().max().max(1e-3));
    }
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    lines[3] = lines[3].replacen(',', ",x", 2);
    std::fs::write(&path, lines.join("\n")).unwrap();
    let e = read_csv(&path).unwrap_err();
    assert!(
        e.contains("trace_io.csv:4: theta") && e.contains("not a number"),
        "{e}"
    );
    std::fs::write(&path, "t,x\n1,2\n").unwrap();
    let e = read_csv(&path).unwrap_err();
    assert!(e.contains("trace_io.csv:1: not a flexarm trace"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A waypoint path simulated segment by segment, as the drive runs it
/// (`Drive::path_segments`, `simulate_segments`): the reference passes through every waypoint at
/// its time, has no jump where segments meet, and the arm follows.
#[test]
fn a_huge_trace_is_refused_with_its_size_before_it_is_read() {
    use flexarm_host::output::MAX_TRACE_BYTES;
    let dir = std::env::temp_dir().join(format!("flexarm-trace-huge-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("huge.csv");
    // A sparse file one byte over the bound: nothing of it is read.
    let f = std::fs::File::create(&path).unwrap();
    f.set_len(MAX_TRACE_BYTES + 1).unwrap();
    let e = read_csv(&path).unwrap_err();
    assert!(
        e.contains("huge.csv: 300.0 MB: a trace is read up to 300 MB (1000000 samples)"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_path_runs_segment_by_segment_through_its_waypoints() {
    use flexarm_core::Vector2;
    use flexarm_core::control::motor::MotorLaw;
    use flexarm_core::controller::Controller;
    use flexarm_core::drive::{Drive, MoveLimits, Waypoint};
    use flexarm_core::observer_gains::{GAIN_1KHZ, gain};
    use flexarm_core::time::Ticks;
    use flexarm_host::sim::simulate_segments;
    let mut ctrl = Controller::<f32>::paper(
        MotorLaw::Tracking,
        JointTrajectory::Hold(Vector2::zeros()),
        1e-4,
        1e-3,
        gain(&GAIN_1KHZ),
    );
    let mut drive = Drive::new(&mut ctrl, 1000, Ticks(0), MoveLimits::default());
    let points = [(0.3, 0.2, 1.0), (0.5, -0.1, 1.0), (0.2, 0.0, 1.5)].map(|(a, b, dt)| Waypoint {
        theta: Vector2::new(a, b),
        dt,
    });
    drive.load_waypoints(&ctrl, 0, &points).unwrap();
    let mut start = 0.0;
    let segments: Vec<_> = drive
        .path_segments(Vector2::zeros(), points.len())
        .map(|c| {
            let s = (start, JointTrajectory::Cubic(c));
            start += f64::from(c.duration);
            s
        })
        .collect();
    let cfg = SimConfig {
        duration: 4.0,
        ..SimConfig::default()
    };
    let (summary, trace) = simulate_segments(&cfg, &segments, true).unwrap();
    let mut at = 0.0;
    for w in &points {
        at += f64::from(w.dt);
        let s = trace
            .iter()
            .min_by(|a, b| (a.t - at).abs().total_cmp(&(b.t - at).abs()))
            .unwrap();
        let gap = (s.q_d - w.theta.cast::<f64>()).abs().max();
        assert!(
            gap < 1e-5,
            "at {at} s the reference is {gap:.1e} rad from its waypoint"
        );
    }
    // Continuous: no step of the reference larger than the path's speed allows in a period.
    let jump = trace
        .windows(2)
        .map(|w| (w[1].q_d - w[0].q_d).abs().max())
        .fold(0.0, f64::max);
    assert!(jump < 2e-3, "largest reference step {jump:.1e} rad");
    assert!(summary.max_error < 5e-3, "{}", summary.max_error);
}
