//! Seeded mutations of files, for the fuzz tests of every reader in the
//! workspace (control files, `.csrbf`, meshes, scenes). Test tooling, not
//! engine: behind the `fuzz` feature.

use crate::synthetic::Rng;

/// Numbers that break readers: huge counts, negatives, NaN, overflow.
pub const POISON: [&str; 10] = [
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

/// One seeded mutation of a file's bytes, for fuzz tests of readers: bits
/// flipped, a cut, a number replaced by one of [`POISON`], a slice
/// duplicated, random bytes inserted, or another file's head spliced in
/// front (`others`, at least one).
pub fn mutate(bytes: &[u8], rng: &mut Rng, others: &[&[u8]]) -> Vec<u8> {
    let mut b = bytes.to_vec();
    match rng.below(6) {
        // Flip a few bits.
        0 => {
            for _ in 0..1 + rng.below(4) {
                if !b.is_empty() {
                    let i = rng.below(b.len());
                    b[i] ^= 1u8 << rng.below(8);
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
            let piece: Vec<u8> = (0..1 + rng.below(16))
                .map(|_| rng.next_u64() as u8)
                .collect();
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
