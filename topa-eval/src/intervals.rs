//! Interval estimates for few-seed claims, after rliable (Agarwal et al. 2021, "Deep RL at the Edge of the
//! Statistical Precipice"): scores as a runs × tasks matrix per group (runs = seeds; tasks = push-grid cells, or one
//! task for a per-seed number), the mean and the interquartile mean (IQM) of all scores, percentile 95 % confidence
//! intervals from a bootstrap stratified by group (each group's seeds resampled on their own), the difference of two
//! groups' means with its interval, and the probability of improvement P(X > Y).
//!
//! Where we part from rliable's default: it resamples runs independently within each task, which suits Atari games
//! but not the cells of one push grid — a seed that falls under one force falls under its neighbours, and drawing
//! seeds per cell would average that away into an interval far too narrow (two O seeds 0.7 s apart gave ±0.2 s).
//! So a seed is resampled whole, its cells together. Two additions where our data is richer than a score per run:
//! a seed's command-noise success rate is a count of Bernoulli runs, so each replicate redraws it (20 runs per
//! level resolve far less than 100); and a grid that is a sample of the paper's grid (the quick protocol's 7 × 7
//! cells of the 13 × 13) is bootstrapped over cells too (rliable's `task_bootstrap`), so that the interval covers
//! which forces were sampled.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Bootstrap replicates (rliable's default is 50 000 for its figures; 10 000 fixes the second decimal here).
pub const REPLICATES: usize = 10_000;
/// Seeds per group below which a bootstrap interval is shown but decides nothing: the percentile bootstrap
/// under-covers badly on three values (it cannot see beyond the extremes it was given).
pub const MIN_RUNS_FOR_VERDICT: usize = 5;
/// Fixed, so that a report renders the same intervals every time from the same JSON.
const SEED: u64 = 0x5EED_CAFE;

/// A point estimate and its 95 % interval.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Interval {
    pub point: f64,
    pub lo: f64,
    pub hi: f64,
}

impl Interval {
    /// "point [lo, hi]" with `digits` decimals; "–" without data.
    pub fn show(&self, digits: usize) -> String {
        if !self.point.is_finite() {
            "–".into()
        } else {
            format!("{:.d$} [{:.d$}, {:.d$}]", self.point, self.lo, self.hi, d = digits)
        }
    }
    /// Above zero, below zero, or straddling it.
    pub fn sign(&self) -> Option<bool> {
        if self.lo > 0.0 {
            Some(true)
        } else if self.hi < 0.0 {
            Some(false)
        } else {
            None
        }
    }
}

/// One group's scores: `runs[r][t]` is run r's score on task t. `trials[r][t]`, where given, is the number of
/// Bernoulli runs behind a success percentage (each replicate redraws it).
#[derive(Debug, Clone, Default)]
pub struct Scores {
    pub runs: Vec<Vec<f64>>,
    pub trials: Option<Vec<Vec<usize>>>,
}

impl Scores {
    /// One number per run (a single task).
    pub fn per_run(xs: &[f64]) -> Scores {
        Scores { runs: xs.iter().filter(|x| x.is_finite()).map(|&x| vec![x]).collect(), trials: None }
    }
    pub fn len(&self) -> usize {
        self.runs.len()
    }
    fn tasks(&self) -> usize {
        self.runs.first().map_or(0, Vec::len)
    }
    pub fn is_empty(&self) -> bool {
        self.runs.is_empty() || self.tasks() == 0
    }
}

/// How to resample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resampling {
    /// Also resample the tasks (a grid sampled from a larger one).
    pub tasks: bool,
}

/// Mean of all scores.
pub fn mean(runs: &[Vec<f64>]) -> f64 {
    let n: usize = runs.iter().map(Vec::len).sum();
    runs.iter().flatten().sum::<f64>() / n as f64
}

/// Interquartile mean of all scores: the mean of the middle 50 % (scipy's `trim_mean(x, 0.25)`, as rliable).
pub fn iqm(runs: &[Vec<f64>]) -> f64 {
    let mut all: Vec<f64> = runs.iter().flatten().copied().collect();
    all.sort_by(f64::total_cmp);
    let cut = all.len() / 4;
    let mid = &all[cut..all.len() - cut];
    mid.iter().sum::<f64>() / mid.len() as f64
}

/// P(X > Y) + ½ P(X = Y) between two groups' scores, averaged over tasks (rliable's probability of improvement).
pub fn probability_of_improvement(x: &[Vec<f64>], y: &[Vec<f64>]) -> f64 {
    let tasks = x.first().map_or(0, Vec::len);
    let mut sum = 0.0;
    for t in 0..tasks {
        let mut s = 0.0;
        for a in x {
            for b in y {
                s += if a[t] > b[t] {
                    1.0
                } else if a[t] == b[t] {
                    0.5
                } else {
                    0.0
                };
            }
        }
        sum += s / (x.len() * y.len()) as f64;
    }
    sum / tasks as f64
}

/// One bootstrap replicate of a group: its runs drawn with replacement, each whole (with `tasks`, the tasks were
/// drawn first, shared by both groups); success percentages redrawn from their runs.
fn replicate(s: &Scores, task_ids: &[usize], rng: &mut ChaCha8Rng) -> Vec<Vec<f64>> {
    let n = s.runs.len();
    let picks: Vec<usize> = (0..n).map(|_| rng.random_range(0..n)).collect();
    let mut out = vec![vec![0.0; task_ids.len()]; n];
    for (j, &t) in task_ids.iter().enumerate() {
        for (row, &r) in out.iter_mut().zip(&picks) {
            let x = s.runs[r][t];
            row[j] = match &s.trials {
                Some(trials) if trials[r][t] > 0 => {
                    let k = trials[r][t];
                    let p = x / 100.0;
                    100.0 * (0..k).filter(|_| rng.random::<f64>() < p).count() as f64 / k as f64
                }
                _ => x,
            };
        }
    }
    out
}

fn task_draw(tasks: usize, how: Resampling, rng: &mut ChaCha8Rng) -> Vec<usize> {
    if how.tasks {
        (0..tasks).map(|_| rng.random_range(0..tasks)).collect()
    } else {
        (0..tasks).collect()
    }
}

fn percentile_interval(point: f64, mut reps: Vec<f64>) -> Interval {
    reps.sort_by(f64::total_cmp);
    let at = |q: f64| reps[((q * (reps.len() - 1) as f64).round() as usize).min(reps.len() - 1)];
    Interval { point, lo: at(0.025), hi: at(0.975) }
}

const NONE: Interval = Interval { point: f64::NAN, lo: f64::NAN, hi: f64::NAN };

/// An aggregate of one group's scores with its 95 % interval.
pub fn interval(s: &Scores, how: Resampling, aggregate: fn(&[Vec<f64>]) -> f64) -> Interval {
    if s.is_empty() {
        return NONE;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    let reps = (0..REPLICATES)
        .map(|_| {
            let ids = task_draw(s.tasks(), how, &mut rng);
            aggregate(&replicate(s, &ids, &mut rng))
        })
        .collect();
    percentile_interval(aggregate(&s.runs), reps)
}

/// The difference of two groups' means, `x − y`, and P(X > Y), each with its 95 % interval. The groups are
/// resampled independently (they are different seeds); drawn tasks are shared (the same forces for both).
pub fn compare(x: &Scores, y: &Scores, how: Resampling) -> Option<(Interval, Interval)> {
    if x.is_empty() || y.is_empty() || x.tasks() != y.tasks() {
        return None;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    // P(X > Y) is not linear in a cell's percentage: redrawing a cell's trials breaks its ties (100 % against
    // 100 %) one way more often than the other and pulls every replicate down, so that the estimate fell outside
    // its own interval. Its interval resamples runs only, on a stream of its own (the difference's is unchanged).
    let mut rng_p = ChaCha8Rng::seed_from_u64(SEED + 1);
    let runs_only = |s: &Scores| Scores { runs: s.runs.clone(), trials: None };
    let (xr, yr) = (runs_only(x), runs_only(y));
    let (mut diffs, mut probs) = (Vec::with_capacity(REPLICATES), Vec::with_capacity(REPLICATES));
    for _ in 0..REPLICATES {
        let ids = task_draw(x.tasks(), how, &mut rng);
        let (a, b) = (replicate(x, &ids, &mut rng), replicate(y, &ids, &mut rng));
        diffs.push(mean(&a) - mean(&b));
        let ids = task_draw(x.tasks(), how, &mut rng_p);
        probs.push(probability_of_improvement(&replicate(&xr, &ids, &mut rng_p), &replicate(&yr, &ids, &mut rng_p)));
    }
    Some((
        percentile_interval(mean(&x.runs) - mean(&y.runs), diffs),
        percentile_interval(probability_of_improvement(&x.runs, &y.runs), probs),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iqm_trims_a_quarter_each_side_and_mean_is_plain() {
        let runs = vec![vec![1.0, 2.0], vec![3.0, 4.0], vec![5.0, 6.0], vec![7.0, 100.0]];
        assert_eq!(iqm(&runs), (3.0 + 4.0 + 5.0 + 6.0) / 4.0);
        assert_eq!(mean(&runs), 128.0 / 8.0);
        // Three scores: nothing to trim (scipy's trim_mean(x, 0.25) cuts ⌊0.75⌋ = 0).
        assert_eq!(iqm(&[vec![1.0], vec![2.0], vec![9.0]]), 4.0);
    }

    #[test]
    fn probability_of_improvement_counts_ties_half() {
        let x = vec![vec![2.0, 1.0], vec![3.0, 1.0]];
        let y = vec![vec![1.0, 1.0], vec![2.0, 1.0]];
        // Task 0: pairs (2>1, 2=2, 3>1, 3>2) = 3.5 / 4; task 1: all ties = 0.5.
        assert!((probability_of_improvement(&x, &y) - (3.5 / 4.0 + 0.5) / 2.0).abs() < 1e-12);
    }

    #[test]
    fn the_probability_of_improvement_lies_in_its_own_interval() {
        // Every cell a win for x, some by 100 % against 50 %, some by 50 % against 0 %, two trials a cell:
        // redrawing the trials would turn wins into ties in nearly every replicate (the estimate 1.0 above the
        // interval's top, ~0.97).
        let cells = |a: f64, b: f64, k: usize| [vec![a; k], vec![b; 10 - k]].concat();
        let x = vec![cells(100.0, 50.0, 6), cells(100.0, 50.0, 7)];
        let y = vec![cells(50.0, 0.0, 6), cells(50.0, 0.0, 5)];
        let trials = Some(vec![vec![2; 10]; 2]);
        let (xs, ys) = (Scores { runs: x, trials: trials.clone() }, Scores { runs: y, trials });
        let (d, p) = compare(&xs, &ys, Resampling { tasks: false }).unwrap();
        assert_eq!(p.point, 1.0);
        assert!(p.lo <= p.point && p.point <= p.hi, "the estimate must lie in its interval: {p:?}");
        assert!(d.lo < d.point && d.point < d.hi, "the difference's interval still redraws the trials: {d:?}");
    }

    #[test]
    fn a_clear_difference_excludes_zero_and_overlapping_seeds_do_not() {
        let cells = |base: f64, n: usize| -> Vec<Vec<f64>> {
            (0..n).map(|r| (0..40).map(|c| base + 0.1 * r as f64 + 0.01 * c as f64).collect()).collect()
        };
        let hi = Scores { runs: cells(9.0, 3), trials: None };
        let lo = Scores { runs: cells(5.0, 3), trials: None };
        let (d, p) = compare(&hi, &lo, Resampling { tasks: false }).unwrap();
        assert!((d.point - 4.0).abs() < 1e-9 && d.sign() == Some(true), "{d:?}");
        assert_eq!((p.point, p.lo), (1.0, 1.0));
        // Two groups drawn from the same spread: the interval straddles zero.
        let a = Scores::per_run(&[8.0, 9.5, 9.0]);
        let b = Scores::per_run(&[8.5, 9.2, 9.4]);
        let (d, _) = compare(&a, &b, Resampling { tasks: false }).unwrap();
        assert_eq!(d.sign(), None, "{d:?}");
        assert!(d.lo < d.point && d.point < d.hi);
        // The same numbers give the same interval (the report renders identically from its JSON).
        assert_eq!(compare(&a, &b, Resampling { tasks: false }).unwrap().0, d);
    }

    #[test]
    fn fewer_noise_runs_widen_the_interval() {
        // Three seeds at 60 %, 65 %, 70 % success: from 20 runs each the interval is wider than from 100.
        let of = |k: usize| Scores { runs: vec![vec![60.0], vec![65.0], vec![70.0]], trials: Some(vec![vec![k]; 3]) };
        let (w20, w100) = (
            interval(&of(20), Resampling { tasks: false }, mean),
            interval(&of(100), Resampling { tasks: false }, mean),
        );
        assert!(w20.hi - w20.lo > 1.3 * (w100.hi - w100.lo), "20 runs {w20:?}, 100 runs {w100:?}");
        // Resampling the tasks widens a grid's interval when the cells differ.
        let grid = Scores { runs: vec![(0..49).map(|c| (c % 7) as f64).collect(); 2], trials: None };
        let fixed = interval(&grid, Resampling { tasks: false }, mean);
        let sampled = interval(&grid, Resampling { tasks: true }, mean);
        assert_eq!((fixed.lo, fixed.hi), (3.0, 3.0), "identical seeds: no spread over runs");
        assert!(sampled.hi - sampled.lo > 0.5, "{sampled:?}");
    }
}
