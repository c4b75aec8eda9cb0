//! A bounded mutation fuzzer over every loader (OBJ, PLY, glTF/GLB, Mitsuba XML, the scene file)
//! and the preset parser, run by the ordinary test command in seconds.
//!
//! Each seed in `tests/fuzz_seeds/` is mutated many times (bit flips, interesting bytes and number
//! tokens, deleted, duplicated and truncated ranges) with a fixed random sequence, so a failure is
//! reproducible. For every mutant: no panic; an error names the file; a scene that loads is valid.
//! `EPIVOX_FUZZ_ITERS=N` runs N mutants per seed instead of the default (e.g. 20000 for a long run);
//! failing inputs are kept in `target/fuzz-failures/`.

use epivox::preset::Preset;
use epivox::scene::load_scene;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, Once};
use std::time::{Duration, Instant};

/// xorshift64*: small, fast, and the same sequence everywhere.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
}

/// Values that reach the edges of parsers and of the parameter ranges.
const TOKENS: &[&str] = &[
    "-1",
    "0",
    "-0",
    "1e38",
    "-1e38",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "4294967295",
    "4294967296",
    "65535",
    "99999999999999999999",
    "0.5",
    "3",
    ",",
    " ",
    "\n",
    "\"",
    "[",
    "]",
    "{",
    "}",
    "<",
    ">",
    "/>",
    "#",
    "=",
    "%",
    "\u{1b}[31m",
];

const BYTES: &[u8] = b"\0\xff\x7f\x80-+.e9 \n\r\t[]{}<>\"'=,#/:%$";

fn mutate(rng: &mut Rng, seed: &[u8]) -> Vec<u8> {
    let mut d = seed.to_vec();
    for _ in 0..1 + rng.below(4) {
        let len = d.len();
        let at = rng.below(len + 1);
        match rng.below(8) {
            0 if len > 0 => d[at.min(len - 1)] ^= 1 << rng.below(8),
            1 if len > 0 => d[at.min(len - 1)] = BYTES[rng.below(BYTES.len())],
            2 => {
                let n = 1 + rng.below(16);
                d.drain(at..(at + n).min(len));
            }
            3 => {
                let n = 1 + rng.below(64);
                let copy: Vec<u8> = d[at..(at + n).min(len)].to_vec();
                d.splice(at..at, copy);
            }
            4 => {
                let t = TOKENS[rng.below(TOKENS.len())].as_bytes();
                d.splice(at..at, t.iter().copied());
            }
            5 => {
                // Replace the number under `at` (if any) by an interesting token.
                let is_num = |b: u8| b.is_ascii_digit() || b == b'.' || b == b'-';
                let mut s = at.min(len.saturating_sub(1));
                if len > 0 && is_num(d[s]) {
                    while s > 0 && is_num(d[s - 1]) {
                        s -= 1;
                    }
                    let mut e = s;
                    while e < len && is_num(d[e]) {
                        e += 1;
                    }
                    let t = TOKENS[rng.below(12)].as_bytes();
                    d.splice(s..e, t.iter().copied());
                }
            }
            6 => d.truncate(at),
            _ => {
                // Swap two ranges' worth of lines: reorders headers and elements.
                let b = rng.below(len + 1);
                let (lo, hi) = (at.min(b), at.max(b));
                d[lo..hi].reverse();
            }
        }
    }
    d
}

fn seeds_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_seeds")
}

fn iterations(default: usize) -> usize {
    std::env::var("EPIVOX_FUZZ_ITERS").ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic".into())
}

/// Panics anywhere in the process, counted by a panic hook: the loaders guard some third-party
/// parsers with `catch_unwind`, and a panic caught there is still a bug (its message reaches the
/// user's terminal).
static PANICS: AtomicUsize = AtomicUsize::new(0);

/// One fuzz test at a time, so that a panic is blamed on the right mutant.
static SERIAL: Mutex<()> = Mutex::new(());

fn count_panics() {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            PANICS.fetch_add(1, Ordering::SeqCst);
            previous(info);
        }));
    });
}

/// Mutates `seed` (a file in `tests/fuzz_seeds/`) `n` times in a folder holding all the seeds (so
/// references between them resolve) and runs `check` on each mutant. Returns the failures.
fn fuzz(seed: &str, n: usize, rng_seed: u64, check: impl Fn(&Path) -> Result<(), String>) -> Vec<String> {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    count_panics();
    let dir = tempfile::tempdir().unwrap();
    for entry in std::fs::read_dir(seeds_dir()).unwrap() {
        let p = entry.unwrap().path();
        std::fs::copy(&p, dir.path().join(p.file_name().unwrap())).unwrap();
    }
    let original = std::fs::read(seeds_dir().join(seed)).unwrap();
    let target = dir.path().join(seed);
    let mut rng = Rng(rng_seed);
    let mut failures = Vec::new();
    let mut slowest = Duration::ZERO;
    // The unmutated seed must load: otherwise the fuzzer only exercises the first error path.
    if let Err(e) = check(&target) {
        failures.push(format!("{seed} (unmutated): {e}"));
    }
    for i in 0..n {
        let data = mutate(&mut rng, &original);
        std::fs::write(&target, &data).unwrap();
        let t = Instant::now();
        let panics = PANICS.load(Ordering::SeqCst);
        let result = catch_unwind(AssertUnwindSafe(|| check(&target)));
        slowest = slowest.max(t.elapsed());
        let failure = match result {
            Err(p) => Some(format!("panicked: {}", panic_text(&*p))),
            Ok(_) if PANICS.load(Ordering::SeqCst) != panics => Some("panicked (the panic was caught inside)".into()),
            Ok(Ok(())) => None,
            Ok(Err(e)) => Some(e),
        };
        if let Some(why) = failure {
            let keep = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz-failures");
            let _ = std::fs::create_dir_all(&keep);
            let kept = keep.join(format!("{i}-{seed}"));
            let _ = std::fs::write(&kept, &data);
            failures.push(format!("{seed} mutant {i} (kept as {}): {why}", kept.display()));
        }
    }
    eprintln!("{seed}: {n} mutants, {} failures, slowest {:.0} ms", failures.len(), slowest.as_secs_f64() * 1e3);
    failures
}

/// A refusal passes when its message names the file.
fn names_the_file(name: &str, e: impl std::fmt::Display) -> Result<(), String> {
    let msg = e.to_string();
    if msg.contains(name) {
        Ok(())
    } else {
        Err(format!("the error does not name {name}: {msg}"))
    }
}

/// A scene either loads valid, or fails with a message naming the file.
fn scene_check(path: &Path) -> Result<(), String> {
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    match load_scene(path) {
        Ok(s) => s.validate().map_err(|e| format!("loaded an invalid scene: {e}")),
        Err(e) => names_the_file(&name, e),
    }
}

fn preset_check(path: &Path) -> Result<(), String> {
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    match Preset::load(path) {
        Ok(p) => {
            // A preset that loads can be written and read back.
            Preset::parse(&p.to_toml(), path).map(|_| ()).map_err(|e| format!("does not round-trip: {e}"))
        }
        Err(e) => names_the_file(&name, e),
    }
}

fn assert_none(failures: Vec<String>) {
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
}

#[test]
fn fuzz_obj() {
    assert_none(fuzz("tri.obj", iterations(400), 0x0b1, scene_check));
}

#[test]
fn fuzz_ply() {
    let mut f = fuzz("quad.ply", iterations(300), 0x91e, scene_check);
    f.extend(fuzz("binary.ply", iterations(300), 0x91f, scene_check));
    assert_none(f);
}

#[test]
fn fuzz_gltf() {
    let mut f = fuzz("scene.gltf", iterations(300), 0x617f, scene_check);
    f.extend(fuzz("scene.glb", iterations(300), 0x61b, scene_check));
    assert_none(f);
}

#[test]
fn fuzz_mitsuba() {
    assert_none(fuzz("scene.xml", iterations(300), 0x3175, scene_check));
}

#[test]
fn fuzz_scene_file() {
    assert_none(fuzz("room.scene.toml", iterations(400), 0x70e1, scene_check));
}

#[test]
fn fuzz_preset() {
    assert_none(fuzz("look.toml", iterations(600), 0x9e5e7, preset_check));
}

/// The harness itself: mutants differ from the seed and from each other, and the sequence is fixed.
#[test]
fn mutations_are_varied_and_reproducible() {
    let seed = std::fs::read(seeds_dir().join("room.scene.toml")).unwrap();
    let (mut a, mut b) = (Rng(7), Rng(7));
    let ma: Vec<Vec<u8>> = (0..50).map(|_| mutate(&mut a, &seed)).collect();
    let mb: Vec<Vec<u8>> = (0..50).map(|_| mutate(&mut b, &seed)).collect();
    assert_eq!(ma, mb);
    let distinct: std::collections::HashSet<&Vec<u8>> = ma.iter().collect();
    assert!(distinct.len() > 45, "only {} distinct mutants", distinct.len());
    assert!(ma.iter().filter(|m| **m != seed).count() > 45);
}
