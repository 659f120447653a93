//! `topa sysid`'s tools: excitation, motor logs, the fit, the synthetic bench, the estimator's tuning.

use std::path::PathBuf;

use clap::Subcommand;
use topa_sysid::excite::{CommandKind, Shape};
use topa_sysid::fit::Kind;

#[derive(Subcommand)]
pub(crate) enum SysidCmd {
    /// Write a frequency-rich command trajectory for a motor bench or a robot hung in the air (CSV a bench
    /// controller can play) and the plot of its spectrum.
    Excite {
        /// The robot spec whose motors are excited (position targets start from its stand pose).
        #[arg(long, default_value = "assets/robots/topa_closed.toml")]
        robot: PathBuf,
        /// Motors to excite, by actuator name (default: all of the spec's motors).
        #[arg(long, value_delimiter = ',')]
        motors: Vec<String>,
        /// The excitation's shape: multisine (random phases over the band), chirp (a sweep through it), prbs.
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
        /// Seed of the random draws (the multisine's phases, the PRBS's flips).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// The CSV to write (the spectrum goes beside it as *_spectrum.png).
        #[arg(long, default_value = "out/sysid/excite.csv")]
        out: PathBuf,
    },
    /// Play an excitation through a bench with hidden parameters and write the log its sensors would record (and
    /// the hidden values beside it, *_truth.json): a bench that does not exist, to rehearse or prove a fit.
    Simulate {
        /// The bench MJCF.
        #[arg(long, default_value = "assets/mjcf/benches/topa_motors.xml")]
        bench: PathBuf,
        /// Instead of a bench: this robot spec hung in the air (base fixed, contacts off, loops closed).
        #[arg(long, conflicts_with = "bench")]
        robot: Option<PathBuf>,
        /// The excitation CSV (`topa sysid excite`); position targets go through the bench actuators' PD gains.
        #[arg(long)]
        excitation: PathBuf,
        /// Seed of the hidden parameters: each motor's armature, damping, dry friction and torque constant off the
        /// bench's by 30–50 % either way, and a delay of 1–5 ms.
        #[arg(long, default_value_t = 7)]
        hidden_seed: u64,
        /// The hidden delay, s, instead of a drawn one.
        #[arg(long)]
        hidden_delay: Option<f64>,
        /// Encoder counts per output revolution (the realistic sim2sim's: 16384; 0: exact).
        #[arg(long, default_value_t = 16384.0)]
        counts_per_rev: f64,
        /// White position noise, rad.
        #[arg(long, default_value_t = 2e-4)]
        position_noise: f64,
        /// Seed of the sensor noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// The log CSV to write.
        #[arg(long, default_value = "out/sysid/log.csv")]
        out: PathBuf,
    },
    /// Tune the state estimator's noise parameters against ground truth: on recordings of the realistic sim2sim
    /// with a policy walking (default), or on a robot's own recordings in the same columns; writes a sim2sim config
    /// with the tuned values and the velocity error before and after.
    Estimator {
        /// The policy that walks while the realistic sim2sim records (when no --recording is given).
        #[arg(long, default_value = "assets/policies/C/seed1.json")]
        policy: PathBuf,
        /// Seconds of each recording.
        #[arg(long, default_value_t = 48.0)]
        seconds: f64,
        /// Tune on this recording instead (CSV, docs/sysid.md); needs --held-out-recording.
        #[arg(long, requires = "held_out_recording")]
        recording: Option<PathBuf>,
        /// The recording the tuned filter is checked on (CSV, as --recording).
        #[arg(long)]
        held_out_recording: Option<PathBuf>,
        /// Seed of the fitted recording (the held-out one gets seed + 1).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output folder (estimator.toml, estimator.md, estimator.json, the recordings).
        #[arg(long, default_value = "out/sysid/estimator")]
        out: PathBuf,
    },
    /// Identify the motors' armature, damping, dry friction, torque constant and command delay from a log: MuJoCo
    /// replays the logged commands and Levenberg–Marquardt matches the logged positions.
    Fit {
        /// The bench MJCF (every joint a logged motor; docs/sysid.md).
        #[arg(long, default_value = "assets/mjcf/benches/topa_motors.xml")]
        bench: PathBuf,
        /// Instead of a bench: this robot spec hung in the air (base fixed, contacts off, loops closed); the log
        /// holds all its motors.
        #[arg(long, conflicts_with = "bench")]
        robot: Option<PathBuf>,
        /// The log CSV (docs/sysid.md).
        #[arg(long)]
        log: PathBuf,
        /// A second log to hold out (default: the last --held-out share of --log).
        #[arg(long)]
        held_out_log: Option<PathBuf>,
        /// Share of the log held out when no --held-out-log is given.
        #[arg(long, default_value_t = 0.2)]
        held_out: f64,
        /// Parameters to fit.
        #[arg(
            long,
            value_enum,
            value_delimiter = ',',
            default_value = "armature,damping,frictionloss,torque-constant,delay"
        )]
        fit: Vec<Kind>,
        /// Window length, s: each window starts from the logged state (multiple shooting). Default: 5 s when every
        /// motor runs its PD loop (errors die out), 0.5 s for torque or current commands (open loop drifts).
        #[arg(long)]
        window: Option<f64>,
        /// Seconds after each window's start left out of the comparison (default under PD loops: 0.1 s on a bench,
        /// 1 s on the hung robot; 0 for torque or current commands).
        #[arg(long)]
        burn_in: Option<f64>,
        /// Upper bound of the delay, s.
        #[arg(long, default_value_t = 0.02)]
        max_delay: f64,
        /// Box of each parameter: [0, range × the bench's value] (torque constant: [1/range, range] × its start).
        #[arg(long, default_value_t = 5.0)]
        range: f64,
        /// Start value of the torque constant (N·m/A for current logs; a ratio otherwise).
        #[arg(long, default_value_t = 1.0)]
        torque_constant: f64,
        /// Simulations the fit may run at most.
        #[arg(long, default_value_t = 3000)]
        max_evaluations: usize,
        /// Hidden true values (a *_truth.json of `topa sysid simulate`): report each fitted value's error.
        #[arg(long)]
        truth: Option<PathBuf>,
        /// Output folder (identified.json, identified.md, fit.png, <bench>_identified.xml).
        #[arg(long, default_value = "out/sysid/fit")]
        out: PathBuf,
    },
}
