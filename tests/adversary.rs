//! The cyclic adversary on the cart-pole: the schedule's phases, frozen networks really frozen, the adversary
//! learning to hurt a fixed policy, and resume in the middle of phase 2.

mod common;

use common::{cartpole_config, cartpole_trainer, set_push_bound};
use trainer::config::TrainConfig;
use trainer::schedule::Phase;
use trainer::Trainer;

fn config(seed: u64, p1: usize, p2: usize, p3: usize, cycles: usize) -> TrainConfig {
    let mut c = cartpole_config(seed, TrainConfig::default().run.iterations);
    let a = &mut c.adversary;
    (a.phase1_policy_iters, a.phase2_adversary_iters, a.phase3_policy_iters, a.cycles) = (p1, p2, p3, cycles);
    a.hidden = vec![32, 32];
    a.learning_rate = 1e-3;
    set_push_bound(&mut c, 1.5); // N on the pole
    c
}

fn trainer(cfg: &TrainConfig) -> Trainer {
    cartpole_trainer(cfg, true)
}

fn flat(vars: &[candle_core::Var]) -> Vec<Vec<f32>> {
    vars.iter().map(|v| v.as_tensor().flatten_all().unwrap().to_vec1::<f32>().unwrap()).collect()
}

#[test]
fn phases_alternate_and_frozen_networks_do_not_move() {
    let mut t = trainer(&config(1, 2, 2, 2, 2));
    assert_eq!(t.schedule.phases(), vec![1, 1, 2, 2, 3, 3, 2, 2, 3, 3]);
    let mut seen = vec![];
    loop {
        let (pol, adv) = (flat(&t.policy.ac.vars()), flat(&t.adversary.as_ref().unwrap().agent.ac.vars()));
        let stats = |n: &trainer::normalizer::Normalizer| (n.mean.clone(), n.m2.clone(), n.count);
        let (pol_norm, adv_norm) =
            (stats(&t.policy.normalizer), stats(&t.adversary.as_ref().unwrap().agent.normalizer));
        let Some(log) = t.iterate().unwrap() else { break };
        seen.push(log.phase.number());
        let (pol2, adv2) = (flat(&t.policy.ac.vars()), flat(&t.adversary.as_ref().unwrap().agent.ac.vars()));
        match log.phase {
            Phase::Policy => {
                assert_eq!(adv2, adv, "phase 1: the adversary does not learn");
                assert!(log.adversary.is_none() && log.perturbation.iter().all(|&m| m == 0.0));
            }
            Phase::Adversary => {
                assert_eq!(pol2, pol, "phase 2: the policy is frozen, bit for bit");
                assert_eq!(stats(&t.policy.normalizer), pol_norm, "phase 2: the policy's normaliser is frozen too");
                assert!(log.policy.is_none() && log.adversary.is_some(), "no gradient work for the frozen policy");
                assert_ne!(adv2, adv);
            }
            Phase::PolicyUnderAttack => {
                assert_eq!(adv2, adv, "phase 3: the adversary is frozen, bit for bit");
                assert_eq!(stats(&t.adversary.as_ref().unwrap().agent.normalizer), adv_norm);
                assert!(log.adversary.is_none() && log.policy.is_some());
                assert_ne!(pol2, pol);
            }
        }
    }
    assert_eq!(seen, vec![1, 1, 2, 2, 3, 3, 2, 2, 3, 3]);
}

/// The policy's weights after each iteration of the run `cfg` describes, its schedule to the end.
fn policy_after_each_iteration(cfg: &TrainConfig) -> Vec<Vec<Vec<f32>>> {
    let mut t = trainer(cfg);
    let mut after = vec![];
    while t.iterate().unwrap().is_some() {
        after.push(flat(&t.policy.ac.vars()));
    }
    after
}

#[test]
fn phase_three_trains_the_policy_with_its_own_entropy_bonus() {
    // ppo's bonus decays to none after iteration 0; phase 3 (iterations 2 and 3) takes adversary.policy_entropy_coef.
    let with = |phase3: f64| {
        let mut c = config(6, 1, 1, 2, 1);
        (c.ppo.entropy_coef, c.ppo.entropy_coef_end, c.ppo.entropy_decay_iterations) = (0.05, 0.0, 1);
        c.adversary.policy_entropy_coef = phase3;
        c
    };
    let decayed = policy_after_each_iteration(&with(0.05));
    let mut constant = with(0.05);
    constant.ppo.entropy_decay_iterations = 0;
    // Weights compared whole, not printed: a failure names the phase, not ten thousand floats.
    assert!(policy_after_each_iteration(&constant) == decayed, "phase 1 at 0.05 and phase 3 at 0.05 either way");
    let none = policy_after_each_iteration(&with(0.0));
    assert!(none[..2] == decayed[..2], "phases 1 and 2 do not read the phase-3 weight");
    assert!(none[2] != decayed[2], "phase 3 updates with adversary.policy_entropy_coef, not ppo's schedule");
}

#[test]
fn phase_three_learns_from_mirrored_data_when_asked() {
    // Iteration 0 is phase 1, iteration 1 phase 2, iterations 2 and 3 phase 3.
    let with = |everywhere: bool, phase3: bool| {
        let mut c = config(7, 1, 1, 2, 1);
        (c.losses.symmetry_augmentation, c.adversary.policy_symmetry_augmentation) = (everywhere, phase3);
        c
    };
    let plain = policy_after_each_iteration(&with(false, false));
    let phase3 = policy_after_each_iteration(&with(false, true));
    assert!(phase3[..2] == plain[..2], "phases 1 and 2 learn as without mirrored data (a forked C stays the C)");
    assert!(phase3[2] != plain[2], "phase 3 learns from the mirrored minibatches");
    let everywhere = policy_after_each_iteration(&with(true, false));
    assert!(everywhere[0] != plain[0], "losses.symmetry_augmentation acts from phase 1 on");
    assert!(policy_after_each_iteration(&with(true, true)) == everywhere, "both keys on: phase 3 augmented once");
}

#[test]
fn mirrored_data_in_phase_three_needs_the_tasks_mirror() {
    let mut c = config(7, 1, 1, 1, 1);
    c.adversary.policy_symmetry_augmentation = true;
    let no_mirror = || {
        let inner = cartpole_trainer(&c, false).env;
        let mut v = common::view::ObsView::new(inner, 4, Box::new(|o: &[f32]| o.to_vec()));
        v.channels = v.inner().perturbation_channels();
        Box::new(v)
    };
    let err = Trainer::new(c.clone(), no_mirror(), true).err().expect("refused").to_string();
    assert!(err.contains("adversary.policy_symmetry_augmentation") && err.contains("set it to false"), "{err}");
    assert!(Trainer::new(c.clone(), no_mirror(), false).is_ok(), "a run without the adversary has no phase 3");
}

#[test]
fn the_adversary_learns_to_topple_a_fixed_policy() {
    // Phase 1 learns to balance; phase 2 trains the adversary against the frozen balancer.
    let mut t = trainer(&config(2, 20, 30, 0, 1));
    let mut phase2 = vec![];
    while let Some(log) = t.iterate().unwrap() {
        if log.phase == Phase::Adversary && log.episodes.episodes > 0 {
            phase2.push(log.episodes.mean_length);
        } else if log.phase == Phase::Adversary {
            phase2.push(200.0); // no episode ended at all: the attack failed this iteration
        }
    }
    let early: f64 = phase2[..5].iter().sum::<f64>() / 5.0;
    let late: f64 = phase2[phase2.len() - 5..].iter().sum::<f64>() / 5.0;
    eprintln!("episode length under attack: first 5 iterations {early:.1}, last 5 {late:.1}");
    assert!(late < 0.7 * early, "the adversary did not learn: episode length {early:.1} → {late:.1}");
}

#[test]
fn resume_in_the_middle_of_phase_two_continues_exactly() {
    let cfg = config(3, 2, 4, 2, 1);
    let mut straight = trainer(&cfg);
    for _ in 0..7 {
        straight.iterate().unwrap();
    }
    let dir = std::env::temp_dir().join(format!("topa-adv-resume-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut first = trainer(&cfg);
    for _ in 0..4 {
        first.iterate().unwrap();
    }
    let pos = first.position().unwrap();
    assert_eq!((pos.phase, pos.iter_in_phase), (Phase::Adversary, 2), "stopped mid-phase 2");
    trainer::checkpoint::save(&first, &dir, "test", 0).unwrap();
    let (side, loaded) = trainer::checkpoint::read_sidecar(&trainer::checkpoint::latest(&dir).unwrap()).unwrap();
    let mut resumed = trainer(&side.config);
    trainer::checkpoint::restore(&mut resumed, &side, &loaded).unwrap();
    let pos = resumed.position().unwrap();
    assert_eq!(
        (pos.phase, pos.iter_in_phase, pos.phase_len - pos.iter_in_phase),
        (Phase::Adversary, 2, 2),
        "2 iterations of phase 2 remain"
    );
    for _ in 0..3 {
        resumed.iterate().unwrap();
    }
    assert_eq!(flat(&resumed.policy.ac.vars()), flat(&straight.policy.ac.vars()));
    assert_eq!(
        flat(&resumed.adversary.as_ref().unwrap().agent.ac.vars()),
        flat(&straight.adversary.as_ref().unwrap().agent.ac.vars())
    );
    assert_eq!(resumed.env.obs(), straight.env.obs());
    std::fs::remove_dir_all(dir).ok();
}

/// The same on TopA through the CLI, with the training preset (domain randomisation, pushes, noise) and the
/// adversary attacking half the envs in phase 3: a run resumed from a checkpoint in phase 2 or in phase 3 — with
/// another thread count — ends with the straight run's policy, byte for byte.
#[test]
fn a_topa_adversary_run_resumed_anywhere_ends_with_the_straight_runs_policy() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = std::env::temp_dir().join(format!("topa-ca-resume-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let cfg = dir.join("cfg.toml");
    let base = root.join("configs/cpu.toml");
    std::fs::write(
        &cfg,
        format!(
            "base = {:?}\n[run]\nnum_envs = 8\nsteps_per_env = 8\ncheckpoint_every = 1\nkeep_checkpoints = 100\n\
             [adversary]\nphase1_policy_iters = 2\nphase2_adversary_iters = 3\nphase3_policy_iters = 3\ncycles = 1\n",
            base.display().to_string()
        ),
    )
    .unwrap();
    let topa = |args: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_topa")).args(args).output().unwrap();
        assert!(out.status.success(), "topa {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    };
    let straight = dir.join("straight");
    let (cfg_s, straight_s) = (cfg.to_str().unwrap(), straight.to_str().unwrap());
    // An adversary run's length is its schedule: --iterations, which would be ignored, is refused with the fix.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_topa"))
        .args(["train", "--config", cfg_s, "--adversary", "--iterations", "3", "--quiet", "--out", straight_s])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("[adversary] schedule"), "{err}");
    assert!(!straight.exists(), "a refused run writes nothing");
    topa(&["train", "--config", cfg_s, "--adversary", "--threads", "1", "--quiet", "--out", straight_s]);
    let want = std::fs::read(straight.join("policy.safetensors")).unwrap();
    // Completed iterations 1–2: phase 1; 3–5: phase 2; 6–8: phase 3.
    for (at, threads) in [(4, "2"), (6, "1")] {
        let run = dir.join(format!("resumed-{at}"));
        let ck = run.join("checkpoints");
        std::fs::create_dir_all(&ck).unwrap();
        for f in std::fs::read_dir(straight.join("checkpoints")).unwrap() {
            let p = f.unwrap().path();
            let name = p.file_name().unwrap().to_str().unwrap().to_string();
            let keep = name
                .strip_prefix("ckpt_")
                .and_then(|s| s.split('.').next())
                .is_some_and(|n| n.parse::<usize>().unwrap() <= at);
            if keep {
                std::fs::copy(&p, ck.join(&name)).unwrap();
            }
        }
        std::fs::copy(straight.join("config.toml"), run.join("config.toml")).unwrap();
        std::fs::write(ck.join("latest.json"), format!("{{\"sidecar\": \"ckpt_{at:07}.json\", \"iteration\": {at}}}"))
            .unwrap();
        topa(&["train", "--resume", run.to_str().unwrap(), "--threads", threads, "--quiet"]);
        let got = std::fs::read(run.join("policy.safetensors")).unwrap();
        assert!(got == want, "resumed after iteration {at} with {threads} thread(s): the policy differs");
    }
    std::fs::remove_dir_all(dir).ok();
}
