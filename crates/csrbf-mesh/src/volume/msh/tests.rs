//! Gmsh files as Gmsh writes them: both versions, sparse node tags,
//! entities, prisms, second-order cells.

use std::path::Path;

use glam::DVec3;

use crate::volume::quality::min_corner_det;
use crate::volume::tests::{refused, sample};
use crate::volume::{CellKind, VolumeFormat, VolumeMesh, Zone};

#[test]
fn a_wedge_through_gmsh_stays_in_vtk_order_and_positive() {
    let m = sample();
    let wedge = m.cells.cell(3).to_vec();
    let p: Vec<DVec3> = wedge.iter().map(|&v| m.points[v as usize]).collect();
    assert!(min_corner_det(CellKind::Wedge, &p) > 0.0);
    for f in [VolumeFormat::Msh, VolumeFormat::Msh22] {
        let bytes = m.to_bytes(f).unwrap();
        let back = VolumeMesh::from_bytes(&bytes, f, Path::new("w.msh")).unwrap();
        assert_eq!(back.cells.cell(3), wedge);
    }
    // The 2.2 file holds Gmsh's order: 1 9 2 then 5 10 6 (1-based: +1).
    let text = String::from_utf8(m.to_bytes(VolumeFormat::Msh22).unwrap()).unwrap();
    assert!(text.contains("\n4 6 2 1 1 2 10 3 6 11 7\n"), "{text}");
    // A prism as Gmsh makes it: bottom (0, 1, 2) turning toward the top.
    let gmsh = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n6\n1 0 0 0\n2 1 0 0\n3 0 1 0\n\
                4 0 0 1\n5 1 0 1\n6 0 1 1\n$EndNodes\n$Elements\n1\n1 6 2 0 1 1 2 3 4 5 6\n$EndElements\n";
    let m = VolumeMesh::from_bytes(gmsh.as_bytes(), VolumeFormat::Msh, Path::new("p.msh")).unwrap();
    assert_eq!(m.cells.cell(0), [0, 2, 1, 3, 5, 4]);
    let p: Vec<DVec3> = m
        .cells
        .cell(0)
        .iter()
        .map(|&v| m.points[v as usize])
        .collect();
    assert!(min_corner_det(CellKind::Wedge, &p) > 0.0);
}

pub(crate) const MSH22: &str = "$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
2
2 1 \"inlet\"
3 2 \"fluid region\"
$EndPhysicalNames
$Comments
anything, even $Nodes
$EndComments
$Nodes
5
10 0 0 0
20 1 0 0
30 0 1 0
40 0 0 1
7 1 1 1
$EndNodes
$Elements
3
1 2 2 1 5 10 30 20
2 4 2 2 1 10 20 30 40
3 15 2 0 3 7
$EndElements
$NodeData
1
\"temperature\"
1
0.0
3
0
1
5
10 1
20 1
30 1
40 1
7 1
$EndNodeData
";

pub(crate) const MSH41: &str = "$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
2
2 5 \"wall\"
3 6 \"air\"
$EndPhysicalNames
$Entities
0 0 1 1
3 0 0 0 1 1 0 1 5 3 1 2 3
1 0 0 -1 1 1 1 2 6 8 1 -3
$EndEntities
$Nodes
2 5 2 100
2 3 0 3
2
100
50
0 0 0
1 0 0
0 1 0
3 1 0 2
7
9
0 0 1
0 0 -1
$EndNodes
$Elements
2 3 1 3
2 3 2 1
1 2 100 50
3 1 4 2
2 2 50 100 7
3 2 50 100 9
$EndElements
$Periodic
0
$EndPeriodic
";

#[test]
fn gmsh_files_read_right() {
    let m =
        VolumeMesh::from_bytes(MSH22.as_bytes(), VolumeFormat::Msh, Path::new("a.msh")).unwrap();
    assert_eq!(m.points.len(), 5);
    assert_eq!(m.points[4], DVec3::ONE);
    assert_eq!(
        m.cells.kinds,
        [CellKind::Triangle, CellKind::Tetra, CellKind::Vertex]
    );
    assert_eq!(m.cells.cell(0), [0, 2, 1]);
    assert_eq!(m.cells.cell(1), [0, 1, 2, 3]);
    assert_eq!(m.cells.cell(2), [4]);
    assert_eq!(m.cell_zones, [1, 2, 0]);
    assert_eq!(
        m.zones,
        [
            Zone {
                name: "inlet".into(),
                tag: 1,
                dim: 2
            },
            Zone {
                name: "fluid region".into(),
                tag: 2,
                dim: 3
            },
        ]
    );

    let m =
        VolumeMesh::from_bytes(MSH41.as_bytes(), VolumeFormat::Msh, Path::new("b.msh")).unwrap();
    assert_eq!(m.points[1], DVec3::X);
    assert_eq!(m.points[4], -DVec3::Z);
    assert_eq!(m.cells.cell(0), [0, 1, 2]);
    assert_eq!(m.cells.cell(1), [0, 2, 1, 3]);
    assert_eq!(m.cells.cell(2), [0, 2, 1, 4]);
    assert_eq!(m.cell_zones, [5, 6, 6]);
    assert_eq!(m.zone("air").map(|z| z.dim), Some(3));
    assert_eq!(m.zone("wall").map(|z| z.tag), Some(5));
}

#[test]
fn gmsh_physical_tags_shared_by_two_dimensions_get_their_own_zones() {
    let text = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n2 1 \"inlet\"\n3 1 \"fluid\"\n\
                $EndPhysicalNames\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n\
                $Elements\n2\n1 2 2 1 1 1 3 2\n2 4 2 1 1 1 2 3 4\n$EndElements\n";
    let m = VolumeMesh::from_bytes(text.as_bytes(), VolumeFormat::Msh, Path::new("c.msh")).unwrap();
    assert_eq!(m.zone("inlet").map(|z| (z.tag, z.dim)), Some((1, 2)));
    assert_eq!(m.zone("fluid").map(|z| (z.tag, z.dim)), Some((2, 3)));
    assert_eq!(m.cell_zones, [1, 2]);
}

#[test]
fn the_bundled_gmsh_file_reads() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/volume/sphere_in_box.msh");
    // Bundled (made by scripts/make_volume_sample.py): its absence fails.
    let bytes = std::fs::read(&path).expect("assets/volume/sphere_in_box.msh is bundled");
    let m = VolumeMesh::from_bytes(&bytes, VolumeFormat::Msh, &path).unwrap();
    let names: Vec<&str> = m.zones.iter().map(|z| z.name.as_str()).collect();
    for z in ["outer", "inner", "fluid"] {
        assert!(names.contains(&z), "{names:?}");
    }
    let fluid = m.zone("fluid").unwrap().tag;
    let tets = m.zone_cells(fluid);
    assert!(!tets.is_empty());
    for c in tets {
        let p: Vec<DVec3> = m
            .cells
            .cell(c as usize)
            .iter()
            .map(|&v| m.points[v as usize])
            .collect();
        assert!(
            min_corner_det(m.cells.kinds[c as usize], &p) > 0.0,
            "cell {c}"
        );
    }
    for f in [VolumeFormat::Msh, VolumeFormat::Vtk, VolumeFormat::Vtu] {
        let back = VolumeMesh::from_bytes(&m.to_bytes(f).unwrap(), f, Path::new("x")).unwrap();
        assert_eq!(back, m, "{f:?}");
    }
}
#[test]
fn second_order_cells_are_refused_by_name() {
    refused(
        MSH22
            .replace(
                "2 4 2 2 1 10 20 30 40",
                "2 11 2 2 1 10 20 30 40 1 2 3 4 5 6",
            )
            .as_bytes(),
        VolumeFormat::Msh,
        "second-order cells (Gmsh type 11, 10-node tetrahedron) at element 2: csrbf morphs linear cells only",
    );
    refused(
        MSH41.replace("3 1 4 2\n", "3 1 11 2\n").as_bytes(),
        VolumeFormat::Msh,
        "second-order cells (Gmsh type 11, 10-node tetrahedron) at element 2",
    );
}
