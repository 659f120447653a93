//! The candle custom ops: a single fused layer ([`LinearOp`], behind [`super::linear`]) and the layer chain behind
//! [`super::Mlp::forward`] ([`ChainOp`]).
//!
//! Both compute in [`super::layer`] on the raw storages and return freshly allocated vectors moved into candle
//! tensors (no copy). Backward kernels take the gradient in whatever layout candle hands over.
//!
//! The chain. candle's backward adds every gradient it receives into a fresh zero tensor
//! (`grads.or_insert(arg)` = `zeros_like` + `add`), which for the hidden activations of the paper's networks
//! (6144×(512+256+128) floats per pass) costs more memory traffic than the element-wise work of the layers
//! themselves. [`ChainOp`] therefore links the layers of one `Mlp::forward` call with 1-element *token* tensors:
//! each hidden layer's real output lives in a context shared by the chain's ops, the op of layer `l + 1` reads it
//! from there, and in backward op `l + 1` leaves the gradient with respect to layer `l`'s pre-activation in the
//! context for op `l` (candle runs the ops' backward in reverse topological order, so `l + 1` always comes first).
//! Only the network's input and its output are real graph tensors; every weight and bias is a real argument of
//! its layer's op and gets its gradient through candle as usual. The backward of layer `l + 1` also applies the
//! ELU derivative of layer `l` and sums its bias gradient right after the `dZ·W` product, block by block, while
//! the block is in cache.

use super::gemm::{MatRef, PackedB};
use super::kernels::Activation;
use super::layer;
use candle_core::{bail, CpuStorage, CustomOp3, Device, Layout, Result, Shape, Storage, Tensor};
use std::sync::{Arc, Mutex};

/// A 2-D f32 view of a CPU storage.
pub(crate) fn mat_of(s: &CpuStorage, l: &Layout, what: &str) -> Result<(MatRef, usize, usize)> {
    let data = match s {
        CpuStorage::F32(v) => v.as_slice(),
        _ => bail!("nn: {what} must be f32"),
    };
    let dims = l.dims();
    if dims.len() != 2 {
        bail!("nn: {what} must be 2-D, got shape {:?}", dims);
    }
    let (r, c) = (dims[0], dims[1]);
    let st = l.stride();
    if r > 0 && c > 0 {
        let last = l.start_offset() + (r - 1) * st[0] + (c - 1) * st[1];
        if last >= data.len() {
            bail!("nn: {what}: layout out of bounds");
        }
    }
    let ptr = data.as_ptr().wrapping_add(l.start_offset());
    Ok((MatRef { ptr, rs: st[0] as isize, cs: st[1] as isize }, r, c))
}

/// A contiguous f32 slice of a CPU storage (weights, biases, our own outputs).
pub(crate) fn slice_of<'a>(s: &'a CpuStorage, l: &Layout, what: &str) -> Result<&'a [f32]> {
    let data = match s {
        CpuStorage::F32(v) => v.as_slice(),
        _ => bail!("nn: {what} must be f32"),
    };
    match l.contiguous_offsets() {
        Some((a, b)) => Ok(&data[a..b]),
        None => bail!("nn: {what} must be contiguous"),
    }
}

fn cpu<'a>(s: &'a Storage, what: &str) -> Result<&'a CpuStorage> {
    match s {
        Storage::Cpu(c) => Ok(c),
        _ => bail!("nn: {what} must be on the CPU"),
    }
}

/// Runs `f` on the CPU f32 storage and layout of `t` (holding its read lock).
fn with_storage<R>(t: &Tensor, what: &str, f: impl FnOnce(&CpuStorage, &Layout) -> Result<R>) -> Result<R> {
    let (s, l) = t.storage_and_layout();
    f(cpu(&s, what)?, l)
}

fn tensor(v: Vec<f32>, shape: impl Into<Shape>) -> Result<Tensor> {
    Tensor::from_vec(v, shape.into(), &Device::Cpu)
}

fn check_layer(x_cols: usize, w_rows: usize, w_cols: usize, b_len: usize) -> Result<()> {
    if w_cols != x_cols {
        bail!("nn: input has {x_cols} features, weight is [{w_rows}, {w_cols}]");
    }
    if b_len != w_rows {
        bail!("nn: bias has {b_len} elements, weight is [{w_rows}, {w_cols}]");
    }
    Ok(())
}

/// One fused layer `y = act(x·Wᵀ + b)`; arguments `(x, W, b)`.
pub(crate) struct LinearOp {
    pub act: Activation,
}

impl CustomOp3 for LinearOp {
    fn name(&self) -> &'static str {
        "nn-linear"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
        s3: &CpuStorage,
        l3: &Layout,
    ) -> Result<(CpuStorage, Shape)> {
        let (x, m, k) = mat_of(s1, l1, "input")?;
        let w = slice_of(s2, l2, "weight")?;
        let b = slice_of(s3, l3, "bias")?;
        let n = b.len();
        check_layer(k, l2.dims()[0], *l2.dims().get(1).unwrap_or(&0), n)?;
        let mut y = Vec::with_capacity(m * n);
        // SAFETY: `forward` writes all m·n elements; f32 has no invalid bit patterns.
        #[allow(clippy::uninit_vec)]
        unsafe {
            y.set_len(m * n)
        };
        layer::forward(x, m, k, w, b, n, self.act, &mut y, &mut PackedB::default());
        Ok((CpuStorage::F32(y), Shape::from((m, n))))
    }

    fn bwd(
        &self,
        x: &Tensor,
        w: &Tensor,
        _b: &Tensor,
        y: &Tensor,
        dy: &Tensor,
    ) -> Result<(Option<Tensor>, Option<Tensor>, Option<Tensor>)> {
        let (m, n) = y.dims2()?;
        let k = x.dim(1)?;
        let (dz, db) = with_storage(dy, "gradient", |ds, dl| {
            with_storage(y, "output", |ys, yl| {
                let (dyv, _, _) = mat_of(ds, dl, "gradient")?;
                Ok(layer::output_grad(dyv, slice_of(ys, yl, "output")?, m, n, self.act))
            })
        })?;
        let dw = with_storage(x, "input", |xs, xl| {
            let (xv, _, _) = mat_of(xs, xl, "input")?;
            Ok(layer::weight_grad(&dz, xv, m, n, k))
        })?;
        let dx = if x.track_op() {
            let w = w.contiguous()?;
            let dx = with_storage(&w, "weight", |ws, wl| {
                Ok(layer::input_grad(&dz, slice_of(ws, wl, "weight")?, m, n, k, None).0)
            })?;
            Some(tensor(dx, (m, k))?)
        } else {
            None
        };
        Ok((dx, Some(tensor(dw, (n, k))?), Some(tensor(db, n)?)))
    }
}

/// What the ops of one chain share.
pub(crate) struct ChainCtx {
    rows: usize,
    /// Activation after each layer but the last.
    hidden_act: Activation,
    state: Mutex<ChainState>,
}

struct ChainState {
    /// Output of hidden layer `l` (post-activation), written by op `l`'s forward.
    hidden: Vec<Option<Arc<Vec<f32>>>>,
    /// Gradient with respect to layer `l`'s pre-activation and its bias gradient, left by op `l + 1`'s backward.
    pending: Vec<Option<(Vec<f32>, Vec<f32>)>>,
}

impl ChainCtx {
    pub fn new(rows: usize, n_layers: usize, hidden_act: Activation) -> Arc<Self> {
        Arc::new(ChainCtx {
            rows,
            hidden_act,
            state: Mutex::new(ChainState {
                hidden: vec![None; n_layers],
                pending: (0..n_layers).map(|_| None).collect(),
            }),
        })
    }

    fn hidden(&self, l: usize) -> Result<Arc<Vec<f32>>> {
        match &self.state.lock().unwrap().hidden[l] {
            Some(h) => Ok(h.clone()),
            None => bail!("nn: chain layer {l} has no stored output"),
        }
    }
}

/// Layer `l` of an [`Mlp`](super::Mlp) chain; arguments `(input, W_l, b_l)` where the input is the network input
/// for `l = 0` and the 1-element token of layer `l − 1` otherwise. Its result is the token (hidden layers) or the
/// network output (last layer).
pub(crate) struct ChainOp {
    pub ctx: Arc<ChainCtx>,
    pub l: usize,
    pub n_layers: usize,
}

impl ChainOp {
    fn act(&self) -> Activation {
        if self.l + 1 == self.n_layers {
            Activation::Identity
        } else {
            self.ctx.hidden_act
        }
    }
    fn is_last(&self) -> bool {
        self.l + 1 == self.n_layers
    }
}

/// The 1-element tensor that links two layers of a chain.
fn token() -> (CpuStorage, Shape) {
    (CpuStorage::F32(vec![0.0]), Shape::from(1))
}

impl CustomOp3 for ChainOp {
    fn name(&self) -> &'static str {
        "nn-mlp-layer"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
        s3: &CpuStorage,
        l3: &Layout,
    ) -> Result<(CpuStorage, Shape)> {
        let w = slice_of(s2, l2, "weight")?;
        let b = slice_of(s3, l3, "bias")?;
        let n = b.len();
        let m = self.ctx.rows;
        let mut y = Vec::with_capacity(m * n);
        // SAFETY: `forward` writes all m·n elements.
        #[allow(clippy::uninit_vec)]
        unsafe {
            y.set_len(m * n)
        };
        let k;
        if self.l == 0 {
            let (x, rows, cols) = mat_of(s1, l1, "input")?;
            debug_assert_eq!(rows, m);
            k = cols;
            check_layer(k, l2.dims()[0], *l2.dims().get(1).unwrap_or(&0), n)?;
            layer::forward(x, m, k, w, b, n, self.act(), &mut y, &mut PackedB::default());
        } else {
            let h = self.ctx.hidden(self.l - 1)?;
            k = *l2.dims().get(1).unwrap_or(&0);
            if h.len() != m * k {
                bail!("nn: layer {} expects {k} inputs, the previous layer has {}", self.l, h.len() / m.max(1));
            }
            check_layer(k, l2.dims()[0], k, n)?;
            layer::forward(MatRef::row_major(&h, k), m, k, w, b, n, self.act(), &mut y, &mut PackedB::default());
        }
        if self.is_last() {
            Ok((CpuStorage::F32(y), Shape::from((m, n))))
        } else {
            self.ctx.state.lock().unwrap().hidden[self.l] = Some(Arc::new(y));
            Ok(token())
        }
    }

    fn bwd(
        &self,
        input: &Tensor,
        w: &Tensor,
        b: &Tensor,
        res: &Tensor,
        grad: &Tensor,
    ) -> Result<(Option<Tensor>, Option<Tensor>, Option<Tensor>)> {
        let m = self.ctx.rows;
        let n = b.dim(0)?;
        // Gradient with respect to this layer's pre-activation, and the bias gradient.
        let (dz, db) = if self.is_last() {
            with_storage(grad, "gradient", |gs, gl| {
                with_storage(res, "output", |ys, yl| {
                    let (g, _, _) = mat_of(gs, gl, "gradient")?;
                    Ok(layer::output_grad(g, slice_of(ys, yl, "output")?, m, n, self.act()))
                })
            })?
        } else {
            match self.ctx.state.lock().unwrap().pending[self.l].take() {
                Some(p) => p,
                None => bail!("nn: chain layer {}: backward reached before the next layer's", self.l),
            }
        };
        let w = w.contiguous()?;
        let (dw, k, d_input) = with_storage(&w, "weight", |ws, wl| {
            let wv = slice_of(ws, wl, "weight")?;
            let k = wl.dims()[1];
            if self.l == 0 {
                let dw = with_storage(input, "input", |xs, xl| {
                    let (xv, _, _) = mat_of(xs, xl, "input")?;
                    Ok(layer::weight_grad(&dz, xv, m, n, k))
                })?;
                let dx = if input.track_op() {
                    Some(tensor(layer::input_grad(&dz, wv, m, n, k, None).0, (m, k))?)
                } else {
                    None
                };
                Ok((dw, k, dx))
            } else {
                let h = self.ctx.hidden(self.l - 1)?;
                let dw = layer::weight_grad(&dz, MatRef::row_major(&h, k), m, n, k);
                let (dz_prev, db_prev) = layer::input_grad(&dz, wv, m, n, k, Some((&h, self.ctx.hidden_act)));
                self.ctx.state.lock().unwrap().pending[self.l - 1] = Some((dz_prev, db_prev.unwrap()));
                // The token's gradient: its value is never used.
                Ok((dw, k, Some(tensor(vec![0.0], 1)?)))
            }
        })?;
        Ok((d_input, Some(tensor(dw, (n, k))?), Some(tensor(db, n)?)))
    }
}
