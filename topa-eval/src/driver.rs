//! The operator of a course run, as a path follower: pure pursuit on a look-ahead point of the path turned into
//! the policy's (v_x, v_y, w_z) commands within the ranges it was trained on, at a chosen top speed, slowing for
//! turns and turning on the spot when the path doubles back. The look-ahead shortens in corridors (where the walls
//! are near), as a person steering through a narrow passage looks closer.

use topa_env::config::CommandConfig;
use topa_env::course::path::wrap;
use topa_env::course::Course;

/// How the operator drives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Driver {
    /// Forward speed on straight path, m/s.
    pub top_speed: f64,
    /// Look-ahead distance, m (shortened near walls).
    pub lookahead: f64,
    /// Largest yaw rate the operator commands, rad/s (the policy's range, capped at 1 rad/s).
    pub max_yaw_rate: f64,
    /// Largest sideways command, m/s.
    pub max_side_speed: f64,
    /// Heading error beyond which the operator stops and turns on the spot, rad.
    pub turn_in_place: f64,
}

impl Driver {
    /// A driver at `top_speed` within `ranges` (the policy's training command ranges); an error if the speed is
    /// not a forward command the policy was trained on.
    pub fn new(top_speed: f64, ranges: &CommandConfig) -> crate::error::Result<Driver> {
        let [_, vmax] = ranges.lin_vel_x;
        if !(top_speed > 0.0 && top_speed <= vmax + 1e-9) {
            crate::error::invalid!(
                "speed {top_speed} m/s is outside the policy's forward command range (0, {vmax}] m/s it was trained on"
            );
        }
        let yaw = ranges.ang_vel_z[1].min(-ranges.ang_vel_z[0]).min(1.0);
        let side = ranges.lin_vel_y[1].min(-ranges.lin_vel_y[0]).min(0.2);
        Ok(Driver { top_speed, lookahead: 0.8, max_yaw_rate: yaw, max_side_speed: side, turn_in_place: 1.0 })
    }

    /// The command for a robot at `xy` heading `yaw` whose progress along the path is `s`.
    pub fn command(&self, course: &Course, s: f64, xy: [f64; 2], yaw: f64) -> [f64; 3] {
        let clearance = course.wall_clearance(xy);
        let look = if clearance < 1.0 { self.lookahead * 0.6 } else { self.lookahead };
        let target = course.path.at(s + look);
        let (dx, dy) = (target.xy[0] - xy[0], target.xy[1] - xy[1]);
        let alpha = wrap(dy.atan2(dx) - yaw);
        // Slow for the turn ahead: the heading change over the next metre.
        let ahead = wrap(course.path.at(s + 1.0).heading - course.path.at(s).heading).abs();
        let v_turn = self.top_speed * (1.0 - 0.6 * (ahead / std::f64::consts::FRAC_PI_2).min(1.0));
        if alpha.abs() > self.turn_in_place {
            return [0.0, 0.0, self.max_yaw_rate * alpha.signum()];
        }
        let v = v_turn.min(self.top_speed * alpha.cos().max(0.0)).max(0.1_f64.min(self.top_speed));
        // Pure pursuit: the arc through the look-ahead point has curvature 2 sin α / L.
        let dist = dx.hypot(dy).max(1e-3);
        let w = (v * 2.0 * alpha.sin() / dist).clamp(-self.max_yaw_rate, self.max_yaw_rate);
        // Sideways correction towards the path (body frame), small.
        let near = course.path.project(xy, s - 0.5, s + 0.5).0;
        let (ex, ey) = (near.xy[0] - xy[0], near.xy[1] - xy[1]);
        let lateral = -yaw.sin() * ex + yaw.cos() * ey;
        let vy = (0.8 * lateral).clamp(-self.max_side_speed, self.max_side_speed);
        [v, vy, w]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn course() -> Course {
        Course::parse(include_str!("../../assets/courses/indoor.toml")).unwrap()
    }

    #[test]
    fn on_the_path_it_drives_straight_at_top_speed_and_steers_back_when_off() {
        let c = course();
        let d = Driver::new(0.5, &CommandConfig::default()).unwrap();
        let [v, vy, w] = d.command(&c, 5.0, [5.0, 0.0], 0.0);
        assert!((v - 0.5).abs() < 1e-9 && vy.abs() < 1e-9 && w.abs() < 1e-9, "{v} {vy} {w}");
        // Left of the path (y > 0): turn right and step right.
        let [_, vy, w] = d.command(&c, 5.0, [5.0, 0.2], 0.0);
        assert!(w < 0.0 && vy < 0.0, "{vy} {w}");
        // Facing back: stop and turn on the spot.
        let [v, _, w] = d.command(&c, 5.0, [5.0, 0.0], 3.0);
        assert!(v == 0.0 && w.abs() == d.max_yaw_rate, "{v} {w}");
    }

    #[test]
    fn it_slows_before_a_corner_and_refuses_speeds_the_policy_never_saw() {
        let c = course();
        let d = Driver::new(0.7, &CommandConfig::default()).unwrap();
        let straight = d.command(&c, 5.0, [5.0, 0.0], 0.0)[0];
        let corner = d.command(&c, 19.5, [19.5, 0.0], 0.0)[0];
        assert!(corner < 0.7 * straight, "{corner} vs {straight}");
        let err = Driver::new(0.9, &CommandConfig::default()).unwrap_err().to_string();
        assert!(err.contains("0.9") && err.contains("0.7"), "{err}");
        assert!(Driver::new(0.0, &CommandConfig::default()).is_err());
    }
}
