//! Orientation keys interpolated on the unit quaternions (Shoemake): slerp
//! between keys, or squad for a smooth turn through several keys.

use glam::{DQuat, DVec3, EulerRot};

/// An orientation at a time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrientationKey {
    /// Time in seconds.
    pub time: f64,
    /// Unit quaternion.
    pub rotation: DQuat,
}

impl OrientationKey {
    /// A key from an axis and an angle in degrees.
    pub fn from_axis_angle(time: f64, axis: DVec3, degrees: f64) -> OrientationKey {
        OrientationKey {
            time,
            rotation: DQuat::from_axis_angle(axis.normalize_or(DVec3::Y), degrees.to_radians()),
        }
    }

    /// A key from Euler angles in degrees, applied in the order X, then Y, then Z.
    pub fn from_euler_degrees(time: f64, xyz: DVec3) -> OrientationKey {
        OrientationKey {
            time,
            rotation: DQuat::from_euler(
                EulerRot::ZYX,
                xyz.z.to_radians(),
                xyz.y.to_radians(),
                xyz.x.to_radians(),
            ),
        }
    }
}

/// How to interpolate between orientation keys (`"squad"` or `"slerp"` in files).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Interpolation {
    /// Spherical linear between neighbouring keys: constant speed, corners at keys.
    Slerp,
    /// Spherical cubic (squad): smooth through the keys.
    #[default]
    Squad,
}

/// Orientation over time.
#[derive(Clone, Debug, PartialEq)]
pub struct Orientation {
    keys: Vec<OrientationKey>,
    /// Squad's inner control quaternions, one per key.
    inner: Vec<DQuat>,
    interpolation: Interpolation,
}

impl Orientation {
    /// Interpolates `keys` (sorted by time, unit quaternions). Each key is
    /// flipped if needed to lie in the hemisphere of the one before, so every
    /// turn takes the short way.
    pub fn new(mut keys: Vec<OrientationKey>, interpolation: Interpolation) -> Orientation {
        for i in 1..keys.len() {
            if keys[i].rotation.dot(keys[i - 1].rotation) < 0.0 {
                keys[i].rotation = -keys[i].rotation;
            }
        }
        let n = keys.len();
        let inner = (0..n)
            .map(|i| {
                let q = keys[i].rotation;
                if i == 0 || i + 1 == n {
                    return q;
                }
                let inv = q.inverse();
                let a = log(inv * keys[i + 1].rotation);
                let b = log(inv * keys[i - 1].rotation);
                (q * exp(-(a + b) * 0.25)).normalize()
            })
            .collect();
        Orientation {
            keys,
            inner,
            interpolation,
        }
    }

    /// The keys (after hemisphere alignment).
    pub fn keys(&self) -> &[OrientationKey] {
        &self.keys
    }

    /// The rotation at `time`: identity with no key; held before the first
    /// and after the last key.
    pub fn rotation(&self, time: f64) -> DQuat {
        let Some((i, s)) = crate::spline::segment(&self.keys, |k| k.time, time) else {
            return match (self.keys.first(), self.keys.last()) {
                (Some(f), Some(l)) => {
                    if time >= l.time {
                        l.rotation
                    } else {
                        f.rotation
                    }
                }
                _ => DQuat::IDENTITY,
            };
        };
        let (q0, q1) = (self.keys[i].rotation, self.keys[i + 1].rotation);
        let q = match self.interpolation {
            Interpolation::Slerp => q0.slerp(q1, s),
            Interpolation::Squad => {
                let a = q0.slerp(q1, s);
                let b = self.inner[i].slerp(self.inner[i + 1], s);
                a.slerp(b, 2.0 * s * (1.0 - s))
            }
        };
        q.normalize()
    }
}

/// Logarithm of a unit quaternion, as a pure quaternion's vector part.
fn log(q: DQuat) -> DVec3 {
    let v = DVec3::new(q.x, q.y, q.z);
    let s = v.length();
    if s < 1e-12 {
        return DVec3::ZERO;
    }
    v * (s.atan2(q.w) / s)
}

/// Exponential of a pure quaternion given by its vector part.
fn exp(v: DVec3) -> DQuat {
    let a = v.length();
    if a < 1e-12 {
        return DQuat::IDENTITY;
    }
    let s = a.sin() / a;
    DQuat::from_xyzw(v.x * s, v.y * s, v.z * s, a.cos())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys() -> Vec<OrientationKey> {
        vec![
            OrientationKey::from_axis_angle(0.0, DVec3::Y, 0.0),
            OrientationKey::from_axis_angle(1.0, DVec3::Y, 90.0),
            OrientationKey::from_axis_angle(2.5, DVec3::new(1.0, 1.0, 0.0), 200.0),
            OrientationKey::from_euler_degrees(3.0, DVec3::new(10.0, 20.0, 30.0)),
        ]
    }

    #[test]
    fn stays_unit_and_passes_through_keys() {
        for interp in [Interpolation::Slerp, Interpolation::Squad] {
            let o = Orientation::new(keys(), interp);
            for k in 0..=300 {
                let q = o.rotation(k as f64 / 100.0);
                assert!((q.length() - 1.0).abs() < 1e-12);
            }
            for (k, key) in keys().iter().enumerate() {
                let q = o.rotation(key.time);
                assert!(
                    q.dot(key.rotation).abs() > 1.0 - 1e-12,
                    "{interp:?} key {k}"
                );
            }
        }
    }

    #[test]
    fn takes_the_short_way() {
        // 350 degrees about Y is -10 degrees: half way is -5, not 175.
        let o = Orientation::new(
            vec![
                OrientationKey::from_axis_angle(0.0, DVec3::Y, 0.0),
                OrientationKey::from_axis_angle(1.0, DVec3::Y, 350.0),
            ],
            Interpolation::Slerp,
        );
        let half = o.rotation(0.5);
        let want = DQuat::from_axis_angle(DVec3::Y, (-5f64).to_radians());
        assert!(half.dot(want).abs() > 1.0 - 1e-9, "{half:?}");
    }

    #[test]
    fn squad_is_smooth_at_inner_keys() {
        let h = 1e-5;
        let angular = |o: &Orientation, t: f64| {
            let a = o.rotation(t);
            let b = o.rotation(t + h);
            let (axis, ang) = (a.inverse() * b).to_axis_angle();
            a * (axis * ang / h)
        };
        // Evenly spaced keys: the angular velocity is continuous.
        let mut even = keys();
        for (i, k) in even.iter_mut().enumerate() {
            k.time = i as f64;
        }
        let o = Orientation::new(even, Interpolation::Squad);
        for t in [1.0, 2.0] {
            let (before, after) = (angular(&o, t - 2.0 * h), angular(&o, t + h));
            assert!(
                (before - after).length() < 1e-3 * before.length().max(1.0),
                "{before} vs {after} at {t}"
            );
        }
        // Uneven spacing (timing marks): the turn keeps its direction through the key.
        let o = Orientation::new(keys(), Interpolation::Squad);
        for t in [1.0, 2.5] {
            let (before, after) = (angular(&o, t - 2.0 * h), angular(&o, t + h));
            assert!(
                before.normalize().dot(after.normalize()) > 1.0 - 1e-6,
                "{before} vs {after} at {t}"
            );
        }
    }
}
