//! Movies from pictures: MP4 through ffmpeg, GIF in pure Rust, or a folder
//! of numbered PNGs. Every output is written beside its target under a
//! temporary name and renamed at the end, so it appears whole or not at all.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use crate::image::Image;
use crate::{RenderError, Result};

/// What kind of movie a path asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MovieFormat {
    /// H.264 MP4 through ffmpeg.
    Mp4,
    /// Animated GIF.
    Gif,
    /// A folder of `frame_00000.png`, ...
    Frames,
}

impl MovieFormat {
    /// `.mp4`, `.gif`, or a folder (a path ending in `/`, an existing
    /// folder, or no extension).
    pub fn of(path: &Path) -> Result<MovieFormat> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("mp4") => Ok(MovieFormat::Mp4),
            Some("gif") => Ok(MovieFormat::Gif),
            None => Ok(MovieFormat::Frames),
            _ if path.is_dir() => Ok(MovieFormat::Frames),
            Some(other) => Err(RenderError::Io {
                path: path.to_owned(),
                message: format!(
                    "unknown movie format {other:?}: use .mp4, .gif or a folder for PNG frames"
                ),
            }),
        }
    }
}

/// Writes `bytes` to `path` whole or not at all.
pub fn write_whole(path: &Path, bytes: &[u8]) -> Result<()> {
    csrbf_mesh::write_atomic(path, bytes).map_err(|e| match e {
        csrbf_mesh::MeshError::Io { source, .. } => io(path, source),
        other => io(path, other),
    })
}

fn io(path: &Path, e: impl std::fmt::Display) -> RenderError {
    RenderError::Io {
        path: path.to_owned(),
        message: e.to_string(),
    }
}

/// A temporary name beside `path` (csrbf-mesh's, the one rule for all).
fn temp_beside(path: &Path) -> Result<PathBuf> {
    csrbf_mesh::temp_beside(path).map_err(|e| io(path, e))
}

enum Sink {
    Mp4 {
        child: Child,
    },
    Gif {
        encoder: gif::Encoder<std::fs::File>,
    },
    Frames {
        count: usize,
    },
}

/// A movie being written frame by frame.
pub struct MovieWriter {
    path: PathBuf,
    tmp: PathBuf,
    width: u32,
    height: u32,
    fps: f64,
    sink: Option<Sink>,
    frames: usize,
}

/// The ffmpeg program: `CSRBF_FFMPEG` if set, else `ffmpeg` (`ffmpeg.exe`
/// on Windows) in a folder of the PATH.
fn ffmpeg() -> Result<PathBuf> {
    if let Some(p) = std::env::var_os("CSRBF_FFMPEG") {
        return Ok(PathBuf::from(p));
    }
    find_on_path("ffmpeg", std::env::var_os("PATH").as_deref()).ok_or(RenderError::NoFfmpeg)
}

/// The program `name` (with the platform's executable suffix, `.exe` on
/// Windows) in the first folder of `path` (a PATH value) that holds it.
fn find_on_path(name: &str, path: Option<&std::ffi::OsStr>) -> Option<PathBuf> {
    let file = format!("{name}{}", std::env::consts::EXE_SUFFIX);
    std::env::split_paths(path?)
        .filter(|d| !d.as_os_str().is_empty())
        .map(|d| d.join(&file))
        .find(|p| p.is_file())
}

impl MovieWriter {
    /// Starts a movie of `width` x `height` pictures at `fps`. For MP4 it
    /// checks that ffmpeg runs before any frame is drawn.
    pub fn create(path: &Path, width: u32, height: u32, fps: f64) -> Result<MovieWriter> {
        let format = MovieFormat::of(path)?;
        if !(fps > 0.0 && fps <= csrbf_anim::MAX_FPS) {
            return Err(io(
                path,
                format!(
                    "frames per second must be within (0, {}], got {fps}",
                    csrbf_anim::MAX_FPS
                ),
            ));
        }
        let tmp = temp_beside(path)?;
        let sink = match format {
            MovieFormat::Mp4 => {
                let tmp_mp4 = tmp.with_extension("tmp.mp4");
                let child = Command::new(ffmpeg()?)
                    .args([
                        "-hide_banner",
                        "-loglevel",
                        "error",
                        "-y",
                        "-f",
                        "rawvideo",
                        "-pix_fmt",
                        "rgba",
                    ])
                    .args([
                        "-s",
                        &format!("{width}x{height}"),
                        "-r",
                        &format!("{fps}"),
                        "-i",
                        "-",
                    ])
                    .args([
                        "-vf",
                        "scale=trunc(iw/2)*2:trunc(ih/2)*2",
                        "-c:v",
                        "libx264",
                        "-pix_fmt",
                        "yuv420p",
                    ])
                    .args(["-crf", "20", "-movflags", "+faststart", "-f", "mp4"])
                    .arg(&tmp_mp4)
                    .stdin(Stdio::piped())
                    .stdout(Stdio::null())
                    .stderr(Stdio::piped())
                    .spawn()
                    .map_err(|e| {
                        if e.kind() == std::io::ErrorKind::NotFound {
                            RenderError::NoFfmpeg
                        } else {
                            io(path, e)
                        }
                    })?;
                track_child(child.id());
                csrbf_mesh::track_temp(&tmp_mp4);
                return Ok(MovieWriter {
                    path: path.to_owned(),
                    tmp: tmp_mp4,
                    width,
                    height,
                    fps,
                    sink: Some(Sink::Mp4 { child }),
                    frames: 0,
                });
            }
            MovieFormat::Gif => {
                if width > u16::MAX as u32 || height > u16::MAX as u32 {
                    return Err(io(path, "a GIF is at most 65535 pixels on a side"));
                }
                let file = std::fs::File::create(&tmp).map_err(|e| io(path, e))?;
                let mut encoder = gif::Encoder::new(file, width as u16, height as u16, &[])
                    .map_err(|e| RenderError::Encode(e.to_string()))?;
                encoder
                    .set_repeat(gif::Repeat::Infinite)
                    .map_err(|e| RenderError::Encode(e.to_string()))?;
                Sink::Gif { encoder }
            }
            MovieFormat::Frames => {
                if path.is_dir()
                    && std::fs::read_dir(path)
                        .map(|mut d| d.next().is_some())
                        .unwrap_or(false)
                {
                    return Err(io(
                        path,
                        "the frames folder is not empty; give a new or empty folder",
                    ));
                }
                std::fs::create_dir(&tmp).map_err(|e| io(path, e))?;
                Sink::Frames { count: 0 }
            }
        };
        csrbf_mesh::track_temp(&tmp);
        Ok(MovieWriter {
            path: path.to_owned(),
            tmp,
            width,
            height,
            fps,
            sink: Some(sink),
            frames: 0,
        })
    }

    /// Adds a picture of the movie's size.
    pub fn push(&mut self, image: &Image) -> Result<()> {
        if image.width != self.width || image.height != self.height {
            return Err(RenderError::Encode(format!(
                "frame of {} x {} in a movie of {} x {}",
                image.width, image.height, self.width, self.height
            )));
        }
        match self.sink.as_mut() {
            Some(Sink::Mp4 { child }) => {
                let stdin = child
                    .stdin
                    .as_mut()
                    .ok_or_else(|| RenderError::Encode("ffmpeg closed its input".into()))?;
                stdin.write_all(&image.rgba).map_err(|e| {
                    RenderError::Encode(format!("ffmpeg stopped reading frames: {e}"))
                })?;
            }
            Some(Sink::Gif { encoder }) => {
                let mut rgba = image.rgba.clone();
                let mut frame = gif::Frame::from_rgba_speed(
                    self.width as u16,
                    self.height as u16,
                    &mut rgba,
                    10,
                );
                frame.delay = (100.0 / self.fps).round().max(1.0) as u16;
                encoder.write_frame(&frame).map_err(|e| io(&self.path, e))?;
            }
            Some(Sink::Frames { count }) => {
                let p = self.tmp.join(format!("frame_{:05}.png", *count));
                std::fs::write(&p, image.to_png()?).map_err(|e| io(&p, e))?;
                *count += 1;
            }
            None => return Err(RenderError::Encode("the movie is already finished".into())),
        }
        self.frames += 1;
        Ok(())
    }

    /// Frames written so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Completes the movie and moves it into place.
    pub fn finish(mut self) -> Result<PathBuf> {
        match self.sink.take() {
            Some(Sink::Mp4 { mut child }) => {
                drop(child.stdin.take());
                let id = child.id();
                let out = child.wait_with_output().map_err(|e| io(&self.path, e));
                untrack_child(id);
                let out = out?;
                if !out.status.success() {
                    return Err(RenderError::Encode(format!(
                        "ffmpeg failed: {}",
                        String::from_utf8_lossy(&out.stderr).trim()
                    )));
                }
                csrbf_mesh::replace(&self.tmp, &self.path).map_err(|e| io(&self.path, e))?;
            }
            Some(Sink::Gif { encoder }) => {
                let file = encoder.into_inner().map_err(|e| io(&self.path, e))?;
                file.sync_all().map_err(|e| io(&self.path, e))?;
                drop(file);
                csrbf_mesh::replace(&self.tmp, &self.path).map_err(|e| io(&self.path, e))?;
            }
            Some(Sink::Frames { .. }) => {
                if self.path.is_dir() {
                    std::fs::remove_dir(&self.path).map_err(|e| io(&self.path, e))?;
                }
                csrbf_mesh::replace(&self.tmp, &self.path).map_err(|e| io(&self.path, e))?;
            }
            None => {}
        }
        csrbf_mesh::untrack_temp(&self.tmp);
        Ok(self.path.clone())
    }
}

/// ffmpeg processes writing movies right now, for [`interrupt`].
static CHILDREN: std::sync::Mutex<Vec<u32>> = std::sync::Mutex::new(Vec::new());

fn track_child(id: u32) {
    if let Ok(mut c) = CHILDREN.lock() {
        c.push(id);
    }
}

fn untrack_child(id: u32) {
    if let Ok(mut c) = CHILDREN.lock() {
        c.retain(|&x| x != id);
    }
}

/// On SIGINT or SIGTERM (called from the handler): stops every ffmpeg this
/// process started and removes every temporary file or folder being
/// written, movies and meshes alike, so an interruption leaves no litter.
pub fn interrupt() {
    if let Ok(mut children) = CHILDREN.lock() {
        for id in children.drain(..) {
            let id = id.to_string();
            let _ = if cfg!(windows) {
                Command::new("taskkill").args(["/PID", &id, "/F"]).output()
            } else {
                Command::new("kill").args(["-KILL", &id]).output()
            };
        }
    }
    csrbf_mesh::remove_live_temps();
}

impl Drop for MovieWriter {
    /// An unfinished movie leaves nothing behind.
    fn drop(&mut self) {
        match self.sink.take() {
            Some(Sink::Mp4 { mut child }) => {
                drop(child.stdin.take());
                let _ = child.kill();
                let _ = child.wait();
                untrack_child(child.id());
                let _ = std::fs::remove_file(&self.tmp);
            }
            Some(Sink::Gif { encoder }) => {
                drop(encoder);
                let _ = std::fs::remove_file(&self.tmp);
            }
            Some(Sink::Frames { .. }) => {
                let _ = std::fs::remove_dir_all(&self.tmp);
            }
            None => {}
        }
        csrbf_mesh::untrack_temp(&self.tmp);
    }
}

pub use csrbf_anim::MAX_FRAMES;

/// What to render of a scene as a movie.
#[derive(Clone, Copy, Debug)]
#[non_exhaustive]
pub struct MovieOptions {
    /// Picture size.
    pub size: [u32; 2],
    /// Frames per second.
    pub fps: f64,
    /// First time drawn, in seconds.
    pub from: f64,
    /// Last time drawn, in seconds.
    pub to: f64,
    /// Look of every frame.
    pub look: crate::SceneOptions,
    /// Write a GIF beside the asked-for MP4 when ffmpeg is missing.
    pub gif_fallback: bool,
}

impl MovieOptions {
    /// The whole scene at its own size and rate.
    pub fn of(scene: &csrbf_anim::Scene) -> MovieOptions {
        MovieOptions {
            size: scene.file.size,
            fps: scene.file.fps,
            from: 0.0,
            to: scene.file.duration,
            look: crate::SceneOptions::default(),
            gif_fallback: false,
        }
    }

    /// How many frames that is: both ends included.
    pub fn frames(&self) -> usize {
        csrbf_anim::frame_count(self.to - self.from, self.fps)
    }
}

/// A movie written.
#[derive(Clone, Debug)]
pub struct Written {
    /// Where it is (the GIF when it fell back).
    pub path: PathBuf,
    /// Frames in it.
    pub frames: usize,
    /// Why it is a GIF instead of the MP4 asked for, when it fell back.
    pub fell_back: Option<String>,
}

/// Renders a scene from `options.from` to `options.to` into a movie at
/// `out` (MP4, GIF or a folder of PNGs, by [`MovieFormat::of`]).
/// `progress(done, total)` is called after every frame; returning false
/// cancels, and nothing is left on disk. The one frame loop of `csrbf
/// animate`, the demos and the studio's export.
pub fn render_movie(
    scene: &csrbf_anim::Scene,
    out: &Path,
    options: MovieOptions,
    progress: &mut dyn FnMut(usize, usize) -> bool,
) -> Result<Written> {
    let o = options;
    if !(o.fps > 0.0 && o.fps <= csrbf_anim::MAX_FPS) {
        return Err(io(
            out,
            format!(
                "frames per second must be within (0, {}], got {}",
                csrbf_anim::MAX_FPS,
                o.fps
            ),
        ));
    }
    if !(o.from >= 0.0 && o.to > o.from && o.to.is_finite()) {
        return Err(io(
            out,
            format!("times {} to {}: need 0 <= from < to, finite", o.from, o.to),
        ));
    }
    let frames = o.frames();
    if frames > MAX_FRAMES {
        return Err(io(
            out,
            format!(
                "{:.0} s at {} fps is {frames} frames, more than the limit of {MAX_FRAMES}: shorten the time range or lower the rate",
                o.to - o.from,
                o.fps
            ),
        ));
    }
    let (writer, fell_back) = match MovieWriter::create(out, o.size[0], o.size[1], o.fps) {
        Err(RenderError::NoFfmpeg) if o.gif_fallback => {
            let gif = out.with_extension("gif");
            let w = MovieWriter::create(&gif, o.size[0], o.size[1], o.fps)?;
            (w, Some(RenderError::NoFfmpeg.to_string()))
        }
        other => (other?, None),
    };
    let mut writer = writer;
    let mut r = crate::SceneRenderer::new(scene, o.size[0], o.size[1])?;
    let mut frame = csrbf_anim::Frame::default();
    for k in 0..frames {
        let time = (o.from + k as f64 / o.fps).min(o.to);
        scene.frame_into(time, &mut frame);
        let img = r.render(scene, &frame, o.look)?;
        writer.push(&img)?;
        if !progress(k + 1, frames) {
            // Dropping the writer removes what it wrote.
            return Err(RenderError::Cancelled);
        }
    }
    Ok(Written {
        path: writer.finish()?,
        frames,
        fell_back,
    })
}

#[cfg(test)]
mod tests {
    use super::find_on_path;

    #[test]
    fn ffmpeg_is_found_in_the_first_path_folder_that_holds_it() {
        let base = std::env::temp_dir().join(format!("csrbf-path-{}", std::process::id()));
        let (a, b, c) = (base.join("a"), base.join("b b"), base.join("c"));
        for d in [&a, &b, &c] {
            std::fs::create_dir_all(d).expect("dir");
        }
        let exe = format!("ffmpeg{}", std::env::consts::EXE_SUFFIX);
        // A folder named like the program is not it.
        std::fs::create_dir_all(a.join(&exe)).expect("dir");
        std::fs::write(b.join(&exe), b"").expect("write");
        std::fs::write(c.join(&exe), b"").expect("write");
        let path = std::env::join_paths([&a, &b, &c]).expect("path");
        assert_eq!(find_on_path("ffmpeg", Some(&path)), Some(b.join(&exe)));
        assert_eq!(find_on_path("ffmpeg", None), None);
        let only_a = std::env::join_paths([&a]).expect("path");
        assert_eq!(find_on_path("ffmpeg", Some(&only_a)), None);
        let _ = std::fs::remove_dir_all(&base);
    }
}
