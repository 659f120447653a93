//! The paper's cyclic adversarial schedule: phase 1 (policy only), then `cycles` × (phase 2: adversary learns
//! against the frozen policy; phase 3: policy learns under the frozen adversary). Without the adversary the
//! schedule is phase 1 alone. A run's position is a pure function of its global iteration, so checkpoints only
//! store the iteration and resume lands mid-phase exactly.

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Phase {
    /// Phase 1 (and the whole run without an adversary): the policy learns, nothing perturbs it.
    Policy,
    /// Phase 2: the adversary learns; the policy is frozen.
    Adversary,
    /// Phase 3: the policy learns under the frozen adversary's perturbations.
    PolicyUnderAttack,
}

impl Phase {
    pub fn number(self) -> u8 {
        match self {
            Phase::Policy => 1,
            Phase::Adversary => 2,
            Phase::PolicyUnderAttack => 3,
        }
    }
    pub fn policy_learns(self) -> bool {
        self != Phase::Adversary
    }
    pub fn adversary_acts(self) -> bool {
        self != Phase::Policy
    }
}

/// Where an iteration falls in the schedule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Position {
    pub phase: Phase,
    /// 1-based cycle for phases 2 and 3; 0 in phase 1.
    pub cycle: usize,
    /// Iterations of this phase already done before this one.
    pub iter_in_phase: usize,
    /// Length of this phase.
    pub phase_len: usize,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Schedule {
    /// (phase, cycle, length) in order.
    segments: Vec<(Phase, usize, usize)>,
}

impl Schedule {
    /// Policy only, `iterations` long.
    pub fn plain(iterations: usize) -> Self {
        Schedule { segments: vec![(Phase::Policy, 0, iterations)] }
    }

    pub fn cyclic(phase1: usize, phase2: usize, phase3: usize, cycles: usize) -> Self {
        let mut segments = vec![(Phase::Policy, 0, phase1)];
        for c in 1..=cycles {
            segments.push((Phase::Adversary, c, phase2));
            segments.push((Phase::PolicyUnderAttack, c, phase3));
        }
        segments.retain(|s| s.2 > 0);
        Schedule { segments }
    }

    pub fn total(&self) -> usize {
        self.segments.iter().map(|s| s.2).sum()
    }

    /// The position of global iteration `iter` (0-based), or None past the end.
    pub fn position(&self, iter: usize) -> Option<Position> {
        let mut start = 0;
        for &(phase, cycle, len) in &self.segments {
            if iter < start + len {
                return Some(Position { phase, cycle, iter_in_phase: iter - start, phase_len: len });
            }
            start += len;
        }
        None
    }

    /// The phase numbers of every iteration, in order (for tests and the progress display).
    pub fn phases(&self) -> Vec<u8> {
        self.segments.iter().flat_map(|&(p, _, len)| std::iter::repeat_n(p.number(), len)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sequence_is_phase_one_then_two_three_per_cycle() {
        let s = Schedule::cyclic(3, 2, 1, 2);
        assert_eq!(s.phases(), vec![1, 1, 1, 2, 2, 3, 2, 2, 3]);
        assert_eq!(s.total(), 9);
        assert_eq!(s.position(4), Some(Position { phase: Phase::Adversary, cycle: 1, iter_in_phase: 1, phase_len: 2 }));
        assert_eq!(s.position(8).unwrap().phase, Phase::PolicyUnderAttack);
        assert_eq!(s.position(8).unwrap().cycle, 2);
        assert_eq!(s.position(9), None);
        assert_eq!(Schedule::plain(4).phases(), vec![1, 1, 1, 1]);
    }
}
