//! `material: "from-file"`: an entity whose `Obj` or `Gltf` shape brings its own materials.
//!
//! Such an entity is spawned as one entity per material its file's triangles use, named
//! `entity/material` (e.g. `lamp/shade`), each with the entity's transform, the triangles of
//! that material, a Lambert material of the file's diffuse colour (OBJ `Kd`, glTF
//! `baseColorFactor`) and, when the file's material emits (OBJ `Ke`, glTF `emissiveFactor`
//! times `KHR_materials_emissive_strength`), an area emitter. Every later system (validation,
//! baking, emitters, the build) then sees ordinary entities.

use super::components::{Emitter, Shape};
use crate::formats::access::SceneFiles;
use crate::formats::mesh_files;
use crate::formats::schema::ShapeDesc;
use glam::Vec3A;
use raylab_integrators::bsdf::Lambert;
use raylab_integrators::{Material, SurfaceMaterial};

/// The material name that asks for the file's own materials. It cannot name a material of
/// the scene's table.
pub const FROM_FILE: &str = "from-file";

/// One material's share of a mesh file.
pub struct Part {
    /// The file's name for the material.
    pub name: String,
    pub shape: Shape,
    pub material: SurfaceMaterial,
    pub emitter: Option<Emitter>,
}

/// Loads the mesh file of `desc` split by material. Errors: a shape that is not a mesh file,
/// a file that cannot be loaded (an OBJ whose MTL file cannot be, too), a colour that is not
/// a reflectance.
pub fn file_parts(desc: &ShapeDesc, files: &SceneFiles) -> Result<Vec<Part>, String> {
    let (mesh, file) = match desc {
        ShapeDesc::Obj { path, normals } => {
            let file = files.named(path)?;
            (
                mesh_files::load_obj(&file, true, files)?.shaded(*normals),
                file,
            )
        }
        ShapeDesc::Gltf { path } => {
            let file = files.named(path)?;
            (mesh_files::load_gltf(&file, files)?, file)
        }
        _ => {
            return Err(format!(
                "`material: \"{FROM_FILE}\"` takes the materials of a mesh file: the shape must be \
                 `Obj` or `Gltf`"
            ))
        }
    };
    mesh.split_by_material()
        .into_iter()
        .map(|(m, mesh)| {
            let shape = Shape::from(mesh);
            let material = Lambert::new(raylab_integrators::spectrum::of_rgb(Vec3A::from_array(
                m.albedo,
            )))
            .map(|l| SurfaceMaterial::from(Material::Lambert(l)))
            .map_err(|e| {
                format!(
                    "material `{}` of `{}`: diffuse colour: {e}",
                    m.name,
                    file.display()
                )
            })?;
            let emitter = m.emission.map(|radiance| Emitter::Area {
                radiance: Vec3A::from_array(radiance),
                two_sided: m.two_sided,
                texture: None,
                spectrum: None,
            });
            Ok(Part {
                name: m.name,
                shape,
                material,
                emitter,
            })
        })
        .collect()
}
