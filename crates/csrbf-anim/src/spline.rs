//! Kochanek-Bartels interpolating splines with per-key tension, continuity
//! and bias, and timing marks (keys at arbitrary times).

use glam::DVec3;

/// A position key: where the object's frame is at `time`, and the shape of
/// the curve through it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionKey {
    /// Time in seconds.
    pub time: f64,
    /// Position.
    pub position: DVec3,
    /// Tension: 1 tightens the curve to a corner, -1 loosens it. Default 0.
    pub tension: f64,
    /// Continuity: 0 keeps the tangent continuous; other values make a kink.
    pub continuity: f64,
    /// Bias: -1 leans the tangent to the next key, 1 to the previous.
    pub bias: f64,
}

impl PositionKey {
    /// A key with tension, continuity and bias 0 (Catmull-Rom).
    pub fn new(time: f64, position: DVec3) -> PositionKey {
        PositionKey {
            time,
            position,
            tension: 0.0,
            continuity: 0.0,
            bias: 0.0,
        }
    }
}

/// A Kochanek-Bartels spline through keys sorted by time.
#[derive(Clone, Debug, PartialEq)]
pub struct Trajectory {
    keys: Vec<PositionKey>,
    /// Outgoing and incoming tangent of each key, per unit of segment parameter.
    out_tangents: Vec<DVec3>,
    in_tangents: Vec<DVec3>,
}

impl Trajectory {
    /// The spline through `keys`, which must be in strictly increasing time
    /// order (the scene loader checks and says which key is out of order).
    pub fn new(keys: Vec<PositionKey>) -> Trajectory {
        let n = keys.len();
        let mut out_t = vec![DVec3::ZERO; n];
        let mut in_t = vec![DVec3::ZERO; n];
        for i in 0..n {
            let k = keys[i];
            let prev = if i > 0 { keys[i - 1] } else { k };
            let next = if i + 1 < n { keys[i + 1] } else { k };
            let (d0, d1) = (k.position - prev.position, next.position - k.position);
            let (t, c, b) = (k.tension, k.continuity, k.bias);
            let mut ts = d0 * ((1.0 - t) * (1.0 + c) * (1.0 + b) * 0.5)
                + d1 * ((1.0 - t) * (1.0 - c) * (1.0 - b) * 0.5);
            let mut td = d0 * ((1.0 - t) * (1.0 - c) * (1.0 + b) * 0.5)
                + d1 * ((1.0 - t) * (1.0 + c) * (1.0 - b) * 0.5);
            // Timing marks: scale the tangents so the velocity is continuous
            // across keys whose segments last differently (Kochanek-Bartels 1984).
            if i > 0 && i + 1 < n {
                let (dt0, dt1) = (k.time - prev.time, next.time - k.time);
                ts *= 2.0 * dt1 / (dt0 + dt1);
                td *= 2.0 * dt0 / (dt0 + dt1);
            }
            out_t[i] = ts;
            in_t[i] = td;
        }
        Trajectory {
            keys,
            out_tangents: out_t,
            in_tangents: in_t,
        }
    }

    /// The keys.
    pub fn keys(&self) -> &[PositionKey] {
        &self.keys
    }

    /// Position at `time`; before the first key the first position, after the
    /// last the last. `ZERO` for a trajectory with no key.
    pub fn position(&self, time: f64) -> DVec3 {
        let Some((i, s)) = segment(&self.keys, |k| k.time, time) else {
            return match (self.keys.first(), self.keys.last()) {
                (Some(f), Some(l)) => {
                    if time >= l.time {
                        l.position
                    } else {
                        f.position
                    }
                }
                _ => DVec3::ZERO,
            };
        };
        let (p0, p1) = (self.keys[i].position, self.keys[i + 1].position);
        let (m0, m1) = (self.out_tangents[i], self.in_tangents[i + 1]);
        let (s2, s3) = (s * s, s * s * s);
        p0 * (2.0 * s3 - 3.0 * s2 + 1.0)
            + m0 * (s3 - 2.0 * s2 + s)
            + p1 * (-2.0 * s3 + 3.0 * s2)
            + m1 * (s3 - s2)
    }

    /// Velocity (derivative by time) at `time`, inside the keys' span.
    pub fn velocity(&self, time: f64) -> DVec3 {
        let Some((i, s)) = segment(&self.keys, |k| k.time, time) else {
            return DVec3::ZERO;
        };
        let dt = self.keys[i + 1].time - self.keys[i].time;
        let (p0, p1) = (self.keys[i].position, self.keys[i + 1].position);
        let (m0, m1) = (self.out_tangents[i], self.in_tangents[i + 1]);
        let s2 = s * s;
        (p0 * (6.0 * s2 - 6.0 * s)
            + m0 * (3.0 * s2 - 4.0 * s + 1.0)
            + p1 * (-6.0 * s2 + 6.0 * s)
            + m1 * (3.0 * s2 - 2.0 * s))
            / dt
    }
}

/// The segment of `keys` (times by `time_of`) containing `time` and the
/// parameter in it, or None before the first key, after the last, or with
/// fewer than two keys. Allocates nothing: every track of a frame asks.
pub(crate) fn segment<K>(
    keys: &[K],
    time_of: impl Fn(&K) -> f64,
    time: f64,
) -> Option<(usize, f64)> {
    let n = keys.len();
    if n < 2 {
        return None;
    }
    let t = |i: usize| time_of(&keys[i]);
    if !(time > t(0)) || time >= t(n - 1) {
        return None;
    }
    // Last key at or before `time`.
    let i = keys
        .partition_point(|k| time_of(k) <= time)
        .saturating_sub(1)
        .min(n - 2);
    let s = (time - t(i)) / (t(i + 1) - t(i));
    Some((i, s.clamp(0.0, 1.0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys(times: &[f64], pts: &[[f64; 3]]) -> Vec<PositionKey> {
        times
            .iter()
            .zip(pts)
            .map(|(t, p)| PositionKey::new(*t, DVec3::from_array(*p)))
            .collect()
    }

    #[test]
    fn passes_through_its_keys_at_their_times() {
        let k = keys(
            &[0.0, 0.7, 1.1, 3.0, 3.2],
            &[
                [0.0, 0.0, 0.0],
                [1.0, 2.0, 0.0],
                [2.0, -1.0, 1.0],
                [0.0, 5.0, 2.0],
                [1.0, 1.0, 1.0],
            ],
        );
        let mut k2 = k.clone();
        k2[2].tension = 0.5;
        k2[3].continuity = -0.4;
        k2[1].bias = 0.7;
        for tr in [Trajectory::new(k.clone()), Trajectory::new(k2)] {
            for key in tr.keys() {
                assert!(
                    (tr.position(key.time) - key.position).length() < 1e-12,
                    "at {}",
                    key.time
                );
            }
            assert_eq!(tr.position(-1.0), k[0].position);
            assert_eq!(tr.position(10.0), k[4].position);
        }
    }

    #[test]
    fn zero_tcb_with_uniform_keys_is_catmull_rom() {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 2.0, 0.0],
            [3.0, 2.0, 1.0],
            [4.0, 0.0, 0.0],
            [6.0, 1.0, 2.0],
        ]
        .map(DVec3::from_array);
        let tr = Trajectory::new(keys(&[0.0, 1.0, 2.0, 3.0, 4.0], &p.map(|v| v.to_array())));
        for i in 1..3 {
            for k in 0..=10 {
                let s = k as f64 / 10.0;
                // Catmull-Rom between p[i] and p[i+1].
                let (a, b, c, d) = (p[i - 1], p[i], p[i + 1], p[i + 2]);
                let want = ((b * 2.0)
                    + (c - a) * s
                    + (a * 2.0 - b * 5.0 + c * 4.0 - d) * s * s
                    + (b * 3.0 - a - c * 3.0 + d) * s * s * s)
                    * 0.5;
                assert!((tr.position(i as f64 + s) - want).length() < 1e-12);
            }
        }
    }

    #[test]
    fn velocity_is_continuous_at_keys_with_zero_continuity_and_uneven_timing() {
        let tr = Trajectory::new(keys(
            &[0.0, 0.3, 1.5, 2.0],
            &[
                [0.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [2.0, 0.0, 1.0],
                [3.0, 3.0, 3.0],
            ],
        ));
        for t in [0.3, 1.5] {
            let (a, b) = (tr.velocity(t - 1e-7), tr.velocity(t + 1e-7));
            assert!(
                (a - b).length() < 1e-4 * a.length().max(1.0),
                "{a} vs {b} at {t}"
            );
            let (p, q) = (tr.position(t - 1e-9), tr.position(t + 1e-9));
            assert!((p - q).length() < 1e-6);
        }
        // A continuity other than 0 makes a kink.
        let mut k = keys(
            &[0.0, 1.0, 2.0],
            &[[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 0.0, 0.0]],
        );
        k[1].continuity = 0.8;
        let tr = Trajectory::new(k);
        assert!((tr.velocity(1.0 - 1e-7) - tr.velocity(1.0 + 1e-7)).length() > 0.1);
    }
}
