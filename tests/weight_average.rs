//! Weight averaging (`topa average`): the mean is taken of each policy's layers as functions of the raw
//! observation (its normaliser folded in), checked here against the layers' definitions on shipped policies.

use rand::{RngExt, SeedableRng};
use trainer::nn::Linear;
use trainer::policy_file::Policy;
use trainer::weight_average::average;

fn load(rel: &str) -> Policy {
    Policy::load(&topa_env::assets::repo_dir().join(rel)).unwrap()
}

fn matrix(l: &Linear) -> (Vec<Vec<f64>>, Vec<f64>) {
    let (out, inp) = l.weight.as_tensor().dims2().unwrap();
    let w = l.weight.as_tensor().flatten_all().unwrap().to_vec1::<f32>().unwrap();
    let rows = (0..out).map(|o| w[o * inp..(o + 1) * inp].iter().map(|&x| x as f64).collect()).collect();
    (rows, l.bias.as_tensor().to_vec1::<f32>().unwrap().iter().map(|&x| x as f64).collect())
}

/// `W · v + b` for the layer `l`.
fn apply(l: &Linear, v: &[f64]) -> Vec<f64> {
    let (w, b) = matrix(l);
    w.iter().zip(b).map(|(row, b)| row.iter().zip(v).map(|(w, x)| w * x).sum::<f64>() + b).collect()
}

/// The normalised value of raw `x` in observation column `c` under `p`'s normaliser.
fn norm(p: &Policy, c: usize, x: f64) -> f64 {
    let (mean, scale) = p.normalizer_affine();
    (x - mean[c]) * scale[c]
}

fn close(a: &[f64], b: &[f64], tol: f64) {
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!((x - y).abs() <= tol * (1.0 + y.abs()), "component {i}: {x} vs {y}");
    }
}

/// Raw observation columns drawn around each policy's statistics (both policies see the same values).
fn raw_row(p: &Policy, rng: &mut rand_chacha::ChaCha8Rng) -> Vec<f64> {
    let (mean, scale) = p.normalizer_affine();
    mean.iter().zip(&scale).map(|(m, s)| m + (rng.random::<f64>() * 4.0 - 2.0) / s).collect()
}

#[test]
fn the_first_layer_is_the_mean_of_the_policies_first_layers_on_the_raw_observation() {
    // Two seeds of one recipe: one network, different normaliser statistics.
    let (p, q) = (load("assets/policies/cassie/seed1.json"), load("assets/policies/cassie/seed2.json"));
    assert_ne!(p.normalizer_affine().0, q.normalizer_affine().0, "the test needs normalisers that differ");
    let names = ["seed1".to_string(), "seed2".to_string()];
    let r = average(&[p.clone(), q.clone()], &names).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    for _ in 0..5 {
        let x = raw_row(&p, &mut rng);
        let pre = |a: &Policy| {
            let v: Vec<f64> = x.iter().enumerate().map(|(c, &x)| norm(a, c, x)).collect();
            apply(&a.actor().layers[0], &v)
        };
        let mean: Vec<f64> = pre(&p).iter().zip(pre(&q)).map(|(a, b)| (a + b) / 2.0).collect();
        close(&pre(&r), &mean, 1e-4);
    }
    // Deeper layers read no normalised value: their weights are the element-wise mean.
    for i in 1..p.actor().layers.len() {
        let (wp, bp) = matrix(&p.actor().layers[i]);
        let (wq, bq) = matrix(&q.actor().layers[i]);
        let (wr, br) = matrix(&r.actor().layers[i]);
        let mean = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(a, b)| (a + b) / 2.0).collect::<Vec<_>>();
        close(&br, &mean(&bp, &bq), 1e-6);
        close(&wr.concat(), &mean(&wp.concat(), &wq.concat()), 1e-6);
    }
    // The mean carries the last policy's normaliser and sidecar.
    assert_eq!(r.normalizer_affine(), q.normalizer_affine());
    assert_eq!(r.meta.provenance.seed, q.meta.provenance.seed);
}

#[test]
fn the_estimate_is_averaged_in_the_units_of_the_values_it_estimates() {
    let (p, q) =
        (load("assets/policies/C-velocity-free/seed1.json"), load("assets/policies/C-velocity-free/seed2.json"));
    let view = p.view().clone();
    let est = view.estimate.clone().expect("a velocity-free policy estimates the base velocity");
    let r = average(&[p.clone(), q.clone()], &["1".into(), "2".into()]).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let x = raw_row(&p, &mut rng);
    // The estimator's last layer, from one hidden activation to the estimate in m/s.
    let e = p.estimator().unwrap().layers.len() - 1;
    let h: Vec<f64> = (0..p.estimator().unwrap().layers[e].weight.as_tensor().dims2().unwrap().1)
        .map(|_| rng.random::<f64>() - 0.5)
        .collect();
    let out = |a: &Policy| -> Vec<f64> {
        let (mean, scale) = a.normalizer_affine();
        let n = apply(&a.estimator().unwrap().layers[e], &h);
        n.iter().zip(est.clone()).map(|(v, c)| v / scale[c] + mean[c]).collect()
    };
    let mean: Vec<f64> = out(&p).iter().zip(out(&q)).map(|(a, b)| (a + b) / 2.0).collect();
    close(&out(&r), &mean, 1e-4);
    // The actor's first layer on the raw inputs and a raw estimate (m/s).
    let v: Vec<f64> = est.clone().map(|_| rng.random::<f64>() - 0.5).collect();
    let pre = |a: &Policy| {
        let mut inp: Vec<f64> = (0..view.inputs).map(|c| norm(a, c, x[c])).collect();
        inp.extend(est.clone().zip(&v).map(|(c, &v)| norm(a, c, v)));
        apply(&a.actor().layers[0], &inp)
    };
    let mean: Vec<f64> = pre(&p).iter().zip(pre(&q)).map(|(a, b)| (a + b) / 2.0).collect();
    close(&pre(&r), &mean, 1e-4);
}

#[test]
fn one_policy_averaged_acts_as_itself() {
    for rel in ["assets/policies/cassie/seed1.json", "assets/policies/C-velocity-free/seed1.json"] {
        let mut p = load(rel);
        let mut r = average(std::slice::from_ref(&p), &["p".into()]).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let obs: Vec<f32> = (0..4).flat_map(|_| raw_row(&p, &mut rng)).map(|x| x as f32).collect();
        let (mut a, mut b) = (Vec::new(), Vec::new());
        p.act(&obs, &mut a);
        r.act(&obs, &mut b);
        let (a, b): (Vec<f64>, Vec<f64>) =
            (a.iter().map(|&x| x as f64).collect(), b.iter().map(|&x| x as f64).collect());
        close(&b, &a, 1e-4);
    }
}

#[test]
fn policies_of_different_networks_are_refused_by_name() {
    let (p, q) = (load("assets/policies/cassie/seed1.json"), load("assets/policies/C/seed1.json"));
    let err = average(&[q, p], &["assets/policies/C/seed1.json".into(), "cassie".into()]).err().unwrap().to_string();
    assert!(err.contains("assets/policies/C/seed1.json") && err.contains("not the same network"), "{err}");
    assert!(average(&[], &[]).is_err());
}
