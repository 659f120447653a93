//! An experiment through the wire (tracking, pushes, the course) beside the same experiment in process: one Markdown table, written
//! with the run's JSON.

use topa_eval::course::{minutes, CourseResult, CourseRun};
use topa_eval::results::{PushGrid, TrackingRow};

use crate::robot::Counters;

/// What one run through the wire was: the network, the results, and what the wire counted.
#[derive(Debug, Clone, serde::Serialize)]
pub struct WireRun<'a> {
    pub policy: &'a str,
    pub sim2sim: String,
    /// What carried the wire: "loopback UDP", "Zenoh".
    pub carrier: &'a str,
    pub loss: f64,
    pub latency_ms: f64,
    pub jitter_ms: f64,
    pub results: WireResults<'a>,
    pub counters: &'a Counters,
}

/// The experiment's results through the wire, and the in-process ones to compare with.
#[derive(Debug, Clone, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum WireResults<'a> {
    Tracking { rows: &'a [TrackingRow], in_process: Option<&'a [TrackingRow]> },
    Push { forces: &'a [[f64; 2]], fell_at: &'a [Option<f64>], window_s: f64, in_process: Option<&'a PushGrid> },
    Course { course: &'a str, runs: &'a [CourseRun], in_process: Option<&'a CourseResult> },
}

/// A course run's cells: reached the goal, time, interventions (falls / walls / stuck), joint-limit hits.
fn course_cells(r: &CourseRun) -> String {
    format!(
        "{} | {} | {} ({} / {} / {}) | {:.1}",
        if r.finished { "yes" } else { "no" },
        minutes(r.time_s),
        r.interventions(),
        r.falls,
        r.wall_contacts,
        r.stuck,
        r.joint_limit_hits_per_min
    )
}

fn mae(r: &TrackingRow) -> String {
    if r.fell {
        format!("{:.3} (fell at {:.1} s)", r.mae, r.fell_at.unwrap_or(0.0))
    } else {
        format!("{:.3}", r.mae)
    }
}

/// The Markdown page of a run.
pub fn markdown(run: &WireRun) -> String {
    let what = match run.results {
        WireResults::Tracking { .. } => "Tracking",
        WireResults::Push { .. } => "Pushes",
        WireResults::Course { .. } => "The course",
    };
    let mut s = format!(
        "# {what} through the wire\n\n`{}`, {} sim2sim; `topa control` and `topa sim-robot` as two processes over \
         {}; network: {:.0} % loss, {} ms latency, {} ms jitter per datagram.\n\n",
        run.policy,
        run.sim2sim,
        run.carrier,
        run.loss * 100.0,
        run.latency_ms,
        run.jitter_ms
    );
    match &run.results {
        WireResults::Tracking { rows, in_process } => {
            s += "| command | MAE in process | MAE through the wire | difference |\n|---|---:|---:|---:|\n";
            for r in rows.iter() {
                let inproc = in_process.and_then(|rows| rows.iter().find(|p| p.key == r.key));
                let (p, d) = match inproc {
                    Some(p) => (format!("{} ({} starts)", mae(p), p.starts), format!("{:+.3}", r.mae - p.mae)),
                    None => ("—".into(), "—".into()),
                };
                s += &format!("| {} | {p} | {} | {d} |\n", r.key, mae(r));
            }
        }
        WireResults::Push { forces, fell_at, window_s, in_process } => {
            let t = |f: Option<f64>| f.map_or(format!("stood {window_s} s"), |t| format!("fell at {t:.2} s"));
            s += "| torso force (F_x, F_y), N | in process | through the wire |\n|---|---|---|\n";
            for (f, fell) in forces.iter().zip(fell_at.iter()) {
                let p = in_process.and_then(|g| {
                    let ix = g.axis.iter().position(|a| (a - f[0]).abs() < 1e-9)?;
                    let iy = g.axis.iter().position(|a| (a - f[1]).abs() < 1e-9)?;
                    let tf = g.t_fall[iy * g.axis.len() + ix];
                    Some(t((tf < g.window_s).then_some(tf)))
                });
                s += &format!("| ({}, {}) | {} | {} |\n", f[0], f[1], p.unwrap_or("—".into()), t(*fell));
            }
        }
        WireResults::Course { course, runs, in_process } => {
            s += &format!(
                "Course `{course}`; through the wire, the clock stops while the robot is put back and soft-started.\n\n\
                 | top speed (m/s) | in process: goal | time | interventions (falls / walls / stuck) | joint-limit \
                 hits/min | through the wire: goal | time | interventions | joint-limit hits/min |\n\
                 |---:|---|---:|---|---:|---|---:|---|---:|\n"
            );
            for r in runs.iter() {
                let p = in_process
                    .and_then(|c| c.runs.iter().find(|p| (p.top_speed - r.top_speed).abs() < 1e-9))
                    .map_or("— | — | — | —".to_string(), course_cells);
                s += &format!("| {:.2} | {p} | {} |\n", r.top_speed, course_cells(r));
            }
        }
    }
    let c = run.counters;
    s += &format!(
        "\nThe wire: {} sensor frames sent, {} lost on the way; {} motor commands applied, {} lost, {} late \
         (reordered), {} refused; the drives' watchdog tripped {} times; physics steps more than one step late: {} \
         (worst lag {:.1} ms).\n",
        c.frames_sent,
        c.lost_to_controller,
        c.commands_applied,
        c.lost_from_controller,
        c.commands_late,
        c.commands_refused,
        c.watchdog_trips,
        c.overruns,
        c.max_lag_s * 1e3
    );
    s
}
