//! Domain randomisation of the env's own model copy, per episode: the paper's friction and mass scales, and
//! beyond the paper, when configured, the torso's centre of mass and the contacts' damping ratio.

use rand::RngExt;

use super::RobotEnv;
use crate::error::Result;

impl RobotEnv {
    /// The episode's draw of the model's randomised values on this env's own copy.
    pub(super) fn randomize_model(&mut self) -> Result<()> {
        let dr = self.cfg.domain_rand.clone();
        let friction = self.rng.random_range(dr.friction_scale[0]..=dr.friction_scale[1]);
        self.friction_scale = friction;
        let nbody = self.nominal.body_mass.len();
        let mass: Vec<f64> = (0..nbody).map(|_| self.rng.random_range(dr.mass_scale[0]..=dr.mass_scale[1])).collect();
        let nominal = self.nominal.clone();
        let floor = self.idx.floor_geom;
        let feet = self.idx.foot_geoms;
        let m = self.data.model_mut();
        for (b, s) in mass.iter().enumerate() {
            m.body_mass_mut()[b] = nominal.body_mass[b] * s;
            m.body_inertia_mut()[b] = nominal.body_inertia[b].map(|i| i * s);
        }
        // Contact friction is the larger of the two geoms' values: scale both the floor and the soles.
        for g in [floor, feet[0], feet[1]] {
            m.geom_friction_mut()[g][0] = nominal.geom_friction[g][0] * friction;
        }
        // Beyond the paper, drawn only when configured (the paper's draws stay the same stream).
        let torso = self.idx.torso_body;
        if dr.torso_com_offset != [0.0; 3] {
            let mut ipos = nominal.body_ipos[torso];
            for (k, half) in dr.torso_com_offset.iter().enumerate() {
                ipos[k] += if *half > 0.0 { self.rng.random_range(-half..=*half) } else { 0.0 };
            }
            self.data.model_mut().body_ipos_mut()[torso] = ipos;
        }
        let [z0, z1] = dr.contact_damping_ratio;
        if z1 > 0.0 {
            let z = self.rng.random_range(z0..=z1);
            let m = self.data.model_mut();
            // A solref in MuJoCo's direct form (negative: stiffness, damping) has no damping ratio to draw.
            for (g, r) in nominal.geom_solref.iter().enumerate().filter(|(_, r)| r[0] > 0.0) {
                m.geom_solref_mut()[g] = [r[0], z];
            }
        }
        self.data.set_const()?;
        Ok(())
    }
}
