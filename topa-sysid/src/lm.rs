//! Levenberg–Marquardt from the `levenberg-marquardt` crate for a problem given as a residual vector and its
//! Jacobian over a free parameter vector z. The crate is on nalgebra 0.34 (`lm_nalgebra` here); this adapter keeps
//! that version in one place.

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
pub use lm_nalgebra::DMatrix;
use lm_nalgebra::{DVector, Dyn, Owned};

pub trait Residuals: Sync {
    /// r(z); None when the model cannot be evaluated there (the optimiser then backs off).
    fn residuals(&self, z: &[f64]) -> Option<Vec<f64>>;
    /// ∂r/∂z.
    fn jacobian(&self, z: &[f64]) -> Option<DMatrix<f64>>;
}

pub struct Minimum {
    pub z: Vec<f64>,
    pub converged: bool,
    /// The optimiser's reason for stopping.
    pub termination: String,
    pub evaluations: usize,
}

struct Adapter<'a, P> {
    problem: &'a P,
    z: DVector<f64>,
}

impl<P: Residuals> LeastSquaresProblem<f64, Dyn, Dyn> for Adapter<'_, P> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, z: &DVector<f64>) {
        self.z.copy_from(z);
    }

    fn params(&self) -> DVector<f64> {
        self.z.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        let r = self.problem.residuals(self.z.as_slice())?;
        r.iter().all(|x| x.is_finite()).then(|| DVector::from_vec(r))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let j = self.problem.jacobian(self.z.as_slice())?;
        j.iter().all(|x| x.is_finite()).then_some(j)
    }
}

/// Minimises ½‖r(z)‖² from `z0`, with at most `patience` × (len + 1) residual evaluations.
pub fn minimize<P: Residuals>(problem: &P, z0: Vec<f64>, patience: usize) -> Minimum {
    let adapter = Adapter { problem, z: DVector::from_vec(z0) };
    let (adapter, report) = LevenbergMarquardt::new().with_patience(patience.max(1)).minimize(adapter);
    Minimum {
        z: adapter.z.as_slice().to_vec(),
        converged: report.termination.was_successful(),
        termination: format!("{:?}", report.termination),
        evaluations: report.number_of_evaluations,
    }
}
