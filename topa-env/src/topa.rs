//! TopA's two models: the closed chain and the serial approximation most RL frameworks use, as the
//! `--model closed|open` shorthand names them. (TopA's reference numbers, against which the tests check the
//! spec, the maps and the mirror, are test data: `topa-env/tests/reference/topa.rs`.)

use serde::{Deserialize, Serialize};

use crate::error::EnvError;

/// Which MJCF variant: the real closed chain or the serial approximation most RL frameworks use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ModelKind {
    Closed,
    Open,
}

impl ModelKind {
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Closed => "closed",
            ModelKind::Open => "open",
        }
    }
    /// How policy files name the robot a policy was trained on.
    pub fn robot_name(self) -> &'static str {
        match self {
            ModelKind::Closed => "topa_closed",
            ModelKind::Open => "topa_open",
        }
    }
    /// The model a policy file names by its robot's name (`topa_closed`, `topa_open`).
    pub fn of_policy(robot: Option<&str>) -> crate::error::Result<ModelKind> {
        match robot {
            Some(r) => {
                [ModelKind::Closed, ModelKind::Open].into_iter().find(|k| k.robot_name() == r).ok_or_else(|| {
                    EnvError::Choice(format!("robot '{r}' is not one of this build's robots (topa_closed, topa_open)"))
                })
            }
            None => Err(EnvError::Choice("the policy file does not name the robot it was trained on".into())),
        }
    }
    /// The bundled spec of this model, relative to the repository root.
    pub fn spec_path(self) -> &'static str {
        match self {
            ModelKind::Closed => "assets/robots/topa_closed.toml",
            ModelKind::Open => "assets/robots/topa_open.toml",
        }
    }
    /// The bundled MJCF file, relative to the repository's `assets/mjcf/`.
    pub fn file_name(self) -> &'static str {
        match self {
            ModelKind::Closed => "topa_closed.xml",
            ModelKind::Open => "topa_open.xml",
        }
    }
}

impl std::str::FromStr for ModelKind {
    type Err = EnvError;
    fn from_str(s: &str) -> Result<Self, EnvError> {
        match s {
            "closed" => Ok(ModelKind::Closed),
            "open" => Ok(ModelKind::Open),
            _ => Err(EnvError::Choice(format!("unknown model '{s}': use 'closed' or 'open'"))),
        }
    }
}
