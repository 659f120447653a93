//! A terrain as MJCF: one height field over the whole grid (the robot's own floor switched off), its samples
//! written after compiling (MuJoCo 2.2's MJCF takes a field's elevations only from a file), and the contact
//! capacity raised: a box sole on a height field touches one prism per cell under it, not four corners.

use std::sync::Arc;

use mujoco::{hfield_box, Model, ObjType};

use super::config::BoxContacts;
use super::field::Terrain;
use crate::error::{EnvError, Result};
use crate::spec::RobotSpec;
use crate::world::{FrictionMap, WorldXml, MAPPED_FLOOR_FRICTION};

/// Name of the height field and of its geom.
pub const TERRAIN_NAME: &str = "terrain";

/// Contact and constraint capacity on terrain, ~2× the largest use `topa bench memory --terrain` measured (512 envs
/// × 300 steps, Euler and RK4, walking pushed, falling, lying and thrashing): 65 contacts, 276 constraint rows,
/// 3556 mjtNum of stack (the stack ~6×: it grows with the square of the rows).
/// `nuser_geom`: the field's `user` value selects its box contacts (`mujoco::hfield_box`).
const SIZE: &str = r#"<size nconmax="120" njmax="600" nstack="20000" nuser_geom="1"/>"#;

impl Terrain {
    /// Lowest and highest sample, m.
    pub fn height_range(&self) -> (f64, f64) {
        let lo = self.heights.iter().copied().fold(f32::INFINITY, f32::min) as f64;
        let hi = self.heights.iter().copied().fold(f32::NEG_INFINITY, f32::max) as f64;
        (lo, hi)
    }

    /// The field's elevation span, m (MuJoCo needs a positive one, also for a flat field).
    fn span(&self) -> f64 {
        let (lo, hi) = self.height_range();
        (hi - lo).max(1e-3)
    }

    pub fn world(&self) -> WorldXml {
        let [w, h] = self.cfg.extent();
        let (lo, _) = self.height_range();
        let assets = format!(
            r#"  <hfield name="{TERRAIN_NAME}" nrow="{}" ncol="{}" size="{} {} {} 0.1"/>
  <texture name="terrain_tex" type="2d" builtin="checker" rgb1="0.42 0.45 0.42" rgb2="0.52 0.55 0.5" width="64" height="64" mark="edge" markrgb="0.3 0.3 0.3"/>
  <material name="terrain_mat" texture="terrain_tex" texrepeat="{} {}" reflectance="0.05"/>"#,
            self.ny,
            self.nx,
            w / 2.0,
            h / 2.0,
            self.span(),
            w / 2.0,
            h / 2.0,
        );
        let user = match self.cfg.contacts {
            BoxContacts::Prisms => 0.0,
            BoxContacts::Vertices => hfield_box::USER_VERTEX_CONTACTS,
        };
        let worldbody = format!(
            r#"  <geom name="{TERRAIN_NAME}" type="hfield" hfield="{TERRAIN_NAME}" user="{user}" pos="{} {} {lo}" contype="0" conaffinity="1" condim="3" friction="{MAPPED_FLOOR_FRICTION} 0.005 0.0001" material="terrain_mat" group="0"/>"#,
            w / 2.0,
            h / 2.0,
        );
        WorldXml { assets, worldbody, top: SIZE.into(), keep_floor: false }
    }

    /// The robot on this terrain, and the friction under its feet.
    pub fn compile(&self, spec: &RobotSpec) -> Result<(Arc<Model>, FrictionMap)> {
        hfield_box::install();
        let mut model = crate::world::compile(spec, &self.world())?;
        let m = Arc::make_mut(&mut model);
        let id = m.id(ObjType::Hfield, TERRAIN_NAME)?;
        if (m.hfield_nrow()[id] as usize, m.hfield_ncol()[id] as usize) != (self.ny, self.nx) {
            return Err(EnvError::Config(format!(
                "terrain height field compiled as {}×{} samples, expected {}×{}",
                m.hfield_nrow()[id],
                m.hfield_ncol()[id],
                self.ny,
                self.nx
            )));
        }
        let (lo, span) = (self.height_range().0, self.span());
        let adr = m.hfield_adr()[id] as usize;
        // MuJoCo's layout is ours: row r at y = r·dy from the field's −y edge, column c at x = c·dx.
        let data = &mut m.hfield_data_mut()[adr..adr + self.nx * self.ny];
        for (d, &h) in data.iter_mut().zip(&self.heights) {
            *d = ((h as f64 - lo) / span) as f32;
        }
        Ok((model, self.friction_map()))
    }
}
