//! A course's path: a polyline in the floor plane, parameterised by arc length.

/// A polyline with its cumulative arc length.
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    pts: Vec<[f64; 2]>,
    /// Arc length at each point (0 at the first).
    cum: Vec<f64>,
}

/// A point of the plane at `s` along the path, with the path's heading there (rad, from +x).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    pub s: f64,
    pub xy: [f64; 2],
    pub heading: f64,
}

impl Path {
    /// A path through `pts` (at least two, no two consecutive ones equal).
    pub fn new(pts: Vec<[f64; 2]>) -> crate::error::Result<Path> {
        if pts.len() < 2 {
            return Err(crate::error::EnvError::Course(format!(
                "a path needs at least 2 points, this one has {}",
                pts.len()
            )));
        }
        let mut cum = vec![0.0];
        for (i, w) in pts.windows(2).enumerate() {
            let l = dist(w[0], w[1]);
            if l < 1e-6 || !l.is_finite() {
                return Err(crate::error::EnvError::Course(format!(
                    "path points {i} and {} are the same point (or not finite)",
                    i + 1
                )));
            }
            cum.push(cum[i] + l);
        }
        Ok(Path { pts, cum })
    }

    pub fn length(&self) -> f64 {
        *self.cum.last().unwrap()
    }

    pub fn points(&self) -> &[[f64; 2]] {
        &self.pts
    }

    /// The segment `s` lies on (the last one at and beyond the end).
    fn segment(&self, s: f64) -> usize {
        match self.cum.binary_search_by(|c| c.total_cmp(&s)) {
            Ok(i) | Err(i) => i.saturating_sub(1).min(self.pts.len() - 2),
        }
    }

    fn heading_of(&self, seg: usize) -> f64 {
        let (a, b) = (self.pts[seg], self.pts[seg + 1]);
        (b[1] - a[1]).atan2(b[0] - a[0])
    }

    /// The point at arc length `s`, clamped to the path.
    pub fn at(&self, s: f64) -> PathPoint {
        let s = s.clamp(0.0, self.length());
        let i = self.segment(s);
        let (a, b) = (self.pts[i], self.pts[i + 1]);
        let u = (s - self.cum[i]) / (self.cum[i + 1] - self.cum[i]);
        PathPoint { s, xy: [a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])], heading: self.heading_of(i) }
    }

    /// The point of the path nearest to `p` among those with arc length in [`lo`, `hi`], and its distance. The
    /// window keeps a follower's progress from jumping to a parallel leg of the path that happens to be nearer.
    pub fn project(&self, p: [f64; 2], lo: f64, hi: f64) -> (PathPoint, f64) {
        let (lo, hi) = (lo.max(0.0), hi.min(self.length()));
        let mut best = (self.at(lo), f64::INFINITY);
        for i in self.segment(lo)..=self.segment(hi) {
            let (s0, s1) = (self.cum[i].max(lo), self.cum[i + 1].min(hi));
            if s1 < s0 {
                continue;
            }
            let (u, q) = closest_on_segment(p, self.at(s0).xy, self.at(s1).xy);
            let d = dist(p, q);
            if d < best.1 {
                best = (PathPoint { s: s0 + u * (s1 - s0), xy: q, heading: self.heading_of(i) }, d);
            }
        }
        best
    }

    /// The path between arc lengths `from` and `to` as a polyline (its end points and the corners between).
    pub fn slice(&self, from: f64, to: f64) -> Vec<[f64; 2]> {
        let mut out = vec![self.at(from).xy];
        out.extend(self.pts.iter().zip(&self.cum).filter(|(_, &c)| c > from + 1e-9 && c < to - 1e-9).map(|(p, _)| *p));
        out.push(self.at(to).xy);
        out
    }
}

pub fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// Distance between segments [a, b] and [c, d].
pub fn segment_distance(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> f64 {
    if segments_cross(a, b, c, d) {
        return 0.0;
    }
    [point_segment_distance(a, c, d), point_segment_distance(b, c, d), point_segment_distance(c, a, b), {
        point_segment_distance(d, a, b)
    }]
    .into_iter()
    .fold(f64::INFINITY, f64::min)
}

pub fn point_segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    dist(p, closest_on_segment(p, a, b).1)
}

/// The point of segment [a, b] nearest to `p`, and where it is along the segment (0 at a, 1 at b).
fn closest_on_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> (f64, [f64; 2]) {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l2 = dx * dx + dy * dy;
    let u = if l2 > 0.0 { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0) } else { 0.0 };
    (u, [a[0] + u * dx, a[1] + u * dy])
}

fn cross(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Whether the segments properly cross (each one's end points strictly on either side of the other).
pub fn segments_cross(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let (d1, d2) = (cross(c, d, a), cross(c, d, b));
    let (d3, d4) = (cross(a, b, c), cross(a, b, d));
    d1 * d2 < 0.0 && d3 * d4 < 0.0
}

/// Wraps an angle to (−π, π].
pub fn wrap(a: f64) -> f64 {
    let t = a.rem_euclid(std::f64::consts::TAU);
    if t > std::f64::consts::PI {
        t - std::f64::consts::TAU
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn l_path() -> Path {
        Path::new(vec![[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]]).unwrap()
    }

    #[test]
    fn arc_length_points_and_headings() {
        let p = l_path();
        assert_eq!(p.length(), 7.0);
        let q = p.at(5.5);
        assert!((q.xy[0] - 4.0).abs() < 1e-12 && (q.xy[1] - 1.5).abs() < 1e-12);
        assert!((q.heading - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(p.at(-1.0).xy, [0.0, 0.0]);
        assert_eq!(p.at(99.0).xy, [4.0, 3.0]);
        assert_eq!(p.slice(2.0, 6.0), vec![[2.0, 0.0], [4.0, 0.0], [4.0, 2.0]]);
    }

    #[test]
    fn projection_stays_in_its_window() {
        // A U: two parallel legs 1 m apart. A point between them projects to the leg its window allows.
        let u = Path::new(vec![[0.0, 0.0], [5.0, 0.0], [5.0, 1.0], [0.0, 1.0]]).unwrap();
        let (q, d) = u.project([2.0, 0.4], 0.0, 4.0);
        assert!((q.s - 2.0).abs() < 1e-12 && (d - 0.4).abs() < 1e-12);
        let (q, d) = u.project([2.0, 0.4], 7.0, 11.0);
        assert!((q.s - 9.0).abs() < 1e-12 && (d - 0.6).abs() < 1e-12);
    }

    #[test]
    fn bad_paths_and_geometry_helpers() {
        assert!(Path::new(vec![[0.0, 0.0]]).unwrap_err().to_string().contains("at least 2"));
        assert!(Path::new(vec![[0.0, 0.0], [0.0, 0.0]]).unwrap_err().to_string().contains("same point"));
        assert!(segments_cross([0.0, -1.0], [0.0, 1.0], [-1.0, 0.0], [1.0, 0.0]));
        assert!(!segments_cross([0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 1.0]), "a shared end point is no crossing");
        assert!((segment_distance([0.0, 0.0], [1.0, 0.0], [2.0, 1.0], [3.0, 1.0]) - 2f64.sqrt()).abs() < 1e-12);
        assert!((wrap(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
    }
}
