//! The wire's cost in the loop: a sensor frame sent to a controller thread, which decodes it, ticks (C+A seed 1)
//! and sends the motor command back — timed from send to the command's arrival, 5 000 round trips, over loopback
//! UDP and (a build with `--features zenoh`) over Zenoh between two peer sessions on loopback TCP; median, p99 and
//! max beside the control period they must fit in, and Zenoh's over UDP's, measured in one run.

use std::net::{SocketAddr, UdpSocket};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Result;
use topa_control::driver::Readings;
use topa_control::transport::Link;
use topa_control::{wire, Controller, Mode, MotorCommand};

const TRIPS: usize = 5_000;
/// Round trips before the timed ones: the soft start, warm caches, and (Zenoh) the subscriptions' propagation.
const WARM_UP: usize = 200;

#[path = "common/stats.rs"]
mod stats;
use stats::quantiles;

fn free() -> SocketAddr {
    UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap()
}

/// Round trips from `robot` through a controller on `ctl`, µs.
fn round_trips(controller_dir: &Path, mut robot: Link, mut ctl: Link) -> Result<Vec<f64>> {
    let mut c = Controller::load(controller_dir)?;
    let n = c.spec().n_motors();
    let period = c.spec().control_period_s;
    let nominal: Vec<f64> = c.spec().motors.iter().map(|m| m.nominal).collect();
    let done = Arc::new(AtomicBool::new(false));
    let stop = done.clone();
    let controller = std::thread::spawn(move || -> Result<()> {
        let mut r = Readings::new(n);
        let mut buf = Vec::new();
        c.start();
        let mut seq = 0u32;
        while !stop.load(Ordering::Relaxed) {
            // Yield between polls: a spinning thread would starve the carrier's own threads (Zenoh's runtime).
            let Some(d) = ctl.poll(|d| wire::check(d, wire::SENSORS, n).map(|h| h.0))? else {
                std::thread::yield_now();
                continue;
            };
            wire::decode_sensors(d, &mut r).map_err(anyhow::Error::msg)?;
            let out = c.tick(&r.frame()).map_err(anyhow::Error::msg)?;
            ctl.send(wire::encode_command(out, 2, 0, seq, r.timestamp_s, &mut buf))?;
            seq += 1;
        }
        Ok(())
    });
    let mut r = Readings::new(n);
    r.motor_pos.copy_from_slice(&nominal);
    r.base_velocity = Some([0.1, 0.0, 0.0]);
    let (mut buf, mut cmd) =
        (Vec::new(), MotorCommand { mode: Mode::Passive, target: vec![0.0; n], kp: vec![0.0; n], kd: vec![0.0; n] });
    let mut trips = Vec::with_capacity(TRIPS);
    let mut seq = 0u32;
    for trip in 0..TRIPS + WARM_UP {
        let started = Instant::now();
        'resend: loop {
            r.timestamp_s = seq as f64 * period;
            let t = Instant::now();
            robot.send(wire::encode_sensors(&r, 1, 0, seq, &mut buf))?;
            seq += 1;
            loop {
                if let Some(d) = robot.poll(|d| wire::check(d, wire::COMMAND, n).map(|h| h.0))? {
                    wire::decode_command(d, &mut cmd).map_err(anyhow::Error::msg)?;
                    if trip >= WARM_UP {
                        trips.push(t.elapsed().as_secs_f64() * 1e6);
                    }
                    break 'resend;
                }
                // Until the peers found each other a frame may go nowhere: send another.
                if trip < WARM_UP && t.elapsed() > Duration::from_millis(50) {
                    continue 'resend;
                }
                anyhow::ensure!(started.elapsed() < Duration::from_secs(5), "no command came back (trip {trip})");
                std::thread::yield_now();
            }
        }
    }
    done.store(true, Ordering::Relaxed);
    controller.join().map_err(|_| anyhow::anyhow!("the controller thread panicked"))??;
    anyhow::ensure!(cmd.mode == Mode::Policy, "the controller ended in {:?}", cmd.mode);
    Ok(trips)
}

fn report(what: &str, trips: Vec<f64>, period: f64) -> f64 {
    let (m, p99, max) = quantiles(trips);
    println!(
        "  {what:<22} median {m:7.1} µs   p99 {p99:7.1} µs   max {max:8.1} µs   p99 / period {:.4}",
        p99 * 1e-6 / period
    );
    m
}

fn main() -> Result<()> {
    let dir = std::env::temp_dir().join(format!("topa-bench-wire-{}", std::process::id()));
    topa_tools::controller_export::export(Path::new("assets/policies/CA/seed1.json"), &dir)?;
    let period = Controller::load(&dir)?.spec().control_period_s;
    println!(
        "frame → controller tick → command, C+A seed 1, {TRIPS} round trips (control period {:.0} ms):",
        period * 1e3
    );
    let (robot_addr, ctl_addr) = (free(), free());
    let udp = round_trips(&dir, Link::bind(robot_addr, ctl_addr)?, Link::bind(ctl_addr, robot_addr)?)?;
    let udp_median = report("loopback UDP", udp, period);
    #[cfg(feature = "zenoh")]
    {
        use topa_control::zenoh_carrier::ZenohSession;
        let (a, b) = (free(), free());
        let robot = ZenohSession::open(&[format!("tcp/{a}")], &[format!("tcp/{b}")])?;
        let ctl = ZenohSession::open(&[format!("tcp/{b}")], &[format!("tcp/{a}")])?;
        let robot = Link::zenoh(robot.carrier("bench/sensors".into(), Some("bench/command".into()))?);
        let ctl = Link::zenoh(ctl.carrier("bench/command".into(), Some("bench/sensors".into()))?);
        let zenoh = round_trips(&dir, robot, ctl)?;
        let zenoh_median = report("Zenoh (loopback TCP)", zenoh, period);
        println!("  Zenoh / UDP, median: {:.2}", zenoh_median / udp_median);
    }
    #[cfg(not(feature = "zenoh"))]
    println!(
        "  (Zenoh: not in this build; `cargo bench --bench wire_roundtrip --features zenoh` sets it beside UDP's median \
         {udp_median:.1} µs)"
    );
    std::fs::remove_dir_all(dir).ok();
    Ok(())
}
