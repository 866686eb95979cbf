//! The compact replay file (`.csrbf`): everything needed to replay the
//! deformations of a control file for any number of frames, in a small
//! versioned binary format that loads back bit-exact.
//!
//! Layout (all little-endian):
//!
//! ```text
//! magic "CSRBF\0" | version u16 (4, or 5 with a mesh stamp) | combine u16 (0 chain, 1 add) | stages u32
//! per stage:
//!   kernel u8 | polynomial u8 | reserved u16 | radius f64 | phase f64 | n u32
//!   starts 3n f64 | coefficients 3n f64
//!   if linear: centre 3 f64 | scale f64 | coefficients 12 f64
//!   order n u32
//!   region: tag u8 (0 all, 1 sphere, 2 box, 3 vertices, 4 group, 5 falloff,
//!           6 weights: n u32, n vertices u32, n weights f32; 7 connected:
//!           distance f64, from u8 (0 starts, 1 handle)) and its data
//!   sweep: step u32 | steps u32 (0 0: not a sweep's step)
//! version 5 only: mesh stamp: flag u8 (1) | vertices u32 | faces flag u8
//!   (0 unknown, 1 known) | faces' hash u64 when known
//! checksum u64: FNV-1a of every byte before it
//! ```
//!
//! Field by field: the kernel (C0-C6) and polynomial (none, linear), the
//! radius of support R, the stage's phase within the file (in [0, 1]), the
//! starts and their coefficients alpha, the affine part (centre, scale and
//! the 4 coefficient vectors of p(x)) when linear, the order the system was
//! factored in (kept so a refit is bit-exact), the region, and which step
//! of a fold-free sweep the stage is, and (version 5) the mesh whose vertices
//! its regions list by index ([`MeshStamp`]). A file without a stamp is
//! written as version 4, so builds before the stamp read it. Version 3 files
//! (no weights or connected regions), version 2 files (no sweep) and version
//! 1 files (no combine, no phase: chained, every phase 1) still read.
//!
//! The checksum proves the bytes were not damaged; the values are checked
//! too: a NaN or infinite start, coefficient, affine term or phase is refused.

use glam::DVec3;

use crate::deformation::{Affine, Deformation};
use crate::error::{Error, FormatError, Result};
use crate::kernel::{Kernel, Polynomial};
use crate::region::{Origin, Region};
use crate::stage::Combine;
use crate::stage::{FittedStage, SweepStep};

/// The file's first bytes.
pub const MAGIC: &[u8; 6] = b"CSRBF\0";
/// The version this build writes (it reads this one and versions 1 to 4).
pub const VERSION: u16 = 5;

/// What a `.csrbf` file holds: deformations with their regions and phases,
/// and how they combine.
#[derive(Clone, Debug, PartialEq)]
pub struct Replay {
    /// Deformation, region and phase of each stage, in order.
    pub stages: Vec<FittedStage>,
    /// How the stages act together.
    pub combine: Combine,
    /// The mesh its regions' vertex indices refer to, when they list
    /// vertices of one (files before version 5: not known).
    pub mesh: Option<MeshStamp>,
}

/// Which mesh a file's regions were made on, when they list its vertices
/// by index (a connected region resolved on it, a vertex list or weights):
/// replayed on another mesh the same indices name other vertices, and the
/// edit lands in scattered places. A replay checks it ([`MeshStamp::check`])
/// before moving anything.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshStamp {
    /// Its vertices.
    pub vertices: u32,
    /// Its faces' vertex indices hashed ([`MeshStamp::of`]), when known.
    pub faces: Option<u64>,
}

impl MeshStamp {
    /// The stamp of a mesh of `vertices` points and these faces (each a
    /// list of vertex indices); `None` faces when the caller has only the
    /// points. The faces' hash does not depend on their order, nor on which
    /// corner a face lists first (neither changes which vertex an index
    /// names), only on the set of faces and their orientation.
    pub fn of<'a>(vertices: usize, faces: Option<impl Iterator<Item = &'a [u32]>>) -> MeshStamp {
        MeshStamp {
            vertices: vertices.min(u32::MAX as usize) as u32,
            faces: faces.map(|faces| {
                faces.fold(0u64, |sum, f| {
                    // From its smallest corner on, its orientation kept.
                    let first = (0..f.len()).min_by_key(|&k| f[k]).unwrap_or(0);
                    let mut h = Fnv::new();
                    h.add(&(f.len() as u32).to_le_bytes());
                    for k in 0..f.len() {
                        h.add(&f[(first + k) % f.len()].to_le_bytes());
                    }
                    sum.wrapping_add(h.finish())
                })
            }),
        }
    }

    /// `Ok` when `mesh` (a stamp of the mesh about to be moved) is the one
    /// this stamp names: the same count of vertices and, where both know
    /// them, the same faces.
    pub fn check(&self, mesh: &MeshStamp) -> Result<()> {
        let same_faces = match (self.faces, mesh.faces) {
            (Some(a), Some(b)) => a == b,
            _ => true,
        };
        if self.vertices == mesh.vertices && same_faces {
            return Ok(());
        }
        let what = if self.vertices != mesh.vertices {
            format!(
                "it was fitted on a mesh of {} vertices, this one has {}",
                self.vertices, mesh.vertices
            )
        } else {
            format!(
                "it was fitted on a mesh of {} vertices with other faces (another mesh with as many vertices, or its polygons split into triangles)",
                self.vertices
            )
        };
        Err(FormatError::OtherMesh(what).into())
    }
}

impl Replay {
    /// The file's bytes ([`encode`], with its mesh stamp).
    pub fn to_bytes(&self) -> Vec<u8> {
        encode_for(&self.stages, self.combine, self.mesh)
    }

    /// Whether any stage's region lists vertices by index (so the file
    /// should carry the [`MeshStamp`] of the mesh they index).
    pub fn lists_vertices(stages: &[FittedStage]) -> bool {
        stages.iter().any(|s| s.region.lists_vertices())
    }

    /// Reads a file's bytes ([`decode`]).
    pub fn from_bytes(bytes: &[u8]) -> Result<Replay> {
        decode(bytes)
    }

    /// The rest points moved by every stage ([`crate::compose_with_groups`]).
    pub fn compose(
        &self,
        rest: &[glam::Vec3],
        groups: &dyn Fn(&str) -> Option<Vec<u32>>,
    ) -> Result<Vec<glam::Vec3>> {
        crate::stage::compose_with_groups(rest, &self.stages, self.combine, groups)
    }
}

/// A damaged file's error.
fn damaged(message: impl Into<String>) -> Error {
    FormatError::Damaged(message.into()).into()
}

/// Encodes deformations with their regions and phases (borrowed: nothing is
/// copied but into the bytes), without a mesh stamp.
pub fn encode(stages: &[FittedStage], combine: Combine) -> Vec<u8> {
    encode_for(stages, combine, None)
}

/// [`encode`] with the stamp of the mesh its regions' indices refer to.
pub fn encode_for(stages: &[FittedStage], combine: Combine, mesh: Option<MeshStamp>) -> Vec<u8> {
    let mut w = Vec::new();
    w.extend_from_slice(MAGIC);
    // Version 4 when there is no stamp: older builds read such a file.
    let version: u16 = if mesh.is_some() { VERSION } else { 4 };
    w.extend_from_slice(&version.to_le_bytes());
    w.extend_from_slice(&(combine as u16).to_le_bytes());
    w.extend_from_slice(&(stages.len() as u32).to_le_bytes());
    for FittedStage {
        deformation: d,
        region,
        phase,
        sweep,
        rigid_part,
    } in stages
    {
        w.push(d.kernel().code());
        w.push(d.polynomial() as u8);
        // Flags (what was a reserved zero: older builds read it and ignore
        // it): bit 0, a handle's rigid part.
        w.extend_from_slice(&u16::from(*rigid_part).to_le_bytes());
        w.extend_from_slice(&d.radius().to_le_bytes());
        w.extend_from_slice(&phase.to_le_bytes());
        w.extend_from_slice(&(d.starts().len() as u32).to_le_bytes());
        for v in d.starts().iter().chain(d.coefficients()) {
            put_vec(&mut w, *v);
        }
        if let Some(a) = d.affine() {
            put_vec(&mut w, a.center);
            w.extend_from_slice(&a.scale.to_le_bytes());
            for c in a.coefficients {
                put_vec(&mut w, c);
            }
        }
        for o in d.order() {
            w.extend_from_slice(&o.to_le_bytes());
        }
        put_region(&mut w, region);
        let (step, steps) = sweep.map_or((0, 0), |s| (s.index, s.count));
        w.extend_from_slice(&step.to_le_bytes());
        w.extend_from_slice(&steps.to_le_bytes());
    }
    // Version 5: the mesh stamp (a flag byte, then the vertices and, behind
    // a second flag, the faces' hash).
    match mesh {
        None => {}
        Some(m) => {
            w.push(1);
            w.extend_from_slice(&m.vertices.to_le_bytes());
            match m.faces {
                None => w.push(0),
                Some(h) => {
                    w.push(1);
                    w.extend_from_slice(&h.to_le_bytes());
                }
            }
        }
    }
    let sum = fnv1a(&w);
    w.extend_from_slice(&sum.to_le_bytes());
    w
}

/// Decodes a file made by [`encode`] (or a version 1 file), checking magic,
/// version, sizes, checksum and that every value is finite.
pub fn decode(bytes: &[u8]) -> Result<Replay> {
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        // The JSON `csrbf fit --out D.json` writes is for people to read.
        if bytes.trim_ascii_start().starts_with(b"{") {
            return Err(damaged(
                "it is JSON, the form `csrbf fit --out D.json` writes for people to read; \
                 deformations are read back only from .csrbf files (csrbf fit --out D.csrbf)",
            ));
        }
        return Err(damaged("it does not start with the csrbf magic bytes"));
    }
    if bytes.len() < 22 {
        return Err(damaged(format!("truncated: only {} bytes", bytes.len())));
    }
    let (body, tail) = bytes.split_at(bytes.len() - 8);
    let version = u16::from_le_bytes([bytes[6], bytes[7]]);
    if !(1..=VERSION).contains(&version) {
        return Err(damaged(format!(
            "version {version} is not supported (this build reads versions 1 to {VERSION})"
        )));
    }
    let mut sum = [0u8; 8];
    sum.copy_from_slice(tail);
    if u64::from_le_bytes(sum) != fnv1a(body) {
        return Err(damaged(
            "checksum mismatch: the file is damaged or truncated",
        ));
    }
    let mut r = Reader { b: body, at: 8 };
    let combine = match (version, r.u16("header")?) {
        (1, _) | (_, 0) => Combine::Chain,
        (_, 1) => Combine::Add,
        (_, c) => return Err(damaged(format!("unknown combine code {c}"))),
    };
    let count = r.u32("stage count")? as usize;
    let mut out = Vec::new();
    for s in 0..count {
        let kernel = Kernel::from_code(r.u8("kernel")?)
            .ok_or_else(|| damaged(format!("stage {s}: unknown kernel code")))?;
        let poly = match r.u8("polynomial")? {
            0 => Polynomial::None,
            1 => Polynomial::Linear,
            c => {
                return Err(damaged(format!("stage {s}: unknown polynomial code {c}")));
            }
        };
        let flags = r.u16("flags")?;
        let radius = r.f64("radius")?;
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(damaged(format!("stage {s}: radius {radius} is not valid")));
        }
        let phase = if version == 1 { 1.0 } else { r.f64("phase")? };
        if !(0.0..=1.0).contains(&phase) {
            return Err(damaged(format!(
                "stage {s}: phase {phase} is not within [0, 1]"
            )));
        }
        let n = r.u32("start count")? as usize;
        // Guard the allocations against a forged count.
        if n.saturating_mul(52) > r.b.len() - r.at.min(r.b.len()) {
            return Err(damaged(format!(
                "stage {s}: {n} starts do not fit in the file"
            )));
        }
        let starts = (0..n)
            .map(|_| r.vec("starts"))
            .collect::<Result<Vec<_>>>()?;
        let coefficients = (0..n)
            .map(|_| r.vec("coefficients"))
            .collect::<Result<Vec<_>>>()?;
        let affine = match poly {
            Polynomial::None => None,
            Polynomial::Linear => {
                let center = r.vec("polynomial centre")?;
                let scale = r.f64("polynomial scale")?;
                let mut c = [DVec3::ZERO; 4];
                for v in &mut c {
                    *v = r.vec("polynomial coefficients")?;
                }
                Some(Affine {
                    center,
                    scale,
                    coefficients: c,
                })
            }
        };
        let order = (0..n).map(|_| r.u32("order")).collect::<Result<Vec<_>>>()?;
        if order.iter().any(|&o| o as usize >= n) {
            return Err(damaged(format!(
                "stage {s}: order refers to a start that does not exist"
            )));
        }
        let region = get_region(&mut r)?;
        let finite = |what: &str, v: &[DVec3]| -> Result<()> {
            match v.iter().position(|x| !x.is_finite()) {
                Some(i) => Err(damaged(format!(
                    "stage {s}: {what} {i} is not finite (NaN or infinite)"
                ))),
                None => Ok(()),
            }
        };
        finite("start", &starts)?;
        finite("coefficient", &coefficients)?;
        if let Some(a) = &affine {
            finite("affine coefficient", &a.coefficients)?;
            if !(a.center.is_finite() && a.scale.is_finite() && a.scale != 0.0) {
                return Err(damaged(format!(
                    "stage {s}: the affine part's centre or scale is not finite"
                )));
            }
        }
        let sweep = if version >= 3 {
            let (index, count) = (r.u32("sweep step")?, r.u32("sweep steps")?);
            match (index, count) {
                (0, 0) => None,
                (i, c) if i < c && c as usize <= crate::MAX_STEPS => {
                    Some(SweepStep { index: i, count: c })
                }
                _ => {
                    return Err(damaged(format!(
                        "stage {s}: sweep step {index} of {count} is not valid"
                    )));
                }
            }
        } else {
            None
        };
        out.push(FittedStage {
            deformation: Deformation::from_parts(
                kernel,
                radius,
                starts,
                coefficients,
                affine,
                order,
            ),
            region,
            phase,
            sweep,
            rigid_part: flags & 1 == 1,
        });
    }
    let mesh = if version >= 5 {
        match r.u8("mesh stamp")? {
            0 => None,
            1 => {
                let vertices = r.u32("mesh stamp")?;
                let faces = match r.u8("mesh stamp")? {
                    0 => None,
                    1 => Some(r.u64("mesh stamp")?),
                    f => return Err(damaged(format!("unknown mesh stamp faces flag {f}"))),
                };
                Some(MeshStamp { vertices, faces })
            }
            f => return Err(damaged(format!("unknown mesh stamp flag {f}"))),
        }
    } else {
        None
    };
    if r.at != r.b.len() {
        return Err(damaged(format!(
            "{} unexpected bytes after the last stage",
            r.b.len() - r.at
        )));
    }
    Ok(Replay {
        stages: out,
        combine,
        mesh,
    })
}

fn put_vec(w: &mut Vec<u8>, v: DVec3) {
    for c in v.to_array() {
        w.extend_from_slice(&c.to_le_bytes());
    }
}

fn put_region(w: &mut Vec<u8>, region: &Region) {
    match region {
        Region::All => w.push(0),
        Region::Sphere { center, radius } => {
            w.push(1);
            put_vec(w, *center);
            w.extend_from_slice(&radius.to_le_bytes());
        }
        Region::Box { min, max } => {
            w.push(2);
            put_vec(w, *min);
            put_vec(w, *max);
        }
        Region::Vertices(v) => {
            w.push(3);
            w.extend_from_slice(&(v.len() as u32).to_le_bytes());
            for i in v {
                w.extend_from_slice(&i.to_le_bytes());
            }
        }
        Region::Group(name) => {
            w.push(4);
            w.extend_from_slice(&(name.len() as u32).to_le_bytes());
            w.extend_from_slice(name.as_bytes());
        }
        Region::Falloff { inner, width } => {
            w.push(5);
            w.extend_from_slice(&width.to_le_bytes());
            put_region(w, inner);
        }
        Region::Weights { vertices, weights } => {
            w.push(6);
            w.extend_from_slice(&(vertices.len() as u32).to_le_bytes());
            for i in vertices {
                w.extend_from_slice(&i.to_le_bytes());
            }
            for x in weights {
                w.extend_from_slice(&x.to_le_bytes());
            }
        }
        Region::Connected { distance, from } => {
            w.push(7);
            w.extend_from_slice(&distance.to_le_bytes());
            w.push(match from {
                Origin::Starts => 0,
                Origin::Handle => 1,
            });
        }
    }
}

fn get_region(r: &mut Reader) -> Result<Region> {
    Ok(match r.u8("region tag")? {
        0 => Region::All,
        1 => Region::Sphere {
            center: r.vec("region")?,
            radius: r.f64("region")?,
        },
        2 => Region::Box {
            min: r.vec("region")?,
            max: r.vec("region")?,
        },
        3 => {
            let n = r.u32("region size")? as usize;
            r.need(n.saturating_mul(4), "region vertices")?;
            Region::Vertices(
                (0..n)
                    .map(|_| r.u32("region vertices"))
                    .collect::<Result<_>>()?,
            )
        }
        4 => {
            let n = r.u32("region name length")? as usize;
            let bytes = r.take(n, "region name")?;
            Region::Group(
                String::from_utf8(bytes.to_vec())
                    .map_err(|_| damaged("region name is not UTF-8"))?,
            )
        }
        5 => {
            let width = r.f64("region falloff")?;
            let inner = get_region(r)?;
            if !(width > 0.0 && width.is_finite())
                || matches!(inner, Region::Falloff { .. } | Region::Weights { .. })
            {
                return Err(damaged(format!("region falloff {width} is not valid")));
            }
            Region::Falloff {
                inner: Box::new(inner),
                width,
            }
        }
        6 => {
            let n = r.u32("region size")? as usize;
            r.need(n.saturating_mul(8), "region weights")?;
            let vertices = (0..n)
                .map(|_| r.u32("region vertices"))
                .collect::<Result<Vec<_>>>()?;
            let weights = (0..n)
                .map(|_| r.u32("region weights").map(f32::from_bits))
                .collect::<Result<Vec<_>>>()?;
            if let Some(w) = weights.iter().find(|w| !(0.0..=1.0).contains(*w)) {
                return Err(damaged(format!("region weight {w} is not within [0, 1]")));
            }
            Region::Weights { vertices, weights }
        }
        7 => {
            let distance = r.f64("region distance")?;
            if !(distance >= 0.0 && distance.is_finite()) {
                return Err(damaged(format!("region distance {distance} is not valid")));
            }
            let from = match r.u8("region origin")? {
                0 => Origin::Starts,
                1 => Origin::Handle,
                o => return Err(damaged(format!("unknown region origin {o}"))),
            };
            Region::Connected { distance, from }
        }
        t => return Err(damaged(format!("unknown region tag {t}"))),
    })
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn need(&self, n: usize, what: &str) -> Result<()> {
        if self.b.len().saturating_sub(self.at) < n {
            return Err(damaged(format!(
                "truncated at byte {} while reading {what}",
                self.at
            )));
        }
        Ok(())
    }
    fn take(&mut self, n: usize, what: &str) -> Result<&[u8]> {
        self.need(n, what)?;
        let s = &self.b[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }
    fn u8(&mut self, what: &str) -> Result<u8> {
        Ok(self.take(1, what)?[0])
    }
    fn u16(&mut self, what: &str) -> Result<u16> {
        let s = self.take(2, what)?;
        Ok(u16::from_le_bytes([s[0], s[1]]))
    }
    fn u32(&mut self, what: &str) -> Result<u32> {
        let mut a = [0u8; 4];
        a.copy_from_slice(self.take(4, what)?);
        Ok(u32::from_le_bytes(a))
    }
    fn u64(&mut self, what: &str) -> Result<u64> {
        let mut a = [0u8; 8];
        a.copy_from_slice(self.take(8, what)?);
        Ok(u64::from_le_bytes(a))
    }
    fn f64(&mut self, what: &str) -> Result<f64> {
        let mut a = [0u8; 8];
        a.copy_from_slice(self.take(8, what)?);
        Ok(f64::from_le_bytes(a))
    }
    fn vec(&mut self, what: &str) -> Result<DVec3> {
        Ok(DVec3::new(
            self.f64(what)?,
            self.f64(what)?,
            self.f64(what)?,
        ))
    }
}

/// 64-bit FNV-1a, fed piece by piece.
struct Fnv(u64);

impl Fnv {
    fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn add(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }
    fn finish(&self) -> u64 {
        self.0
    }
}

/// 64-bit FNV-1a.
pub(crate) fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The deformation for people to read: kernel, R, polynomial, starts,
/// coefficients, the polynomial part, the order and the region.
#[cfg(feature = "serde")]
pub fn to_json(stages: &[FittedStage], combine: Combine) -> serde_json::Value {
    let list: Vec<serde_json::Value> = stages
        .iter()
        .map(|FittedStage { deformation: d, region, phase, sweep, rigid_part }| {
            serde_json::json!({
                "rigid_part": rigid_part,
                "kernel": d.kernel(),
                "radius": d.radius(),
                "phase": phase,
                "sweep": sweep.map(|s| serde_json::json!({"step": s.index, "steps": s.count})),
                "polynomial": d.polynomial(),
                "starts": d.starts().iter().map(|v| v.to_array()).collect::<Vec<_>>(),
                "coefficients": d.coefficients().iter().map(|v| v.to_array()).collect::<Vec<_>>(),
                "affine": d.affine(),
                "order": d.order(),
                "region": region,
            })
        })
        .collect();
    serde_json::json!({ "format": "csrbf", "version": VERSION, "combine": combine, "deformations": list })
}

impl Deformation {
    /// Encodes it alone as a `.csrbf` file's bytes (over every point, at
    /// full phase): what `csrbf fit` writes for a file of one deformation.
    pub fn to_bytes(&self) -> Vec<u8> {
        crate::format::encode(
            &[crate::FittedStage::new(self.clone())],
            crate::Combine::Chain,
        )
    }

    /// Decodes a `.csrbf` file of one deformation over every point at full
    /// phase (what [`Deformation::to_bytes`] writes). A file of several
    /// deformations, or of one with a region or another phase, is refused:
    /// read it with [`crate::format::decode`].
    pub fn from_bytes(bytes: &[u8]) -> Result<Deformation> {
        let replay = crate::format::decode(bytes)?;
        let n = replay.stages.len();
        let mut stages = replay.stages.into_iter();
        match (stages.next(), n) {
            (Some(s), 1) if s.region == crate::Region::All && s.phase == 1.0 => Ok(s.deformation),
            (Some(s), 1) => Err(crate::error::FormatError::NotSingle(format!(
                "its deformation has region {} and phase {}",
                s.region, s.phase
            ))
            .into()),
            _ => Err(
                crate::error::FormatError::NotSingle(format!("it holds {n} deformations")).into(),
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A version 1 file (no combine, no phase) as an earlier build wrote it.
    fn version_1(coefficient: f64) -> Vec<u8> {
        let mut w = Vec::new();
        w.extend_from_slice(MAGIC);
        w.extend_from_slice(&1u16.to_le_bytes());
        w.extend_from_slice(&0u16.to_le_bytes());
        w.extend_from_slice(&1u32.to_le_bytes());
        w.push(Kernel::C2.code());
        w.push(Polynomial::None as u8);
        w.extend_from_slice(&0u16.to_le_bytes());
        w.extend_from_slice(&2.0f64.to_le_bytes());
        w.extend_from_slice(&1u32.to_le_bytes());
        put_vec(&mut w, DVec3::new(1.0, 2.0, 3.0));
        put_vec(&mut w, DVec3::new(0.0, coefficient, 0.0));
        w.extend_from_slice(&0u32.to_le_bytes());
        w.push(0);
        let sum = fnv1a(&w);
        w.extend_from_slice(&sum.to_le_bytes());
        w
    }

    #[test]
    fn version_1_files_still_read_chained_at_full_phase() {
        let r = decode(&version_1(0.5)).expect("version 1");
        assert_eq!(r.combine, Combine::Chain);
        assert_eq!(r.stages.len(), 1);
        let FittedStage {
            deformation: d,
            region,
            phase,
            ..
        } = &r.stages[0];
        assert_eq!((region, *phase), (&Region::All, 1.0));
        assert_eq!(
            d.displacement_at(DVec3::new(1.0, 2.0, 3.0)),
            DVec3::new(0.0, 0.5, 0.0)
        );
    }

    /// Issue 7: a checksum only proves the bytes arrived; values are checked too.
    #[test]
    fn non_finite_values_are_refused_with_a_valid_checksum() {
        for bad in [f64::NAN, f64::INFINITY] {
            let e = decode(&version_1(bad))
                .expect_err("NaN accepted")
                .to_string();
            assert!(e.contains("coefficient 0 is not finite"), "{e}");
        }
        let d = Deformation::from_parts(
            Kernel::C2,
            1.0,
            vec![DVec3::new(f64::NAN, 0.0, 0.0)],
            vec![DVec3::ZERO],
            None,
            vec![0],
        );
        let e = decode(&encode(&[FittedStage::new(d)], Combine::Chain))
            .expect_err("NaN start accepted")
            .to_string();
        assert!(e.contains("start 0 is not finite"), "{e}");
    }

    #[test]
    fn weights_and_connected_regions_round_trip() {
        let d = Deformation::from_parts(
            Kernel::C2,
            1.0,
            vec![DVec3::ZERO],
            vec![DVec3::X],
            None,
            vec![0],
        );
        let regions = [
            Region::Weights {
                vertices: vec![2, 5, 9],
                weights: vec![1.0, 0.5, 0.125],
            },
            Region::Connected {
                distance: 0.25,
                from: Origin::Handle,
            },
            Region::Falloff {
                inner: Box::new(Region::Connected {
                    distance: 1.5,
                    from: Origin::Starts,
                }),
                width: 0.5,
            },
        ];
        let stages: Vec<FittedStage> = regions
            .iter()
            .map(|r| FittedStage::new(d.clone()).with_region(r.clone()))
            .collect();
        let back = decode(&encode(&stages, Combine::Chain)).expect("decode");
        assert_eq!(back.stages, stages);
        // A weight out of [0, 1] is damage, even under a good checksum.
        let bad = FittedStage::new(d).with_region(Region::Weights {
            vertices: vec![0],
            weights: vec![2.0],
        });
        let e = decode(&encode(&[bad], Combine::Chain))
            .expect_err("weight 2 accepted")
            .to_string();
        assert!(e.contains("region weight 2"), "{e}");
    }
}
