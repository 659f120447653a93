//! A bench that does not exist: an excitation trajectory played through the bench MJCF with hidden "true"
//! parameters, its positions read through the realistic sim2sim's encoder model (quantisation) plus white noise.
//! The proof that `fit` recovers what it should, and a dry run for a team before its hardware arrives.

use std::path::Path;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use topa_env::sim2sim::sensors::{gaussian, EncoderConfig};

use super::bench::{Bench, Params};
use super::log::{Command, MotorLog, MotorTrace};
use crate::error::{bad_file, ensure_file, Error, Result};

/// How the synthetic sensors read the true motion.
#[derive(Debug, Clone, Copy)]
pub struct SensorModel {
    /// Encoder counts per output revolution (0: exact).
    pub counts_per_rev: f64,
    /// White position noise, rad.
    pub position_noise: f64,
    pub seed: u64,
}

impl SensorModel {
    /// The noise floor these sensors put under any fit: the RMS of quantisation and white noise, rad.
    pub fn floor(&self) -> f64 {
        let q = if self.counts_per_rev > 0.0 { std::f64::consts::TAU / self.counts_per_rev } else { 0.0 };
        (q * q / 12.0 + self.position_noise * self.position_noise).sqrt()
    }
}

/// Reads an excitation trajectory (`topa sysid excite`'s CSV: `time` and `<motor>:target` or `<motor>:torque`) into
/// a log with the positions still empty (held at the first target, or zero, until simulated) and the PD gains
/// zero until [`drive_gains_from_model`] sets them.
pub fn read_excitation(path: &Path) -> Result<MotorLog> {
    let text = std::fs::read_to_string(path).map_err(Error::io("cannot read the excitation", path))?;
    let mut lines = text.lines().filter(|l| !l.trim().is_empty() && !l.starts_with('#'));
    let header: Vec<&str> = lines.next().ok_or_else(|| Error::bad_file("no header"))?.split(',').collect();
    ensure_file!(header[0] == "time", "excitation {}: the first column must be `time`", path.display());
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); header.len()];
    for (i, l) in lines.enumerate() {
        let f: Vec<&str> = l.split(',').collect();
        ensure_file!(f.len() == header.len(), "excitation {}: row {} has {} fields", path.display(), i + 1, f.len());
        for (c, v) in cols.iter_mut().zip(f) {
            let x: f64 =
                v.trim().parse().map_err(|e| Error::file(format!("excitation {}: {v:?}", path.display()), e))?;
            ensure_file!(x.is_finite(), "excitation {}: row {} has {x}", path.display(), i + 1);
            c.push(x);
        }
    }
    let time = cols[0].clone();
    let mut motors = Vec::new();
    for (c, name) in header.iter().enumerate().skip(1) {
        let (motor, q) = name.split_once(':').ok_or_else(|| Error::bad_file(format!("excitation column {name:?}")))?;
        let u = cols[c].clone();
        let (command, rest) = match q {
            "target" => {
                let n = u.len();
                (Command::Position { target: u.clone(), kp: vec![0.0; n], kd: vec![0.0; n] }, u[0])
            }
            "torque" => (Command::Torque(u), 0.0),
            _ => bad_file!("excitation column {name:?}: expected <motor>:target or <motor>:torque"),
        };
        motors.push(MotorTrace { name: motor.to_string(), command, position: vec![rest; time.len()], velocity: None });
    }
    Ok(MotorLog { time, motors })
}

/// Position targets get the PD gains of the bench's actuators (`gainprm` = kp, `biasprm` = 0 −kp −kd).
pub fn drive_gains_from_model(bench: &Bench, log: &mut MotorLog) {
    for (m, trace) in log.motors.iter_mut().enumerate() {
        if let Command::Position { kp, kd, .. } = &mut trace.command {
            let (p, d) = bench.pd_gains(m);
            kp.fill(p);
            kd.fill(d);
        }
    }
}

/// Plays `excitation` through `bench` with the `truth` from rest and returns the log its sensors would write.
pub fn record(bench: &Bench, excitation: &MotorLog, truth: &Params, sensors: &SensorModel) -> Result<MotorLog> {
    let n = excitation.time.len();
    let sim = bench.simulate(truth, excitation, &[(0, n)])?;
    let encoder = EncoderConfig {
        enabled: sensors.counts_per_rev > 0.0,
        counts_per_rev: sensors.counts_per_rev,
        velocity_noise: 0.0,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(sensors.seed);
    let mut log = excitation.clone();
    let k = bench.motors.len();
    for (m, trace) in log.motors.iter_mut().enumerate() {
        for i in 1..n {
            let q = sim[(i - 1) * k + m];
            trace.position[i] = encoder.quantise(q + sensors.position_noise * gaussian(&mut rng));
        }
        trace.position[0] = encoder.quantise(trace.position[0] + sensors.position_noise * gaussian(&mut rng));
    }
    Ok(log)
}

/// Hidden "true" values: each motor's armature, damping, dry friction and torque constant off `nominal` by 30–50 %
/// either way, and a delay of 1–5 ms.
pub fn hidden(nominal: &Params, seed: u64) -> Params {
    use rand::RngExt;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut off = |v: f64| {
        let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
        v * (1.0 + sign * rng.random_range(0.3..0.5))
    };
    let motors = nominal
        .motors
        .iter()
        .map(|m| super::bench::MotorParams {
            armature: off(m.armature),
            damping: off(m.damping),
            frictionloss: off(m.frictionloss),
            torque_constant: off(m.torque_constant),
        })
        .collect();
    Params { motors, delay_s: rng.random_range(0.001..0.005) }
}
