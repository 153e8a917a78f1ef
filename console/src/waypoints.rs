//! A waypoint file: CSV, a header `theta1,theta2,dt` then one waypoint a line, θ1 and θ2 [rad]
//! in the core's joint frames and `dt` [s] the time from the previous waypoint (from the held
//! pose, for the first). Blank lines and lines starting with `#` are skipped. An error names the
//! file, the line and the column. Besides the format, the file is checked against the drive's
//! rules that do not depend on where the arm holds ([`crate::check::path`]): every point within
//! the joint ranges, every `dt` at least a motor period, no mean speed above the limit.

use flexarm_core::drive::MAX_WAYPOINTS;
use flexarm_link::msg::Waypoint;

use crate::client::ConsoleError;

/// The columns, in order.
const COLUMNS: [&str; 3] = ["theta1", "theta2", "dt"];

/// The waypoints of the file `path`.
pub fn read(path: &str) -> Result<Vec<Waypoint>, ConsoleError> {
    let text =
        std::fs::read_to_string(path).map_err(|e| ConsoleError::Usage(format!("{path}: {e}")))?;
    parse(path, &text)
}

/// The waypoints of `text`, read from `path` (for the errors).
pub fn parse(path: &str, text: &str) -> Result<Vec<Waypoint>, ConsoleError> {
    let bad = |line: usize, what: String| ConsoleError::Usage(format!("{path}:{line}: {what}"));
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let Some((n, header)) = lines.next() else {
        return Err(bad(
            1,
            "no header: the file starts with `theta1,theta2,dt`".into(),
        ));
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    if names != COLUMNS {
        return Err(bad(
            n,
            format!("the header is `{header}`, not `theta1,theta2,dt`"),
        ));
    }
    let mut out = Vec::new();
    let mut at = Vec::new();
    for (n, line) in lines {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != COLUMNS.len() {
            return Err(bad(
                n,
                format!("{} values, not 3 (theta1, theta2, dt)", cells.len()),
            ));
        }
        let mut v = [0f32; 3];
        for ((slot, cell), name) in v.iter_mut().zip(&cells).zip(COLUMNS) {
            *slot = cell
                .parse::<f32>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    bad(
                        n,
                        format!("column `{name}`: `{cell}` is not a finite number"),
                    )
                })?;
        }
        if v[2] <= 0.0 {
            return Err(bad(n, format!("column `dt`: {} s, not positive", v[2])));
        }
        if out.len() == MAX_WAYPOINTS {
            return Err(bad(
                n,
                format!("more than {MAX_WAYPOINTS} waypoints, the firmware's list"),
            ));
        }
        out.push(Waypoint {
            theta: [v[0], v[1]],
            dt: v[2],
        });
        at.push(n);
    }
    if out.is_empty() {
        return Err(bad(n, "a header and no waypoint".into()));
    }
    crate::check::path(&out).map_err(|(i, why)| bad(at.get(i).copied().unwrap_or(n), why))?;
    Ok(out)
}

/// Uploads `points` to the drive in chunks of a frame's worth (`Command::Waypoints`).
pub fn upload(c: &mut crate::client::Client, points: &[Waypoint]) -> Result<(), ConsoleError> {
    use flexarm_link::msg::WAYPOINTS_PER_CHUNK;
    for (k, chunk) in points.chunks(WAYPOINTS_PER_CHUNK).enumerate() {
        let first = k * WAYPOINTS_PER_CHUNK;
        let command = flexarm_link::Command::Waypoints {
            first: first as u16,
            points: heapless::Vec::from_slice(chunk)
                .map_err(|_| ConsoleError::Usage("a chunk larger than a frame holds".into()))?,
        };
        c.done(&format!("waypoints {first}…"), command)?;
    }
    Ok(())
}
