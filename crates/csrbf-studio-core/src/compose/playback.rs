//! Real-time playback: whole frames of the scene's rate by the wall clock.

use super::SceneDoc;

/// Playing a scene in real time: the playhead moves by whole frames of the
/// scene's fps as wall-clock time passes; when drawing is slower than the
/// scene, frames are skipped (and counted) so the scene keeps its speed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Playback {
    /// Whether it plays.
    pub playing: bool,
    /// Start again at the end of the range instead of stopping.
    pub looping: bool,
    /// Play only between these times (the whole scene when None).
    pub range: Option<(f64, f64)>,
    /// Frames skipped because a frame took longer than the scene allows.
    pub dropped: u64,
    /// Wall-clock seconds not yet turned into frames.
    carry: f64,
}

impl Playback {
    /// The scene's frame at `time` (rounded down).
    pub fn frame_of(doc: &SceneDoc, time: f64) -> i64 {
        (time * doc.file.fps + 1e-9).floor() as i64
    }

    fn bounds(&self, doc: &SceneDoc) -> (f64, f64) {
        let d = doc.file.duration;
        match self.range {
            Some((a, b)) if a < b => (a.clamp(0.0, d), b.clamp(0.0, d)),
            _ => (0.0, d),
        }
    }

    /// Starts playing (from the range's start if the playhead is at its end).
    pub fn play(&mut self, doc: &mut SceneDoc) {
        let (a, b) = self.bounds(doc);
        if doc.playhead >= b || doc.playhead < a {
            doc.playhead = a;
        }
        self.playing = true;
        self.carry = 0.0;
    }

    /// Stops where it is.
    pub fn pause(&mut self) {
        self.playing = false;
    }

    /// Moves the playhead by `frames` whole frames (negative: back), within
    /// the range.
    pub fn step(&self, doc: &mut SceneDoc, frames: i64) {
        let (a, b) = self.bounds(doc);
        let f = Playback::frame_of(doc, doc.playhead) + frames;
        doc.playhead = (f as f64 / doc.file.fps).clamp(a, b);
    }

    /// Advances by `elapsed` seconds of wall-clock time: returns how many
    /// frames the playhead moved (more than one when frames were dropped).
    pub fn advance(&mut self, doc: &mut SceneDoc, elapsed: f64) -> i64 {
        if !self.playing || !(elapsed >= 0.0) {
            return 0;
        }
        let fps = doc.file.fps;
        self.carry += elapsed;
        let frames = (self.carry * fps + 1e-9).floor() as i64;
        if frames == 0 {
            return 0;
        }
        self.carry -= frames as f64 / fps;
        self.dropped += (frames - 1).max(0) as u64;
        let (a, b) = self.bounds(doc);
        let mut t = (Playback::frame_of(doc, doc.playhead) + frames) as f64 / fps;
        if t > b + 1e-9 {
            if self.looping && b > a {
                t = a + (t - b - 1.0 / fps).rem_euclid(b - a + 1.0 / fps);
            } else {
                t = b;
                self.playing = false;
            }
        }
        doc.playhead = t.clamp(a, b);
        frames
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use csrbf_anim::SceneFile;

    fn doc() -> SceneDoc {
        let file = SceneFile::parse(
            r#"{"duration": 2, "fps": 10, "camera": {"eye": [0, 0, 5], "target": [0, 0, 0]}, "objects": []}"#,
        )
        .expect("a scene");
        SceneDoc::new(file, None)
    }

    #[test]
    fn playing_moves_the_playhead_by_the_fps_and_counts_dropped_frames() {
        let mut d = doc();
        let mut p = Playback::default();
        p.play(&mut d);
        // Real time at the scene's rate: one frame per 0.1 s.
        for k in 1..=5 {
            assert_eq!(p.advance(&mut d, 0.1), 1);
            assert!((d.playhead - 0.1 * k as f64).abs() < 1e-9, "{}", d.playhead);
        }
        assert_eq!(p.dropped, 0);
        // Half-frames add up; a slow frame skips frames and says so.
        assert_eq!(p.advance(&mut d, 0.05), 0);
        assert_eq!(p.advance(&mut d, 0.05), 1);
        assert_eq!(p.advance(&mut d, 0.35), 3);
        assert_eq!(p.dropped, 2);
        assert!((d.playhead - 0.9).abs() < 1e-9, "{}", d.playhead);
        // The end stops it, or wraps when looping.
        assert!(p.advance(&mut d, 5.0) > 0);
        assert_eq!(d.playhead, 2.0);
        assert!(!p.playing);
        p.looping = true;
        p.range = Some((0.5, 1.0));
        p.play(&mut d);
        assert_eq!(d.playhead, 0.5);
        for _ in 0..6 {
            p.advance(&mut d, 0.1);
        }
        assert!((d.playhead - 0.5).abs() < 1e-9, "wrapped: {}", d.playhead);
        // Frame steps stay in the range; paused, time does nothing.
        p.pause();
        assert_eq!(p.advance(&mut d, 1.0), 0);
        p.step(&mut d, -3);
        assert_eq!(d.playhead, 0.5);
        p.step(&mut d, 2);
        assert!((d.playhead - 0.7).abs() < 1e-9);
    }
}
