//! Excitation signals for actuator identification (the paper: "frequency-rich signals applied to the motors"):
//! a logarithmic chirp, a multisine with random phases, or a pseudo-random binary sequence, with amplitude, band and
//! duration chosen, faded in and out so that a bench or a hanging robot starts and ends at rest; written as a CSV a
//! bench controller can play (one column of targets per motor, around each motor's offset).

use std::f64::consts::{PI, TAU};
use std::fmt::Write as _;

use crate::error::{ensure, Result};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The signal's shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Shape {
    /// Logarithmic sweep from the band's low to its high frequency.
    Chirp,
    /// Sum of sines at log-spaced frequencies over the band, random phases, scaled to the amplitude.
    Multisine,
    /// ± amplitude, flipping or not at random every 1 / (2 × band high) s.
    Prbs,
}

/// What the targets command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum CommandKind {
    /// Position targets for the motor's PD loop (rad, around each motor's offset).
    Position,
    /// Torque (N·m).
    Torque,
}

impl CommandKind {
    /// The log column's quantity (`<motor>:<quantity>`).
    pub fn column(self) -> &'static str {
        match self {
            CommandKind::Position => "target",
            CommandKind::Torque => "torque",
        }
    }
    pub fn unit(self) -> &'static str {
        match self {
            CommandKind::Position => "rad",
            CommandKind::Torque => "N·m",
        }
    }
}

/// An excitation design.
#[derive(Debug, Clone, PartialEq)]
pub struct Design {
    pub shape: Shape,
    /// Peak deviation from the offset (rad or N·m).
    pub amplitude: f64,
    /// [low, high] frequency, Hz.
    pub band: [f64; 2],
    pub duration_s: f64,
    /// Samples per second of the written trajectory.
    pub rate_hz: f64,
    /// Fade in and out, s.
    pub fade_s: f64,
    pub seed: u64,
}

/// Sines in a multisine.
const MULTISINE_TONES: usize = 24;

impl Design {
    /// Refuses a design that cannot excite its band (a band above Nyquist, a non-positive amplitude…).
    pub fn check(&self) -> Result<()> {
        let [lo, hi] = self.band;
        ensure!(self.amplitude > 0.0 && self.amplitude.is_finite(), "--amplitude must be positive");
        ensure!(lo > 0.0 && hi > lo, "--band LOW,HIGH needs 0 < LOW < HIGH (Hz), got {lo},{hi}");
        ensure!(
            hi <= self.rate_hz / 4.0,
            "--band high {hi} Hz needs --rate of at least {} Hz (four samples per period), got {}",
            4.0 * hi,
            self.rate_hz
        );
        ensure!(
            self.duration_s >= 2.0 * self.fade_s + 1.0 / lo,
            "--duration {} s is too short for the band's low {lo} Hz (one period) and the fades",
            self.duration_s
        );
        Ok(())
    }

    pub fn samples(&self) -> usize {
        (self.duration_s * self.rate_hz).round() as usize + 1
    }

    /// The signal for motor `m` (its own random phases / switching, from the seed and m), one value per sample.
    pub fn signal(&self, m: usize) -> Vec<f64> {
        let n = self.samples();
        let dt = 1.0 / self.rate_hz;
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        rng.set_stream(m as u64);
        let [lo, hi] = self.band;
        let t_end = self.duration_s;
        let raw: Vec<f64> = match self.shape {
            Shape::Chirp => {
                let k = (hi / lo).ln() / t_end;
                (0..n).map(|i| (TAU * lo * (((k * i as f64 * dt).exp() - 1.0) / k)).sin()).collect()
            }
            Shape::Multisine => {
                // Log-spaced tones snapped to whole periods of the run (multiples of 1/T): no leakage between
                // them in a spectrum of the whole run, and no two alike.
                let df = 1.0 / t_end;
                let mut bins: Vec<u64> = (0..MULTISINE_TONES)
                    .map(|j| {
                        (lo * (hi / lo).powf(j as f64 / (MULTISINE_TONES - 1) as f64) / df).round().max(1.0) as u64
                    })
                    .collect();
                bins.dedup();
                let tones: Vec<(f64, f64)> =
                    bins.iter().map(|&b| (b as f64 * df, rng.random_range(0.0..TAU))).collect();
                (0..n).map(|i| tones.iter().map(|(f, p)| (TAU * f * i as f64 * dt + p).sin()).sum()).collect()
            }
            Shape::Prbs => {
                let bit = 1.0 / (2.0 * hi);
                let mut out = Vec::with_capacity(n);
                let (mut level, mut next) = (1.0, 0.0);
                for i in 0..n {
                    let t = i as f64 * dt;
                    if t >= next {
                        // Flat spectrum up to ~0.9 × high (sinc² of the bit), down to 1 / duration.
                        if rng.random::<bool>() {
                            level = -level;
                        }
                        next += bit;
                    }
                    out.push(level);
                }
                out
            }
        };
        let peak = raw.iter().fold(0.0f64, |a, x| a.max(x.abs())).max(1e-12);
        raw.iter()
            .enumerate()
            .map(|(i, x)| self.amplitude * x / peak * fade(i as f64 * dt, t_end, self.fade_s))
            .collect()
    }
}

/// A raised-cosine fade in over the first `f` seconds and out over the last.
fn fade(t: f64, end: f64, f: f64) -> f64 {
    if f <= 0.0 {
        return 1.0;
    }
    let edge = t.min(end - t).max(0.0);
    if edge >= f {
        1.0
    } else {
        0.5 - 0.5 * (PI * edge / f).cos()
    }
}

/// The trajectory as CSV: a header naming what is commanded, then `time` and one `<motor>:target` (position) or
/// `<motor>:torque` column per motor (offset + signal): the command columns of the log `topa sysid fit` reads.
pub fn csv(d: &Design, kind: CommandKind, motors: &[(String, f64)]) -> String {
    let mut s = format!(
        "# topa sysid excite: {} {}, amplitude {} {}, band {}–{} Hz, {} s at {} Hz, seed {}\n",
        format!("{kind:?}").to_lowercase(),
        format!("{:?}", d.shape).to_lowercase(),
        d.amplitude,
        kind.unit(),
        d.band[0],
        d.band[1],
        d.duration_s,
        d.rate_hz,
        d.seed
    );
    s.push_str("time");
    for (name, _) in motors {
        let _ = write!(s, ",{name}:{}", kind.column());
    }
    s.push('\n');
    let signals: Vec<Vec<f64>> = (0..motors.len()).map(|m| d.signal(m)).collect();
    for i in 0..d.samples() {
        let _ = write!(s, "{:.6}", i as f64 / d.rate_hz);
        for (m, (_, offset)) in motors.iter().enumerate() {
            let _ = write!(s, ",{:.6}", offset + signals[m][i]);
        }
        s.push('\n');
    }
    s
}

/// One-sided amplitude spectrum of `x` sampled at `rate` Hz: (frequency, amplitude) up to Nyquist.
pub fn spectrum(x: &[f64], rate: f64) -> Vec<(f64, f64)> {
    use rustfft::num_complex::Complex;
    let n = x.len();
    let mut buf: Vec<Complex<f64>> = x.iter().map(|&v| Complex::new(v, 0.0)).collect();
    rustfft::FftPlanner::new().plan_fft_forward(n).process(&mut buf);
    (1..n / 2).map(|k| (k as f64 * rate / n as f64, 2.0 * buf[k].norm() / n as f64)).collect()
}

/// Share of the signal's energy inside `band` (Hz).
pub fn energy_in_band(x: &[f64], rate: f64, band: [f64; 2]) -> f64 {
    let s = spectrum(x, rate);
    let total: f64 = s.iter().map(|(_, a)| a * a).sum();
    let inside: f64 = s.iter().filter(|(f, _)| *f >= band[0] && *f <= band[1]).map(|(_, a)| a * a).sum();
    inside / total.max(1e-300)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn design(shape: Shape) -> Design {
        Design { shape, amplitude: 0.3, band: [0.5, 20.0], duration_s: 30.0, rate_hz: 500.0, fade_s: 0.5, seed: 7 }
    }

    #[test]
    fn every_shape_stays_within_its_amplitude_starts_and_ends_at_rest_and_fills_its_band() {
        for shape in [Shape::Chirp, Shape::Multisine, Shape::Prbs] {
            let d = design(shape);
            d.check().unwrap();
            let x = d.signal(0);
            assert_eq!(x.len(), 15_001);
            let peak = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            assert!(peak <= 0.3 + 1e-12 && peak > 0.25, "{shape:?}: peak {peak}");
            assert!(x[0].abs() < 1e-12 && x[x.len() - 1].abs() < 1e-9, "{shape:?} fades in and out");
            let share = energy_in_band(&x, 500.0, [0.4, 25.0]);
            // A binary sequence spreads some energy above its band (its edges); the sines keep it inside.
            let want = if shape == Shape::Prbs { 0.7 } else { 0.95 };
            assert!(share > want, "{shape:?}: {share:.3} of the energy in the band");
        }
    }

    #[test]
    fn motors_get_their_own_phases_and_a_seed_fixes_them() {
        let d = design(Shape::Multisine);
        assert_ne!(d.signal(0), d.signal(1));
        assert_eq!(d.signal(1), design(Shape::Multisine).signal(1));
        let c = csv(&d, CommandKind::Position, &[("l_knee".into(), 0.7), ("r_knee".into(), 0.7)]);
        let mut lines = c.lines();
        assert!(lines.next().unwrap().starts_with("# topa sysid excite: position multisine"));
        assert_eq!(lines.next().unwrap(), "time,l_knee:target,r_knee:target");
        assert_eq!(lines.next().unwrap(), "0.000000,0.700000,0.700000");
    }

    #[test]
    fn designs_that_cannot_excite_their_band_are_refused() {
        let err = |d: Design| d.check().unwrap_err().to_string();
        assert!(err(Design { band: [0.5, 200.0], ..design(Shape::Chirp) }).contains("--rate of at least 800"));
        assert!(err(Design { band: [5.0, 1.0], ..design(Shape::Chirp) }).contains("0 < LOW < HIGH"));
        assert!(err(Design { amplitude: 0.0, ..design(Shape::Chirp) }).contains("--amplitude"));
        assert!(err(Design { duration_s: 1.0, ..design(Shape::Chirp) }).contains("too short"));
    }
}
