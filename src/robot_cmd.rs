//! `topa robot`: import a published MJCF, solve a stand pose; prints what was made and what is left to choose.

use anyhow::{bail, Result};
use topa_robot::gains::GainRule;
use topa_robot::{ImportOptions, StandReport};

use crate::cli::RobotCmd;

pub(crate) fn run(cmd: RobotCmd) -> Result<()> {
    match cmd {
        RobotCmd::Import { model, name, robots_dir, kp_saturation, damping_ratio } => {
            if !(kp_saturation > 0.0 && damping_ratio >= 0.0) {
                bail!("--kp-saturation must be > 0 rad and --damping-ratio ≥ 0");
            }
            let gains = GainRule { saturation: kp_saturation, zeta: damping_ratio };
            let r = topa_robot::import(&ImportOptions { model, name, robots_dir, gains })?;
            println!("wrote {} and {}", r.spec.display(), r.mjcf.display());
            if !r.dropped_assets.is_empty() {
                println!(
                    "assets not beside the model (left out, with what shows them): {}",
                    r.dropped_assets.join(", ")
                );
            }
            println!("{:<24} {:>9} {:>8}  gains", "actuator", "kp", "kd");
            for (a, g) in &r.gains {
                println!("{a:<24} {:>9.2} {:>8.3}  {}", g.kp, g.kd, if g.kept { "the model's" } else { "suggested" });
            }
            match &r.stand {
                Some(s) => print_stand(s),
                None => {
                    println!(
                        "left to choose in {} (then run `topa robot stand {}`):",
                        r.spec.display(),
                        r.spec.display()
                    );
                    for l in &r.to_choose {
                        println!("  {l}");
                    }
                }
            }
            Ok(())
        }
        RobotCmd::Stand { spec } => {
            print_stand(&topa_robot::stand(&spec)?);
            Ok(())
        }
    }
}

fn print_stand(s: &StandReport) {
    println!(
        "stand keyframe: loops closed (passive joints moved up to {:.2e} rad), base lowered {:.4} m onto the floor",
        s.closure_change, s.lowered
    );
    println!(
        "largest joint sag standing on PD alone (base harness on): {}; with the feed-forward: {:.4} rad",
        if s.sag_without.is_finite() { format!("{:.4} rad", s.sag_without) } else { "it falls".to_string() },
        s.sag_with
    );
    println!(
        "without the base harness, on PD and feed-forward alone, it {}",
        if s.stands_alone { "stands" } else { "falls (its balance is the policy's)" }
    );
    for (a, t) in &s.feedforward {
        println!("  feedforward {a:<24} {t:>9.3} N·m");
    }
}
