use std::path::PathBuf;

use clap::Subcommand;

#[derive(Subcommand)]
pub(crate) enum RobotCmd {
    /// Make a robot of a published MJCF, left untouched: writes a derived MJCF beside it (NAME.topa.xml: floor, PD
    /// actuators, IMU, sole sites, the stand keyframe with its loops closed) and the drafted spec
    /// (ROBOTS_DIR/NAME.toml: loops, springs, motors, mirror pairs, feet, groups, feed-forward).
    Import {
        /// The published MJCF (the robot's own file, not a scene that includes it).
        model: PathBuf,
        /// The robot's name (letters, digits, '-', '_').
        #[arg(long)]
        name: String,
        /// Where the spec goes.
        #[arg(long, default_value = "assets/robots")]
        robots_dir: PathBuf,
        /// PD gains of torque motors: kp reaches the motor's torque limit at this error, rad.
        #[arg(long, default_value_t = 1.0)]
        kp_saturation: f64,
        /// PD gains of torque motors: damping ratio on the joint's inertia at the stand pose.
        #[arg(long, default_value_t = 0.5)]
        damping_ratio: f64,
    },
    /// Solve a spec's stand keyframe (loops closed, feet on the floor; written into its MJCF) and the gravity
    /// feed-forward that holds it (MuJoCo's inverse dynamics; written into the spec).
    Stand {
        /// The robot spec.
        spec: PathBuf,
    },
}
