//! Help: the keys and pointer gestures of the room shown, in a window that
//! F1 or ? opens and closes (and Help > Keys and mouse), and where the
//! README explains the rest. The same tables as the README's.

use eframe::egui;

/// Which room's keys to show.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Room {
    Picker,
    Composer,
}

/// The Picker's pointer gestures: what, does.
const PICKER_POINTER: &[(&str, &str)] = &[
    (
        "Left press on the surface, drag (Place)",
        "add a control vector there and drag its destination; a click alone is a pin",
    ),
    (
        "Left drag on a start or a destination",
        "move it (a start stays on the surface and carries its vector; Ctrl: the start alone)",
    ),
    (
        "Shift+click a marker; left drag on the background",
        "add to the selection; select in a box",
    ),
    ("Right or middle drag, or Alt+left drag", "orbit"),
    ("Shift+right drag, or Alt+Shift+left drag", "pan"),
    ("Wheel", "zoom towards the point under the pointer"),
    (
        "Vertices: left drag a box; Ctrl+drag",
        "choose vertices (facing you, or all with X-ray); paint them with a brush (Shift adds)",
    ),
    (
        "Vertices: drag a handle's X, Y or Z ring",
        "turn the handle about that axis through its pivot",
    ),
    (
        "Vertices: drag inside the yellow ring",
        "rotate, scale or move the handle (the side panel chooses)",
    ),
];

/// The Picker's keys: keys, does.
const PICKER_KEYS: &[(&str, &str)] = &[
    ("P, S, V", "Place, Select, Vertices tool"),
    ("X, Y, Z", "hold moves to that axis; again to free"),
    ("F, Shift+F", "frame the selection, frame everything"),
    ("Del, Backspace", "delete the selected control vectors"),
    (
        "Ctrl+D",
        "stamp: the next clicks add the selected vector's move elsewhere (Esc stops)",
    ),
    (
        "M",
        "mirror the selection (or the layer) across X (Edit menu: Y, Z)",
    ),
    ("Ctrl+A", "select the active layer's vectors"),
    ("Ctrl+Z, Ctrl+Shift+Z or Ctrl+Y", "undo, redo"),
    (
        "Ctrl+O, Ctrl+S, Ctrl+Shift+S",
        "open a mesh, save the control file, save it as",
    ),
    ("Esc", "clear the selection, stop stamping"),
    ("F1 or ?", "this help"),
];

/// The Composer's pointer gestures.
const COMPOSER_POINTER: &[(&str, &str)] = &[
    ("Left click an object", "select it"),
    (
        "Left drag a position key's marker",
        "move the key (along the held axis with X, Y, Z)",
    ),
    (
        "Left drag a ring of the orientation gizmo",
        "turn the selected orientation key",
    ),
    ("Left drag the scene camera's eye or target", "move it"),
    ("Right or middle drag, or Alt+left drag", "orbit"),
    ("Shift+right drag", "pan"),
    ("Wheel", "zoom"),
    (
        "Timeline: click or drag the ruler; drag a key",
        "scrub; move the key in time (snapped to frames)",
    ),
];

/// The Composer's keys.
const COMPOSER_KEYS: &[(&str, &str)] = &[
    ("Space", "play, pause"),
    (
        "Left, Right, Home, End",
        "a frame back, a frame on, to the start, to the end",
    ),
    (
        "K",
        "a position key for the selected object at the playhead",
    ),
    (
        "Del, Ctrl+D",
        "delete the selected key, copy it to the playhead",
    ),
    (
        "Ctrl+C, Ctrl+V",
        "copy the selected key, paste it at the playhead onto the selected object",
    ),
    ("X, Y, Z", "hold a key's drag to that axis; again to free"),
    ("C, F", "look through the scene camera, frame everything"),
    (
        "Ctrl+O, Ctrl+S, Ctrl+Shift+S",
        "open, save, save the scene as",
    ),
    ("Ctrl+E, Ctrl+Shift+E", "export a movie, export glTF"),
    ("Ctrl+Z, Ctrl+Shift+Z or Ctrl+Y", "undo, redo"),
    ("F1 or ?", "this help"),
];

/// Where the README explains each part (its section titles).
const README: &[(&str, &str)] = &[
    (
        "The studio",
        "the Picker: tools, layers, handles, diagnostics",
    ),
    ("The Composer", "scenes, keys, playback, export"),
    ("Control files", "what the Picker saves, key by key"),
    ("Scene files", "what the Composer saves"),
    (
        "Fold-free sweeps",
        "edits that cannot turn the surface inside out",
    ),
];

/// The title of the help window (what a test looks for).
pub(super) const TITLE: &str = "Keys and mouse";

/// Whether F1 or ? was pressed this frame (consumed).
pub(super) fn toggled(ctx: &egui::Context) -> bool {
    ctx.input_mut(|i| {
        i.consume_key(egui::Modifiers::NONE, egui::Key::F1)
            || i.consume_key(egui::Modifiers::NONE, egui::Key::Questionmark)
            || i.consume_key(egui::Modifiers::SHIFT, egui::Key::Questionmark)
    })
}

/// The help window of `room`, while `open` (its close button clears it).
pub(super) fn window(ctx: &egui::Context, room: Room, open: &mut bool) {
    let (pointer, keys) = match room {
        Room::Picker => (PICKER_POINTER, PICKER_KEYS),
        Room::Composer => (COMPOSER_POINTER, COMPOSER_KEYS),
    };
    egui::Window::new(TITLE)
        .open(open)
        .collapsible(false)
        .resizable(true)
        .default_width(560.0)
        .show(ctx, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                table(ui, "pointer", pointer);
                ui.separator();
                table(ui, "keys", keys);
                ui.separator();
                ui.label("The README (README.md beside the program's sources) explains more:");
                table(ui, "readme", README);
            });
        });
}

/// Two columns: what, does.
fn table(ui: &mut egui::Ui, id: &str, rows: &[(&str, &str)]) {
    egui::Grid::new(id)
        .num_columns(2)
        .striped(true)
        .spacing([16.0, 4.0])
        .show(ui, |ui| {
            for (what, does) in rows {
                ui.label(egui::RichText::new(*what).strong());
                ui.label(*does);
                ui.end_row();
            }
        });
}

/// The Help menu: the keys window, and the README's sections.
pub(super) fn menu(ui: &mut egui::Ui, open: &mut bool) {
    if ui.button("Keys and mouse  F1").clicked() {
        *open = true;
        ui.close();
    }
    ui.separator();
    ui.label("In the README:");
    for (section, about) in README {
        ui.label(format!("{section}: {about}"));
    }
}
