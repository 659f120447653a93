//! The simulator's own physics as a setting (`[env.physics]`): contact model (friction cone, impedance ratio, the
//! contacts' solref/solimp), constraint solver, ground friction, the motors' armature, damping and dry friction,
//! the torso's mass and centre of mass, and the soles' shape and size. Each is relative to the robot's MJCF (a
//! scale of 1, an offset of 0 or a value left out keeps the MJCF's), so a physics-perturbation experiment and a
//! training config that randomises them name the same quantities. The timestep, integrator, solver iterations and
//! control latency have their keys elsewhere (`timestep`, `integrator`, `solver_iterations`, `sim2sim.latency`).

use std::sync::Arc;

use mujoco::{Data, GeomType, Model};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{EnvError, Result};
use crate::indices::RobotIndices;

/// Departures from the MJCF's physics; the default is none.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PhysicsConfig {
    /// Friction cone of every contact (left out: the MJCF's).
    pub cone: Option<ConeChoice>,
    /// Ratio of frictional to normal constraint impedance (MuJoCo 2.2 reads it for elliptic cones).
    pub impratio: Option<f64>,
    /// Contact `solref` (time constant s, damping ratio) of every geom, so of every contact.
    pub contact_solref: Option<[f64; 2]>,
    /// Contact `solimp` (d_min, d_max, width m, midpoint, power) of every geom.
    pub contact_solimp: Option<[f64; 5]>,
    /// Constraint solver (left out: the MJCF's).
    pub solver: Option<SolverChoice>,
    /// Factor on every geom's sliding friction (a contact takes the larger of its two geoms').
    pub friction_scale: f64,
    /// Factor on the motor joints' armature (rotor inertia).
    pub armature_scale: f64,
    /// Factor on the motor joints' viscous damping (a zero in the MJCF stays zero).
    pub damping_scale: f64,
    /// Factor on the motor joints' dry friction (a zero in the MJCF stays zero).
    pub frictionloss_scale: f64,
    /// Factor on the torso's mass and inertia.
    pub torso_mass_scale: f64,
    /// Shift of the torso's centre of mass in its own frame, m.
    pub torso_com_offset: [f64; 3],
    /// The soles' shape: a box becomes the capsule along its longest axis with its thickness as radius; a capsule
    /// becomes the box around it; `swapped` turns each into the other. The sole's lowest point stays where it was
    /// (for a level sole).
    pub foot_shape: Option<FootShape>,
    /// Factor on the soles' sizes (after any change of shape).
    pub foot_size_scale: f64,
}

impl Default for PhysicsConfig {
    fn default() -> Self {
        PhysicsConfig {
            cone: None,
            impratio: None,
            contact_solref: None,
            contact_solimp: None,
            solver: None,
            friction_scale: 1.0,
            armature_scale: 1.0,
            damping_scale: 1.0,
            frictionloss_scale: 1.0,
            torso_mass_scale: 1.0,
            torso_com_offset: [0.0; 3],
            foot_shape: None,
            foot_size_scale: 1.0,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ConeChoice {
    Pyramidal,
    Elliptic,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SolverChoice {
    Pgs,
    Cg,
    Newton,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FootShape {
    Box,
    Capsule,
    /// The other of the two: a box sole becomes a capsule and a capsule a box (one perturbation for any robot).
    Swapped,
}

fn bad(key: &str, why: String) -> EnvError {
    EnvError::Config(format!("physics.{key}: {why}"))
}

impl PhysicsConfig {
    /// Whether this is the MJCF's physics (nothing to apply).
    pub fn is_nominal(&self) -> bool {
        *self == PhysicsConfig::default()
    }

    pub fn validate(&self) -> Result<()> {
        for (key, v) in [
            ("friction_scale", self.friction_scale),
            ("armature_scale", self.armature_scale),
            ("damping_scale", self.damping_scale),
            ("frictionloss_scale", self.frictionloss_scale),
            ("torso_mass_scale", self.torso_mass_scale),
            ("foot_size_scale", self.foot_size_scale),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(key, format!("a factor must be positive and finite, got {v}")));
            }
        }
        if let Some(r) = self.impratio {
            if !(r.is_finite() && r >= 1.0) {
                return Err(bad("impratio", format!("must be at least 1 (MuJoCo's range), got {r}")));
            }
        }
        if let Some([t, z]) = self.contact_solref {
            if !(t.is_finite() && z.is_finite() && t > 0.0 && z > 0.0) {
                return Err(bad(
                    "contact_solref",
                    format!("[time constant, damping ratio] must be positive, got [{t}, {z}]"),
                ));
            }
        }
        if let Some([d0, d1, w, mid, pow]) = self.contact_solimp {
            let ok = (0.0..1.0).contains(&d0) && (0.0..1.0).contains(&d1) && w > 0.0 && (0.0..=1.0).contains(&mid);
            if !(ok && pow >= 1.0) {
                return Err(bad(
                    "contact_solimp",
                    format!(
                        "[d_min, d_max, width, midpoint, power] needs 0 ≤ d < 1, width > 0, midpoint in [0, 1], power ≥ 1; got {:?}",
                        [d0, d1, w, mid, pow]
                    ),
                ));
            }
        }
        if self.torso_com_offset.iter().any(|x| !x.is_finite() || x.abs() > 0.5) {
            return Err(bad(
                "torso_com_offset",
                format!("must be finite and within ±0.5 m, got {:?}", self.torso_com_offset),
            ));
        }
        Ok(())
    }

    /// `on_top` applied after these (a perturbation of a policy's training physics): its choices replace these,
    /// its factors multiply and its offset adds.
    pub fn then(&self, on_top: &PhysicsConfig) -> PhysicsConfig {
        let o = on_top;
        PhysicsConfig {
            cone: o.cone.or(self.cone),
            impratio: o.impratio.or(self.impratio),
            contact_solref: o.contact_solref.or(self.contact_solref),
            contact_solimp: o.contact_solimp.or(self.contact_solimp),
            solver: o.solver.or(self.solver),
            friction_scale: self.friction_scale * o.friction_scale,
            armature_scale: self.armature_scale * o.armature_scale,
            damping_scale: self.damping_scale * o.damping_scale,
            frictionloss_scale: self.frictionloss_scale * o.frictionloss_scale,
            torso_mass_scale: self.torso_mass_scale * o.torso_mass_scale,
            torso_com_offset: std::array::from_fn(|k| self.torso_com_offset[k] + o.torso_com_offset[k]),
            foot_shape: o.foot_shape.or(self.foot_shape),
            foot_size_scale: self.foot_size_scale * o.foot_size_scale,
        }
    }

    /// Puts these physics on `model` (a copy when shared) and recomputes what depends on them.
    pub fn apply(&self, model: &mut Arc<Model>, idx: &RobotIndices) -> Result<()> {
        if self.is_nominal() {
            return Ok(());
        }
        self.validate()?;
        self.put(Arc::make_mut(model), idx)?;
        Ok(Data::set_const_of(model)?)
    }

    fn put(&self, m: &mut Model, idx: &RobotIndices) -> Result<()> {
        if let Some(c) = self.cone {
            m.set_cone(match c {
                ConeChoice::Pyramidal => mujoco::Cone::Pyramidal,
                ConeChoice::Elliptic => mujoco::Cone::Elliptic,
            });
        }
        if let Some(r) = self.impratio {
            m.set_impratio(r);
        }
        if let Some(s) = self.solver {
            m.set_solver(match s {
                SolverChoice::Pgs => mujoco::Solver::Pgs,
                SolverChoice::Cg => mujoco::Solver::Cg,
                SolverChoice::Newton => mujoco::Solver::Newton,
            });
        }
        for g in 0..m.ngeom() {
            if let Some(r) = self.contact_solref {
                m.geom_solref_mut()[g] = r;
            }
            if let Some(i) = self.contact_solimp {
                m.geom_solimp_mut()[g] = i;
            }
            m.geom_friction_mut()[g][0] *= self.friction_scale;
        }
        for &dof in &idx.actuated_dof {
            m.dof_armature_mut()[dof] *= self.armature_scale;
            m.dof_damping_mut()[dof] *= self.damping_scale;
            m.dof_frictionloss_mut()[dof] *= self.frictionloss_scale;
        }
        let torso = idx.torso_body;
        m.body_mass_mut()[torso] *= self.torso_mass_scale;
        m.body_inertia_mut()[torso] = m.body_inertia()[torso].map(|i| i * self.torso_mass_scale);
        for k in 0..3 {
            m.body_ipos_mut()[torso][k] += self.torso_com_offset[k];
        }
        for g in idx.foot_geoms {
            self.put_sole(m, g)?;
        }
        Ok(())
    }

    fn put_sole(&self, m: &mut Model, g: usize) -> Result<()> {
        if self.foot_shape.is_none() && self.foot_size_scale == 1.0 {
            return Ok(()); // the MJCF's sole, whatever its shape (a mesh's bounding radius is MuJoCo's to compute)
        }
        let kind = m.geom_type(g);
        let size = m.geom_size()[g];
        let shape = match (kind, self.foot_shape) {
            (GeomType::Box, Some(FootShape::Swapped)) => Some(FootShape::Capsule),
            (GeomType::Capsule, Some(FootShape::Swapped)) => Some(FootShape::Box),
            (_, shape) => shape,
        };
        let (kind, size, quat_change) = match (kind, shape) {
            (GeomType::Box | GeomType::Capsule | GeomType::Sphere, None)
            | (GeomType::Box, Some(FootShape::Box))
            | (GeomType::Capsule, Some(FootShape::Capsule)) => (kind, size, None),
            (GeomType::Box, Some(FootShape::Capsule)) => {
                // Along the longest half-size, as thick as the thinnest: the bottom stays at −(thinnest).
                let long = (0..3).max_by(|&a, &b| size[a].total_cmp(&size[b])).unwrap();
                let r = size.iter().cloned().fold(f64::INFINITY, f64::min);
                (GeomType::Capsule, [r, (size[long] - r).max(0.0), 0.0], Some(axis_to_z(long)))
            }
            (GeomType::Capsule, Some(FootShape::Box)) => {
                let [r, half, _] = size;
                (GeomType::Box, [r, r, half + r], None)
            }
            (k, _) => {
                return Err(EnvError::Config(format!(
                    "physics.foot_shape / foot_size_scale: the sole geom {} is a {k}; only box and capsule soles \
                     change shape (and spheres size)",
                    m.name_of(mujoco::ObjType::Geom, g).unwrap_or("(unnamed)")
                )))
            }
        };
        let s = self.foot_size_scale;
        let size = match kind {
            GeomType::Capsule => [size[0] * s, size[1] * s, 0.0],
            _ => size.map(|x| x * s),
        };
        if let Some(q) = quat_change {
            m.geom_quat_mut()[g] = quat_mul(m.geom_quat()[g], q);
        }
        m.set_geom_type(g, kind);
        m.geom_size_mut()[g] = size;
        m.geom_rbound_mut()[g] = match kind {
            GeomType::Capsule => size[0] + size[1],
            GeomType::Sphere => size[0],
            _ => size.iter().map(|x| x * x).sum::<f64>().sqrt(), // a box
        };
        Ok(())
    }
}

/// The rotation taking the geom's local z onto its local axis `axis` (a capsule lies along its z).
fn axis_to_z(axis: usize) -> [f64; 4] {
    let h = std::f64::consts::FRAC_1_SQRT_2;
    match axis {
        0 => [h, 0.0, h, 0.0],  // +90° about y: z → x
        1 => [h, -h, 0.0, 0.0], // −90° about x: z → y
        _ => [1.0, 0.0, 0.0, 0.0],
    }
}

fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::RobotSpec;

    fn robot(spec: &str) -> (Arc<Model>, RobotIndices) {
        let (spec, model) = RobotSpec::load(&crate::assets::resolve_path(spec)).unwrap();
        let model = Arc::new(model);
        let idx = RobotIndices::resolve(&model, &Arc::new(spec)).unwrap();
        (model, idx)
    }

    /// The lowest world z of a box or capsule geom at the stand keyframe.
    fn sole_bottom(model: &Arc<Model>, idx: &RobotIndices, g: usize) -> f64 {
        let mut d = Data::new(model.clone()).unwrap();
        d.reset_keyframe(idx.stand_key).unwrap();
        d.kinematics().unwrap();
        let (p, r, s) = (d.geom_xpos()[g], d.geom_xmat()[g], model.geom_size()[g]);
        // Row 2 of the geom's rotation: each local axis's world z.
        let z = [r[6], r[7], r[8]];
        match model.geom_type(g) {
            GeomType::Box => p[2] - (0..3).map(|k| z[k].abs() * s[k]).sum::<f64>(),
            GeomType::Capsule => p[2] - z[2].abs() * s[1] - s[0],
            k => panic!("sole is a {k}"),
        }
    }

    #[test]
    fn a_perturbation_on_top_replaces_choices_multiplies_factors_and_adds_offsets() {
        let trained = PhysicsConfig {
            cone: Some(ConeChoice::Elliptic),
            impratio: Some(2.0),
            friction_scale: 0.8,
            torso_com_offset: [0.01, 0.0, 0.0],
            ..Default::default()
        };
        let on_top = PhysicsConfig {
            cone: Some(ConeChoice::Pyramidal),
            friction_scale: 0.5,
            torso_com_offset: [0.02, -0.01, 0.0],
            ..Default::default()
        };
        let both = trained.then(&on_top);
        assert_eq!((both.cone, both.impratio), (Some(ConeChoice::Pyramidal), Some(2.0)));
        assert!((both.friction_scale - 0.4).abs() < 1e-12);
        assert!((both.torso_com_offset[0] - 0.03).abs() < 1e-12 && both.torso_com_offset[1] == -0.01);
        assert_eq!(trained.then(&PhysicsConfig::default()), trained, "nothing on top changes nothing");
    }

    #[test]
    fn values_land_relative_to_the_mjcf_and_the_shared_model_is_untouched() {
        let (nominal, idx) = robot("assets/robots/topa_closed.toml");
        let mut model = nominal.clone();
        let p = PhysicsConfig {
            cone: Some(ConeChoice::Elliptic),
            impratio: Some(10.0),
            contact_solref: Some([0.01, 0.8]),
            solver: Some(SolverChoice::Pgs),
            friction_scale: 0.5,
            armature_scale: 1.3,
            torso_mass_scale: 1.2,
            torso_com_offset: [0.02, -0.01, 0.0],
            ..Default::default()
        };
        p.apply(&mut model, &idx).unwrap();
        assert_eq!(
            (model.cone(), model.solver(), model.impratio()),
            (mujoco::Cone::Elliptic, mujoco::Solver::Pgs, 10.0)
        );
        let (t, d) = (idx.torso_body, idx.actuated_dof[3]);
        assert!((model.body_mass()[t] - 1.2 * nominal.body_mass()[t]).abs() < 1e-12);
        assert!((model.body_ipos()[t][0] - nominal.body_ipos()[t][0] - 0.02).abs() < 1e-12);
        assert!((model.dof_armature()[d] - 1.3 * nominal.dof_armature()[d]).abs() < 1e-12);
        assert!(nominal.dof_armature()[d] > 0.0, "the test needs a motor with armature");
        let f = idx.foot_geoms[0];
        assert_eq!(model.geom_friction()[f][0], 0.5 * nominal.geom_friction()[f][0]);
        assert_eq!(model.geom_solref()[idx.floor_geom], [0.01, 0.8]);
        // The shared model the caller still holds is the MJCF's.
        assert_eq!(nominal.cone(), mujoco::Cone::Pyramidal);
        assert_eq!(nominal.body_mass()[t], robot("assets/robots/topa_closed.toml").0.body_mass()[t]);
        // Nominal physics leave the very same model.
        let mut same = nominal.clone();
        PhysicsConfig::default().apply(&mut same, &idx).unwrap();
        assert!(Arc::ptr_eq(&same, &nominal));
    }

    #[test]
    fn soles_change_shape_and_size_with_their_lowest_point_kept() {
        for (spec, shape, new_kind) in [
            ("assets/robots/topa_closed.toml", FootShape::Swapped, GeomType::Capsule),
            ("assets/robots/cassie.toml", FootShape::Box, GeomType::Box),
        ] {
            let (nominal, idx) = robot(spec);
            let g = idx.foot_geoms[1];
            let before = sole_bottom(&nominal, &idx, g);
            let mut model = nominal.clone();
            PhysicsConfig { foot_shape: Some(shape), ..Default::default() }.apply(&mut model, &idx).unwrap();
            assert_eq!(model.geom_type(g), new_kind, "{spec}");
            let after = sole_bottom(&model, &idx, g);
            // Exact for a level sole (TopA's box); Cassie's capsule is tilted at the stand, its box reaches lower.
            let tol = if spec.contains("topa") { 1e-9 } else { 0.01 };
            assert!((after - before).abs() < tol, "{spec}: sole bottom {before} → {after}");
            let s = model.geom_size()[g];
            let bound = match new_kind {
                GeomType::Box => s.iter().map(|x| x * x).sum::<f64>().sqrt(),
                _ => s[0] + s[1],
            };
            assert_eq!(model.geom_rbound()[g], bound);
            // The long axis keeps its length: a TopA sole of 2 × 9 cm stays 18 cm long as a capsule.
            if spec.contains("topa") {
                let n = nominal.geom_size()[g];
                assert!((s[0] + s[1] - n[0]).abs() < 1e-12 && s[0] == n[2], "{s:?} from {n:?}");
            }
            let mut bigger = nominal.clone();
            PhysicsConfig { foot_size_scale: 1.1, ..Default::default() }.apply(&mut bigger, &idx).unwrap();
            assert!((bigger.geom_size()[g][0] - 1.1 * nominal.geom_size()[g][0]).abs() < 1e-12);
        }
    }

    #[test]
    fn bad_values_are_refused_naming_the_key() {
        let cases = [
            (PhysicsConfig { friction_scale: -0.5, ..Default::default() }, "physics.friction_scale"),
            (PhysicsConfig { impratio: Some(0.5), ..Default::default() }, "physics.impratio"),
            (PhysicsConfig { contact_solref: Some([0.0, 1.0]), ..Default::default() }, "physics.contact_solref"),
            (
                PhysicsConfig { contact_solimp: Some([0.9, 1.2, 0.001, 0.5, 2.0]), ..Default::default() },
                "contact_solimp",
            ),
            (PhysicsConfig { torso_com_offset: [f64::NAN, 0.0, 0.0], ..Default::default() }, "torso_com_offset"),
        ];
        for (p, key) in cases {
            let e = p.validate().unwrap_err().to_string();
            assert!(e.contains(key), "{e}");
        }
        let unknown = toml::from_str::<PhysicsConfig>("frction_scale = 0.5").unwrap_err().to_string();
        assert!(unknown.contains("frction_scale"), "{unknown}");
    }
}
