//! Prints the stand keyframe of a robot with closed loops: the spec's nominal kinematic-joint angles, the motor
//! positions that reach them and every passive joint of the loops, solved by the linkage (how the crank and rod
//! angles of assets/mjcf/kestrel.xml's keyframe were made). Usage: cargo run --example solve_stand -- SPEC.toml

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).ok_or("usage: solve_stand SPEC.toml")?;
    let (spec, model) = topa_env::spec::RobotSpec::load(std::path::Path::new(&path))?;
    let mut linkage = topa_env::linkage::Linkage::new(&spec, &model)?;
    let motors = linkage.motors(&spec.nominal_joints())?;
    let qpos = linkage.closed_qpos(&motors)?;
    let fmt = |v: &[f64]| v.iter().map(|x| format!("{x:.9}")).collect::<Vec<_>>().join(" ");
    println!("motors {}", fmt(&motors));
    println!("qpos {}", fmt(&qpos));
    Ok(())
}
