//! Vertex normals of one triangle list, prepared once for many frames.
//!
//! [`crate::triangle_vertex_normals_into`] scatters each triangle's area
//! vector into its three vertices with scalar `Vec3` arithmetic: about 90
//! instructions a triangle. A [`VertexNormals`] keeps the triangles whose
//! corners are in range and, where the CPU has AVX2 (checked at run time),
//! makes a frame two passes over points kept as x y z w, four floats a
//! vertex: the same scatter, two triangles a step (their corners loaded as
//! 128-bit halves, edges and cross products in 256-bit registers, then six
//! read-add-writes of x y z w; the fourth float rides along and is never
//! read), then the sums normalised eight vertices at a time and written as
//! turned `Vec3`s.
//!
//! The scatter takes the triangles in an order made once (`schedule`):
//! each vertex still meets its triangles in their order, so the normals
//! are bit for bit the plain function's, but two triangles that share a
//! vertex are 16 places apart where the mesh allows. In the mesh's own
//! order neighbouring triangles share vertices, and each read-add-write
//! waited on the store just before it to the same vertex (the fish's
//! frame 16.2 -> 14.5 us, medians of 11 interleaved runs). The way out
//! issues the square roots and divisions of the blocks two ahead of the
//! one it finishes: finished in program order, a block's products, turn
//! and interleave filled the scheduler waiting on its own division
//! (14.5 -> 13.3 us). Where the CPU also has AVX-512F, the way out's
//! transposes and interleaves are two-table permutes (three instructions
//! where AVX2 needs a dozen shuffles and blends). Without AVX2 a frame
//! takes the plain function; the same passes one vector at a time stay as
//! the reference of the others in the tests.
//!
//! Tried and measured not to win (the fish's frame, interleaved): the
//! gathers of the passes before this scatter (area vectors of eight
//! triangles by coordinate, then each vertex's sum through a table padded
//! to eight lanes: 4,700 gathers a frame), and again with the corners
//! loaded whole from x y z w points, each vertex's sum from 128-bit loads
//! of its triangles' area vectors in a table of blocks by width, fused
//! with the way out (15.0 us against 14.5 for the scheduled scatter: the
//! area pass and the table's loads cost what the waits did); the cross
//! product in z x y order (two shuffles a step fewer) with six 32-bit
//! offset loads in place of three 64-bit ones (14.7 against 14.5); square
//! roots three blocks ahead (15.4 against 13.3).
//!
//! A caller that builds its points itself (a frame: rest points plus
//! displacements, [`NormalsScratch::points_mut`], [`add_scaled`]) hands them
//! over with no pass to copy `Vec3`s ([`VertexNormals::moved_from_lanes`]),
//! and may leave its last displacements to the pass that moves the points
//! out ([`VertexNormals::moved_from_lanes_adding`]): a frame's points are
//! read and written once fewer.

use glam::{Mat3, Vec3};

/// Vertices a pass of the way out handles at a time (eight f32 in an AVX2
/// register).
#[cfg(target_arch = "x86_64")]
const LANES: usize = 8;

/// Blocks of eight whose square roots and divisions the way out issues
/// before it finishes the block at hand.
#[cfg(target_arch = "x86_64")]
const AHEAD: usize = 2;

/// Floats a point or a sum takes: x y z and one the passes never read.
pub const POINT_FLOATS: usize = 4;

/// The triangles of one mesh whose corners are all in range, for its
/// normals frame after frame ([`VertexNormals::compute_into`], or
/// [`VertexNormals::moved_into`] with a rigid motion).
///
/// ```
/// use csrbf_mesh::{NormalsScratch, VertexNormals};
/// use glam::Vec3;
///
/// let normals = VertexNormals::new(&[[0, 1, 2]], 3);
/// let (mut scratch, mut out) = (NormalsScratch::default(), Vec::new());
/// normals.compute_into(&[Vec3::ZERO, Vec3::X, Vec3::Y], &mut scratch, &mut out);
/// assert_eq!(out, vec![Vec3::Z; 3]);
/// ```
#[derive(Clone, Debug, Default)]
pub struct VertexNormals {
    vertices: usize,
    /// The triangles whose corners are all below `vertices`, in their order.
    triangles: Vec<[u32; 3]>,
    /// Their corners as float offsets into the points, `4 i` for vertex
    /// `i`, three a triangle, the triangles in the order of [`schedule`]
    /// (the AVX2 scatter indexes by them unchecked);
    /// empty when `4 vertices` does not fit in a `u32` (the plain function
    /// then takes every frame).
    corners: Vec<u32>,
}

/// Buffers a frame's normals use, kept between frames so that a frame
/// allocates nothing.
#[derive(Clone, Debug, Default)]
pub struct NormalsScratch {
    /// Points as x y z w, [`POINT_FLOATS`] floats a vertex.
    xyzw: CacheAligned,
    /// Each vertex's sum of area vectors, x y z w likewise.
    sum: CacheAligned,
}

/// Floats whose first sits on a 64-byte boundary (a cache line, where the
/// allocator allows it), so that a 512-bit load or store of them never
/// straddles two lines: one that does costs two. A frame's point lanes,
/// sums, rest points and displacements; derefs to `[f32]`.
#[derive(Clone, Debug, Default)]
pub struct CacheAligned {
    buf: Vec<f32>,
    start: usize,
    len: usize,
}

impl CacheAligned {
    /// `len` floats of `value`.
    pub fn filled(len: usize, value: f32) -> CacheAligned {
        let mut a = CacheAligned::default();
        a.resize(len, value);
        a
    }

    /// As long as `len`: the floats kept, new ones `value`.
    pub fn resize(&mut self, len: usize, value: f32) {
        if len == self.len {
            return;
        }
        const LINE: usize = 64 / std::mem::size_of::<f32>();
        let mut buf = vec![value; len + LINE - 1];
        // Elements to the first line boundary (0 where it cannot say).
        let start = buf.as_ptr().align_offset(64).min(LINE - 1);
        let keep = len.min(self.len);
        buf[start..start + keep].copy_from_slice(&self[..keep]);
        *self = CacheAligned { buf, start, len };
    }
}

impl From<Vec<f32>> for CacheAligned {
    fn from(values: Vec<f32>) -> CacheAligned {
        let mut a = CacheAligned::filled(values.len(), 0.0);
        a.copy_from_slice(&values);
        a
    }
}

impl std::ops::Deref for CacheAligned {
    type Target = [f32];
    fn deref(&self) -> &[f32] {
        &self.buf[self.start..self.start + self.len]
    }
}

impl std::ops::DerefMut for CacheAligned {
    fn deref_mut(&mut self) -> &mut [f32] {
        &mut self.buf[self.start..self.start + self.len]
    }
}

impl VertexNormals {
    /// The triangles of `vertices` vertices; triangles with an index out of
    /// range are dropped (as the plain function skips them).
    pub fn new(triangles: &[[u32; 3]], vertices: usize) -> VertexNormals {
        let triangles = triangles
            .iter()
            .filter(|t| t.iter().all(|&i| (i as usize) < vertices))
            .copied()
            .collect::<Vec<_>>();
        let fits = u32::try_from(POINT_FLOATS * vertices).is_ok();
        let corners = match fits {
            true => schedule(&triangles, vertices)
                .into_iter()
                .flat_map(|t| triangles[t])
                .map(|i| POINT_FLOATS as u32 * i)
                .collect(),
            false => Vec::new(),
        };
        VertexNormals {
            vertices,
            triangles,
            corners,
        }
    }

    /// Number of vertices it was made for.
    pub fn vertices(&self) -> usize {
        self.vertices
    }

    /// The proof of AVX2 when the passes can take a frame (the CPU has it
    /// and every point has an offset in a `u32`).
    fn cpu(&self) -> Option<Avx2> {
        avx2().filter(|_| self.corners.len() == 3 * self.triangles.len())
    }

    /// Area-weighted normals of `positions` into `out` (vertices on no
    /// triangle get +Z), bit for bit those of
    /// [`crate::triangle_vertex_normals_into`]. Positions of another length
    /// than [`VertexNormals::vertices`] are handed to the plain function,
    /// with the triangles kept.
    pub fn compute_into(
        &self,
        positions: &[Vec3],
        scratch: &mut NormalsScratch,
        out: &mut Vec<Vec3>,
    ) {
        let cpu = self.cpu();
        if positions.len() != self.vertices || cpu.is_none() {
            crate::triangle_vertex_normals_into(positions, &self.triangles, out);
            return;
        }
        scratch.take_points(self, positions);
        self.sums(cpu, scratch);
        // Every value is written below: no clearing pass.
        out.resize(self.vertices, Vec3::ZERO);
        write_out(cpu, &scratch.sum, true, None, out);
    }

    /// The normals of `positions` and a rigid motion in one pass:
    /// `positions[i]` becomes `rotation * positions[i] + shift` and
    /// `normals[i]` the normal before the motion turned by `rotation` (an
    /// orthonormal matrix turns area vectors as it turns points).
    /// Positions of another length than [`VertexNormals::vertices`] are
    /// handed to the plain function, with the triangles kept.
    pub fn moved_into(
        &self,
        positions: &mut [Vec3],
        rotation: Mat3,
        shift: Vec3,
        scratch: &mut NormalsScratch,
        normals: &mut Vec<Vec3>,
    ) {
        let cpu = self.cpu();
        if positions.len() != self.vertices || cpu.is_none() {
            plain_moved(positions, &self.triangles, rotation, shift, normals);
            return;
        }
        scratch.take_points(self, positions);
        self.moved_lanes(cpu, rotation, shift, scratch, positions, normals);
    }

    /// [`VertexNormals::moved_into`] for points the caller wrote as x y z w
    /// into [`NormalsScratch::points_mut`]: no pass of its own to copy
    /// them. `positions` and `normals` are replaced by the moved points and
    /// their turned normals, bit for bit what [`VertexNormals::moved_into`]
    /// gives for the same points.
    pub fn moved_from_lanes(
        &self,
        rotation: Mat3,
        shift: Vec3,
        scratch: &mut NormalsScratch,
        positions: &mut Vec<Vec3>,
        normals: &mut Vec<Vec3>,
    ) {
        let cpu = self.cpu();
        if cpu.is_none() {
            let xyzw = scratch.points_mut(self);
            positions.clear();
            positions.extend(
                xyzw.chunks_exact(POINT_FLOATS)
                    .map(|p| Vec3::new(p[0], p[1], p[2])),
            );
            plain_moved(positions, &self.triangles, rotation, shift, normals);
            return;
        }
        positions.resize(self.vertices, Vec3::ZERO);
        self.moved_lanes(cpu, rotation, shift, scratch, positions, normals);
    }

    /// [`VertexNormals::moved_from_lanes`] after the last displacements:
    /// the points in the lanes become `base + d * t` for each `(d, t)` of
    /// `stages` in turn (`base`: those points themselves when None), as
    /// [`scaled_sum_into`] and [`add_scaled`] make them, and with AVX2 they
    /// are moved into `positions` in the same pass (no pass of the way out
    /// for them, no pass a stage). Bit for bit those calls.
    #[allow(clippy::too_many_arguments)]
    pub fn moved_from_lanes_adding(
        &self,
        base: Option<&[f32]>,
        stages: &[(&[f32], f32)],
        rotation: Mat3,
        shift: Vec3,
        scratch: &mut NormalsScratch,
        positions: &mut Vec<Vec3>,
        normals: &mut Vec<Vec3>,
    ) {
        let cpu = self.cpu();
        let p = scratch.points_mut(self);
        let fits = stages.iter().all(|(d, _)| d.len() == p.len())
            && base.is_none_or(|b| b.len() == p.len());
        if cpu.is_none() || !fits {
            for (k, &(d, t)) in stages.iter().enumerate() {
                match base {
                    Some(b) if k == 0 => scaled_sum_into(p, b, d, t),
                    _ => add_scaled(p, d, t),
                }
            }
            if stages.is_empty()
                && let Some(b) = base
                && b.len() == p.len()
            {
                p.copy_from_slice(b);
            }
            self.moved_from_lanes(rotation, shift, scratch, positions, normals);
            return;
        }
        let m = rotation.to_cols_array();
        positions.resize(self.vertices, Vec3::ZERO);
        add_moved(
            cpu,
            avx512(),
            p,
            base,
            stages,
            &m,
            shift.to_array(),
            positions,
        );
        self.sums(cpu, scratch);
        // Every value is written below: no clearing pass.
        normals.resize(self.vertices, Vec3::ZERO);
        write_out(cpu, &scratch.sum, true, Some((&m, None)), normals);
    }

    /// The normals of the points in `scratch.xyzw` turned by `rotation`
    /// into `normals`, and the points moved into `positions` (as long as
    /// [`VertexNormals::vertices`]).
    fn moved_lanes(
        &self,
        cpu: Option<Avx2>,
        rotation: Mat3,
        shift: Vec3,
        scratch: &mut NormalsScratch,
        positions: &mut [Vec3],
        normals: &mut Vec<Vec3>,
    ) {
        self.sums(cpu, scratch);
        let m = rotation.to_cols_array();
        // Every value is written below: no clearing pass.
        normals.resize(self.vertices, Vec3::ZERO);
        write_out(cpu, &scratch.sum, true, Some((&m, None)), normals);
        let shift = Some(shift.to_array());
        write_out(cpu, &scratch.xyzw, false, Some((&m, shift)), positions);
    }

    /// The scatter pass over the points in `s.xyzw`, into `s.sum`.
    fn sums(&self, cpu: Option<Avx2>, s: &mut NormalsScratch) {
        // Sized here whoever filled them: the scatter relies on it.
        s.points_mut(self);
        s.sum.resize(POINT_FLOATS * self.vertices, 0.0);
        s.sum.fill(0.0);
        match cpu {
            #[cfg(target_arch = "x86_64")]
            Some(Avx2(())) if self.corners.len() == 3 * self.triangles.len() => {
                // SAFETY: an `Avx2` exists only when the CPU has AVX2; `new`
                // kept only triangles whose corners are below `vertices`
                // and made `corners` their offsets `4 i` (all of them, as
                // just checked), and both buffers were just sized to four
                // floats for each of `vertices`.
                #[allow(unsafe_code)]
                unsafe {
                    sums_avx2(&self.corners, &s.xyzw, &mut s.sum);
                }
            }
            _ => sums_plain(&self.triangles, &s.xyzw, &mut s.sum),
        }
    }
}

impl NormalsScratch {
    /// The points as x y z w, [`POINT_FLOATS`] floats for each of
    /// [`VertexNormals::vertices`] of `normals`, for a caller that builds a
    /// frame's points there before [`VertexNormals::moved_from_lanes`]
    /// (they hold what the last frame left; the fourth float of each is
    /// never read).
    pub fn points_mut(&mut self, normals: &VertexNormals) -> &mut [f32] {
        self.xyzw.resize(POINT_FLOATS * normals.vertices, 0.0);
        &mut self.xyzw
    }

    /// `positions` copied in as x y z 0.
    fn take_points(&mut self, normals: &VertexNormals, positions: &[Vec3]) {
        let xyzw = self.points_mut(normals);
        for (q, p) in xyzw.chunks_exact_mut(POINT_FLOATS).zip(positions) {
            q.copy_from_slice(&[p.x, p.y, p.z, 0.0]);
        }
    }
}

/// `lanes[i] += d[i] * t` for every `i` of both (the product rounded, then
/// the sum: no fused multiply-add, so each lane is bit for bit the `Vec3`
/// code's `p += d * t`), eight lanes at a time where the CPU has AVX2: a
/// frame's displacements added in [`NormalsScratch::points_mut`].
pub fn add_scaled(lanes: &mut [f32], d: &[f32], t: f32) {
    #[inline(always)]
    fn body(lanes: &mut [f32], d: &[f32], t: f32) {
        for (x, d) in lanes.iter_mut().zip(d) {
            *x += *d * t;
        }
    }
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn body_avx2(lanes: &mut [f32], d: &[f32], t: f32) {
        body(lanes, d, t);
    }
    #[cfg(target_arch = "x86_64")]
    if let Some(Avx2(())) = avx2() {
        // SAFETY: an `Avx2` exists only when the CPU has AVX2.
        #[allow(unsafe_code)]
        unsafe {
            return body_avx2(lanes, d, t);
        }
    }
    body(lanes, d, t);
}

/// `out[i] = base[i] + d[i] * t` for every `i` of the three: what
/// [`add_scaled`] leaves in a copy of `base`, without the copy.
pub fn scaled_sum_into(out: &mut [f32], base: &[f32], d: &[f32], t: f32) {
    #[inline(always)]
    fn body(out: &mut [f32], base: &[f32], d: &[f32], t: f32) {
        for (o, (b, d)) in out.iter_mut().zip(base.iter().zip(d)) {
            *o = *b + *d * t;
        }
    }
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn body_avx2(out: &mut [f32], base: &[f32], d: &[f32], t: f32) {
        body(out, base, d, t);
    }
    #[cfg(target_arch = "x86_64")]
    if let Some(Avx2(())) = avx2() {
        // SAFETY: an `Avx2` exists only when the CPU has AVX2.
        #[allow(unsafe_code)]
        unsafe {
            return body_avx2(out, base, d, t);
        }
    }
    body(out, base, d, t);
}

/// `p = base + d * t` for each `(d, t)` of `stages` in turn (`base`: `p`
/// itself when None) over x y z w, and each point moved, `m * p + shift`
/// ([`turn_one`]), into `out`: the last displacements of a frame and its
/// rigid motion in one pass, two points a 256-bit step with AVX2, eight
/// with AVX-512 (`wide`).
#[allow(clippy::too_many_arguments)]
fn add_moved(
    cpu: Option<Avx2>,
    wide: Option<Avx512>,
    p: &mut [f32],
    base: Option<&[f32]>,
    stages: &[(&[f32], f32)],
    m: &[f32; 9],
    shift: [f32; 3],
    out: &mut [Vec3],
) {
    let n = out.len();
    let whole = n.saturating_sub(1) / 2 * 2;
    let floats = POINT_FLOATS * n;
    assert!(
        p.len() >= floats
            && stages.iter().all(|(d, _)| d.len() >= floats)
            && base.is_none_or(|b| b.len() >= floats),
        "lanes too short"
    );
    // Where the one-point-at-a-time loop below starts.
    #[cfg(not(target_arch = "x86_64"))]
    let start = 0;
    #[cfg(target_arch = "x86_64")]
    let start = if let Some(Avx2(())) = cpu {
        // SAFETY: an `Avx2` exists only when the CPU has AVX2; the lanes
        // were just checked to hold four floats for each of `out`, and
        // `whole` is even and leaves at least one point to the loop below.
        #[allow(unsafe_code)]
        unsafe {
            if let Some(Avx512(())) = wide {
                // SAFETY: as above, and an `Avx512` exists only when the
                // CPU has AVX-512F and AVX2; eight points a step end at
                // `n - n % 8`.
                let f = match stages.len() {
                    0 => add_moved_avx512::<0>,
                    1 => add_moved_avx512::<1>,
                    2 => add_moved_avx512::<2>,
                    3 => add_moved_avx512::<3>,
                    4 => add_moved_avx512::<4>,
                    _ => add_moved_avx512::<{ usize::MAX }>,
                };
                f(p, base, stages, m, shift, n - n % LANES, out);
                n - n % LANES
            } else {
                let f = match stages.len() {
                    0 => add_moved_avx2::<0>,
                    1 => add_moved_avx2::<1>,
                    2 => add_moved_avx2::<2>,
                    3 => add_moved_avx2::<3>,
                    4 => add_moved_avx2::<4>,
                    _ => add_moved_avx2::<{ usize::MAX }>,
                };
                f(p, base, stages, m, shift, whole, out);
                whole
            }
        }
    } else {
        0
    };
    let _ = (cpu, wide, whole);
    for (i, o) in out.iter_mut().enumerate().skip(start) {
        let at = POINT_FLOATS * i..POINT_FLOATS * (i + 1);
        for k in at.clone() {
            let mut q = base.map_or(p[k], |b| b[k]);
            for (d, t) in stages {
                q += d[k] * t;
            }
            p[k] = q;
        }
        let q = &p[at];
        *o = turn_one(m, Some(shift), q[0], q[1], q[2]);
    }
}

/// [`add_moved`] for the first `whole` points (even), two a step: the
/// stages added in turn (`N` of them, unrolled; `usize::MAX`: any number), then each coordinate broadcast in its half, the
/// products and sums of [`turn_one`] lane by lane, then each half stored
/// as 16 bytes at its `Vec3` (the fourth float lands on the next point's
/// x, which the next store writes).
///
/// # Safety
/// The CPU has AVX2; `p`, `base` and each stage's displacement hold four
/// floats for each of `out`, and `whole` is even and below `out.len()`.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2")]
unsafe fn add_moved_avx2<const N: usize>(
    p: &mut [f32],
    base: Option<&[f32]>,
    stages: &[(&[f32], f32)],
    m: &[f32; 9],
    s: [f32; 3],
    whole: usize,
    out: &mut [Vec3],
) {
    use std::arch::x86_64::*;
    // SAFETY: the caller's contract; `Vec3` is three f32 in a row
    // (`repr(C)`), so `out` is `3 n` floats and the store at point `i`
    // ends at float `3 i + 4`, within `out` for every `i` below
    // `whole - 1 < n - 1`.
    unsafe {
        let col =
            |c: usize| _mm256_setr_ps(m[c], m[c + 1], m[c + 2], 0.0, m[c], m[c + 1], m[c + 2], 0.0);
        let (c0, c1, c2) = (col(0), col(3), col(6));
        let sh = _mm256_setr_ps(s[0], s[1], s[2], 0.0, s[0], s[1], s[2], 0.0);
        let src = base.map_or(p.as_ptr(), <[f32]>::as_ptr);
        let (pp, dst) = (p.as_mut_ptr(), out.as_mut_ptr().cast::<f32>());
        for i in (0..whole).step_by(2) {
            let at = POINT_FLOATS * i;
            let mut q = _mm256_loadu_ps(src.add(at));
            let add = |q, (d, t): &(&[f32], f32)| {
                // No fused multiply-add: the product rounded, then the sum.
                let d = _mm256_loadu_ps(d.as_ptr().add(at));
                _mm256_add_ps(q, _mm256_mul_ps(d, _mm256_set1_ps(*t)))
            };
            if N == usize::MAX {
                q = stages.iter().fold(q, add);
            } else {
                for stage in &stages[..N] {
                    q = add(q, stage);
                }
            }
            _mm256_storeu_ps(pp.add(at), q);
            let r = _mm256_add_ps(
                _mm256_add_ps(
                    _mm256_add_ps(
                        _mm256_mul_ps(c0, _mm256_permute_ps::<0x00>(q)),
                        _mm256_mul_ps(c1, _mm256_permute_ps::<0x55>(q)),
                    ),
                    _mm256_mul_ps(c2, _mm256_permute_ps::<0xAA>(q)),
                ),
                sh,
            );
            _mm_storeu_ps(dst.add(3 * i), _mm256_castps256_ps128(r));
            _mm_storeu_ps(dst.add(3 * i + 3), _mm256_extractf128_ps::<1>(r));
        }
    }
}

/// [`add_moved`] for the first `whole` points (a multiple of eight), eight
/// a step: the stages added in turn over two 512-bit registers (`N` of
/// them, unrolled; `usize::MAX`: any number), the points stored, then
/// their x, y and z by two-table permutes, [`turn_one`] lane by lane, and
/// 24 floats of `Vec3`s interleaved by permutes.
///
/// # Safety
/// The CPU has AVX-512F and AVX2; `p`, `base` and each stage's
/// displacement hold four floats for each of `out`, and `whole` is a
/// multiple of eight at most `out.len()`.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx512f,avx2")]
unsafe fn add_moved_avx512<const N: usize>(
    p: &mut [f32],
    base: Option<&[f32]>,
    stages: &[(&[f32], f32)],
    m: &[f32; 9],
    s: [f32; 3],
    whole: usize,
    out: &mut [Vec3],
) {
    use std::arch::x86_64::*;
    // SAFETY: the caller's contract; `Vec3` is three f32 in a row
    // (`repr(C)`), so `out` is `3 n` floats.
    unsafe {
        let mm = m.map(|v| _mm256_set1_ps(v));
        let sh = s.map(|v| _mm256_set1_ps(v));
        let src = base.map_or(p.as_ptr(), <[f32]>::as_ptr);
        let (pp, dst) = (p.as_mut_ptr(), out.as_mut_ptr().cast::<f32>());
        for i in (0..whole).step_by(LANES) {
            let at = POINT_FLOATS * i;
            let mut q = [
                _mm512_loadu_ps(src.add(at)),
                _mm512_loadu_ps(src.add(at + 16)),
            ];
            let add = |q: [__m512; 2], (d, t): &(&[f32], f32)| {
                let t = _mm512_set1_ps(*t);
                // No fused multiply-add: the product rounded, then the sum.
                [0, 16].map(|h| {
                    let d = _mm512_loadu_ps(d.as_ptr().add(at + h));
                    _mm512_add_ps(q[h / 16], _mm512_mul_ps(d, t))
                })
            };
            if N == usize::MAX {
                q = stages.iter().fold(q, add);
            } else {
                for stage in &stages[..N] {
                    q = add(q, stage);
                }
            }
            _mm512_storeu_ps(pp.add(at), q[0]);
            _mm512_storeu_ps(pp.add(at + 16), q[1]);
            let [x, y, z] = coordinates_of(q[0], q[1]);
            let (x, y, z) = turn_avx2(&mm, Some(&sh), x, y, z);
            interleave_avx512(dst.add(3 * i), x, y, z);
        }
    }
}

/// Places apart that [`schedule`] puts two triangles sharing a vertex
/// where the mesh allows: eight steps of the scatter. (The fish's frame,
/// best of nine interleaved on a busy machine: 8 places 14.0 us, 16 13.5,
/// 24 14.1, 32 13.0, 48 14.0; 16 to 32 alike within the noise.)
const GAP: usize = 16;

/// How far past the number of triangles placed so far [`schedule`] may
/// put one: room for the holes that [`GAP`] leaves along a row of up to
/// 4,096 triangles for the rows after it to fill, and a bound on its
/// places (a strip whose every triangle shares a vertex with the one
/// before would otherwise take `GAP` places a triangle).
const WINDOW: usize = 1 << 16;

/// An order of `triangles` (their indices) in which each vertex still
/// meets its triangles in their order, but two triangles that share a
/// vertex are [`GAP`] or more places apart where the mesh allows: each
/// triangle in turn takes the first free place at least [`GAP`] after
/// the places of the triangles before it on its corners (list
/// scheduling), so that the scatter's read-add-writes of one vertex do
/// not wait on each other back to back. A triangle's place is after those
/// of the triangles before it on each of its corners, so sorting by place
/// keeps every vertex's order. A triangle goes to the first free place
/// at or after its earliest, which is at most the count so far plus
/// [`WINDOW`] or just after the last place taken, so places stay below
/// `triangles + WINDOW`.
fn schedule(triangles: &[[u32; 3]], vertices: usize) -> Vec<usize> {
    // Place of each vertex's last triangle so far, plus one (0: none).
    let mut last = vec![0usize; vertices];
    // The next place that may be free from each place (a union-find
    // forest over the places, path-halved).
    let mut next: Vec<usize> = Vec::new();
    let mut place = Vec::with_capacity(triangles.len());
    for t in triangles {
        // Just after the latest triangle before it on a corner (0: none).
        let after = t.iter().map(|&v| last[v as usize]).max().unwrap_or(0);
        // `GAP` after it, but not past the window, and never before it.
        let earliest = match after {
            0 => 0,
            _ => (after - 1 + GAP).min(place.len() + WINDOW).max(after),
        };
        let mut p = earliest;
        loop {
            if p >= next.len() {
                next.extend(next.len()..=p);
            }
            if next[p] == p {
                break;
            }
            let up = next[p];
            if up < next.len() {
                next[p] = next[up];
            }
            p = up;
        }
        // Taken: the next free place is further on.
        next[p] = p + 1;
        for &v in t {
            last[v as usize] = p + 1;
        }
        place.push(p);
    }
    let mut order: Vec<usize> = (0..triangles.len()).collect();
    // Places are distinct: the sort keeps nothing equal apart.
    order.sort_unstable_by_key(|&t| place[t]);
    order
}

/// The normals of the plain function and the rigid motion, one vertex at a
/// time (positions of another length, or no AVX2).
fn plain_moved(
    positions: &mut [Vec3],
    triangles: &[[u32; 3]],
    rotation: Mat3,
    shift: Vec3,
    normals: &mut Vec<Vec3>,
) {
    crate::triangle_vertex_normals_into(positions, triangles, normals);
    for (p, n) in positions.iter_mut().zip(normals.iter_mut()) {
        *p = rotation * *p + shift;
        *n = rotation * *n;
    }
}

/// Proof that this CPU has AVX2: only [`avx2`] makes one.
#[derive(Clone, Copy, Debug)]
struct Avx2(());

/// The proof, when the CPU has AVX2 (checked once, then cached by std).
fn avx2() -> Option<Avx2> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        return Some(Avx2(()));
    }
    None
}

/// Proof that this CPU has AVX-512F and AVX2: only [`avx512`] makes one.
#[derive(Clone, Copy, Debug)]
struct Avx512(());

/// The proof, when the CPU has AVX-512F and AVX2 (checked once, then
/// cached by std). Its two-table permutes turn the way out's transposes
/// and interleaves into three instructions each.
fn avx512() -> Option<Avx512> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx2")
    {
        return Some(Avx512(()));
    }
    None
}

/// One triangle's area vector, (b - a) x (c - a), as glam's `Vec3::cross`
/// multiplies and subtracts.
#[inline(always)]
fn cross_of(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> [f32; 3] {
    let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    [
        e1[1] * e2[2] - e2[1] * e1[2],
        e1[2] * e2[0] - e2[2] * e1[0],
        e1[0] * e2[1] - e2[0] * e1[1],
    ]
}

/// One vector of the normalisation, as the plain function does it in
/// `Vec3`: ((x x + y y) + z z), then times 1 / sqrt; +Z for a zero (or
/// NaN) sum.
#[inline(always)]
fn unit(v: [f32; 3]) -> [f32; 3] {
    let len2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    if len2 > 0.0 {
        let r = len2.sqrt().recip();
        [v[0] * r, v[1] * r, v[2] * r]
    } else {
        [0.0, 0.0, 1.0]
    }
}

/// One column vector turned as glam's `Mat3 * Vec3` computes it (x y z
/// columns in turn, no fused multiply-add), then shifted: bit for bit the
/// plain code's.
#[inline(always)]
fn turn_one(m: &[f32; 9], shift: Option<[f32; 3]>, a: f32, b: f32, c: f32) -> Vec3 {
    let r = [
        (m[0] * a + m[3] * b) + m[6] * c,
        (m[1] * a + m[4] * b) + m[7] * c,
        (m[2] * a + m[5] * b) + m[8] * c,
    ];
    // Adding no shift, not +0 (which would turn -0 into +0).
    match shift {
        Some(s) => Vec3::new(r[0] + s[0], r[1] + s[1], r[2] + s[2]),
        None => Vec3::new(r[0], r[1], r[2]),
    }
}

/// A turn of the way out: the matrix by columns and the shift after it
/// (None adds nothing).
type Turn<'a> = Option<(&'a [f32; 9], Option<[f32; 3]>)>;

/// One vector of the way out: `src`'s x y z, normalised if `normalise`,
/// then turned and shifted.
#[inline(always)]
fn out_one(src: &[f32], normalise: bool, turn: Turn) -> Vec3 {
    let mut v = [src[0], src[1], src[2]];
    if normalise {
        v = unit(v);
    }
    match turn {
        Some((m, shift)) => turn_one(m, shift, v[0], v[1], v[2]),
        None => Vec3::from_array(v),
    }
}

/// The way out: for the first `out.len()` vectors of `src` (x y z w, four
/// floats each), normalised if `normalise` ([`unit`]), turned and shifted
/// by `turn` ([`turn_one`]), as `Vec3`s into `out`: a frame's normals and
/// its moved points, eight vectors at a time with AVX2.
fn write_out(cpu: Option<Avx2>, src: &[f32], normalise: bool, turn: Turn, out: &mut [Vec3]) {
    assert!(src.len() >= POINT_FLOATS * out.len(), "lanes too short");
    #[cfg(target_arch = "x86_64")]
    if let Some(Avx2(())) = cpu {
        // SAFETY: an `Avx2` exists only when the CPU has AVX2; `src` was
        // just checked to hold four floats for each of `out`.
        #[allow(unsafe_code)]
        unsafe {
            // SAFETY: an `Avx512` exists only when the CPU has AVX-512F
            // and AVX2.
            if let Some(Avx512(())) = avx512() {
                return write_out_avx512(src, normalise, turn, out);
            }
            return write_out_avx2(src, normalise, turn, out);
        }
    }
    let _ = cpu;
    write_plain(src, normalise, turn, out);
}

/// [`write_out`] one vector at a time (the reference of the AVX2 pass).
fn write_plain(src: &[f32], normalise: bool, turn: Turn, out: &mut [Vec3]) {
    for (o, s) in out.iter_mut().zip(src.chunks_exact(POINT_FLOATS)) {
        *o = out_one(s, normalise, turn);
    }
}

/// The scatter one triangle at a time in `f32`s (the reference of the AVX2
/// pass): `sum` (zeroed) gets each triangle's area vector at its three
/// corners, in the triangles' order.
fn sums_plain(triangles: &[[u32; 3]], xyzw: &[f32], sum: &mut [f32]) {
    let p = |i: usize| [xyzw[4 * i], xyzw[4 * i + 1], xyzw[4 * i + 2]];
    for t in triangles {
        let [a, b, c] = t.map(|i| i as usize);
        let area = cross_of(p(a), p(b), p(c));
        for v in [a, b, c] {
            for (s, a) in sum[4 * v..4 * v + 3].iter_mut().zip(area) {
                *s += a;
            }
        }
    }
}

/// The scatter, two triangles a step: their corners' x y z w in the halves
/// of 256-bit registers, the edges, the cross product as
/// `e1.yzx * e2.zxy - e2.yzx * e1.zxy` (each lane the products and
/// difference of [`cross_of`]), then six read-add-writes of x y z w, the
/// first triangle's three corners before the second's (an odd one last,
/// alone). `corners` holds three float offsets a triangle, `4 i` for vertex
/// `i`: addresses with no multiplication.
///
/// # Safety
/// The CPU has AVX2; `corners.len()` is a multiple of three and every
/// offset in it is at most `xyzw.len() - 4` and `sum.len() - 4`.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2")]
unsafe fn sums_avx2(corners: &[u32], xyzw: &[f32], sum: &mut [f32]) {
    use std::arch::x86_64::*;
    let (p, s) = (xyzw.as_ptr(), sum.as_mut_ptr());
    // SAFETY: the caller's contract (offsets in range).
    unsafe {
        let point = |c: u32| _mm_loadu_ps(p.add(c as usize));
        let add = |c: u32, area: __m128| {
            let at = s.add(c as usize);
            _mm_storeu_ps(at, _mm_add_ps(_mm_loadu_ps(at), area));
        };
        let pairs = corners.chunks_exact(6);
        let odd = pairs.remainder();
        for c in pairs {
            // Two offsets a 64-bit load (little-endian: the first in the
            // low half): three loads a pair where six were, the loads
            // being what the scatter waits on. The three unaligned reads
            // cover the chunk's 24 bytes exactly.
            let w = c.as_ptr().cast::<u64>();
            let w = [0, 1, 2].map(|k| w.add(k).read_unaligned());
            let c = [
                w[0] as u32,
                (w[0] >> 32) as u32,
                w[1] as u32,
                (w[1] >> 32) as u32,
                w[2] as u32,
                (w[2] >> 32) as u32,
            ];
            let two = |i: usize| _mm256_set_m128(point(c[i + 3]), point(c[i]));
            let a = two(0);
            let e1 = _mm256_sub_ps(two(1), a);
            let e2 = _mm256_sub_ps(two(2), a);
            let yzx = |v| _mm256_permute_ps::<0b11_00_10_01>(v);
            let zxy = |v| _mm256_permute_ps::<0b11_01_00_10>(v);
            let area = _mm256_sub_ps(
                _mm256_mul_ps(yzx(e1), zxy(e2)),
                _mm256_mul_ps(yzx(e2), zxy(e1)),
            );
            let (first, second) = (
                _mm256_castps256_ps128(area),
                _mm256_extractf128_ps::<1>(area),
            );
            add(c[0], first);
            add(c[1], first);
            add(c[2], first);
            add(c[3], second);
            add(c[4], second);
            add(c[5], second);
        }
        if let [a, b, c] = *odd {
            let pa = point(a);
            let e1 = _mm_sub_ps(point(b), pa);
            let e2 = _mm_sub_ps(point(c), pa);
            let yzx = |v| _mm_permute_ps::<0b11_00_10_01>(v);
            let zxy = |v| _mm_permute_ps::<0b11_01_00_10>(v);
            let area = _mm_sub_ps(_mm_mul_ps(yzx(e1), zxy(e2)), _mm_mul_ps(yzx(e2), zxy(e1)));
            add(a, area);
            add(b, area);
            add(c, area);
        }
    }
}

/// Which float of two tables (a permute's first: 0-15, second: 16-31)
/// each lane takes.
#[cfg(target_arch = "x86_64")]
type Picks = [i32; 16];

/// x, y or z (`c`) of eight x y z w vectors held in two 16-float tables.
#[cfg(target_arch = "x86_64")]
const fn coordinate_picks(c: i32) -> Picks {
    let mut p = [0; 16];
    let mut i = 0;
    while i < 16 {
        p[i] = 4 * (i as i32 % 8) + c;
        i += 1;
    }
    p
}

/// Floats `from..from + 16` of eight `Vec3`s interleaved from the table
/// x0..x7 y0..y7 and the table z0..z7: float `f` is coordinate `f % 3` of
/// vector `f / 3`.
#[cfg(target_arch = "x86_64")]
const fn interleave_picks(from: i32) -> Picks {
    let mut p = [0; 16];
    let mut i = 0;
    while i < 16 {
        let f = (from + i as i32) % 24;
        p[i] = 8 * (f % 3) + f / 3;
        i += 1;
    }
    p
}

/// The picks of x, y and z of eight x y z w vectors.
#[cfg(target_arch = "x86_64")]
const COORDINATE_PICKS: [Picks; 3] = [
    coordinate_picks(0),
    coordinate_picks(1),
    coordinate_picks(2),
];

/// The picks of the first 16 floats of eight interleaved `Vec3`s and of
/// the last 8.
#[cfg(target_arch = "x86_64")]
const INTERLEAVE_PICKS: [Picks; 2] = [interleave_picks(0), interleave_picks(16)];

/// Eight x y z w vectors (32 floats from `at`) as x, y and z: two loads and
/// three two-table permutes (moves only).
///
/// # Safety
/// The CPU has AVX-512F; `at` points to 32 readable floats.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[inline]
#[target_feature(enable = "avx512f,avx2")]
unsafe fn coordinates_avx512(at: *const f32) -> [std::arch::x86_64::__m256; 3] {
    use std::arch::x86_64::*;
    // SAFETY: the caller's contract.
    unsafe { coordinates_of(_mm512_loadu_ps(at), _mm512_loadu_ps(at.add(16))) }
}

/// [`coordinates_avx512`] of vectors in two registers, four in each.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx512f,avx2")]
fn coordinates_of(
    a: std::arch::x86_64::__m512,
    b: std::arch::x86_64::__m512,
) -> [std::arch::x86_64::__m256; 3] {
    use std::arch::x86_64::*;
    COORDINATE_PICKS.map(|p| {
        // SAFETY: `p` is sixteen i32s, 64 readable bytes.
        #[allow(unsafe_code)]
        let picks = unsafe { _mm512_loadu_si512(p.as_ptr().cast()) };
        _mm512_castps512_ps256(_mm512_permutex2var_ps(a, picks, b))
    })
}

/// Eight vectors' x, y and z stored as 24 floats of `Vec3`s at `dst`: two
/// two-table permutes (moves only), a 64-byte and a 32-byte store.
///
/// # Safety
/// The CPU has AVX-512F; `dst` points to 24 writable floats.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[inline]
#[target_feature(enable = "avx512f,avx2")]
unsafe fn interleave_avx512(
    dst: *mut f32,
    x: std::arch::x86_64::__m256,
    y: std::arch::x86_64::__m256,
    z: std::arch::x86_64::__m256,
) {
    use std::arch::x86_64::*;
    // SAFETY: the caller's contract.
    unsafe {
        let xy = _mm512_castpd_ps(_mm512_insertf64x4::<1>(
            _mm512_castpd256_pd512(_mm256_castps_pd(x)),
            _mm256_castps_pd(y),
        ));
        let z = _mm512_castps256_ps512(z);
        let pick = |p: &Picks| {
            let picks = _mm512_loadu_si512(p.as_ptr().cast());
            _mm512_permutex2var_ps(xy, picks, z)
        };
        _mm512_storeu_ps(dst, pick(&INTERLEAVE_PICKS[0]));
        _mm256_storeu_ps(
            dst.add(16),
            _mm512_castps512_ps256(pick(&INTERLEAVE_PICKS[1])),
        );
    }
}

/// [`write_out`] eight vectors at a time as [`write_out_avx2`] computes
/// them, the transpose and the interleave by two-table permutes.
///
/// # Safety
/// The CPU has AVX-512F and AVX2; `src` holds at least `4 out.len()`
/// floats.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx512f,avx2")]
unsafe fn write_out_avx512(src: &[f32], normalise: bool, turn: Turn, out: &mut [Vec3]) {
    use std::arch::x86_64::*;
    let n = out.len();
    let whole = n - n % LANES;
    // SAFETY: the caller's contract; `Vec3` is three f32 in a row
    // (`repr(C)`), so `out` is `3 n` floats.
    unsafe {
        let turn = turn.map(|(m, shift)| {
            (
                m.map(|v| _mm256_set1_ps(v)),
                shift.map(|s| s.map(|v| _mm256_set1_ps(v))),
            )
        });
        let (at, dst) = (src.as_ptr(), out.as_mut_ptr().cast::<f32>());
        for k in (0..whole).step_by(LANES) {
            let [mut x, mut y, mut z] = coordinates_avx512(at.add(POINT_FLOATS * k));
            if normalise {
                (x, y, z) = unit_avx2(x, y, z);
            }
            if let Some((mm, shift)) = turn {
                (x, y, z) = turn_avx2(&mm, shift.as_ref(), x, y, z);
            }
            interleave_avx512(dst.add(3 * k), x, y, z);
        }
    }
    for (i, o) in out.iter_mut().enumerate().skip(whole) {
        *o = out_one(&src[POINT_FLOATS * i..], normalise, turn);
    }
}

/// Eight vectors of [`unit`] lane by lane: [`lengths_avx2`], then
/// [`scale_avx2`].
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn unit_avx2(
    x: std::arch::x86_64::__m256,
    y: std::arch::x86_64::__m256,
    z: std::arch::x86_64::__m256,
) -> (
    std::arch::x86_64::__m256,
    std::arch::x86_64::__m256,
    std::arch::x86_64::__m256,
) {
    let (len2, r) = lengths_avx2(x, y, z);
    scale_avx2(x, y, z, len2, r)
}

/// The first half of [`unit`] for eight vectors: ((x x + y y) + z z) and
/// 1 / its square root.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn lengths_avx2(
    x: std::arch::x86_64::__m256,
    y: std::arch::x86_64::__m256,
    z: std::arch::x86_64::__m256,
) -> (std::arch::x86_64::__m256, std::arch::x86_64::__m256) {
    use std::arch::x86_64::*;
    // No fused multiply-add: the plain function rounds each product.
    let len2 = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(x, x), _mm256_mul_ps(y, y)),
        _mm256_mul_ps(z, z),
    );
    (
        len2,
        _mm256_div_ps(_mm256_set1_ps(1.0), _mm256_sqrt_ps(len2)),
    )
}

/// The second half of [`unit`] for eight vectors: the products by `r`;
/// +Z where `len2` is not above zero.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn scale_avx2(
    x: std::arch::x86_64::__m256,
    y: std::arch::x86_64::__m256,
    z: std::arch::x86_64::__m256,
    len2: std::arch::x86_64::__m256,
    r: std::arch::x86_64::__m256,
) -> (
    std::arch::x86_64::__m256,
    std::arch::x86_64::__m256,
    std::arch::x86_64::__m256,
) {
    use std::arch::x86_64::*;
    let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
    let positive = _mm256_cmp_ps::<_CMP_GT_OQ>(len2, zero);
    (
        _mm256_and_ps(positive, _mm256_mul_ps(x, r)),
        _mm256_and_ps(positive, _mm256_mul_ps(y, r)),
        _mm256_blendv_ps(one, _mm256_mul_ps(z, r), positive),
    )
}

/// Eight vectors of [`turn_one`] lane by lane: the matrix's entries and
/// the shift broadcast.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn turn_avx2(
    mm: &[std::arch::x86_64::__m256; 9],
    shift: Option<&[std::arch::x86_64::__m256; 3]>,
    x: std::arch::x86_64::__m256,
    y: std::arch::x86_64::__m256,
    z: std::arch::x86_64::__m256,
) -> (
    std::arch::x86_64::__m256,
    std::arch::x86_64::__m256,
    std::arch::x86_64::__m256,
) {
    use std::arch::x86_64::*;
    let row = |i: usize| {
        let r = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(mm[i], x), _mm256_mul_ps(mm[i + 3], y)),
            _mm256_mul_ps(mm[i + 6], z),
        );
        match shift {
            Some(s) => _mm256_add_ps(r, s[i]),
            None => r,
        }
    };
    (row(0), row(1), row(2))
}

/// [`write_out`] eight vectors at a time: x y z w of vectors j and j + 4
/// in the halves of a register, transposed into x, y and z (moves only);
/// the normalisation of [`unit`] and the products and sums of
/// [`turn_one`] lane by lane; then eight x, y and z interleaved into 24
/// floats by permutes and blends (moves only). The loads, lengths, square
/// roots and divisions run [`AHEAD`] blocks before the rest. The last
/// `n % 8` vectors one at a time.
///
/// # Safety
/// The CPU has AVX2; `src` holds at least `4 out.len()` floats.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2")]
unsafe fn write_out_avx2(src: &[f32], normalise: bool, turn: Turn, out: &mut [Vec3]) {
    use std::arch::x86_64::*;
    let n = out.len();
    let whole = n - n % LANES;
    // SAFETY: the caller's contract; `Vec3` is three f32 in a row
    // (`repr(C)`), so `out` is `3 n` floats.
    unsafe {
        let turn = turn.map(|(m, shift)| {
            (
                m.map(|v| _mm256_set1_ps(v)),
                shift.map(|s| s.map(|v| _mm256_set1_ps(v))),
            )
        });
        // Which vector each float of the three stores comes from: the
        // stores hold x0 y0 z0 x1 y1 z1 x2 y2 | z2 x3 y3 z3 x4 y4 z4 x5 |
        // y5 z5 x6 y6 z6 x7 y7 z7.
        let from = [
            _mm256_setr_epi32(0, 0, 0, 1, 1, 1, 2, 2),
            _mm256_setr_epi32(2, 3, 3, 3, 4, 4, 4, 5),
            _mm256_setr_epi32(5, 5, 6, 6, 6, 7, 7, 7),
        ];
        let (at, dst) = (src.as_ptr(), out.as_mut_ptr().cast::<f32>());
        // The x, y and z of the block of eight from vector `k`.
        let block = |k: usize| {
            let l = |j: usize| _mm_loadu_ps(at.add(POINT_FLOATS * (k + j)));
            let v = [0, 1, 2, 3].map(|j| _mm256_set_m128(l(j + 4), l(j)));
            let (t0, t1) = (
                _mm256_unpacklo_ps(v[0], v[1]),
                _mm256_unpacklo_ps(v[2], v[3]),
            );
            let (t2, t3) = (
                _mm256_unpackhi_ps(v[0], v[1]),
                _mm256_unpackhi_ps(v[2], v[3]),
            );
            [
                _mm256_shuffle_ps::<0x44>(t0, t1),
                _mm256_shuffle_ps::<0xEE>(t0, t1),
                _mm256_shuffle_ps::<0x44>(t2, t3),
            ]
        };
        // Its squared lengths and their reciprocal roots when normalising
        // (the square root and the division: the long wait).
        let lengths = |[x, y, z]: [__m256; 3]| match normalise {
            true => lengths_avx2(x, y, z),
            false => (_mm256_setzero_ps(), _mm256_setzero_ps()),
        };
        // Software pipelined: the loads, lengths, roots and divisions of
        // the block `AHEAD` blocks on (zeros past the end, never used) are
        // issued before this block's products, turn and stores, so that
        // the divider works on later blocks while this one is finished
        // (in program order, a block's finishing ops filled the scheduler
        // waiting on its own division).
        let ahead = |k: usize| match k < whole {
            true => {
                let c = block(k);
                (c, lengths(c))
            }
            false => {
                let zero = _mm256_setzero_ps();
                ([zero; 3], (zero, zero))
            }
        };
        let mut queue: [([__m256; 3], (__m256, __m256)); AHEAD] =
            std::array::from_fn(|d| ahead(LANES * d));
        for k in (0..whole).step_by(LANES) {
            let ([mut x, mut y, mut z], (len2, r)) = queue[0];
            queue.rotate_left(1);
            queue[AHEAD - 1] = ahead(k + LANES * AHEAD);
            if normalise {
                (x, y, z) = scale_avx2(x, y, z, len2, r);
            }
            if let Some((mm, shift)) = turn {
                (x, y, z) = turn_avx2(&mm, shift.as_ref(), x, y, z);
            }
            let pick = |j: usize| {
                (
                    _mm256_permutevar8x32_ps(x, from[j]),
                    _mm256_permutevar8x32_ps(y, from[j]),
                    _mm256_permutevar8x32_ps(z, from[j]),
                )
            };
            // Blend masks: bit i set takes float i from the second operand.
            let (px, py, pz) = pick(0);
            let o0 = _mm256_blend_ps::<0x24>(_mm256_blend_ps::<0x92>(px, py), pz);
            let (px, py, pz) = pick(1);
            let o1 = _mm256_blend_ps::<0x49>(_mm256_blend_ps::<0x24>(px, py), pz);
            let (px, py, pz) = pick(2);
            let o2 = _mm256_blend_ps::<0x92>(_mm256_blend_ps::<0x49>(px, py), pz);
            _mm256_storeu_ps(dst.add(3 * k), o0);
            _mm256_storeu_ps(dst.add(3 * k + 8), o1);
            _mm256_storeu_ps(dst.add(3 * k + 16), o2);
        }
    }
    for (i, o) in out.iter_mut().enumerate().skip(whole) {
        *o = out_one(&src[POINT_FLOATS * i..], normalise, turn);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seeded xorshift in [0, 1).
    fn rng(mut s: u64) -> impl FnMut() -> f32 {
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    fn bits(v: &[Vec3]) -> Vec<[u32; 3]> {
        v.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
    }

    /// Random triangle lists with repeated corners, out-of-range indices,
    /// unused vertices and coincident points (zero normals); counts that are
    /// and are not multiples of eight, and empty ones.
    fn cases() -> Vec<(Vec<Vec3>, Vec<[u32; 3]>)> {
        let mut r = rng(0x9e37_79b9_7f4a_7c15);
        let mut out = Vec::new();
        for (n, m) in [
            (0, 0),
            (1, 0),
            (3, 1),
            (8, 8),
            (10, 0),
            (50, 80),
            (701, 1403),
        ] {
            let mut positions: Vec<Vec3> = (0..n).map(|_| Vec3::new(r(), r(), r())).collect();
            let mut tris: Vec<[u32; 3]> = (0..m)
                .map(|_| {
                    let i = |x: f32| (x * (n as f32 + 2.0)) as u32; // sometimes out of range
                    [i(r()), i(r()), i(r())]
                })
                .collect();
            if n > 4 {
                positions[3] = positions[2];
                tris.push([2, 3, 2]); // zero area, a corner twice
                tris.push([1, 1, 4]);
                positions[0] = -positions[0]; // signs of every kind
            }
            out.push((positions, tris));
        }
        out
    }

    /// Both passes (AVX2 where the CPU has it, and one vector at a time)
    /// give the plain function's normals bit for bit, also after the points
    /// moved.
    #[test]
    fn agrees_bit_for_bit_with_the_plain_function() {
        let mut r = rng(7);
        for (mut positions, tris) in cases() {
            let normals = VertexNormals::new(&tris, positions.len());
            assert_eq!(normals.vertices(), positions.len());
            let mut scratch = NormalsScratch::default();
            for _ in 0..2 {
                let want = bits(&crate::triangle_vertex_normals(&positions, &tris));
                for cpu in [None, avx2()] {
                    scratch.take_points(&normals, &positions);
                    normals.sums(cpu, &mut scratch);
                    let mut got = vec![Vec3::NAN; positions.len()];
                    write_out(cpu, &scratch.sum, true, None, &mut got);
                    assert_eq!(bits(&got), want, "{} points, {cpu:?}", positions.len());
                }
                let mut out = vec![Vec3::X; 3];
                normals.compute_into(&positions, &mut scratch, &mut out);
                assert_eq!(bits(&out), want);
                for p in &mut positions {
                    *p += Vec3::new(r(), r(), r()) * 0.1;
                }
            }
        }
    }

    /// Two triangles a cell of a `w` by `h` grid, row after row: each
    /// triangle shares a vertex with the one before.
    fn grid(w: u32, h: u32) -> (usize, Vec<[u32; 3]>) {
        let mut tris = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let a = j * (w + 1) + i;
                let (b, c) = (a + 1, a + w + 1);
                tris.extend([[a, b, c + 1], [a, c + 1, c]]);
            }
        }
        (((w + 1) * (h + 1)) as usize, tris)
    }

    /// The scatter's order holds every triangle once and keeps each
    /// vertex's triangles in their order (so the sums add as the plain
    /// function adds) on random meshes, grids with short and long rows
    /// and a strip; on a grid it puts triangles that share a vertex apart.
    #[test]
    fn the_schedule_keeps_each_vertexs_order_and_spreads_a_grid() {
        let strip: Vec<[u32; 3]> = (0..20_000).map(|k| [k, k + 1, k + 2]).collect();
        let mut meshes: Vec<(usize, Vec<[u32; 3]>)> = cases()
            .into_iter()
            .map(|(p, t)| (p.len(), VertexNormals::new(&t, p.len()).triangles))
            .collect();
        meshes.extend([grid(40, 30), grid(5000, 4), (20_002, strip)]);
        for (n, tris) in &meshes {
            let order = schedule(tris, *n);
            let mut seen = vec![false; tris.len()];
            for &t in &order {
                assert!(!std::mem::replace(&mut seen[t], true), "triangle {t} twice");
            }
            assert!(seen.iter().all(|&s| s), "{n} vertices: a triangle left out");
            let mut last = vec![0; *n];
            for &t in &order {
                for &v in &tris[t] {
                    assert!(last[v as usize] <= t, "vertex {v}: triangle {t} too early");
                    last[v as usize] = t;
                }
            }
        }
        // Pairs of triangles at most eight places apart that share a
        // vertex: each triangle with several of the next in the grid's own
        // order, a tenth as many pairs in the schedule's.
        let (n, tris) = grid(40, 30);
        let close = |order: &[usize]| {
            let shares = |a: usize, b: usize| tris[a].iter().any(|v| tris[b].contains(v));
            (0..order.len())
                .flat_map(|i| (i + 1..order.len().min(i + 9)).map(move |j| (i, j)))
                .filter(|&(i, j)| shares(order[i], order[j]))
                .count()
        };
        let (before, after) = (
            close(&(0..tris.len()).collect::<Vec<_>>()),
            close(&schedule(&tris, n)),
        );
        assert!(after * 10 < before, "{after} close pairs against {before}");
    }

    /// The rigid motion turns points and normals as the plain code would.
    #[test]
    fn a_rigid_motion_turns_points_and_normals() {
        let rotation = Mat3::from_quat(glam::Quat::from_rotation_y(0.7));
        let shift = Vec3::new(1.0, -2.0, 0.5);
        for (positions, tris) in cases() {
            let normals = VertexNormals::new(&tris, positions.len());
            let want_n: Vec<Vec3> = crate::triangle_vertex_normals(&positions, &tris)
                .iter()
                .map(|n| rotation * *n)
                .collect();
            let want_p: Vec<Vec3> = positions.iter().map(|p| rotation * *p + shift).collect();
            let (mut moved, mut got) = (positions.clone(), Vec::new());
            let mut scratch = NormalsScratch::default();
            normals.moved_into(&mut moved, rotation, shift, &mut scratch, &mut got);
            assert_eq!((bits(&moved), bits(&got)), (bits(&want_p), bits(&want_n)));
        }
    }

    /// Points written as x y z w give what the same points given as `Vec3`s
    /// give, bit for bit, and displacements added lane by lane what
    /// `p += d * t` gives (signed zeros, NaN and infinities among them).
    #[test]
    fn points_by_coordinate_move_as_points_do() {
        let rotation = Mat3::from_quat(glam::Quat::from_rotation_z(2.3));
        let shift = Vec3::new(-0.5, 3.0, 0.25);
        let mut r = rng(11);
        for (positions, tris) in cases() {
            let normals = VertexNormals::new(&tris, positions.len());
            let d: Vec<Vec3> = positions
                .iter()
                .map(|_| Vec3::new(r() - 0.5, -0.0, r()))
                .collect();
            let t = r();
            let mut want_p: Vec<Vec3> =
                positions.iter().zip(&d).map(|(p, d)| *p + *d * t).collect();
            let mut want_n = Vec::new();
            let mut scratch = NormalsScratch::default();
            normals.moved_into(&mut want_p, rotation, shift, &mut scratch, &mut want_n);
            // A scratch used for a bigger mesh before, and a fresh one.
            let (big, big_tris) = cases().pop().unwrap_or_default();
            VertexNormals::new(&big_tris, big.len()).compute_into(
                &big,
                &mut scratch,
                &mut Vec::new(),
            );
            for mut scratch in [scratch, NormalsScratch::default()] {
                let lanes = scratch.points_mut(&normals);
                assert_eq!(lanes.len(), POINT_FLOATS * positions.len());
                // The fourth float of each point left as it was: never read.
                for (q, p) in lanes.chunks_exact_mut(POINT_FLOATS).zip(&positions) {
                    q[..3].copy_from_slice(&p.to_array());
                }
                let dc: Vec<f32> = d.iter().flat_map(|d| [d.x, d.y, d.z, -0.0]).collect();
                add_scaled(lanes, &dc, t);
                let (mut got_p, mut got_n) = (vec![Vec3::X], Vec::new());
                normals.moved_from_lanes(rotation, shift, &mut scratch, &mut got_p, &mut got_n);
                assert_eq!(bits(&got_p), bits(&want_p), "{} points", positions.len());
                assert_eq!(bits(&got_n), bits(&want_n), "{} points", positions.len());
            }
        }
        let x = [
            0.0,
            -0.0,
            1.5,
            f32::NAN,
            f32::INFINITY,
            -3.25,
            7.0,
            -0.0,
            0.5,
            1e30,
        ];
        let d = [-0.0, -0.0, 0.1, 1.0, -1.0, 0.0, f32::NAN, 0.0, 1e-30, 1e30];
        for t in [0.0, 0.3, 1.0, -0.0, -0.7] {
            let mut got = x;
            add_scaled(&mut got, &d, t);
            let mut sum = [f32::NAN; 10];
            scaled_sum_into(&mut sum, &x, &d, t);
            for (((g, s), x), d) in got.iter().zip(sum).zip(x).zip(d) {
                assert_eq!(g.to_bits(), (x + d * t).to_bits(), "{x} + {d} * {t}");
                assert_eq!(s.to_bits(), g.to_bits(), "{x} + {d} * {t}");
            }
        }
    }

    /// A way out's kernel.
    #[cfg(target_arch = "x86_64")]
    #[allow(unsafe_code)]
    type Kernel = unsafe fn(&[f32], bool, Turn, &mut [Vec3]);

    /// The AVX2 way out (eight at a time, transposed in, interleaved out)
    /// writes what the plain one writes, for every count up to a few blocks
    /// and a tail, normalised or not, turned, shifted or neither (zero and
    /// NaN sums, signed zeros and garbage in the fourth floats among them).
    #[test]
    fn the_way_out_is_the_plain_one() {
        let mut r = rng(3);
        let m = Mat3::from_quat(glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.2, 2.0))
            .to_cols_array();
        for n in 0..=27 {
            let mut src: Vec<f32> = (0..POINT_FLOATS * n).map(|_| r() - 0.5).collect();
            for (k, v) in src.chunks_exact_mut(POINT_FLOATS).enumerate() {
                match k % 5 {
                    0 => v[..3].copy_from_slice(&[0.0, -0.0, 0.0]),
                    1 => v[k % 3] = -0.0,
                    2 => v[1] = f32::NAN,
                    _ => v[3] = f32::INFINITY,
                }
            }
            src.extend([f32::NAN; 5]); // beyond the vectors: never read
            for normalise in [false, true] {
                for turn in [None, Some((&m, None)), Some((&m, Some([0.5, -0.0, -2.0])))] {
                    let mut want = vec![Vec3::ZERO; n];
                    write_plain(&src, normalise, turn, &mut want);
                    for cpu in [None, avx2()] {
                        let mut got = vec![Vec3::NAN; n];
                        write_out(cpu, &src, normalise, turn, &mut got);
                        let at = format!("{n} vectors, {normalise}, {turn:?}, {cpu:?}");
                        assert_eq!(bits(&got), bits(&want), "{at}");
                    }
                    // Each kernel, whichever `write_out` picks here.
                    #[cfg(target_arch = "x86_64")]
                    #[allow(unsafe_code)]
                    for kernel in [
                        avx2().map(|_| write_out_avx2 as Kernel),
                        avx512().map(|_| write_out_avx512 as Kernel),
                    ]
                    .into_iter()
                    .flatten()
                    {
                        let mut got = vec![Vec3::NAN; n];
                        // SAFETY: each kernel only where the CPU has what
                        // it needs; `src` holds four floats a vector.
                        unsafe { kernel(&src[..], normalise, turn, &mut got[..]) };
                        let at = format!("{n} vectors, {normalise}, {turn:?}, {kernel:?}");
                        assert_eq!(bits(&got), bits(&want), "{at}");
                    }
                }
            }
        }
    }

    /// The last displacements added as the points are moved out give what
    /// adding them lane by lane and then moving the points give, bit for
    /// bit, with every kernel (one point at a time, AVX2, AVX-512 where
    /// the CPU has them), for none to six stages, from the lanes or from a
    /// base, over counts with and without a tail.
    #[test]
    fn adding_as_the_points_move_out_is_adding_then_moving() {
        let rotation = Mat3::from_quat(glam::Quat::from_rotation_x(0.9));
        let shift = Vec3::new(0.25, -1.0, 3.0);
        let m = rotation.to_cols_array();
        let mut r = rng(5);
        for (positions, tris) in cases() {
            let n = positions.len();
            let normals = VertexNormals::new(&tris, n);
            let lanes: Vec<f32> = positions
                .iter()
                .flat_map(|p| [p.x, p.y, p.z, 0.0])
                .collect();
            let ds: Vec<Vec<f32>> = (0..6)
                .map(|_| {
                    let d = |k: usize| if k % 4 == 3 { -0.0 } else { r() - 0.5 };
                    (0..4 * n).map(d).collect()
                })
                .collect();
            let ts = [0.3, 0.0, 1.0, 0.7, -0.0, 0.5];
            for count in [0, 1, 2, 3, 4, 6] {
                let stages: Vec<(&[f32], f32)> = ds
                    .iter()
                    .zip(ts)
                    .take(count)
                    .map(|(d, t)| (&d[..], t))
                    .collect();
                let mut want = lanes.clone();
                for (d, t) in &stages {
                    add_scaled(&mut want, d, *t);
                }
                let points: Vec<Vec3> = want
                    .chunks_exact(4)
                    .map(|q| Vec3::new(q[0], q[1], q[2]))
                    .collect();
                let want_p: Vec<Vec3> = points.iter().map(|p| rotation * *p + shift).collect();
                let want_n: Vec<Vec3> = crate::triangle_vertex_normals(&points, &tris)
                    .iter()
                    .map(|v| rotation * *v)
                    .collect();
                for from_base in [false, true] {
                    let base = from_base.then_some(&lanes[..]);
                    let start = || match from_base {
                        true => vec![f32::NAN; 4 * n],
                        false => lanes.clone(),
                    };
                    for (cpu, wide) in [(None, None), (avx2(), None), (avx2(), avx512())] {
                        let (mut p, mut out) = (start(), vec![Vec3::NAN; n]);
                        add_moved(
                            cpu,
                            wide,
                            &mut p,
                            base,
                            &stages,
                            &m,
                            shift.to_array(),
                            &mut out,
                        );
                        let at =
                            format!("{n} points, {count} stages, {from_base}, {cpu:?} {wide:?}");
                        let lane_bits =
                            |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                        assert_eq!(lane_bits(&p), lane_bits(&want), "{at}");
                        assert_eq!(bits(&out), bits(&want_p), "{at}");
                    }
                    let mut scratch = NormalsScratch::default();
                    scratch.points_mut(&normals).copy_from_slice(&start());
                    let (mut got_p, mut got_n) = (vec![Vec3::X; 2], Vec::new());
                    normals.moved_from_lanes_adding(
                        base,
                        &stages,
                        rotation,
                        shift,
                        &mut scratch,
                        &mut got_p,
                        &mut got_n,
                    );
                    assert_eq!(bits(&got_p), bits(&want_p), "{n} points, {count} stages");
                    assert_eq!(bits(&got_n), bits(&want_n), "{n} points, {count} stages");
                }
            }
        }
    }

    /// Cache-aligned floats start on a line, keep what they held as they
    /// grow or shrink, and fill what is new.
    #[test]
    fn cache_aligned_floats_keep_their_values() {
        let mut a = CacheAligned::from(vec![1.0, -0.0, 3.0]);
        assert_eq!(
            a.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            [1.0f32, -0.0, 3.0].map(f32::to_bits)
        );
        for len in [3, 40, 17, 0, 5] {
            let before: Vec<f32> = a.to_vec();
            a.resize(len, 9.0);
            assert_eq!(a.len(), len);
            assert_eq!(a.as_ptr() as usize % 64, 0, "{len} floats");
            let kept = before.len().min(len);
            assert_eq!(a[..kept], before[..kept]);
            assert!(a[kept..].iter().all(|&x| x == 9.0));
        }
        assert!(CacheAligned::default().is_empty());
    }

    /// Positions of another length go to the plain function, over the
    /// triangles kept.
    #[test]
    fn another_length_falls_back_to_the_plain_function() {
        let tris = [[0, 1, 2], [2, 3, 4]];
        let normals = VertexNormals::new(&tris, 3);
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE];
        let (mut scratch, mut got) = (NormalsScratch::default(), Vec::new());
        normals.compute_into(&p, &mut scratch, &mut got);
        assert_eq!(got, crate::triangle_vertex_normals(&p, &tris[..1]));
        let mut moved = p;
        normals.moved_into(&mut moved, Mat3::IDENTITY, Vec3::X, &mut scratch, &mut got);
        assert_eq!(moved[4], Vec3::ONE + Vec3::X);
    }
}
