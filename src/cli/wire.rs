//! `topa sim-robot` and `topa control`: the simulated robot and the controller as two processes on the wire.

use std::net::SocketAddr;
use std::path::PathBuf;

use clap::Args;
use topa_eval::settings::Sim2SimMode;

/// Which transport carries the wire.
#[derive(Args, Clone)]
pub(crate) struct CarriageArgs {
    /// Carry the wire over Zenoh instead of UDP (a build with `--features zenoh`): this side listens on
    /// tcp/<--listen> and connects to the other's address; operator messages travel in the same session.
    #[arg(long)]
    pub(crate) zenoh: bool,
    /// The key expressions' prefix over Zenoh: <prefix>/sensors, <prefix>/command, <prefix>/operator.
    #[arg(long, default_value = "topa", requires = "zenoh")]
    pub(crate) zenoh_prefix: String,
}

/// The simulated robot: MuJoCo in real time, the drives' PD and watchdog, sensor frames out, commands in.
#[derive(Args)]
pub(crate) struct SimRobotArgs {
    /// The policy whose robot and physics to simulate (its training config; the policy itself runs in `topa control`).
    #[arg(long)]
    pub(crate) policy: PathBuf,
    /// ideal, realistic (the robot's sensors, state estimator, action delay and motor limits), or a TOML file.
    #[arg(long, default_value = "realistic")]
    pub(crate) sim2sim: Sim2SimMode,
    /// This robot's socket.
    #[arg(long, default_value = "127.0.0.1:7700")]
    pub(crate) listen: SocketAddr,
    /// The other side's socket: the controller's.
    #[arg(long, alias = "controller", default_value = "127.0.0.1:7701")]
    pub(crate) peer: SocketAddr,
    #[command(flatten)]
    pub(crate) carriage: CarriageArgs,
    /// Share of datagrams lost, each direction (0–1).
    #[arg(long, value_parser = crate::cli::values::share, default_value_t = 0.0)]
    pub(crate) loss: f64,
    /// Fixed one-way latency added to each datagram, ms.
    #[arg(long, value_parser = crate::cli::values::non_negative, default_value_t = 0.0)]
    pub(crate) latency_ms: f64,
    /// Extra latency drawn uniformly from [0, jitter] per datagram, ms.
    #[arg(long, value_parser = crate::cli::values::non_negative, default_value_t = 0.0)]
    pub(crate) jitter_ms: f64,
    /// The drives damp when no command came for this long, ms (default: five control periods).
    #[arg(long, value_parser = crate::cli::values::positive)]
    pub(crate) watchdog_ms: Option<f64>,
    /// Sensor frames per second (default: one per physics step, as drives report at their bus rate).
    #[arg(long, value_parser = crate::cli::values::positive)]
    pub(crate) frame_hz: Option<f64>,
    /// Seed of the simulation's and the network's draws.
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
    /// Stop after this long, s (default: run until interrupted; ignored by the experiments, which take their own
    /// time).
    #[arg(long, value_parser = crate::cli::values::positive)]
    pub(crate) seconds: Option<f64>,
    /// Run the tracking experiment through the controller, acting as its operator: the six commands, one run each.
    #[arg(long)]
    pub(crate) tracking: bool,
    /// Push the torso through the controller, on a zero command: these force magnitudes, N, each along +x, −x,
    /// +y, −y, one run each (the cells of `topa eval push`'s grid on its axes).
    #[arg(long, value_delimiter = ',', conflicts_with = "tracking")]
    pub(crate) push: Option<Vec<f64>>,
    /// Drive this course through the controller, acting as its operator (as `topa eval course` does): one run per
    /// top speed of --speeds.
    #[arg(long, conflicts_with_all = ["tracking", "push"])]
    pub(crate) course: Option<PathBuf>,
    /// Top speeds of --course, m/s (within the policy's forward command range).
    #[arg(long, value_delimiter = ',', default_value = "0.7", requires = "course")]
    pub(crate) speeds: Vec<f64>,
    /// Seconds per command of --tracking (after settling), or per push.
    #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 10.0)]
    pub(crate) window: f64,
    /// The operator's socket of --tracking, --push and --course.
    #[arg(long, default_value = "127.0.0.1:7703")]
    pub(crate) operator_listen: SocketAddr,
    /// The controller's operator socket (its --operator-listen).
    #[arg(long, default_value = "127.0.0.1:7702")]
    pub(crate) operator: SocketAddr,
    /// Write the results and the wire's counters as JSON here, and the Markdown page beside it (.md).
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// The in-process result to set beside (the tracking.json of `topa eval tracking`, the push.json of `topa eval
    /// push`, or the course.json of `topa eval course`, on the same policy and sim2sim mode).
    #[arg(long)]
    pub(crate) compare: Option<PathBuf>,
}

/// The robot-side controller on a robot on the wire (a real robot's bridge, or `topa sim-robot`).
#[derive(Args)]
pub(crate) struct ControlArgs {
    /// The controller file's folder (`topa export --policy P --controller DIR`).
    #[arg(long)]
    pub(crate) controller: PathBuf,
    /// This controller's socket.
    #[arg(long, default_value = "127.0.0.1:7701")]
    pub(crate) listen: SocketAddr,
    /// The other side's socket: the robot's.
    #[arg(long, alias = "robot", default_value = "127.0.0.1:7700")]
    pub(crate) peer: SocketAddr,
    #[command(flatten)]
    pub(crate) carriage: CarriageArgs,
    /// The socket operator messages come to (velocity command, stop, reset, start).
    #[arg(long, default_value = "127.0.0.1:7702")]
    pub(crate) operator_listen: SocketAddr,
    /// The operator's socket (the only sender accepted there).
    #[arg(long, default_value = "127.0.0.1:7703")]
    pub(crate) operator: SocketAddr,
    /// Start at once: soft start on the first sensor frame, then the policy.
    #[arg(long)]
    pub(crate) start: bool,
    /// The velocity command to start with, v_x,v_y,w_z (m/s, m/s, rad/s).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, default_value = "0,0,0")]
    pub(crate) command: Vec<f64>,
    /// Stop (damping) and exit after this long, s (default: run until interrupted).
    #[arg(long, value_parser = crate::cli::values::positive)]
    pub(crate) seconds: Option<f64>,
    /// Drive from the terminal's keys (w/s a/d q/e steps, g start, space stop, r reset).
    #[arg(long)]
    pub(crate) keyboard: bool,
    /// Drive from a gamepad (left stick v_x / v_y, right stick w_z, A start, B stop, Y reset); with --keyboard,
    /// the newest of the two wins.
    #[arg(long)]
    pub(crate) gamepad: bool,
    /// Record what the controller saw and sent as MCAP (Foxglove): /sensors, /command, /operator.
    #[arg(long)]
    pub(crate) record: Option<PathBuf>,
}
