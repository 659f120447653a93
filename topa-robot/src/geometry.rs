//! Where a collision geom reaches lowest in a pose: how the import finds the feet, places the sole sites and sets
//! the stand height.

use mujoco::{Data, GeomType};

/// The world point of geom `g` that is lowest (least z) in `data`'s pose; for a flat face, the face's centre.
pub(crate) fn lowest_point(data: &Data, g: usize) -> [f64; 3] {
    let m = data.model();
    let c = data.geom_xpos()[g];
    let r = data.geom_xmat()[g];
    let s = m.geom_size()[g];
    // Column k of the geom's rotation: its k-th axis in the world.
    let axis = |k: usize| [r[k], r[3 + k], r[6 + k]];
    let down = |p: [f64; 3], dz: f64| [p[0], p[1], p[2] - dz];
    match m.geom_type(g) {
        GeomType::Sphere => down(c, s[0]),
        GeomType::Capsule => {
            let a = axis(2);
            // A capsule within 1 mm of level rests on its middle.
            let end = if (a[2] * s[1]).abs() < 1e-3 { 0.0 } else { -a[2].signum() * s[1] };
            down([c[0] + end * a[0], c[1] + end * a[1], c[2] + end * a[2]], s[0])
        }
        GeomType::Box => {
            let mut p = c;
            for k in 0..3 {
                let a = axis(k);
                // A face that is nearly level: the face's centre, not a corner.
                if a[2].abs() < 0.1 {
                    continue;
                }
                for (i, v) in p.iter_mut().enumerate() {
                    *v -= a[2].signum() * s[k] * a[i];
                }
            }
            p
        }
        GeomType::Cylinder => {
            let a = axis(2);
            let dz = (a[2] * s[1]).abs() + (1.0 - a[2] * a[2]).max(0.0).sqrt() * s[0];
            down(c, dz)
        }
        GeomType::Ellipsoid => {
            let dz = (0..3).map(|k| (r[6 + k] * s[k]).powi(2)).sum::<f64>().sqrt();
            down(c, dz)
        }
        // Meshes and the rest: their bounding sphere (conservative: the sole site sits at most that far low).
        _ => down(c, m.geom_rbound()[g]),
    }
}

/// A world point in `body`'s frame.
pub(crate) fn in_body_frame(data: &Data, body: usize, p: [f64; 3]) -> [f64; 3] {
    let (x, r) = (data.xpos()[body], data.xmat()[body]);
    let d = [p[0] - x[0], p[1] - x[1], p[2] - x[2]];
    std::array::from_fn(|k| r[k] * d[0] + r[3 + k] * d[1] + r[6 + k] * d[2])
}
