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

/// Answers the open file dialog with `path` (typed into its focused name
/// field, then its Open or Save button).
pub fn choose(h: &mut Harness<'_, StudioApp>, path: &std::path::Path, verb: &str) {
    use egui_kittest::kittest::Queryable;
    h.run_steps(2);
    h.event(egui::Event::Text(path.display().to_string()));
    h.run_steps(1);
    h.get_by_label(verb).click();
    h.run_steps(3);
}
