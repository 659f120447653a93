//! `topa bench physics MODEL`: our safe `Data::step` loop against Debian's `mujoco-testspeed` on the same model
//! and step count (back to back, best of several rounds), and a batch of `Data` on 2 threads against 1.

use std::path::Path;
use std::process::Command;
use std::sync::Arc;
use std::time::Instant;

use mujoco::{Data, Model, ObjType};
use rayon::prelude::*;

use crate::error::{bad_bench, Error, Result};

/// Puts `d` where testspeed starts: keyframe "test" if the model has one, else qpos0.
fn initial_data(model: &Arc<Model>) -> Result<Data> {
    let mut d = Data::new(model.clone())?;
    if let Ok(key) = model.id(ObjType::Key, "test") {
        d.reset_keyframe(key)?;
        d.set_time(0.0);
    }
    Ok(d)
}

/// The same pseudo-random control noise testspeed injects (Halton sequence, 1 % of each control range).
fn inject_ctrl_noise(model: &Model, d: &mut Data, i: usize, noise: f64) {
    let ranges = model.actuator_ctrlrange();
    let limited = model.actuator_ctrllimited();
    for (j, c) in d.ctrl_mut().iter_mut().enumerate() {
        let (center, radius) = if limited[j] != 0 {
            ((ranges[j][0] + ranges[j][1]) / 2.0, (ranges[j][1] - ranges[j][0]) / 2.0)
        } else {
            (0.0, 1.0)
        };
        let h = mujoco::halton(i, j + 2);
        *c = center + radius * noise * (2.0 * h - 1.0);
    }
}

/// Steps one `Data` `nstep` times the way testspeed does; returns steps per second.
pub fn our_steps_per_second(model: &Arc<Model>, nstep: usize) -> Result<f64> {
    let mut d = initial_data(model)?;
    let start = Instant::now();
    for i in 0..nstep {
        inject_ctrl_noise(model, &mut d, i, 0.01);
        d.step()?;
    }
    Ok(nstep as f64 / start.elapsed().as_secs_f64())
}

/// Runs `mujoco-testspeed MODEL nstep 1 0.01` and reads its "Steps per second".
pub fn testspeed_steps_per_second(path: &Path, nstep: usize) -> Result<f64> {
    let out = Command::new("mujoco-testspeed").arg(path).arg(nstep.to_string()).arg("1").arg("0.01").output().map_err(
        |e| Error::bench("cannot run mujoco-testspeed: install it with `apt-get install -y libmujoco-samples`", e),
    )?;
    let text = String::from_utf8_lossy(&out.stdout);
    let sps = text
        .lines()
        .find_map(|l| l.trim().strip_prefix("Steps per second").map(|r| r.trim_start_matches([' ', ':'])))
        .and_then(|v| v.trim().parse::<f64>().ok());
    match sps {
        Some(v) => Ok(v),
        None => bad_bench!("mujoco-testspeed printed no 'Steps per second' line:\n{text}"),
    }
}

/// Steps `batch` Data, `nstep` steps each, on a pool of `threads`; returns total steps per second.
pub fn batch_steps_per_second(model: &Arc<Model>, batch: usize, nstep: usize, threads: usize) -> Result<f64> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::bench(format!("building a pool of {threads} threads"), e))?;
    let mut datas = (0..batch).map(|_| initial_data(model)).collect::<Result<Vec<_>>>()?;
    let start = Instant::now();
    pool.install(|| {
        datas.par_iter_mut().try_for_each(|d| -> Result<()> {
            for i in 0..nstep {
                inject_ctrl_noise(model, d, i, 0.01);
                d.step()?;
            }
            Ok(())
        })
    })?;
    Ok((batch * nstep) as f64 / start.elapsed().as_secs_f64())
}

pub fn run(path: &Path, nstep: usize, rounds: usize, batch: usize, with_testspeed: bool) -> Result<()> {
    let model = Arc::new(Model::from_xml_path(path)?);
    println!("model {} ({}), {} steps per run, best of {rounds} rounds", model.name(), path.display(), nstep);
    let (mut ours, mut theirs) = (0.0f64, 0.0f64);
    for r in 0..rounds {
        // Alternate the order so neither side always runs on a warmer (or busier) machine.
        if r % 2 == 0 {
            ours = ours.max(our_steps_per_second(&model, nstep)?);
        }
        if with_testspeed {
            theirs = theirs.max(testspeed_steps_per_second(path, nstep)?);
        }
        if r % 2 == 1 {
            ours = ours.max(our_steps_per_second(&model, nstep)?);
        }
    }
    let per = (nstep / batch).max(100);
    let batch_1 = batch_steps_per_second(&model, batch, per, 1)?;
    let batch_2 = batch_steps_per_second(&model, batch, per, 2)?;
    println!("{:<44} {:>12.0} steps/s", "topa Data::step (1 thread)", ours);
    if with_testspeed {
        println!("{:<44} {:>12.0} steps/s", "mujoco-testspeed (1 thread)", theirs);
        println!("{:<44} {:>12.3}   (goal ≥ 0.98)", "ratio topa / testspeed", ours / theirs);
    }
    println!("{:<44} {:>12.0} steps/s", format!("batch of {batch} Data, 1 thread"), batch_1);
    println!("{:<44} {:>12.0} steps/s", format!("batch of {batch} Data, 2 threads"), batch_2);
    println!("{:<44} {:>12.3}   (goal ≥ 1.9)", "speed-up 2 threads / 1 thread", batch_2 / batch_1);
    Ok(())
}
