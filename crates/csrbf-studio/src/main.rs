//! `csrbf-studio [MESH] [CONTROLS]`: the Picker. Opens a mesh (and a control
//! file on it) and lets a person place, drag and tune control vectors with a
//! live preview; `csrbf-studio SCENE.scene.json` opens a scene in the
//! Composer. See docs/studio.md and docs/composer.md.

use std::path::PathBuf;

use csrbf_studio::app::{Args, StudioApp};
use eframe::egui;

fn main() -> std::process::ExitCode {
    let mut args = Args::default();
    let mut size = [1280.0, 800.0];
    let mut it = std::env::args_os().skip(1);
    while let Some(a) = it.next() {
        let s = a.to_string_lossy();
        match s.as_ref() {
            "-h" | "--help" => {
                println!(
                    "csrbf-studio [MESH [CONTROLS] | SCENE.scene.json] [--size WxH]\n\n\
                     The Picker: place, drag and tune control vectors on a mesh with a live preview.\n\
                     MESH: .obj .ply .stl .off .gltf .glb; CONTROLS: a control file as `csrbf deform` reads it.\n\
                     The Composer: a scene file as `csrbf animate` reads it opens in it (objects, keys, playback, export).\n\
                     Keys: see docs/studio.md and docs/composer.md."
                );
                return std::process::ExitCode::SUCCESS;
            }
            "--size" => {
                let v = it
                    .next()
                    .map(|v| v.to_string_lossy().into_owned())
                    .unwrap_or_default();
                match v
                    .split_once('x')
                    .and_then(|(w, h)| Some((w.parse::<f32>().ok()?, h.parse::<f32>().ok()?)))
                {
                    Some((w, h)) if w >= 200.0 && h >= 150.0 && w <= 16384.0 && h <= 16384.0 => {
                        size = [w, h]
                    }
                    _ => {
                        eprintln!(
                            "error: --size {v:?}: expected WIDTHxHEIGHT, e.g. 1280x800 (at least 200x150)"
                        );
                        return std::process::ExitCode::from(2);
                    }
                }
            }
            _ if s.starts_with('-') => {
                eprintln!("error: unknown option {s:?} (see --help)");
                return std::process::ExitCode::from(2);
            }
            _ if args.mesh.is_none() => args.mesh = Some(PathBuf::from(a)),
            _ if args.controls.is_none() => args.controls = Some(PathBuf::from(a)),
            _ => {
                eprintln!("error: too many arguments: csrbf-studio [MESH] [CONTROLS]");
                return std::process::ExitCode::from(2);
            }
        }
    }
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_inner_size(size)
            .with_title("csrbf studio")
            .with_drag_and_drop(true),
        // A software rasteriser often misses a display refresh by a little
        // and then waits for the next one (22 fps for 30 fps scenes at
        // 1280x800 on lavapipe): frames are shown as soon as drawn.
        // CSRBF_STUDIO_VSYNC=1 waits for the display again.
        wgpu_options: eframe::egui_wgpu::WgpuConfiguration {
            surface: eframe::egui_wgpu::SurfaceConfig {
                present_mode: if std::env::var_os("CSRBF_STUDIO_VSYNC").is_some() {
                    eframe::wgpu::PresentMode::AutoVsync
                } else {
                    eframe::wgpu::PresentMode::AutoNoVsync
                },
                desired_maximum_frame_latency: Some(2),
            },
            ..Default::default()
        },
        ..Default::default()
    };
    let run = eframe::run_native(
        "csrbf-studio",
        options,
        Box::new(move |cc| Ok(Box::new(StudioApp::new(cc, args)))),
    );
    match run {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!(
                "error: cannot open a window: {e}\n(on a machine without a display, run it under Xvfb: scripts/studio.sh)"
            );
            std::process::ExitCode::FAILURE
        }
    }
}
