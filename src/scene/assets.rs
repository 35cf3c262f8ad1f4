//! Mesh assets and instancing: the ECS system that resolves every `Instance` shape to one
//! shared, reference-counted copy of a mesh from the scene's `meshes` table.
//!
//! An asset is loaded (file read, procedural mesh generated, degenerate triangles dropped) the
//! first time an entity uses it, in file order, and never again: every instance holds the
//! same `Arc<LocalMesh>`, and the build step gives each asset one BVH. Unused assets are not
//! loaded (a warning says so). Errors name the entity that asked for the asset, and the asset.

use super::components::{FileOrder, Instanced, LocalMesh, Name, Shape, Transform, WorldShape};
use super::stamps::{asset_stamps, CachedAsset};
use super::systems::{self, EntityError};
use crate::formats::access::SceneFiles;
use crate::formats::schema::{MeshTable, ShapeDesc};
use glam::{Affine3A, Vec3A};
use hecs::{CommandBuffer, Entity, World};
use std::sync::Arc;

/// Warnings about the assets loaded, and the assets to keep for the next edit.
pub struct ResolvedMeshes {
    pub warnings: Vec<String>,
    pub cache: Vec<CachedAsset>,
}

/// Gives every entity whose shape is `Instance { mesh }` an [`Instanced`] component pointing at
/// the one loaded copy of asset `mesh`: the one in `cache` if its description and file did not
/// change, else loaded now (once). Its `mesh` index is set when the world is numbered
/// (`crate::scene::edit`). Errors: an unknown name, an asset that cannot be loaded or is not
/// made of triangles, an instance reaching beyond [`systems::MAX_COORDINATE`].
pub fn resolve_instances(
    world: &mut World,
    table: &MeshTable,
    files: &SceneFiles,
    cache: &[CachedAsset],
) -> Result<ResolvedMeshes, EntityError> {
    // The assets still as they were, then those loaded now.
    let mut loaded: Vec<CachedAsset> = Vec::new();
    for (name, desc) in &table.0 {
        if let Some(c) = cache.iter().find(|c| c.matches(name, desc)) {
            loaded.push(CachedAsset::new(
                name,
                desc,
                asset_stamps(desc, files),
                Arc::clone(&c.mesh),
            ));
        }
    }
    let mut warnings = Vec::new();
    let mut resolved = CommandBuffer::new();
    {
        let mut query = world.query::<(Entity, &FileOrder, &Name, &Transform, &Shape)>();
        let mut items: Vec<_> = query
            .iter()
            .filter_map(|(e, o, n, t, s)| match s {
                Shape::Instance { mesh } => Some((e, o, n, t, mesh)),
                _ => None,
            })
            .collect();
        items.sort_by_key(|(_, order, ..)| **order);
        for (entity, _, name, transform, mesh) in items {
            let fail = |m: String| (name.0.clone(), m);
            let Some((asset_name, desc)) = table.0.iter().find(|(n, _)| n == mesh) else {
                let known = if table.0.is_empty() {
                    "the scene defines no meshes (add a `meshes` table)".to_string()
                } else {
                    let names: Vec<&str> = table.0.iter().map(|(n, _)| n.as_str()).collect();
                    format!("defined meshes: {}", names.join(", "))
                };
                return Err(fail(format!("unknown mesh `{mesh}`; {known}")));
            };
            let asset = match loaded.iter().find(|c| c.name == *mesh) {
                Some(c) => Arc::clone(&c.mesh),
                None => {
                    let stamps = asset_stamps(desc, files);
                    let (asset, dropped) = load_asset(asset_name, desc, files)
                        .map_err(|e| fail(format!("mesh `{mesh}`: {e}")))?;
                    if dropped > 0 {
                        warnings.push(format!(
                            "mesh `{mesh}`: dropped {dropped} degenerate triangle(s) of {}",
                            dropped + asset.triangles.len()
                        ));
                    }
                    let asset = Arc::new(asset);
                    loaded.push(CachedAsset::new(
                        asset_name,
                        desc,
                        stamps,
                        Arc::clone(&asset),
                    ));
                    asset
                }
            };
            let m = transform.matrix();
            check_instance_reach(&asset, &m).map_err(fail)?;
            // Rays are moved into the instance's space by the inverse.
            if !m.inverse().is_finite() {
                return Err(fail(match transform.matrix {
                    None => format!(
                        "transform.scale {:?} is too small: the instance's transform cannot be inverted",
                        transform.scale.to_array()
                    ),
                    Some(_) => "transform.matrix cannot be inverted".into(),
                }));
            }
            resolved.insert_one(entity, Instanced { mesh: 0, asset });
        }
    }
    resolved.run_on(world);
    Ok(ResolvedMeshes {
        warnings,
        cache: loaded,
    })
}

/// Loads one asset in its own space: the mesh and how many degenerate triangles were dropped.
fn load_asset(
    name: &str,
    desc: &ShapeDesc,
    files: &SceneFiles,
) -> Result<(LocalMesh, usize), String> {
    match desc {
        ShapeDesc::Sphere { .. } => {
            return Err(
                "a mesh asset must be made of triangles; a Sphere is analytic (use Icosphere)"
                    .into(),
            )
        }
        ShapeDesc::Disk | ShapeDesc::Cylinder { .. } => {
            return Err(
                "a mesh asset must be made of triangles; a Disk or Cylinder is analytic (place \
                     it as an entity's shape)"
                    .into(),
            )
        }
        ShapeDesc::Instance { .. } => {
            return Err("a mesh asset cannot itself be an Instance".into());
        }
        ShapeDesc::Curves { .. } => {
            return Err(
                "a mesh asset must be made of triangles; Curves are analytic (place them as an \
                 entity's shape)"
                    .into(),
            )
        }
        _ => {}
    }
    let shape = super::describe::shape_from_desc(desc.clone(), files)?;
    systems::validate_shape(&shape, &Transform::default())?;
    let WorldShape::Triangles {
        triangles,
        normals,
        uvs,
        ..
    } = systems::bake_shape(&shape, &Affine3A::IDENTITY)
    else {
        return Err("a mesh asset must be made of triangles".into());
    };
    let before = triangles.len();
    let (triangles, normals, uvs) = systems::drop_degenerate(triangles, normals, uvs);
    if triangles.is_empty() {
        return Err(format!(
            "has no triangles (of {before}) that are not degenerate"
        ));
    }
    let mut bounds = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
    for p in triangles.iter().flatten() {
        bounds = (bounds.0.min(*p), bounds.1.max(*p));
    }
    let dropped = before - triangles.len();
    Ok((
        LocalMesh {
            id: super::components::new_geometry_id(),
            name: name.to_string(),
            triangles,
            normals,
            uvs,
            bounds,
        },
        dropped,
    ))
}

pub use crate::accel::box_corners;

/// An instance must stay within reach like any geometry: its world box's corners are checked.
fn check_instance_reach(asset: &LocalMesh, m: &Affine3A) -> Result<(), String> {
    systems::check_points_reach(
        box_corners(asset.bounds)
            .into_iter()
            .map(|p| m.transform_point3a(p)),
    )
}
