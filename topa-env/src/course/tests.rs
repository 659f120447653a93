use super::*;

const INDOOR: &str = include_str!("../../../assets/courses/indoor.toml");

fn with(extra: &str) -> crate::error::Result<Course> {
    Course::parse(&format!("{INDOOR}\n{extra}"))
}

#[test]
fn the_indoor_course_is_about_100_m_with_its_elements() {
    let c = Course::parse(INDOOR).unwrap();
    assert!((c.path.length() - 100.0).abs() < 1e-9, "{}", c.path.length());
    // Two corridors of 2 sides (mitred: 2 walls a side around the 90° corner, 3 around the U-turn's two corners)
    // and 2 door frames of 2 posts.
    assert_eq!(c.walls.len(), 2 * 2 + 2 * 3 + 2 * 2);
    assert_eq!(c.material_at([5.0, 0.0]), Some("tiles"));
    assert_eq!(c.material_at([20.0, 8.0]), Some("wood"));
    assert_eq!(c.material_at([100.0, 100.0]), None);
    // In a corridor the walls are half_width − thickness/2 from the path.
    assert!((c.wall_clearance([30.0, 15.0]) - 0.36).abs() < 1e-9, "{}", c.wall_clearance([30.0, 15.0]));
}

#[test]
fn a_path_that_leaves_its_floor_is_named_with_where() {
    let text = INDOOR.replace("[30.0, 40.0],", "[30.0, 45.0],");
    let err = Course::parse(&text).unwrap_err().to_string();
    assert!(err.contains("leaves its floor") && err.contains("(30.00, 41.5"), "{err}");
}

#[test]
fn overlapping_walls_and_walls_on_the_path_are_named() {
    let err = with("[[wall]]\nfrom = [5.0, 1.0]\nto = [5.0, 3.0]\n[[wall]]\nfrom = [4.0, 2.0]\nto = [6.0, 2.0]")
        .unwrap_err()
        .to_string();
    assert!(err.contains("wall 0") && err.contains("wall 1") && err.contains("overlap"), "{err}");
    let err = with("[[wall]]\nfrom = [5.0, -1.0]\nto = [5.0, 1.0]").unwrap_err().to_string();
    assert!(err.contains("wall 0") && err.contains("from the path"), "{err}");
    // A door frame inside a corridor collides with its walls.
    let err = with("[[door]]\nat_m = 45.0\nclear_width = 0.8").unwrap_err().to_string();
    assert!(err.contains("overlap"), "{err}");
}

#[test]
fn wrong_keys_and_values_are_named() {
    assert!(with("[[threshold]]\nat_m = 5.0\nheight = 0.2").unwrap_err().to_string().contains("not a threshold"));
    assert!(with("[[threshold]]\nat_m = 500.0\nheight = 0.01").unwrap_err().to_string().contains("100.0 m long"));
    assert!(with("[[floor]]\nmaterial = \"ice\"\nmin = [0, 0]\nmax = [1, 1]")
        .unwrap_err()
        .to_string()
        .contains("no material 'ice'"));
    let err = with("[[threshold]]\nat_m = 5.0\nheigth = 0.01").unwrap_err().to_string();
    assert!(err.contains("heigth"), "{err}");
    let err = Course::load(std::path::Path::new("no/such/course.toml")).unwrap_err().to_string();
    assert!(err.contains("no/such/course.toml") && err.contains("assets/courses"), "{err}");
}

#[test]
fn the_course_compiles_with_the_robot_and_its_feet_get_the_material_friction() {
    let spec = crate::spec::RobotSpec::load(&crate::assets::resolve_path("assets/robots/topa_closed.toml")).unwrap().0;
    let c = Course::parse(INDOOR).unwrap();
    let (m, map) = c.compile(&spec).unwrap();
    let floor = m.id(mujoco::ObjType::Geom, &spec.floor_geom).unwrap();
    assert_eq!(m.geom_friction()[floor][0], crate::world::MAPPED_FLOOR_FRICTION);
    assert_eq!(m.geom_conaffinity()[floor], 1, "the robot's floor stays the ground");
    assert_eq!((map.at([5.0, 0.0]), map.at([20.0, 8.0])), (0.45, 0.65));
    let patch = m.id(mujoco::ObjType::Geom, "course_floor0").unwrap();
    assert_eq!(m.geom_conaffinity()[patch], 0, "patches are drawn, the map carries their friction");
    let walls = m.names(mujoco::ObjType::Geom).iter().filter(|n| n.starts_with(WALL_PREFIX)).count();
    assert_eq!(walls, c.walls.len());
}

#[test]
fn a_robot_pushed_into_a_wall_touches_it_and_the_wall_counts_as_ground() {
    // The walls live in static bodies of their own (mjcf.rs): they must still collide and still be ground.
    let spec = crate::spec::RobotSpec::load(&crate::assets::resolve_path("assets/robots/topa_closed.toml")).unwrap().0;
    let c = Course::parse(INDOOR).unwrap();
    let (m, _) = c.compile(&spec).unwrap();
    let wall = m.id(mujoco::ObjType::Geom, &format!("{WALL_PREFIX}0")).unwrap();
    assert_ne!(m.geom_bodyid()[wall], 0, "a wall has a body of its own");
    assert!(crate::world::is_ground(&m, wall));
    let free = (0..m.njnt()).find(|&j| m.jnt_type(j) == mujoco::JointType::Free).unwrap();
    let adr = m.jnt_qposadr()[free] as usize;
    let w = &c.walls[0];
    let mut d = mujoco::Data::new(m.clone()).unwrap();
    d.qpos_mut()[adr..adr + 3].copy_from_slice(&[(w.from[0] + w.to[0]) / 2.0, (w.from[1] + w.to[1]) / 2.0, 0.4]);
    d.forward().unwrap();
    let touches = |d: &mujoco::Data| d.contacts().iter().any(|k| k.geom1 as usize == wall || k.geom2 as usize == wall);
    assert!(touches(&d), "a robot inside a wall must touch it");
    d.qpos_mut()[adr + 1] += 3.0;
    d.forward().unwrap();
    assert!(!touches(&d), "3 m away it must not");
}
