//! An env's complete state as flat f64/u64 rows (checkpoints resume bit for bit, evaluation snapshots).

use super::RobotEnv;
use crate::error::{EnvError, Result};
use crate::perturb::Perturbation;
use crate::{state, task};

impl RobotEnv {
    /// Appends everything that makes this env's future: the MuJoCo state, the randomised model values, the
    /// command, perturbations, gait timers, counters, the random stream and the sim2sim state.
    pub(super) fn save_snapshot(&self, f: &mut Vec<f64>, u: &mut Vec<u64>) {
        let d = &self.data;
        d.save_state(f);
        let m = d.model();
        f.extend_from_slice(m.body_mass());
        f.extend(m.body_inertia().iter().flatten());
        f.extend(m.geom_friction().iter().map(|g| g[0]));
        // The draws beyond the paper, only when configured (rows of the paper's configs keep their length).
        let dr = &self.cfg.domain_rand;
        if dr.torso_com_offset != [0.0; 3] {
            f.extend_from_slice(&m.body_ipos()[self.idx.torso_body]);
        }
        if dr.contact_damping_ratio[1] > 0.0 {
            f.extend(m.geom_solref().iter().map(|r| r[1]));
        }
        f.extend_from_slice(&self.command);
        let o = self.command_override;
        f.extend_from_slice(&o.unwrap_or([0.0; 3]));
        let p = &self.perturbation;
        f.extend(p.command_offset.iter().chain(&p.gravity_offset).chain(p.foot_force.iter().flatten()));
        f.extend_from_slice(&p.torso_force_local);
        f.extend_from_slice(&self.last_action);
        f.extend_from_slice(&self.air_time);
        f.extend_from_slice(&self.contact_time);
        f.extend(self.history.iter().map(|&x| f64::from(x))); // empty without `[env.observation] history`
        u.extend([self.step_count as u64, self.next_resample as u64, self.next_push as u64, o.is_some() as u64]);
        u.extend(self.last_contact.map(|c| c as u64));
        u.push(self.experience_steps);
        task::save_rng(&self.rng, u);
        if let Some(s) = &self.sim2sim {
            s.save(f, u);
        }
        self.save_terrain(f, u);
    }

    /// How many f64 values `save_snapshot` writes.
    fn snapshot_len(&self) -> usize {
        let (mut f, mut u) = (Vec::new(), Vec::new());
        self.save_snapshot(&mut f, &mut u);
        f.len()
    }

    /// Restores what `save_snapshot` wrote; returns how many f64 and u64 values it read.
    pub(super) fn load_snapshot(&mut self, f: &[f64], u: &[u64]) -> Result<(usize, usize)> {
        let mut fi = 0;
        let mut take = |n: usize| -> Result<&[f64]> {
            let s = f.get(fi..fi + n).ok_or_else(|| EnvError::Shape("env snapshot too short".into()))?;
            fi += n;
            Ok(s)
        };
        let (nbody, ngeom) = (self.nominal.body_mass.len(), self.nominal.geom_friction.len());
        // Rows written before the applied forces were part of the physics state are shorter by exactly them:
        // those load with zero applied forces (what the next step's perturbation overwrites anyway).
        let (with, without) = (self.data.state_len(), self.data.state_len_without_forces());
        let legacy = f.len() + (with - without) == self.snapshot_len();
        let state = if legacy {
            let mut s = take(without)?.to_vec();
            s.resize(with, 0.0);
            s
        } else {
            take(with)?.to_vec()
        };
        self.data.load_state(&state)?;
        let mass = take(nbody)?.to_vec();
        let inertia = take(3 * nbody)?.to_vec();
        let friction = take(ngeom)?.to_vec();
        let dr = self.cfg.domain_rand.clone();
        let torso = self.idx.torso_body;
        let ipos = if dr.torso_com_offset != [0.0; 3] {
            take(3)?.to_vec()
        } else {
            self.data.model().body_ipos()[torso].to_vec()
        };
        let damping: Vec<f64> = if dr.contact_damping_ratio[1] > 0.0 {
            take(ngeom)?.to_vec()
        } else {
            self.data.model().geom_solref().iter().map(|r| r[1]).collect()
        };
        // The episode's friction scale, which a ground friction map multiplies, is the floor's over its nominal.
        let floor = self.idx.floor_geom;
        let nominal_floor = self.nominal.geom_friction[floor][0];
        self.friction_scale = if nominal_floor > 0.0 { friction[floor] / nominal_floor } else { 1.0 };
        let m = self.data.model();
        if mass != m.body_mass()
            || friction.iter().zip(m.geom_friction()).any(|(a, g)| *a != g[0])
            || ipos != m.body_ipos()[torso]
            || damping.iter().zip(m.geom_solref()).any(|(a, r)| *a != r[1])
        {
            let m = self.data.model_mut();
            m.body_mass_mut().copy_from_slice(&mass);
            for (b, c) in m.body_inertia_mut().iter_mut().zip(inertia.chunks_exact(3)) {
                *b = [c[0], c[1], c[2]];
            }
            for (g, v) in m.geom_friction_mut().iter_mut().zip(&friction) {
                g[0] = *v;
            }
            m.body_ipos_mut()[torso] = [ipos[0], ipos[1], ipos[2]];
            for (r, z) in m.geom_solref_mut().iter_mut().zip(&damping) {
                r[1] = *z;
            }
            // set_const resets the Data to qpos0; restore the state afterwards.
            self.data.set_const()?;
            self.data.load_state(&state)?;
        }
        let arr3 = |s: &[f64]| [s[0], s[1], s[2]];
        self.command = arr3(take(3)?);
        let over = arr3(take(3)?);
        let p = take(12)?.to_vec();
        let torso = arr3(take(3)?);
        self.perturbation = Perturbation {
            command_offset: arr3(&p[0..3]),
            gravity_offset: arr3(&p[3..6]),
            foot_force: [arr3(&p[6..9]), arr3(&p[9..12])],
            torso_force_local: torso,
        };
        let n = self.last_action.len();
        self.last_action.copy_from_slice(take(n)?);
        self.air_time.copy_from_slice(take(2)?);
        self.contact_time.copy_from_slice(take(2)?);
        let h = self.history.len();
        for (d, v) in self.history.iter_mut().zip(take(h)?) {
            *d = *v as f32;
        }
        let need = 7 + task::RNG_WORDS;
        let w = u.get(..need).ok_or_else(|| EnvError::Shape("env snapshot too short".into()))?;
        self.step_count = w[0] as usize;
        self.next_resample = w[1] as usize;
        self.next_push = w[2] as usize;
        self.command_override = (w[3] != 0).then_some(over);
        self.last_contact = [w[4] != 0, w[5] != 0];
        self.experience_steps = w[6];
        self.rng = task::load_rng(&w[7..]);
        let (mut fi, mut need) = (fi, need);
        if let Some(s) = &mut self.sim2sim {
            let (a, b) = s.load(f.get(fi..).unwrap_or(&[]), u.get(need..).unwrap_or(&[]))?;
            fi += a;
            need += b;
        }
        let (a, b) = self.load_terrain(f.get(fi..).unwrap_or(&[]), u.get(need..).unwrap_or(&[]))?;
        let (fi, need) = (fi + a, need + b);
        // Derived quantities (contacts, velocities) for the observation and the next reward. The forward pass
        // writes into the state itself (it renormalises the base quaternion in place, a last-bit change, and
        // rewrites the warm start), which the uninterrupted run never saw: the saved state goes back afterwards.
        self.data.forward()?;
        state::read_into(&self.data, &self.idx, &mut self.robot_state);
        self.data.load_state(&state)?;
        Ok((fi, need))
    }
}
