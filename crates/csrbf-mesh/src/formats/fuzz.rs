//! Seeded mutation fuzzing of every reader (issue 7): valid files of every
//! format, and the bundled real models, are bit-flipped, cut, spliced and
//! given huge counts and out-of-range numbers; each case must give an error
//! or a valid mesh, never a panic, and no single allocation may ask for more
//! than [`LIMIT`] bytes (the allocator below refuses it, which aborts the
//! test loudly). Stable Rust, no fuzzing engine: thousands of cases per
//! format in a few seconds.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;

use csrbf::fuzz::mutate;
use csrbf::synthetic::Rng;

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

/// A small valid mesh with every feature: polygons, parts, per-corner UVs,
/// colours, normals per corner (a hard edge at vertices 1 and 2, and a face
/// without normals).
fn sample() -> Mesh {
    let src = b"v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 1 1 0 0 0 1\nv 0 1 0 1 1 1\nv 0 0 1 0.5 0.5 0.5\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
vn 0 0 -1\nvn 0 -1 0\no box\ng bottom\nusemtl a\nf 1/1/1 2/2/1 3/3/1 4/4/1\ng side\nusemtl b\ns 1\nf 1/1/2 2/2/2 5/3/2\ns off\nf 2/2 3/3 5/4\n";
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

/// Issue 25: a material library is a side file read with warnings, never
/// refused: mutated libraries give materials and a few warnings, no panic
/// and no huge allocation.
#[test]
fn the_material_library_reader_survives_mutations() {
    let seed = b"# Blender MTL\nnewmtl blinn3\nNs 96\nKd 0.2 0.4 0.6\nd 0.5\nTr 0.1\n\
map_Kd -o 0.1 0.2 -bm 1 -clamp on duck tex.png\nnewmtl b\nKd 1\nmap_Kd b.jpg\n";
    let mut rng = Rng::new(25);
    for case in 0..10_000 {
        let input = mutate(seed, &mut rng, &[seed]);
        let mut warnings = Vec::new();
        let entries = super::mtl::parse(&input, Path::new("fuzz.mtl"), &mut warnings);
        assert!(warnings.len() <= 9, "case {case}: {warnings:?}");
        for e in entries {
            assert!(
                e.color.iter().all(|c| c.is_finite()) && (0.0..=1.0).contains(&e.color[3]),
                "case {case}: {e:?}"
            );
        }
    }
}

/// The volume readers (`.vtk`, `.vtu`, `.msh`) under the same mutations:
/// every flavour the writers make and files as meshio, Gmsh and ParaView
/// write them; each case gives an error or a mesh that passes
/// `VolumeMesh::check`, never a panic or a huge allocation.
#[test]
fn every_volume_reader_survives_thousands_of_mutations() {
    use crate::volume::VolumeMesh;
    let mut seeds = crate::volume::tests::fuzz_seeds();
    let bundled =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/volume/sphere_in_box.msh");
    if let Ok(bytes) = std::fs::read(bundled) {
        seeds.push((crate::volume::VolumeFormat::Msh, bytes));
    }
    let all: Vec<&[u8]> = seeds.iter().map(|(_, b)| b.as_slice()).collect();
    let start = std::time::Instant::now();
    let mut report = Vec::new();
    for (k, (fmt, bytes)) in seeds.iter().enumerate() {
        let mut rng = Rng::new(7000 + k as u64);
        let (mut ok, mut refused) = (0, 0);
        // The small samples get many cases, the real Gmsh file fewer.
        let cases = if bytes.len() < 20_000 { 10_000 } else { 500 };
        for case in 0..cases {
            let input = mutate(bytes, &mut rng, &all);
            let result = std::panic::catch_unwind(|| {
                VolumeMesh::from_bytes(&input, *fmt, Path::new("fuzz"))
            });
            match result {
                Err(_) => panic!("{fmt:?} seed {k} case {case}: the reader panicked"),
                Ok(Ok(mesh)) => {
                    mesh.check(Path::new("fuzz")).expect("a mesh read is valid");
                    ok += 1;
                }
                Ok(Err(e)) => {
                    assert!(e.to_string().starts_with("fuzz"), "{e}");
                    refused += 1;
                }
            }
        }
        report.push(format!("{fmt:?} seed {k}: {ok} read, {refused} refused"));
    }
    eprintln!(
        "fuzz: {} in {:.1} s",
        report.join("; "),
        start.elapsed().as_secs_f64()
    );
}
