//! `topa compare`: a variant report made from the committed ablation by known changes (every push cell 2 s
//! longer, every tracking error doubled, noise unchanged) gets exactly those differences and the verdicts they
//! imply; reports that cannot be compared are refused with the file named.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

const BASELINE: &str = "docs/results/current/ablation.json";

fn topa(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_topa")).current_dir(env!("CARGO_MANIFEST_DIR")).args(args).output().unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("topa-compare-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn baseline() -> Value {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(BASELINE)).unwrap();
    serde_json::from_str(&text).unwrap()
}

/// The baseline with each policy renamed (other policies), changed by `f`.
fn variant(dir: &Path, f: impl Fn(&mut Value)) -> String {
    let mut v = baseline();
    for r in v["results"].as_array_mut().unwrap() {
        let p = format!("variant/{}", r["policy"].as_str().unwrap());
        r["policy"] = Value::String(p);
        f(r);
    }
    let file = dir.join("ablation.json");
    std::fs::write(&file, serde_json::to_string(&v).unwrap()).unwrap();
    file.display().to_string()
}

fn rows(out: &Path) -> Vec<Value> {
    let v: Value = serde_json::from_str(&std::fs::read_to_string(out.join("compare.json")).unwrap()).unwrap();
    v["rows"].as_array().unwrap().clone()
}

fn find<'a>(rows: &'a [Value], group: &str, measure: &str) -> &'a Value {
    rows.iter().find(|r| r["group"] == group && r["measure"].as_str().unwrap().starts_with(measure)).unwrap()
}

#[test]
fn known_changes_give_their_differences_and_verdicts() {
    let dir = scratch("known");
    let file = variant(&dir, |r| {
        for t in r["push"]["t_fall"].as_array_mut().unwrap() {
            *t = Value::from(t.as_f64().unwrap() + 2.0);
        }
        for row in r["tracking"].as_array_mut().unwrap() {
            for m in row["mae_whole"].as_array_mut().unwrap() {
                *m = Value::from(2.0 * m.as_f64().unwrap());
            }
        }
    });
    let out = dir.join("out");
    let run = topa(&["compare", "--baseline", BASELINE, "--variant", &file, "--out", out.to_str().unwrap()]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let rows = rows(&out);
    for g in ["O", "C", "CA"] {
        let push = find(&rows, g, "push: mean t_fall standing");
        assert!((push["difference"]["point"].as_f64().unwrap() - 2.0).abs() < 1e-9, "{push}");
        assert_eq!(push["verdict"], "better", "{push}");
        // A shift by a constant moves the interval of the variant by exactly that constant.
        let (b, v) = (&push["baseline"], &push["variant"]);
        assert!((v["point"].as_f64().unwrap() - b["point"].as_f64().unwrap() - 2.0).abs() < 1e-9);
        let walking = find(&rows, g, "push: mean t_fall walking");
        assert_eq!(walking["difference"]["point"].as_f64().unwrap(), 0.0);
        assert_eq!(walking["verdict"], "no_difference_resolved");
        let mae = find(&rows, g, "tracking: worst component MAE");
        let (b, d) = (mae["baseline"]["point"].as_f64().unwrap(), mae["difference"]["point"].as_f64().unwrap());
        assert!((d - b).abs() < 1e-9, "doubling adds the baseline's mean: {mae}");
        assert_eq!(mae["verdict"], "worse", "{mae}");
        // Lower is better for an error: the variant is never the better one of a pair.
        assert!(mae["p_variant_better"]["point"].as_f64().unwrap() < 0.5, "{mae}");
        let noise = find(&rows, g, "command noise level 1");
        assert_eq!(noise["difference"]["point"].as_f64().unwrap(), 0.0);
        assert_eq!(find(&rows, g, "gait at 0.5 m/s: air time")["verdict"], "not_judged");
    }
    let md = std::fs::read_to_string(out.join("compare.md")).unwrap();
    assert!(md.contains("| C | push: mean t_fall standing (s) | 5 / 5 |"), "{md}");
}

#[test]
fn fewer_than_five_seeds_decide_nothing_and_only_shared_groups_are_compared() {
    let dir = scratch("few");
    let mut v = baseline();
    let kept: Vec<Value> = v["results"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["name"] == "C")
        .take(2)
        .map(|r| {
            let mut r = r.clone();
            r["policy"] = Value::String(format!("variant/{}", r["policy"].as_str().unwrap()));
            for t in r["push"]["t_fall"].as_array_mut().unwrap() {
                *t = Value::from(t.as_f64().unwrap() + 5.0);
            }
            r
        })
        .collect();
    v["results"] = Value::Array(kept);
    let file = dir.join("ablation.json");
    std::fs::write(&file, serde_json::to_string(&v).unwrap()).unwrap();
    let out = dir.join("out");
    let run =
        topa(&["compare", "--baseline", BASELINE, "--variant", file.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let rows = rows(&out);
    assert!(rows.iter().all(|r| r["group"] == "C"), "O and C+A have no variant");
    let push = find(&rows, "C", "push: mean t_fall standing");
    assert_eq!(push["variant_seeds"], 2);
    assert_eq!(push["verdict"], "too_few_seeds", "{push}");
}

#[test]
fn reports_that_cannot_be_compared_are_refused_naming_the_file() {
    let dir = scratch("refused");
    let out = dir.join("out");
    let out = out.to_str().unwrap();
    let same = topa(&["compare", "--baseline", BASELINE, "--variant", BASELINE, "--out", out]);
    let err = String::from_utf8_lossy(&same.stderr);
    assert!(!same.status.success() && err.contains("in both reports"), "{err}");

    let mut v = baseline();
    v["extent"]["push_step_n"] = Value::from(10.0);
    for r in v["results"].as_array_mut().unwrap() {
        r["policy"] = Value::String(format!("variant/{}", r["policy"].as_str().unwrap()));
    }
    let file = dir.join("other_protocol.json");
    std::fs::write(&file, serde_json::to_string(&v).unwrap()).unwrap();
    let run = topa(&["compare", "--baseline", BASELINE, "--variant", file.to_str().unwrap(), "--out", out]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success() && err.contains("other_protocol.json") && err.contains("protocol"), "{err}");

    let junk = dir.join("junk.json");
    std::fs::write(&junk, "{\"not\": \"a report\"}").unwrap();
    let run = topa(&["compare", "--baseline", BASELINE, "--variant", junk.to_str().unwrap(), "--out", out]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success() && err.contains("junk.json") && err.contains("ablation.json"), "{err}");
}
