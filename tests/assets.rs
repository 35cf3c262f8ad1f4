//! Meshes from files land where the scene puts them, facing the right way.

use glam::{Quat, Vec3A};
use raylab::scene::components::{Name, WorldShape};
use raylab::scene::load_scene;
use std::path::Path;

#[test]
fn obj_mesh_is_placed_and_oriented_by_its_transform() {
    let loaded = load_scene(Path::new("scenes/mesh_files.ron")).unwrap();
    let mut query = loaded.world.query::<(&Name, &WorldShape)>();
    let (_, shape) = query
        .iter()
        .find(|(n, _)| n.0 == "pyramid")
        .expect("the pyramid entity");
    let WorldShape::Triangles { triangles, .. } = shape else {
        panic!("a mesh")
    };
    // 1 quad base (2 triangles after triangulation) + 4 sides.
    assert_eq!(triangles.len(), 6);
    // The apex (0, 1.5, 0) scaled by 0.4 and moved down by 1: (0, -0.4, 0).
    let apex = Vec3A::new(0.0, -0.4, 0.0);
    let with_apex: Vec<&[Vec3A; 3]> = triangles
        .iter()
        .filter(|t| t.iter().any(|v| (*v - apex).length() < 1e-5))
        .collect();
    assert_eq!(with_apex.len(), 4, "four sides meet at the apex");
    // The side (-1,0,1), (1,0,1), apex faces (0, 2, 3) in the file; rotated 30 degrees about y.
    let expected =
        Quat::from_rotation_y(30f32.to_radians()) * glam::Vec3::new(0.0, 2.0, 3.0).normalize();
    let found = with_apex.iter().any(|t| {
        let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        (glam::Vec3::from(n) - expected).length() < 1e-4
    });
    assert!(found, "no side faces {expected}");
    // Every face points away from the pyramid's centre.
    let centre = triangles.iter().flatten().copied().sum::<Vec3A>() / 18.0;
    for t in triangles {
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        assert!(n.dot((t[0] + t[1] + t[2]) / 3.0 - centre) > 0.0);
    }
}

#[test]
fn gltf_mesh_follows_its_node_hierarchy() {
    let loaded = load_scene(Path::new("scenes/mesh_files.ron")).unwrap();
    let mut query = loaded.world.query::<(&Name, &WorldShape)>();
    let (_, shape) = query
        .iter()
        .find(|(n, _)| n.0 == "panel")
        .expect("the panel entity");
    let WorldShape::Triangles {
        triangles, normals, ..
    } = shape
    else {
        panic!("a mesh")
    };
    assert_eq!(triangles.len(), 2);
    // Corner (0.5, 0.5, 0): turned 45 degrees about y by the child node, then scaled by 0.6
    // and moved down 0.3 by the parent: (0.2121, 0.0, -0.2121).
    let corner = Vec3A::new(0.212_132, 0.0, -0.212_132);
    assert!(
        triangles
            .iter()
            .flatten()
            .any(|v| (*v - corner).length() < 1e-4),
        "{triangles:?}"
    );
    // The face and its vertex normals point along (1, 0, 1) / sqrt 2.
    let expected = Vec3A::new(1.0, 0.0, 1.0).normalize();
    for t in triangles {
        assert!(((t[1] - t[0]).cross(t[2] - t[0]).normalize() - expected).length() < 1e-4);
    }
    let normals = normals.as_ref().expect("the file has normals");
    assert!(normals
        .iter()
        .flatten()
        .all(|n| (*n - expected).length() < 1e-4));
}
