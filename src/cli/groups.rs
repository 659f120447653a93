//! The policies of the paper's groups (O, C, C+A) and the sim2sim modes of a multi-mode run.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use topa_eval::results::Group;
use topa_eval::settings::Sim2SimMode;

/// The policies of the paper's three groups.
#[derive(Args, Clone, Debug)]
pub(crate) struct Groups {
    /// Policies trained on the open (serial) model: files, or folders whose *.json policies are all taken
    /// (several seeds: `--o a.json b.json` or `--o assets/policies/O`).
    #[arg(long, num_args = 1..)]
    pub(crate) o: Vec<PathBuf>,
    /// Policies trained on the closed model (files or folders, as --o).
    #[arg(long, num_args = 1..)]
    pub(crate) c: Vec<PathBuf>,
    /// Policies trained on the closed model with the cyclic adversary (files or folders, as --o).
    #[arg(long, num_args = 1..)]
    pub(crate) ca: Vec<PathBuf>,
}

impl Groups {
    /// The (group, file) list, folders expanded.
    pub(crate) fn policies(self) -> Result<Vec<(Group, PathBuf)>> {
        let mut policies: Vec<(Group, PathBuf)> = Vec::new();
        for (group, flag, paths) in [(Group::O, "o", self.o), (Group::C, "c", self.c), (Group::CA, "ca", self.ca)] {
            policies.extend(topa_eval::results::policy_files(flag, &paths)?.into_iter().map(|p| (group, p)));
        }
        Ok(policies)
    }
}

/// A sim2sim mode in a comma-separated list.
#[derive(Clone, Debug)]
pub(crate) struct Sim2SimArg(pub(crate) Sim2SimMode);

impl std::str::FromStr for Sim2SimArg {
    type Err = std::convert::Infallible;
    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        Ok(Sim2SimArg(s.parse()?))
    }
}
