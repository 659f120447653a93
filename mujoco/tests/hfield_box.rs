//! The vertex–face box–height-field collision inside MuJoCo: a model opts in per field, the others keep MuJoCo's
//! prisms, and a box comes to rest where it rests on a plane.

use std::sync::Arc;

use mujoco::{hfield_box, Data, Model};

/// A 0.18 × 0.09 × 0.03 m box (a sole) dropped on a 4 m field sampled every 5 cm, tilted by `slope` (rad) about y,
/// or on a plane; `user` selects the field's collision.
fn scene(ground: &str, user: u8, slope: f64) -> Arc<Model> {
    let floor = match ground {
        "plane" => r#"<geom type="plane" size="3 3 0.1" euler="0 SLOPE 0"/>"#.to_string(),
        _ => format!(r#"<geom type="hfield" hfield="f" user="{user}" euler="0 SLOPE 0"/>"#),
    }
    .replace("SLOPE", &format!("{}", slope.to_degrees()));
    let xml = format!(
        r#"<mujoco><compiler angle="degree"/><option timestep="0.002"/>
<size nuser_geom="1" nconmax="200" njmax="800"/>
<asset><hfield name="f" nrow="81" ncol="81" size="2 2 0.2 0.1"/></asset>
<worldbody>{floor}
<body name="sole" pos="0.013 -0.021 0.08"><freejoint/><geom type="box" size="0.09 0.045 0.015" mass="0.5" friction="1 0.005 0.0001"/></body>
</worldbody></mujoco>"#
    );
    let mut m = Model::from_xml_string(&xml, ".").unwrap();
    // Flat at 0.1 m in the field's frame: every sample at half the elevation range.
    m.hfield_data_mut().iter_mut().for_each(|h| *h = 0.5);
    Arc::new(m)
}

/// The box's rest position and the most contacts seen after 1.5 s.
fn settle(model: Arc<Model>) -> ([f64; 3], usize) {
    hfield_box::install();
    let mut d = Data::new(model).unwrap();
    let mut most = 0;
    for _ in 0..750 {
        d.step().unwrap();
        most = most.max(d.contacts().len());
    }
    ([d.qpos()[0], d.qpos()[1], d.qpos()[2]], most)
}

#[test]
fn a_box_rests_on_a_flat_field_as_on_a_plane_with_at_most_five_contacts() {
    let (plane, plane_n) = settle(scene("plane", 0, 0.0));
    let (prisms, prism_n) = settle(scene("hfield", 0, 0.0));
    let (ours, ours_n) = settle(scene("hfield", 1, 0.0));
    // The field's top is 0.1 m above the plane's level.
    let (plane_z, prisms_z, ours_z) = (plane[2] + 0.1, prisms[2], ours[2]);
    assert!((ours_z - plane_z).abs() < 5e-4, "rest height {ours_z:.5} vs plane {plane_z:.5}");
    assert!((prisms_z - plane_z).abs() < 5e-4, "MuJoCo's prisms {prisms_z:.5} vs plane {plane_z:.5}");
    assert!((ours[0] - plane[0]).abs() < 1e-3 && (ours[1] - plane[1]).abs() < 1e-3, "{ours:?} vs {plane:?}");
    assert_eq!(plane_n, 4);
    assert!(ours_n <= hfield_box::MAX_CONTACTS, "{ours_n} contacts");
    // A model that does not opt in keeps MuJoCo's prisms: one contact per prism under the box.
    assert!(prism_n > hfield_box::MAX_CONTACTS, "MuJoCo's prisms gave {prism_n} contacts");
}

#[test]
fn a_box_holds_on_a_slope_within_its_friction_and_slides_beyond_it() {
    // tan 20° = 0.36 < μ = 1 holds; tan 50° = 1.19 > 1 slides.
    for (deg, holds) in [(20.0f64, true), (50.0, false)] {
        let (p, _) = settle(scene("hfield", 1, deg.to_radians()));
        let moved = (p[0] - 0.013).hypot(p[1] + 0.021);
        assert_eq!(moved < 0.05, holds, "{deg}°: moved {moved:.3} m");
    }
}
