//! Vertex normals of one triangle list, prepared once for many frames.
//!
//! [`crate::triangle_vertex_normals_into`] scatters each triangle's area
//! vector into its three vertices: about 90 instructions a triangle. A
//! [`VertexNormals`] keeps the triangles' corners by column and, for every
//! eight vertices, their triangles in a table eight wide, so that a frame is
//! three passes over plain arrays: the area vectors eight triangles at a
//! time, their sums eight vertices at a time, and the rigid motion of points
//! and normals. With AVX2 (checked at run time) the area pass gathers eight
//! corners' coordinates an instruction and writes each area vector as
//! x y z 0, which the sum pass loads whole (three gathers a row were
//! slower); without it a frame takes the plain function (the
//! same passes one lane at a time were 4x slower than it: they stay as the
//! reference of the AVX2 passes in the tests).
//! Each vertex's sum runs over the same triangles in the same order as the
//! plain function's, so the normals are bit for bit its own.
//!
//! A caller that builds its points by coordinate (a frame: rest points plus
//! displacements, [`NormalsScratch::points_mut`], [`add_scaled`]) hands them
//! over with no pass to take `Vec3`s apart
//! ([`VertexNormals::moved_from_lanes`]); the rigid motion writes the moved
//! points and turned normals as `Vec3`s straight from the lanes.

use glam::{Mat3, Vec3};

/// Lanes of a pass (eight f32 in an AVX2 register).
const LANES: usize = 8;

/// The triangles around every vertex of one mesh, for its normals frame
/// after frame ([`VertexNormals::compute_into`], or
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
    /// Their corners by column, padded with vertex 0 to a multiple of eight.
    corners: [Vec<u32>; 3],
    /// Per eight vertices: where its rows start in `table` and how many.
    groups: Vec<(u32, u32)>,
    /// Row-major, eight wide: row `r` of a group holds the `r`-th triangle
    /// of each of its vertices (ascending; a triangle naming a vertex twice
    /// is there twice, as the scatter adds it twice), or `dummy()`, whose
    /// area vector is -0 (x + -0 = x for every x, so padding changes no bit).
    table: Vec<u32>,
}

/// Buffers a frame's normals use, kept between frames so that a frame
/// allocates nothing.
#[derive(Clone, Debug, Default)]
pub struct NormalsScratch {
    /// Points by coordinate.
    xyz: [Vec<f32>; 3],
    /// Area vectors as x y z 0, four floats a triangle (and the dummy's
    /// -0 -0 -0 0 at the end): the sum pass loads a triangle's three in one
    /// move where three gathers were slower.
    area: Vec<f32>,
    /// Normals by coordinate.
    normal: [Vec<f32>; 3],
}

impl VertexNormals {
    /// The triangles around each of `vertices` vertices; triangles with an
    /// index out of range are dropped (as the plain function skips them).
    pub fn new(triangles: &[[u32; 3]], vertices: usize) -> VertexNormals {
        let triangles: Vec<[u32; 3]> = triangles
            .iter()
            .filter(|t| t.iter().all(|&i| (i as usize) < vertices))
            .copied()
            .collect();
        let padded = triangles.len().next_multiple_of(LANES);
        let corners = [0, 1, 2].map(|c| {
            let mut v: Vec<u32> = triangles.iter().map(|t| t[c]).collect();
            v.resize(padded, 0);
            v
        });
        let mut around = vec![Vec::new(); vertices];
        for (k, t) in triangles.iter().enumerate() {
            for &i in t {
                around[i as usize].push(k as u32);
            }
        }
        let dummy = padded as u32;
        let (mut groups, mut table) = (Vec::new(), Vec::new());
        for group in around.chunks(LANES) {
            let width = group.iter().map(Vec::len).max().unwrap_or(0);
            groups.push((table.len() as u32, width as u32));
            for r in 0..width {
                for lane in 0..LANES {
                    let t = group.get(lane).and_then(|a| a.get(r)).copied();
                    table.push(t.unwrap_or(dummy));
                }
            }
        }
        VertexNormals {
            vertices,
            triangles,
            corners,
            groups,
            table,
        }
    }

    /// Number of vertices it was made for.
    pub fn vertices(&self) -> usize {
        self.vertices
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
        let cpu = avx2();
        if positions.len() != self.vertices || cpu.is_none() {
            crate::triangle_vertex_normals_into(positions, &self.triangles, out);
            return;
        }
        self.normals_by_coordinate(positions, scratch, cpu);
        let [x, y, z] = &scratch.normal;
        out.clear();
        out.extend((0..self.vertices).map(|v| Vec3::new(x[v], y[v], z[v])));
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
        let cpu = avx2();
        if positions.len() != self.vertices || cpu.is_none() {
            plain_moved(positions, &self.triangles, rotation, shift, normals);
            return;
        }
        let [xs, ys, zs] = scratch.points_mut(self);
        for (p, ((x, y), z)) in positions
            .iter()
            .zip(xs.iter_mut().zip(ys.iter_mut()).zip(zs.iter_mut()))
        {
            (*x, *y, *z) = (p.x, p.y, p.z);
        }
        self.moved_lanes(cpu, rotation, shift, scratch, positions, normals);
    }

    /// [`VertexNormals::moved_into`] for points the caller wrote by
    /// coordinate into [`NormalsScratch::points_mut`]: no pass of its own
    /// to take them apart. `positions` and `normals` are replaced by the
    /// moved points and their turned normals, bit for bit what
    /// [`VertexNormals::moved_into`] gives for the same points.
    pub fn moved_from_lanes(
        &self,
        rotation: Mat3,
        shift: Vec3,
        scratch: &mut NormalsScratch,
        positions: &mut Vec<Vec3>,
        normals: &mut Vec<Vec3>,
    ) {
        let cpu = avx2();
        if cpu.is_none() {
            let [xs, ys, zs] = scratch.points_mut(self);
            positions.clear();
            positions.extend(lanes_to_points(xs, ys, zs));
            plain_moved(positions, &self.triangles, rotation, shift, normals);
            return;
        }
        positions.resize(self.vertices, Vec3::ZERO);
        self.moved_lanes(cpu, rotation, shift, scratch, positions, normals);
    }

    /// The normals of the points in `scratch.xyz` turned by `rotation` into
    /// `normals`, and the points moved into `positions` (as long as
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
        self.normals_of_lanes(scratch, cpu);
        let m = rotation.to_cols_array();
        // Every value is written below: no clearing pass.
        normals.resize(self.vertices, Vec3::ZERO);
        turn_into(cpu, &scratch.normal, &m, None, normals);
        turn_into(cpu, &scratch.xyz, &m, Some(shift.to_array()), positions);
    }

    /// The three passes over `positions`, into `scratch.normal`.
    fn normals_by_coordinate(&self, positions: &[Vec3], s: &mut NormalsScratch, cpu: Option<Avx2>) {
        let [xs, ys, zs] = s.points_mut(self);
        for (p, ((x, y), z)) in positions
            .iter()
            .zip(xs.iter_mut().zip(ys.iter_mut()).zip(zs.iter_mut()))
        {
            (*x, *y, *z) = (p.x, p.y, p.z);
        }
        self.normals_of_lanes(s, cpu);
    }

    /// The area and sum passes over the points in `s.xyz`, into `s.normal`.
    fn normals_of_lanes(&self, s: &mut NormalsScratch, cpu: Option<Avx2>) {
        // Sized here whoever filled them: the gathers below rely on it.
        s.points_mut(self);
        let padded_vertices = self.groups.len() * LANES;
        let padded = self.corners[0].len();
        for c in 0..3 {
            s.area.resize(4 * (padded + 1), 0.0);
            s.area[4 * padded + c] = -0.0; // the dummy
            s.normal[c].resize(padded_vertices, 0.0);
        }
        match cpu {
            #[cfg(target_arch = "x86_64")]
            Some(Avx2(())) => {
                // SAFETY: an `Avx2` exists only when the CPU has AVX2; the
                // indices are checked by the callee's contract: `new` kept
                // only corners below `vertices` (padding is vertex 0, and a
                // padded triangle exists only with a real one, so
                // `vertices > 0`), `xyz` holds `vertices` or more values, and
                // `table` names triangles below `padded` or the dummy at
                // `padded`, whose four floats each `area` holds.
                #[allow(unsafe_code)]
                unsafe {
                    areas_avx2(&self.corners, &s.xyz, &mut s.area);
                    sums_avx2(&self.groups, &self.table, &s.area, &mut s.normal);
                }
            }
            _ => {
                areas_plain(&self.corners, &s.xyz, &mut s.area);
                sums_plain(&self.groups, &self.table, &s.area, &mut s.normal);
            }
        }
    }
}

impl NormalsScratch {
    /// The lanes of the points by coordinate, [`VertexNormals::vertices`]
    /// of `normals` long each, for a caller that builds a frame's points
    /// there before [`VertexNormals::moved_from_lanes`] (they hold what the
    /// last frame left).
    pub fn points_mut(&mut self, normals: &VertexNormals) -> [&mut [f32]; 3] {
        // The sum pass moves eight vertices at a time: padded to its groups.
        let padded = (normals.groups.len() * LANES).max(1);
        for xyz in &mut self.xyz {
            xyz.resize(padded, 0.0);
        }
        let n = normals.vertices;
        let [x, y, z] = &mut self.xyz;
        [&mut x[..n], &mut y[..n], &mut z[..n]]
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

/// Points (or normals) from their lanes by coordinate.
fn lanes_to_points<'a>(
    x: &'a [f32],
    y: &'a [f32],
    z: &'a [f32],
) -> impl Iterator<Item = Vec3> + 'a {
    x.iter()
        .zip(y)
        .zip(z)
        .map(|((&x, &y), &z)| Vec3::new(x, y, z))
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

/// One lane of the area pass: (b - a) x (c - a), as glam's `Vec3::cross`
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

/// One lane of the normalisation, as the plain function does it in `Vec3`:
/// ((x x + y y) + z z), then times 1 / sqrt; +Z for a zero (or NaN) sum.
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

/// `m * v (+ shift)` for the first `out.len()` column vectors of `cols`,
/// as `Vec3`s into `out` ([`turn_one`] each): the rigid motion and the
/// way back from lanes in one pass, eight vectors at a time with AVX2.
fn turn_into(
    cpu: Option<Avx2>,
    cols: &[Vec<f32>; 3],
    m: &[f32; 9],
    shift: Option<[f32; 3]>,
    out: &mut [Vec3],
) {
    assert!(cols.iter().all(|c| c.len() >= out.len()), "lanes too short");
    #[cfg(target_arch = "x86_64")]
    if let Some(Avx2(())) = cpu {
        // SAFETY: an `Avx2` exists only when the CPU has AVX2; the columns
        // were just checked to be long enough.
        #[allow(unsafe_code)]
        unsafe {
            return turn_into_avx2(cols, m, shift, out);
        }
    }
    let _ = cpu;
    turn_plain(cols, m, shift, out);
}

/// [`turn_into`] one vector at a time (the reference of the AVX2 pass).
fn turn_plain(cols: &[Vec<f32>; 3], m: &[f32; 9], shift: Option<[f32; 3]>, out: &mut [Vec3]) {
    let [xs, ys, zs] = cols;
    for (o, ((&a, &b), &c)) in out.iter_mut().zip(xs.iter().zip(ys).zip(zs)) {
        *o = turn_one(m, shift, a, b, c);
    }
}

/// [`turn_into`] eight vectors at a time: the products and sums of
/// [`turn_one`] lane by lane, then eight x, y and z interleaved into 24
/// floats by permutes and blends (moves only: no value changes).
///
/// # Safety
/// The CPU has AVX2; each of `cols` holds at least `out.len()` values.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2")]
unsafe fn turn_into_avx2(
    cols: &[Vec<f32>; 3],
    m: &[f32; 9],
    shift: Option<[f32; 3]>,
    out: &mut [Vec3],
) {
    use std::arch::x86_64::*;
    let n = out.len();
    let whole = n - n % LANES;
    // SAFETY: the caller's contract; `Vec3` is three f32 in a row
    // (`repr(C)`), so `out` is `3 n` floats.
    unsafe {
        let mm = m.map(|v| _mm256_set1_ps(v));
        let shift = shift.map(|s| s.map(|v| _mm256_set1_ps(v)));
        // Which vector each float of the three stores comes from: the
        // stores hold x0 y0 z0 x1 y1 z1 x2 y2 | z2 x3 y3 z3 x4 y4 z4 x5 |
        // y5 z5 x6 y6 z6 x7 y7 z7.
        let from = [
            _mm256_setr_epi32(0, 0, 0, 1, 1, 1, 2, 2),
            _mm256_setr_epi32(2, 3, 3, 3, 4, 4, 4, 5),
            _mm256_setr_epi32(5, 5, 6, 6, 6, 7, 7, 7),
        ];
        let dst = out.as_mut_ptr().cast::<f32>();
        for k in (0..whole).step_by(LANES) {
            let a = _mm256_loadu_ps(cols[0].as_ptr().add(k));
            let b = _mm256_loadu_ps(cols[1].as_ptr().add(k));
            let c = _mm256_loadu_ps(cols[2].as_ptr().add(k));
            let row = |i: usize| {
                let r = _mm256_add_ps(
                    _mm256_add_ps(_mm256_mul_ps(mm[i], a), _mm256_mul_ps(mm[i + 3], b)),
                    _mm256_mul_ps(mm[i + 6], c),
                );
                match shift {
                    Some(s) => _mm256_add_ps(r, s[i]),
                    None => r,
                }
            };
            let (x, y, z) = (row(0), row(1), row(2));
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
        *o = turn_one(m, shift, cols[0][i], cols[1][i], cols[2][i]);
    }
}

/// The area pass one lane at a time (the reference of the AVX2 pass).
fn areas_plain(corners: &[Vec<u32>; 3], xyz: &[Vec<f32>; 3], area: &mut [f32]) {
    let p = |i: u32| [0, 1, 2].map(|c| xyz[c][i as usize]);
    for k in 0..corners[0].len() {
        let a = cross_of(p(corners[0][k]), p(corners[1][k]), p(corners[2][k]));
        for c in 0..3 {
            area[4 * k + c] = a[c];
        }
    }
}

/// The sum-and-normalise pass one lane at a time.
fn sums_plain(groups: &[(u32, u32)], table: &[u32], area: &[f32], normal: &mut [Vec<f32>; 3]) {
    for (g, &(start, width)) in groups.iter().enumerate() {
        for lane in 0..LANES {
            let mut sum = [0.0f32; 3];
            for r in 0..width as usize {
                let t = table[start as usize + r * LANES + lane] as usize;
                for c in 0..3 {
                    sum[c] += area[4 * t + c];
                }
            }
            let n = unit(sum);
            for c in 0..3 {
                normal[c][g * LANES + lane] = n[c];
            }
        }
    }
}

/// The area pass, eight triangles at a time.
///
/// # Safety
/// The CPU has AVX2; every corner indexes each of `xyz`; the three corner
/// columns hold as many values as the first, a multiple of eight, and
/// `area` four times as many.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2")]
unsafe fn areas_avx2(corners: &[Vec<u32>; 3], xyz: &[Vec<f32>; 3], area: &mut [f32]) {
    use std::arch::x86_64::*;
    let n = corners[0].len();
    // SAFETY: the caller's contract (indices in range, lengths as said).
    unsafe {
        let load =
            |c: usize, k: usize| _mm256_loadu_si256(corners[c].as_ptr().add(k).cast::<__m256i>());
        let gather = |c: usize, i: __m256i| _mm256_i32gather_ps::<4>(xyz[c].as_ptr(), i);
        for k in (0..n).step_by(LANES) {
            let (ia, ib, ic) = (load(0, k), load(1, k), load(2, k));
            let (ax, ay, az) = (gather(0, ia), gather(1, ia), gather(2, ia));
            let e1 = [
                _mm256_sub_ps(gather(0, ib), ax),
                _mm256_sub_ps(gather(1, ib), ay),
                _mm256_sub_ps(gather(2, ib), az),
            ];
            let e2 = [
                _mm256_sub_ps(gather(0, ic), ax),
                _mm256_sub_ps(gather(1, ic), ay),
                _mm256_sub_ps(gather(2, ic), az),
            ];
            let cross = |i: usize, j: usize| {
                _mm256_sub_ps(_mm256_mul_ps(e1[i], e2[j]), _mm256_mul_ps(e2[i], e1[j]))
            };
            // Eight x y z 0 in a row: a 4 x 8 transpose (moves only).
            let (x, y, z, w) = (cross(1, 2), cross(2, 0), cross(0, 1), _mm256_setzero_ps());
            let (t0, t1) = (_mm256_unpacklo_ps(x, y), _mm256_unpackhi_ps(x, y));
            let (t2, t3) = (_mm256_unpacklo_ps(z, w), _mm256_unpackhi_ps(z, w));
            // Triangles k and k + 4, k + 1 and k + 5, ... in the two halves.
            let r0 = _mm256_shuffle_ps::<0x44>(t0, t2);
            let r1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
            let r2 = _mm256_shuffle_ps::<0x44>(t1, t3);
            let r3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
            let at = area.as_mut_ptr().add(4 * k);
            _mm256_storeu_ps(at, _mm256_permute2f128_ps::<0x20>(r0, r1));
            _mm256_storeu_ps(at.add(8), _mm256_permute2f128_ps::<0x20>(r2, r3));
            _mm256_storeu_ps(at.add(16), _mm256_permute2f128_ps::<0x31>(r0, r1));
            _mm256_storeu_ps(at.add(24), _mm256_permute2f128_ps::<0x31>(r2, r3));
        }
    }
}

/// The sum-and-normalise pass, eight vertices at a time.
///
/// # Safety
/// The CPU has AVX2; every entry `t` of `table` has its four floats at
/// `4 t` in `area`; each group's rows lie in `table`; each `normal` column
/// holds eight values per group.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2")]
unsafe fn sums_avx2(
    groups: &[(u32, u32)],
    table: &[u32],
    area: &[f32],
    normal: &mut [Vec<f32>; 3],
) {
    use std::arch::x86_64::*;
    // SAFETY: the caller's contract (indices in range, lengths as said).
    unsafe {
        let zero = _mm256_setzero_ps();
        let one = _mm256_set1_ps(1.0);
        for (g, &(start, width)) in groups.iter().enumerate() {
            // Lanes j and j + 4 summed as x y z 0 in the halves of acc[j]:
            // a triangle's area vector in one load, each lane's sum the
            // same additions in the same order; one transpose a group.
            let mut acc = [zero; 4];
            for r in 0..width as usize {
                let at = table.as_ptr().add(start as usize + r * LANES);
                let l = |j: usize| _mm_loadu_ps(area.as_ptr().add(4 * *at.add(j) as usize));
                for (j, acc) in acc.iter_mut().enumerate() {
                    *acc = _mm256_add_ps(*acc, _mm256_set_m128(l(j + 4), l(j)));
                }
            }
            let (t0, t1) = (
                _mm256_unpacklo_ps(acc[0], acc[1]),
                _mm256_unpacklo_ps(acc[2], acc[3]),
            );
            let (t2, t3) = (
                _mm256_unpackhi_ps(acc[0], acc[1]),
                _mm256_unpackhi_ps(acc[2], acc[3]),
            );
            let sum = [
                _mm256_shuffle_ps::<0x44>(t0, t1),
                _mm256_shuffle_ps::<0xEE>(t0, t1),
                _mm256_shuffle_ps::<0x44>(t2, t3),
            ];
            // No fused multiply-add: the plain function rounds each product.
            let len2 = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(sum[0], sum[0]), _mm256_mul_ps(sum[1], sum[1])),
                _mm256_mul_ps(sum[2], sum[2]),
            );
            let r = _mm256_div_ps(one, _mm256_sqrt_ps(len2));
            let positive = _mm256_cmp_ps::<_CMP_GT_OQ>(len2, zero);
            let unit = [
                _mm256_and_ps(positive, _mm256_mul_ps(sum[0], r)),
                _mm256_and_ps(positive, _mm256_mul_ps(sum[1], r)),
                _mm256_blendv_ps(one, _mm256_mul_ps(sum[2], r), positive),
            ];
            for c in 0..3 {
                _mm256_storeu_ps(normal[c].as_mut_ptr().add(g * LANES), unit[c]);
            }
        }
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

    /// Both passes (AVX2 where the CPU has it, and one lane at a time) give
    /// the plain function's normals bit for bit, also after the points moved.
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
                    normals.normals_by_coordinate(&positions, &mut scratch, cpu);
                    let [x, y, z] = &scratch.normal;
                    let got: Vec<Vec3> = (0..positions.len())
                        .map(|v| Vec3::new(x[v], y[v], z[v]))
                        .collect();
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

    /// The rigid motion turns points and normals as the plain code would
    /// (both turn passes: AVX2 where the CPU has it, and the plain one).
    #[test]
    fn a_rigid_motion_turns_points_and_normals() {
        let m = Mat3::from_quat(glam::Quat::from_rotation_x(-1.1)).to_cols_array();
        for cpu in [None, avx2()] {
            let cols = [
                vec![1.0, -0.0, 3.5],
                vec![0.25, 2.0, -0.0],
                vec![-7.0, 0.5, 0.0],
            ];
            let want: Vec<Vec3> = (0..3)
                .map(|k| Mat3::from_cols_array(&m) * Vec3::new(cols[0][k], cols[1][k], cols[2][k]))
                .collect();
            let mut got = vec![Vec3::NAN; 3];
            turn_into(cpu, &cols, &m, None, &mut got);
            assert_eq!(bits(&got), bits(&want), "{cpu:?}");
        }
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
            assert_eq!((moved, got), (want_p, want_n));
        }
    }

    /// Points written by coordinate give what the same points given as
    /// `Vec3`s give, bit for bit, and displacements added lane by lane
    /// what `p += d * t` gives (signed zeros, NaN and infinities among them).
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
                for (c, lane) in lanes.into_iter().enumerate() {
                    for (x, p) in lane.iter_mut().zip(&positions) {
                        *x = p[c];
                    }
                    let dc: Vec<f32> = d.iter().map(|d| d[c]).collect();
                    add_scaled(lane, &dc, t);
                }
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

    /// The AVX2 turn (eight at a time, interleaved by permutes) writes what
    /// the plain one writes, for every count up to a few blocks and a tail.
    #[test]
    fn the_turn_into_vec3s_is_the_plain_one() {
        let mut r = rng(3);
        let m = Mat3::from_quat(glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.2, 2.0))
            .to_cols_array();
        for n in 0..=27 {
            let cols = [0, 1, 2].map(|c| {
                let mut v: Vec<f32> = (0..n).map(|_| r() - 0.5).collect();
                if n > c {
                    v[c] = -0.0;
                }
                v.resize(n.next_multiple_of(LANES), f32::NAN); // padding never read
                v
            });
            for shift in [None, Some([0.5, -0.0, -2.0])] {
                let mut want = vec![Vec3::ZERO; n];
                turn_plain(&cols, &m, shift, &mut want);
                for cpu in [None, avx2()] {
                    let mut got = vec![Vec3::NAN; n];
                    turn_into(cpu, &cols, &m, shift, &mut got);
                    assert_eq!(bits(&got), bits(&want), "{n} vectors, {shift:?}, {cpu:?}");
                }
            }
        }
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
