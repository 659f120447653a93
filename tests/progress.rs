//! A run's kept checkpoints as policies: the last checkpoint's export is the run's own policy file byte for byte,
//! an earlier one records its own point in the run, and a damaged checkpoint is refused by name.

use trainer::policy_file::Policy;

mod common;

#[test]
fn a_checkpoint_exports_as_the_policy_the_run_had_at_that_iteration() {
    let dir = std::env::temp_dir().join(format!("topa-progress-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let config = dir.join("cartpole.toml");
    std::fs::write(&config, format!("{}{}", common::KEEP_ALL_RUN, common::TINY_CARTPOLE)).unwrap();
    let run = dir.join("run");
    common::cli_train(Some(&config), &run, false, None);

    let picked: Vec<usize> = topa_eval::progress::checkpoints(&run, 5).unwrap().into_iter().map(|c| c.0).collect();
    assert_eq!(picked, [5, 10, 12], "multiples of 5 and the last");

    let ck = run.join("checkpoints");
    let last = topa_train::export_checkpoint(&ck.join("ckpt_0000012.json"), &dir.join("it12")).unwrap();
    assert_eq!(
        std::fs::read(dir.join("it12.safetensors")).unwrap(),
        std::fs::read(run.join("policy.safetensors")).unwrap(),
        "the last checkpoint's actor and normaliser are the exported policy's"
    );
    let end = Policy::load(&run.join("policy.json")).unwrap();
    let p12 = Policy::load(&last).unwrap();
    assert_eq!(p12.meta.provenance.iterations, 12);
    assert_eq!(p12.meta.provenance.samples, end.meta.provenance.samples);
    assert_eq!(p12.meta.provenance.config, end.meta.provenance.config, "the same resolved config");

    let p5 =
        Policy::load(&topa_train::export_checkpoint(&ck.join("ckpt_0000005.json"), &dir.join("it5")).unwrap()).unwrap();
    assert_eq!((p5.meta.provenance.iterations, p5.meta.provenance.samples), (5, 5 * 8 * 16));
    assert!(p5.meta.provenance.wall_time_s < p12.meta.provenance.wall_time_s);
    let (mut a5, mut a12) = (Vec::new(), Vec::new());
    let obs = [0.05f32, -0.1, 0.02, 0.3];
    Policy::clone(&p5).act(&obs, &mut a5);
    Policy::clone(&p12).act(&obs, &mut a12);
    assert_ne!(a5, a12, "seven iterations of learning changed the policy");

    // A damaged weights file: one clear error naming it.
    let w = ck.join("ckpt_0000010.safetensors");
    let mut bytes = std::fs::read(&w).unwrap();
    let n = bytes.len();
    bytes[n - 3] ^= 0x55;
    std::fs::write(&w, bytes).unwrap();
    let e = topa_train::export_checkpoint(&ck.join("ckpt_0000010.json"), &dir.join("it10")).unwrap_err();
    assert!(format!("{e:#}").contains("ckpt_0000010.safetensors does not match the checksum"), "{e:#}");
    std::fs::remove_dir_all(dir).ok();
}
