//! Where a run's wall time was spent. A run can be resumed on another machine or with another thread count, and a
//! C+A run carries its C run's time; one total says little, so each stretch of iterations keeps its machine and
//! thread count, and times of two runs can be compared stretch by stretch.

use serde::{Deserialize, Serialize};

/// Iterations `first..last` (last exclusive) run on one machine with one thread count.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Segment {
    /// Logical CPUs, CPU model and matrix kernel, e.g. "2 × AMD EPYC (family 26 model 2, AVX-512)".
    pub machine: String,
    /// Worker threads the run used.
    pub threads: usize,
    pub first_iteration: usize,
    pub last_iteration: usize,
    pub wall_time_s: f64,
}

/// This machine in the form [`Segment::machine`] uses: logical CPUs, the CPU's model name and, on x86-64, its
/// family and model numbers (a virtual machine's model name is often only "AMD EPYC", which spans several
/// generations) and the kernel of the matrix products ([`crate::nn::gemm_kernel`]): the wall time of a run depends on
/// all of them, e.g. "2 × AMD EPYC (family 26 model 2, AVX-512)".
pub fn this_machine() -> String {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    describe_machine(&cpuinfo, std::thread::available_parallelism().map_or(1, |n| n.get()), crate::nn::gemm_kernel())
}

/// [`this_machine`] from the text of `/proc/cpuinfo`, the logical CPU count and the kernel's instruction set.
fn describe_machine(cpuinfo: &str, cpus: usize, isa: &str) -> String {
    // The first processor's block; every logical CPU of one machine reports the same.
    let field = |key: &str| {
        cpuinfo.lines().find_map(|l| {
            let (k, v) = l.split_once(':')?;
            (k.trim() == key).then(|| v.trim().to_string())
        })
    };
    let name = field("model name").filter(|n| !n.is_empty()).unwrap_or_else(|| "unknown CPU".into());
    let mut detail = Vec::new();
    if let (Some(f), Some(m)) = (field("cpu family"), field("model")) {
        detail.push(format!("family {f} model {m}"));
    }
    if !isa.is_empty() {
        detail.push(isa.to_string());
    }
    if detail.is_empty() {
        format!("{cpus} × {name}")
    } else {
        format!("{cpus} × {name} ({})", detail.join(", "))
    }
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

    #[test]
    fn the_machine_line_carries_family_model_and_kernel() {
        let info = "processor\t: 0\nvendor_id\t: AuthenticAMD\ncpu family\t: 26\nmodel\t\t: 2\n\
                    model name\t: AMD EPYC\nflags\t\t: fpu avx512f\n\nprocessor\t: 1\ncpu family\t: 26\n";
        assert_eq!(describe_machine(info, 2, "AVX-512"), "2 × AMD EPYC (family 26 model 2, AVX-512)");
        assert_eq!(describe_machine(info, 2, ""), "2 × AMD EPYC (family 26 model 2)");
        // No /proc/cpuinfo (another OS): the count and an honest unknown.
        assert_eq!(describe_machine("", 4, ""), "4 × unknown CPU");
        // "model name" must not be taken for "model".
        let arm = "model name\t: Neoverse\n";
        assert_eq!(describe_machine(arm, 8, ""), "8 × Neoverse");
    }
}
