//! TensorBoard after an interruption: a run killed between checkpoints and resumed shows every step once, with
//! the values of a run that never stopped — read back by our own TFRecord parser (length and data CRC-32C checked),
//! independent of the writer crate's reader.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

mod common;

/// TFRecord's masked CRC-32C (Castagnoli).
fn masked_crc(data: &[u8]) -> u32 {
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI).checksum(data);
    crc.rotate_right(15).wrapping_add(0xa282_ead8)
}

/// Protobuf fields of one message: (field number, wire type, varint value or bytes).
fn fields(mut b: &[u8]) -> Vec<(u64, u8, u64, &[u8])> {
    fn varint(b: &mut &[u8]) -> u64 {
        let (mut v, mut shift) = (0u64, 0);
        loop {
            let byte = b[0];
            *b = &b[1..];
            v |= u64::from(byte & 0x7f) << shift;
            if byte < 0x80 {
                return v;
            }
            shift += 7;
        }
    }
    let mut out = Vec::new();
    while !b.is_empty() {
        let key = varint(&mut b);
        let (field, wire) = (key >> 3, (key & 7) as u8);
        let (n, bytes): (u64, &[u8]) = match wire {
            0 => (varint(&mut b), &[]),
            1 => {
                let (x, rest) = b.split_at(8);
                b = rest;
                (0, x)
            }
            2 => {
                let len = varint(&mut b) as usize;
                let (x, rest) = b.split_at(len);
                b = rest;
                (0, x)
            }
            5 => {
                let (x, rest) = b.split_at(4);
                b = rest;
                (0, x)
            }
            w => panic!("unexpected wire type {w}"),
        };
        out.push((field, wire, n, bytes));
    }
    out
}

/// An `Event`'s step and its scalar values (tensorflow/core/util/event.proto: step = 2, summary = 5;
/// Summary.value = 1; Value.tag = 1, Value.simple_value = 2).
fn event_scalars(data: &[u8]) -> (i64, Vec<(String, f32)>) {
    let mut step = 0;
    let mut values = Vec::new();
    for (field, _, n, bytes) in fields(data) {
        match field {
            2 => step = n as i64,
            5 => {
                for (_, _, _, value) in fields(bytes).into_iter().filter(|f| f.0 == 1) {
                    let mut tag = String::new();
                    let mut x = None;
                    for (f, _, _, b) in fields(value) {
                        match f {
                            1 => tag = String::from_utf8(b.to_vec()).unwrap(),
                            2 => x = Some(f32::from_le_bytes(b.try_into().unwrap())),
                            _ => {}
                        }
                    }
                    values.extend(x.map(|x| (tag, x)));
                }
            }
            _ => {}
        }
    }
    (step, values)
}

/// Every scalar in the event files of `tb/`, in TensorBoard's file order, as (tag, step) → values seen.
fn scalars(tb: &Path) -> BTreeMap<(String, i64), Vec<f32>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(tb).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    let mut out: BTreeMap<(String, i64), Vec<f32>> = BTreeMap::new();
    for f in files {
        let bytes = std::fs::read(&f).unwrap();
        let mut at = 0;
        while at < bytes.len() {
            let len_bytes = &bytes[at..at + 8];
            let len = u64::from_le_bytes(len_bytes.try_into().unwrap()) as usize;
            let len_crc = u32::from_le_bytes(bytes[at + 8..at + 12].try_into().unwrap());
            assert_eq!(len_crc, masked_crc(len_bytes), "{}: length CRC at byte {at}", f.display());
            let data = &bytes[at + 12..at + 12 + len];
            let data_crc = u32::from_le_bytes(bytes[at + 12 + len..at + 16 + len].try_into().unwrap());
            assert_eq!(data_crc, masked_crc(data), "{}: data CRC at byte {at}", f.display());
            at += 16 + len;
            let (step, values) = event_scalars(data);
            for (tag, x) in values {
                out.entry((tag, step)).or_default().push(x);
            }
        }
    }
    out
}

fn train(config: &Path, out: &Path, resume: bool, iterations: Option<usize>) {
    common::cli_train((!resume).then_some(config), out, resume, iterations);
}

#[test]
fn a_killed_and_resumed_run_shows_each_step_once_with_the_straight_values() {
    let dir = std::env::temp_dir().join(format!("topa-tensorboard-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let config = dir.join("cartpole.toml");
    std::fs::write(&config, format!("{}{}", common::KEEP_ALL_RUN, common::TINY_CARTPOLE)).unwrap();

    let straight = dir.join("straight");
    train(&config, &straight, false, Some(20));

    // The interrupted run: 12 iterations written, but killed before the checkpoint at 12 was on disk — the last
    // checkpoint is iteration 10, so iterations 11 and 12 are redone on resume.
    let killed = dir.join("killed");
    train(&config, &killed, false, None);
    let ck = killed.join("checkpoints");
    for e in std::fs::read_dir(&ck).unwrap() {
        let p = e.unwrap().path();
        if p.file_name().unwrap().to_string_lossy().starts_with("ckpt_0000012") {
            std::fs::remove_file(p).unwrap();
        }
    }
    std::fs::write(ck.join("latest.json"), r#"{"sidecar": "ckpt_0000010.json", "iteration": 10}"#).unwrap();
    let before = scalars(&killed.join("tb"));
    assert!(before.keys().any(|(_, s)| *s == 12), "the killed run had logged iteration 12");
    train(&config, &killed, true, Some(20));

    let (a, b) = (scalars(&straight.join("tb")), scalars(&killed.join("tb")));
    let twice: Vec<_> = b.iter().filter(|(_, v)| v.len() != 1).map(|(k, v)| (k, v.len())).collect();
    assert!(twice.is_empty(), "steps seen more than once: {twice:?}");
    let steps: std::collections::BTreeSet<i64> = b.keys().map(|(_, s)| *s).collect();
    assert_eq!(steps, (1..=20).collect(), "every iteration once");
    // Timing scalars differ between runs; everything the learning produced is identical.
    let learned = |m: &BTreeMap<(String, i64), Vec<f32>>| -> BTreeMap<(String, i64), Vec<f32>> {
        m.iter().filter(|((t, _), _)| !t.starts_with("perf/")).map(|(k, v)| (k.clone(), v.clone())).collect()
    };
    assert_eq!(learned(&a), learned(&b), "the resumed run's curves are the straight run's");
    std::fs::remove_dir_all(dir).ok();
}
