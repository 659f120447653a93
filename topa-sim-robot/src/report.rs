//! The tracking experiment through the wire beside the same experiment in process: one Markdown table, written
//! with the run's JSON.

use topa_eval::results::TrackingRow;

use crate::robot::Counters;

/// What one run through the wire was: the network, and what it counted.
#[derive(Debug, Clone, serde::Serialize)]
pub struct WireRun<'a> {
    pub policy: &'a str,
    pub sim2sim: String,
    pub loss: f64,
    pub latency_ms: f64,
    pub jitter_ms: f64,
    pub rows: &'a [TrackingRow],
    pub in_process: Option<&'a [TrackingRow]>,
    pub counters: &'a Counters,
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
    let mut s = format!(
        "# Tracking through the wire\n\n`{}`, {} sim2sim; `topa control` and `topa sim-robot` as two processes on \
         loopback UDP; network: {:.0} % loss, {} ms latency, {} ms jitter per datagram.\n\n",
        run.policy,
        run.sim2sim,
        run.loss * 100.0,
        run.latency_ms,
        run.jitter_ms
    );
    s += "| command | MAE in process | MAE through the wire | difference |\n|---|---:|---:|---:|\n";
    for r in run.rows {
        let inproc = run.in_process.and_then(|rows| rows.iter().find(|p| p.key == r.key));
        let (p, d) = match inproc {
            Some(p) => (format!("{} ({} starts)", mae(p), p.starts), format!("{:+.3}", r.mae - p.mae)),
            None => ("—".into(), "—".into()),
        };
        s += &format!("| {} | {p} | {} | {d} |\n", r.key, mae(r));
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
