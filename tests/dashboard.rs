//! The training dashboard of a real 20-iteration TopA run: a panel for every reward term of the table, lines that
//! stay inside their axes even through a spike of 10⁶, and tick labels that never repeat.

use std::path::{Path, PathBuf};

use topa_train::dashboard::{self, Group, Run};

mod common;

const CONFIG: &str = r#"
base = "CPU"
[run]
num_envs = 16
steps_per_env = 24
iterations = 20
threads = 1
checkpoint_every = 10
[network]
actor_hidden = [16]
critic_hidden = [16]
"#;

fn short_run(dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let cpu = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/cpu.toml");
    let config = dir.join("short.toml");
    std::fs::write(&config, CONFIG.replace("CPU", &cpu.display().to_string())).unwrap();
    let out = dir.join("run");
    common::cli_train(Some(&config), &out, false, None);
    out
}

/// Rewrites one cell of metrics.csv.
fn spike(csv: &Path, column: &str, iteration: usize, value: f64) {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let c = lines[0].split(',').position(|h| h == column).unwrap();
    let mut cells: Vec<String> = lines[iteration].split(',').map(str::to_string).collect();
    cells[c] = value.to_string();
    lines[iteration] = cells.join(",");
    std::fs::write(csv, lines.join("\n") + "\n").unwrap();
}

/// A line's blue, or the blue of its faint or banded forms (blue well above red and green); axes, text and the
/// phase shading are grey.
fn is_line(p: &image::Rgb<u8>) -> bool {
    p[2] as i32 > p[0] as i32 + 30 && p[2] as i32 > p[1] as i32 + 10
}

#[test]
fn a_twenty_iteration_run_draws_every_term_inside_its_axes_with_distinct_ticks() {
    let dir = std::env::temp_dir().join(format!("topa-dashboard-{}", std::process::id()));
    let out = short_run(&dir);
    let csv = out.join("metrics.csv");
    spike(&csv, "policy_value_loss", 10, 1e6);
    spike(&csv, "mean_return", 12, -1e6);
    // Beyond the scale but not astronomically: the line would cross the caption if it were not clipped.
    let entropy = Run::load(&out).unwrap().columns["policy_entropy"].clone();
    spike(&csv, "policy_entropy", 15, entropy[14] + 50.0);
    let png = dir.join("dashboard.png");
    let run = Run::load(&out).unwrap();
    let group = Group { name: "C".into(), runs: vec![run.clone()] };
    let layout = dashboard::render(std::slice::from_ref(&group), &png).unwrap();
    assert!(png.with_extension("svg").exists(), "an SVG beside the PNG");

    // Every reward term of the table has its panel.
    let titles: Vec<&str> = layout.iter().map(|(t, _)| t.as_str()).collect();
    for term in topa_env::rewards::TERM_NAMES {
        assert!(titles.contains(&format!("reward: {term}").as_str()), "no panel for {term}: {titles:?}");
    }
    for t in ["mean episode return", "value loss", "KL (line: target)", "learning rate", "entropy", "samples/s"] {
        assert!(titles.contains(&t), "no panel {t}");
    }

    // No line pixel outside the plotting areas (the header's colour key aside).
    let img = image::open(&png).unwrap().to_rgb8();
    let (w, h) = img.dimensions();
    let inside = |x: i32, y: i32| {
        layout.iter().any(|(_, [x0, y0, x1, y1])| x >= x0 - 1 && x <= x1 + 1 && y >= y0 - 1 && y <= y1 + 1)
    };
    let mut outside = Vec::new();
    for y in 60..h as i32 {
        for x in 0..w as i32 {
            if is_line(img.get_pixel(x as u32, y as u32)) && !inside(x, y) {
                outside.push((x, y));
            }
        }
    }
    assert!(
        outside.is_empty(),
        "{} line pixels outside the axes, e.g. {:?}",
        outside.len(),
        &outside[..outside.len().min(5)]
    );
    // Off-scale stretches are cut at the edge, not drawn along it (plotters alone would clamp them there: a flat
    // bold line on the border that reads as data).
    let bold = image::Rgb([31u8, 119, 180]);
    for (title, [x0, y0, x1, y1]) in &layout {
        for y in [*y0, *y0 + 1, *y1 - 1, *y1] {
            let n = (*x0..=*x1).filter(|&x| img.get_pixel(x as u32, y as u32) == &bold).count();
            assert!(n < 40, "{title}: {n} bold pixels along the border row {y}");
        }
    }

    // The spiked panels keep a readable scale: the bulk of the values spans most of the axis.
    let values = run.columns["policy_value_loss"].clone();
    let r = dashboard::robust_range(&values, None);
    assert!(r.end < 1e5, "the spike is clipped, not scaled to: {r:?}");

    // Tick labels are distinct at every scale, the old repeating case (−6 … −4) included.
    for r in [-6.2..-3.9, 0.0..1e-4, 0.00990..0.01001, -1e6..2e6, 0.0..20.0, 9.98e6..1.0e7, r] {
        let labels = dashboard::tick_labels(&r);
        let mut unique = labels.clone();
        unique.dedup();
        assert_eq!(unique, labels, "repeated tick labels on {r:?}");
        assert!(labels.len() >= 2, "{r:?}: {labels:?}");
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn seeds_of_a_group_share_a_band_and_bad_input_is_named() {
    let dir = std::env::temp_dir().join(format!("topa-plot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let err = dashboard::plot(&[], &["C".into()], &dir.join("x.png")).unwrap_err().to_string();
    assert!(err.contains("NAME=RUN"), "{err}");
    let err = dashboard::plot(&[dir.join("nothing")], &[], &dir.join("x.png")).unwrap_err().to_string();
    assert!(err.contains("metrics.csv"), "{err}");
    // EMA as TensorBoard computes it: debiased, so the first value is the first sample.
    let e = dashboard::ema(&[2.0, f64::NAN, 4.0], 0.6);
    assert_eq!(e[0], 2.0);
    assert!(e[1].is_nan());
    assert!((e[2] - (0.6 * 0.4 * 2.0 + 0.4 * 4.0) / (1.0 - 0.36)).abs() < 1e-12);
    std::fs::remove_dir_all(dir).ok();
}
