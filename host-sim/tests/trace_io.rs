//! A trace's indices computed afterwards (`sim::summarize`, what `flexarm compare` runs on a
//! recording) equal those the simulator computes as it runs; a trace's CSV reads back what was
//! written, and a damaged one is refused naming the file, the line and the column.

use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
use flexarm_sim::output::{read_csv, write_csv};
use flexarm_sim::sim::{SimConfig, simulate, summarize};
use flexarm_sim::study::{Case, Outcome};

fn paper_run() -> (flexarm_sim::sim::Summary, Vec<flexarm_sim::sim::Sample>) {
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
