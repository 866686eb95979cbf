//! numpy's (N, 3) buffers seen as glam vectors, without a copy.
//!
//! The one `unsafe` of this crate (the workspace denies it elsewhere but in
//! the engine's SIMD dispatch): reading or filling a caller's array in place
//! is what `out=` promises, and copying 1M points in and out would add about
//! 5 % to an evaluation.
#![allow(unsafe_code)]

use glam::{DVec3, Vec3};

// glam's Vec3 and DVec3 are `#[repr(C)]` structs of three f32 / f64, with
// the alignment of their scalar: checked here at compile time.
const _: () = assert!(size_of::<Vec3>() == 12 && align_of::<Vec3>() == align_of::<f32>());
const _: () = assert!(size_of::<DVec3>() == 24 && align_of::<DVec3>() == align_of::<f64>());

/// Scalars whose triples are a glam vector.
pub trait Triple: Copy + 'static {
    /// The vector of three of them.
    type V: Copy + Send + Sync;
}
impl Triple for f32 {
    type V = Vec3;
}
impl Triple for f64 {
    type V = DVec3;
}

/// `s` as vectors; `s.len()` must be a multiple of 3 (the callers pass (N, 3)
/// arrays; checked).
pub fn vectors<T: Triple>(s: &[T]) -> &[T::V] {
    assert!(s.len().is_multiple_of(3), "an (N, 3) buffer");
    // SAFETY: T::V is #[repr(C)] {x, y, z: T}, 3 * size_of::<T>() bytes with
    // T's alignment (asserted above), so len / 3 of them fill exactly the
    // same bytes; every bit pattern of T is valid in both; the lifetime and
    // borrow are the input's.
    unsafe { std::slice::from_raw_parts(s.as_ptr().cast::<T::V>(), s.len() / 3) }
}

/// `s` as mutable vectors; `s.len()` must be a multiple of 3.
pub fn vectors_mut<T: Triple>(s: &mut [T]) -> &mut [T::V] {
    assert!(s.len().is_multiple_of(3), "an (N, 3) buffer");
    // SAFETY: as in `vectors`; the exclusive borrow of `s` moves to the result.
    unsafe { std::slice::from_raw_parts_mut(s.as_mut_ptr().cast::<T::V>(), s.len() / 3) }
}
