use super::*;

/// A `n × n` field over ±`half` m whose heights are `f(x, y)` (top = 1 m, so data are heights).
fn field(n: usize, half: f64, f: impl Fn(f64, f64) -> f64) -> (Vec<f32>, [f64; 4]) {
    let d = 2.0 * half / (n - 1) as f64;
    let data = (0..n * n).map(|i| f((i % n) as f64 * d - half, (i / n) as f64 * d - half) as f32).collect();
    (data, [half, half, 1.0, 0.1])
}

fn level_box(pos: [f64; 3], half: [f64; 3]) -> Box3 {
    Box3 { pos, rot: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0], half }
}

#[test]
fn surface_is_exact_on_a_tilted_plane() {
    let (data, size) = field(21, 1.0, |x, y| 0.5 + 0.2 * x - 0.1 * y);
    let f = Field { data: &data, nrow: 21, ncol: 21, size };
    let n_expect = {
        let l = (0.2f64 * 0.2 + 0.1 * 0.1 + 1.0).sqrt();
        [-0.2 / l, 0.1 / l, 1.0 / l]
    };
    for &(x, y) in &[(0.013, -0.37), (0.5, 0.5), (-0.99, 0.99), (0.31, 0.29)] {
        let (h, n) = f.surface(x, y).unwrap();
        assert!((h - (0.5 + 0.2 * x - 0.1 * y)).abs() < 1e-6, "h({x}, {y}) = {h}");
        for i in 0..3 {
            assert!((n[i] - n_expect[i]).abs() < 1e-6, "normal {n:?}");
        }
    }
    assert!(f.surface(1.01, 0.0).is_none());
}

#[test]
fn surface_follows_mujocos_diagonal() {
    // One cell with a single raised sample at (r, c) = (1, 1): on MuJoCo's diagonal (0,0)–(1,1) the height rises
    // linearly, and off it only the triangle holding that sample sees it.
    let data = [0.0f32, 0.0, 0.0, 1.0];
    let f = Field { data: &data, nrow: 2, ncol: 2, size: [0.5, 0.5, 1.0, 0.1] };
    assert!((f.surface(0.0, 0.0).unwrap().0 - 0.5).abs() < 1e-12);
    // u = 0.75, w = 0.25 (below the diagonal): h = u·(h10 − h00) + w·(h11 − h10) = 0.25.
    assert!((f.surface(0.25, -0.25).unwrap().0 - 0.25).abs() < 1e-12);
    assert!((f.surface(-0.25, 0.25).unwrap().0 - 0.25).abs() < 1e-12);
}

#[test]
fn a_level_box_on_flat_ground_touches_at_its_four_corners() {
    let (data, size) = field(41, 1.0, |_, _| 0.2);
    let f = Field { data: &data, nrow: 41, ncol: 41, size };
    let b = level_box([0.013, -0.021, 0.2 + 0.015 - 0.001], [0.09, 0.045, 0.015]);
    let mut c = Vec::new();
    contacts(&f, &b, 0.0, &mut c);
    assert_eq!(c.len(), 4, "a box on flat ground: four contacts");
    for k in &c {
        assert!((k.dist + 0.001).abs() < 1e-6, "depth {}", k.dist);
        assert!((k.normal[2] - 1.0).abs() < 1e-12);
        assert!((k.pos[2] - 0.1995).abs() < 1e-6, "midway between the surfaces: {}", k.pos[2]);
        assert!((k.pos[0] - b.pos[0]).abs() > 0.089 && (k.pos[1] - b.pos[1]).abs() > 0.044, "a corner: {:?}", k.pos);
    }
    // Lifted 1 mm clear: nothing, unless the margin reaches it.
    let lifted = level_box([b.pos[0], b.pos[1], 0.2 + 0.015 + 0.001], b.half);
    contacts(&f, &lifted, 0.0, &mut c);
    assert!(c.is_empty());
    contacts(&f, &lifted, 0.002, &mut c);
    assert_eq!(c.len(), 4);
    assert!(c.iter().all(|k| (k.dist - 0.001).abs() < 1e-6));
}

#[test]
fn a_step_edge_under_the_sole_is_found_by_the_field_samples() {
    // A 5 cm step at x = 0 (sampled every 2.5 cm): the sole straddles it, its corners hang over the lower side
    // (no corner below the surface), so only the samples of the step's edge inside the box hold it.
    let (data, size) = field(81, 1.0, |x, _| if x >= 0.0 { 0.05 } else { 0.0 });
    let f = Field { data: &data, nrow: 81, ncol: 81, size };
    let b = level_box([-0.07, 0.0, 0.05 + 0.015 - 0.002], [0.09, 0.045, 0.015]);
    let mut c = Vec::new();
    contacts(&f, &b, 0.0, &mut c);
    assert!(!c.is_empty() && c.len() <= MAX_CONTACTS);
    for k in &c {
        assert!(k.dist < 0.0 && k.dist > -0.003, "depth {}", k.dist);
        assert!(k.normal[2] > 0.99, "the sole's bottom face holds it: {:?}", k.normal);
        assert!(k.pos[0] >= -0.001, "on the step: {:?}", k.pos);
    }
}

#[test]
fn reduction_keeps_the_deepest_and_spans_the_patch() {
    let at = |x: f64, y: f64, dist: f64| Candidate { pos: [x, y, 0.0], normal: [0.0, 0.0, 1.0], dist };
    let mut c = vec![at(0.0, 0.0, -0.001), at(1.0, 1.0, -0.002), at(0.5, 0.5, -0.009), at(1.0, 0.0, -0.001)];
    c.push(at(0.0, 1.0, -0.001));
    c.push(at(0.4, 0.6, -0.001));
    reduce(&mut c);
    // The patch's four corners and, deeper than all of them, its centre.
    let xs: Vec<[f64; 2]> = c.iter().map(|k| [k.pos[0], k.pos[1]]).collect();
    assert_eq!(c.len(), MAX_CONTACTS, "{xs:?}");
    for corner in [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [0.5, 0.5]] {
        assert!(xs.contains(&corner), "{corner:?} in {xs:?}");
    }
    // Where the centre is no deeper than the corners it is not kept.
    c = vec![at(0.0, 0.0, -0.001), at(1.0, 1.0, -0.001), at(0.5, 0.5, -0.001), at(1.0, 0.0, -0.001)];
    c.push(at(0.0, 1.0, -0.001));
    reduce(&mut c);
    assert_eq!(c.len(), 4);
    assert!(c.iter().all(|k| k.pos != [0.5, 0.5, 0.0]));
}
