//! `topa sysid …`: the identification tools on the command line.

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{Context, Result};
use clap::Subcommand;

use crate::sysid::excite::{self, CommandKind, Design, Shape};

#[derive(Subcommand)]
pub enum SysidCmd {
    /// Write a frequency-rich command trajectory for a motor bench or a robot hung in the air (CSV a bench
    /// controller can play) and the plot of its spectrum.
    Excite {
        /// The robot spec whose motors are excited (position targets start from its stand pose).
        #[arg(long, default_value = "assets/robots/topa_closed.toml")]
        robot: PathBuf,
        /// Motors to excite, by actuator name (default: all of the spec's motors).
        #[arg(long, value_delimiter = ',')]
        motors: Vec<String>,
        #[arg(long, value_enum, default_value = "multisine")]
        shape: Shape,
        /// What the trajectory commands.
        #[arg(long, value_enum, default_value = "position")]
        kind: CommandKind,
        /// Peak deviation from the stand pose (rad) or from zero torque (N·m).
        #[arg(long, default_value_t = 0.2)]
        amplitude: f64,
        /// Frequency band LOW,HIGH (Hz).
        #[arg(long, value_delimiter = ',', default_value = "0.5,15")]
        band: Vec<f64>,
        /// Seconds.
        #[arg(long, default_value_t = 30.0)]
        duration: f64,
        /// Samples per second of the written trajectory.
        #[arg(long, default_value_t = 500.0)]
        rate: f64,
        /// Fade in and out, s.
        #[arg(long, default_value_t = 1.0)]
        fade: f64,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// The CSV to write (the spectrum goes beside it as *_spectrum.png).
        #[arg(long, default_value = "out/sysid/excite.csv")]
        out: PathBuf,
    },
}

pub fn run(cmd: SysidCmd) -> Result<()> {
    match cmd {
        SysidCmd::Excite { robot, motors, shape, kind, amplitude, band, duration, rate, fade, seed, out } => {
            anyhow::ensure!(band.len() == 2, "--band takes LOW,HIGH in Hz, e.g. 0.5,15");
            let d = Design {
                shape,
                amplitude,
                band: [band[0], band[1]],
                duration_s: duration,
                rate_hz: rate,
                fade_s: fade,
                seed,
            };
            d.check()?;
            let (spec, model) =
                topa_env::spec::RobotSpec::load(&topa_env::assets::robot_path(&robot.to_string_lossy()))?;
            let spec = Arc::new(spec);
            let idx = topa_env::RobotIndices::resolve(&model, &spec)?;
            let all: Vec<(String, f64)> = spec
                .motors
                .iter()
                .zip(&idx.nominal_actuated)
                .map(|(m, &q)| (m.actuator.clone(), if kind == CommandKind::Position { q } else { 0.0 }))
                .collect();
            let chosen: Vec<(String, f64)> = if motors.is_empty() {
                all
            } else {
                motors
                    .iter()
                    .map(|name| {
                        all.iter().find(|(n, _)| n == name).cloned().with_context(|| {
                            let names: Vec<&str> = all.iter().map(|(n, _)| n.as_str()).collect();
                            format!("--motors: {} has no motor '{name}' (its motors: {})", spec.name, names.join(", "))
                        })
                    })
                    .collect::<Result<_>>()?
            };
            if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)?;
            }
            crate::eval::report::write_text(
                out.parent().unwrap_or(std::path::Path::new(".")),
                &out.file_name().context("--out names a file")?.to_string_lossy(),
                &excite::csv(&d, kind, &chosen),
            )?;
            let png = out.with_file_name(format!(
                "{}_spectrum.png",
                out.file_stem().map_or("excite".into(), |s| s.to_string_lossy().into_owned())
            ));
            crate::sysid::spectrum_plot::plot(&d, &d.signal(0), &png)?;
            let share = excite::energy_in_band(&d.signal(0), rate, d.band);
            println!(
                "{}: {} motors × {} samples ({:?} {:?}, {:.0} % of the energy in {}–{} Hz); spectrum: {}",
                out.display(),
                chosen.len(),
                d.samples(),
                kind,
                shape,
                100.0 * share,
                d.band[0],
                d.band[1],
                png.display()
            );
        }
    }
    Ok(())
}
