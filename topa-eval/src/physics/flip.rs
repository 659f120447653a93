//! What the fragility search finds for one failed case: the smallest perturbation that fails it.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

/// Why one failed case fails.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Flip {
    /// The seed's label in the report ("C+A 4").
    pub seed: String,
    pub policy: PathBuf,
    pub case: String,
    pub finding: Finding,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Finding {
    /// Survives at `survives` (the largest size tried that it survives), fails from `fails` (the smallest size
    /// tried that fails, with what it missed there); `survives_at` and `fails_at` are those sizes as shares of
    /// the case's departure from nominal (0–1).
    Threshold { survives: String, fails: String, missed: String, survives_at: f64, fails_at: f64 },
    /// A switch: the case itself is the smallest perturbation.
    Switch,
    /// A combination whose members in `failing` fail by themselves (alone, or as the smallest failing subset).
    Members { failing: Vec<String> },
}

impl Finding {
    pub fn describe(&self) -> String {
        match self {
            Finding::Threshold { survives, fails, missed, .. } => {
                format!("fails from {fails} ({missed}); survives {survives}")
            }
            Finding::Switch => "the switch itself".into(),
            Finding::Members { failing } => format!("its part {} fails by itself", failing.join(" + ")),
        }
    }
}
