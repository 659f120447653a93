//! The PPO loss terms: gradients against finite differences, the decay term's reach, the symmetry loss on an
//! equivariant policy, the adaptive learning rate, NaN handling, and config errors.

use candle_core::{Device, Tensor, Var};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use topa_train::load_config;
use trainer::actor_critic::ActorCritic;
use trainer::actor_view::ActorView;
use trainer::config::{LossConfig, PpoConfig, TrainConfig};
use trainer::ppo::{self, Agent, Batch};
use trainer::storage::Rollout;

#[path = "../topa-env/tests/reference/topa.rs"]
mod topa;

fn agent(seed: u64, sym: bool, losses: LossConfig) -> Agent {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let ac = ActorCritic::new(ActorView::whole(42), 10, &[16, 8], &[16, 8], &[], 0.7, &mut rng).unwrap();
    Agent::new(ac, PpoConfig::default(), losses, sym.then(topa::symmetry), 0.0).unwrap()
}

fn batch(seed: u64, rows: usize) -> Batch {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut v = |n: usize, s: f32| -> Vec<f32> { (0..n).map(|_| rng.random_range(-s..s)).collect() };
    Batch {
        rows,
        mirrored: false,
        obs: v(rows * 42, 1.0),
        actor_obs: Vec::new(),
        actions: v(rows * 10, 1.0),
        means: v(rows * 10, 0.5),
        log_probs: v(rows, 1.0).iter().map(|x| x - 9.0).collect(),
        values: v(rows, 1.0),
        returns: v(rows, 2.0),
        advantages: v(rows, 1.5),
    }
}

/// Value of one loss term (index into surrogate, value, entropy, symmetry, decay) at the current weights.
fn term(a: &Agent, b: &Batch, which: usize) -> (Tensor, f64) {
    let obs = Tensor::from_slice(&b.obs, (b.rows, 42), &Device::Cpu).unwrap();
    let mean = a.ac.actor.forward(&obs).unwrap();
    let t = a.loss_terms(b, &obs, &mean).unwrap();
    let x = match which {
        0 => t.surrogate,
        1 => t.value,
        2 => t.entropy,
        3 => t.symmetry.unwrap(),
        _ => t.decay.unwrap(),
    };
    let v = x.to_scalar::<f32>().unwrap() as f64;
    (x, v)
}

fn nudge(var: &Var, i: usize, delta: f32) {
    let mut w = var.as_tensor().flatten_all().unwrap().to_vec1::<f32>().unwrap();
    w[i] += delta;
    var.set(&Tensor::from_vec(w, var.shape(), &Device::Cpu).unwrap()).unwrap();
}

#[test]
fn every_loss_term_has_the_gradient_finite_differences_give() {
    let losses = LossConfig { symmetry_coef: 0.7, decay_coef: 0.05, symmetry_augmentation: false };
    let a = agent(1, true, losses);
    let b = batch(2, 24);
    let names = ["surrogate", "value", "entropy", "symmetry", "decay"];
    for (which, name) in names.iter().enumerate() {
        let (loss, _) = term(&a, &b, which);
        let grads = loss.backward().unwrap();
        let mut checked = 0;
        for (vname, var) in a.ac.named_vars() {
            let Some(g) = grads.get(var.as_tensor()) else { continue };
            let g = g.flatten_all().unwrap().to_vec1::<f32>().unwrap();
            // Probe the three largest-gradient entries of each parameter (well above f32 noise).
            let mut order: Vec<usize> = (0..g.len()).collect();
            order.sort_by(|&i, &j| g[j].abs().partial_cmp(&g[i].abs()).unwrap());
            for &i in order.iter().take(3) {
                if g[i].abs() < 1e-3 {
                    continue;
                }
                let h = 2e-3f32;
                nudge(&var, i, h);
                let up = term(&a, &b, which).1;
                nudge(&var, i, -2.0 * h);
                let down = term(&a, &b, which).1;
                nudge(&var, i, h);
                let fd = (up - down) / (2.0 * h as f64);
                let rel = (fd - g[i] as f64).abs() / (g[i].abs() as f64).max(1e-2);
                assert!(rel < 0.03, "{name}: d/d {vname}[{i}] analytic {} vs finite difference {fd}", g[i]);
                checked += 1;
            }
        }
        assert!(checked > 0, "{name}: no gradient was checked");
    }
}

#[test]
fn decay_touches_only_the_actors_last_layer() {
    let a = agent(3, false, LossConfig { symmetry_coef: 0.0, decay_coef: 1.0, symmetry_augmentation: false });
    let b = batch(4, 8);
    let (decay, value) = term(&a, &b, 4);
    let last = a.ac.actor.last_layer();
    let expected: f64 = [&last.weight, &last.bias]
        .iter()
        .flat_map(|v| v.as_tensor().flatten_all().unwrap().to_vec1::<f32>().unwrap())
        .map(|x| (x as f64).powi(2))
        .sum();
    assert!((value - expected).abs() < 1e-4 * expected, "{value} vs ‖θ_last‖² = {expected}");
    let grads = decay.backward().unwrap();
    for (name, var) in a.ac.named_vars() {
        let g = grads
            .get(var.as_tensor())
            .map(|g| g.abs().unwrap().sum_all().unwrap().to_scalar::<f32>().unwrap())
            .unwrap_or(0.0);
        let is_last = name.starts_with(&format!("actor.{}.", a.ac.actor.layers.len() - 1));
        assert_eq!(g > 0.0, is_last, "{name}: gradient {g}");
    }
}

/// Sets the actor to an equivariant-by-construction network: hidden units in mirror pairs
/// h = ELU(W o + b), h' = ELU(W S_o o + b), output V h + S_a V h' + c with S_a c = c.
fn make_equivariant(a: &Agent, rng: &mut ChaCha8Rng) {
    let s = topa::symmetry();
    let layers = &a.ac.actor.layers;
    assert_eq!(layers.len(), 2, "one hidden layer");
    let k = layers[0].out_dim() / 2;
    let mut w = vec![0.0f32; 2 * k * 42];
    let mut b1 = vec![0.0f32; 2 * k];
    for r in 0..k {
        b1[r] = rng.random_range(-0.5..0.5);
        b1[k + r] = b1[r];
        for i in 0..42 {
            let x = rng.random_range(-0.3..0.3);
            w[r * 42 + i] = x;
            // (W S_o)[r][perm[i]] += sign[i] W[r][i]
            w[(k + r) * 42 + s.obs.perm[i]] += s.obs.sign[i] * x;
        }
    }
    let mut v = vec![0.0f32; 10 * 2 * k];
    for o in 0..10 {
        for r in 0..k {
            let x = rng.random_range(-0.3..0.3);
            v[o * 2 * k + r] += x;
            // (S_a V)[o'][k + r] with o' = the row that takes V's row o: S_a[o'][perm[o']] = sign[o'].
            let row = (0..10).find(|&q| s.act.perm[q] == o).unwrap();
            v[row * 2 * k + k + r] += s.act.sign[row] * x;
        }
    }
    let mut c = vec![0.0f32; 10];
    for o in 0..10 {
        let x: f32 = rng.random_range(-0.2..0.2);
        c[o] += 0.5 * x;
        c[s.act.perm[o]] += 0.5 * s.act.sign[o] * x;
    }
    let set = |var: &Var, data: Vec<f32>| var.set(&Tensor::from_vec(data, var.shape(), &Device::Cpu).unwrap()).unwrap();
    set(&layers[0].weight, w);
    set(&layers[0].bias, b1);
    set(&layers[1].weight, v);
    set(&layers[1].bias, c);
}

#[test]
fn symmetry_loss_is_zero_for_an_equivariant_policy_and_positive_otherwise() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let ac = ActorCritic::new(ActorView::whole(42), 10, &[16], &[16], &[], 1.0, &mut rng).unwrap();
    let a = Agent::new(
        ac,
        PpoConfig::default(),
        LossConfig { symmetry_coef: 1.0, decay_coef: 0.0, symmetry_augmentation: false },
        Some(topa::symmetry()),
        0.0,
    )
    .unwrap();
    let b = batch(6, 32);
    let random = term(&a, &b, 3).1;
    assert!(random > 1e-3, "a random network is not symmetric: {random}");
    make_equivariant(&a, &mut rng);
    let equivariant = term(&a, &b, 3).1;
    assert!(equivariant < 1e-10, "an equivariant network has zero symmetry loss, got {equivariant}");
}

/// Symmetry by data: a mirrored batch is the batch and its mirror image; its L_symmetry is the paper's on the
/// sampled rows; and for an equivariant policy the mirror images carry the same surrogate as the samples, while
/// for a random one they do not (which is what they teach).
#[test]
fn a_mirrored_batch_is_the_batch_and_its_mirror_image() {
    let losses = LossConfig { symmetry_coef: 1.0, decay_coef: 0.0, symmetry_augmentation: true };
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let a = Agent::new(
        ActorCritic::new(ActorView::whole(42), 10, &[16], &[16], &[], 0.7, &mut rng).unwrap(),
        PpoConfig::default(),
        losses,
        Some(topa::symmetry()),
        0.0,
    )
    .unwrap();
    let sym = a.symmetry.clone().unwrap();
    let b = batch(9, 24);
    let mut m = b.clone();
    m.append_mirror(&sym, &sym.obs);
    assert_eq!((m.rows, m.sampled_rows(), b.sampled_rows()), (48, 24, 24));
    let mut back = vec![0.0; 24 * 42];
    sym.obs.apply_rows(&m.obs[24 * 42..], &mut back);
    assert_eq!(back, b.obs, "the second half's observations mirror back to the samples");
    sym.act.apply_rows(&m.actions[24 * 10..], &mut back[..240]);
    assert_eq!(back[..240], b.actions[..]);
    assert_eq!((&m.advantages[24..], &m.log_probs[24..]), (&b.advantages[..], &b.log_probs[..]));
    let (paper, halves) = (term(&a, &b, 3).1, term(&a, &m, 3).1);
    assert!(paper > 1e-3 && (paper - halves).abs() < 1e-6 * paper.max(1.0), "L_symmetry {paper} vs {halves}");
    let gap = |a: &Agent| (term(a, &m, 0).1 - term(a, &b, 0).1).abs();
    assert!(gap(&a) > 1e-3, "a random policy's mirror images are new data: surrogate gap {}", gap(&a));
    make_equivariant(&a, &mut rng);
    assert!(gap(&a) < 1e-5, "an equivariant policy's are not: surrogate gap {}", gap(&a));
}

#[test]
fn adaptive_learning_rate_moves_the_right_way() {
    let p = PpoConfig::default();
    let lr = 1e-3;
    assert!((ppo::adapt_learning_rate(lr, 3.0 * p.desired_kl, &p) - lr / 1.5).abs() < 1e-15);
    assert!((ppo::adapt_learning_rate(lr, 0.25 * p.desired_kl, &p) - lr * 1.5).abs() < 1e-15);
    assert_eq!(ppo::adapt_learning_rate(lr, p.desired_kl, &p), lr);
    assert_eq!(ppo::adapt_learning_rate(p.lr_min, 10.0, &p), p.lr_min, "bounded below");
    assert_eq!(ppo::adapt_learning_rate(p.lr_max, 1e-9, &p), p.lr_max, "bounded above");
    assert_eq!(ppo::adapt_learning_rate(lr, f64::NAN, &p), lr);
}

#[test]
fn the_entropy_bonus_decays_linearly_then_holds() {
    let mut p = PpoConfig { entropy_coef: 0.03, entropy_coef_end: 0.01, ..PpoConfig::default() };
    assert_eq!(p.entropy_coef_at(700), 0.03, "no decay without its iterations");
    p.entropy_decay_iterations = 400;
    for (it, want) in [(0, 0.03), (100, 0.025), (200, 0.02), (400, 0.01), (10_000, 0.01)] {
        assert!((p.entropy_coef_at(it) - want).abs() < 1e-15, "iteration {it}: {}", p.entropy_coef_at(it));
    }
}

#[test]
fn a_nan_loss_skips_the_update_and_keeps_the_weights() {
    let mut a = agent(7, true, LossConfig::default());
    let mut r = Rollout::new(4, 8, 42, 10);
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    r.obs.iter_mut().for_each(|x| *x = rng.random_range(-1.0..1.0));
    r.std = vec![0.7; 10];
    r.compute_returns(&[0.0; 8], 0.99, 0.95);
    r.advantages[3] = f32::NAN;
    let before: Vec<Vec<f32>> =
        a.ac.vars().iter().map(|v| v.as_tensor().flatten_all().unwrap().to_vec1().unwrap()).collect();
    let stats = a.update(&r, &mut rng).unwrap();
    let after: Vec<Vec<f32>> =
        a.ac.vars().iter().map(|v| v.as_tensor().flatten_all().unwrap().to_vec1().unwrap()).collect();
    // Only the minibatches holding the NaN sample are skipped; the weights stay finite.
    assert!(stats.skipped >= 1 && stats.skipped <= stats.minibatches, "{stats:?}");
    assert!(after.iter().flatten().all(|x| x.is_finite()));
    let mut all_nan = r.clone();
    all_nan.advantages.iter_mut().for_each(|x| *x = f32::NAN);
    let mut b = agent(7, true, LossConfig::default());
    let stats = b.update(&all_nan, &mut rng).unwrap();
    assert_eq!(stats.skipped, stats.minibatches);
    let kept: Vec<Vec<f32>> =
        b.ac.vars().iter().map(|v| v.as_tensor().flatten_all().unwrap().to_vec1().unwrap()).collect();
    assert_eq!(kept, before, "weights kept when every minibatch is skipped");
}

#[test]
fn unknown_or_invalid_config_keys_are_clear_errors() {
    let dir = std::env::temp_dir().join(format!("topa-cfg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let err = TrainConfig::load(&write("typo.toml", "[ppo]\nlearning_rat = 1e-4\n")).unwrap_err().to_string();
    assert!(err.contains("learning_rat") && err.contains("typo.toml"), "{err}");
    // The first line names the file and the key; TOML's own layout (the table it is in) follows as TOML writes it.
    assert!(err.lines().next().unwrap().contains("typo.toml") && err.contains("`ppo`"), "{err}");
    let err = TrainConfig::load(&write("bad.toml", "[ppo]\ngamma = 1.5\n")).unwrap_err().to_string();
    assert!(err.contains("ppo.gamma"), "{err}");
    let err = format!(
        "{:#}",
        anyhow::Error::from(load_config(&write("env.toml", "[env.rewards]\nsigma_v = -1.0\n")).unwrap_err())
    );
    assert!(err.contains("sigma_v") && err.contains("env.toml"), "{err}");
    let err = format!(
        "{:#}",
        anyhow::Error::from(load_config(&write("env2.toml", "[env.rewards]\nsigma_vv = 1.0\n")).unwrap_err())
    );
    assert!(err.contains("sigma_vv") && err.contains("env2.toml"), "{err}");
    let err = TrainConfig::load(&write("ent.toml", "[ppo]\nentropy_coef_end = -0.01\n")).unwrap_err().to_string();
    assert!(err.contains("ppo.entropy_coef_end must be ≥ 0"), "{err}");
    let err = TrainConfig::load(&write("adv.toml", "[adversary]\nattack_share = 1.5\n")).unwrap_err().to_string();
    assert!(err.contains("adversary.attack_share"), "{err}");
    let phase3 = write("adv3.toml", "[adversary]\npolicy_entropy_coef = -0.01\n");
    let err = TrainConfig::load(&phase3).unwrap_err().to_string();
    assert!(err.contains("adversary.policy_entropy_coef must be ≥ 0"), "{err}");
    let (ok, ok_env) =
        load_config(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/configs/paper.toml"))).unwrap();
    assert_eq!(ok.run.num_envs, 4096);
    assert_eq!(ok.ppo.learning_rate, 3e-5);
    let (_, cpu_env) =
        load_config(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/configs/cpu.toml"))).unwrap();
    // The CPU preset keeps the paper's reward weights; only the air-time term (its form, target and weight), our
    // swing-height term (weight 0 in the paper) and the hip-yaw kernel's width (a σ the paper does not give) differ
    // (README, "Training").
    let mut cpu_rewards = cpu_env.rewards.clone();
    let paper = &ok_env.rewards;
    cpu_rewards.sigma_yaw = paper.sigma_yaw;
    (cpu_rewards.air_time_form, cpu_rewards.air_time_target, cpu_rewards.feet_air_time) =
        (paper.air_time_form, paper.air_time_target, paper.feet_air_time);
    assert_eq!(paper.feet_clearance, 0.0, "the paper's table has no clearance term");
    (cpu_rewards.feet_clearance, cpu_rewards.clearance_form, cpu_rewards.clearance_target) =
        (paper.feet_clearance, paper.clearance_form, paper.clearance_target);
    assert_eq!(&cpu_rewards, paper, "the CPU preset keeps the paper's rewards");
    // Every shipped experiment file loads (its `base` chain included) and changes something.
    let experiments = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/configs/experiments"));
    for e in std::fs::read_dir(experiments).unwrap() {
        let path = e.unwrap().path();
        let (c, _) = load_config(&path).unwrap_or_else(|e| panic!("{}: {e:#}", path.display()));
        // Each lever changes something against the file it starts from (an earlier preset, kept whole as the
        // base of the experiments measured against it, starts from nothing).
        let text = std::fs::read_to_string(&path).unwrap();
        let table: toml::Table = toml::from_str(&text).unwrap();
        let Some(base) = table.get("base") else { continue };
        let base = path.parent().unwrap().join(base.as_str().expect("`base` names a file"));
        let (b, _) = load_config(&base).unwrap();
        assert_ne!(toml::to_string(&c).unwrap(), toml::to_string(&b).unwrap(), "{}", path.display());
    }
    // `base`: a file holds only what it changes; tables merge key by key; unknown keys still fail, in either file.
    write("base.toml", "[run]\nnum_envs = 64\nseed = 3\n[env.rewards]\nsigma_v = 0.5\n");
    let (child, child_env) = load_config(&write("child.toml", "base = \"base.toml\"\n[run]\nseed = 9\n")).unwrap();
    assert_eq!((child.run.num_envs, child.run.seed, child_env.rewards.sigma_v), (64, 9, 0.5));
    let err = TrainConfig::load(&write("c2.toml", "base = \"base.toml\"\n[run]\nsede = 9\n")).unwrap_err().to_string();
    assert!(err.contains("sede"), "{err}");
    let err = TrainConfig::load(&write("c3.toml", "base = \"missing.toml\"\n")).unwrap_err().to_string();
    assert!(err.contains("missing.toml"), "{err}");
    write("loop.toml", "base = \"loop.toml\"\n");
    assert!(TrainConfig::load(&dir.join("loop.toml")).unwrap_err().to_string().contains("cycle"));
    std::fs::remove_dir_all(dir).ok();
}
