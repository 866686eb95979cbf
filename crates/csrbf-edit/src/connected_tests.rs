//! A region that follows the surface (issue 23): an arm's edit leaves the
//! torso beside it alone, however near in space.

use glam::{DVec3, Vec3};

use crate::controls::ControlFile;
use csrbf::synthetic::{grid, hairpin};
use csrbf::{Combine, compose};
use csrbf::{Origin, Region};

/// Pulls the arm leg of a hairpin outward near its bottom with R wide
/// enough to reach the torso leg across the gap.
fn arm_pull(region: &str) -> String {
    format!(
        r#"{{"radius": 0.6, "kernel": "c2",
            "controls": [{{"from": [0.2, -1.5, 0.5], "to": [0.3, -1.5, 0.5]}},
                         {{"from": [0.2, -1.0, 0.5], "to": [0.2, -1.0, 0.5]}}],
            "region": {region}}}"#
    )
}

fn moved_on(text: &str, points: &[Vec3], tris: &[[u32; 3]]) -> Vec<f32> {
    let file = ControlFile::parse(text).expect("parse");
    let spec = file.deformations[0]
        .resolve_on(points, tris, &|_| None)
        .expect("resolve");
    let stages = spec.fit().expect("fit");
    let out = compose(points, &stages, Combine::Chain).expect("compose");
    out.iter()
        .zip(points)
        .map(|(a, b)| a.distance(*b))
        .collect()
}

#[test]
fn an_arm_edit_leaves_the_torso_beside_it_alone() {
    let (points, tris, torso) = hairpin(0.2, 2.0);
    let largest_on = |m: &[f32], on: bool| {
        m.iter()
            .zip(&torso)
            .filter(|(_, t)| **t == on)
            .map(|(m, _)| *m)
            .fold(0.0f32, f32::max)
    };
    // In space, the torso leg 0.2 away moves with the arm.
    let spatial = moved_on(&arm_pull("null"), &points, &tris);
    assert!(
        largest_on(&spatial, true) > 0.01,
        "the space map reaches the torso"
    );
    // Along the surface it is 3.9 away (up, over, down): it stays.
    let connected = moved_on(
        &arm_pull(r#"{"connected": {"distance": 0.5}, "falloff": 0.3}"#),
        &points,
        &tris,
    );
    assert_eq!(largest_on(&connected, true), 0.0, "the torso moved");
    // The arm still reaches its destination.
    assert!((largest_on(&connected, false) - 0.1).abs() < 1e-4);
    // And matches the space map where the region weighs 1.
    for (i, p) in points.iter().enumerate() {
        if p.x > 0.15 && (p.y + 1.5).abs() < 0.1 && (p.z - 0.5).abs() < 0.3 {
            assert!((connected[i] - spatial[i]).abs() < 1e-6, "vertex {i}");
        }
    }
}

#[test]
fn other_pieces_of_the_mesh_weigh_nothing() {
    // Two flat sheets meeting edge to edge in space, not sharing a vertex.
    let (mut points, mut tris) = grid(10);
    let (q, u) = grid(10);
    let base = points.len() as u32;
    points.extend(q.iter().map(|p| *p + Vec3::X));
    tris.extend(u.iter().map(|t| t.map(|v| v + base)));
    let text = r#"{"radius": 0.5, "controls": [{"from": [0.95, 0.5, 0], "to": [0.95, 0.5, 0.1]}],
                   "region": {"connected": {"distance": 0.3, "from": "starts"}, "falloff": 0.2}}"#;
    let m = moved_on(text, &points, &tris);
    assert!(m[..base as usize].iter().any(|&x| x > 0.05));
    assert!(
        m[base as usize..].iter().all(|&x| x == 0.0),
        "the other sheet moved"
    );
    // The weights themselves: 1 near the start, blended, none past 0.5.
    let spec = &ControlFile::parse(text).expect("parse").deformations[0];
    let r = spec.resolve_on(&points, &tris, &|_| None).expect("resolve");
    let Region::Weights { vertices, weights } = &r.region else {
        panic!("not resolved: {:?}", r.region);
    };
    let start = DVec3::new(0.95, 0.5, 0.0);
    for (&v, &w) in vertices.iter().zip(weights) {
        assert!(v < base);
        let d = points[v as usize].as_dvec3().distance(start);
        assert!(d < 0.5 + 1e-9 && w > 0.0 && w <= 1.0, "{v}: {d} {w}");
        // The start enters at its nearest vertex, up to an edge (0.1) off.
        if d < 0.3 - 0.1 {
            assert_eq!(w, 1.0, "{v} at {d}");
        }
    }
}

#[test]
fn a_handle_measures_from_its_selection() {
    let (points, tris, torso) = hairpin(0.2, 2.0);
    // Turn the arm's lower half about a pivot at its middle.
    let text = r#"{"radius": 0.6, "kernel": "c2",
        "handle": {"select": {"box": {"min": [0.15, -2.1, -1], "max": [0.3, -1.4, 2]}},
                   "rotate": {"axis": [0, 0, 1], "angle_deg": 20, "pivot": [0.2, -1.2, 0.5]}},
        "anchor": {"box": {"min": [0.15, -0.9, -1], "max": [0.3, 0.0, 2]}},
        "region": {"connected": {"distance": 0.2}, "falloff": 0.2}}"#;
    let f = ControlFile::parse(text).expect("parse");
    assert_eq!(f.deformations[0].region.origin(), Some(Origin::Handle));
    assert!(f.deformations[0].needs_mesh());
    let m = moved_on(text, &points, &tris);
    assert!(m.iter().zip(&torso).all(|(m, t)| !*t || *m == 0.0));
    assert!(m.iter().any(|&x| x > 0.05));
}

#[test]
fn connected_regions_are_checked_and_written_back() {
    let bad = [
        (
            r#"{"connected": {"distance": -1}}"#,
            "region.connected.distance",
        ),
        (
            r#"{"connected": {"distance": "far"}}"#,
            "region.connected.distance",
        ),
        (r#"{"connected": {}}"#, "region.connected.distance"),
        (
            r#"{"connected": {"distance": 1, "from": "hand"}}"#,
            "region.connected.from",
        ),
        (
            r#"{"connected": {"distance": 1, "from": "handle"}}"#,
            "region.connected.from",
        ),
        (
            r#"{"connected": {"distance": 1, "form": "starts"}}"#,
            "region.connected.form",
        ),
        (r#"{"connected": 3}"#, "region.connected"),
        (
            r#"{"weights": {"vertices": [1, 2], "weights": [1]}}"#,
            "region.weights.weights",
        ),
        (
            r#"{"weights": {"vertices": [1], "weights": [1.5]}}"#,
            "region.weights.weights[0]",
        ),
        (
            r#"{"weights": {"vertices": [1], "weights": [1]}, "falloff": 1}"#,
            "region.falloff",
        ),
    ];
    for (region, at) in bad {
        let e = ControlFile::parse(&arm_pull(region)).expect_err(region);
        assert_eq!(e.location, at, "{region}: {e}");
    }
    // JSON has no NaN; the engine's own check names the field.
    let nan = Region::Connected {
        distance: f64::NAN,
        from: Origin::Starts,
    };
    assert!(
        nan.check()
            .expect_err("NaN")
            .to_string()
            .contains("connected.distance")
    );
    // Not in a handle's selection or an anchor.
    let e = ControlFile::parse(
        r#"{"radius": 1, "handle": {"select": {"connected": {"distance": 1}}, "scale": 2}}"#,
    )
    .expect_err("connected select");
    assert_eq!(e.location, "handle.select.connected");
    // Round trip through the writer.
    let f = ControlFile::parse(&arm_pull(
        r#"{"connected": {"distance": 0.5, "from": "starts"}, "falloff": 0.25}"#,
    ))
    .expect("parse");
    let again = ControlFile::parse(&f.to_text()).expect("reparse");
    assert_eq!(again.deformations, f.deformations);
    // Weights too.
    let w = ControlFile::parse(&arm_pull(
        r#"{"weights": {"vertices": [3, 1], "weights": [0.5, 1]}}"#,
    ))
    .expect("parse");
    assert_eq!(
        ControlFile::parse(&w.to_text())
            .expect("reparse")
            .deformations,
        w.deformations
    );
    // Without faces a connected region cannot be resolved.
    let (points, _, _) = hairpin(0.2, 1.0);
    let e = f.deformations[0]
        .resolve(&points, &|_| None)
        .expect_err("no faces");
    assert!(e.to_string().contains("needs a mesh with faces"), "{e}");
    // Nor used unresolved.
    assert!(
        f.deformations[0]
            .region
            .weights(&points, &|_| None)
            .is_err()
    );
}

#[test]
fn weights_select_sorted_and_in_range() {
    let points: Vec<Vec3> = (0..5).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect();
    let none = |_: &str| None;
    let w = Region::Weights {
        vertices: vec![3, 1, 4],
        weights: vec![0.5, 1.0, 0.0],
    };
    assert_eq!(
        w.weights(&points, &none).expect("weights"),
        (vec![1, 3], vec![1.0, 0.5])
    );
    assert_eq!(w.select(&points, &none).expect("select"), vec![1, 3]);
    let out = Region::Weights {
        vertices: vec![9],
        weights: vec![1.0],
    };
    assert!(out.weights(&points, &none).is_err());
}

#[test]
fn a_cached_resolution_walks_the_surface_again_only_when_its_seeds_change() {
    let (points, tris, _) = hairpin(0.2, 2.0);
    let file = ControlFile::parse(&arm_pull(
        r#"{"connected": {"distance": 0.5}, "falloff": 0.3}"#,
    ))
    .expect("parse");
    let mut spec = file.deformations[0].clone();
    let mut cache = crate::controls::SurfaceCache::default();
    let resolve = |spec: &crate::controls::ControlSpec,
                   cache: &mut crate::controls::SurfaceCache| {
        let cached = spec
            .resolve_cached(&points, &tris, &|_| None, cache)
            .expect("resolve cached");
        let fresh = spec.resolve_on(&points, &tris, &|_| None).expect("resolve");
        assert_eq!(cached, fresh, "the cache changes nothing");
    };
    resolve(&spec, &mut cache);
    assert_eq!(cache.walks(), 1);
    // A drag: the destination moves, the region grows from the same start.
    for k in 1..=3 {
        spec.targets[0].x += 0.01 * k as f64;
        resolve(&spec, &mut cache);
    }
    assert_eq!(cache.walks(), 1, "a moved destination walked again");
    // A moved start grows the region from elsewhere.
    spec.starts[0].y += 0.3;
    resolve(&spec, &mut cache);
    assert_eq!(cache.walks(), 2);
    // So does a wider region.
    spec.region = Region::Connected {
        distance: 0.8,
        from: Origin::Starts,
    };
    resolve(&spec, &mut cache);
    assert_eq!(cache.walks(), 3);
    // A pin that becomes a moving start is a new seed.
    spec.targets[1].z += 0.05;
    resolve(&spec, &mut cache);
    assert_eq!(cache.walks(), 4);
}
