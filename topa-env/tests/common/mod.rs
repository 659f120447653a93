//! Shared checks of the linkage tests (TopA's and Kestrel's).

use nalgebra::DMatrix;
use topa_env::linkage::Linkage;

/// J at motor positions `q`, checked column by column against central finite differences of the solved loop
/// closure (step 1e-4 rad) to 1e-6.
pub fn jacobian_checked_by_finite_differences(l: &mut Linkage, q: &[f64]) -> DMatrix<f64> {
    let n = l.n_motors();
    let h = 1e-4;
    let j = l.jacobian(q).unwrap();
    for k in 0..n {
        let (mut up, mut down) = (q.to_vec(), q.to_vec());
        up[k] += h;
        down[k] -= h;
        let (a, b) = (l.joints(&up).unwrap(), l.joints(&down).unwrap());
        for r in 0..n {
            let fd = (a[r] - b[r]) / (2.0 * h);
            assert!((fd - j[(r, k)]).abs() < 1e-6, "∂q_{r}/∂m_{k}: finite difference {fd} vs J {}", j[(r, k)]);
        }
    }
    j
}
