//! `scripts/train_seeds.sh`, the driver that trains a preset's shipped seeds, run against a stand-in for
//! `topa train` (a shell script that writes what the driver reads: checkpoints, their sidecars, an exported policy)
//! so that its scheduling is checked in seconds: lanes side by side, a C+A waiting for the C of its seed in another
//! lane, a finished run resumed rather than restarted, and each kind of bad input stopping it with one error.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/train_seeds.sh");
const CONFIG: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/configs/cpu.toml");
const TERRAIN: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/configs/terrain.toml");
const SCAN: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/configs/terrain-scan.toml");

/// Stands in for `topa train`: logs "start RUN" / "end RUN" (for a fork also the run and iteration it forks from,
/// and every run's arguments) to $STUB_LOG, sleeps $STUB_S_<group> seconds (the run's name less its seed, `-` as
/// `_`: STUB_S_C_terrain for C-terrain-s2), fails for a run named in $STUB_FAIL,
/// and writes a finished run's checkpoint sidecar (iteration = `run.iterations` = 10) and policy.json. As
/// `topa config show FILE` it prints the file.
const STUB: &str = r#"#!/usr/bin/env bash
set -eu
if [ "$1" = config ]; then cat "$3"; exit 0; fi
all="$*"
out="" resume="" init="" adv=0 threads=""
while [ $# -gt 0 ]; do
    case "$1" in
        --out) out=$2; shift ;;
        --resume) resume=$2; shift ;;
        --init-from) init=$2; shift ;;
        --threads) threads=$2; shift ;;
        --adversary) adv=1 ;;
    esac
    shift
done
[ -n "$resume" ] && out=$resume
name=$(basename "$out")
echo "start $name threads=$threads resume=$([ -n "$resume" ] && echo 1 || echo 0)" >>"$STUB_LOG"
echo "args $name $all" >>"$STUB_LOG"
if [ -n "$init" ]; then
    it=$(sed -n 's/.*"iteration": \([0-9]*\).*/\1/p' "$init/checkpoints/latest.json")
    echo "fork $name from $(basename "$init") at $it" >>"$STUB_LOG"
fi
group=${name%-s*}
group=${group//-/_}
sleep "$(eval echo "\${STUB_S_$group:-0.2}")"
case " ${STUB_FAIL:-} " in *" $name "*) echo "stub: $name diverged" >&2; exit 1 ;; esac
mkdir -p "$out/checkpoints"
printf '{"iteration": 10, "config": {"run": {"iterations": 10}}}\n' >"$out/checkpoints/ckpt_0000010.json"
printf '{\n  "sidecar": "ckpt_0000010.json",\n  "iteration": 10\n}\n' >"$out/checkpoints/latest.json"
echo '{}' >"$out/policy.json"
echo "end $name" >>"$STUB_LOG"
"#;

struct Bed {
    dir: PathBuf,
}

impl Bed {
    fn new(tag: &str) -> Bed {
        let dir = std::env::temp_dir().join(format!("topa-train-seeds-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let stub = dir.join("topa");
        std::fs::write(&stub, STUB).unwrap();
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&stub, std::fs::Permissions::from_mode(0o755)).unwrap();
        Bed { dir }
    }

    fn runs(&self) -> PathBuf {
        self.dir.join("runs")
    }

    fn driver(&self, lanes: usize, runs: &[&str]) -> Command {
        // A driver that waits for ever (a lane not stopped) fails the test through the timeout's status, 124.
        let mut c = Command::new("timeout");
        c.args(["60", "bash", SCRIPT]).arg(CONFIG).arg(self.runs()).args(runs);
        c.env("TOPA", self.dir.join("topa"))
            .env("LANES", lanes.to_string())
            .env("STUB_LOG", self.dir.join("events"))
            .env("TRAIN_SEEDS_POLL_S", "0.05")
            .env_remove("THREADS");
        c
    }

    fn events(&self) -> Vec<String> {
        std::fs::read_to_string(self.dir.join("events")).unwrap_or_default().lines().map(str::to_owned).collect()
    }

    fn at(&self, event: &str) -> usize {
        let ev = self.events();
        ev.iter().position(|e| e.starts_with(event)).unwrap_or_else(|| panic!("no `{event}` in {ev:#?}"))
    }
}

impl Drop for Bed {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

fn text(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).to_string() + &String::from_utf8_lossy(&o.stdout)
}

fn finished(runs: &Path, name: &str) -> bool {
    runs.join(name).join("checkpoints/latest.json").is_file() && runs.join(name).join("policy.json").is_file()
}

#[test]
fn two_lanes_train_side_by_side_and_a_c_plus_a_waits_for_its_c_in_the_other_lane() {
    let bed = Bed::new("lanes");
    // Dealt out in turn: lane 1 gets O1 and CA1, lane 2 gets C1 and O2; C1 takes longest, so CA1 must wait.
    let mut c = bed.driver(2, &["O1", "C1", "CA1", "O2"]);
    // Seconds, not milliseconds: a loaded machine may take a while to start the second lane.
    c.env("STUB_S_C", "2.0").env("STUB_S_O", "1.0");
    let o = c.output().unwrap();
    assert!(o.status.success(), "{}", text(&o));
    for run in ["O-s1", "C-s1", "CA-s1", "O-s2"] {
        assert!(finished(&bed.runs(), run), "{run} not trained:\n{}", text(&o));
    }
    // Side by side: the second lane's first run starts before the first lane's first run ends.
    assert!(bed.at("start C-s1") < bed.at("end O-s1"), "{:#?}", bed.events());
    // The fork comes after its C finished, from the C's last iteration, and said that it waited.
    assert!(bed.at("end C-s1") < bed.at("start CA-s1"), "{:#?}", bed.events());
    assert!(bed.events().contains(&"fork CA-s1 from C-s1 at 10".to_owned()));
    assert!(text(&o).contains("CA1: waiting for"), "{}", text(&o));
    // Each lane gets its share of the cores (at least one thread).
    let cores = std::thread::available_parallelism().unwrap().get();
    let want = format!("threads={}", (cores / 2).max(1));
    assert!(bed.events().iter().filter(|e| e.starts_with("start")).all(|e| e.contains(&want)), "{:#?}", bed.events());
}

#[test]
fn a_repeated_call_resumes_what_has_checkpoints_and_trains_the_rest() {
    let bed = Bed::new("resume");
    let o = bed.driver(1, &["C2"]).output().unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let o = bed.driver(1, &["C2", "O3"]).output().unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let ev = bed.events();
    assert_eq!(ev.iter().filter(|e| e.starts_with("start C-s2")).count(), 2, "{ev:#?}");
    assert!(ev.iter().any(|e| e.starts_with("start C-s2") && e.ends_with("resume=1")), "{ev:#?}");
    assert!(ev.iter().any(|e| e.starts_with("start O-s3") && e.ends_with("resume=0")), "{ev:#?}");
}

#[test]
fn a_c_plus_a_without_a_finished_c_is_refused_outside_lanes() {
    let bed = Bed::new("noc");
    let o = bed.driver(1, &["CA4"]).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("CA4 needs a finished") && text(&o).contains("run C4"), "{}", text(&o));
    // A C still training (a checkpoint short of its length) is not finished either.
    let ck = bed.runs().join("C-s4/checkpoints");
    std::fs::create_dir_all(&ck).unwrap();
    std::fs::write(ck.join("ckpt_0000005.json"), r#"{"iteration": 5, "config": {"run": {"iterations": 10}}}"#).unwrap();
    std::fs::write(ck.join("latest.json"), r#"{"sidecar": "ckpt_0000005.json", "iteration": 5}"#).unwrap();
    let o = bed.driver(1, &["CA4"]).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(bed.events().is_empty(), "{:#?}", bed.events());
}

#[test]
fn a_failing_lane_stops_the_call_and_the_lane_waiting_on_it() {
    let bed = Bed::new("fail");
    // Lane 1: C5 (fails); lane 2: CA5, which would otherwise wait for C5 for ever.
    let mut c = bed.driver(2, &["C5", "CA5"]);
    c.env("STUB_FAIL", "C-s5");
    let o = c.output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("a lane failed"), "{}", text(&o));
    assert!(!bed.events().iter().any(|e| e.starts_with("start CA-s5")), "{:#?}", bed.events());
}

#[test]
fn bad_arguments_are_one_error_each_before_anything_trains() {
    let bed = Bed::new("bad");
    for (runs, lanes, says) in [
        (&["C1", "X2"][..], "1", "X2: not a group of seeds"),
        (&["C"][..], "1", "C: no seed number"),
        (&["C1"][..], "two", "LANES=two"),
    ] {
        let mut c = bed.driver(1, runs);
        c.env("LANES", lanes);
        let o = c.output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(text(&o).contains(says), "{says}: {}", text(&o));
    }
    // A terrain run whose preset is missing is refused up front too, not when its turn comes (the blind control
    // reads both terrain presets).
    for run in ["C-terrain1", "C-terrain-blind1"] {
        let mut c = bed.driver(1, &["C1", run]);
        c.env("TERRAIN_CONFIG", bed.dir.join("none.toml"));
        let o = c.output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(
            text(&o).contains(&format!("{run}: ")) && text(&o).contains("none.toml: no such preset"),
            "{}",
            text(&o)
        );
    }
    let o = Command::new("bash").arg(SCRIPT).arg("configs/none.toml").arg(bed.runs()).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("configs/none.toml: no such preset"), "{}", text(&o));
    assert!(bed.events().is_empty(), "{:#?}", bed.events());
}

#[test]
fn terrain_runs_fork_from_their_flat_run_and_the_blind_control_gets_the_scan_runs_length() {
    let bed = Bed::new("terrain");
    // Dealt out in turn, lane 1: C2, C3, CA-terrain2; lane 2: C-terrain2, C-terrain3, C-terrain-blind3 — each lane
    // waits for a run of the other.
    let runs = ["C2", "C-terrain2", "C3", "C-terrain3", "CA-terrain2", "C-terrain-blind3"];
    let mut c = bed.driver(2, &runs);
    // C-terrain2 ends 2 s after lane 1 reaches CA-terrain2 (at 4 s against 2 s), so that lane waits whatever
    // the machine's load; with equal lengths the two would tie and the wait could be skipped.
    c.env("STUB_S_C", "1.0").env("STUB_S_C_terrain", "3.0");
    let o = c.output().unwrap();
    assert!(o.status.success(), "{}", text(&o));
    for run in ["C-s2", "C-s3", "C-terrain-s2", "C-terrain-s3", "CA-terrain-s2", "C-terrain-blind-s3"] {
        assert!(finished(&bed.runs(), run), "{run} not trained:\n{}", text(&o));
    }
    let ev = bed.events();
    let args = |run: &str| ev.iter().find(|e| e.starts_with(&format!("args {run} "))).cloned().unwrap_or_default();
    // Each terrain run starts from its flat (or terrain) run's last checkpoint, on the terrain preset.
    assert!(ev.contains(&"fork C-terrain-s2 from C-s2 at 10".to_owned()), "{ev:#?}");
    assert!(ev.contains(&"fork CA-terrain-s2 from C-terrain-s2 at 10".to_owned()), "{ev:#?}");
    assert!(ev.contains(&"fork C-terrain-blind-s3 from C-terrain-s3 at 10".to_owned()), "{ev:#?}");
    assert!(args("C-terrain-s2").contains(&format!("--config {TERRAIN}")), "{ev:#?}");
    assert!(args("CA-terrain-s2").contains("--adversary"), "{ev:#?}");
    // The blind control runs as many iterations as the scan preset's run.
    let scan: toml::Value = toml::from_str(&std::fs::read_to_string(SCAN).unwrap()).unwrap();
    let n = scan["run"]["iterations"].as_integer().unwrap();
    assert!(args("C-terrain-blind-s3").contains(&format!("--config {TERRAIN} --iterations {n} ")), "{ev:#?}");
    // A run waits for the one it forks from when the other lane trains it.
    assert!(bed.at("end C-s2") < bed.at("start C-terrain-s2"), "{ev:#?}");
    assert!(bed.at("end C-terrain-s2") < bed.at("start CA-terrain-s2"), "{ev:#?}");
    assert!(
        text(&o).contains("C-terrain2: waiting for") && text(&o).contains("CA-terrain2: waiting for"),
        "{}",
        text(&o)
    );
}
