//! The integrator an env runs with: the MJCF's own, or an override for training speed.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Which integrator the env runs: the MJCF's own, or an override.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum IntegratorChoice {
    #[default]
    Model,
    Euler,
    Rk4,
    Implicit,
}

impl IntegratorChoice {
    pub fn name(self) -> &'static str {
        match self {
            IntegratorChoice::Model => "model",
            IntegratorChoice::Euler => "euler",
            IntegratorChoice::Rk4 => "rk4",
            IntegratorChoice::Implicit => "implicit",
        }
    }
    /// The override, or None to keep the model's.
    pub fn resolve(self) -> Option<mujoco::Integrator> {
        use mujoco::Integrator;
        match self {
            IntegratorChoice::Model => None,
            IntegratorChoice::Euler => Some(Integrator::Euler),
            IntegratorChoice::Rk4 => Some(Integrator::Rk4),
            IntegratorChoice::Implicit => Some(Integrator::Implicit),
        }
    }
}

impl std::str::FromStr for IntegratorChoice {
    type Err = crate::error::EnvError;
    fn from_str(s: &str) -> std::result::Result<Self, crate::error::EnvError> {
        [IntegratorChoice::Model, IntegratorChoice::Euler, IntegratorChoice::Rk4, IntegratorChoice::Implicit]
            .into_iter()
            .find(|i| i.name() == s)
            .ok_or_else(|| {
                crate::error::EnvError::Choice(format!(
                    "integrator '{s}' is unknown: use model, euler, rk4 or implicit"
                ))
            })
    }
}

impl std::fmt::Display for IntegratorChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
