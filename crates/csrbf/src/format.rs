//! The compact replay file (`.csrbf`): everything needed to replay a chain
//! of deformations for any number of frames, in a small versioned binary
//! format that loads back bit-exact.
//!
//! Layout (all little-endian):
//!
//! ```text
//! magic "CSRBF\0" | version u16 = 1 | reserved u16 | stages u32
//! per stage:
//!   kernel u8 | polynomial u8 | reserved u16 | radius f64 | n u32
//!   starts 3n f64 | coefficients 3n f64
//!   if linear: centre 3 f64 | scale f64 | coefficients 12 f64
//!   order n u32
//!   region: tag u8 (0 all, 1 sphere, 2 box, 3 vertices, 4 group) and its data
//! checksum u64: FNV-1a of every byte before it
//! ```

use glam::DVec3;

use crate::deformation::{Affine, Deformation};
use crate::error::{Error, Result};
use crate::kernel::{Kernel, Polynomial};
use crate::region::Region;

/// The file's first bytes.
pub const MAGIC: &[u8; 6] = b"CSRBF\0";
/// The version this build writes and reads.
pub const VERSION: u16 = 1;

/// Encodes a chain of deformations with their regions.
pub fn encode(stages: &[(Deformation, Region)]) -> Vec<u8> {
    let mut w = Vec::new();
    w.extend_from_slice(MAGIC);
    w.extend_from_slice(&VERSION.to_le_bytes());
    w.extend_from_slice(&0u16.to_le_bytes());
    w.extend_from_slice(&(stages.len() as u32).to_le_bytes());
    for (d, region) in stages {
        w.push(d.kernel().code());
        w.push(d.polynomial() as u8);
        w.extend_from_slice(&0u16.to_le_bytes());
        w.extend_from_slice(&d.radius().to_le_bytes());
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
    }
    let sum = fnv1a(&w);
    w.extend_from_slice(&sum.to_le_bytes());
    w
}

/// Decodes a file made by [`encode`], checking magic, version, sizes and checksum.
pub fn decode(bytes: &[u8]) -> Result<Vec<(Deformation, Region)>> {
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err(Error::Format(
            "it does not start with the csrbf magic bytes".into(),
        ));
    }
    if bytes.len() < 22 {
        return Err(Error::Format(format!(
            "truncated: only {} bytes",
            bytes.len()
        )));
    }
    let (body, tail) = bytes.split_at(bytes.len() - 8);
    let version = u16::from_le_bytes([bytes[6], bytes[7]]);
    if version != VERSION {
        return Err(Error::Format(format!(
            "version {version} is not supported (this build reads version {VERSION})"
        )));
    }
    let mut sum = [0u8; 8];
    sum.copy_from_slice(tail);
    if u64::from_le_bytes(sum) != fnv1a(body) {
        return Err(Error::Format(
            "checksum mismatch: the file is damaged or truncated".into(),
        ));
    }
    let mut r = Reader { b: body, at: 8 };
    r.u16("header")?;
    let count = r.u32("stage count")? as usize;
    let mut out = Vec::new();
    for s in 0..count {
        let kernel = Kernel::from_code(r.u8("kernel")?)
            .ok_or_else(|| Error::Format(format!("stage {s}: unknown kernel code")))?;
        let poly = match r.u8("polynomial")? {
            0 => Polynomial::None,
            1 => Polynomial::Linear,
            c => {
                return Err(Error::Format(format!(
                    "stage {s}: unknown polynomial code {c}"
                )));
            }
        };
        r.u16("reserved")?;
        let radius = r.f64("radius")?;
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(Error::Format(format!(
                "stage {s}: radius {radius} is not valid"
            )));
        }
        let n = r.u32("start count")? as usize;
        // Guard the allocations against a forged count.
        if n.saturating_mul(52) > r.b.len() - r.at.min(r.b.len()) {
            return Err(Error::Format(format!(
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
            return Err(Error::Format(format!(
                "stage {s}: order refers to a start that does not exist"
            )));
        }
        let region = get_region(&mut r)?;
        out.push((
            Deformation::from_parts(kernel, radius, starts, coefficients, affine, order, None),
            region,
        ));
    }
    if r.at != r.b.len() {
        return Err(Error::Format(format!(
            "{} unexpected bytes after the last stage",
            r.b.len() - r.at
        )));
    }
    Ok(out)
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
                    .map_err(|_| Error::Format("region name is not UTF-8".into()))?,
            )
        }
        t => return Err(Error::Format(format!("unknown region tag {t}"))),
    })
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn need(&self, n: usize, what: &str) -> Result<()> {
        if self.b.len().saturating_sub(self.at) < n {
            return Err(Error::Format(format!(
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

/// 64-bit FNV-1a.
fn fnv1a(bytes: &[u8]) -> u64 {
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
pub fn to_json(stages: &[(Deformation, Region)]) -> serde_json::Value {
    let list: Vec<serde_json::Value> = stages
        .iter()
        .map(|(d, region)| {
            serde_json::json!({
                "kernel": d.kernel(),
                "radius": d.radius(),
                "polynomial": d.polynomial(),
                "starts": d.starts().iter().map(|v| v.to_array()).collect::<Vec<_>>(),
                "coefficients": d.coefficients().iter().map(|v| v.to_array()).collect::<Vec<_>>(),
                "affine": d.affine(),
                "order": d.order(),
                "region": region,
            })
        })
        .collect();
    serde_json::json!({ "format": "csrbf", "version": VERSION, "deformations": list })
}
