//! Motor logs, the data `topa sysid fit` matches: one CSV row per sample, `time` and per motor what was commanded
//! and what was measured. Read strictly: a log with gaps, NaN, an unknown column, unsorted time or a motor without
//! its command or position is refused with the row and column, never silently repaired.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{bad_file, ensure_file, Error, Result};

/// What a motor was commanded.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Torque at the output, N·m (the driver's nominal torque constant applied).
    Torque(Vec<f64>),
    /// Phase current, A (the torque constant is then N·m per A at the output).
    Current(Vec<f64>),
    /// Position target of the driver's PD loop, rad, with its gains per sample.
    Position { target: Vec<f64>, kp: Vec<f64>, kd: Vec<f64> },
}

impl Command {
    pub fn kind(&self) -> &'static str {
        match self {
            Command::Torque(_) => "torque",
            Command::Current(_) => "current",
            Command::Position { .. } => "target",
        }
    }
}

/// One motor's columns.
#[derive(Debug, Clone, PartialEq)]
pub struct MotorTrace {
    pub name: String,
    pub command: Command,
    /// Measured position, rad.
    pub position: Vec<f64>,
    /// Measured velocity, rad/s, when logged.
    pub velocity: Option<Vec<f64>>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct MotorLog {
    pub time: Vec<f64>,
    pub motors: Vec<MotorTrace>,
}

const QUANTITIES: [&str; 7] = ["target", "kp", "kd", "torque", "current", "position", "velocity"];

/// A time step this much longer than the median one is a gap.
const GAP_FACTOR: f64 = 1.5;

impl MotorLog {
    pub fn read(path: &Path) -> Result<MotorLog> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            Error::file(format!("cannot read the log {} (give a CSV as docs/sysid.md describes)", path.display()), e)
        })?;
        Self::parse(&text).map_err(|e| Error::file(format!("log {}", path.display()), e))
    }

    pub fn parse(text: &str) -> Result<MotorLog> {
        let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty() && !l.starts_with('#'));
        let (_, header) = lines.next().ok_or_else(|| Error::bad_file("no header row (time,<motor>:<quantity>,…)"))?;
        let columns: Vec<&str> = header.split(',').map(str::trim).collect();
        ensure_file!(columns.first() == Some(&"time"), "the first column must be `time`, not {:?}", columns.first());
        let mut names: Vec<&str> = Vec::new();
        for c in &columns[1..] {
            let (motor, q) = c.split_once(':').ok_or_else(|| {
                Error::bad_file(format!(
                    "column {c:?}: expected <motor>:<quantity> with quantity one of {}",
                    QUANTITIES.join(", ")
                ))
            })?;
            ensure_file!(
                QUANTITIES.contains(&q),
                "column {c:?}: unknown quantity {q:?} (expected one of {})",
                QUANTITIES.join(", ")
            );
            if !names.contains(&motor) {
                names.push(motor);
            }
        }
        for (i, c) in columns.iter().enumerate() {
            ensure_file!(!columns[..i].contains(c), "column {c:?} appears twice");
        }
        let mut data: Vec<Vec<f64>> = vec![Vec::new(); columns.len()];
        for (line_no, line) in lines {
            let fields: Vec<&str> = line.split(',').collect();
            ensure_file!(
                fields.len() == columns.len(),
                "line {}: {} fields, the header has {}",
                line_no + 1,
                fields.len(),
                columns.len()
            );
            for ((f, col), out) in fields.iter().zip(&columns).zip(&mut data) {
                let v: f64 = f.trim().parse().map_err(|e| {
                    Error::file(format!("line {}, column {col}: {:?} is not a number", line_no + 1, f.trim()), e)
                })?;
                ensure_file!(
                    v.is_finite(),
                    "line {}, column {col}: {v} (NaN or infinite samples are not allowed)",
                    line_no + 1
                );
                out.push(v);
            }
        }
        let time = std::mem::take(&mut data[0]);
        ensure_file!(time.len() >= 10, "{} samples: a log needs at least 10", time.len());
        let dts: Vec<f64> = time.windows(2).map(|w| w[1] - w[0]).collect();
        if let Some(i) = dts.iter().position(|&d| d <= 0.0) {
            bad_file!("time is not increasing at t = {} s (sample {}): sort the rows by time", time[i + 1], i + 2);
        }
        let mut sorted = dts.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2];
        if let Some(i) = dts.iter().position(|&d| d > GAP_FACTOR * median) {
            bad_file!(
                "a gap of {:.4} s after t = {} s (the log's step is {median:.4} s): the fit needs evenly sampled data; \
                 split the log at the gap",
                dts[i],
                time[i]
            );
        }
        let col =
            |motor: &str, q: &str| columns.iter().position(|c| *c == format!("{motor}:{q}")).map(|i| data[i].clone());
        let mut motors = Vec::new();
        for name in names {
            let position = col(name, "position")
                .ok_or_else(|| Error::bad_file(format!("motor {name}: no `{name}:position` column (measured, rad)")))?;
            let commands: Vec<&str> =
                ["target", "torque", "current"].into_iter().filter(|q| col(name, q).is_some()).collect();
            ensure_file!(
                commands.len() == 1,
                "motor {name}: {} command columns ({}); give exactly one of {name}:target (with :kp and :kd), \
                 {name}:torque or {name}:current",
                commands.len(),
                commands.join(", ")
            );
            let command = match commands[0] {
                "target" => Command::Position {
                    target: col(name, "target").unwrap(),
                    kp: col(name, "kp")
                        .ok_or_else(|| Error::bad_file(format!("motor {name}: a position target needs {name}:kp")))?,
                    kd: col(name, "kd")
                        .ok_or_else(|| Error::bad_file(format!("motor {name}: a position target needs {name}:kd")))?,
                },
                "torque" => Command::Torque(col(name, "torque").unwrap()),
                _ => Command::Current(col(name, "current").unwrap()),
            };
            if !matches!(command, Command::Position { .. }) {
                ensure_file!(
                    col(name, "kp").is_none() && col(name, "kd").is_none(),
                    "motor {name}: kp/kd columns belong to a position target, and this motor logs its {}",
                    command.kind()
                );
            }
            motors.push(MotorTrace { name: name.to_string(), command, position, velocity: col(name, "velocity") });
        }
        ensure_file!(!motors.is_empty(), "no motor columns after `time`");
        Ok(MotorLog { time, motors })
    }

    /// The log as CSV, in the format `parse` reads (every value in its shortest exact form: a round trip is exact).
    pub fn to_csv(&self) -> String {
        let mut s = String::from("time");
        for m in &self.motors {
            match &m.command {
                Command::Position { .. } => {
                    let _ = write!(s, ",{0}:target,{0}:kp,{0}:kd", m.name);
                }
                c => {
                    let _ = write!(s, ",{}:{}", m.name, c.kind());
                }
            }
            let _ = write!(s, ",{}:position", m.name);
            if m.velocity.is_some() {
                let _ = write!(s, ",{}:velocity", m.name);
            }
        }
        s.push('\n');
        for i in 0..self.time.len() {
            let _ = write!(s, "{}", self.time[i]);
            for m in &self.motors {
                match &m.command {
                    Command::Position { target, kp, kd } => {
                        let _ = write!(s, ",{},{},{}", target[i], kp[i], kd[i]);
                    }
                    Command::Torque(u) | Command::Current(u) => {
                        let _ = write!(s, ",{}", u[i]);
                    }
                }
                let _ = write!(s, ",{}", m.position[i]);
                if let Some(v) = &m.velocity {
                    let _ = write!(s, ",{}", v[i]);
                }
            }
            s.push('\n');
        }
        s
    }

    /// Sample interval, s.
    pub fn step(&self) -> f64 {
        (self.time[self.time.len() - 1] - self.time[0]) / (self.time.len() - 1) as f64
    }

    /// The velocity of motor `m` at sample `i`: logged, or the central difference of positions.
    pub fn velocity(&self, m: usize, i: usize) -> f64 {
        let t = &self.motors[m];
        if let Some(v) = &t.velocity {
            return v[i];
        }
        let (a, b) = (i.saturating_sub(1), (i + 1).min(self.time.len() - 1));
        (t.position[b] - t.position[a]) / (self.time[b] - self.time[a])
    }

    /// The samples `from..to` as a log of their own.
    pub fn slice(&self, from: usize, to: usize) -> MotorLog {
        let cut = |v: &Vec<f64>| v[from..to].to_vec();
        MotorLog {
            time: cut(&self.time),
            motors: self
                .motors
                .iter()
                .map(|m| MotorTrace {
                    name: m.name.clone(),
                    command: match &m.command {
                        Command::Torque(u) => Command::Torque(cut(u)),
                        Command::Current(u) => Command::Current(cut(u)),
                        Command::Position { target, kp, kd } => {
                            Command::Position { target: cut(target), kp: cut(kp), kd: cut(kd) }
                        }
                    },
                    position: cut(&m.position),
                    velocity: m.velocity.as_ref().map(cut),
                })
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn log(rows: &[&str], header: &str) -> String {
        format!("# a comment\n{header}\n{}\n", rows.join("\n"))
    }

    fn rows(n: usize) -> Vec<String> {
        (0..n).map(|i| format!("{:.3},{},80,2,{}", i as f64 * 0.002, 0.1 * i as f64, 0.09 * i as f64)).collect()
    }

    const HEADER: &str = "time,knee:target,knee:kp,knee:kd,knee:position";

    fn err(text: &str) -> String {
        format!("{:#}", MotorLog::parse(text).unwrap_err())
    }

    #[test]
    fn a_log_round_trips_and_velocity_comes_from_positions() {
        let r = rows(20);
        let l = MotorLog::parse(&log(&r.iter().map(String::as_str).collect::<Vec<_>>(), HEADER)).unwrap();
        assert_eq!(l.motors.len(), 1);
        assert!(matches!(&l.motors[0].command, Command::Position { kp, .. } if kp[3] == 80.0));
        assert!((l.step() - 0.002).abs() < 1e-12);
        assert!((l.velocity(0, 5) - 0.09 / 0.002).abs() < 1e-9);
        assert_eq!(MotorLog::parse(&l.to_csv()).unwrap(), l);
        assert_eq!(l.slice(2, 12).time.len(), 10);
    }

    #[test]
    fn bad_logs_are_refused_naming_the_place() {
        let mut r = rows(20);
        let ok = |r: &Vec<String>| log(&r.iter().map(String::as_str).collect::<Vec<_>>(), HEADER);
        r[7] = "0.014,NaN,80,2,0.6".into();
        assert!(err(&ok(&r)).contains("line 10, column knee:target: NaN"), "{}", err(&ok(&r)));
        let mut r = rows(20);
        r.swap(4, 5);
        assert!(err(&ok(&r)).contains("not increasing at t = 0.008"), "{}", err(&ok(&r)));
        let mut r = rows(20);
        r.remove(9);
        assert!(err(&ok(&r)).contains("a gap of 0.0040 s after t = 0.016"), "{}", err(&ok(&r)));
        let r = rows(20);
        let text = ok(&r).replace("knee:kd", "knee:kdd");
        assert!(err(&text).contains("unknown quantity \"kdd\""), "{}", err(&text));
        let text = ok(&r).replace(",knee:kp,knee:kd", ",knee:torque,knee:kd");
        assert!(err(&text).contains("2 command columns (target, torque)"), "{}", err(&text));
        let text = ok(&r).replace("knee:position", "knee:velocity");
        assert!(err(&text).contains("no `knee:position` column"), "{}", err(&text));
        let mut r = rows(20);
        r[3].push_str(",1");
        assert!(err(&ok(&r)).contains("line 6: 6 fields, the header has 5"), "{}", err(&ok(&r)));
    }
}
