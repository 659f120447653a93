//! The policy's forward pass with buffers sized at load: the normaliser (in f64, as in training), the concurrent
//! estimator when the policy has one, the actor (ELU MLPs, the last layer linear). No allocation per call.

use std::path::Path;

use nalgebra::{DMatrix, DVector};
use safetensors::{Dtype, SafeTensors};

use crate::error::{Error, Result};
use crate::spec::ControllerSpec;

struct Mlp {
    layers: Vec<(DMatrix<f32>, DVector<f32>)>,
    /// One output buffer per layer.
    out: Vec<DVector<f32>>,
}

impl Mlp {
    fn forward(&mut self, x: &DVector<f32>) -> &DVector<f32> {
        let last = self.layers.len() - 1;
        for (l, (w, b)) in self.layers.iter().enumerate() {
            let (done, rest) = self.out.split_at_mut(l);
            let y = &mut rest[0];
            let input = if l == 0 { x } else { &done[l - 1] };
            y.copy_from(b);
            y.gemv(1.0, w, input, 1.0);
            if l < last {
                y.apply(|v| *v = if *v > 0.0 { *v } else { v.exp_m1() });
            }
        }
        &self.out[last]
    }
}

/// The loaded networks and their buffers.
pub struct Networks {
    mean: Vec<f64>,
    scale: Vec<f64>,
    estimator: Option<Mlp>,
    actor: Mlp,
    inputs: DVector<f32>,
    actor_in: DVector<f32>,
}

fn tensor(st: &SafeTensors, name: &str, shape: &[usize], file: &Path) -> Result<Vec<f64>> {
    let bad = |message: String| Error::File { path: file.to_path_buf(), message };
    let t = st.tensor(name).map_err(|_| bad(format!("no tensor '{name}'")))?;
    if t.shape() != shape {
        return Err(bad(format!("'{name}' has shape {:?}, expected {shape:?}", t.shape())));
    }
    let v: Vec<f64> = match t.dtype() {
        Dtype::F32 => t.data().chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64).collect(),
        Dtype::F64 => t.data().chunks_exact(8).map(|b| f64::from_le_bytes(b.try_into().unwrap())).collect(),
        d => return Err(bad(format!("'{name}' is {d:?}, expected f32 or f64"))),
    };
    if v.iter().any(|x| !x.is_finite()) {
        return Err(bad(format!("'{name}' has non-finite values")));
    }
    Ok(v)
}

fn mlp(st: &SafeTensors, net: &str, dims: &[usize], file: &Path) -> Result<Mlp> {
    let mut layers = Vec::new();
    for i in 0..dims.len() - 1 {
        let (rows, cols) = (dims[i + 1], dims[i]);
        let w = tensor(st, &format!("{net}.{i}.weight"), &[rows, cols], file)?;
        let b = tensor(st, &format!("{net}.{i}.bias"), &[rows], file)?;
        layers.push((
            DMatrix::from_row_iterator(rows, cols, w.iter().map(|&x| x as f32)),
            DVector::from_iterator(rows, b.iter().map(|&x| x as f32)),
        ));
    }
    let out = dims[1..].iter().map(|&d| DVector::zeros(d)).collect();
    Ok(Mlp { layers, out })
}

impl Networks {
    /// Loads the weights file of `spec`, checking its checksum, every tensor's shape and its values.
    pub fn load(spec: &ControllerSpec, file: &Path) -> Result<Networks> {
        let bytes = std::fs::read(file).map_err(|source| Error::Io { path: file.to_path_buf(), source })?;
        let bad = |message: String| Error::File { path: file.to_path_buf(), message };
        if crc32fast::hash(&bytes) != spec.weights_crc32 {
            return Err(bad("does not match the controller file's checksum: export it again".into()));
        }
        let st = SafeTensors::deserialize(&bytes).map_err(|e| bad(format!("not a safetensors file: {e}")))?;
        let (o, n) = (&spec.observation, spec.n_motors());
        let mean = tensor(&st, "normalizer.mean", &[o.row], file)?;
        let m2 = tensor(&st, "normalizer.m2", &[o.row], file)?;
        let count = tensor(&st, "normalizer.count", &[1], file)?[0].max(1.0);
        // The trainer's normaliser: (x − mean) / (std + 1e-2).
        let scale = m2.iter().map(|m| 1.0 / ((m / count).sqrt() + 1e-2)).collect();
        let dims = |input: usize, hidden: &[usize], out: usize| -> Vec<usize> {
            std::iter::once(input).chain(hidden.iter().copied()).chain(std::iter::once(out)).collect()
        };
        let estimator = match &spec.estimator_hidden {
            Some(h) => Some(mlp(&st, "estimator", &dims(o.inputs, h, 3), file)?),
            None => None,
        };
        let actor_in = o.inputs + if estimator.is_some() { 3 } else { 0 };
        let actor = mlp(&st, "actor", &dims(actor_in, &spec.hidden, n), file)?;
        Ok(Networks {
            mean,
            scale,
            estimator,
            actor,
            inputs: DVector::zeros(o.inputs),
            actor_in: DVector::zeros(actor_in),
        })
    }

    /// The action for one raw observation row (the actor's inputs), into `action`.
    pub fn act(&mut self, row: &[f32], action: &mut [f64]) {
        for (i, x) in self.inputs.iter_mut().enumerate() {
            *x = ((row[i] as f64 - self.mean[i]) * self.scale[i]) as f32;
        }
        let k = self.inputs.len();
        self.actor_in.rows_mut(0, k).copy_from(&self.inputs);
        if let Some(e) = &mut self.estimator {
            let v = e.forward(&self.inputs);
            self.actor_in.rows_mut(k, 3).copy_from(v);
        }
        let a = self.actor.forward(&self.actor_in);
        for (o, v) in action.iter_mut().zip(a.iter()) {
            *o = *v as f64;
        }
    }
}
