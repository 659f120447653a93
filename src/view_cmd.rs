//! `topa view`: the live viewer, or without a display a GIF of the same walk.

use std::path::PathBuf;

use anyhow::{ensure, Result};
use topa_eval::play;
use topa_view::session::Ground;

use crate::cli::view::ViewArgs;

/// The GIF's walk when `--seconds` does not say, s.
const GIF_SECONDS: f64 = 8.0;

/// The GIF written when there is no display and no `--gif`.
const HEADLESS_GIF: &str = "topa-walk.gif";

pub(crate) fn run(a: ViewArgs) -> Result<()> {
    trainer::nn::init_threads(1)?;
    ensure!(a.command.len() == 3, "--command takes three numbers v_x,v_y,w_z, got {}", a.command.len());
    let command = [a.command[0], a.command[1], a.command[2]];
    let settings = a.sim.settings()?;
    // From any folder (after `cargo install`): a relative policy path not found here is the repository's.
    let policy = topa_env::assets::resolve_path(&a.policy.to_string_lossy());
    let gif = match (&a.gif, topa_view::has_display()) {
        (Some(g), _) => Some(g.clone()),
        (None, false) => {
            eprintln!("no display (DISPLAY is not set): writing the walk to {HEADLESS_GIF} instead of a window");
            Some(PathBuf::from(HEADLESS_GIF))
        }
        (None, true) => None,
    };
    if let Some(gif) = gif {
        ensure!(
            a.frames.is_none() && a.screenshot.is_none(),
            "--frames and --screenshot are the window's: drop them with --gif"
        );
        let o = play::PlayOptions {
            command,
            seconds: a.seconds.unwrap_or(GIF_SECONDS),
            video: Some(gif),
            video_size: (a.size.width.min(640), a.size.height.min(480)),
            fps: 20,
            quality: Some(a.quality.into()),
            ..Default::default()
        };
        let s = play::run(&policy, &o, &settings)?;
        let fall = s.fell_at_s.map_or("no fall".to_string(), |t| format!("fell at {t:.1} s"));
        if let Some(v) = &s.video {
            println!(
                "{}: {} frames, {} walking at ({:.2}, {:.2}, {:.2}), {fall}",
                v.display(),
                s.video_frames,
                policy.display(),
                command[0],
                command[1],
                command[2]
            );
        }
        return Ok(());
    }
    let ground = match (&a.course, a.tile) {
        (Some(c), _) => Ground::Course(c.clone(), a.speed),
        (None, Some(k)) => Ground::Tile(k, a.level as usize - 1),
        (None, None) => Ground::Flat,
    };
    ensure!(a.seconds.is_none(), "--seconds is the GIF's length: add --gif FILE, or drop it for the window");
    let session = topa_view::Session::new(&policy, &settings, &ground, command)?;
    let title = format!("topa view — {}", policy.display());
    let mut viewer = topa_view::Viewer::open(session, (a.size.width, a.size.height), a.quality.into(), &title)?;
    let frames = viewer.run(a.frames)?;
    if let Some(p) = &a.screenshot {
        viewer.screenshot(p)?;
        println!("screenshot: {} (after {frames} frames)", p.display());
    }
    let s = &viewer.session;
    println!("{:.1} s simulated; falls {}, resets {}", s.time(), s.falls, s.resets);
    Ok(())
}
