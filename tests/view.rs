//! The live viewer in a real window on a virtual display (Xvfb): the window is not blank, the robot is drawn where
//! its torso is, keys sent as window events change the measured velocity, Ctrl+drag pulls the torso. (Without a
//! display `topa view` writes a GIF: tests/video.rs.)

use std::path::PathBuf;
use std::process::{Child, Command, Stdio};

use topa_eval::settings::EvalSettings;
use topa_view::glfw::{Action, Key, Modifiers, MouseButton, WindowEvent};
use topa_view::session::Ground;
use topa_view::{Session, Viewer};

fn policy() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/policies/CA/seed1.json")
}

/// An Xvfb display of its own for this test process; killed on drop.
struct VirtualDisplay(Child);

impl VirtualDisplay {
    fn start() -> (VirtualDisplay, String) {
        let n = 100 + std::process::id() % 800;
        let name = format!(":{n}");
        let child = Command::new("Xvfb")
            .args([name.as_str(), "-screen", "0", "800x600x24", "-nolisten", "tcp"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb (the virtual display the viewer's test draws into): run scripts/setup.sh");
        // Ready when its socket exists.
        let socket = format!("/tmp/.X11-unix/X{n}");
        for _ in 0..100 {
            if std::path::Path::new(&socket).exists() {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
        (VirtualDisplay(child), name)
    }
}

impl Drop for VirtualDisplay {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn key(v: &mut Viewer, k: Key) {
    v.handle(WindowEvent::Key(k, 0, Action::Press, Modifiers::empty())).unwrap();
}

fn frames(v: &mut Viewer, n: usize) {
    for _ in 0..n {
        v.frame(true).unwrap();
    }
}

// One test: GLFW is one library state per process, and the steps build on each other.
#[test]
fn the_viewer_draws_the_robot_and_obeys_keys_and_mouse() {
    let (_x, display) = VirtualDisplay::start();
    // Before any other thread of this test process reads the environment (one test in this binary).
    std::env::set_var("DISPLAY", &display);
    let session = Session::new(&policy(), &EvalSettings::default(), &Ground::Flat, [0.0; 3]).unwrap();
    let mut v = Viewer::open(session, (480, 360), mujoco::render::Quality::Fast, "test").unwrap();

    // Standing on a zero command for 2 s.
    frames(&mut v, 60);
    let still = v.session.shown_velocity();
    assert!(still[0].abs() < 0.1, "standing: v_x {still:?}");

    // The window is not blank: many colours, and the robot is where its torso projects.
    let (rgb, (w, h)) = v.pixels();
    assert_eq!((w, h), (480, 360));
    let mut colours: Vec<u32> = rgb.chunks_exact(3).map(|p| u32::from_le_bytes([p[0], p[1], p[2], 0])).collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(colours.len() > 50, "a blank window: {} colours", colours.len());
    let env = v.session.env();
    let torso = env.indices().torso_body;
    let (px, py) = v.project(env.data().xpos()[torso]).expect("the torso is in front of the camera");
    let (px, py) = (px.round() as usize, py.round() as usize);
    assert!(px < w && py < h, "the torso projects to ({px}, {py}), outside the window");
    let model = v.session.env().data().model_arc().clone();
    let g = v.geom_at(px, py).unwrap().expect("a geom is drawn at the torso's pixel");
    assert_ne!(model.geom_bodyid()[g], 0, "the torso's pixel shows the floor, not the robot");
    assert_eq!(v.geom_at(w / 2, 2).unwrap(), None, "the top row is sky");

    // Five W presses: 0.5 m/s forward; after 3 s the measured velocity follows.
    for _ in 0..5 {
        key(&mut v, Key::W);
    }
    assert_eq!(v.session.controls.command, [0.5, 0.0, 0.0]);
    frames(&mut v, 90);
    let walk = v.session.shown_velocity();
    assert!(walk[0] > 0.35, "walking after W×5: v_x {walk:?}");

    // Stop, then turn left (Q×3: 0.6 rad/s).
    key(&mut v, Key::Space);
    for _ in 0..3 {
        key(&mut v, Key::Q);
    }
    frames(&mut v, 90);
    let turn = v.session.shown_velocity();
    assert!(turn[2] > 0.3 && turn[0].abs() < 0.2, "turning after Q×3: {turn:?}");
    assert_eq!(v.session.falls, 0);

    // Ctrl+drag on the torso picks it and pulls it.
    let env = v.session.env();
    let torso_xpos = env.data().xpos()[torso];
    frames(&mut v, 1);
    let (px, py) = v.project(torso_xpos).unwrap();
    v.handle(WindowEvent::CursorPos(px, py)).unwrap();
    v.handle(WindowEvent::MouseButton(MouseButton::Button2, Action::Press, Modifiers::Control)).unwrap();
    assert_eq!(v.dragged(), Some(torso), "Ctrl+right press on the torso picks the torso");
    v.handle(WindowEvent::CursorPos(px + 60.0, py)).unwrap();
    frames(&mut v, 3);
    let pull = v.session.env().data().xfrc_applied()[torso];
    assert!(pull[..3].iter().map(|f| f * f).sum::<f64>().sqrt() > 1.0, "the spring pulls the torso: {pull:?}");
    v.handle(WindowEvent::MouseButton(MouseButton::Button2, Action::Release, Modifiers::Control)).unwrap();
    assert_eq!(v.dragged(), None);

    // Reset puts it back and counts; P pauses the clock.
    key(&mut v, Key::R);
    assert_eq!((v.session.resets, v.session.time()), (1, 0.0));
    key(&mut v, Key::P);
    frames(&mut v, 5);
    assert_eq!(v.session.time(), 0.0, "paused");
}
