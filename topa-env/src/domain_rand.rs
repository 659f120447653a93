//! Per-episode domain randomisation of each env's model (`[env.domain_rand]`): the paper's friction and mass
//! scales, and beyond the paper the torso's centre of mass and the contacts' damping ratio.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{EnvError, Result};

/// Per-episode randomisation of the env's own model copy (paper: "scale" operator).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct DomainRandConfig {
    /// Randomise each episode (false: the nominal model).
    pub enabled: bool,
    /// Range of the ground (and sole) friction scale (paper: [0.75, 1.25]).
    pub friction_scale: [f64; 2],
    /// Range of the scale of every link's mass, inertia scaled alike so density stays uniform (paper: [0.9, 1.1]).
    pub mass_scale: [f64; 2],
    /// Shift of the torso's centre of mass, uniform in ± this per axis of its frame, m (0: none; beyond the paper).
    pub torso_com_offset: [f64; 3],
    /// Range of the contacts' damping ratio (every geom's solref, its time constant kept), drawn per episode
    /// ([0, 0]: the MJCF's; beyond the paper).
    pub contact_damping_ratio: [f64; 2],
}

impl Default for DomainRandConfig {
    fn default() -> Self {
        DomainRandConfig {
            enabled: true,
            friction_scale: [0.75, 1.25],
            mass_scale: [0.9, 1.1],
            torso_com_offset: [0.0; 3],
            contact_damping_ratio: [0.0; 2],
        }
    }
}

impl DomainRandConfig {
    pub fn validate(&self) -> Result<()> {
        check_range("domain_rand.friction_scale", self.friction_scale)?;
        check_range("domain_rand.mass_scale", self.mass_scale)?;
        if self.mass_scale[0] <= 0.0 || self.friction_scale[0] <= 0.0 {
            return Err(EnvError::Config("domain_rand scales must be positive".into()));
        }
        if self.torso_com_offset.iter().any(|x| !(x.is_finite() && (0.0..=0.5).contains(x))) {
            return Err(EnvError::Config(format!(
                "domain_rand.torso_com_offset: each axis's half-range must be in [0, 0.5] m, got {:?}",
                self.torso_com_offset
            )));
        }
        check_range("domain_rand.contact_damping_ratio", self.contact_damping_ratio)?;
        if self.contact_damping_ratio != [0.0; 2] && self.contact_damping_ratio[0] <= 0.0 {
            return Err(EnvError::Config(format!(
                "domain_rand.contact_damping_ratio: a damping ratio must be positive, got {:?} ([0, 0] turns it off)",
                self.contact_damping_ratio
            )));
        }
        Ok(())
    }
}

/// A `[low, high]` range of finite values (every range of the env config).
pub(crate) fn check_range(name: &str, r: [f64; 2]) -> Result<()> {
    if !(r[0].is_finite() && r[1].is_finite() && r[0] <= r[1]) {
        return Err(EnvError::Config(format!("{name} must be [low, high] with low ≤ high, got {r:?}")));
    }
    Ok(())
}
