//! Phase tracks: the phase of a deformation over time, so a face can smile,
//! hold and relax.

/// How a phase track moves between keys (`"smooth"` or `"linear"` in files).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Easing {
    /// Straight lines between keys.
    Linear,
    /// Ease in and out of every key (smoothstep): no jumps in speed at keys.
    #[default]
    Smooth,
}

/// Keys (time, phase) with phase in [0, 1], sorted by time.
#[derive(Clone, Debug, PartialEq)]
pub struct PhaseTrack {
    keys: Vec<(f64, f64)>,
    easing: Easing,
}

impl PhaseTrack {
    /// A track through `keys` (sorted by time, phases in [0, 1]).
    pub fn new(keys: Vec<(f64, f64)>, easing: Easing) -> PhaseTrack {
        PhaseTrack { keys, easing }
    }

    /// A constant phase.
    pub fn constant(phase: f64) -> PhaseTrack {
        PhaseTrack {
            keys: vec![(0.0, phase)],
            easing: Easing::Linear,
        }
    }

    /// The keys.
    pub fn keys(&self) -> &[(f64, f64)] {
        &self.keys
    }

    /// How it moves between keys.
    pub fn easing(&self) -> Easing {
        self.easing
    }

    /// The phase at `time`, held before the first and after the last key.
    pub fn phase(&self, time: f64) -> f64 {
        let Some((i, s)) = crate::spline::segment(&self.keys, |k| k.0, time) else {
            return match (self.keys.first(), self.keys.last()) {
                (Some(f), Some(l)) => {
                    if time >= l.0 {
                        l.1
                    } else {
                        f.1
                    }
                }
                _ => 1.0,
            };
        };
        let s = match self.easing {
            Easing::Linear => s,
            Easing::Smooth => s * s * (3.0 - 2.0 * s),
        };
        let (a, b) = (self.keys[i].1, self.keys[i + 1].1);
        (a + (b - a) * s).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smile_hold_relax() {
        let t = PhaseTrack::new(
            vec![(0.0, 0.0), (1.0, 1.0), (2.0, 1.0), (3.0, 0.0)],
            Easing::Smooth,
        );
        assert_eq!(t.phase(-1.0), 0.0);
        assert_eq!(t.phase(0.0), 0.0);
        assert_eq!(t.phase(1.0), 1.0);
        assert_eq!(t.phase(1.5), 1.0);
        assert_eq!(t.phase(0.5), 0.5);
        assert!(t.phase(0.25) < 0.25);
        assert_eq!(t.phase(3.0), 0.0);
        assert_eq!(t.phase(9.0), 0.0);
        let l = PhaseTrack::new(vec![(0.0, 0.0), (2.0, 1.0)], Easing::Linear);
        assert!((l.phase(0.5) - 0.25).abs() < 1e-12);
        assert_eq!(PhaseTrack::constant(0.3).phase(5.0), 0.3);
    }
}
