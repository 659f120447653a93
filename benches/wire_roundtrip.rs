//! The wire's cost in the loop: a sensor frame sent over loopback UDP to a controller thread, which decodes it,
//! ticks (C+A seed 1) and sends the motor command back — timed from send to the command's arrival, 5 000 round
//! trips; median, p99 and max beside the control period they must fit in.

use std::net::{SocketAddr, UdpSocket};
use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::Result;
use topa_control::driver::Readings;
use topa_control::transport::Link;
use topa_control::{wire, Controller, Mode, MotorCommand};

const TRIPS: usize = 5_000;

#[path = "common/stats.rs"]
mod stats;
use stats::quantiles;

fn free() -> SocketAddr {
    UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap()
}

fn main() -> Result<()> {
    let dir = std::env::temp_dir().join(format!("topa-bench-wire-{}", std::process::id()));
    topa_tools::controller_export::export(Path::new("assets/policies/CA/seed1.json"), &dir)?;
    let mut c = Controller::load(&dir)?;
    let n = c.spec().n_motors();
    let period = c.spec().control_period_s;
    let nominal: Vec<f64> = c.spec().motors.iter().map(|m| m.nominal).collect();
    let (robot_addr, ctl_addr) = (free(), free());
    let mut ctl = Link::bind(ctl_addr, robot_addr)?;
    let controller = std::thread::spawn(move || -> Result<()> {
        let mut r = Readings::new(n);
        let mut buf = Vec::new();
        c.start();
        for seq in 0..(TRIPS as u32 + 200) {
            let d = loop {
                if let Some(d) = ctl.poll(|d| wire::check(d, wire::SENSORS, n).map(|h| h.0))? {
                    break d;
                }
            };
            wire::decode_sensors(d, &mut r).map_err(anyhow::Error::msg)?;
            let out = c.tick(&r.frame()).map_err(anyhow::Error::msg)?;
            ctl.send(wire::encode_command(out, 2, 0, seq, r.timestamp_s, &mut buf))?;
        }
        Ok(())
    });
    let mut robot = Link::bind(robot_addr, ctl_addr)?;
    let mut r = Readings::new(n);
    r.motor_pos.copy_from_slice(&nominal);
    r.base_velocity = Some([0.1, 0.0, 0.0]);
    let (mut buf, mut cmd) =
        (Vec::new(), MotorCommand { mode: Mode::Passive, target: vec![0.0; n], kp: vec![0.0; n], kd: vec![0.0; n] });
    let mut trips = Vec::with_capacity(TRIPS);
    for seq in 0..(TRIPS as u32 + 200) {
        r.timestamp_s = seq as f64 * period;
        let t = Instant::now();
        robot.send(wire::encode_sensors(&r, 1, 0, seq, &mut buf))?;
        let d = loop {
            if let Some(d) = robot.poll(|d| wire::check(d, wire::COMMAND, n).map(|h| h.0))? {
                break d;
            }
            anyhow::ensure!(t.elapsed() < Duration::from_secs(1), "no command came back");
        };
        wire::decode_command(d, &mut cmd).map_err(anyhow::Error::msg)?;
        // The first 200 cover the soft start and warm the caches.
        if seq >= 200 {
            trips.push(t.elapsed().as_secs_f64() * 1e6);
        }
    }
    controller.join().map_err(|_| anyhow::anyhow!("the controller thread panicked"))??;
    anyhow::ensure!(cmd.mode == Mode::Policy, "the controller ended in {:?}", cmd.mode);
    let (m, p99, max) = quantiles(trips);
    println!("frame → controller tick → command over loopback UDP, C+A seed 1, {TRIPS} round trips:");
    println!("  round trip  median {m:7.1} µs   p99 {p99:7.1} µs   max {max:7.1} µs");
    println!("  p99 / control period ({:.0} ms): {:.4}", period * 1e3, p99 * 1e-6 / period);
    std::fs::remove_dir_all(dir).ok();
    Ok(())
}
