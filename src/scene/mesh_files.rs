//! Mesh files: Wavefront OBJ through `tobj` and glTF 2.0 / GLB through `gltf`, each read into
//! one local-space [`Shape::Mesh`]. Both parsers are third-party code fed user files: a panic
//! in either is caught and becomes an error naming the file.

use super::components::Shape;
use glam::Vec3A;
use std::path::Path;

/// Loads an OBJ file as one mesh (all its objects), with normals when every object has them.
pub fn load_obj(file: &Path) -> Result<Shape, String> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    // The parser is third-party code fed user files: a panic in it is an error here, not a crash.
    let loaded = std::panic::catch_unwind(|| tobj::load_obj(file, &options))
        .map_err(|_| format!("the OBJ parser failed on `{}`", file.display()))?;
    let (models, _materials) =
        loaded.map_err(|e| format!("cannot load OBJ file `{}`: {e}", file.display()))?;
    let mut positions: Vec<Vec3A> = Vec::new();
    let mut normals: Vec<Vec3A> = Vec::new();
    let mut indices: Vec<[u32; 3]> = Vec::new();
    let all_normals = models.iter().all(|m| !m.mesh.normals.is_empty());
    for m in &models {
        let base = positions.len() as u32;
        let count = m.mesh.positions.len() / 3;
        positions.extend(
            m.mesh
                .positions
                .chunks_exact(3)
                .map(|p| Vec3A::new(p[0], p[1], p[2])),
        );
        if all_normals {
            normals.extend(
                m.mesh
                    .normals
                    .chunks_exact(3)
                    .map(|n| Vec3A::new(n[0], n[1], n[2])),
            );
        }
        for t in m.mesh.indices.chunks_exact(3) {
            if t.iter().any(|&i| i as usize >= count) {
                return Err(format!(
                    "OBJ file `{}`: a face index is out of range",
                    file.display()
                ));
            }
            indices.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    if indices.is_empty() {
        return Err(format!("OBJ file `{}` has no faces", file.display()));
    }
    let normals = (all_normals && normals.len() == positions.len()).then_some(normals);
    Ok(Shape::Mesh {
        positions,
        indices,
        normals,
    })
}

/// Loads the triangles of a glTF file's default scene (or its first) as one mesh, each mesh
/// placed by its node's world transform; normals when every primitive has them.
pub fn load_gltf(file: &Path) -> Result<Shape, String> {
    let fail =
        |e: &dyn std::fmt::Display| format!("cannot load glTF file `{}`: {e}", file.display());
    let load = || -> Result<_, gltf::Error> {
        let gltf = gltf::Gltf::open(file)?;
        let buffers = gltf::import_buffers(&gltf.document, file.parent(), gltf.blob.clone())?;
        Ok((gltf.document, buffers))
    };
    // Third-party parsing of user files: a panic is an error here, not a crash.
    let (document, buffers) = std::panic::catch_unwind(load)
        .map_err(|_| format!("the glTF parser failed on `{}`", file.display()))?
        .map_err(|e| fail(&e))?;
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| format!("glTF file `{}` has no scene", file.display()))?;
    let (mut positions, mut normals, mut indices) = (Vec::new(), Vec::new(), Vec::new());
    let mut all_normals = true;
    let mut stack: Vec<(gltf::Node, glam::Mat4)> =
        scene.nodes().map(|n| (n, glam::Mat4::IDENTITY)).collect();
    while let Some((node, parent)) = stack.pop() {
        let world = parent * glam::Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(mesh) = node.mesh() {
            let normal_matrix = glam::Mat3::from_mat4(world).inverse().transpose();
            for primitive in mesh.primitives() {
                if primitive.mode() != gltf::mesh::Mode::Triangles {
                    return Err(format!(
                        "glTF file `{}`: only triangle primitives are supported",
                        file.display()
                    ));
                }
                let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
                let base = positions.len() as u32;
                let Some(p) = reader.read_positions() else {
                    continue;
                };
                positions
                    .extend(p.map(|v| Vec3A::from(world.transform_point3(glam::Vec3::from(v)))));
                let count = positions.len() as u32 - base;
                match reader.read_normals() {
                    Some(n) if all_normals => normals.extend(n.map(|v| {
                        Vec3A::from(normal_matrix * glam::Vec3::from(v)).normalize_or_zero()
                    })),
                    _ => all_normals = false,
                }
                let tri: Vec<u32> = match reader.read_indices() {
                    Some(i) => i.into_u32().collect(),
                    None => (0..count).collect(),
                };
                for t in tri.chunks_exact(3) {
                    if t.iter().any(|&i| i >= count) {
                        return Err(format!(
                            "glTF file `{}`: an index is out of range",
                            file.display()
                        ));
                    }
                    indices.push([base + t[0], base + t[1], base + t[2]]);
                }
            }
        }
        stack.extend(node.children().map(|c| (c, world)));
    }
    if indices.is_empty() {
        return Err(format!("glTF file `{}` has no triangles", file.display()));
    }
    let normals = (all_normals && normals.len() == positions.len()).then_some(normals);
    Ok(Shape::Mesh {
        positions,
        indices,
        normals,
    })
}
