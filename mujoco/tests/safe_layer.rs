//! mujoco-sys against small MJCF fixtures: physics, loop closure, errors that must not kill the process, threads.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use mujoco::{Data, Model, MujocoError, ObjType, Warning};
use rayon::prelude::*;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures").join(name)
}

fn load(name: &str) -> Arc<Model> {
    Arc::new(Model::from_xml_path(fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}")))
}

#[test]
fn pendulum_small_angle_period_matches_theory() {
    let model = load("pendulum.xml");
    let mut d = Data::new(model.clone()).unwrap();
    let hinge = model.jnt_qposadr_of(model.id(ObjType::Joint, "swing").unwrap());
    d.qpos_mut()[hinge] = 0.02; // small angle: the finite-amplitude correction is θ²/16 ≈ 2.5e-5
                                // Times of downward zero crossings of the angle, linearly interpolated between steps.
    let mut crossings = Vec::new();
    let mut prev = (d.time(), d.qpos()[hinge]);
    while crossings.len() < 4 {
        d.step().unwrap();
        let cur = (d.time(), d.qpos()[hinge]);
        if prev.1 > 0.0 && cur.1 <= 0.0 {
            crossings.push(prev.0 + (cur.0 - prev.0) * prev.1 / (prev.1 - cur.1));
        }
        prev = cur;
        assert!(d.time() < 20.0, "pendulum never swung");
    }
    let period = (crossings[3] - crossings[0]) / 3.0;
    let theory = 2.0 * std::f64::consts::PI * (1.0f64 / 9.81).sqrt();
    let rel = (period - theory).abs() / theory;
    assert!(rel < 0.01, "period {period:.5} s vs 2π√(L/g) = {theory:.5} s (rel. error {rel:.2e})");
}

#[test]
fn four_bar_loop_stays_closed_while_driven() {
    let model = load("fourbar.xml");
    let eq = model.id(ObjType::Equality, "loop").unwrap();
    let mut d = Data::new(model.clone()).unwrap();
    let mut worst: f64 = 0.0;
    let mut crank_travel: f64 = 0.0;
    while d.time() < 2.0 {
        d.ctrl_mut()[0] = 0.2 * (3.0 * d.time()).sin();
        d.step().unwrap();
        worst = worst.max(d.equality_residual(eq));
        crank_travel = crank_travel.max(d.qpos()[0].abs());
    }
    assert!(crank_travel > 0.2, "the actuator did not move the linkage (max crank angle {crank_travel})");
    assert!(worst < 1e-4, "loop-closure residual reached {worst:.3e} m");
    eprintln!("four-bar: max residual {worst:.3e} m, max crank angle {crank_travel:.3} rad");
    // The residual the engine reports is the real geometric gap between the two anchor points.
    let d_free = Data::new(model.clone()).unwrap();
    assert_eq!(d_free.equality_residual(eq), 0.0, "no constraint rows before the first forward");
}

#[test]
fn malformed_xml_is_an_error_with_mujocos_line_info() {
    let err = Model::from_xml_path(fixture("malformed.xml")).err().expect("malformed XML must not load");
    let msg = err.to_string();
    assert!(matches!(err, MujocoError::Load { .. }), "{err:?}");
    assert!(msg.contains("Line number=3") || msg.contains("line 3"), "no line info in: {msg}");
    assert!(msg.contains("malformed.xml"), "error must name the file: {msg}");
}

#[test]
fn missing_file_is_an_error_naming_it() {
    let err = Model::from_xml_path("/no/such/model.xml").err().unwrap();
    assert!(matches!(err, MujocoError::MissingFile { .. }), "{err:?}");
    assert!(err.to_string().contains("/no/such/model.xml"));
}

#[test]
fn unknown_names_are_errors_naming_the_object() {
    let model = load("fourbar.xml");
    for kind in ObjType::ALL {
        let err = model.id(kind, "no_such_thing").unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("no_such_thing") && msg.contains(&kind.to_string()) && msg.contains("fourbar"), "{msg}");
    }
    let msg = model.id(ObjType::Joint, "crnak").unwrap_err().to_string();
    assert!(msg.contains("crank"), "the error should list the joints that exist: {msg}");
    assert_eq!(model.id(ObjType::Joint, "rocker").unwrap(), 2);
    assert_eq!(model.id(ObjType::Actuator, "drive").unwrap(), 0);
}

#[test]
fn xml_string_loads_through_vfs_with_includes_from_base_dir() {
    let dir = tempdir();
    std::fs::write(
        dir.join("part.xml"),
        r#"<mujoco><body name="included" pos="0 0 1"><freejoint/><geom type="sphere" size="0.1" mass="2"/></body></mujoco>"#,
    )
    .unwrap();
    let xml = r#"<mujoco model="from_string"><worldbody><include file="part.xml"/></worldbody></mujoco>"#;
    let m = Model::from_xml_string(xml, &dir).unwrap();
    assert_eq!(m.name(), "from_string");
    assert!((m.total_mass() - 2.0).abs() < 1e-12);
    assert!(m.id(ObjType::Body, "included").is_ok());
    let err =
        Model::from_xml_string("<mujoco><worldbody><geom type=\"nope\"/></worldbody></mujoco>", &dir).err().unwrap();
    assert!(err.to_string().contains("nope") || err.to_string().contains("type"), "{err}");
    std::fs::remove_dir_all(dir).ok();
}

fn tempdir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("topa-test-{}-{:?}", std::process::id(), std::thread::current().id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Steps until `mj_step` fails; returns (steps that succeeded, the error).
fn step_until_error(d: &mut Data, max: usize) -> (usize, Option<MujocoError>) {
    for i in 0..max {
        if let Err(e) = d.step() {
            return (i, Some(e));
        }
    }
    (max, None)
}

#[test]
fn fatal_error_in_step_is_err_and_data_recovers_while_other_threads_run() {
    let overflow = load("stack_overflow.xml");
    let healthy = load("pendulum.xml");
    // Reference trajectory for the healthy model, stepped alone.
    let reference = {
        let mut d = Data::new(healthy.clone()).unwrap();
        d.qpos_mut()[0] = 0.3;
        for _ in 0..20000 {
            d.step().unwrap();
        }
        d.qpos().to_vec()
    };
    let bystander = std::thread::spawn({
        let healthy = healthy.clone();
        move || {
            let mut d = Data::new(healthy).unwrap();
            d.qpos_mut()[0] = 0.3;
            for _ in 0..20000 {
                d.step().expect("a bystander thread must never see another thread's error");
            }
            d.qpos().to_vec()
        }
    });
    let mut d = Data::new(overflow.clone()).unwrap();
    for round in 0..3 {
        let (ok_steps, err) = step_until_error(&mut d, 2000);
        let err = err.unwrap_or_else(|| panic!("round {round}: the tiny stack never overflowed"));
        assert!(ok_steps > 10, "stepping in the air should work before contact (got {ok_steps} steps)");
        // MuJoCo's "Stack overflow" becomes a capacity error that names the MJCF attribute to raise.
        assert!(matches!(err, MujocoError::Capacity { call: "mj_step", attribute: "nstack", .. }), "{err:?}");
        assert!(err.to_string().contains("raise `nstack`"), "the error must name the fix: {err}");
        d.reset().unwrap();
        assert_eq!(d.time(), 0.0);
        for _ in 0..5 {
            d.step().expect("after reset the Data steps again");
        }
    }
    assert_eq!(bystander.join().unwrap(), reference);
    assert!(!std::path::Path::new("MUJOCO_LOG.TXT").exists(), "MuJoCo must not write its log file");
}

#[test]
fn contacts_or_constraint_rows_beyond_the_size_are_errors_never_silent_truncation() {
    for (file, attribute, limit) in [("contact_overflow.xml", "nconmax", 3), ("constraint_overflow.xml", "njmax", 6)] {
        let mut d = Data::new(load(file)).unwrap();
        let (ok_steps, err) = step_until_error(&mut d, 2000);
        let err = err.unwrap_or_else(|| panic!("{file}: the boxes landed without overflowing {attribute}"));
        assert!(ok_steps > 10, "{file}: the boxes fall freely first ({ok_steps} steps)");
        match &err {
            MujocoError::Capacity { attribute: a, limit: l, suggested, .. } => {
                assert_eq!((*a, *l), (attribute, limit), "{err}");
                assert!(*suggested > limit, "the suggested size must be larger: {err}");
            }
            other => panic!("{file}: expected a capacity error, got {other:?}"),
        }
        assert!(err.to_string().contains(&format!("raise `{attribute}`")), "{err}");
    }
    // The same scene with MuJoCo's default sizes lands without error.
    let mut d = Data::new(load("boxes.xml")).unwrap();
    assert_eq!(step_until_error(&mut d, 2000).1, None);
}

#[test]
fn eight_datas_on_a_rayon_pool_match_sequential_bit_for_bit() {
    // Falling, colliding boxes: contacts make the solver's path state-dependent, so any sharing between threads
    // would show up as a difference.
    let model = load("boxes.xml");
    let run = |d: &mut Data, k: usize| {
        d.qvel_mut()[0] = 0.1 * k as f64;
        for _ in 0..400 {
            d.step().unwrap();
        }
    };
    let fresh = || (0..8).map(|_| Data::new(model.clone()).unwrap()).collect::<Vec<_>>();
    let mut seq = fresh();
    for (k, d) in seq.iter_mut().enumerate() {
        run(d, k);
    }
    let mut par = fresh();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    pool.install(|| par.par_iter_mut().enumerate().for_each(|(k, d)| run(d, k)));
    for (a, b) in seq.iter().zip(&par) {
        assert_eq!(a.qpos(), b.qpos());
        assert_eq!(a.qvel(), b.qvel());
    }
    assert_ne!(seq[0].qpos(), seq[1].qpos(), "different controls must give different states");
}

#[test]
fn model_mut_is_copy_on_write_and_set_const_updates_derived_mass() {
    let model = load("fourbar.xml");
    let mut a = Data::new(model.clone()).unwrap();
    let b = Data::new(model.clone()).unwrap();
    let body = model.id(ObjType::Body, "rocker").unwrap();
    let before = model.body_mass()[body];
    a.model_mut().body_mass_mut()[body] *= 2.0;
    a.set_const().unwrap();
    assert_eq!(b.model().body_mass()[body], before, "the shared model must not change");
    assert!((a.model().body_mass()[body] - 2.0 * before).abs() < 1e-12);
    assert!((a.model().body_subtreemass()[body] - 2.0 * before).abs() < 1e-12, "mj_setConst recomputed subtree mass");
    let copy = a.model().try_clone().unwrap();
    assert_eq!(copy.body_mass(), a.model().body_mass());
}

#[test]
fn divergence_is_detected_through_warnings() {
    let model = load("fourbar.xml");
    let mut d = Data::new(model).unwrap();
    d.qvel_mut()[0] = f64::NAN;
    d.step().unwrap();
    assert!(d.is_unstable(), "a NaN velocity must be flagged");
    assert!(d.warning_count(Warning::BadQvel) + d.warning_count(Warning::BadQacc) > 0);
    d.reset().unwrap();
    assert!(!d.is_unstable());
}

#[test]
fn contacts_report_forces_that_hold_up_the_weight() {
    let m = load("boxes.xml");
    let mut d = Data::new(m.clone()).unwrap();
    for _ in 0..1500 {
        d.step().unwrap();
    }
    let normal_sum: f64 = (0..d.contacts().len()).map(|i| d.contact_force(i).unwrap()[0]).sum();
    let weight = m.total_mass() * 9.81;
    assert!((normal_sum - weight).abs() / weight < 0.02, "normal forces {normal_sum:.3} N vs weight {weight:.3} N");
    assert!(d.contact_force(d.contacts().len()).is_err());
}

#[test]
fn a_state_snapshot_continues_the_simulation_bit_for_bit() {
    let m = Arc::new(Model::from_xml_path(fixture("fourbar.xml")).unwrap());
    let mut a = Data::new(m.clone()).unwrap();
    for _ in 0..50 {
        a.step().unwrap();
    }
    let mut snap = Vec::new();
    a.save_state(&mut snap);
    assert_eq!(snap.len(), a.state_len());
    let mut b = Data::new(m).unwrap();
    assert_eq!(b.load_state(&snap).unwrap(), snap.len());
    for _ in 0..100 {
        a.step().unwrap();
        b.step().unwrap();
    }
    assert_eq!(a.qpos(), b.qpos());
    assert_eq!(a.qvel(), b.qvel());
    assert!(b.load_state(&snap[..snap.len() - 1]).unwrap_err().to_string().contains("needs"));
}
