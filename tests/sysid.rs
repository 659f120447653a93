//! Actuator identification end to end on a bench that does not exist: hidden values 30–50 % off the model's,
//! a multisine through the drives' PD loops, encoder quantisation and noise — and the fit must find the values
//! back, with intervals and a held-out error at the noise floor. Then the ways a log or a bench can be wrong.

use std::path::{Path, PathBuf};

use topa_sysid::bench::Bench;
use topa_sysid::excite::{self, CommandKind, Design, Shape};
use topa_sysid::fit::{FitOptions, Kind};
use topa_sysid::identify::{self, Plan};
use topa_sysid::log::MotorLog;
use topa_sysid::synthetic::{self, SensorModel};

const BENCH: &str = "assets/mjcf/benches/topa_motors.xml";

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn tempdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("topa-sysid-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const MOTORS: [(&str, f64); 10] = [
    ("l_hip_roll", 0.0),
    ("l_hip_yaw", 0.0),
    ("l_hip_pitch", -0.3),
    ("l_knee_motor", 0.6),
    ("l_ankle_motor", 0.3),
    ("r_hip_roll", 0.0),
    ("r_hip_yaw", 0.0),
    ("r_hip_pitch", -0.3),
    ("r_knee_motor", 0.6),
    ("r_ankle_motor", 0.3),
];

/// A multisine for every motor of the bench, written as `topa sysid excite` writes it, and read back.
fn excitation(dir: &Path, seconds: f64) -> MotorLog {
    let d = Design {
        shape: Shape::Multisine,
        amplitude: 0.2,
        band: [0.5, 15.0],
        duration_s: seconds,
        rate_hz: 500.0,
        fade_s: 1.0,
        seed: 3,
    };
    let motors: Vec<(String, f64)> = MOTORS.iter().map(|(n, q)| (n.to_string(), *q)).collect();
    let f = dir.join("excite.csv");
    std::fs::write(&f, excite::csv(&d, CommandKind::Position, &motors)).unwrap();
    synthetic::read_excitation(&f).unwrap()
}

fn options(kinds: &[Kind], max_evaluations: usize) -> FitOptions {
    FitOptions { kinds: kinds.to_vec(), window: 0, max_delay: 0.02, range: 5.0, max_evaluations }
}

#[test]
fn hidden_motor_parameters_are_found_back_within_their_bounds() {
    let dir = tempdir("recover");
    let mut exc = excitation(&dir, 16.0);
    let mut bench = Bench::load(&root().join(BENCH), &exc).unwrap();
    synthetic::drive_gains_from_model(&bench, &mut exc);
    let start = bench.nominal();
    let truth = synthetic::hidden(&start, 11);
    let sensors = SensorModel { counts_per_rev: 16384.0, position_noise: 2e-4, seed: 5 };
    let log = synthetic::record(&bench, &exc, &truth, &sensors).unwrap();
    bench.burn_in = 50;
    let plan = Plan {
        bench: &bench,
        log: &log,
        log_path: Path::new("synthetic.csv"),
        held_out: None,
        held_out_fraction: 0.25,
        window_s: 4.0,
        options: options(&Kind::ALL, 3000),
        start,
        truth: Some(truth.clone()),
    };
    let id = identify::identify(&plan).unwrap();
    assert!(id.fit.converged, "{}", id.fit.termination);
    let check = id.truth.as_ref().unwrap();
    for e in &check.errors {
        let bound = match e.kind {
            Kind::Frictionloss => 0.10,
            Kind::Delay => 1.0, // physics steps
            _ => 0.05,
        };
        assert!(e.error.abs() <= bound, "{:?} of motor {}: error {:+.4} beyond ±{bound}", e.kind, e.motor, e.error);
    }
    // Most true values inside their 95 % intervals (41 of them: a few may fall out by chance or by the small bias
    // that noisy initial states leave).
    let inside = check.errors.iter().filter(|e| e.in_ci).count();
    assert!(
        inside * 10 >= check.errors.len() * 8,
        "{inside} of {} true values inside their intervals",
        check.errors.len()
    );
    // Held out: at the floor the true values themselves reach, and far below the start values.
    assert!(id.held_out_rmse <= 1.2 * check.held_out_floor, "{} vs floor {}", id.held_out_rmse, check.held_out_floor);
    assert!(id.held_out_rmse_start > 10.0 * id.held_out_rmse);
    assert!(check.held_out_floor < 2.0 * sensors.floor());

    // The identified MJCF is a new file MuJoCo loads, with the values in it.
    let xml = dir.join("identified.xml");
    identify::write_patched_mjcf(&root().join(BENCH), &id.fit.params, &id.motors, &xml).unwrap();
    // (MuJoCo writes six significant digits; the torque constant goes into the PD gains.)
    let patched = Bench::load(&xml, &log).unwrap();
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-5 * b.abs();
    for (m, (p, f)) in patched.nominal().motors.iter().zip(&id.fit.params.motors).enumerate() {
        assert!(close(p.armature, f.armature) && close(p.damping, f.damping), "{p:?} vs {f:?}");
        assert!(close(p.frictionloss, f.frictionloss), "{p:?} vs {f:?}");
        let (kp, kd) = (patched.pd_gains(m), bench.pd_gains(m));
        assert!(close(kp.0, kd.0 * f.torque_constant) && close(kp.1, kd.1 * f.torque_constant), "{kp:?} {kd:?}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_fit_cut_short_says_so_and_keeps_its_best_values() {
    let dir = tempdir("short");
    let mut exc = excitation(&dir, 6.0);
    let bench = Bench::load(&root().join(BENCH), &exc).unwrap();
    synthetic::drive_gains_from_model(&bench, &mut exc);
    let start = bench.nominal();
    let truth = synthetic::hidden(&start, 2);
    let sensors = SensorModel { counts_per_rev: 16384.0, position_noise: 0.0, seed: 1 };
    let log = synthetic::record(&bench, &exc, &truth, &sensors).unwrap();
    let plan = Plan {
        bench: &bench,
        log: &log,
        log_path: Path::new("synthetic.csv"),
        held_out: None,
        held_out_fraction: 0.2,
        window_s: 2.0,
        options: options(&[Kind::Delay, Kind::Damping], 2),
        start,
        truth: None,
    };
    let id = identify::identify(&plan).unwrap();
    assert!(!id.fit.converged);
    assert!(id.fit.termination.contains("LostPatience"), "{}", id.fit.termination);
    assert!(id.fit.rmse < id.fit.rmse_start, "the best values so far are kept");
    assert!(identify::markdown(&id).contains("**Did not converge**"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn logs_that_do_not_fit_the_bench_are_refused_naming_the_fix() {
    let dir = tempdir("bad");
    let exc = excitation(&dir, 3.0);
    let bench = root().join(BENCH);
    // A motor the bench does not have.
    let mut wrong = exc.clone();
    wrong.motors[2].name = "l_hip_pitchh".into();
    let e = format!("{:#}", Bench::load(&bench, &wrong).err().unwrap());
    assert!(e.contains("motor l_hip_pitchh of the log is not an actuator") && e.contains("l_hip_pitch,"), "{e}");
    // A motor of the bench missing from the log.
    let mut fewer = exc.clone();
    fewer.motors.pop();
    let e = format!("{:#}", Bench::load(&bench, &fewer).err().unwrap());
    assert!(e.contains("actuator r_ankle_motor of") && e.contains("has no columns in the log"), "{e}");
    // A sample step the timestep does not divide.
    let mut odd = exc.clone();
    odd.time.iter_mut().for_each(|t| *t *= 1.25);
    let e = format!("{:#}", Bench::load(&bench, &odd).err().unwrap());
    assert!(e.contains("not a whole number of the bench's timestep"), "{e}");
    // A missing bench and a malformed one.
    let e = format!("{:#}", anyhow::Error::from(Bench::load(&dir.join("none.xml"), &exc).err().unwrap()));
    assert!(e.contains("none.xml"), "{e}");
    std::fs::write(dir.join("broken.xml"), "<mujoco><worldbody><body></mujoco>").unwrap();
    let e = format!("{:#}", anyhow::Error::from(Bench::load(&dir.join("broken.xml"), &exc).err().unwrap()));
    assert!(e.contains("broken.xml"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

mod estimator_tuning {
    use super::*;
    use topa_env::policy_runner::PolicyRunner;
    use topa_eval::settings::{EvalSettings, Sim2SimMode};
    use topa_sysid::estimator;

    #[test]
    fn the_filter_replays_exactly_and_tuning_lowers_the_held_out_velocity_error() {
        let dir = tempdir("estimator");
        let mut runner = PolicyRunner::load(&root().join("assets/policies/C/seed1.json"), "C").unwrap();
        let s = EvalSettings { seed: 3, threads: 1, ..EvalSettings::default() }
            .with_sim2sim(&Sim2SimMode::Realistic)
            .unwrap();
        let fit = estimator::record(&mut runner, &s, 6.0).unwrap();
        let held = estimator::record(&mut runner, &EvalSettings { seed: 4, ..s.clone() }, 6.0).unwrap();
        assert!(fit.len() > 3000, "{} filter steps", fit.len());
        // The replay with the recording's own settings is the filter that ran.
        let default = s.sim2sim.estimator.filter.clone();
        let again = estimator::replay(&default, &fit);
        let worst = again.iter().zip(&fit).map(|(a, x)| (a - x.estimate).norm()).fold(0.0, f64::max);
        assert!(worst < 1e-9, "replay differs from the online filter by {worst} m/s");
        let t = estimator::tune(&default, &fit, &held).unwrap();
        assert!(t.fit_rmse[1] < 0.8 * t.fit_rmse[0], "{:?}", t.fit_rmse);
        assert!(t.held_out_rmse[1] < 0.8 * t.held_out_rmse[0], "{:?}", t.held_out_rmse);

        // The CSV carries what the tuning needs: the same replay from the file (the first row starts the filter).
        let f = dir.join("rec.csv");
        std::fs::write(&f, estimator::to_csv(&held)).unwrap();
        let back = estimator::read_csv(&f).unwrap();
        assert_eq!(back.len(), held.len());
        let (a, b) = (estimator::replay(&t.tuned, &held), estimator::replay(&t.tuned, &back));
        assert!((estimator::rmse(&a, &held) - estimator::rmse(&b, &back)).abs() < 2e-3);

        // Bad recordings: a missing column, a NaN.
        let text = std::fs::read_to_string(&f).unwrap();
        std::fs::write(&f, text.replacen(",restart_height", "", 1)).unwrap();
        let e = format!("{:#}", estimator::read_csv(&f).unwrap_err());
        assert!(e.contains("expected the columns"), "{e}");
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        let mut fields: Vec<String> = lines[5].split(',').map(String::from).collect();
        fields[1] = "NaN".into();
        lines[5] = fields.join(",");
        std::fs::write(&f, lines.join("\n")).unwrap();
        let e = format!("{:#}", estimator::read_csv(&f).unwrap_err());
        assert!(e.contains("row 5, column accel_x: NaN"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
