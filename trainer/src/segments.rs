//! Where a run's wall time was spent. A run can be resumed on another machine or with another thread count, and a
//! C+A run carries its C run's time; one total says little, so each stretch of iterations keeps its machine and
//! thread count, and times of two runs can be compared stretch by stretch.

use serde::{Deserialize, Serialize};

/// Iterations `first..last` (last exclusive) run on one machine with one thread count.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Segment {
    /// Logical CPUs and CPU model, e.g. "2 × AMD EPYC".
    pub machine: String,
    /// Worker threads the run used.
    pub threads: usize,
    pub first_iteration: usize,
    pub last_iteration: usize,
    pub wall_time_s: f64,
}

/// This machine in the form [`Segment::machine`] uses: logical CPUs and the CPU's model name.
pub fn this_machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    format!("{} × {cpu}", std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Adds one iteration (`iteration` → `iteration + 1`, `seconds` long) to `segments`: it lengthens the last
/// stretch when that one ran on the same machine and threads and ends where this iteration starts, else it opens
/// a new one.
pub fn record(segments: &mut Vec<Segment>, machine: &str, threads: usize, iteration: usize, seconds: f64) {
    if let Some(s) = segments.last_mut() {
        if s.machine == machine && s.threads == threads && s.last_iteration == iteration {
            s.last_iteration += 1;
            s.wall_time_s += seconds;
            return;
        }
    }
    segments.push(Segment {
        machine: machine.to_string(),
        threads,
        first_iteration: iteration,
        last_iteration: iteration + 1,
        wall_time_s: seconds,
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stretch_grows_until_machine_threads_or_iteration_change() {
        let mut s = Vec::new();
        record(&mut s, "2 × A", 2, 0, 1.0);
        record(&mut s, "2 × A", 2, 1, 1.5);
        assert_eq!(s.len(), 1);
        assert_eq!((s[0].first_iteration, s[0].last_iteration, s[0].wall_time_s), (0, 2, 2.5));
        record(&mut s, "2 × A", 1, 2, 3.0); // resumed with one thread
        record(&mut s, "16 × B", 1, 3, 0.5); // then on another machine
        record(&mut s, "16 × B", 1, 10, 0.5); // a gap (iterations redone after a resume) starts a new stretch
        assert_eq!(s.len(), 4);
        assert_eq!((s[1].threads, s[1].first_iteration, s[1].last_iteration), (1, 2, 3));
        assert_eq!((s[3].first_iteration, s[3].last_iteration), (10, 11));
        let total: f64 = s.iter().map(|x| x.wall_time_s).sum();
        assert_eq!(total, 6.5);
    }

    #[test]
    fn this_machine_names_cpus_and_model() {
        let m = this_machine();
        let (n, model) = m.split_once(" × ").expect("count × model");
        assert!(n.parse::<usize>().unwrap() >= 1);
        assert!(!model.is_empty());
    }
}
