//! `bench`: fit, bind, evaluate, refit and frame, median of several runs, on a
//! mesh and control file or on the synthetic scenes of the issue.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use csrbf::Combine;
use csrbf::synthetic::SyntheticScene;
use csrbf::{Binding, FitPhases, SolverChoice, System, frame};
use csrbf_edit::controls::{ControlFile, ControlSpec};
use glam::{DVec3, Vec3};
use serde_json::json;

use crate::common::{Progress, read_controls, read_mesh};

#[derive(Args)]
pub struct BenchArgs {
    /// A mesh to deform (with --controls, or the mesh of --scene scan).
    #[arg(long)]
    mesh: Option<PathBuf>,
    /// A control file (with --mesh); its first deformation is measured.
    #[arg(long, requires = "mesh")]
    controls: Option<PathBuf>,
    /// A synthetic scene: fish (975 V / 92 N), face (6158 V / 32 N), 100k (100k V / 1k N), 1m (1M V / 10k N),
    /// V/N (any sizes, R for about 44 neighbours: 100000/100000 fits 100k starts),
    /// scan: the vertices of --mesh with --starts of them spread over it, R --share of its diagonal,
    /// or volume/N/K/S[/R]: a tetrahedral box of N^3 cubes around K^3 cavities of S^3 cubes, the cavities moved (R in cubes, 4),
    /// every boundary node a control (volume/56/0/0: 1M cells). A volume --mesh takes a boundary morph as --controls.
    #[arg(long)]
    scene: Option<String>,
    /// Starts of --scene scan.
    #[arg(long, default_value_t = 4000, value_parser = clap::value_parser!(u32).range(1..=10_000_000))]
    starts: u32,
    /// R of --scene scan as a share of the mesh's diagonal.
    #[arg(long, default_value_t = 0.05)]
    share: f64,
    /// Every synthetic scene in turn.
    #[arg(long)]
    all: bool,
    /// Force a solver: auto, skyline or supernodal.
    #[arg(long, default_value = "auto")]
    solver: String,
    /// Runs per phase, 1 to 1000; the median is reported.
    #[arg(long, default_value_t = 7, value_parser = clap::value_parser!(u32).range(1..=1000))]
    runs: u32,
    /// Print one JSON object (a list with --all).
    #[arg(long)]
    json: bool,
    /// Write the synthetic scene as a mesh (PLY: its points on a sphere with their
    /// Delaunay triangles) and its controls (JSON) into this directory.
    #[arg(long)]
    export: Option<PathBuf>,
    /// The papers' table: Face, Fish, Ball, with frames per second for
    /// deformation alone and with rendering at 1024x768.
    #[arg(long)]
    paper: bool,
    /// Samples per pixel for --paper's rendering: 4 (smooth edges, as movies) or 1.
    #[arg(long, default_value_t = 4)]
    samples: u32,
}

type Scene = SyntheticScene;

fn synthetic(name: &str) -> Result<Scene> {
    csrbf::synthetic::scene(name).with_context(|| {
        format!(
            "unknown scene {name:?}: expected {}, V/N (V points, N starts: 100000/100000) or scan",
            csrbf::synthetic::SCENES.join(", ")
        )
    })
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Untimed calls before the timed ones: at least [`WARM_CALLS`], and
/// more until [`WARM_MS`] have passed (none begun after [`WARM_CAP_MS`]).
const WARM_CALLS: usize = 3;
const WARM_MS: f64 = 100.0;
const WARM_CAP_MS: f64 = 1000.0;

/// Runs `f` untimed until it is warm, then `runs` times; the median in
/// milliseconds. Warm: the process's first calls start the thread pool,
/// fault in the allocator's pages and bring the cores up to speed (a
/// scan's fit measured 26, 16 and 10 ms, then 7 from the fourth on), so
/// it is called [`WARM_CALLS`] times and for [`WARM_MS`] at least, or once
/// when a call takes [`WARM_CAP_MS`]. The peer script warms up alike.
fn time<T>(runs: usize, mut f: impl FnMut() -> Result<T>) -> Result<(f64, T)> {
    let warm = Instant::now();
    let mut last = f()?;
    let mut calls = 1;
    loop {
        let ms = warm.elapsed().as_secs_f64() * 1e3;
        if ms >= WARM_CAP_MS || (calls >= WARM_CALLS && ms >= WARM_MS) {
            break;
        }
        last = f()?;
        calls += 1;
    }
    let mut times = Vec::with_capacity(runs);
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        let out = f()?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
        last = out; // the previous one is dropped outside the timing
    }
    Ok((median(times), last))
}

/// Peak resident memory of this process so far, in MB (Linux; 0 elsewhere).
pub(crate) fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(0.0, |kb| kb / 1024.0)
}

pub fn bench(args: &BenchArgs, progress: &Progress) -> Result<()> {
    if args.paper {
        return paper(args, progress);
    }
    let volume_files = match (&args.mesh, &args.controls) {
        (Some(m), Some(c)) if crate::volume::is_volume(m) => Some((m.as_path(), c.as_path())),
        _ => None,
    };
    if volume_files.is_some()
        || args
            .scene
            .as_deref()
            .is_some_and(|s| s.starts_with("volume"))
    {
        return crate::volume::bench(
            args.scene.as_deref(),
            volume_files,
            args.runs as usize,
            args.json,
            args.export.as_deref(),
            progress,
        );
    }
    let solver: SolverChoice = args.solver.parse().map_err(anyhow::Error::msg)?;
    // The faces of --scene scan's mesh, for --export.
    let mut scan_faces = None;
    let scenes: Vec<Scene> = if args.all {
        ["fish", "face", "100k", "1m"]
            .into_iter()
            .map(synthetic)
            .collect::<Result<_>>()?
    } else if args.scene.as_deref() == Some("scan") {
        let Some(m) = &args.mesh else {
            bail!("--scene scan puts its starts on a mesh's surface: give --mesh M");
        };
        if !(args.share > 0.0 && args.share <= 1.0) {
            bail!("--share {}: must be within (0, 1]", args.share);
        }
        let mesh = read_mesh(m, progress)?;
        let name = m
            .file_stem()
            .map_or("scan".into(), |s| format!("scan-{}", s.to_string_lossy()));
        scan_faces = Some(mesh.faces);
        vec![csrbf::synthetic::scan_scene(
            &name,
            mesh.positions,
            args.starts as usize,
            args.share,
        )]
    } else if let Some(s) = &args.scene {
        vec![synthetic(s)?]
    } else if let (Some(m), Some(c)) = (&args.mesh, &args.controls) {
        if args.export.is_some() {
            bail!(
                "--export writes the synthetic scenes (--scene NAME, --scene scan); {} and {} are files already",
                m.display(),
                c.display()
            );
        }
        let mesh = read_mesh(m, progress)?;
        let spec = read_controls(c, progress)?.deformations.swap_remove(0);
        let spec = spec
            .resolve(&mesh.positions, &|n| mesh.part_vertices(n))
            .with_context(|| c.display().to_string())?;
        vec![Scene {
            name: m.display().to_string(),
            points: mesh.positions,
            starts: spec.starts,
            targets: spec.targets,
            options: spec.options,
        }]
    } else {
        bail!("give --mesh and --controls, --scene NAME, --all or --paper");
    };
    if let Some(dir) = &args.export {
        for s in &scenes {
            export(s, scan_faces.clone(), dir)?;
        }
        return Ok(());
    }
    let mut results = Vec::new();
    for mut s in scenes {
        s.options = s.options.with_solver(solver);
        progress.say(format_args!(
            "{}: {} vertices, {} controls, R {:.4}",
            s.name,
            s.points.len(),
            s.starts.len(),
            s.options.radius
        ));
        let r = run(&s, args.runs as usize)?;
        if !args.json {
            out_line!(
                "{:<10} V {:>8} N {:>6} R {:.4} | {} {:>4} nbrs | fit {:>9.3} ms | bind {:>9.3} ms | evaluate {:>9.3} ms ({}) | fit+evaluate {:>9.3} ms | refit {:>8.3} ms | frame {:>7.3} ms | peak {:>6.0} MB",
                s.name,
                s.points.len(),
                s.starts.len(),
                s.options.radius,
                r["solver"].as_str().unwrap_or(""),
                r["neighbours_mean"].as_f64().unwrap_or(0.0).round(),
                r["fit_ms"].as_f64().unwrap_or(0.0),
                r["bind_ms"].as_f64().unwrap_or(0.0),
                r["evaluate_ms"].as_f64().unwrap_or(0.0),
                r["roofline"]["evaluate_over_bound"]
                    .as_f64()
                    .map_or("no roofline".to_string(), |q| format!("{q:.1}x roofline")),
                r["fit_evaluate_ms"].as_f64().unwrap_or(0.0),
                r["refit_ms"].as_f64().unwrap_or(0.0),
                r["frame_ms"].as_f64().unwrap_or(0.0),
                r["peak_rss_mb"].as_f64().unwrap_or(0.0),
            );
        }
        results.push(r);
    }
    if args.json {
        let out = if results.len() == 1 {
            results.swap_remove(0)
        } else {
            json!(results)
        };
        out_line!("{}", serde_json::to_string_pretty(&out)?);
    }
    Ok(())
}

fn run(s: &Scene, runs: usize) -> Result<serde_json::Value> {
    // Fit: everything that depends on the controls.
    // Each fit's phases: the timed ones are the last `runs`.
    let mut phases: Vec<FitPhases> = Vec::new();
    let (fit_ms, (sys, def)) = time(runs, || {
        let sys = System::new(&s.starts, s.options)?;
        let def = sys.solve(&s.targets)?;
        phases.push(sys.stats().phases);
        Ok((sys, def))
    })?;
    let phases = median_phases(&phases[phases.len().saturating_sub(runs.max(1))..]);
    let (evaluate_ms, disp) = time(runs, || Ok(def.displacements_f32(&s.points)))?;
    // What the evaluation did, counted in a pass of its own (not timed),
    // and the machine's arithmetic rate measured now, for its roofline.
    let counts = def.evaluation_counts(&s.points);
    let roofline = def.roofline(&counts);
    let (fit_evaluate_ms, _) = time(runs, || {
        let d = System::new(&s.starts, s.options)?.solve(&s.targets)?;
        Ok(d.displacements_f32(&s.points))
    })?;
    let (bind_ms, binding) = time(runs.min(3), || Ok(Binding::new(&def, &s.points)))?;
    let moved: Vec<DVec3> = s
        .targets
        .iter()
        .map(|t| *t + DVec3::new(0.0, 0.0, 0.01 * s.options.radius))
        .collect();
    let mut out = disp.clone();
    let (refit_ms, _) = time(runs, || {
        let d = sys.solve(&moved)?;
        binding.displacements_into(&d, &mut out)?;
        Ok(())
    })?;
    // A start dragged a little (its neighbours kept): the system rebuilt
    // from the one before, then solved.
    let mut dragged = s.starts.clone();
    if let Some(d) = dragged.get_mut(s.starts.len() / 2) {
        *d += DVec3::new(1e-3, -2e-3, 1e-3) * s.options.radius;
    }
    let (moved_start_ms, rebuilt) = time(runs, || {
        let again = sys.rebuild(&dragged, s.options)?;
        again.solve(&s.targets)?;
        Ok(again.stats().reused)
    })?;
    let mut positions = vec![Vec3::ZERO; s.points.len()];
    let mut k = 0;
    let (frame_ms, _) = time(runs.max(11), || {
        k += 1;
        frame(&s.points, &out, (k % 10) as f64 / 10.0, &mut positions)?;
        Ok(())
    })?;
    let st = sys.stats();
    Ok(json!({
        "scene": s.name,
        "vertices": s.points.len(),
        "controls": s.starts.len(),
        "radius": s.options.radius,
        "solver": st.solver,
        "neighbours_mean": st.neighbours_mean,
        "bandwidth": st.bandwidth,
        "envelope": st.envelope,
        "profile_bytes": st.profile_bytes,
        "dense_bytes": st.dense_bytes,
        "factor_bytes": st.factor_bytes,
        "binding_mb": binding.bytes() as f64 / 1e6,
        "pairs": binding.pairs(),
        "fit_ms": fit_ms,
        "fit_phases_ms": fit_phases(&phases),
        "factor": {
            "multiply_adds": st.factor_flops,
            // At the machine's f64 rate on every thread (the roofline's
            // measurement below): the numeric phase's time over this.
            "bound_ms": roofline.f64_bound_ms(st.factor_flops),
            "numeric_over_bound": (st.factor_flops > 0.0)
                .then(|| phases.numeric_ms / roofline.f64_bound_ms(st.factor_flops)),
            "multiply_adds_per_ns": st.factor_flops / (phases.numeric_ms * 1e6),
        },
        "bind_ms": bind_ms,
        "evaluate_ms": evaluate_ms,
        "evaluation": {
            "points": counts.points,
            "cells": counts.cells,
            "candidates": counts.candidates,
            "kernel_evaluations": counts.kernel_evaluations,
            "hits": counts.hits,
            "candidates_per_s": counts.candidates as f64 / (evaluate_ms * 1e-3),
            "kernel_evaluations_per_s": counts.kernel_evaluations as f64 / (evaluate_ms * 1e-3),
        },
        "roofline": {
            "lanes": roofline.lanes,
            "threads": roofline.threads,
            "fma_per_ns": roofline.fma_per_ns,
            "operations_per_register": roofline.operations,
            "bound_ms": roofline.bound_ms,
            // None (null) when nothing was counted: no kernel evaluations.
            "evaluate_over_bound": (roofline.bound_ms > 0.0).then(|| evaluate_ms / roofline.bound_ms),
        },
        "fit_evaluate_ms": fit_evaluate_ms,
        "refit_ms": refit_ms,
        // A start moved by 0.2 % of R: the fit again (only the matrix
        // assembled and factored when its neighbours stay: `reused`).
        "moved_start": { "ms": moved_start_ms, "reused": rebuilt },
        "frame_ms": frame_ms,
        "peak_rss_mb": peak_rss_mb(),
        "runs": runs,
        "threads": rayon::current_num_threads(),
    }))
}

/// Where a build of the system spent its time: each phase's median over
/// the timed fits, and their sum (the fit's median also holds the solve).
fn fit_phases(p: &FitPhases) -> serde_json::Value {
    json!({
        "checks": p.checks_ms,
        "graph": p.graph_ms,
        "ordering": p.ordering_ms,
        "assembly": p.assembly_ms,
        "symbolic": p.symbolic_ms,
        "numeric": p.numeric_ms,
        "polynomial": p.polynomial_ms,
        "total": p.total_ms(),
    })
}

/// Each phase's median over `all` (the timed fits).
fn median_phases(all: &[FitPhases]) -> FitPhases {
    let of = |f: fn(&FitPhases) -> f64| {
        if all.is_empty() {
            0.0
        } else {
            median(all.iter().map(f).collect())
        }
    };
    FitPhases {
        checks_ms: of(|p| p.checks_ms),
        graph_ms: of(|p| p.graph_ms),
        ordering_ms: of(|p| p.ordering_ms),
        assembly_ms: of(|p| p.assembly_ms),
        symbolic_ms: of(|p| p.symbolic_ms),
        numeric_ms: of(|p| p.numeric_ms),
        polynomial_ms: of(|p| p.polynomial_ms),
    }
}

/// Writes a scene's points as a mesh and its controls; `faces` are the
/// mesh's own (a scan scene), else the points' sphere's.
fn export(s: &Scene, faces: Option<csrbf_mesh::Faces>, dir: &std::path::Path) -> Result<()> {
    // The synthetic points lie on a sphere about (0.5, 0.5, 0.5): their faces
    // are its Delaunay triangulation, so the export is a mesh a viewer can show.
    let mesh = csrbf_mesh::Mesh {
        faces: faces
            .unwrap_or_else(|| csrbf_mesh::shapes::sphere_faces(&s.points, glam::Vec3::splat(0.5))),
        positions: s.points.clone(),
        ..Default::default()
    };
    let stem = file_stem(&s.name);
    csrbf_mesh::write(&dir.join(format!("{stem}.ply")), &mesh)?;
    let spec = ControlSpec::new(s.starts.clone(), s.targets.clone(), s.options);
    let file = ControlFile::new(vec![spec], Combine::Chain);
    csrbf_mesh::write_atomic(&dir.join(format!("{stem}.json")), file.to_text().as_bytes())?;
    Ok(())
}

/// A synthetic scene's name as a file name inside the export folder: every
/// character but letters, digits, `-` and `_` made `-` ("100000/100000" is
/// "100000-100000").
fn file_stem(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .collect()
}

/// The papers' table (Athlon 1 GHz, 2002, rendering at 1024x768 included):
/// face 107 fps, fish 632, ball 72.
/// Seconds of passes over a demo's frames that `--paper` times at least
/// for its deformation-alone figure.
const PAPER_SECONDS: f64 = 0.5;

fn paper(args: &BenchArgs, progress: &Progress) -> Result<()> {
    let dir = std::env::temp_dir().join(format!("csrbf-paper-{}", std::process::id()));
    let result = paper_in(&dir, args, progress);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

fn paper_in(dir: &std::path::Path, args: &BenchArgs, progress: &Progress) -> Result<()> {
    use csrbf_render::{SceneOptions, SceneRenderer};
    let mut rows = Vec::new();
    for (name, label, paper_fps) in [
        ("face", "Face", 107.0),
        ("fish", "Fish", 632.0),
        ("ball", "Ball", 72.0),
    ] {
        let Some(d) = csrbf_anim::demos::demo(name) else {
            continue;
        };
        let path = d.write(&dir.join(name), name)?;
        let scene = csrbf_anim::Scene::load(&path)?;
        let frames = scene.frame_count();
        let times: Vec<f64> = (0..frames).map(|k| k as f64 / scene.file.fps).collect();
        // Deformation alone: every frame of the animation, several passes;
        // at least `--runs` and enough for half a second, at most 1000 (a
        // pass of the fish takes about 3 ms: seven passes were a window of
        // 21 ms, which one hiccup of a shared machine could fill).
        let mut per_pass = Vec::new();
        let mut frame = csrbf_anim::Frame::default();
        let start = Instant::now();
        while per_pass.len() < (args.runs as usize).max(3)
            || (start.elapsed().as_secs_f64() < PAPER_SECONDS && per_pass.len() < 1000)
        {
            let t = Instant::now();
            for &time in &times {
                scene.frame_into(time, &mut frame);
                std::hint::black_box(&frame);
            }
            per_pass.push(t.elapsed().as_secs_f64() / frames as f64);
        }
        let deform_s = median(per_pass);
        // With rendering and read-back at 1024x768.
        let mut r = SceneRenderer::with_samples(&scene, 1024, 768, args.samples)?;
        r.render(&scene, &scene.frame(0.0), SceneOptions::default())?; // shader compilation
        let t = Instant::now();
        for &time in &times {
            scene.frame_into(time, &mut frame);
            std::hint::black_box(r.render(&scene, &frame, SceneOptions::default())?);
        }
        let render_s = t.elapsed().as_secs_f64() / frames as f64;
        let obj = &scene.objects[if name == "ball" { 1 } else { 0 }];
        let vectors: usize = scene
            .frame(d.poster)
            .objects
            .iter()
            .map(|o| o.controls.len())
            .sum();
        let radii: Vec<f64> = obj
            .deformations
            .iter()
            .flat_map(|a| a.stages.iter().map(|s| s.deformation.radius()))
            .collect();
        let radius = if name == "ball" {
            "varies".to_string()
        } else {
            radii
                .iter()
                .map(|r| format!("{r}"))
                .collect::<Vec<_>>()
                .join("/")
        };
        let vectors = if name == "ball" {
            format!("varies ({vectors} at an impact)")
        } else {
            format!("{vectors}")
        };
        progress.say(format_args!("{label}: {frames} frames"));
        rows.push(json!({
            "model": label,
            "vertices": obj.mesh.positions.len(),
            "polygons": obj.mesh.faces.len(),
            "triangles": obj.mesh.faces.triangle_count(),
            "vectors": vectors,
            "radius": radius,
            "deformation_fps": 1.0 / deform_s,
            "deformation_render_fps": 1.0 / render_s,
            "paper_fps": paper_fps,
            "deformation_x_paper": 1.0 / deform_s / paper_fps,
            "render_x_paper": 1.0 / render_s / paper_fps,
            "adapter": r.renderer().adapter(),
        }));
    }
    if args.json {
        out_line!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        out_line!(
            "| model | vertices | polygons | vectors | R | deformation fps | x papers | with rendering 1024x768 fps | x papers | papers' fps |"
        );
        out_line!("|---|---|---|---|---|---|---|---|---|---|");
        for r in &rows {
            out_line!(
                "| {} | {} | {} | {} | {} | {:.0} | {:.0}x | {:.1} | {:.2}x | {} |",
                r["model"].as_str().unwrap_or(""),
                r["vertices"],
                r["polygons"],
                r["vectors"].as_str().unwrap_or(""),
                r["radius"].as_str().unwrap_or(""),
                r["deformation_fps"].as_f64().unwrap_or(0.0),
                r["deformation_x_paper"].as_f64().unwrap_or(0.0),
                r["deformation_render_fps"].as_f64().unwrap_or(0.0),
                r["render_x_paper"].as_f64().unwrap_or(0.0),
                r["paper_fps"],
            );
        }
    }
    Ok(())
}
