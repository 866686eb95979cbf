//! Seeded mutation fuzzing of every reader (issue 7): valid files of every
//! format, and the bundled real models, are bit-flipped, cut, spliced and
//! given huge counts and out-of-range numbers; each case must give an error
//! or a valid mesh, never a panic, and no single allocation may ask for more
//! than [`LIMIT`] bytes (the allocator below refuses it, which aborts the
//! test loudly). Stable Rust, no fuzzing engine: thousands of cases per
//! format in a few seconds.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;

use crate::{Format, Mesh};

/// Most bytes one allocation may ask for while fuzzing.
const LIMIT: usize = 256 << 20;

struct Limited;

// SAFETY: forwards to the system allocator; only refuses (null) requests
// over the limit, which the standard library turns into an abort, i.e. a
// failed test run.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Limited {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() > LIMIT {
            eprintln!(
                "fuzz: an allocation of {} bytes was asked for",
                layout.size()
            );
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's layout contract is passed on unchanged.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the pointer came from `alloc` above, i.e. from System.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > LIMIT {
            eprintln!("fuzz: a reallocation to {new_size} bytes was asked for");
            return std::ptr::null_mut();
        }
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Limited = Limited;

/// A seeded generator (xorshift).
pub(crate) struct Rng(u64);

impl Rng {
    pub(crate) fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1)
    }
    pub(crate) fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    pub(crate) fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Numbers that break readers: huge counts, negatives, NaN, overflow.
const POISON: [&str; 10] = [
    "18446744073709551615",
    "4294967295",
    "40000000000",
    "-1",
    "nan",
    "1e39",
    "1e300",
    "-0",
    "0",
    "2147483648",
];

/// One mutation of `bytes`, chosen by `rng`.
pub(crate) fn mutate(bytes: &[u8], rng: &mut Rng, others: &[&[u8]]) -> Vec<u8> {
    let mut b = bytes.to_vec();
    match rng.below(6) {
        // Flip a few bits.
        0 => {
            for _ in 0..1 + rng.below(4) {
                if !b.is_empty() {
                    let i = rng.below(b.len());
                    b[i] ^= 1 << rng.below(8);
                }
            }
        }
        // Cut.
        1 => b.truncate(rng.below(b.len() + 1)),
        // A number replaced by a poison one (text), or bytes set to 0xFF (binary).
        2 => {
            let starts: Vec<usize> = (0..b.len())
                .filter(|&i| b[i].is_ascii_digit() && (i == 0 || !b[i - 1].is_ascii_digit()))
                .collect();
            if starts.is_empty() {
                if b.len() >= 4 {
                    let i = rng.below(b.len() - 3);
                    b[i..i + 4].copy_from_slice(&[0xFF; 4]);
                }
            } else {
                let s = starts[rng.below(starts.len())];
                let e = (s..b.len())
                    .find(|&i| !b[i].is_ascii_digit() && b[i] != b'.')
                    .unwrap_or(b.len());
                let p = POISON[rng.below(POISON.len())].as_bytes();
                b.splice(s..e, p.iter().copied());
            }
        }
        // A slice duplicated.
        3 => {
            if !b.is_empty() {
                let s = rng.below(b.len());
                let e = (s + 1 + rng.below(64)).min(b.len());
                let piece = b[s..e].to_vec();
                let at = rng.below(b.len());
                b.splice(at..at, piece);
            }
        }
        // Random bytes inserted.
        4 => {
            let at = rng.below(b.len() + 1);
            let piece: Vec<u8> = (0..1 + rng.below(16)).map(|_| rng.next() as u8).collect();
            b.splice(at..at, piece);
        }
        // Another file's head spliced in front.
        _ => {
            let other = others[rng.below(others.len())];
            let n = rng.below(other.len().min(256) + 1);
            b.splice(0..0, other[..n].iter().copied());
        }
    }
    b
}

/// A small valid mesh with every feature: polygons, parts, per-corner UVs, colours.
fn sample() -> Mesh {
    let src = b"v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 1 1 0 0 0 1\nv 0 1 0 1 1 1\nv 0 0 1 0.5 0.5 0.5\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
o box\ng bottom\nusemtl a\nf 1/1 2/2 3/3 4/4\ng side\nusemtl b\nf 1/1 2/2 5/3\nf 2/2 3/3 5/4\n";
    Mesh::from_bytes(src, Format::Obj, Path::new("s.obj")).expect("sample")
}

#[test]
fn every_reader_survives_thousands_of_mutations() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/models");
    let m = sample();
    let formats = [
        Format::Obj,
        Format::Ply,
        Format::PlyAscii,
        Format::Stl,
        Format::Off,
        Format::Gltf,
        Format::Glb,
    ];
    let mut seeds: Vec<(Format, Vec<u8>)> = formats
        .iter()
        .map(|&f| (f, m.to_bytes(f).expect("encode")))
        .collect();
    for (name, f) in [
        ("assimp_BoxTextured.glb", Format::Glb),
        ("assimp_sphereWithHole.stl", Format::Stl),
        ("cgal_hand.off", Format::Off),
        ("pyvista_airplane.ply", Format::Ply),
        ("assimp_Suzanne_248.obj", Format::Obj),
    ] {
        seeds.push((f, std::fs::read(root.join(name)).expect("bundled model")));
    }
    // Any panic, even one a reader catches itself, fails the test.
    static PANICS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let previous = std::sync::Arc::new(std::panic::take_hook());
    let me = std::thread::current().id();
    let others = previous.clone();
    std::panic::set_hook(Box::new(move |info| {
        // Other tests run on other threads at the same time: only ours
        // count, theirs are reported as usual.
        if std::thread::current().id() == me {
            PANICS.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            eprintln!("fuzz: panic: {info}");
        } else {
            others(info);
        }
    }));
    let all: Vec<&[u8]> = seeds.iter().map(|(_, b)| b.as_slice()).collect();
    let start = std::time::Instant::now();
    let mut report = Vec::new();
    for (k, (fmt, bytes)) in seeds.iter().enumerate() {
        let mut rng = Rng::new(1000 + k as u64);
        let (mut ok, mut refused) = (0, 0);
        // The small generated files get many cases, the real models fewer.
        let cases = if bytes.len() < 20_000 { 10_000 } else { 1_000 };
        for case in 0..cases {
            let input = mutate(bytes, &mut rng, &all);
            let read_as = if *fmt == Format::PlyAscii {
                Format::Ply
            } else {
                *fmt
            };
            let result =
                std::panic::catch_unwind(|| Mesh::from_bytes(&input, read_as, Path::new("fuzz")));
            match result {
                Err(_) => panic!("{fmt:?} seed {k} case {case}: the reader panicked"),
                Ok(Ok(mesh)) => {
                    mesh.validate(Path::new("fuzz"))
                        .expect("a mesh read is valid");
                    ok += 1;
                }
                Ok(Err(_)) => refused += 1,
            }
        }
        report.push(format!(
            "{fmt:?}: {cases} cases ({ok} read, {refused} refused)"
        ));
    }
    let _ = std::panic::take_hook();
    drop(previous);
    eprintln!(
        "fuzz: {} in {:.1} s",
        report.join("; "),
        start.elapsed().as_secs_f64()
    );
    assert_eq!(
        PANICS.load(std::sync::atomic::Ordering::SeqCst),
        0,
        "a reader panicked"
    );
}
