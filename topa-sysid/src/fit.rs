//! Identification: the bench's parameters that make MuJoCo replay a log best, by Levenberg–Marquardt (the
//! `levenberg-marquardt` crate) on the position error over short windows (multiple shooting: each window starts
//! from the logged state, so drift never dominates), with box bounds and 95 % confidence intervals.

use super::lm::{self, DMatrix, Residuals};
use crate::error::{ensure, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::bench::{Bench, MotorParams, Params, Window};
use super::log::MotorLog;

/// A parameter kind the fit can free.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    Armature,
    Damping,
    Frictionloss,
    TorqueConstant,
    Delay,
}

impl Kind {
    pub const ALL: [Kind; 5] = [Kind::Armature, Kind::Damping, Kind::Frictionloss, Kind::TorqueConstant, Kind::Delay];

    pub fn name(self) -> &'static str {
        match self {
            Kind::Armature => "armature",
            Kind::Damping => "damping",
            Kind::Frictionloss => "frictionloss",
            Kind::TorqueConstant => "torque_constant",
            Kind::Delay => "delay",
        }
    }

    pub fn unit(self) -> &'static str {
        match self {
            Kind::Armature => "kg·m²",
            Kind::Damping => "N·m·s/rad",
            Kind::Frictionloss => "N·m",
            Kind::TorqueConstant => "× (N·m/A for current)",
            Kind::Delay => "s",
        }
    }

    /// This kind's value of motor `m` in `p` (the delay is shared).
    pub fn get(self, p: &Params, m: usize) -> f64 {
        let q = &p.motors[m];
        match self {
            Kind::Armature => q.armature,
            Kind::Damping => q.damping,
            Kind::Frictionloss => q.frictionloss,
            Kind::TorqueConstant => q.torque_constant,
            Kind::Delay => p.delay_s,
        }
    }

    fn set(self, p: &mut Params, m: usize, v: f64) {
        let q: &mut MotorParams = &mut p.motors[m];
        match self {
            Kind::Armature => q.armature = v,
            Kind::Damping => q.damping = v,
            Kind::Frictionloss => q.frictionloss = v,
            Kind::TorqueConstant => q.torque_constant = v,
            Kind::Delay => p.delay_s = v,
        }
    }
}

/// One free parameter: which, of which motor (the delay is shared: motor 0), and its box.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Free {
    pub kind: Kind,
    pub motor: usize,
    pub bounds: [f64; 2],
}

/// The fit's settings.
#[derive(Debug, Clone)]
pub struct FitOptions {
    pub kinds: Vec<Kind>,
    /// Samples per window.
    pub window: usize,
    /// Upper bound of the delay, s.
    pub max_delay: f64,
    /// Upper bounds are this many times the nominal value (lower bounds 0; the torque constant's 1/this).
    pub range: f64,
    pub max_evaluations: usize,
}

/// A fitted value with its 95 % interval (infinite when the log cannot tell it).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Estimate {
    pub kind: Kind,
    pub motor: usize,
    pub value: f64,
    pub ci95: [f64; 2],
    /// The value sits on its box (the interval then says little).
    pub at_bound: bool,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FitResult {
    pub params: Params,
    pub estimates: Vec<Estimate>,
    pub converged: bool,
    /// The optimiser's reason for stopping.
    pub termination: String,
    pub evaluations: usize,
    /// Position RMSE over the fitted windows, rad: with the start values and with the fitted ones.
    pub rmse_start: f64,
    pub rmse: f64,
    /// Lag-1 autocorrelation of the residuals: the intervals are widened by (1 + ρ)/(1 − ρ) for it.
    pub residual_autocorrelation: f64,
}

/// θ = lo + (hi − lo)(1 + sin z)/2: every z maps into the box (the bounded transform of MINUIT).
fn to_theta(z: f64, [lo, hi]: [f64; 2]) -> f64 {
    lo + (hi - lo) * (1.0 + z.sin()) / 2.0
}

fn to_z(theta: f64, [lo, hi]: [f64; 2]) -> f64 {
    // Never start on the box's edge, where the transform's slope is zero.
    let margin = 0.02 * (hi - lo);
    let t = theta.clamp(lo + margin, hi - margin);
    (2.0 * (t - lo) / (hi - lo) - 1.0).asin()
}

struct Problem<'a> {
    bench: &'a Bench,
    log: &'a MotorLog,
    windows: &'a [Window],
    measured: Vec<f64>,
    base: Params,
    free: Vec<Free>,
}

impl Problem<'_> {
    fn params_at(&self, theta: &[f64]) -> Params {
        let mut p = self.base.clone();
        for (f, &t) in self.free.iter().zip(theta) {
            f.kind.set(&mut p, f.motor, t);
        }
        p
    }

    fn theta(&self, z: &[f64]) -> Vec<f64> {
        self.free.iter().zip(z).map(|(f, &z)| to_theta(z, f.bounds)).collect()
    }

    fn residuals_at(&self, theta: &[f64]) -> Option<Vec<f64>> {
        let sim = self.bench.simulate(&self.params_at(theta), self.log, self.windows).ok()?;
        Some(sim.iter().zip(&self.measured).map(|(s, m)| s - m).collect())
    }

    /// ∂r/∂θ by forward differences, the perturbed rollouts in parallel. Motors of different trees are
    /// independent: one rollout perturbs one kind of parameter on one motor of each tree, and each tree's rows
    /// give its motor's column.
    fn jacobian_theta(&self, theta: &[f64], r0: &[f64]) -> Option<DMatrix<f64>> {
        let n_motors = self.bench.motors.len();
        let step = |j: usize| {
            let f = &self.free[j];
            let h = 1e-3 * theta[j].abs().max(0.05 * (f.bounds[1] - f.bounds[0]));
            // Step towards the box's inside.
            if theta[j] + h > f.bounds[1] {
                -h
            } else {
                h
            }
        };
        // One rollout per (kind, slot): the slot-th motor of every tree moves that kind of parameter at once.
        let tree = &self.bench.tree;
        let slot = |m: usize| tree[..m].iter().filter(|&&t| t == tree[m]).count();
        let mut groups: Vec<Vec<usize>> = Vec::new();
        let mut keys: Vec<(Kind, usize)> = Vec::new();
        for (j, f) in self.free.iter().enumerate() {
            let key = (f.kind, if f.kind == Kind::Delay { usize::MAX } else { slot(f.motor) });
            match keys.iter().position(|k| *k == key) {
                Some(g) => groups[g].push(j),
                None => {
                    keys.push(key);
                    groups.push(vec![j]);
                }
            }
        }
        let rollouts: Vec<Option<Vec<f64>>> = groups
            .par_iter()
            .map(|cols| {
                let mut t = theta.to_vec();
                cols.iter().for_each(|&j| t[j] += step(j));
                self.residuals_at(&t)
            })
            .collect();
        let mut jac = DMatrix::zeros(r0.len(), self.free.len());
        for (cols, r) in groups.iter().zip(rollouts) {
            let r = r?;
            for &j in cols {
                let h = step(j);
                let f = &self.free[j];
                let shared = cols.len() == 1 || f.kind == Kind::Delay;
                for (row, (a, b)) in r.iter().zip(r0).enumerate() {
                    if shared || tree[row % n_motors] == tree[f.motor] {
                        jac[(row, j)] = (a - b) / h;
                    }
                }
            }
        }
        Some(jac)
    }
}

impl Residuals for Problem<'_> {
    fn residuals(&self, z: &[f64]) -> Option<Vec<f64>> {
        self.residuals_at(&self.theta(z))
    }

    fn jacobian(&self, z: &[f64]) -> Option<DMatrix<f64>> {
        let theta = self.theta(z);
        let r0 = self.residuals_at(&theta)?;
        let mut j = self.jacobian_theta(&theta, &r0)?;
        // Chain rule through the bounded transform.
        for (c, (f, &z)) in self.free.iter().zip(z).enumerate() {
            let d = (f.bounds[1] - f.bounds[0]) / 2.0 * z.cos();
            j.column_mut(c).scale_mut(d);
        }
        Some(j)
    }
}

/// The free parameters and their boxes.
pub fn free_parameters(bench: &Bench, start: &Params, o: &FitOptions) -> Vec<Free> {
    let mut free = Vec::new();
    for m in 0..bench.motors.len() {
        for &kind in &o.kinds {
            let nominal = kind.get(start, m);
            let bounds = match kind {
                Kind::Delay => continue,
                Kind::TorqueConstant => [nominal / o.range, nominal * o.range],
                // A zero nominal gets a box in the unit's own scale.
                _ => [0.0, if nominal > 0.0 { nominal * o.range } else { 1.0 }],
            };
            free.push(Free { kind, motor: m, bounds });
        }
    }
    if o.kinds.contains(&Kind::Delay) {
        free.push(Free { kind: Kind::Delay, motor: 0, bounds: [0.0, o.max_delay] });
    }
    free
}

fn rms(r: &[f64]) -> f64 {
    (r.iter().map(|x| x * x).sum::<f64>() / r.len().max(1) as f64).sqrt()
}

/// Fits `start`'s free parameters to the log's `windows`.
pub fn fit(bench: &Bench, log: &MotorLog, windows: &[Window], start: &Params, o: &FitOptions) -> Result<FitResult> {
    let free = free_parameters(bench, start, o);
    ensure!(!free.is_empty(), "nothing to fit: --fit names no parameter");
    let measured = bench.measured(log, windows);
    ensure!(measured.len() > 2 * free.len(), "the fitted part of the log is too short for {} parameters", free.len());
    let z0: Vec<f64> = free.iter().map(|f| to_z(f.kind.get(start, f.motor), f.bounds)).collect();
    let problem = Problem { bench, log, windows, measured, base: start.clone(), free };
    let rmse_start = rms(&problem.residuals_at(&problem.theta(&z0)).unwrap_or_default());
    let min = lm::minimize(&problem, z0, o.max_evaluations / (problem.free.len() + 1));
    let theta = problem.theta(&min.z);
    let params = problem.params_at(&theta);
    let r = problem.residuals_at(&theta).unwrap_or_default();
    let rmse = rms(&r);
    let n_motors = bench.motors.len();
    // Lag-1 autocorrelation of each motor's residual series (stride n_motors), pooled.
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..r.len() {
        den += r[i] * r[i];
        if i + n_motors < r.len() {
            num += r[i] * r[i + n_motors];
        }
    }
    let rho = if den > 0.0 { (num / den).clamp(0.0, 0.99) } else { 0.0 };
    let cov = covariance(&problem, &theta, &r, rho);
    let estimates = problem
        .free
        .iter()
        .enumerate()
        .map(|(j, f)| {
            let sd = cov.as_ref().map(|c| c[(j, j)].max(0.0).sqrt()).unwrap_or(f64::INFINITY);
            let sd = if sd.is_finite() { sd } else { f64::INFINITY };
            let edge = 1e-3 * (f.bounds[1] - f.bounds[0]);
            Estimate {
                kind: f.kind,
                motor: f.motor,
                value: theta[j],
                ci95: [theta[j] - 1.96 * sd, theta[j] + 1.96 * sd],
                at_bound: theta[j] - f.bounds[0] < edge || f.bounds[1] - theta[j] < edge,
            }
        })
        .collect();
    Ok(FitResult {
        params,
        estimates,
        converged: min.converged,
        termination: min.termination,
        evaluations: min.evaluations,
        rmse_start,
        rmse,
        residual_autocorrelation: rho,
    })
}

/// s² (JᵀJ)⁻¹ in θ, widened for correlated residuals. A parameter the log does not move at all gets an infinite
/// variance (and the others their own); None when JᵀJ is singular among the rest.
fn covariance(p: &Problem, theta: &[f64], r: &[f64], rho: f64) -> Option<DMatrix<f64>> {
    let j = p.jacobian_theta(theta, r)?;
    let dof = r.len().saturating_sub(theta.len()).max(1) as f64;
    let s2 = r.iter().map(|x| x * x).sum::<f64>() / dof;
    let jtj = j.transpose() * &j;
    let seen: Vec<usize> = (0..jtj.nrows()).filter(|&i| jtj[(i, i)] > 0.0).collect();
    // Scale to unit diagonal before inverting: the parameters' units differ by orders of magnitude.
    let d: Vec<f64> = seen.iter().map(|&i| jtj[(i, i)].sqrt()).collect();
    let scaled = DMatrix::from_fn(seen.len(), seen.len(), |a, b| jtj[(seen[a], seen[b])] / (d[a] * d[b]));
    let inv = scaled.try_inverse()?;
    let inflation = (1.0 + rho) / (1.0 - rho);
    let mut cov = DMatrix::from_element(jtj.nrows(), jtj.ncols(), 0.0);
    for i in 0..jtj.nrows() {
        cov[(i, i)] = f64::INFINITY;
    }
    for (a, &ia) in seen.iter().enumerate() {
        for (b, &ib) in seen.iter().enumerate() {
            cov[(ia, ib)] = s2 * inflation * inv[(a, b)] / (d[a] * d[b]);
        }
    }
    Some(cov)
}

/// Position RMSE of `params` replaying `windows` of the log, rad.
pub fn rmse(bench: &Bench, log: &MotorLog, windows: &[Window], params: &Params) -> Result<f64> {
    let sim = bench.simulate(params, log, windows)?;
    let meas = bench.measured(log, windows);
    Ok(rms(&sim.iter().zip(&meas).map(|(s, m)| s - m).collect::<Vec<_>>()))
}
