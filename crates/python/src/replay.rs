//! A whole trajectory through the engine, as `haptic6d run` replays it: the engine is reset at
//! the first row's pose, then one [`engine::Engine::step`] per row on the loop's clock
//! (`frame / rate_hz` s for the safety layer), through the command line's own frame loop
//! ([`scene::rt::run_frames`], not paced). The frames come back as the columns of
//! `frames.csv`.

use collide::Pose;
use engine::Engine;
use scene::device::ReplayDevice;
use scene::report::FRAMES_HEADER;
use scene::rt::{run_frames, FrameRecord, LoopParams, Pacing};
use scene::trajectory::{TrajSample, Trajectory, TRAJECTORY_HEADER};

use crate::options::check_pose;
use crate::Failure;

/// One column of the replay, by its `frames.csv` type.
#[derive(Clone, Debug, PartialEq)]
pub enum Column {
    /// Real values (times s, poses mm and rad, wrench N and N·mm, timings µs, depth mm).
    Real(Vec<f64>),
    /// Counts (pairs, iterations, passes, splits, scanned).
    Count(Vec<i64>),
    /// The frame status names (`ok`, `lagging`, ...).
    Status(Vec<&'static str>),
}

/// The column names, as in `frames.csv`'s header.
pub fn column_names() -> impl Iterator<Item = &'static str> {
    FRAMES_HEADER.split(',')
}

/// A trajectory from a row-major `N × 7` array (`t,x,y,z,gamma,beta,alpha`: s, mm, rad),
/// checked as a trajectory file is: at least one row, every value finite, time never going
/// backwards, poses within the accepted range.
pub fn trajectory_from_rows(values: &[f64]) -> Result<Trajectory, Failure> {
    if values.is_empty() || !values.chunks_exact(7).remainder().is_empty() {
        return Err(Failure::value(format!(
            "trajectory: {} values; expected an array of shape (N, 7) with N >= 1 ({TRAJECTORY_HEADER})",
            values.len()
        )));
    }
    let rows = values.len() / 7;
    engine::config::MAX_FRAMES
        .check_as("trajectory rows", rows as u64)
        .map_err(|e| Failure::value(e.to_string()))?;
    let names: Vec<&str> = TRAJECTORY_HEADER.split(',').collect();
    let mut samples = Vec::with_capacity(rows);
    let mut last_t = f64::NEG_INFINITY;
    for (i, row) in values.chunks_exact(7).enumerate() {
        if let Some(k) = row.iter().position(|v| !v.is_finite()) {
            return Err(Failure::value(format!(
                "trajectory row {i}: {} = {} is not finite",
                names[k], row[k]
            )));
        }
        if row[0] < last_t {
            return Err(Failure::value(format!(
                "trajectory row {i}: time {} goes backwards (previous {last_t}); sort the rows by t",
                row[0]
            )));
        }
        last_t = row[0];
        let q = [row[1], row[2], row[3], row[4], row[5], row[6]];
        check_pose(&format!("trajectory row {i}"), &q)?;
        samples.push(TrajSample { t: row[0], q });
    }
    Ok(Trajectory { samples })
}

/// Replays `trajectory` into `engine` as `haptic6d run` does (reset at the first row, then one
/// step per row at `rate_hz` on the loop's clock, not paced) and returns every frame. `label`
/// names the engine in errors (the scene name).
pub fn replay(
    engine: &mut Engine,
    trajectory: Trajectory,
    rate_hz: f64,
    label: &str,
) -> Result<Vec<FrameRecord>, Failure> {
    let first = trajectory
        .samples
        .first()
        .map(|s| Pose::from_array(s.q))
        .ok_or_else(|| Failure::value("trajectory: no rows"))?;
    engine.reset(&first).map_err(|source| {
        Failure::from(scene::SceneError::Engine {
            file: label.to_string(),
            source,
        })
    })?;
    let params = LoopParams {
        pacing: Pacing {
            rate_hz,
            ..Pacing::default()
        },
        ..LoopParams::default()
    };
    params
        .validate()
        .map_err(|e| Failure::value(e.to_string()))?;
    let mut records = Vec::with_capacity(trajectory.len());
    let mut device = ReplayDevice::new(trajectory);
    run_frames(engine, &mut device, &params, &mut records);
    Ok(records)
}

/// The frames as the columns of `frames.csv`, in its order (force and torque: the wrench
/// sent, after the safety layer).
pub fn columns(records: &[FrameRecord]) -> Vec<(&'static str, Column)> {
    let real = |f: &dyn Fn(&FrameRecord) -> f64| Column::Real(records.iter().map(f).collect());
    let count = |f: &dyn Fn(&FrameRecord) -> u32| {
        Column::Count(records.iter().map(|r| i64::from(f(r))).collect())
    };
    column_names()
        .enumerate()
        .map(|(i, name)| {
            let col = match i {
                0 => real(&|r| r.t),
                1..=6 => real(&|r| r.frame.q_h[i - 1]),
                7..=12 => real(&|r| r.frame.q_g[i - 7]),
                13..=18 => real(&|r| r.frame.wrench[i - 13]),
                19 => count(&|r| r.frame.pairs),
                20 => real(&|r| r.frame.cd_us),
                21 => real(&|r| r.frame.opt_us),
                22 => real(&|r| r.frame.total_us),
                23 => count(&|r| r.frame.iterations),
                24 => real(&|r| r.frame.penetration_mm),
                25 => count(&|r| r.frame.passes),
                26 => Column::Status(records.iter().map(|r| r.frame.status.name()).collect()),
                27 => count(&|r| r.frame.splits),
                28 => count(&|r| r.frame.scanned),
                _ => real(&|r| r.frame.ahead_us),
            };
            (name, col)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use engine::EngineConfig;
    use scene::report::frames_csv;
    use spheretree::{Sphere, SphereTree};

    fn engine() -> Engine {
        let tool = SphereTree::from_slots(1, 2, vec![Sphere::new([0.0; 3], 5.0)]).unwrap();
        let object = SphereTree::from_slots(1, 2, vec![Sphere::new([0.0; 3], 20.0)]).unwrap();
        Engine::new(
            &tool,
            &[(object, Pose::identity())],
            EngineConfig::default(),
        )
        .unwrap()
    }

    /// The hand moves down through the sphere; the tool rests on it.
    fn press() -> Vec<f64> {
        (0..200)
            .flat_map(|i| {
                let t = i as f64 * 1e-3;
                [t, 0.0, 0.0, 40.0 - 0.3 * i as f64, 0.0, 0.0, 0.0]
            })
            .collect()
    }

    #[test]
    fn columns_hold_the_frames_csv_values() {
        let traj = trajectory_from_rows(&press()).unwrap();
        let records = replay(&mut engine(), traj, 1000.0, "test").unwrap();
        assert_eq!(records.len(), 200);
        let csv = frames_csv(&records);
        let cols = columns(&records);
        assert_eq!(
            cols.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(","),
            FRAMES_HEADER
        );
        for (row, line) in csv.lines().skip(1).enumerate() {
            for (k, field) in line.split(',').enumerate() {
                let shown = match &cols[k].1 {
                    // The times, printed to the nanosecond.
                    Column::Real(v) if cols[k].0.ends_with("_us") => format!("{:.3}", v[row]),
                    Column::Real(v) => format!("{}", v[row]),
                    Column::Count(v) => format!("{}", v[row]),
                    Column::Status(v) => v[row].to_string(),
                };
                assert_eq!(shown, field, "row {row} column {}", cols[k].0);
            }
        }
        // The tool came to rest on the object (5 + 20 mm) and was pushed back up.
        let Column::Real(zg) = &cols[9].1 else {
            panic!("zg is real")
        };
        assert!(zg.last().unwrap() >= &(25.0 - 0.01));
    }

    #[test]
    fn a_replay_equals_the_command_line_loop() {
        let rows = press();
        let mut a = engine();
        let ours = replay(&mut a, trajectory_from_rows(&rows).unwrap(), 1000.0, "t").unwrap();
        let mut b = engine();
        let traj = trajectory_from_rows(&rows).unwrap();
        b.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
        let mut device = ReplayDevice::new(traj);
        let theirs = scene::rt::run_loop(&mut b, &mut device, &LoopParams::default()).unwrap();
        let strip = |r: &FrameRecord| {
            let mut f = r.frame;
            (f.cd_us, f.opt_us, f.total_us, f.ahead_us) = (0.0, 0.0, 0.0, 0.0);
            (r.t, f)
        };
        let x: Vec<_> = ours.iter().map(strip).collect();
        let y: Vec<_> = theirs.frames.iter().map(strip).collect();
        assert_eq!(x, y);
    }

    #[test]
    fn bad_rows_are_refused_with_their_index() {
        let mut rows = press();
        rows[7 * 3 + 2] = f64::NAN;
        let e = trajectory_from_rows(&rows).unwrap_err();
        assert_eq!(e.message, "trajectory row 3: y = NaN is not finite");
        let mut rows = press();
        rows[7 * 5] = -1.0;
        let e = trajectory_from_rows(&rows).unwrap_err().message;
        assert!(
            e.starts_with("trajectory row 5: time -1 goes backwards"),
            "{e}"
        );
        let e = trajectory_from_rows(&[0.0; 6]).unwrap_err().message;
        assert!(e.contains("shape (N, 7)"), "{e}");
        let e = trajectory_from_rows(&[]).unwrap_err().message;
        assert!(e.contains("shape (N, 7)"), "{e}");
        let mut rows = press();
        rows[1] = 1e12;
        let e = trajectory_from_rows(&rows).unwrap_err().message;
        assert!(e.starts_with("trajectory row 0 = "), "{e}");
    }
}
