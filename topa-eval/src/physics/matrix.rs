//! The perturbation matrix of `topa physics`: named cases, each a departure from the physics a policy is evaluated
//! with (the `[env.physics]` keys, relative to the policy's own, plus the timestep, integrator, solver iterations
//! and control latency), and seeded random combinations of them. A matrix is a TOML file:
//!
//! ```toml
//! combinations = 8        # random combinations of the cases below
//! combination_size = 3    # cases per combination, each changing other quantities
//! seed = 1
//!
//! [[case]]
//! name = "friction x0.5"
//! friction_scale = 0.5
//! ```

use std::path::Path;

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use topa_env::physics::PhysicsConfig;
use topa_env::IntegratorChoice;

use crate::error::{ensure, Error, Result};
use crate::settings::EvalSettings;

/// The built-in matrix (configs/physics/matrix.toml).
pub const BUILT_IN: &str = include_str!("../../../configs/physics/matrix.toml");

/// The longest control latency a case may add, in control periods: beyond it the action a policy computed is
/// older than the next one it computes, which no controller runs.
pub const MAX_LATENCY_PERIODS: f64 = 1.0;

/// The keys of a case that are not `[env.physics]` keys.
const OWN_KEYS: [&str; 5] = ["name", "timestep", "integrator", "solver_iterations", "latency_s"];

/// The keys whose departure has a size (a factor, an offset, a latency); every other key is a switch.
const GRADED: [&str; 8] = [
    "friction_scale",
    "armature_scale",
    "damping_scale",
    "frictionloss_scale",
    "torso_mass_scale",
    "torso_com_offset",
    "foot_size_scale",
    "latency_s",
];

/// One perturbation: what it changes, by name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Perturbation {
    pub name: String,
    /// The keys this case sets, as written (cases setting a common key are never combined).
    pub keys: Vec<String>,
    #[serde(default, skip_serializing_if = "PhysicsConfig::is_nominal")]
    pub physics: PhysicsConfig,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timestep: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub integrator: Option<IntegratorChoice>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solver_iterations: Option<usize>,
    /// Added control latency: the action reaches the motors this much later, s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub latency_s: Option<f64>,
}

impl Perturbation {
    /// The evaluation's own physics (every report's first row).
    pub fn nominal() -> Perturbation {
        Perturbation {
            name: "nominal".into(),
            keys: Vec::new(),
            physics: PhysicsConfig::default(),
            timestep: None,
            integrator: None,
            solver_iterations: None,
            latency_s: None,
        }
    }

    pub fn is_nominal(&self) -> bool {
        self.keys.is_empty()
    }

    /// Reads one `[[case]]` table; errors name the case and the key.
    fn parse(mut t: toml::Table, at: &str) -> Result<Perturbation> {
        let name = match t.remove("name") {
            Some(toml::Value::String(s)) if !s.trim().is_empty() => s,
            Some(_) => return Err(Error::bad_file(format!("{at}: `name` must be a non-empty string"))),
            None => return Err(Error::bad_file(format!("{at}: every case needs a `name`"))),
        };
        let at = format!("{at} ('{name}')");
        let mut keys: Vec<String> = t.keys().cloned().collect();
        ensure!(!keys.is_empty(), "{at}: the case changes nothing; give at least one key (see docs/configuration.md)");
        keys.sort();
        let take = |t: &mut toml::Table, key: &str| -> Result<Option<toml::Value>> { Ok(t.remove(key)) };
        let float = |v: Option<toml::Value>, key: &str| -> Result<Option<f64>> {
            match v {
                None => Ok(None),
                Some(toml::Value::Float(x)) => Ok(Some(x)),
                Some(toml::Value::Integer(i)) => Ok(Some(i as f64)),
                Some(other) => Err(Error::bad_file(format!("{at}: `{key}` must be a number, got {other}"))),
            }
        };
        let timestep = float(take(&mut t, "timestep")?, "timestep")?;
        let latency_s = float(take(&mut t, "latency_s")?, "latency_s")?;
        let integrator = match take(&mut t, "integrator")? {
            None => None,
            Some(toml::Value::String(s)) => {
                Some(s.parse::<IntegratorChoice>().map_err(|e| Error::bad_file(format!("{at}: {e}")))?)
            }
            Some(other) => return Err(Error::bad_file(format!("{at}: `integrator` must be a string, got {other}"))),
        };
        let solver_iterations = match take(&mut t, "solver_iterations")? {
            None => None,
            Some(toml::Value::Integer(n)) if n >= 1 => Some(n as usize),
            Some(other) => {
                return Err(Error::bad_file(format!(
                    "{at}: `solver_iterations` must be a whole number ≥ 1, got {other}"
                )))
            }
        };
        // What is left are `[env.physics]` keys; an unknown one is named with the known ones.
        let physics: PhysicsConfig = toml::Value::Table(t).try_into().map_err(|e: toml::de::Error| {
            let own = OWN_KEYS.join("`, `");
            Error::bad_file(format!("{at}: {} (or one of `{own}`)", e.message().replace('\n', " ")))
        })?;
        physics.validate().map_err(|e| Error::bad_file(format!("{at}: {e}")))?;
        if let Some(dt) = timestep {
            ensure!(dt.is_finite() && dt > 0.0, "{at}: timestep must be positive, got {dt}");
        }
        if let Some(l) = latency_s {
            ensure!(l.is_finite() && l > 0.0, "{at}: latency_s must be positive, got {l}");
        }
        Ok(Perturbation { name, keys, physics, timestep, integrator, solver_iterations, latency_s })
    }

    /// Both cases at once (their keys are disjoint).
    fn with(&self, other: &Perturbation) -> Perturbation {
        let mut keys = [self.keys.clone(), other.keys.clone()].concat();
        keys.sort();
        Perturbation {
            name: format!("{} + {}", self.name, other.name),
            keys,
            physics: self.physics.then(&other.physics),
            timestep: other.timestep.or(self.timestep),
            integrator: other.integrator.or(self.integrator),
            solver_iterations: other.solver_iterations.or(self.solver_iterations),
            latency_s: other.latency_s.or(self.latency_s),
        }
    }

    /// Levels of a magnitude search from nominal (0) to this case (`levels`): the latency's physics steps of `dt`
    /// for a latency alone, else eighths of the departure. `None` for a case with a switch (cone, solver,
    /// integrator, sole shape, a contact parameter, the timestep or the iterations): its smallest form is itself.
    pub fn levels(&self, dt: f64) -> Option<usize> {
        if !self.keys.iter().all(|k| GRADED.contains(&k.as_str())) {
            return None;
        }
        match (self.latency_s, self.keys.len()) {
            (Some(l), 1) => Some(((l / dt).round() as usize).max(1)),
            _ => Some(8),
        }
    }

    /// This case `k` of `levels` of the way from nominal: factors and offsets linearly, the latency rounded to
    /// whole physics steps of `dt`. Named by its sizes.
    pub fn graded(&self, k: usize, levels: usize, dt: f64) -> Perturbation {
        let t = k as f64 / levels as f64;
        let lerp = |f: f64| 1.0 + t * (f - 1.0);
        let mut g = self.clone();
        let p = &mut g.physics;
        for f in [
            &mut p.friction_scale,
            &mut p.armature_scale,
            &mut p.damping_scale,
            &mut p.frictionloss_scale,
            &mut p.torso_mass_scale,
            &mut p.foot_size_scale,
        ] {
            *f = lerp(*f);
        }
        p.torso_com_offset = p.torso_com_offset.map(|o| t * o);
        g.latency_s = self.latency_s.map(|l| (t * l / dt).round() * dt).filter(|&l| l > 0.0);
        g.name = g.sizes();
        g
    }

    /// The sizes of the graded quantities this case sets, in words ("friction x0.62, latency 12.5 ms").
    pub fn sizes(&self) -> String {
        let p = &self.physics;
        let mut out: Vec<String> = [
            ("friction", p.friction_scale),
            ("armature", p.armature_scale),
            ("joint damping", p.damping_scale),
            ("dry friction", p.frictionloss_scale),
            ("torso mass", p.torso_mass_scale),
            ("soles", p.foot_size_scale),
        ]
        .iter()
        .filter(|(_, f)| *f != 1.0)
        .map(|(what, f)| format!("{what} x{f:.3}"))
        .collect();
        if p.torso_com_offset != [0.0; 3] {
            let [x, y, z] = p.torso_com_offset.map(|o| 100.0 * o);
            out.push(format!("torso CoM ({x:+.2}, {y:+.2}, {z:+.2}) cm"));
        }
        if let Some(l) = self.latency_s {
            out.push(format!("latency {:.1} ms", 1e3 * l));
        }
        if out.is_empty() {
            return "nominal".into();
        }
        out.join(", ")
    }

    /// The evaluation settings of this case on top of `base` for a policy acting every `policy_dt` s: an error
    /// names a timestep that does not divide the control period and a latency that is not a whole number of
    /// physics steps or longer than `MAX_LATENCY_PERIODS` periods.
    pub fn settings(&self, base: &EvalSettings, policy_dt: f64) -> Result<EvalSettings> {
        let mut s = base.clone();
        s.physics = base.physics.then(&self.physics);
        if let Some(dt) = self.timestep {
            s.timestep = Some(dt);
        }
        if let Some(i) = self.integrator {
            s.integrator = i;
        }
        if let Some(n) = self.solver_iterations {
            s.solver_iterations = Some(n);
        }
        let dt = s.timestep();
        let periods = policy_dt / dt;
        ensure!(
            (periods - periods.round()).abs() < 1e-6 && periods.round() >= 1.0,
            "case '{}': the timestep {dt} s does not divide the policy's control period {policy_dt} s; use a divisor \
             of it",
            self.name
        );
        if let Some(l) = self.latency_s {
            let max = MAX_LATENCY_PERIODS * policy_dt;
            ensure!(
                l <= max + 1e-12,
                "case '{}': a latency of {l} s is longer than {MAX_LATENCY_PERIODS} control period(s) ({max} s); an \
                 action older than the next one is not a controller",
                self.name
            );
            let steps = l / dt;
            ensure!(
                (steps - steps.round()).abs() < 1e-6,
                "case '{}': a latency of {l} s is not a whole number of physics steps of {dt} s; use a multiple of it",
                self.name
            );
            let lat = &mut s.sim2sim.latency;
            lat.action_physics_steps += steps.round() as usize;
            if lat.action_physics_steps_max > 0 {
                lat.action_physics_steps_max += steps.round() as usize; // a drawn range moves with it
            }
        }
        Ok(s)
    }
}

/// A matrix: the one-at-a-time cases, then the random combinations.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Matrix {
    /// Where it came from ("built-in" or the file), for the report.
    pub source: String,
    pub cases: Vec<Perturbation>,
    pub combinations: usize,
    pub combination_size: usize,
    pub seed: u64,
}

impl Matrix {
    /// The built-in matrix, or the one in `file`.
    pub fn load(file: Option<&Path>) -> Result<Matrix> {
        match file {
            None => Matrix::parse(BUILT_IN, "built-in configs/physics/matrix.toml"),
            Some(f) => {
                let text = std::fs::read_to_string(f).map_err(Error::io("cannot read the perturbation matrix", f))?;
                Matrix::parse(&text, &f.display().to_string())
            }
        }
    }

    /// Reads a matrix from TOML; `source` names it in errors.
    pub fn parse(text: &str, source: &str) -> Result<Matrix> {
        let mut t: toml::Table = toml::from_str(text).map_err(|e| {
            Error::bad_file(format!("perturbation matrix {source}: {}", e.message().replace('\n', " ")))
        })?;
        let at = format!("perturbation matrix {source}");
        let count = |t: &mut toml::Table, key: &str, default: i64| -> Result<i64> {
            match t.remove(key) {
                None => Ok(default),
                Some(toml::Value::Integer(n)) if n >= 0 => Ok(n),
                Some(v) => Err(Error::bad_file(format!("{at}: `{key}` must be a whole number ≥ 0, got {v}"))),
            }
        };
        let combinations = count(&mut t, "combinations", 0)? as usize;
        let combination_size = count(&mut t, "combination_size", 2)? as usize;
        let seed = count(&mut t, "seed", 1)? as u64;
        let cases = match t.remove("case") {
            Some(toml::Value::Array(a)) => a,
            None => Vec::new(),
            Some(_) => return Err(Error::bad_file(format!("{at}: `case` must be an array of tables ([[case]])"))),
        };
        if let Some(k) = t.keys().next() {
            return Err(Error::bad_file(format!(
                "{at}: unknown key `{k}`; a matrix has `combinations`, `combination_size`, `seed` and [[case]] tables"
            )));
        }
        let cases = cases
            .into_iter()
            .enumerate()
            .map(|(i, c)| match c {
                toml::Value::Table(c) => Perturbation::parse(c, &format!("{at}, case {}", i + 1)),
                _ => Err(Error::bad_file(format!("{at}, case {}: a case is a table", i + 1))),
            })
            .collect::<Result<Vec<_>>>()?;
        ensure!(!cases.is_empty(), "{at}: no [[case]]; a matrix needs at least one");
        for (i, c) in cases.iter().enumerate() {
            ensure!(
                !cases[..i].iter().any(|d| d.name == c.name),
                "{at}: two cases are named '{}'; names identify rows of the report",
                c.name
            );
        }
        ensure!(
            combinations == 0 || combination_size >= 2,
            "{at}: combination_size must be at least 2 (a combination of one case is that case)"
        );
        Ok(Matrix { source: source.into(), cases, combinations, combination_size, seed })
    }

    /// Every case a policy runs: nominal, each case alone, then the random combinations (`combination_picks`).
    pub fn expand(&self) -> Vec<Perturbation> {
        let mut out = vec![Perturbation::nominal()];
        out.extend(self.cases.iter().cloned());
        out.extend(self.combination_picks().iter().map(|p| self.combine(p)));
        out
    }

    /// The members (indices into `cases`) of each random combination: cases with disjoint keys, drawn from the
    /// matrix's seed; fewer than `combinations` when no more disjoint sets exist.
    pub fn combination_picks(&self) -> Vec<Vec<usize>> {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let mut made: Vec<Vec<usize>> = Vec::new();
        let mut tries = 0;
        while made.len() < self.combinations && tries < 100 * self.combinations.max(1) {
            tries += 1;
            let mut order: Vec<usize> = (0..self.cases.len()).collect();
            order.shuffle(&mut rng);
            let mut pick: Vec<usize> = Vec::new();
            for i in order {
                let disjoint = pick.iter().all(|&j| self.cases[j].keys.iter().all(|k| !self.cases[i].keys.contains(k)));
                if disjoint && pick.len() < self.combination_size {
                    pick.push(i);
                }
            }
            pick.sort();
            if pick.len() == self.combination_size && !made.contains(&pick) {
                made.push(pick);
            }
        }
        made
    }

    /// The combination of the given cases (indices into `cases`, at least one).
    pub fn combine(&self, members: &[usize]) -> Perturbation {
        let mut c = self.cases[members[0]].clone();
        for &j in &members[1..] {
            c = c.with(&self.cases[j]);
        }
        c
    }

    /// Checks every case against a policy acting every `policy_dt` s before anything runs.
    pub fn check(&self, base: &EvalSettings, policy_dt: f64) -> Result<()> {
        for c in self.expand() {
            c.settings(base, policy_dt)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str) -> String {
        crate::error::chain(&Matrix::parse(text, "m.toml").unwrap_err())
    }

    #[test]
    fn bad_matrices_get_one_error_naming_the_case_and_the_key() {
        let e = err("[[case]]\nname = \"slippery\"\nfrction_scale = 0.5\n");
        assert!(e.contains("m.toml") && e.contains("slippery") && e.contains("frction_scale"), "{e}");
        let e = err("[[case]]\nname = \"negative\"\nfriction_scale = -0.5\n");
        assert!(e.contains("negative") && e.contains("friction_scale") && e.contains("positive"), "{e}");
        let e = err("[[case]]\nname = \"empty\"\n");
        assert!(e.contains("changes nothing"), "{e}");
        let e = err("[[case]]\nfriction_scale = 0.5\n");
        assert!(e.contains("case 1") && e.contains("name"), "{e}");
        let e = err("[[case]]\nname = \"a\"\nintegrator = \"verlet\"\n");
        assert!(e.contains("verlet"), "{e}");
        let e = err("combinatons = 3\n[[case]]\nname = \"a\"\nfriction_scale = 0.5\n");
        assert!(e.contains("combinatons"), "{e}");
        let e = err("[[case]]\nname = \"a\"\nfriction_scale = 0.5\n[[case]]\nname = \"a\"\nfriction_scale = 2.0\n");
        assert!(e.contains("two cases are named 'a'"), "{e}");
    }

    #[test]
    fn latency_becomes_physics_steps_within_one_control_period() {
        let m = Matrix::parse("[[case]]\nname = \"late\"\nlatency_s = 0.01\n", "m.toml").unwrap();
        let base = EvalSettings::default(); // 2.5 ms physics steps
        let s = m.cases[0].settings(&base, 0.02).unwrap();
        assert_eq!(s.sim2sim.latency.action_physics_steps, 4);
        let long = Matrix::parse("[[case]]\nname = \"too late\"\nlatency_s = 0.03\n", "m.toml").unwrap();
        let e = long.check(&base, 0.02).unwrap_err().to_string();
        assert!(e.contains("too late") && e.contains("longer than 1 control period"), "{e}");
        let odd = Matrix::parse("[[case]]\nname = \"odd\"\nlatency_s = 0.003\n", "m.toml").unwrap();
        assert!(odd.check(&base, 0.02).unwrap_err().to_string().contains("whole number of physics steps"));
        let dt = Matrix::parse("[[case]]\nname = \"dt\"\ntimestep = 0.003\n", "m.toml").unwrap();
        assert!(dt.check(&base, 0.02).unwrap_err().to_string().contains("does not divide"));
    }

    #[test]
    fn the_built_in_matrix_expands_to_nominal_each_case_and_disjoint_seeded_combinations() {
        let m = Matrix::load(None).unwrap();
        let all = m.expand();
        assert_eq!(all.len(), 1 + m.cases.len() + m.combinations);
        assert!(all[0].is_nominal() && all[1..].iter().all(|c| !c.is_nominal()));
        assert_eq!(all, m.expand(), "the combinations are fixed by the matrix's seed");
        for c in &all[1 + m.cases.len()..] {
            let mut keys = c.keys.clone();
            keys.dedup();
            assert_eq!(keys.len(), c.keys.len(), "{}: a key set twice", c.name);
            assert_eq!(c.name.matches(" + ").count() + 1, m.combination_size);
        }
        // The built-in matrix runs on TopA's and Cassie's 50 Hz policies at the evaluation's timestep.
        m.check(&EvalSettings::default(), 0.02).unwrap();
        // A combination multiplies factors and keeps both cases' choices.
        let two = Matrix::parse(
            "combinations = 1\n[[case]]\nname = \"a\"\nfriction_scale = 0.5\n[[case]]\nname = \"b\"\ncone = \"elliptic\"\n",
            "m.toml",
        )
        .unwrap()
        .expand();
        let c = &two[3];
        assert_eq!((c.physics.friction_scale, c.physics.cone), (0.5, Some(topa_env::physics::ConeChoice::Elliptic)));
    }
}
