//! The Composer's timeline: the transport (play, pause, frame steps, loop,
//! range, every frame), the scene's fps and duration, a ruler to scrub, and
//! a row per track of every object (position, orientation, each
//! deformation's phase) with its keys: click to select, drag in time (one
//! undo step, snapped to frames; passing another key reorders, landing on
//! one is refused), Key to add one at the playhead.

use eframe::egui;

use super::composer::Composer;
use crate::compose::{KeyRef, SceneEdit, Track};

/// Height of a track row, in points.
const ROW: f32 = 18.0;
/// Width of the track names.
const NAMES: f32 = 190.0;

impl Composer {
    pub(super) fn timeline_ui(&mut self, ui: &mut egui::Ui) {
        self.transport_ui(ui);
        ui.separator();
        egui::ScrollArea::vertical()
            .auto_shrink([false, false])
            .show(ui, |ui| self.tracks_ui(ui));
    }

    fn transport_ui(&mut self, ui: &mut egui::Ui) {
        let mut action = None;
        let mut timing = None;
        ui.horizontal_wrapped(|ui| {
            action = transport_buttons(ui, self.playback.playing);
            playback_options(ui, self);
            ui.separator();
            if playhead_ui(ui, self) {
                action = Some(Transport::Playhead);
            }
            ui.separator();
            timing = timing_ui(ui, self);
        });
        match action {
            Some(Transport::Start) => self.set_playhead(0.0),
            Some(step @ (Transport::Back | Transport::Next)) => {
                self.playback.pause();
                let by = if step == Transport::Back { -1 } else { 1 };
                self.playback.step(&mut self.doc, by);
            }
            Some(Transport::Play) => self.toggle_play(),
            Some(Transport::End) => {
                let d = self.doc.file.duration;
                self.set_playhead(d);
            }
            Some(Transport::Playhead) => {
                let t = self.doc.playhead;
                self.set_playhead(t);
            }
            None => {}
        }
        if let Some((fps, duration)) = timing {
            self.edit_merging(SceneEdit::SetTiming { fps, duration }, Some("timing"));
        }
    }

    fn tracks_ui(&mut self, ui: &mut egui::Ui) {
        let width = (ui.available_width() - NAMES - 80.0).max(80.0);
        let mut out = Rows {
            scrub: ruler_ui(ui, self, width),
            ..Rows::default()
        };
        self.rows.clear();
        let objects = self.doc.file.objects.clone();
        for (o, of) in objects.iter().enumerate() {
            ui.horizontal(|ui| {
                let name = egui::RichText::new(&of.name).strong();
                if ui
                    .selectable_label(self.selected == Some(o), name)
                    .clicked()
                {
                    out.select_object = Some(o);
                }
            });
            for (track, name) in track_names(of) {
                ui.horizontal(|ui| track_row(ui, self, (o, of), (track, &name), width, &mut out));
            }
            ui.add_space(4.0);
        }
        self.apply_rows(out);
    }

    /// What the rows asked for: selections, a scrub, a key added or moved.
    fn apply_rows(&mut self, out: Rows) {
        if let Some(o) = out.select_object {
            self.selected = Some(o);
        }
        if let Some(k) = out.select_key {
            self.key = Some(k);
            self.selected = Some(k.0);
        }
        if let Some(t) = out.scrub {
            self.set_playhead(t);
        }
        if let Some((o, track)) = out.add {
            self.add_key(o, track);
        }
        if let Some(((o, track, index), time)) = out.moved
            && self.edit(SceneEdit::MoveKey {
                object: o,
                track,
                index,
                time,
            })
        {
            let i = self.doc.key_times(o, track).iter().position(|&k| k == time);
            self.key = i.map(|i| (o, track, i));
        }
    }
}

/// A transport button pressed, or the playhead typed.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Transport {
    Start,
    Back,
    Play,
    Next,
    End,
    Playhead,
}

/// Start, Back, Play or Pause, Next, End.
fn transport_buttons(ui: &mut egui::Ui, playing: bool) -> Option<Transport> {
    let mut action = None;
    let play = if playing { "Pause" } else { "Play" };
    for (label, hover, what) in [
        ("Start", "To the start (Home)", Transport::Start),
        ("Back", "One frame back (Left)", Transport::Back),
        (play, "Space", Transport::Play),
        ("Next", "One frame on (Right)", Transport::Next),
        ("End", "To the end (End)", Transport::End),
    ] {
        if ui.button(label).on_hover_text(hover).clicked() {
            action = Some(what);
        }
    }
    action
}

/// Loop, every frame, and the range played.
fn playback_options(ui: &mut egui::Ui, c: &mut Composer) {
    ui.checkbox(&mut c.playback.looping, "Loop");
    ui.checkbox(&mut c.every_frame, "Every frame")
        .on_hover_text(
            "Draw every frame even when slower than real time, instead of dropping frames",
        );
    let d = c.doc.file.duration;
    let mut ranged = c.playback.range.is_some();
    if ui
        .checkbox(&mut ranged, "Range")
        .on_hover_text("Play only between two times")
        .changed()
    {
        c.playback.range = ranged.then_some((0.0, d));
    }
    if let Some((a, b)) = c.playback.range.as_mut() {
        ui.add(seconds(a, d));
        ui.label("to");
        ui.add(seconds(b, d));
    }
}

/// A time in the scene, `[0, duration]` seconds.
fn seconds(v: &mut f64, duration: f64) -> egui::DragValue<'_> {
    egui::DragValue::new(v)
        .update_while_editing(false)
        .range(0.0..=duration)
        .speed(0.02)
        .suffix(" s")
}

/// The playhead as a number; true when it was typed or dragged.
fn playhead_ui(ui: &mut egui::Ui, c: &mut Composer) -> bool {
    let mut t = c.doc.playhead;
    let changed = ui
        .add(
            egui::DragValue::new(&mut t)
                .update_while_editing(false)
                .range(0.0..=c.doc.file.duration)
                .speed(1.0 / c.doc.file.fps)
                .suffix(" s")
                .max_decimals(3),
        )
        .on_hover_text("The playhead")
        .changed();
    if changed {
        c.doc.playhead = t;
    }
    changed
}

/// The scene's frame rate and duration; the new pair when either changed.
fn timing_ui(ui: &mut egui::Ui, c: &Composer) -> Option<(f64, f64)> {
    let (mut fps, mut duration) = (c.doc.file.fps, c.doc.file.duration);
    let a = ui
        .add(
            egui::DragValue::new(&mut fps)
                .update_while_editing(false)
                .range(1.0..=240.0)
                .speed(0.2)
                .suffix(" fps"),
        )
        .changed();
    let b = ui
        .add(
            egui::DragValue::new(&mut duration)
                .update_while_editing(false)
                .range(0.04..=3600.0)
                .speed(0.02)
                .suffix(" s long"),
        )
        .changed();
    (a || b).then_some((fps, duration))
}

/// What the timeline's rows asked for this frame (applied after drawing).
#[derive(Default)]
struct Rows {
    scrub: Option<f64>,
    select_key: Option<KeyRef>,
    select_object: Option<usize>,
    add: Option<(usize, Track)>,
    moved: Option<(KeyRef, f64)>,
}

/// The ruler: click or drag to scrub (the time asked for).
fn ruler_ui(ui: &mut egui::Ui, c: &mut Composer, width: f32) -> Option<f64> {
    let duration = c.doc.file.duration;
    let mut scrub = None;
    ui.horizontal(|ui| {
        ui.add_sized([NAMES, ROW], egui::Label::new("Time"));
        ui.add_space(56.0);
        let (rect, r) =
            ui.allocate_exact_size(egui::vec2(width, ROW), egui::Sense::click_and_drag());
        c.ruler = rect;
        let p = ui.painter_at(rect.expand(2.0));
        p.rect_filled(rect, 2.0, egui::Color32::from_gray(45));
        let step = nice_step(duration, width);
        let mut s = 0.0;
        while s <= duration + 1e-9 {
            let x = rect.left() + (s / duration) as f32 * rect.width();
            p.line_segment(
                [
                    egui::pos2(x, rect.bottom() - 6.0),
                    egui::pos2(x, rect.bottom()),
                ],
                egui::Stroke::new(1.0, egui::Color32::GRAY),
            );
            p.text(
                egui::pos2(x + 2.0, rect.top()),
                egui::Align2::LEFT_TOP,
                format!("{s:.2}")
                    .trim_end_matches('0')
                    .trim_end_matches('.'),
                egui::FontId::proportional(10.0),
                egui::Color32::LIGHT_GRAY,
            );
            s += step;
        }
        if (r.clicked() || r.dragged())
            && let Some(pos) = r.interact_pointer_pos()
        {
            scrub = Some(((pos.x - rect.left()) / rect.width()) as f64 * duration);
        }
    });
    scrub
}

/// An object's tracks and their names: position, orientation, then each
/// deformation's phase (named by its control file).
fn track_names(of: &csrbf_anim::ObjectFile) -> Vec<(Track, String)> {
    let mut tracks = vec![
        (Track::Position, "position".to_string()),
        (Track::Orientation, "orientation".to_string()),
    ];
    for (pi, p) in of.parts.iter().enumerate() {
        for (di, d) in p.deformations.iter().enumerate() {
            let stem = std::path::Path::new(&d.controls)
                .file_stem()
                .map_or(d.controls.clone(), |s| s.to_string_lossy().into_owned());
            let track = Track::Phase {
                part: pi,
                deformation: di,
            };
            tracks.push((track, format!("phase {stem}")));
        }
    }
    tracks
}

/// The time scale of a row: x of a time, and the frame time nearest an x.
#[derive(Clone, Copy)]
struct Scale {
    rect: egui::Rect,
    duration: f64,
    fps: f64,
}

impl Scale {
    fn x_of(&self, t: f64) -> f32 {
        self.rect.left() + (t / self.duration) as f32 * self.rect.width()
    }

    fn t_of(&self, x: f32) -> f64 {
        let t = ((x - self.rect.left()) / self.rect.width()) as f64 * self.duration;
        ((t * self.fps).round() / self.fps).clamp(0.0, self.duration)
    }

    /// The key of `times` within 6 points of `x`, the nearest.
    fn nearest(&self, times: &[f64], x: f32) -> Option<usize> {
        times
            .iter()
            .enumerate()
            .map(|(i, &t)| (i, (self.x_of(t) - x).abs()))
            .filter(|(_, d)| *d <= 6.0)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
    }
}

/// One track's row: its name, a Key button, and its keys on the time scale
/// (click to select, drag in time).
fn track_row(
    ui: &mut egui::Ui,
    c: &mut Composer,
    (o, of): (usize, &csrbf_anim::ObjectFile),
    (track, name): (Track, &str),
    width: f32,
    out: &mut Rows,
) {
    ui.allocate_ui_with_layout(
        egui::vec2(NAMES, ROW),
        egui::Layout::left_to_right(egui::Align::Center),
        |ui| {
            ui.set_min_width(NAMES);
            ui.add(egui::Label::new(format!("    {name}")).truncate());
        },
    );
    if ui
        .add_sized([50.0, ROW], egui::Button::new("Key"))
        .on_hover_text("A key at the playhead, with the value shown there now")
        .clicked()
    {
        out.add = Some((o, track));
    }
    let (rect, r) = ui.allocate_exact_size(egui::vec2(width, ROW), egui::Sense::click_and_drag());
    c.rows.push(((o, track), rect));
    let scale = Scale {
        rect,
        duration: c.doc.file.duration,
        fps: c.doc.file.fps,
    };
    let times = c.doc.key_times(o, track);
    paint_row(ui, c, (o, of), track, scale, &times);
    row_input(ui, c, (o, track), scale, &times, &r, out);
}

/// A row's background, its curve or line, its keys and the playhead.
fn paint_row(
    ui: &egui::Ui,
    c: &Composer,
    (o, of): (usize, &csrbf_anim::ObjectFile),
    track: Track,
    scale: Scale,
    times: &[f64],
) {
    let rect = scale.rect;
    let p = ui.painter_at(rect.expand(6.0));
    let shade = if c.selected == Some(o) { 38 } else { 32 };
    p.rect_filled(rect, 2.0, egui::Color32::from_gray(shade));
    // A phase track shows its phase over time (0 at the row's bottom, 1 at
    // its top), with a key being dragged where the drag has it; the other
    // tracks a line between keys.
    let phased = match track {
        Track::Phase { part, deformation } => of
            .parts
            .get(part)
            .and_then(|p| p.deformations.get(deformation)),
        _ => None,
    };
    let dragging = c
        .time_drag
        .filter(|((ko, kt, _), _)| *ko == o && *kt == track);
    if let Some(d) = phased {
        let mut keys: Vec<(f64, f64)> = d.phase.iter().map(|k| (k.time, k.phase)).collect();
        if let Some(((_, _, ki), to)) = dragging
            && let Some(k) = keys.get_mut(ki)
        {
            k.0 = to;
        }
        p.add(egui::Shape::line(
            phase_curve(keys, d.easing, rect, scale.duration),
            egui::Stroke::new(1.0, egui::Color32::from_rgb(110, 150, 200)),
        ));
    } else if let [first, .., last] = times {
        p.line_segment(
            [
                egui::pos2(scale.x_of(*first), rect.center().y),
                egui::pos2(scale.x_of(*last), rect.center().y),
            ],
            egui::Stroke::new(1.0, egui::Color32::from_gray(90)),
        );
    }
    for (i, &t) in times.iter().enumerate() {
        let chosen = c.key == Some((o, track, i));
        let t = match dragging {
            Some(((_, _, ki), to)) if ki == i => to,
            _ => t,
        };
        // A phase key sits on its curve, at its phase.
        let y = phased
            .and_then(|d| d.phase.get(i))
            .map_or(rect.center().y, |k| phase_y(rect, k.phase));
        let (size, fill) = if chosen {
            (6.0, egui::Color32::from_rgb(255, 220, 80))
        } else {
            (4.5, egui::Color32::from_rgb(190, 190, 200))
        };
        diamond(&p, egui::pos2(scale.x_of(t), y), size, fill);
    }
    // The playhead.
    let x = scale.x_of(c.doc.playhead);
    p.line_segment(
        [egui::pos2(x, rect.top()), egui::pos2(x, rect.bottom())],
        egui::Stroke::new(1.5, egui::Color32::from_rgb(240, 90, 70)),
    );
}

/// A row's pointer: a drag moves the key under the press in time (else
/// scrubs); a click selects the key under it (else scrubs there and
/// selects the object).
fn row_input(
    ui: &egui::Ui,
    c: &mut Composer,
    (o, track): (usize, Track),
    scale: Scale,
    times: &[f64],
    r: &egui::Response,
    out: &mut Rows,
) {
    let at = r.interact_pointer_pos();
    // A drag starts a few points from where it was pressed: the key is the
    // one under the press.
    let origin = ui.input(|i| i.pointer.press_origin()).or(at);
    if r.drag_started()
        && let Some(pos) = origin
        && let Some(i) = scale.nearest(times, pos.x)
    {
        out.select_key = Some((o, track, i));
        c.time_drag = Some(((o, track, i), times[i]));
    }
    if r.dragged()
        && let Some(pos) = at
    {
        if let Some((k, _)) = c
            .time_drag
            .filter(|((ko, kt, _), _)| *ko == o && *kt == track)
        {
            c.time_drag = Some((k, scale.t_of(pos.x)));
        } else {
            out.scrub = Some(scale.t_of(pos.x));
        }
    }
    if r.drag_stopped()
        && let Some((k, to)) = c.time_drag.take()
        && k.0 == o
        && k.1 == track
        && times.get(k.2).is_some_and(|&t| t != to)
    {
        out.moved = Some((k, to));
    }
    if r.clicked()
        && let Some(pos) = at
    {
        match scale.nearest(times, pos.x) {
            Some(i) => out.select_key = Some((o, track, i)),
            None => {
                out.scrub = Some(scale.t_of(pos.x));
                out.select_object = Some(o);
            }
        }
    }
}

/// A phase track's curve across `rect` (the row of a scene `duration`
/// seconds long): a point every 3 points of width, phase 0 at the bottom
/// (inset 3) and 1 at the top. `keys` are (time, phase), in any order (a key
/// being dragged may have passed another); none is a constant phase of 1,
/// as the scene loader has it.
fn phase_curve(
    mut keys: Vec<(f64, f64)>,
    easing: csrbf_anim::Easing,
    rect: egui::Rect,
    duration: f64,
) -> Vec<egui::Pos2> {
    keys.sort_by(|a, b| a.0.total_cmp(&b.0));
    let track = if keys.is_empty() {
        csrbf_anim::PhaseTrack::constant(1.0)
    } else {
        csrbf_anim::PhaseTrack::new(keys, easing)
    };
    let steps = ((rect.width() / 3.0).ceil() as usize).max(1);
    (0..=steps)
        .map(|i| {
            let f = i as f32 / steps as f32;
            let t = f as f64 * duration;
            egui::pos2(
                rect.left() + f * rect.width(),
                phase_y(rect, track.phase(t)),
            )
        })
        .collect()
}

/// Where a phase lies in a timeline row: 0 at the bottom (inset 3), 1 at
/// the top.
fn phase_y(rect: egui::Rect, phase: f64) -> f32 {
    rect.bottom() - 3.0 - phase as f32 * (rect.height() - 6.0).max(0.0)
}

/// A key's diamond.
fn diamond(p: &egui::Painter, c: egui::Pos2, r: f32, fill: egui::Color32) {
    p.add(egui::Shape::convex_polygon(
        vec![
            egui::pos2(c.x, c.y - r),
            egui::pos2(c.x + r, c.y),
            egui::pos2(c.x, c.y + r),
            egui::pos2(c.x - r, c.y),
        ],
        fill,
        egui::Stroke::new(1.0, egui::Color32::BLACK),
    ));
}

/// Seconds between ruler labels: 1, 2 or 5 times a power of ten, about
/// 70 points apart.
fn nice_step(duration: f64, width: f32) -> f64 {
    let raw = duration * 70.0 / width.max(1.0) as f64;
    let p = 10f64.powf(raw.max(1e-6).log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * p)
}

/// The Composer's status: the scene's size and timing, the playing rate
/// and frames dropped, the frame's time, unsaved.
pub(super) fn compose_status(ui: &mut egui::Ui, c: &Composer, rate: f64, frame: &str) {
    let vertices: usize = c.loaded.scene.as_ref().map_or(0, |s| {
        s.objects.iter().map(|o| o.mesh.positions.len()).sum()
    });
    ui.label(format!(
        "{} objects · {} vertices · {} fps · {:.2} s",
        c.doc.file.objects.len(),
        vertices,
        c.doc.file.fps,
        c.doc.file.duration
    ));
    ui.separator();
    if c.playback.playing {
        ui.label(format!("playing at {rate:.1} fps"));
        if c.every_frame {
            ui.label("(every frame: slower than real time when it must)");
        } else if c.playback.dropped > 0 {
            ui.colored_label(
                egui::Color32::from_rgb(240, 190, 90),
                format!(
                    "{} frames dropped: this machine draws slower than {} fps",
                    c.playback.dropped, c.doc.file.fps
                ),
            );
        }
        ui.separator();
    } else if c.playback.dropped > 0 {
        ui.label(format!("last play dropped {} frames", c.playback.dropped));
        ui.separator();
    }
    ui.label(frame);
    if c.doc.dirty {
        ui.separator();
        ui.label("unsaved");
    }
    ui.separator();
}

#[cfg(test)]
mod tests {
    use super::*;
    use csrbf_anim::Easing;

    /// The curve passes through each key at its time and phase, holds
    /// before the first and after the last, eases between them, and does
    /// not care in which order the keys come.
    #[test]
    fn a_phase_curve_passes_through_its_keys() {
        let rect = egui::Rect::from_min_size(egui::pos2(100.0, 50.0), egui::vec2(300.0, 18.0));
        let keys = vec![(1.0, 0.0), (3.0, 1.0), (2.0, 0.25)];
        let y_of = |phase: f32| rect.bottom() - 3.0 - phase * (rect.height() - 6.0);
        let curve = phase_curve(keys.clone(), Easing::Linear, rect, 4.0);
        assert_eq!(curve.len(), 101);
        assert_eq!(curve[0].x, rect.left());
        assert_eq!(curve[100].x, rect.right());
        let at = |t: f32| {
            curve
                .iter()
                .min_by(|a, b| {
                    let x = rect.left() + t / 4.0 * rect.width();
                    (a.x - x).abs().total_cmp(&(b.x - x).abs())
                })
                .expect("points")
                .y
        };
        for (t, phase) in [(1.0, 0.0), (2.0, 0.25), (3.0, 1.0), (0.0, 0.0), (4.0, 1.0)] {
            assert!(
                (at(t) - y_of(phase)).abs() < 1e-3,
                "t {t}: {} vs {}",
                at(t),
                y_of(phase)
            );
        }
        // Linear between 2 s (0.25) and 3 s (1): at 2.4 s (point 60), 0.55;
        // smooth is flatter near the keys.
        assert!((curve[60].y - y_of(0.55)).abs() < 1e-3, "{}", curve[60].y);
        let smooth = phase_curve(keys, Easing::Smooth, rect, 4.0);
        let near = |c: &[egui::Pos2]| c[52].y; // 2.08 s, just after the key at 2 s
        assert!(
            (near(&smooth) - y_of(0.25)).abs() < (near(&curve) - y_of(0.25)).abs(),
            "smooth {} linear {}",
            near(&smooth),
            near(&curve)
        );
        // No keys: the loader's constant phase of 1.
        let none = phase_curve(Vec::new(), Easing::Smooth, rect, 4.0);
        assert!(none.iter().all(|p| (p.y - y_of(1.0)).abs() < 1e-6));
    }
}
