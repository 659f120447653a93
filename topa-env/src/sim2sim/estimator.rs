//! Contact-aided linear Kalman filter for the base position and velocity in the world frame — the estimator of
//! the MIT Cheetah software (Bledt et al., "MIT Cheetah 3", IROS 2018; `LinearKFPositionVelocityEstimator`),
//! which the paper cites, written for any number of feet.
//!
//! State `x = [p (3), v (3), f_1 (3), …, f_n (3)]`: base (IMU) position and velocity and each foot's position,
//! all in the world frame. Process: `p += v·dt + ½a·dt²`, `v += a·dt` with `a = R·f_imu + g` (the accelerometer's
//! specific force rotated by the IMU orientation, plus gravity); feet stay where they are. Measurements, per foot:
//! * its position relative to the base from leg kinematics, `f_i − p = R·r_i(q)`;
//! * the base velocity implied by a foot that does not move, `v = −R·(ω × r_i + ṙ_i(q, q̇))`;
//! * its height, `f_i,z = 0` (flat ground).
//!
//! A foot in contact is trusted with the configured noise once it has been down for `contact_ramp_s` (before,
//! trust ramps up linearly, as the Cheetah's phase-based trust does: a foot that just touched down still bounces
//! and slides); a swinging foot gets its measurement and process noise multiplied by `swing_scale`, so it
//! neither pulls the base nor stays pinned where it was.

use nalgebra::{DMatrix, DVector, Vector3};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Noise densities and variances of the filter (tunable in the sim2sim config).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct EstimatorConfig {
    /// Process noise on the base position, m²/s.
    pub q_position: f64,
    /// Process noise on the base velocity (accelerometer noise), (m/s)²/s.
    pub q_velocity: f64,
    /// Process noise on a foot in contact (slip), m²/s.
    pub q_foot: f64,
    /// Measurement variance of a foot's position relative to the base (kinematics, encoders), m².
    pub r_foot_position: f64,
    /// Measurement variance of the base velocity implied by a standing foot, (m/s)².
    pub r_foot_velocity: f64,
    /// Measurement variance of a standing foot's height, m².
    pub r_foot_height: f64,
    /// Factor on a swinging foot's noise (measurement and process).
    pub swing_scale: f64,
    /// Time after touchdown until a foot is fully trusted, s.
    pub contact_ramp_s: f64,
    /// A flat foot that rolls (heel-off, toe-off) is not standing still at its sole centre: its noise grows by
    /// 1 + (|ω_foot| / `roll_rate`)², ω_foot its angular velocity in the world, rad/s (0: off).
    pub roll_rate: f64,
}

impl Default for EstimatorConfig {
    fn default() -> Self {
        // The orders of magnitude of the Cheetah software's defaults (its process noise 0.02 on position and
        // velocity per step, 0.002 on feet; sensor noise 0.001 on relative positions, 0.1 on velocities,
        // 0.001 on heights; 100× for a swing foot), re-expressed per second for a rate-independent filter.
        EstimatorConfig {
            q_position: 0.02,
            q_velocity: 0.5,
            q_foot: 0.002,
            r_foot_position: 1e-4,
            r_foot_velocity: 0.01,
            r_foot_height: 1e-4,
            swing_scale: 1e4,
            contact_ramp_s: 0.03,
            roll_rate: 0.5,
        }
    }
}

/// What the filter reads each step (all in the world frame except where noted).
#[derive(Debug, Clone, Default)]
pub struct EstimatorInput {
    /// Base acceleration, world frame (R·f_imu + g), m/s².
    pub accel: Vector3<f64>,
    /// Each foot's position relative to the base (IMU), rotated to the world frame: R·r_i.
    pub foot_rel: Vec<Vector3<f64>>,
    /// The base velocity each foot implies if it stands still: −R·(ω × r_i + ṙ_i).
    pub foot_vel: Vec<Vector3<f64>>,
    pub contact: Vec<bool>,
    /// Each foot's angular speed in the world frame, rad/s.
    pub foot_spin: Vec<f64>,
}

#[derive(Debug, Clone)]
pub struct ContactKf {
    cfg: EstimatorConfig,
    feet: usize,
    /// Time each foot has been in contact, s (0 in swing).
    stance: Vec<f64>,
    x: DVector<f64>,
    p: DMatrix<f64>,
}

impl ContactKf {
    pub fn new(cfg: EstimatorConfig, feet: usize) -> Self {
        let n = 6 + 3 * feet;
        ContactKf { cfg, feet, stance: vec![0.0; feet], x: DVector::zeros(n), p: DMatrix::identity(n, n) * 1e-3 }
    }

    /// Starts at rest with the base `height` above the ground (x, y = 0) and the feet where kinematics puts them.
    pub fn reset(&mut self, height: f64, foot_rel: &[Vector3<f64>]) {
        let n = self.x.len();
        self.x.fill(0.0);
        self.x[2] = height;
        for (i, r) in foot_rel.iter().enumerate().take(self.feet) {
            for k in 0..3 {
                self.x[6 + 3 * i + k] = self.x[k] + r[k];
            }
        }
        self.p = DMatrix::identity(n, n) * 1e-3;
        // A robot starts standing: its feet are trusted at once.
        self.stance.fill(self.cfg.contact_ramp_s);
    }

    pub fn position(&self) -> Vector3<f64> {
        Vector3::new(self.x[0], self.x[1], self.x[2])
    }

    /// Estimated base velocity, world frame.
    pub fn velocity(&self) -> Vector3<f64> {
        Vector3::new(self.x[3], self.x[4], self.x[5])
    }

    /// The filter's complete state, flattened (for snapshots): x then the upper triangle of P.
    pub fn save(&self, out: &mut Vec<f64>) {
        out.extend(self.stance.iter());
        out.extend(self.x.iter());
        let n = self.x.len();
        for i in 0..n {
            for j in i..n {
                out.push(self.p[(i, j)]);
            }
        }
    }

    /// Inverse of `save`; returns the number of values read.
    pub fn load(&mut self, v: &[f64]) -> usize {
        let (n, f) = (self.x.len(), self.feet);
        self.stance.copy_from_slice(&v[..f]);
        self.x.copy_from_slice(&v[f..f + n]);
        let mut k = f + n;
        for i in 0..n {
            for j in i..n {
                self.p[(i, j)] = v[k];
                self.p[(j, i)] = v[k];
                k += 1;
            }
        }
        k
    }

    /// Values `save` writes.
    pub fn saved_len(&self) -> usize {
        let n = self.x.len();
        self.feet + n + n * (n + 1) / 2
    }

    /// One predict + update step of `dt` seconds. Returns false (and leaves the state unchanged) when an input is
    /// not finite or the update fails numerically; the caller then resets the filter.
    pub fn step(&mut self, dt: f64, u: &EstimatorInput) -> bool {
        let finite = u.accel.iter().all(|a| a.is_finite())
            && u.foot_rel.iter().chain(&u.foot_vel).all(|r| r.iter().all(|a| a.is_finite()));
        let finite = finite && u.foot_spin.iter().all(|w| w.is_finite());
        let sizes = [u.foot_rel.len(), u.foot_vel.len(), u.contact.len(), u.foot_spin.len()];
        if !finite || sizes.iter().any(|&n| n != self.feet) {
            return false;
        }
        let n = self.x.len();
        for (t, &on) in self.stance.iter_mut().zip(&u.contact) {
            *t = if on { *t + dt } else { 0.0 };
        }
        let c = &self.cfg;
        // Noise factor per foot: 1 when trusted, up to `swing_scale` in the air.
        let scale: Vec<f64> = self
            .stance
            .iter()
            .zip(&u.foot_spin)
            .map(|(&t, &spin)| {
                let trust =
                    if c.contact_ramp_s > 0.0 { (t / c.contact_ramp_s).min(1.0) } else { (t > 0.0) as u8 as f64 };
                let rolling = if c.roll_rate > 0.0 { 1.0 + (spin / c.roll_rate).powi(2) } else { 1.0 };
                (1.0 + (1.0 - trust) * (c.swing_scale - 1.0)) * rolling
            })
            .collect();
        // Predict.
        let mut x = self.x.clone();
        for k in 0..3 {
            x[k] += self.x[3 + k] * dt + 0.5 * u.accel[k] * dt * dt;
            x[3 + k] += u.accel[k] * dt;
        }
        let mut a = DMatrix::<f64>::identity(n, n);
        for k in 0..3 {
            a[(k, 3 + k)] = dt;
        }
        let mut q = DMatrix::<f64>::zeros(n, n);
        for k in 0..3 {
            q[(k, k)] = c.q_position * dt;
            q[(3 + k, 3 + k)] = c.q_velocity * dt;
        }
        for (i, &s) in scale.iter().enumerate() {
            for k in 0..3 {
                q[(6 + 3 * i + k, 6 + 3 * i + k)] = c.q_foot * dt * s;
            }
        }
        let p = &a * &self.p * a.transpose() + q;
        // Update: per foot, relative position (3), implied base velocity (3), height (1).
        let m = 7 * self.feet;
        let mut h = DMatrix::<f64>::zeros(m, n);
        let mut y = DVector::<f64>::zeros(m);
        let mut r = DMatrix::<f64>::zeros(m, m);
        for i in 0..self.feet {
            let (row, col) = (7 * i, 6 + 3 * i);
            let s = scale[i];
            for k in 0..3 {
                h[(row + k, k)] = -1.0;
                h[(row + k, col + k)] = 1.0;
                y[row + k] = u.foot_rel[i][k];
                r[(row + k, row + k)] = c.r_foot_position * s;
                h[(row + 3 + k, 3 + k)] = 1.0;
                y[row + 3 + k] = u.foot_vel[i][k];
                r[(row + 3 + k, row + 3 + k)] = c.r_foot_velocity * s;
            }
            h[(row + 6, col + 2)] = 1.0;
            y[row + 6] = 0.0;
            r[(row + 6, row + 6)] = c.r_foot_height * s;
        }
        let innovation = &y - &h * &x;
        let s_mat = &h * &p * h.transpose() + r;
        let Some(chol) = s_mat.cholesky() else { return false };
        // K = P Hᵀ S⁻¹, computed as (S⁻¹ H P)ᵀ with S symmetric.
        let k_gain = chol.solve(&(&h * &p)).transpose();
        let x_new = &x + &k_gain * innovation;
        let i_kh = DMatrix::<f64>::identity(n, n) - &k_gain * &h;
        let mut p_new = &i_kh * &p;
        p_new = (&p_new + p_new.transpose()) * 0.5;
        if !x_new.iter().chain(p_new.iter()).all(|v| v.is_finite()) {
            return false;
        }
        self.x = x_new;
        self.p = p_new;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A base moving at constant velocity over two planted feet: the filter converges to the true velocity.
    #[test]
    fn converges_to_the_velocity_that_planted_feet_imply() {
        let mut kf = ContactKf::new(EstimatorConfig::default(), 2);
        let feet = [Vector3::new(0.0, 0.1, -0.5), Vector3::new(0.0, -0.1, -0.5)];
        kf.reset(0.5, &feet);
        let v_true = Vector3::new(0.4, -0.1, 0.0);
        let dt = 0.002;
        let world_feet = [Vector3::new(0.0, 0.1, 0.0), Vector3::new(0.0, -0.1, 0.0)];
        let mut base = Vector3::new(0.0, 0.0, 0.5);
        for _ in 0..2000 {
            base += v_true * dt;
            let u = EstimatorInput {
                accel: Vector3::zeros(),
                foot_rel: world_feet.iter().map(|f| f - base).collect(),
                foot_vel: vec![v_true; 2],
                contact: vec![true, true],
                foot_spin: vec![0.0; 2],
            };
            assert!(kf.step(dt, &u));
        }
        assert!((kf.velocity() - v_true).norm() < 1e-3, "{}", kf.velocity());
        assert!((kf.position().z - 0.5).abs() < 1e-3);
    }

    #[test]
    fn a_non_finite_input_is_refused_and_the_state_kept() {
        let mut kf = ContactKf::new(EstimatorConfig::default(), 2);
        kf.reset(0.5, &[Vector3::zeros(), Vector3::zeros()]);
        let before = kf.velocity();
        let u = EstimatorInput {
            accel: Vector3::new(f64::NAN, 0.0, 0.0),
            foot_rel: vec![Vector3::zeros(); 2],
            foot_vel: vec![Vector3::zeros(); 2],
            contact: vec![true, true],
            foot_spin: vec![0.0; 2],
        };
        assert!(!kf.step(0.002, &u));
        assert_eq!(kf.velocity(), before);
    }

    #[test]
    fn snapshot_round_trips() {
        let mut kf = ContactKf::new(EstimatorConfig::default(), 2);
        kf.reset(0.5, &[Vector3::new(0.1, 0.1, -0.5), Vector3::new(0.1, -0.1, -0.5)]);
        let mut v = Vec::new();
        kf.save(&mut v);
        assert_eq!(v.len(), kf.saved_len());
        let mut other = ContactKf::new(EstimatorConfig::default(), 2);
        assert_eq!(other.load(&v), v.len());
        assert_eq!(other.x, kf.x);
        assert_eq!(other.p, kf.p);
    }
}
