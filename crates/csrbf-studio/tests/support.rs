//! Helpers shared by the kittest modules (`app`, `compose`).

use csrbf_studio::app::StudioApp;
use eframe::egui;
use egui_kittest::Harness;

/// The pointer moved to `at` and the primary button pressed (or released)
/// there; the caller steps the harness.
pub fn button(h: &mut Harness<'_, StudioApp>, at: egui::Pos2, pressed: bool) {
    h.event(egui::Event::PointerMoved(at));
    h.event(egui::Event::PointerButton {
        pos: at,
        button: egui::PointerButton::Primary,
        pressed,
        modifiers: egui::Modifiers::NONE,
    });
}
