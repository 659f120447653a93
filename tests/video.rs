//! Rendering by MuJoCo itself on a machine without a display: the standing robot is in the picture where the
//! camera looks, frames are not blank, a video has the right number of frames, and a machine without the GL
//! libraries gets told what to install.

use std::path::Path;
use std::process::Command;

use mujoco::render::Renderer;
use topa_env::{assets, EnvConfig, ModelKind, RobotEnv, Task};
use topa_eval::play::{self, PlayOptions};
use topa_eval::settings::EvalSettings;
use topa_eval::video::GlContext;

fn tempdir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("topa-video-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn the_standing_robot_fills_the_middle_of_the_frame() {
    let _gl = GlContext::headless(320, 240).expect("headless OpenGL (EGL)");
    let model = assets::load_model(ModelKind::Closed).unwrap();
    let mut env = RobotEnv::new(model.clone(), std::sync::Arc::new(EnvConfig::default()), 1, 0).unwrap();
    let mut obs = vec![0.0f32; 42];
    env.reset(&mut obs).unwrap();
    let mut r = Renderer::new(model.clone(), 320, 240, mujoco::render::Quality::High).unwrap();
    r.track(env.indices().torso_body, 1.8, 150.0, -15.0);
    let frame = r.render(env.data_mut(), Some(("time", "0.00 s"))).unwrap().to_vec();
    assert_eq!(frame.len(), 320 * 240 * 3);
    // Not blank: the picture has many distinct colours (floor checker, robot shells, shading).
    let mut colours: Vec<[u8; 3]> = frame.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    colours.sort();
    colours.dedup();
    assert!(colours.len() > 50, "only {} distinct colours", colours.len());
    // The torso's origin, projected through the camera, lands on one of the torso's own geoms.
    let torso = env.indices().torso_body;
    let (px, py) = r.project(env.data().xpos()[torso]).expect("the torso is in front of the camera");
    assert!((0.0..320.0).contains(&px) && (0.0..240.0).contains(&py), "torso at ({px}, {py})");
    let g = r.geom_at(env.data_mut(), px as usize, py as usize).unwrap().expect("robot pixels, not background");
    assert_eq!(model.geom_bodyid()[g] as usize, torso, "the torso's pixel shows geom {g}");
    // A corner shows the floor or the sky, not the robot.
    let corner = r.geom_at(env.data_mut(), 2, 237).unwrap();
    assert!(corner.is_none_or(|g| model.geom_bodyid()[g] == 0), "corner: {corner:?}");
}

#[test]
fn a_robot_with_collision_geometry_only_is_drawn() {
    // Cassie is vendored without its visual meshes: its geoms are all in the collision group MuJoCo hides.
    let _gl = GlContext::headless(320, 240).expect("headless OpenGL (EGL)");
    let spec = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/robots/cassie.toml"));
    let (_, model) = topa_env::spec::RobotSpec::load(spec).unwrap();
    let model = std::sync::Arc::new(model);
    let mut data = mujoco::Data::new(model.clone()).unwrap();
    data.forward().unwrap();
    let pelvis = (1..model.raw().nbody as usize).next().unwrap();
    let mut r = Renderer::new(model.clone(), 320, 240, mujoco::render::Quality::Fast).unwrap();
    r.track(pelvis, 2.5, 150.0, -15.0);
    r.render(&mut data, None).unwrap();
    let (px, py) = r.project(data.xpos()[pelvis]).unwrap();
    let g = r.geom_at(&mut data, px as usize, py as usize).unwrap().expect("the pelvis is drawn");
    assert_ne!(model.geom_bodyid()[g], 0, "the pelvis's pixel shows the floor");
}

#[test]
fn a_video_of_n_seconds_has_n_times_fps_frames() {
    let dir = tempdir("frames");
    let out = dir.join("stand.gif");
    let policy = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/policies/C/seed1.json"));
    let settings = EvalSettings { settle_s: 1.0, ..EvalSettings::default() };
    let o = PlayOptions {
        command: [0.3, 0.0, 0.0],
        seconds: 1.0,
        video: Some(out.clone()),
        video_size: (160, 120),
        fps: 10,
        ..Default::default()
    };
    let s = play::run(policy, &o, &settings).unwrap();
    assert_eq!(s.video_frames, 20, "2 s (1 s settling + 1 s) at 10 fps");
    let mut decoder = gif::DecodeOptions::new().read_info(std::fs::File::open(&out).unwrap()).unwrap();
    let mut frames = 0;
    while let Some(f) = decoder.read_next_frame().unwrap() {
        assert_eq!((f.width, f.height, f.delay), (160, 120, 10));
        frames += 1;
    }
    assert_eq!(frames, 20);
    assert!(!out.with_extension("gif.tmp").exists(), "no temporary file left");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn without_gl_libraries_the_command_says_what_to_install() {
    // A libEGL that is not a library stands for a machine without EGL.
    let dir = tempdir("nogl");
    std::fs::write(dir.join("libEGL.so.1"), b"not a library").unwrap();
    std::fs::write(dir.join("libEGL.so"), b"not a library").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_topa"))
        .args(["play", "--policy", concat!(env!("CARGO_MANIFEST_DIR"), "/assets/policies/C/seed1.json")])
        .args(["--seconds", "0.1", "--video"])
        .arg(dir.join("x.gif"))
        .env("LD_LIBRARY_PATH", &dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "a clean error exit, not a crash: {err}");
    assert!(err.contains("apt-get install") && err.contains("libegl1"), "{err}");
    assert!(!dir.join("x.gif").exists() && !dir.join("x.gif.tmp").exists());
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn without_a_display_view_writes_a_gif() {
    let dir = std::env::temp_dir().join(format!("topa-view-gif-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_topa"))
        .args(["view", "--seconds", "1", "--size", "160x120", "--policy"])
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/policies/CA/seed1.json"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let gif = dir.join("topa-walk.gif");
    let mut d = gif::DecodeOptions::new().read_info(std::fs::File::open(&gif).unwrap()).unwrap();
    let mut n = 0;
    while d.read_next_frame().unwrap().is_some() {
        n += 1;
    }
    let settle = topa_eval::settings::EvalSettings::default().settle_s;
    assert_eq!(n, ((settle + 1.0) * 20.0).round() as usize, "the settling and 1 s at 20 frames a second");
    let _ = std::fs::remove_dir_all(&dir);
}
