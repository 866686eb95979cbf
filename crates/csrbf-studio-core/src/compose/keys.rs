//! Key edits: add at the playhead, set, copy, paste, move in time, delete,
//! TCB; every track kept in time order.

use csrbf_anim::{ObjectFile, OrientationKeyFile, PhaseKeyFile, PositionKeyFile, SceneFile};

use super::{KeyValue, Track};
use crate::EditError;

/// The value of key `index`, its time and TCB kept.
pub(super) fn set(
    file: &mut SceneFile,
    object: usize,
    track: Track,
    index: usize,
    value: KeyValue,
) -> Result<(), EditError> {
    let o = object_mut(file, object)?;
    let t = key_time(o, track, index)?;
    put_key(o, track, t, value, None)?;
    Ok(())
}

/// Key `index` (value and TCB) copied to the playhead `t`.
pub(super) fn copy(
    file: &mut SceneFile,
    object: usize,
    track: Track,
    index: usize,
    t: f64,
) -> Result<(), EditError> {
    in_time(file, t)?;
    let o = object_mut(file, object)?;
    let value = key_value(o, track, index)
        .ok_or_else(|| EditError::Invalid(format!("no key {index} in this track")))?;
    let tcb = match track {
        Track::Position => o
            .trajectory
            .get(index)
            .map(|k| [k.tension, k.continuity, k.bias]),
        _ => None,
    };
    put_key(o, track, t, value, tcb)?;
    Ok(())
}

/// A key of `value` (and, for a position key, `tcb`) at the playhead `t`:
/// a key added, or one pasted from a copy. A key already there takes them.
pub(super) fn paste(
    file: &mut SceneFile,
    object: usize,
    track: Track,
    t: f64,
    value: KeyValue,
    tcb: Option<[f64; 3]>,
) -> Result<(), EditError> {
    in_time(file, t)?;
    put_key(object_mut(file, object)?, track, t, value, tcb)?;
    Ok(())
}

/// Key `index` moved to `time`, reordered if it passes another.
pub(super) fn move_to(
    file: &mut SceneFile,
    object: usize,
    track: Track,
    index: usize,
    time: f64,
) -> Result<(), EditError> {
    in_time(file, time)?;
    let o = object_mut(file, object)?;
    match track {
        Track::Position => move_key(&mut o.trajectory, index, time),
        Track::Orientation => move_key(&mut o.orientation, index, time),
        Track::Phase { part, deformation } => {
            move_key(phase_track(o, part, deformation)?, index, time)
        }
    }
}

/// Key `index` deleted.
pub(super) fn delete(
    file: &mut SceneFile,
    object: usize,
    track: Track,
    index: usize,
) -> Result<(), EditError> {
    let o = object_mut(file, object)?;
    match track {
        Track::Position => delete_key(&mut o.trajectory, index),
        Track::Orientation => delete_key(&mut o.orientation, index),
        Track::Phase { part, deformation } => delete_key(phase_track(o, part, deformation)?, index),
    }
}

/// A position key's tension, continuity and bias, each in [-1, 1].
pub(super) fn set_tcb(
    file: &mut SceneFile,
    object: usize,
    index: usize,
    tcb: [f64; 3],
) -> Result<(), EditError> {
    if tcb.iter().any(|x| !(-1.0..=1.0).contains(x)) {
        return Err(EditError::Invalid(format!(
            "tension, continuity and bias must be within [-1, 1], got {tcb:?}"
        )));
    }
    let o = object_mut(file, object)?;
    let k = o
        .trajectory
        .get_mut(index)
        .ok_or_else(|| EditError::Invalid(format!("no position key {index}")))?;
    [k.tension, k.continuity, k.bias] = tcb;
    Ok(())
}

/// A time inside the scene, `[0, duration]`.
fn in_time(file: &SceneFile, t: f64) -> Result<(), EditError> {
    let duration = file.duration;
    if t.is_finite() && (0.0..=duration).contains(&t) {
        Ok(())
    } else {
        Err(EditError::Invalid(format!(
            "time {t} s is outside the scene (0 to {duration} s)"
        )))
    }
}

/// A track's keys, whatever their kind: time is all the ordering needs.
trait Timed: Clone {
    fn time(&self) -> f64;
    fn set_time(&mut self, t: f64);
}

macro_rules! timed {
    ($t:ty) => {
        impl Timed for $t {
            fn time(&self) -> f64 {
                self.time
            }
            fn set_time(&mut self, t: f64) {
                self.time = t;
            }
        }
    };
}
timed!(PositionKeyFile);
timed!(OrientationKeyFile);
timed!(PhaseKeyFile);

/// Puts `key` where its time belongs; a key at the same time is replaced
/// when `replace`, else refused.
fn insert_sorted<K: Timed>(keys: &mut Vec<K>, key: K, replace: bool) -> Result<usize, EditError> {
    let t = key.time();
    match keys.iter().position(|k| k.time() == t) {
        Some(i) if replace => {
            keys[i] = key;
            Ok(i)
        }
        Some(_) => Err(EditError::Invalid(format!(
            "a key is already at {t} s: two keys of a track cannot share a time"
        ))),
        None => {
            let i = keys.iter().position(|k| k.time() > t).unwrap_or(keys.len());
            keys.insert(i, key);
            Ok(i)
        }
    }
}

fn move_key<K: Timed>(keys: &mut Vec<K>, index: usize, time: f64) -> Result<(), EditError> {
    if index >= keys.len() {
        return Err(EditError::Invalid(format!("no key {index} in this track")));
    }
    let mut k = keys.remove(index);
    k.set_time(time);
    let old = keys.clone();
    insert_sorted(keys, k, false)
        .map(|_| ())
        .inspect_err(|_| *keys = old)
}

fn delete_key<K>(keys: &mut Vec<K>, index: usize) -> Result<(), EditError> {
    if index >= keys.len() {
        return Err(EditError::Invalid(format!("no key {index} in this track")));
    }
    keys.remove(index);
    Ok(())
}

/// Puts a key of `value` at time `t` (replacing the value of a key already
/// there, keeping its TCB unless `tcb` is given).
fn put_key(
    o: &mut ObjectFile,
    track: Track,
    t: f64,
    value: KeyValue,
    tcb: Option<[f64; 3]>,
) -> Result<usize, EditError> {
    match (track, value) {
        (Track::Position, KeyValue::Position(p)) if p.iter().all(|x| x.is_finite()) => {
            let old = o.trajectory.iter().find(|k| k.time == t).copied();
            let [tension, continuity, bias] =
                tcb.unwrap_or(old.map_or([0.0; 3], |k| [k.tension, k.continuity, k.bias]));
            let key = PositionKeyFile {
                time: t,
                position: p,
                tension,
                continuity,
                bias,
            };
            insert_sorted(&mut o.trajectory, key, true)
        }
        (Track::Orientation, KeyValue::Orientation(q)) => {
            let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            if !(n > 0.0 && n.is_finite()) {
                return Err(EditError::Invalid(format!(
                    "quaternion {q:?} is not a rotation"
                )));
            }
            let key = OrientationKeyFile {
                time: t,
                quaternion: Some(q.map(|x| x / n)),
                axis: None,
                angle: None,
                euler: None,
            };
            insert_sorted(&mut o.orientation, key, true)
        }
        (Track::Phase { part, deformation }, KeyValue::Phase(p)) if (0.0..=1.0).contains(&p) => {
            let d = phase_track(o, part, deformation)?;
            insert_sorted(d, PhaseKeyFile { time: t, phase: p }, true)
        }
        _ => Err(EditError::Invalid(format!(
            "{value:?} is not a valid key for the {track:?} track"
        ))),
    }
}

/// The time of key `index` of a track.
fn key_time(o: &mut ObjectFile, track: Track, index: usize) -> Result<f64, EditError> {
    let t = match track {
        Track::Position => o.trajectory.get(index).map(|k| k.time),
        Track::Orientation => o.orientation.get(index).map(|k| k.time),
        Track::Phase { part, deformation } => phase_track(o, part, deformation)?
            .get(index)
            .map(|k| k.time),
    };
    t.ok_or_else(|| EditError::Invalid(format!("no key {index} in this track")))
}

/// The value of key `index` of a track (an orientation written as an axis
/// and angle or Euler angles is given as its quaternion).
pub fn key_value(o: &ObjectFile, track: Track, index: usize) -> Option<KeyValue> {
    match track {
        Track::Position => o
            .trajectory
            .get(index)
            .map(|k| KeyValue::Position(k.position)),
        Track::Orientation => o
            .orientation
            .get(index)
            .and_then(orientation_quaternion)
            .map(KeyValue::Orientation),
        Track::Phase { part, deformation } => o
            .parts
            .get(part)?
            .deformations
            .get(deformation)?
            .phase
            .get(index)
            .map(|k| KeyValue::Phase(k.phase)),
    }
}

/// An orientation key's rotation as a unit quaternion `[x, y, z, w]`,
/// however the file wrote it (None for a key the CLI would refuse).
pub fn orientation_quaternion(k: &OrientationKeyFile) -> Option<[f64; 4]> {
    use csrbf::glam::{DQuat, DVec3};
    let q = match (k.quaternion, k.axis, k.angle, k.euler) {
        (Some(q), None, None, None) => DQuat::from_array(q),
        (None, Some(a), Some(angle), None) => {
            csrbf_anim::OrientationKey::from_axis_angle(0.0, DVec3::from_array(a), angle).rotation
        }
        (None, None, None, Some(e)) => {
            csrbf_anim::OrientationKey::from_euler_degrees(0.0, DVec3::from_array(e)).rotation
        }
        _ => return None,
    };
    let n = q.length();
    (n > 1e-9 && n.is_finite()).then(|| (q / n).to_array())
}

pub(super) fn object_mut(file: &mut SceneFile, i: usize) -> Result<&mut ObjectFile, EditError> {
    file.objects
        .get_mut(i)
        .ok_or_else(|| EditError::Invalid(format!("no object {i}")))
}

fn phase_track(
    o: &mut ObjectFile,
    part: usize,
    deformation: usize,
) -> Result<&mut Vec<PhaseKeyFile>, EditError> {
    o.parts
        .get_mut(part)
        .and_then(|p| p.deformations.get_mut(deformation))
        .map(|d| &mut d.phase)
        .ok_or_else(|| EditError::Invalid(format!("no deformation {deformation} in part {part}")))
}
