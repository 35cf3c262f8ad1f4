//! Flattening: the ECS world becomes the render scene. Materials and lights go to their
//! tables (one light per emitting primitive, or per quad, in entity order); the shapes and
//! instances become the accelerator's input ([`crate::accel::Input`]) and the accelerator is
//! built over them. The result implements the integrators' [`Scene`] trait and is immutable
//! and `Sync`.

use super::components::{FileOrder, Instanced, MaterialRef, Name, Transform, WorldShape};
use super::{systems, LoadedScene};
use crate::accel::{
    self, Accel, AccelKind, Accelerator, Geometry, InstanceDesc, Mesh, Shape, ShapeLights,
};
use glam::Vec3A;
use hecs::Entity;
use obvhs::triangle::Triangle;
use raylab_integrators::{Hit, Light, LightTable, Ray, Scene, SurfaceMaterial};
use std::collections::HashMap;
use std::time::{Duration, Instant};

/// Counts and timings of a build, for `raylab validate` and reports.
#[derive(Clone, Debug, Default)]
pub struct BuildStats {
    pub entities: usize,
    pub triangles: usize,
    pub spheres: usize,
    /// Disks and cylinders.
    pub quadrics: usize,
    /// Entries in the light table (a quad light is one, a mesh light one per triangle).
    pub lights: usize,
    /// Entities that emit.
    pub emitters: usize,
    pub bvh_nodes: usize,
    /// Leaves of the flat scene's BVH.
    pub bvh_leaves: usize,
    /// Instances of mesh assets, the triangles of those assets (each once) and the triangles
    /// the instances place (each asset once per instance).
    pub instances: usize,
    pub instanced_triangles: usize,
    pub placed_triangles: usize,
    pub build_time: Duration,
}

/// The flattened, accelerated scene that rendering reads.
pub struct RenderScene {
    pub(crate) accel: Accel,
    materials: Vec<SurfaceMaterial>,
    pub(crate) lights: LightTable,
    bounds: (Vec3A, Vec3A),
    pub stats: BuildStats,
}

impl RenderScene {
    /// [`RenderScene::build_with`] on `threads` worker threads (every core when `None`), so
    /// that `--threads` bounds the build as it bounds the render that follows.
    pub fn build_on_threads(
        scene: &LoadedScene,
        kind: AccelKind,
        threads: Option<usize>,
    ) -> anyhow::Result<RenderScene> {
        Ok(match threads {
            None => Self::build_with(scene, kind),
            Some(n) => rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| anyhow::anyhow!("cannot start {n} worker threads: {e}"))?
                .install(|| Self::build_with(scene, kind)),
        })
    }

    /// [`RenderScene::build_with`] raylab's own accelerator.
    pub fn build(scene: &LoadedScene) -> RenderScene {
        Self::build_with(scene, AccelKind::Raylab)
    }

    /// Builds the render scene from a loaded world over an accelerator of kind `kind`. The
    /// world must have been validated and baked (as [`crate::scene::load_scene`] does).
    pub fn build_with(scene: &LoadedScene, kind: AccelKind) -> RenderScene {
        let start = Instant::now();
        let world = &scene.world;

        // Lights: one table entry per emitting primitive (or quad), in entity order.
        let emitters = systems::collect_emitters(world);
        let mut lights: Vec<Light> = Vec::new();
        // Entity -> (first light, count).
        let mut light_of: HashMap<Entity, (u32, usize)> = HashMap::new();
        for (entity, ls) in &emitters {
            light_of.insert(*entity, (lights.len() as u32, ls.len()));
            lights.extend(ls.iter().cloned());
        }

        // The accelerator's input: shapes and instances in entity order.
        let mut query = world.query::<(Entity, &FileOrder, &WorldShape, &MaterialRef)>();
        let mut shaped: Vec<_> = query.iter().collect();
        shaped.sort_by_key(|(_, order, ..)| **order);
        let shapes = shaped
            .iter()
            .map(|(entity, _, shape, material)| Shape {
                geometry: match shape {
                    WorldShape::Triangles {
                        triangles,
                        normals,
                        uvs,
                        ..
                    } => Geometry::Triangles(Mesh {
                        triangles,
                        normals: normals.as_deref(),
                        uvs: uvs.as_deref(),
                        bounds: (Vec3A::ZERO, Vec3A::ZERO),
                    }),
                    WorldShape::Sphere { center, radius } => Geometry::Sphere {
                        center: *center,
                        radius: *radius,
                    },
                    WorldShape::Quadric(q) => Geometry::Quadric(*q),
                },
                material: material.0,
                // One light for the whole entity (a sphere, a quad), or one per triangle.
                lights: match light_of.get(entity) {
                    None => ShapeLights::None,
                    Some(&(first, 1)) => ShapeLights::Whole(first),
                    Some(&(first, _)) => ShapeLights::PerTriangle(first),
                },
            })
            .collect();
        let mut instances: Vec<(FileOrder, InstanceDesc)> = world
            .query::<(&FileOrder, &Instanced, &MaterialRef, &Transform)>()
            .iter()
            .map(|(order, inst, m, t)| {
                let desc = InstanceDesc {
                    mesh: inst.mesh,
                    material: m.0,
                    local_to_world: t.matrix(),
                };
                (*order, desc)
            })
            .collect();
        instances.sort_by_key(|(order, _)| *order);
        let input = accel::Input {
            shapes,
            meshes: scene
                .meshes
                .iter()
                .map(|m| Mesh {
                    triangles: &m.triangles,
                    normals: m.normals.as_deref(),
                    uvs: m.uvs.as_deref(),
                    bounds: m.bounds,
                })
                .collect(),
            instances: instances.into_iter().map(|(_, d)| d).collect(),
        };
        let accel = Accel::build(kind, &input);

        // A scene without geometry: a point at the origin.
        let bounds = accel.bounds().unwrap_or((Vec3A::ZERO, Vec3A::ZERO));
        let radius = 0.5 * (bounds.1 - bounds.0).length();
        if let Some(env) = scene.environment {
            lights.push(Light::environment(env));
        }
        let lights = LightTable::new(lights, radius);
        let a = accel.stats();
        let stats = BuildStats {
            entities: world.len() as usize,
            triangles: a.triangles,
            spheres: a.spheres,
            quadrics: a.quadrics,
            lights: lights.len(),
            emitters: emitters.len() + usize::from(scene.environment.is_some()),
            bvh_nodes: a.bvh_nodes,
            bvh_leaves: a.bvh_leaves,
            instances: a.instances,
            instanced_triangles: a.instanced_triangles,
            placed_triangles: a.placed_triangles,
            build_time: start.elapsed(),
        };
        RenderScene {
            accel,
            materials: scene.materials.clone(),
            lights,
            bounds,
            stats,
        }
    }

    /// Bytes held by the geometry, its per-primitive data and the BVHs (not the materials or
    /// lights): what a benchmark reports per triangle. Each instanced mesh counts once.
    pub fn memory_bytes(&self) -> usize {
        self.accel.memory_bytes()
    }

    /// Which accelerator the scene was built over.
    pub fn accel_kind(&self) -> AccelKind {
        self.accel.kind()
    }
}

impl Scene for RenderScene {
    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.accel.closest(ray)
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        self.accel.occluded(ray)
    }

    fn material(&self, id: u32) -> &SurfaceMaterial {
        &self.materials[id as usize]
    }

    fn lights(&self) -> &LightTable {
        &self.lights
    }

    fn bounds(&self) -> (Vec3A, Vec3A) {
        self.bounds
    }

    #[inline]
    fn parametrise(&self, hit: &mut Hit) {
        self.accel.parametrise(hit);
    }
}

/// The flat (not instanced) triangles of a loaded scene, exactly as the build places them,
/// in entity order: the geometry `raylab bench` dumps and gives Embree.
pub fn flat_triangles(scene: &LoadedScene) -> Vec<Triangle> {
    let mut query = scene.world.query::<(&FileOrder, &WorldShape)>();
    let mut shapes: Vec<(&FileOrder, &WorldShape)> = query.iter().collect();
    shapes.sort_by_key(|(order, _)| **order);
    shapes
        .iter()
        .flat_map(|(_, shape)| match shape {
            WorldShape::Triangles { triangles, .. } => triangles.as_slice(),
            WorldShape::Sphere { .. } | WorldShape::Quadric(_) => &[],
        })
        .map(|&[v0, v1, v2]| Triangle { v0, v1, v2 })
        .collect()
}

/// The spheres of a loaded scene as (centre, radius), in entity order.
pub fn flat_spheres(scene: &LoadedScene) -> Vec<(Vec3A, f32)> {
    let mut spheres: Vec<(FileOrder, Vec3A, f32)> = scene
        .world
        .query::<(&FileOrder, &WorldShape)>()
        .iter()
        .filter_map(|(order, shape)| match shape {
            WorldShape::Sphere { center, radius } => Some((*order, *center, *radius)),
            WorldShape::Triangles { .. } | WorldShape::Quadric(_) => None,
        })
        .collect();
    spheres.sort_by_key(|s| s.0);
    spheres.into_iter().map(|(_, c, r)| (c, r)).collect()
}

/// Names of the entities that emit, for reports.
pub fn emitter_names(scene: &LoadedScene) -> Vec<String> {
    let mut q = scene
        .world
        .query::<(&FileOrder, &Name, &super::components::Emitter)>();
    let mut v: Vec<_> = q.iter().map(|(o, n, _)| (*o, n.0.clone())).collect();
    v.sort();
    v.into_iter().map(|(_, n)| n).collect()
}
