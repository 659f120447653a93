//! `topa view`'s flags.

use std::path::PathBuf;

use clap::Args;

use super::eval::{QualityArg, Simulation};
use super::values::{at_least_one, positive};

#[derive(Args)]
pub(crate) struct ViewArgs {
    /// The policy file (`assets/policies/<group>/seedN.json`, or a `topa train --out` folder's policy.json).
    #[arg(long, default_value = "assets/policies/CA/seed1.json")]
    pub(crate) policy: PathBuf,
    /// Starting command v_x,v_y,w_z (m/s, m/s, rad/s); the keys change it.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, default_value = "0.4,0,0")]
    pub(crate) command: Vec<f64>,
    /// Walk a course (e.g. assets/courses/indoor.toml), its operator driving until a command key takes over.
    #[arg(long, conflicts_with = "tile")]
    pub(crate) course: Option<PathBuf>,
    /// The course operator's top speed, m/s.
    #[arg(long, requires = "course", value_parser = positive, default_value_t = 0.5)]
    pub(crate) speed: f64,
    /// Walk on a terrain tile of this kind (as `topa eval terrain` builds them) instead of flat ground.
    #[arg(long)]
    pub(crate) tile: Option<topa_env::terrain::TileKind>,
    /// The terrain tile's difficulty, 1 (easiest) to 5.
    #[arg(long, requires = "tile", value_parser = clap::value_parser!(u8).range(1..=5), default_value_t = 3)]
    pub(crate) level: u8,
    /// Window size WIDTHxHEIGHT, pixels (a GIF's: at most 640x480).
    #[arg(long, default_value = "960x640")]
    pub(crate) size: topa_eval::video::FrameSize,
    /// fast (no multisampling, shadows or reflections: smooth on a software renderer) or high.
    #[arg(long, default_value = "fast")]
    pub(crate) quality: QualityArg,
    /// Write the walk to this GIF instead of opening a window (the default without a display: topa-walk.gif).
    #[arg(long)]
    pub(crate) gif: Option<PathBuf>,
    /// Length of the GIF's walk, s [default: 8].
    #[arg(long, value_parser = positive)]
    pub(crate) seconds: Option<f64>,
    /// Draw this many frames, each 1/30 s of simulated time however long it takes, then close (scripted runs).
    #[arg(long, value_parser = at_least_one)]
    pub(crate) frames: Option<usize>,
    /// Write the last frame to this PNG when the window closes.
    #[arg(long)]
    pub(crate) screenshot: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) sim: Simulation,
}
