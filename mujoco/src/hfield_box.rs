//! A cheaper box–height-field collision, chosen per model.
//!
//! MuJoCo 2.2 collides a box with a height field by running a convex penetration test (libccd's MPR) against
//! every triangular prism under the box and keeps one contact per prism that touches: a 18 × 9 cm sole on a 5 cm
//! field makes ~20 tests and up to ~16 contacts, where a plane gives four corners. This one tests the box's
//! corners against the field's triangles and the field's samples against the box (vertex–face both ways, no
//! iteration), then keeps at most [`MAX_CONTACTS`] that span the contact patch, as a box on a plane does.
//! Edge–edge contacts are not tested: a box at least one sample spacing wide always has a sample inside it where an
//! edge of the field cuts into it.
//!
//! A model opts in per height-field geom with `user="1"` (and `<size nuser_geom="1"/>`); every other model keeps
//! MuJoCo's own collision, so [`install`] changes nothing for them.

use std::os::raw::c_int;
use std::sync::OnceLock;

use mujoco_sys::ffi::{self, mjContact, mjData, mjModel, mjtNum};

/// The `user` value of a height-field geom that selects these contacts.
pub const USER_VERTEX_CONTACTS: f64 = 1.0;

/// Contacts kept per box: the four that span the patch (a plane gives a box its four corners) and the deepest.
pub const MAX_CONTACTS: usize = 5;

/// Candidates considered per box (deepest kept when a very large box covers more samples).
const MAX_CANDIDATES: usize = 128;

static MUJOCO_HFIELD_BOX: OnceLock<ffi::mjfCollision> = OnceLock::new();

/// Puts this collision in MuJoCo's table for height field × box, keeping MuJoCo's own for the models that do not
/// opt in. Idempotent; call it before a model that opts in is stepped.
pub fn install() {
    MUJOCO_HFIELD_BOX.get_or_init(|| {
        // SAFETY: one write, under the OnceLock, of a table entry MuJoCo only reads while colliding.
        unsafe {
            let table = &mut *std::ptr::addr_of_mut!(ffi::mjCOLLISIONFUNC);
            let own = table[ffi::mjGEOM_HFIELD as usize][ffi::mjGEOM_BOX as usize];
            table[ffi::mjGEOM_HFIELD as usize][ffi::mjGEOM_BOX as usize] = Some(hfield_box);
            own
        }
    });
}

#[derive(Clone, Copy, Default)]
struct Candidate {
    /// Midpoint between the surfaces, height-field frame.
    pos: [f64; 3],
    /// From the field to the box, height-field frame.
    normal: [f64; 3],
    /// Signed distance (negative: penetration).
    dist: f64,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
/// `m · v` for MuJoCo's row-major 3×3.
fn mul(m: &[f64], v: [f64; 3]) -> [f64; 3] {
    [dot([m[0], m[1], m[2]], v), dot([m[3], m[4], m[5]], v), dot([m[6], m[7], m[8]], v)]
}
/// `mᵀ · v`.
fn mul_t(m: &[f64], v: [f64; 3]) -> [f64; 3] {
    [dot([m[0], m[3], m[6]], v), dot([m[1], m[4], m[7]], v), dot([m[2], m[5], m[8]], v)]
}

/// A height field in its geom's frame: samples `c·dx − sx`, `r·dy − sy`, heights `data·top`.
struct Field<'a> {
    data: &'a [f32],
    nrow: usize,
    ncol: usize,
    size: [f64; 4],
}

impl Field<'_> {
    fn dx(&self) -> f64 {
        2.0 * self.size[0] / (self.ncol - 1) as f64
    }
    fn dy(&self) -> f64 {
        2.0 * self.size[1] / (self.nrow - 1) as f64
    }
    fn h(&self, r: usize, c: usize) -> f64 {
        self.data[r * self.ncol + c] as f64 * self.size[2]
    }

    /// Surface height and upward unit normal at (x, y), on MuJoCo's triangulation of each cell (the diagonal
    /// from sample (r, c) to (r + 1, c + 1)); `None` outside the field.
    fn surface(&self, x: f64, y: f64) -> Option<(f64, [f64; 3])> {
        let (dx, dy) = (self.dx(), self.dy());
        let (fx, fy) = ((x + self.size[0]) / dx, (y + self.size[1]) / dy);
        if !(0.0..=(self.ncol - 1) as f64).contains(&fx) || !(0.0..=(self.nrow - 1) as f64).contains(&fy) {
            return None;
        }
        let c = (fx.floor() as usize).min(self.ncol - 2);
        let r = (fy.floor() as usize).min(self.nrow - 2);
        let (u, w) = (fx - c as f64, fy - r as f64);
        let (h00, h01, h10, h11) = (self.h(r, c), self.h(r + 1, c), self.h(r, c + 1), self.h(r + 1, c + 1));
        // Slopes of the triangle (x along columns, y along rows).
        let (hx, hy) = if w >= u { ((h11 - h01) / dx, (h01 - h00) / dy) } else { ((h10 - h00) / dx, (h11 - h10) / dy) };
        let h = h00 + u * hx * dx + w * hy * dy;
        let n = [-hx, -hy, 1.0];
        let l = norm(n);
        Some((h, [n[0] / l, n[1] / l, n[2] / l]))
    }
}

/// A box in the field's frame: centre, axes (columns of `rot`, row-major), half sizes.
struct Box3 {
    pos: [f64; 3],
    rot: [f64; 9],
    half: [f64; 3],
}

/// Every vertex–face contact of the box and the field within `margin`, reduced to [`MAX_CONTACTS`].
fn contacts(field: &Field, b: &Box3, margin: f64, out: &mut Vec<Candidate>) {
    out.clear();
    let mut push = |c: Candidate| {
        if out.len() < MAX_CANDIDATES {
            out.push(c);
        } else if let Some(worst) = (0..out.len()).max_by(|&i, &j| out[i].dist.total_cmp(&out[j].dist)) {
            if c.dist < out[worst].dist {
                out[worst] = c;
            }
        }
    };
    // The box's corners against the field's surface.
    for k in 0..8 {
        let s = [
            if k & 1 == 0 { -1.0 } else { 1.0 },
            if k & 2 == 0 { -1.0 } else { 1.0 },
            if k & 4 == 0 { -1.0 } else { 1.0 },
        ];
        let v = add3(b.pos, mul(&b.rot, [s[0] * b.half[0], s[1] * b.half[1], s[2] * b.half[2]]));
        if let Some((h, n)) = field.surface(v[0], v[1]) {
            let dist = (v[2] - h) * n[2];
            if dist < margin {
                push(Candidate { pos: add3(v, scale(n, -0.5 * dist)), normal: n, dist });
            }
        }
    }
    // The field's samples inside the box; the box face they are nearest to gives the normal.
    let ext: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| (b.rot[3 * i + j] * b.half[j]).abs()).sum());
    let (dx, dy) = (field.dx(), field.dy());
    let lo_c = ((b.pos[0] - ext[0] - margin + field.size[0]) / dx).ceil().max(0.0) as usize;
    let hi_c =
        (((b.pos[0] + ext[0] + margin + field.size[0]) / dx).floor().max(-1.0) as i64).min(field.ncol as i64 - 1);
    let lo_r = ((b.pos[1] - ext[1] - margin + field.size[1]) / dy).ceil().max(0.0) as usize;
    let hi_r =
        (((b.pos[1] + ext[1] + margin + field.size[1]) / dy).floor().max(-1.0) as i64).min(field.nrow as i64 - 1);
    let bottom = b.pos[2] - ext[2] - margin;
    for r in lo_r as i64..=hi_r {
        for c in lo_c as i64..=hi_c {
            let (r, c) = (r as usize, c as usize);
            let q = [c as f64 * dx - field.size[0], r as f64 * dy - field.size[1], field.h(r, c)];
            if q[2] < bottom {
                continue;
            }
            let ql = mul_t(&b.rot, sub(q, b.pos));
            let pen: [f64; 3] = std::array::from_fn(|i| b.half[i] - ql[i].abs());
            if pen.iter().any(|&p| p <= -margin) {
                continue;
            }
            let i = (0..3).min_by(|&i, &j| pen[i].total_cmp(&pen[j])).unwrap_or(2);
            let mut axis = [0.0; 3];
            axis[i] = if ql[i] >= 0.0 { 1.0 } else { -1.0 };
            // The box's outward normal there; the contact's points from the field into the box, against it.
            let out_n = mul(&b.rot, axis);
            let normal = scale(out_n, -1.0);
            push(Candidate { pos: add3(q, scale(out_n, 0.5 * pen[i])), normal, dist: -pen[i] });
        }
    }
    reduce(out);
}

fn add3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// Keeps four contacts spanning the patch (a box on a plane: its four corners) — the farthest from the deepest,
/// the farthest from that, the farthest from their line, the farthest on its other side — and the deepest as a
/// fifth where it is deeper than all four (a bump under the middle of a sole).
fn reduce(c: &mut Vec<Candidate>) {
    if c.len() <= 4 {
        return;
    }
    let pick = |c: &[Candidate], f: &dyn Fn(&Candidate) -> f64| -> Option<usize> {
        (0..c.len()).map(|i| (i, f(&c[i]))).filter(|x| x.1 > 1e-9).max_by(|a, b| a.1.total_cmp(&b.1)).map(|x| x.0)
    };
    let deepest = c[(0..c.len()).min_by(|&i, &j| c[i].dist.total_cmp(&c[j].dist)).unwrap_or(0)];
    // Kept on the stack: this runs for every box on the field at every physics step.
    let mut keep = [Candidate::default(); MAX_CONTACTS];
    let mut n = 0;
    if let Some(i1) = pick(c, &|x| norm(sub(x.pos, deepest.pos))) {
        let p1 = c[i1].pos;
        (keep[n], n) = (c[i1], n + 1);
        if let Some(i2) = pick(c, &|x| norm(sub(x.pos, p1))) {
            let p2 = c[i2].pos;
            (keep[n], n) = (c[i2], n + 1);
            let line = sub(p2, p1);
            let side = |x: &Candidate| cross(line, sub(x.pos, p1));
            if let Some(i3) = pick(c, &|x| norm(side(x))) {
                (keep[n], n) = (c[i3], n + 1);
                let up = side(&c[i3]);
                if let Some(i4) = pick(c, &|x| -dot(side(x), up) / norm(up)) {
                    (keep[n], n) = (c[i4], n + 1);
                }
            }
        }
    }
    let deepest_kept = keep[..n].iter().map(|k| k.dist).fold(f64::INFINITY, f64::min);
    if deepest.dist < deepest_kept - 1e-4 {
        (keep[n], n) = (deepest, n + 1);
    }
    c.clear();
    c.extend_from_slice(&keep[..n]);
}

/// MuJoCo's collision-function signature; geom 1 is the height field, geom 2 the box.
unsafe extern "C" fn hfield_box(
    m: *const mjModel,
    d: *const mjData,
    con: *mut mjContact,
    g1: c_int,
    g2: c_int,
    margin: mjtNum,
) -> c_int {
    let mm = &*m;
    let dd = &*d;
    let (g1, g2) = (g1 as usize, g2 as usize);
    let nuser = mm.nuser_geom as usize;
    if nuser == 0 || *mm.geom_user.add(g1 * nuser) != USER_VERTEX_CONTACTS {
        return match MUJOCO_HFIELD_BOX.get() {
            Some(Some(own)) => own(m, d, con, g1 as c_int, g2 as c_int, margin),
            _ => 0,
        };
    }
    let hid = *mm.geom_dataid.add(g1) as usize;
    let (nrow, ncol) = (*mm.hfield_nrow.add(hid) as usize, *mm.hfield_ncol.add(hid) as usize);
    if nrow < 2 || ncol < 2 {
        return 0;
    }
    let field = Field {
        data: std::slice::from_raw_parts(mm.hfield_data.add(*mm.hfield_adr.add(hid) as usize), nrow * ncol),
        nrow,
        ncol,
        size: std::array::from_fn(|i| *mm.hfield_size.add(4 * hid + i)),
    };
    let pos1 = std::slice::from_raw_parts(dd.geom_xpos.add(3 * g1), 3);
    let mat1 = std::slice::from_raw_parts(dd.geom_xmat.add(9 * g1), 9);
    let pos2 = std::slice::from_raw_parts(dd.geom_xpos.add(3 * g2), 3);
    let mat2 = std::slice::from_raw_parts(dd.geom_xmat.add(9 * g2), 9);
    let pos = mul_t(mat1, sub([pos2[0], pos2[1], pos2[2]], [pos1[0], pos1[1], pos1[2]]));
    // Bounding-sphere rejection, as MuJoCo's own first test.
    let r = *mm.geom_rbound.add(g2) + margin;
    if pos[0] - r > field.size[0]
        || pos[0] + r < -field.size[0]
        || pos[1] - r > field.size[1]
        || pos[1] + r < -field.size[1]
    {
        return 0;
    }
    if pos[2] - r > field.size[2] {
        return 0;
    }
    // Box axes in the field's frame: mat1ᵀ · mat2.
    let mut rot = [0.0; 9];
    for i in 0..3 {
        for j in 0..3 {
            rot[3 * i + j] = (0..3).map(|k| mat1[3 * k + i] * mat2[3 * k + j]).sum();
        }
    }
    let b = Box3 { pos, rot, half: std::array::from_fn(|i| *mm.geom_size.add(3 * g2 + i)) };
    // One candidate buffer per thread, reused: no allocation on the physics step.
    FOUND.with_borrow_mut(|found| {
        contacts(&field, &b, margin, found);
        for (k, c) in found.iter().enumerate() {
            let out = &mut *con.add(k);
            out.dist = c.dist;
            let n = mul(mat1, c.normal);
            let p = mul(mat1, c.pos);
            out.frame = [n[0], n[1], n[2], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
            out.pos = [p[0] + pos1[0], p[1] + pos1[1], p[2] + pos1[2]];
        }
        found.len() as c_int
    })
}

thread_local! {
    static FOUND: std::cell::RefCell<Vec<Candidate>> = const { std::cell::RefCell::new(Vec::new()) };
}

#[cfg(test)]
mod tests;
