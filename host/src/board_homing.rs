//! The `[homing]` table of a firmware-params source (`firmware/piezo.toml`, or an identified
//! `model.toml`): how each joint of the board's arm finds its reference
//! (`flexarm_core::homing`, `docs/safety.md`, "Frames and homing"). `flexarm-sim
//! firmware-params` writes it into both boards' configurations; a source without the table
//! gives `homing::Config::default()` (both joints by their index marks at 0 rad).
//!
//! ```toml
//! [homing]
//! tolerance = 0.01        # a reference seen again this far off its angle trips [rad]
//! stall_travel = 0.002    # end-stop search: a stall stays within this [rad]
//! stall_time = 0.2        # ... for this long [s]
//! stall_share = 0.9       # ... at this share of the search torque
//!
//! [homing.joint1]
//! method = "end_stop"     # "index", "end_stop" or "switch"
//! angle = 3.1             # the reference's angle in the arm's frame [rad]
//! speed = 0.2             # search speed, its sign the direction [rad/s]
//! torque = 1.0            # torque limit while searching [N·m] (capped at the board's)
//! travel = 6.5            # a search that travels this far fails [rad]
//! ```
//!
//! Every key is optional (the default's value). What the drive could not search with is
//! refused with the key's path, which `flexarm_beam::toml_at::at_line` turns into a line.

use flexarm_beam::toml_at::{de_error, outside};
use flexarm_core::homing::{Config, Method};
use flexarm_core::supervisor::SensorLimits;
use serde::Deserialize;

/// The fastest search [rad/s]: a search is a slow approach to a stop or a mark.
pub const SPEED_MAX: f64 = 1.0;

#[derive(Deserialize)]
struct File {
    homing: Option<Table>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Table {
    tolerance: Option<f64>,
    stall_travel: Option<f64>,
    stall_time: Option<f64>,
    stall_share: Option<f64>,
    joint1: Option<Joint>,
    joint2: Option<Joint>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Joint {
    method: Option<MethodName>,
    angle: Option<f64>,
    speed: Option<f64>,
    torque: Option<f64>,
    travel: Option<f64>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
enum MethodName {
    Index,
    EndStop,
    Switch,
}

/// The homing configuration of the source `text` (the default where it says nothing), or one
/// line naming the key that is wrong (`line N: ` first for a syntax or type error).
pub fn read(text: &str) -> Result<Config<f32>, String> {
    let file: File = toml::from_str(text).map_err(|e| de_error(text, &e))?;
    let mut c = Config::<f32>::default();
    let Some(t) = file.homing else {
        return Ok(c);
    };
    let theta_max = SensorLimits::<f32>::default().theta_max;
    for (j, joint) in [t.joint1, t.joint2].into_iter().enumerate() {
        let (Some(joint), Some(out)) = (joint, c.joints.get_mut(j)) else {
            continue;
        };
        let key = |k: &str| format!("homing.joint{}.{k}", j + 1);
        if let Some(m) = joint.method {
            out.method = match m {
                MethodName::Index => Method::Index,
                MethodName::EndStop => Method::EndStop,
                MethodName::Switch => Method::Switch,
            };
        }
        let range = f64::from(theta_max[j]);
        if let Some(v) = joint.angle {
            out.angle = within(&key("angle"), v, -range, range, "rad")?;
        }
        if let Some(v) = joint.speed {
            out.speed = within(&key("speed"), v, -SPEED_MAX, SPEED_MAX, "rad/s")?;
            if out.speed == 0.0 {
                return Err(format!(
                    "`{}`: must not be 0 (its sign is the search's direction)",
                    key("speed")
                ));
            }
        }
        if let Some(v) = joint.torque {
            out.torque = positive(&key("torque"), v)?;
        }
        if let Some(v) = joint.travel {
            out.travel = positive(&key("travel"), v)?;
        }
    }
    for (name, value, field) in [
        ("tolerance", t.tolerance, &mut c.tolerance),
        ("stall_travel", t.stall_travel, &mut c.stall_travel),
        ("stall_time", t.stall_time, &mut c.stall_time),
    ] {
        if let Some(v) = value {
            *field = positive(&format!("homing.{name}"), v)?;
        }
    }
    if let Some(v) = t.stall_share {
        c.stall_share = within("homing.stall_share", v, 0.0, 1.0, "")?;
        if c.stall_share == 0.0 {
            return Err("`homing.stall_share`: must be > 0".into());
        }
    }
    Ok(c)
}

/// `v` in `f32` when it lies in `[lo, hi]`.
fn within(key: &str, v: f64, lo: f64, hi: f64, unit: &str) -> Result<f32, String> {
    if (lo..=hi).contains(&v) {
        Ok(v as f32)
    } else {
        Err(outside(key, v, lo, hi, unit))
    }
}

/// `v` in `f32` when it is finite and > 0 there.
fn positive(key: &str, v: f64) -> Result<f32, String> {
    let x = v as f32;
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(format!("`{key}`: must be a finite number > 0"))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn no_table_is_the_default_and_a_table_sets_what_it_writes() {
        assert_eq!(read("[piezo]\n").unwrap(), Config::default());
        let c = read(
            "[homing]\ntolerance = 0.02\n[homing.joint1]\nmethod = \"end_stop\"\nangle = 3.1\n\
             [homing.joint2]\nmethod = \"switch\"\nspeed = -0.3\n",
        )
        .unwrap();
        assert_eq!(c.tolerance, 0.02);
        assert_eq!(
            (c.joints[0].method, c.joints[0].angle),
            (Method::EndStop, 3.1)
        );
        assert_eq!(
            (c.joints[1].method, c.joints[1].speed),
            (Method::Switch, -0.3)
        );
        // What it does not write stays the default's.
        assert_eq!(c.joints[1].angle, 0.0);
        assert_eq!(
            c.joints[0].travel,
            Config::<f32>::default().joints[0].travel
        );
    }

    #[test]
    fn what_a_search_cannot_run_names_its_key() {
        for (text, key) in [
            (
                "[homing.joint1]\nmethod = \"magnet\"\n",
                "line 2: `homing.joint1.method`",
            ),
            (
                "[homing.joint2]\nspeed = 0.0\n",
                "`homing.joint2.speed`: must not be 0",
            ),
            (
                "[homing.joint2]\nspeed = 5.0\n",
                "`homing.joint2.speed` = 5 rad/s is outside",
            ),
            (
                "[homing.joint2]\nangle = 2.9\n",
                "`homing.joint2.angle` = 2.9 rad is outside",
            ),
            (
                "[homing.joint1]\ntorque = -1.0\n",
                "`homing.joint1.torque`: must be a finite",
            ),
            (
                "[homing.joint1]\ntravel = nan\n",
                "`homing.joint1.travel`: must be a finite",
            ),
            (
                "[homing]\ntolerance = 0.0\n",
                "`homing.tolerance`: must be a finite",
            ),
            (
                "[homing]\nstall_share = 1.5\n",
                "`homing.stall_share` = 1.5 is outside",
            ),
            ("[homing]\nspeed = 0.1\n", "line 2: `homing.speed`"),
            ("[homing.joint3]\n", "line 1: `homing.joint3`"),
        ] {
            let e = read(text).unwrap_err();
            assert!(e.starts_with(key), "{text:?}: {e}");
        }
    }
}
