//! Scenes that change: the one path by which a scene file becomes a world, whether into an
//! empty world (a load) or into the world of the version before (a save in a live session).
//!
//! [`SceneState::apply`] takes a parsed file and
//! 1. makes the material table, keeping each material whose description did not change;
//! 2. goes through the entities in file order, matching each to the entity of the version
//!    before with the same name (the n-th of that name; the n-th unnamed one for an unnamed
//!    entity). One whose description and files did not change is kept as it is (its material
//!    index and place in the file brought up to date); the others are made into components in a
//!    staging world, reusing the shape or emitter of their match where those did not change;
//! 3. runs the systems (validate, bake, resolve instances) on the staging world alone, so that
//!    an error leaves the live world as it was;
//! 4. moves the staged entities into the world, each marked with what changed on it
//!    ([`Changed`], component by component), and despawns the entities the file no longer has.
//!
//! [`SceneState::render_scene`] then rebuilds what the marks ask for, no more, and clears them:
//! nothing for a material's colour (the accelerator and light table are shared), the light
//! table for an emitter's radiance, the flat BVH and the top level for moved, added or removed
//! entities (large meshes and instanced assets keep their BVHs). A load is the same apply on an
//! empty world, and every rebuild is a function of the world alone, so a scene reached by edits
//! renders the bits the same scene loaded fresh renders.

use super::components::{
    Changed, Emitter, FileOrder, FlipNormals, Instanced, LocalMesh, MaterialRef, MediumBoundary,
    Name, Shape, Transform, WorldShape,
};
use super::describe::{
    camera_from_desc, check_render, emitter_from_desc, shape_from_desc, transform_from_desc, v3,
};
use super::error::SceneError;
use super::materials::material_from_desc;
use super::references::{emitter_files, folder_of, shape_files};
use super::stamps::{restamp, stamp, CachedAsset, Stamp};
use super::textures::TextureLoader;
use super::{assets, file_materials, systems, LoadedScene, RenderScene};
use crate::accel::AccelKind;
use crate::formats::access::SceneFiles;
use crate::formats::schema::{EmitterDesc, EntityDesc, MaterialDesc, SceneFile, ShapeDesc};
use hecs::{CommandBuffer, Entity, World};
use raylab_integrators::bsdf::{checks, Lambert};
use raylab_integrators::spectrum::{of_rgb, rgb_of};
use raylab_integrators::{Material, Spectrum, SurfaceMaterial};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Which entity of the file an entity is: its name and how many entities of that name come
/// before it (unnamed entities are matched by their order among the unnamed).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct EntityKey {
    name: Option<String>,
    occurrence: u32,
}

/// One entity of the file as the world holds it.
struct Record {
    key: EntityKey,
    desc: EntityDesc,
    /// The files its shape and emitter read.
    stamps: Vec<Stamp>,
    /// The entities made of it: one, or one per material of a mesh file (`from-file`).
    entities: Vec<Entity>,
    /// For `from-file`, the materials of its parts, in order.
    part_materials: Vec<SurfaceMaterial>,
}

/// What an apply changed, for the line a live session prints.
#[derive(Clone, Debug, Default)]
pub struct EditReport {
    pub added: Vec<String>,
    pub removed: Vec<String>,
    /// Entities changed, with what changed.
    pub changed: Vec<(String, Changed)>,
    /// Materials whose description changed (or that are new).
    pub materials: Vec<String>,
    pub camera: bool,
    /// The render defaults (integrator, parameters, samples, seed, filter).
    pub render: bool,
    pub environment: bool,
    /// Entities kept as they were.
    pub kept: usize,
}

impl EditReport {
    /// `1 entity changed (material), 1 added`: what changed, or `nothing changed`.
    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        let count = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
        if !self.changed.is_empty() {
            let mut kinds: Vec<String> = Vec::new();
            for (_, c) in &self.changed {
                for k in c.describe().split(", ") {
                    if !kinds.iter().any(|x| x == k) {
                        kinds.push(k.to_string());
                    }
                }
            }
            parts.push(format!(
                "{} changed ({})",
                count(self.changed.len(), "entity"),
                kinds.join(", ")
            ));
        }
        if !self.added.is_empty() {
            parts.push(format!("{} added", count(self.added.len(), "entity")));
        }
        if !self.removed.is_empty() {
            parts.push(format!("{} removed", count(self.removed.len(), "entity")));
        }
        if !self.materials.is_empty() {
            let names: Vec<String> = self.materials.iter().map(|m| format!("`{m}`")).collect();
            parts.push(format!(
                "{} changed ({})",
                count(self.materials.len(), "material"),
                names.join(", ")
            ));
        }
        for (flag, what) in [
            (self.camera, "camera changed"),
            (self.environment, "environment changed"),
            (self.render, "render settings changed"),
        ] {
            if flag {
                parts.push(what.to_string());
            }
        }
        if parts.is_empty() {
            "nothing changed".into()
        } else {
            parts.join(", ")
        }
    }
}

/// What [`SceneState::render_scene`] had to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rebuilt {
    /// The scene was built from nothing (the first build, or another accelerator).
    Everything,
    /// The flat BVH and the top level; `kept` of `meshes` mesh BVHs were kept.
    Geometry { kept: usize, meshes: usize },
    /// The light table only.
    Lights,
    /// Nothing: the accelerator and light table are the ones before.
    Nothing,
}

impl std::fmt::Display for Rebuilt {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self {
            Rebuilt::Everything => write!(f, "built everything"),
            Rebuilt::Geometry { kept, meshes } if *meshes > 0 => write!(
                f,
                "rebuilt the flat BVH and the top level, kept {kept} of {meshes} mesh BVHs"
            ),
            Rebuilt::Geometry { .. } => write!(f, "rebuilt the BVH"),
            Rebuilt::Lights => write!(f, "rebuilt the light table"),
            Rebuilt::Nothing => write!(f, "rebuilt nothing"),
        }
    }
}

/// A scene kept alive across saves: its world, what each entity was made from, and the render
/// scene built last.
pub struct SceneState {
    pub loaded: LoadedScene,
    files: SceneFiles,
    records: Vec<Record>,
    /// The material table's descriptions, the stamps of the images they read, and the
    /// materials, by name, in file order.
    materials: Vec<KeptMaterial>,
    assets: Vec<CachedAsset>,
    /// Entities removed since the last build.
    removed: usize,
    /// The environment changed since the last build.
    environment_changed: bool,
    built: Option<Arc<RenderScene>>,
}

/// A material of the table as it was made, to keep while its description and images stay.
struct KeptMaterial {
    name: String,
    desc: MaterialDesc,
    stamps: Vec<Stamp>,
    material: SurfaceMaterial,
}

/// The material table as the entities are gone through: the file's materials, then the parts'
/// of mesh files (`from-file`) and the black one of pure emitters, as they come.
struct Table {
    materials: Vec<SurfaceMaterial>,
    names: Vec<String>,
    black: Option<u32>,
}

impl Table {
    /// The material entity `e` uses: its own, black for a pure area emitter, none for a
    /// shapeless light.
    fn material_of(&mut self, e: &EntityDesc) -> Result<Option<MaterialRef>, String> {
        Ok(match (&e.material, &e.shape, &e.emitter) {
            (Some(m), _, _) => match self.names.iter().position(|n| n == m) {
                Some(i) => Some(MaterialRef(i as u32)),
                None => {
                    let known = if self.names.is_empty() {
                        "the scene defines no materials".to_string()
                    } else {
                        format!("defined materials: {}", self.names.join(", "))
                    };
                    return Err(format!("unknown material `{m}`; {known}"));
                }
            },
            (None, Some(_), Some(EmitterDesc::Area { .. })) => {
                // A pure emitter reflects nothing.
                let materials = &mut self.materials;
                let id = *self.black.get_or_insert_with(|| {
                    materials.push(
                        Material::Lambert(Lambert {
                            albedo: Spectrum::ZERO,
                        })
                        .into(),
                    );
                    (materials.len() - 1) as u32
                });
                Some(MaterialRef(id))
            }
            (None, Some(_), _) => return Err("has a shape but no material".into()),
            (None, None, _) => None,
        })
    }

    /// Checks that hold between an entity and its material.
    fn check(&self, e: &EntityDesc) -> Result<(), String> {
        let material = e
            .material
            .as_ref()
            .and_then(|m| self.names.iter().position(|n| n == m))
            .map(|i| &self.materials[i]);
        if e.emitter.is_some() && material.is_some_and(|m| m.cutout().is_some()) {
            return Err("an emitter's material cannot be a Cutout (pbrt-v4's alpha)".into());
        }
        let carries = matches!(
            e.shape,
            Some(ShapeDesc::Ply {
                attribute: Some(_),
                ..
            })
        );
        if !carries && material.is_some_and(|m| m.reads_attribute()) {
            return Err(format!(
                "material `{}` reads a mesh attribute, but the shape carries none (a `Ply` shape names one with `attribute`)",
                e.material.as_deref().unwrap_or_default()
            ));
        }
        if !e.flip_normals {
            return Ok(());
        }
        if e.material.as_deref() == Some(file_materials::FROM_FILE) {
            return Err(
                "flip_normals cannot turn the parts of a mesh file split by its \
                        materials (\"from-file\")"
                    .into(),
            );
        }
        let dielectric = e
            .material
            .as_ref()
            .and_then(|m| self.names.iter().position(|n| n == m))
            .is_some_and(|i| self.materials[i].bsdf().is_transmissive());
        if dielectric && matches!(e.shape, Some(ShapeDesc::Sphere { .. })) {
            return Err(
                "flip_normals on a dielectric sphere is not supported: give the \
                        dielectric the inverse IOR instead"
                    .into(),
            );
        }
        Ok(())
    }
}

/// How an entity of the new file gets into the world.
enum Plan {
    /// Kept: the entities of record `record`, with these materials now.
    Keep {
        record: usize,
        materials: Vec<Option<MaterialRef>>,
    },
    /// Made anew in the staging world.
    Make {
        staged: Vec<Entity>,
        part_materials: Vec<SurfaceMaterial>,
    },
}

struct Planned {
    key: EntityKey,
    /// Its name: the file's, or `entity #N` by its place.
    name: String,
    desc: EntityDesc,
    stamps: Vec<Stamp>,
    plan: Plan,
}

/// Whether two descriptions differ in their material alone (neither taking a mesh file's).
fn same_but_material(a: &EntityDesc, b: &EntityDesc) -> bool {
    let from_file = |e: &EntityDesc| e.material.as_deref() == Some(file_materials::FROM_FILE);
    !from_file(a)
        && !from_file(b)
        && a.name == b.name
        && a.transform == b.transform
        && a.shape == b.shape
        && a.emitter == b.emitter
        && a.medium == b.medium
        && a.flip_normals == b.flip_normals
}

impl SceneState {
    /// Loads `file` (read from `path`, reading files as `files` allows) into a new world.
    pub fn new(file: SceneFile, path: &Path, files: SceneFiles) -> Result<SceneState, SceneError> {
        let mut state = SceneState {
            loaded: LoadedScene {
                path: path.to_path_buf(),
                world: World::new(),
                camera: camera_from_desc(&file.camera).map_err(|message| SceneError::Camera {
                    path: path.to_path_buf(),
                    message,
                })?,
                render: file.render.clone(),
                materials: Vec::new(),
                material_names: Vec::new(),
                meshes: Vec::new(),
                environment: None,
                media: Default::default(),
                warnings: Vec::new(),
                inputs: Default::default(),
            },
            files,
            records: Vec::new(),
            materials: Vec::new(),
            assets: Vec::new(),
            removed: 0,
            environment_changed: false,
            built: None,
        };
        state.apply(file)?;
        Ok(state)
    }

    /// The files the world as it is now was made from (what its entities, materials and
    /// mesh assets read, as stamped), in path order: with the scene file and what its import
    /// read, the current scene's inputs.
    pub fn files_in_use(&self) -> Vec<PathBuf> {
        let mut out: Vec<PathBuf> = self
            .records
            .iter()
            .flat_map(|r| &r.stamps)
            .chain(self.materials.iter().flat_map(|m| &m.stamps))
            .chain(self.assets.iter().flat_map(|a| &a.stamps))
            .map(|(f, _)| f.clone())
            .collect();
        out.sort();
        out.dedup();
        out
    }

    fn error(&self, message: String) -> SceneError {
        SceneError::Scene {
            path: self.loaded.path.clone(),
            message,
        }
    }

    fn entity_error(&self, entity: String, message: String) -> SceneError {
        SceneError::Entity {
            path: self.loaded.path.clone(),
            entity,
            message,
        }
    }

    /// Makes the world what `file` describes, changing only what differs from the version
    /// before (see the module's header). On an error the world is left as it was. The loaded
    /// scene's warnings become this apply's (about what it made, not what it kept).
    pub fn apply(&mut self, file: SceneFile) -> Result<EditReport, SceneError> {
        let path = self.loaded.path.clone();
        let mut report = EditReport::default();
        crate::formats::import::check_entities(file.entities.len(), &crate::system::Room::now())
            .map_err(|m| self.error(m))?;

        // Materials: the table entities refer to by name; unchanged ones kept.
        let (mut table, materials) = self.material_table(&file, &mut report)?;
        check_render(&file.render).map_err(|m| self.error(m))?;
        let camera = camera_from_desc(&file.camera).map_err(|message| SceneError::Camera {
            path: path.clone(),
            message,
        })?;
        let environment = match file.environment {
            Some(e) => Some(
                checks::colour("environment", of_rgb(v3(e)))
                    .map(rgb_of)
                    .map_err(|m| self.error(m))?,
            ),
            None => None,
        };
        self.check_one_sky(&file, environment.is_some())?;
        let media =
            super::media::Media::from_file(&file, &self.files).map_err(|m| self.error(m))?;
        if file.entities.is_empty() {
            return Err(self.error("the scene has no entities".into()));
        }

        // Entities, in file order: kept, or made in the staging world.
        let dir = folder_of(&path).to_path_buf();
        let before: HashMap<EntityKey, usize> = self
            .records
            .iter()
            .enumerate()
            .map(|(i, r)| (r.key.clone(), i))
            .collect();
        let mut staging = World::new();
        let mut planned: Vec<Planned> = Vec::with_capacity(file.entities.len());
        let mut seen: HashMap<Option<String>, u32> = HashMap::new();
        for (index, e) in file.entities.into_iter().enumerate() {
            let occurrence = seen.entry(e.name.clone()).or_default();
            let key = EntityKey {
                name: e.name.clone(),
                occurrence: *occurrence,
            };
            *occurrence += 1;
            let name = e.name.clone().unwrap_or_else(|| format!("entity #{index}"));
            let fail = |message: String| self.entity_error(name.clone(), message);
            table.check(&e).map_err(fail)?;
            if let Some(m) = &e.medium {
                media.interface(m).map_err(fail)?;
            }
            let old = before.get(&key).map(|&i| (i, &self.records[i]));
            // The files its shape and emitter read, stamped before they are read.
            let stamps = match old {
                Some((_, r)) if r.desc.shape == e.shape && r.desc.emitter == e.emitter => {
                    restamp(&r.stamps)
                }
                _ => stamp(
                    e.shape
                        .iter()
                        .flat_map(|s| shape_files(s, &self.files))
                        .chain(e.emitter.iter().flat_map(|m| emitter_files(m, &dir)))
                        .collect(),
                ),
            };
            // An instance is kept only with its asset.
            let asset_kept = match &e.shape {
                Some(ShapeDesc::Instance { mesh }) => {
                    let desc = file.meshes.0.iter().find(|(n, _)| n == mesh);
                    desc.is_some_and(|(n, d)| self.assets.iter().any(|a| a.matches(n, d)))
                }
                _ => true,
            };
            let kept = old.filter(|(_, r)| {
                asset_kept && r.stamps == stamps && (r.desc == e || same_but_material(&r.desc, &e))
            });
            let plan = match kept {
                Some((record, r)) => {
                    let from_file = e.material.as_deref() == Some(file_materials::FROM_FILE);
                    let materials = if !from_file {
                        vec![table.material_of(&e).map_err(fail)?]
                    } else {
                        r.part_materials
                            .iter()
                            .map(|m| {
                                table.materials.push(m.clone());
                                Some(MaterialRef(table.materials.len() as u32 - 1))
                            })
                            .collect()
                    };
                    Plan::Keep { record, materials }
                }
                None => {
                    // Its match's shape and emitter may be reused: of one entity only (the
                    // parts of a mesh file each hold a part).
                    let single = old
                        .filter(|(_, r)| r.entities.len() == 1 && r.part_materials.is_empty())
                        .map(|(_, r)| (&r.desc, &r.stamps, r.entities[0]));
                    let (staged, part_materials) = self
                        .make(
                            &mut staging,
                            &e,
                            index as u32,
                            &name,
                            &mut table,
                            single,
                            &stamps,
                        )
                        .map_err(|(entity, message)| self.entity_error(entity, message))?;
                    Plan::Make {
                        staged,
                        part_materials,
                    }
                }
            };
            planned.push(Planned {
                key,
                name,
                desc: e,
                stamps,
                plan,
            });
        }

        // Systems, on the staged entities only: validate, bake, resolve instances.
        let to_scene = |(entity, message)| SceneError::Entity {
            path: path.clone(),
            entity,
            message,
        };
        systems::validate(&staging).map_err(to_scene)?;
        // The memory check counts the triangles of the entities kept as well.
        let kept_triangles: u64 = planned
            .iter()
            .filter_map(|p| match &p.plan {
                Plan::Keep { record, .. } => Some(&self.records[*record].entities),
                Plan::Make { .. } => None,
            })
            .flatten()
            .filter_map(|&e| self.loaded.world.get::<&WorldShape>(e).ok())
            .map(|s| match &*s {
                WorldShape::Triangles { triangles, .. } => triangles.len() as u64,
                WorldShape::Sphere { .. } | WorldShape::Quadric(_) | WorldShape::SdfGrid(_) => 0,
                WorldShape::Curves {
                    segments,
                    split_depth,
                } => systems::curve_triangle_equivalent(segments.len() as u64, *split_depth),
            })
            .sum();
        let mut warnings =
            systems::bake_transforms(&mut staging, kept_triangles).map_err(to_scene)?;
        let resolved =
            assets::resolve_instances(&mut staging, &file.meshes, &self.files, &self.assets)
                .map_err(to_scene)?;
        warnings.extend(resolved.warnings);
        let has_geometry = |w: &World| {
            w.query::<&WorldShape>().iter().next().is_some()
                || w.query::<&Instanced>().iter().next().is_some()
        };
        let kept_geometry = planned.iter().any(|p| match &p.plan {
            Plan::Keep { record, .. } => self.records[*record].entities.iter().any(|&e| {
                self.loaded.world.satisfies::<&WorldShape>(e)
                    || self.loaded.world.satisfies::<&Instanced>(e)
            }),
            Plan::Make { .. } => false,
        });
        if !kept_geometry && !has_geometry(&staging) {
            return Err(self.error("the scene has no geometry (no entity with a shape)".into()));
        }

        // Nothing can fail from here: the world takes the new version.
        self.commit(planned, &mut staging, &mut report);
        self.assets = resolved.cache;
        self.number_assets(&file.meshes, &mut warnings);
        report.camera = camera != self.loaded.camera;
        report.render = file.render != self.loaded.render;
        report.environment = environment != self.loaded.environment;
        self.environment_changed |= report.environment;
        let loaded = &mut self.loaded;
        loaded.camera = camera;
        loaded.render = file.render;
        loaded.materials = table.materials;
        loaded.material_names = table.names;
        loaded.environment = environment;
        loaded.media = media;
        loaded.warnings = warnings;
        self.materials = materials;
        Ok(report)
    }

    /// The material table of `file`, keeping the materials whose descriptions and images did
    /// not change; also the list to keep for the next apply.
    fn material_table(
        &self,
        file: &SceneFile,
        report: &mut EditReport,
    ) -> Result<(Table, Vec<KeptMaterial>), SceneError> {
        let mut textures = TextureLoader::new(&self.files);
        let mut kept = Vec::with_capacity(file.materials.0.len());
        for (name, desc) in &file.materials.0 {
            let fail = |message: String| SceneError::Material {
                path: self.loaded.path.clone(),
                material: name.clone(),
                message,
            };
            if name == file_materials::FROM_FILE {
                return Err(fail(
                    "this name is reserved: it asks for a mesh file's own materials".into(),
                ));
            }
            let before = self
                .materials
                .iter()
                .find(|m| m.name == *name && m.desc == *desc && restamp(&m.stamps) == m.stamps);
            let (material, stamps) = match before {
                Some(m) => (m.material.clone(), m.stamps.clone()),
                None => {
                    if !self.records.is_empty() {
                        report.materials.push(name.clone());
                    }
                    textures.take_read();
                    let material = material_from_desc(desc, &mut textures).map_err(fail)?;
                    (material, stamp(textures.take_read()))
                }
            };
            kept.push(KeptMaterial {
                name: name.clone(),
                desc: desc.clone(),
                stamps,
                material,
            });
        }
        let table = Table {
            materials: kept.iter().map(|m| m.material.clone()).collect(),
            names: kept.iter().map(|m| m.name.clone()).collect(),
            black: None,
        };
        Ok((table, kept))
    }

    /// One sky: the constant `environment` or one `Environment` emitter.
    fn check_one_sky(&self, file: &SceneFile, constant: bool) -> Result<(), SceneError> {
        let maps: Vec<String> = file
            .entities
            .iter()
            .enumerate()
            .filter(|(_, e)| matches!(e.emitter, Some(EmitterDesc::Environment { .. })))
            .map(|(i, e)| e.name.clone().unwrap_or_else(|| format!("entity #{i}")))
            .collect();
        if maps.len() + usize::from(constant) > 1 {
            let mut named: Vec<String> = maps.iter().map(|n| format!("`{n}`")).collect();
            if constant {
                named.insert(0, "the top-level `environment`".into());
            }
            return Err(self.error(format!(
                "a scene has at most one environment; {} are environments",
                named.join(" and ")
            )));
        }
        Ok(())
    }

    /// Makes entity `e` (the `index`-th of the file) into components in `staging`: one entity,
    /// or one per material of its mesh file (`from-file`, whose materials join `table`).
    /// `old` is its match in the version before (description, stamps, entity), if that was
    /// one entity: its shape and emitter are reused where their descriptions and files did
    /// not change.
    #[allow(clippy::too_many_arguments)]
    fn make(
        &self,
        staging: &mut World,
        e: &EntityDesc,
        index: u32,
        name: &str,
        table: &mut Table,
        old: Option<(&EntityDesc, &Vec<Stamp>, Entity)>,
        stamps: &[Stamp],
    ) -> Result<(Vec<Entity>, Vec<SurfaceMaterial>), (String, String)> {
        let fail = |m: String| (name.to_string(), m);
        let transform = transform_from_desc(&e.transform).map_err(fail)?;
        if e.material.as_deref() == Some(file_materials::FROM_FILE) {
            return self.make_file_parts(staging, e, index, name, transform, table);
        }
        let material = table.material_of(e).map_err(fail)?;
        let world = &self.loaded.world;
        let same_files = old.is_some_and(|(_, s, _)| s.as_slice() == stamps);
        let reuse = |same: bool| old.filter(|_| same && same_files).map(|o| o.2);
        let shape = match reuse(old.is_some_and(|(d, ..)| d.shape == e.shape)) {
            Some(entity) => world.get::<&Shape>(entity).ok().map(|s| (*s).clone()),
            None => e
                .shape
                .clone()
                .map(|d| shape_from_desc(d, &self.files))
                .transpose()
                .map_err(fail)?,
        };
        // An environment map is turned by the transform: kept only with it.
        let same_emitter =
            old.is_some_and(|(d, ..)| d.emitter == e.emitter && d.transform == e.transform);
        let emitter = match reuse(same_emitter) {
            Some(entity) => world.get::<&Emitter>(entity).ok().map(|m| (*m).clone()),
            None => e
                .emitter
                .clone()
                .map(|d| emitter_from_desc(d, &transform, &self.files))
                .transpose()
                .map_err(fail)?,
        };
        // One entity with exactly the components it has.
        let mut entity = hecs::EntityBuilder::new();
        entity.add_bundle((
            FileOrder {
                entity: index,
                part: 0,
            },
            Name(name.to_string()),
            transform,
        ));
        if e.flip_normals {
            entity.add(FlipNormals);
        }
        if let Some(m) = &e.medium {
            entity.add(MediumBoundary(m.clone()));
        }
        if let Some(shape) = shape {
            entity.add(shape);
        }
        if let Some(m) = material {
            entity.add(m);
        }
        if let Some(em) = emitter {
            entity.add(em);
        }
        Ok((vec![staging.spawn(entity.build())], Vec::new()))
    }

    /// An entity with `material: "from-file"`: one entity per material of its mesh file (see
    /// [`file_materials`]), those materials appended to the table.
    fn make_file_parts(
        &self,
        staging: &mut World,
        e: &EntityDesc,
        index: u32,
        name: &str,
        transform: Transform,
        table: &mut Table,
    ) -> Result<(Vec<Entity>, Vec<SurfaceMaterial>), (String, String)> {
        let fail = |m: String| (name.to_string(), m);
        if e.emitter.is_some() {
            return Err(fail(format!(
                "with `material: \"{}\"` the file's materials say what emits: remove `emitter`",
                file_materials::FROM_FILE
            )));
        }
        let Some(shape) = &e.shape else {
            return Err(fail("has a material but no shape".into()));
        };
        if let ShapeDesc::Instance { mesh } = shape {
            return Err(fail(format!(
                "instances of mesh `{mesh}` take one material: `material: \"{}\"` works only \
                 on an `Obj` or `Gltf` shape of the entity itself",
                file_materials::FROM_FILE
            )));
        }
        let mut staged = Vec::new();
        let mut materials = Vec::new();
        let parts = file_materials::file_parts(shape, &self.files).map_err(fail)?;
        for (k, part) in parts.into_iter().enumerate() {
            table.materials.push(part.material.clone());
            materials.push(part.material);
            let mut entity = hecs::EntityBuilder::new();
            entity.add_bundle((
                FileOrder {
                    entity: index,
                    part: k as u32,
                },
                Name(format!("{name}/{}", part.name)),
                transform,
                part.shape,
                MaterialRef((table.materials.len() - 1) as u32),
            ));
            if let Some(emitter) = part.emitter {
                entity.add(emitter);
            }
            if let Some(m) = &e.medium {
                entity.add(MediumBoundary(m.clone()));
            }
            staged.push(staging.spawn(entity.build()));
        }
        Ok((staged, materials))
    }

    /// Moves the new version into the world: kept entities brought up to date, staged ones
    /// moved in with what changed marked, the ones the file no longer has despawned.
    fn commit(&mut self, planned: Vec<Planned>, staging: &mut World, report: &mut EditReport) {
        let fresh = self.records.is_empty();
        let old_records = std::mem::take(&mut self.records);
        let mut matched = vec![false; old_records.len()];
        let by_key: HashMap<&EntityKey, usize> = old_records
            .iter()
            .enumerate()
            .map(|(i, r)| (&r.key, i))
            .collect();
        let world = &mut self.loaded.world;
        let mut marks = CommandBuffer::new();
        for (index, p) in planned.into_iter().enumerate() {
            let old = by_key.get(&p.key).copied();
            if let Some(i) = old {
                matched[i] = true;
            }
            let (entities, part_materials) = match p.plan {
                Plan::Keep { record, materials } => {
                    let r = &old_records[record];
                    for (k, (&entity, material)) in r.entities.iter().zip(materials).enumerate() {
                        let order = FileOrder {
                            entity: index as u32,
                            part: k as u32,
                        };
                        let mut changed = Changed::default();
                        if world.get::<&FileOrder>(entity).is_ok_and(|o| *o != order) {
                            changed.order = true;
                            marks.insert_one(entity, order);
                        }
                        let now = world.get::<&MaterialRef>(entity).ok().map(|m| *m);
                        if now != material {
                            changed.material = true;
                            match material {
                                Some(m) => marks.insert_one(entity, m),
                                None => marks.remove_one::<MaterialRef>(entity),
                            }
                        }
                        // An unnamed entity is named by its place.
                        let mut name = entity_name(world, entity);
                        if r.part_materials.is_empty() && name != p.name {
                            name.clone_from(&p.name);
                            marks.insert_one(entity, Name(p.name.clone()));
                        }
                        if changed != Changed::default() {
                            report.changed.push((name, changed));
                            marks.insert_one(entity, changed);
                        } else {
                            report.kept += 1;
                        }
                    }
                    (r.entities.clone(), r.part_materials.clone())
                }
                Plan::Make {
                    staged,
                    part_materials,
                } => {
                    let before: &[Entity] = old.map_or(&[], |i| &old_records[i].entities);
                    let mut entities = Vec::with_capacity(staged.len());
                    for (k, s) in staged.into_iter().enumerate() {
                        let Ok(taken) = staging.take(s) else {
                            continue; // staged entities are all there
                        };
                        let new = world.spawn(taken);
                        let changed = match before.get(k) {
                            Some(&was) if !fresh => compare(world, was, new),
                            _ => Changed {
                                added: true,
                                ..Changed::default()
                            },
                        };
                        if changed.added {
                            if !fresh {
                                report.added.push(entity_name(world, new));
                            }
                        } else if changed == Changed::default() {
                            report.kept += 1;
                        } else {
                            report.changed.push((entity_name(world, new), changed));
                        }
                        marks.insert_one(new, changed);
                        entities.push(new);
                    }
                    // Parts beyond the new ones are gone.
                    self.removed += before.len().saturating_sub(entities.len());
                    for &was in before {
                        let _ = world.despawn(was);
                    }
                    (entities, part_materials)
                }
            };
            self.records.push(Record {
                key: p.key,
                desc: p.desc,
                stamps: p.stamps,
                entities,
                part_materials,
            });
        }
        for (r, _) in old_records.iter().zip(&matched).filter(|(_, m)| !**m) {
            for &e in &r.entities {
                report.removed.push(entity_name(world, e));
                let _ = world.despawn(e);
                self.removed += 1;
            }
        }
        marks.run_on(world);
    }

    /// Numbers the mesh assets the instances use, in order of first use in file order, and
    /// warns about the assets of the table no entity uses.
    fn number_assets(
        &mut self,
        table: &crate::formats::schema::MeshTable,
        warnings: &mut Vec<String>,
    ) {
        let world = &mut self.loaded.world;
        let mut instances: Vec<(FileOrder, Entity)> = world
            .query::<(Entity, &FileOrder, &Instanced)>()
            .iter()
            .map(|(e, o, _)| (*o, e))
            .collect();
        instances.sort_unstable_by_key(|(o, _)| *o);
        let mut meshes: Vec<Arc<LocalMesh>> = Vec::new();
        for (_, e) in instances {
            let Ok(mut inst) = world.get::<&mut Instanced>(e) else {
                continue;
            };
            let index = match meshes.iter().position(|m| Arc::ptr_eq(m, &inst.asset)) {
                Some(i) => i,
                None => {
                    meshes.push(Arc::clone(&inst.asset));
                    meshes.len() - 1
                }
            };
            inst.mesh = index as u32;
        }
        for (name, _) in &table.0 {
            if !meshes.iter().any(|m| m.name == *name) {
                warnings.push(format!(
                    "mesh `{name}` is not used by any entity; not loaded"
                ));
            }
        }
        self.loaded.meshes = meshes;
    }

    /// The render scene built last ([`SceneState::render_scene`]), if any.
    pub fn built(&self) -> Option<&Arc<RenderScene>> {
        self.built.as_ref()
    }

    /// The render scene of the world now, on an accelerator of kind `kind`, building only what
    /// the changes since the last call need (see the module's header), on `threads` worker
    /// threads (every core when `None`). Clears the changes' marks.
    pub fn render_scene(
        &mut self,
        kind: AccelKind,
        threads: Option<usize>,
    ) -> anyhow::Result<(Arc<RenderScene>, Rebuilt)> {
        // Media: every edit builds the scene again (the material slots of the surfaces that
        // bound media, and the media themselves, follow the world).
        let mut geometry = self.removed > 0
            || !self.loaded.media.media.is_empty()
            || self.built.as_ref().is_some_and(|b| b.has_media());
        let mut emitters = self.environment_changed;
        let mut marked = Vec::new();
        for (entity, changed) in self.loaded.world.query::<(Entity, &Changed)>().iter() {
            geometry |= changed.geometry();
            emitters |= changed.emitter;
            marked.push(entity);
        }
        let previous = self.built.as_ref().filter(|b| b.accel_kind() == kind);
        let build = |previous: Option<&RenderScene>| {
            RenderScene::build_reusing_on_threads(&self.loaded, kind, previous, threads)
        };
        let (scene, rebuilt) = match previous {
            None => (build(None)?, Rebuilt::Everything),
            Some(p) if geometry => {
                let scene = build(Some(p))?;
                let rebuilt = Rebuilt::Geometry {
                    kept: scene.stats.reused_bvhs,
                    meshes: scene.accel_mesh_bvhs(),
                };
                (scene, rebuilt)
            }
            Some(p) if emitters => match p.with_lights(&self.loaded) {
                Some(scene) => (scene, Rebuilt::Lights),
                None => {
                    let scene = build(Some(p))?;
                    let rebuilt = Rebuilt::Geometry {
                        kept: scene.stats.reused_bvhs,
                        meshes: scene.accel_mesh_bvhs(),
                    };
                    (scene, rebuilt)
                }
            },
            Some(p) => (p.with_materials(&self.loaded), Rebuilt::Nothing),
        };
        let mut clear = CommandBuffer::new();
        for entity in marked {
            clear.remove_one::<Changed>(entity);
        }
        clear.run_on(&mut self.loaded.world);
        self.removed = 0;
        self.environment_changed = false;
        let scene = Arc::new(scene);
        self.built = Some(Arc::clone(&scene));
        Ok((scene, rebuilt))
    }
}

/// The entity's name, for messages.
fn entity_name(world: &World, entity: Entity) -> String {
    world
        .get::<&Name>(entity)
        .map_or_else(|_| "?".into(), |n| n.0.clone())
}

/// What differs between entity `was` and entity `now`, component by component.
fn compare(world: &World, was: Entity, now: Entity) -> Changed {
    fn differs<T: hecs::Component + PartialEq>(world: &World, a: Entity, b: Entity) -> bool {
        let a = world.get::<&T>(a).ok();
        let b = world.get::<&T>(b).ok();
        a.as_deref() != b.as_deref()
    }
    // An instance's shape names its asset: whether the asset is the same is in `Instanced`.
    let asset = |e| {
        world
            .get::<&Instanced>(e)
            .ok()
            .map(|i| Arc::clone(&i.asset))
    };
    let same_asset = match (asset(was), asset(now)) {
        (Some(a), Some(b)) => Arc::ptr_eq(&a, &b),
        (a, b) => a.is_none() && b.is_none(),
    };
    Changed {
        added: false,
        transform: differs::<Transform>(world, was, now),
        // A mesh file's content is in the shape it was read into.
        shape: differs::<Shape>(world, was, now)
            || differs::<FlipNormals>(world, was, now)
            || !same_asset,
        material: differs::<MaterialRef>(world, was, now),
        emitter: differs::<Emitter>(world, was, now),
        order: differs::<FileOrder>(world, was, now),
    }
}

/// Loads a scene file's description into a world of its own (see [`SceneState::new`]).
pub(super) fn build_world(
    file: SceneFile,
    path: &Path,
    files: &SceneFiles,
) -> Result<LoadedScene, SceneError> {
    Ok(SceneState::new(file, path, files.clone())?.loaded)
}

#[cfg(test)]
#[path = "edit_tests.rs"]
mod tests;
