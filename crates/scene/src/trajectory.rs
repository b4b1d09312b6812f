//! Device trajectories: the `t,x,y,z,gamma,beta,alpha` CSV (read with errors naming file and
//! line, written atomically) and keyframe scripts sampled at the haptic rate.

use std::fmt::Write as _;
use std::path::Path;

use crate::SceneError;

/// The header every trajectory CSV starts with.
pub const TRAJECTORY_HEADER: &str = "t,x,y,z,gamma,beta,alpha";

/// One device sample: time (s) and configuration `[x, y, z, gamma, beta, alpha]` (mm, rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrajSample {
    /// Time since the start, s.
    pub t: f64,
    /// Configuration (mm, mm, mm, rad, rad, rad).
    pub q: [f64; 6],
}

/// A device trajectory: one sample per haptic frame, times non-decreasing.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trajectory {
    /// The samples, in order.
    pub samples: Vec<TrajSample>,
}

impl Trajectory {
    /// Number of samples (frames).
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// True when there is no sample.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Duration from the first to the last sample, s.
    pub fn duration(&self) -> f64 {
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) => b.t - a.t,
            _ => 0.0,
        }
    }

    /// Parses the CSV text; `source` names the file in errors.
    pub fn parse_csv(text: &str, source: &str) -> Result<Self, SceneError> {
        let err = |line: usize, msg: String| SceneError::Trajectory {
            file: source.to_string(),
            line,
            msg,
        };
        // A byte-order mark is not part of the header (and shifts no line).
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut lines = text.lines().enumerate();
        let header = loop {
            match lines.next() {
                Some((_, l)) if l.trim().is_empty() => continue,
                Some((i, l)) => break (i + 1, l),
                None => {
                    return Err(err(
                        1,
                        format!("the file is empty; expected the header `{TRAJECTORY_HEADER}`"),
                    ))
                }
            }
        };
        let cols: Vec<String> = header
            .1
            .split(',')
            .map(|c| c.trim().to_ascii_lowercase())
            .collect();
        if cols.join(",") != TRAJECTORY_HEADER {
            return Err(err(
                header.0,
                format!(
                    "bad header `{}`; expected exactly `{TRAJECTORY_HEADER}`",
                    header.1.trim()
                ),
            ));
        }
        let mut samples = Vec::new();
        let mut last_t = f64::NEG_INFINITY;
        for (i, line) in lines {
            let lineno = i + 1;
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let mut v = [0.0f64; 7];
            let mut n = 0;
            for field in line.split(',') {
                if n == 7 {
                    return Err(err(
                        lineno,
                        "more than 7 fields; expected t,x,y,z,gamma,beta,alpha".into(),
                    ));
                }
                v[n] = field.trim().parse::<f64>().map_err(|_| {
                    err(
                        lineno,
                        format!(
                            "field {} (`{}`) is not a number",
                            TRAJECTORY_HEADER.split(',').nth(n).unwrap_or("?"),
                            field.trim()
                        ),
                    )
                })?;
                if !v[n].is_finite() {
                    return Err(err(lineno, format!("field {} is not finite", n + 1)));
                }
                n += 1;
            }
            if n != 7 {
                return Err(err(
                    lineno,
                    format!("{n} fields; expected 7 (t,x,y,z,gamma,beta,alpha)"),
                ));
            }
            if v[0] < last_t {
                return Err(err(
                    lineno,
                    format!(
                        "time {} goes backwards (previous {last_t}); sort the rows by t",
                        v[0]
                    ),
                ));
            }
            last_t = v[0];
            samples.push(TrajSample {
                t: v[0],
                q: [v[1], v[2], v[3], v[4], v[5], v[6]],
            });
        }
        if samples.is_empty() {
            return Err(err(header.0, "no data rows after the header".into()));
        }
        Ok(Self { samples })
    }

    /// Reads a trajectory CSV file.
    pub fn read_csv(path: &Path) -> Result<Self, SceneError> {
        // Bounded read (a device node or a huge file is refused, not read until memory runs
        // out): 1 GiB is about 10 hours of frames at 1 kHz.
        let io = |source: std::io::Error| SceneError::Io {
            path: path.display().to_string(),
            source,
        };
        let bytes = mesh::read_input(path, 1 << 30).map_err(io)?;
        let text = String::from_utf8(bytes).map_err(|_| {
            io(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                "not UTF-8 text; expected a CSV file",
            ))
        })?;
        Self::parse_csv(&text, &path.display().to_string())
    }

    /// The CSV text (header + one row per sample, full precision).
    pub fn to_csv_string(&self) -> String {
        let mut s = String::with_capacity(64 * (self.samples.len() + 1));
        s.push_str(TRAJECTORY_HEADER);
        s.push('\n');
        for smp in &self.samples {
            let q = smp.q;
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{}",
                smp.t, q[0], q[1], q[2], q[3], q[4], q[5]
            );
        }
        s
    }

    /// Writes the CSV atomically (temp file in the same directory, then rename).
    pub fn write_csv(&self, path: &Path) -> Result<(), SceneError> {
        crate::io::write_atomic(path, self.to_csv_string().as_bytes())
    }
}

/// How a script moves between two keyframes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ease {
    /// Constant velocity.
    Linear,
    /// Smooth start and stop (`3s^2 - 2s^3`): zero velocity at both keyframes.
    Smooth,
}

/// A keyframe: reach `q` (mm, rad) at time `t` (s), moving from the previous keyframe with `ease`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keyframe {
    /// Time, s.
    pub t: f64,
    /// Configuration (mm, rad).
    pub q: [f64; 6],
    /// Interpolation from the previous keyframe.
    pub ease: Ease,
}

/// A scripted device motion: keyframes interpolated per coordinate.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Script {
    /// Keyframes, times increasing.
    pub keys: Vec<Keyframe>,
}

impl Script {
    /// A script starting at `q0` at `t = 0`.
    pub fn starting_at(q0: [f64; 6]) -> Self {
        Self {
            keys: vec![Keyframe {
                t: 0.0,
                q: q0,
                ease: Ease::Linear,
            }],
        }
    }

    /// Appends a move lasting `duration` s to `q` (mm, rad).
    pub fn then(mut self, duration: f64, q: [f64; 6], ease: Ease) -> Self {
        let t0 = self.keys.last().map_or(0.0, |k| k.t);
        self.keys.push(Keyframe {
            t: t0 + duration.max(0.0),
            q,
            ease,
        });
        self
    }

    /// Appends a pause of `duration` s at the last configuration.
    pub fn hold(self, duration: f64) -> Self {
        let q = self.keys.last().map_or([0.0; 6], |k| k.q);
        self.then(duration, q, Ease::Linear)
    }

    /// The last configuration (mm, rad).
    pub fn last_q(&self) -> [f64; 6] {
        self.keys.last().map_or([0.0; 6], |k| k.q)
    }

    /// Total duration, s.
    pub fn duration(&self) -> f64 {
        self.keys.last().map_or(0.0, |k| k.t)
    }

    /// The configuration at time `t` (s), clamped to the first/last keyframe.
    ///
    /// # Real-time
    /// No allocation, no panic; O(number of keyframes).
    pub fn sample(&self, t: f64) -> [f64; 6] {
        let Some(first) = self.keys.first() else {
            return [0.0; 6];
        };
        if t <= first.t {
            return first.q;
        }
        for w in self.keys.windows(2) {
            let (a, b) = (&w[0], &w[1]);
            if t <= b.t {
                let span = b.t - a.t;
                let s = if span > 0.0 { (t - a.t) / span } else { 1.0 };
                let s = match b.ease {
                    Ease::Linear => s,
                    Ease::Smooth => s * s * (3.0 - 2.0 * s),
                };
                let mut q = [0.0; 6];
                for k in 0..6 {
                    q[k] = a.q[k] + (b.q[k] - a.q[k]) * s;
                }
                return q;
            }
        }
        self.last_q()
    }

    /// Samples the script at `rate_hz` (one sample per haptic frame), from 0 to its end.
    pub fn to_trajectory(&self, rate_hz: f64) -> Trajectory {
        let dt = 1.0 / rate_hz;
        let n = ((self.duration() * rate_hz).round() as usize).saturating_add(1);
        Trajectory {
            samples: (0..n)
                .map(|i| {
                    let t = i as f64 * dt;
                    TrajSample {
                        t,
                        q: self.sample(t),
                    }
                })
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_round_trip() {
        let tr = Script::starting_at([0.0, 1.0, 2.0, 0.0, 0.0, 0.0])
            .then(0.01, [1.0, 1.0, 2.0, 0.1, 0.0, -0.2], Ease::Smooth)
            .to_trajectory(1000.0);
        assert_eq!(tr.len(), 11);
        let back = Trajectory::parse_csv(&tr.to_csv_string(), "mem").unwrap();
        assert_eq!(back, tr);
    }

    #[test]
    fn csv_errors_name_file_and_line() {
        let e = Trajectory::parse_csv("t,x,y,z\n", "a.csv")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("a.csv:1: ") && e.contains("header"), "{e}");
        let text = format!("{TRAJECTORY_HEADER}\n0,0,0,0,0,0,0\n0.001,1,2,x,0,0,0\n");
        let e = Trajectory::parse_csv(&text, "b.csv")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("b.csv:3") && e.contains("`x`") && e.contains("field z"),
            "{e}"
        );
        let text = format!("{TRAJECTORY_HEADER}\n0,0,0,0,0,0\n");
        let e = Trajectory::parse_csv(&text, "c.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("c.csv:2") && e.contains("6 fields"), "{e}");
        let text = format!("{TRAJECTORY_HEADER}\n1,0,0,0,0,0,0\n0.5,0,0,0,0,0,0\n");
        let e = Trajectory::parse_csv(&text, "d.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("d.csv:3") && e.contains("backwards"), "{e}");
        let e = Trajectory::parse_csv("", "e.csv").unwrap_err().to_string();
        assert!(e.contains("empty"), "{e}");
    }

    #[test]
    fn script_interpolates_and_clamps() {
        let s = Script::starting_at([0.0; 6])
            .then(1.0, [10.0, 0.0, 0.0, 0.0, 0.0, 1.0], Ease::Linear)
            .hold(0.5);
        assert_eq!(s.sample(-1.0)[0], 0.0);
        assert!((s.sample(0.5)[0] - 5.0).abs() < 1e-12);
        assert!((s.sample(0.5)[5] - 0.5).abs() < 1e-12);
        assert_eq!(s.sample(1.2)[0], 10.0);
        assert_eq!(s.sample(9.0)[0], 10.0);
        assert!((s.duration() - 1.5).abs() < 1e-12);
    }
}
