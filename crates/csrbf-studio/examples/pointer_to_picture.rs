//! Pointer to picture in the real window: the time from a pointer move to
//! the first picture on the X screen that shows it, while a control vector's
//! destination is dragged in the Picker, as a person would see it (the event
//! queue, the app's frame, the preview's worker, the rasteriser, the present).
//!
//! Runs the `csrbf-studio` binary (beside this example, or `$STUDIO`) on
//! MESH in a 1280x800 window on the X display in `$DISPLAY` (no window
//! manager: Xvfb), presses on the model near the viewport's centre, and
//! moves the pointer by a few pixels at a time through XTest. After each
//! move it reads the screen around the pointer (XGetImage, about every
//! millisecond) until it changes (the first picture) and until it stops
//! changing (the last: the full mesh after a stand-in, say). Then it moves
//! the pointer on every 16 ms, as a mouse does, and counts the pictures.
//! The app's own log (`CSRBF_STUDIO_TRACE=1`: each frame's whole time, the
//! app's part, the wait for the worker, the viewport's draw) goes to
//! `$TRACE` (default `target/pointer_to_picture.log`).
//!
//! ```sh
//! cargo build --release -p csrbf-studio --bin csrbf-studio --example pointer_to_picture
//! xvfb-run -a -s "-screen 0 1280x860x24" target/release/examples/pointer_to_picture MESH [MOVES]
//! ```

mod common;
use common::{median, ms};

use std::error::Error;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use x11rb::connection::Connection;
use x11rb::protocol::xproto::{ConnectionExt as _, ImageFormat, MapState, Window};
use x11rb::protocol::xtest::ConnectionExt as _;
use x11rb::rust_connection::RustConnection;

const SIZE: [u16; 2] = [1280, 800];
/// The viewport's background (linear 0.13, 0.14, 0.16), as the window shows it.
const BACKGROUND: [f32; 3] = [0.13, 0.14, 0.16];
/// How long a picture must stay the same to count as settled.
const SETTLED: Duration = Duration::from_millis(300);

/// The studio, killed when this ends (a failed measurement included).
struct Studio(Child);

impl Drop for Studio {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A box on the screen, in root window pixels.
#[derive(Clone, Copy, Debug)]
struct Area {
    x: i16,
    y: i16,
    w: u16,
    h: u16,
}

struct Screen {
    conn: RustConnection,
    root: Window,
}

impl Screen {
    /// The pixels of `a`, 4 bytes each (BGRX on Xvfb's 24-bit screen).
    fn grab(&self, a: Area) -> Result<Vec<u8>, Box<dyn Error>> {
        Ok(self
            .conn
            .get_image(ImageFormat::Z_PIXMAP, self.root, a.x, a.y, a.w, a.h, !0)?
            .reply()?
            .data)
    }

    fn fake(&self, kind: u8, detail: u8, x: i16, y: i16) -> Result<(), Box<dyn Error>> {
        self.conn
            .xtest_fake_input(kind, detail, x11rb::CURRENT_TIME, self.root, x, y, 0)?;
        // A round trip: the server has the fake event when this returns.
        self.conn.get_input_focus()?.reply()?;
        Ok(())
    }

    fn move_to(&self, x: i16, y: i16) -> Result<(), Box<dyn Error>> {
        self.fake(x11rb::protocol::xproto::MOTION_NOTIFY_EVENT, 0, x, y)
    }

    fn button(&self, down: bool) -> Result<(), Box<dyn Error>> {
        let kind = if down {
            x11rb::protocol::xproto::BUTTON_PRESS_EVENT
        } else {
            x11rb::protocol::xproto::BUTTON_RELEASE_EVENT
        };
        self.fake(kind, 1, 0, 0)
    }

    /// The studio's top-level window: viewable and of the asked size.
    fn window(&self) -> Result<Option<Area>, Box<dyn Error>> {
        for &w in &self.conn.query_tree(self.root)?.reply()?.children {
            let attributes = self.conn.get_window_attributes(w)?.reply()?;
            if attributes.map_state != MapState::VIEWABLE {
                continue;
            }
            let g = self.conn.get_geometry(w)?.reply()?;
            if [g.width, g.height] == SIZE {
                return Ok(Some(Area {
                    x: g.x,
                    y: g.y,
                    w: g.width,
                    h: g.height,
                }));
            }
        }
        Ok(None)
    }

    /// Waits until `a` shows the same picture for `quiet` (up to `limit`);
    /// the picture.
    fn settled(
        &self,
        a: Area,
        quiet: Duration,
        limit: Duration,
    ) -> Result<Vec<u8>, Box<dyn Error>> {
        let end = Instant::now() + limit;
        let mut last = self.grab(a)?;
        let mut since = Instant::now();
        while Instant::now() < end {
            std::thread::sleep(Duration::from_millis(20));
            let now = self.grab(a)?;
            if now != last {
                last = now;
                since = Instant::now();
            } else if since.elapsed() >= quiet {
                return Ok(last);
            }
        }
        Err(format!("the screen did not settle in {limit:?}").into())
    }
}

fn srgb(linear: f32) -> f32 {
    if linear <= 0.003_130_8 {
        linear * 12.92
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// The viewport (the box of the background's colour in `window`) and the
/// model's pixel nearest its centre.
fn viewport(pixels: &[u8], window: Area) -> Option<(Area, [i16; 2])> {
    let bg = BACKGROUND.map(|c| srgb(c) * 255.0);
    let (w, h) = (window.w as usize, window.h as usize);
    let is_bg = |x: usize, y: usize| {
        let p = &pixels[(y * w + x) * 4..][..3];
        // BGRX.
        (0..3).all(|k| (p[2 - k] as f32 - bg[k]).abs() <= 3.0)
    };
    let (mut lo, mut hi) = ([usize::MAX; 2], [0usize; 2]);
    for y in 0..h {
        for x in 0..w {
            if is_bg(x, y) {
                lo = [lo[0].min(x), lo[1].min(y)];
                hi = [hi[0].max(x), hi[1].max(y)];
            }
        }
    }
    if lo[0] > hi[0] || hi[0] - lo[0] < 100 || hi[1] - lo[1] < 100 {
        return None;
    }
    let centre = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2];
    // The model's pixel nearest the centre (a hollow model may miss it).
    let mut best: Option<(usize, [usize; 2])> = None;
    for y in lo[1] + 40..hi[1].saturating_sub(40) {
        for x in lo[0] + 40..hi[0].saturating_sub(40) {
            if !is_bg(x, y) {
                let d = x.abs_diff(centre[0]).pow(2) + y.abs_diff(centre[1]).pow(2);
                if best.is_none_or(|(b, _)| d < b) {
                    best = Some((d, [x, y]));
                }
            }
        }
    }
    let (_, at) = best?;
    let area = Area {
        x: window.x + lo[0] as i16,
        y: window.y + lo[1] as i16,
        w: (hi[0] - lo[0] + 1) as u16,
        h: (hi[1] - lo[1] + 1) as u16,
    };
    Some((area, [window.x + at[0] as i16, window.y + at[1] as i16]))
}

fn main() -> Result<(), Box<dyn Error>> {
    let mesh = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "assets/models/cgal_head.off".into());
    let moves: usize = std::env::args()
        .nth(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let studio = match std::env::var_os("STUDIO") {
        Some(s) => PathBuf::from(s),
        None => std::env::current_exe()?
            .parent()
            .and_then(|d| d.parent())
            .ok_or("no folder above this example")?
            .join("csrbf-studio"),
    };
    let trace = std::env::var_os("TRACE")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("target/pointer_to_picture.log"));
    let (conn, screen) = x11rb::connect(None)
        .map_err(|e| format!("no X display ({e}): run it under xvfb-run (see the file's doc)"))?;
    let root = conn.setup().roots[screen].root;
    let x = Screen { conn, root };
    let state = std::env::temp_dir().join(format!("csrbf-pointer-{}", std::process::id()));
    let _studio = Studio(
        Command::new(&studio)
            .arg(&mesh)
            .args(["--size", &format!("{}x{}", SIZE[0], SIZE[1])])
            .env("CSRBF_STUDIO_TRACE", "1")
            .env("CSRBF_STUDIO_STATE", &state)
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&trace)?)
            .spawn()
            .map_err(|e| format!("cannot run {}: {e}", studio.display()))?,
    );
    let opened = Instant::now();
    let window = loop {
        if let Some(w) = x.window()? {
            break w;
        }
        if opened.elapsed() > Duration::from_secs(120) {
            return Err("no studio window after 2 minutes".into());
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let whole = x.settled(window, Duration::from_secs(1), Duration::from_secs(300))?;
    let (view, [px, py]) =
        viewport(&whole, window).ok_or("no viewport with the model in the window")?;
    println!(
        "{mesh}: window after {:.0} ms; viewport {}x{}",
        ms(opened.elapsed()),
        view.w,
        view.h
    );
    // Around the pointer: the destination's arrow and the moved surface.
    let around = |cx: i16, cy: i16| {
        let (w, h) = (320u16.min(view.w), 320u16.min(view.h));
        let x0 = (cx - w as i16 / 2).clamp(view.x, view.x + (view.w - w) as i16);
        let y0 = (cy - h as i16 / 2).clamp(view.y, view.y + (view.h - h) as i16);
        Area { x: x0, y: y0, w, h }
    };
    x.move_to(px, py)?;
    std::thread::sleep(Duration::from_millis(200));
    x.button(true)?;
    // The press places a start; its first picture.
    x.settled(around(px, py), SETTLED, Duration::from_secs(60))?;

    // Moves one at a time, each after the picture settled.
    let step = 4i16;
    let (mut first, mut last) = (Vec::new(), Vec::new());
    let mut cx = px;
    for _ in 0..moves {
        let area = around(cx, py);
        let before = x.settled(area, SETTLED, Duration::from_secs(60))?;
        cx += step;
        x.move_to(cx, py)?;
        let t0 = Instant::now();
        let mut seen = before.clone();
        let (mut first_at, mut last_at) = (None, None);
        while t0.elapsed() < Duration::from_secs(10) {
            let now = x.grab(area)?;
            if now != seen {
                let t = t0.elapsed();
                first_at.get_or_insert(t);
                last_at = Some(t);
                seen = now;
            } else if last_at.is_some_and(|l| t0.elapsed() - l >= SETTLED) {
                break;
            }
            std::thread::sleep(Duration::from_micros(500));
        }
        let first_at = first_at.ok_or("a pointer move changed nothing on screen in 10 s")?;
        first.push(ms(first_at));
        last.push(ms(last_at.unwrap_or(first_at)));
    }
    println!(
        "one move at a time: pointer move to its first picture {:.0} ms (fastest {:.0}, slowest {:.0}), to the last {:.0} ms (medians of {moves})",
        median(first.clone()),
        first.iter().copied().fold(f64::INFINITY, f64::min),
        first.iter().copied().fold(0.0, f64::max),
        median(last)
    );

    // A steady drag: a move every 16 ms for two seconds; pictures counted.
    let area = around(cx, py);
    let mut seen = x.settled(area, SETTLED, Duration::from_secs(60))?;
    let t0 = Instant::now();
    let mut next_move = t0;
    let mut pictures = 0;
    let mut moved = 0;
    while t0.elapsed() < Duration::from_secs(2) {
        if Instant::now() >= next_move {
            cx += if moved % 60 < 30 { 2 } else { -2 };
            x.move_to(cx, py)?;
            moved += 1;
            next_move += Duration::from_millis(16);
        }
        let now = x.grab(area)?;
        if now != seen {
            pictures += 1;
            seen = now;
        }
        std::thread::sleep(Duration::from_micros(500));
    }
    let rate = pictures as f64 / t0.elapsed().as_secs_f64();
    // How far the picture lags behind the pointer once the hand stops: the
    // frames still under way finish.
    let stopped = Instant::now();
    let mut changed = stopped;
    while changed.elapsed() < SETTLED && stopped.elapsed() < Duration::from_secs(10) {
        let now = x.grab(area)?;
        if now != seen {
            changed = Instant::now();
            seen = now;
        }
        std::thread::sleep(Duration::from_micros(500));
    }
    println!(
        "steady drag (a move every 16 ms for 2 s): {pictures} pictures = {rate:.1} fps; the last picture {:.0} ms after the pointer stopped",
        ms(changed - stopped)
    );
    x.button(false)?;
    std::thread::sleep(Duration::from_millis(500));
    let _ = std::fs::remove_dir_all(&state);
    println!("the app's log: {}", trace.display());
    Ok(())
}
