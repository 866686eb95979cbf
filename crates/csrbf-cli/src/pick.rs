//! `pick`: what lies under a pixel of the picture `render` draws with the
//! same flags: point, triangle, face, nearest vertex, parts.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use csrbf_anim::camera::axis_name;
use csrbf_mesh::Bvh;
use glam::Vec2;

use crate::common::Progress;
use crate::look::size_or;
use crate::view::{CameraArgs, aim};

/// Options of `pick`.
#[derive(clap::Args, Debug)]
pub struct PickArgs {
    /// The mesh.
    #[arg(long)]
    pub mesh: PathBuf,
    /// A control file: pick on the deformed mesh.
    #[arg(long)]
    pub controls: Option<PathBuf>,
    /// Phase in [0, 1].
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub phase: f64,
    /// The pixel X,Y (from the top-left corner) of the picture `render` draws with the same flags.
    #[arg(long)]
    pub pixel: String,
    /// Picture size WIDTHxHEIGHT (default 1024x768, as `render`).
    #[arg(long)]
    pub size: Option<String>,
    #[command(flatten)]
    pub camera: CameraArgs,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

pub fn pick(a: &PickArgs, progress: &Progress) -> Result<()> {
    crate::common::check_phase(a.phase)?;
    let size = size_or(a.size.as_deref(), crate::look::DEFAULT_SIZE)?;
    let (x, y) = a
        .pixel
        .split_once(',')
        .and_then(|(x, y)| Some((x.trim().parse::<f32>().ok()?, y.trim().parse::<f32>().ok()?)))
        .with_context(|| format!("--pixel {:?}: expected X,Y, e.g. 512,384", a.pixel))?;
    if !(x >= 0.0 && y >= 0.0 && x < size[0] as f32 && y < size[1] as f32) {
        bail!(
            "--pixel {},{}: outside the {}x{} picture (0..{} across, 0..{} down)",
            x,
            y,
            size[0],
            size[1],
            size[0] - 1,
            size[1] - 1
        );
    }
    let aimed = aim(
        &a.mesh,
        a.controls.as_deref(),
        a.phase,
        size,
        &a.camera,
        false,
    )?;
    let positions = &aimed.positions;
    let triangles = aimed.mesh.faces.triangles();
    let t = Instant::now();
    let bvh = Bvh::new(positions, &triangles);
    let build_ms = t.elapsed().as_secs_f64() * 1e3;
    // The centre of the pixel, as the renderer samples it.
    let ray = aimed
        .camera
        .ray(Vec2::new(x.floor() + 0.5, y.floor() + 0.5), size);
    let t = Instant::now();
    let hit = bvh.cast(positions, &ray);
    let query_us = t.elapsed().as_secs_f64() * 1e6;
    progress.say(format_args!(
        "up {} ({}); BVH over {} triangles in {build_ms:.1} ms, query {query_us:.1} us",
        axis_name(aimed.up.0),
        aimed.up.1,
        bvh.len()
    ));
    let value = match hit {
        None => serde_json::json!({ "hit": false, "pixel": [x, y] }),
        Some(h) => {
            let rest = &aimed.mesh.positions;
            let rest_point = h.point_in(&triangles, rest);
            let nearest = h.nearest_vertex(&triangles);
            let face = aimed.mesh.faces.face_of_triangle(h.triangle as usize);
            let parts: Vec<String> = aimed
                .mesh
                .parts
                .iter()
                .filter(|p| p.faces.binary_search(&(face as u32)).is_ok())
                .map(|p| format!("{} {}", p.kind.name(), p.name))
                .collect();
            serde_json::json!({
                "hit": true,
                "pixel": [x, y],
                "point": h.point.to_array(),
                "rest_point": rest_point.to_array(),
                "distance": h.t,
                "triangle": h.triangle,
                "face": face,
                "nearest_vertex": nearest,
                "nearest_vertex_position": rest[nearest as usize].to_array(),
                "parts": parts,
            })
        }
    };
    if a.json {
        out_line!("{}", serde_json::to_string_pretty(&value)?);
    } else if value["hit"] == false {
        out_line!("pixel {x},{y}: no surface (background)");
    } else {
        let v = &value;
        out_line!("pixel {x},{y}:");
        out_line!("  point        {}", v["point"]);
        out_line!(
            "  rest point   {}  (use it as a control's \"from\")",
            v["rest_point"]
        );
        out_line!("  triangle     {}  (face {})", v["triangle"], v["face"]);
        out_line!(
            "  nearest      vertex {} at {}",
            v["nearest_vertex"],
            v["nearest_vertex_position"]
        );
        out_line!("  parts        {}", v["parts"]);
    }
    Ok(())
}
