//! Flattening: the ECS world becomes the render scene. Materials and lights go to their
//! tables (one light per emitting primitive, or per quad, in file order); the shapes and
//! instances become the accelerator's input ([`crate::accel::Input`]) and the accelerator is
//! built over them. The result implements the integrators' [`Scene`] trait and is immutable
//! and `Sync`.
//!
//! A large mesh that does not emit ([`OWN_BVH_TRIANGLES`]) gets a BVH of its own, placed as an
//! instance by the identity, rather than a place in the flat BVH (unless it is the flat scene's
//! only shape): so that an edit elsewhere
//! (a moved box, an added sphere) rebuilds the small flat BVH and the top level while the
//! large mesh keeps its BVH ([`RenderScene::build_reusing`]). A scene loaded fresh is built the
//! same way, so an edited scene and the same scene loaded fresh are the same bits.

use super::components::{
    Emitter, FileOrder, GeometryId, Instanced, MaterialRef, MediumBoundary, Name, Transform,
    WorldShape,
};
use super::{systems, LoadedScene};
use crate::accel::{
    self, Accel, AccelKind, Accelerator, Geometry, InstanceDesc, Mesh, Shape, ShapeLights,
};
use crate::formats::schema::LightSelection;
use glam::Vec3A;
use hecs::Entity;
use obvhs::triangle::Triangle;
use raylab_integrators::light::table::Emission;
use raylab_integrators::light::LightSelection as Selection;
use raylab_integrators::{
    Hit, Light, LightTable, Medium, MediumId, MediumInterface, Ray, Scene, SurfaceMaterial,
};
use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Meshes of at least this many triangles that do not emit get a BVH of their own (see the
/// module's header). Instancing costs a top-level node and a call per ray that reaches the
/// mesh, small beside the traversal of its 2^16 triangles.
pub const OWN_BVH_TRIANGLES: usize = 1 << 16;

/// Counts and timings of a build, for `raylab validate` and reports.
#[derive(Clone, Debug, Default)]
pub struct BuildStats {
    pub entities: usize,
    pub triangles: usize,
    pub spheres: usize,
    /// Disks and cylinders.
    pub quadrics: usize,
    /// Pieces of curves (BVH primitives).
    pub curve_pieces: usize,
    /// Entries in the light table (a quad light is one, a mesh light one per triangle).
    pub lights: usize,
    /// Entities that emit.
    pub emitters: usize,
    pub bvh_nodes: usize,
    /// Leaves of the flat scene's BVH.
    pub bvh_leaves: usize,
    /// Large meshes with a BVH of their own ([`OWN_BVH_TRIANGLES`]; counted in `triangles`).
    pub own_bvh_meshes: usize,
    /// Mesh BVHs this build took from the scene it was built from, not built again.
    pub reused_bvhs: usize,
    /// Instances of mesh assets, the triangles of those assets (each once) and the triangles
    /// the instances place (each asset once per instance).
    pub instances: usize,
    pub instanced_triangles: usize,
    pub placed_triangles: usize,
    pub build_time: Duration,
}

/// The flattened, accelerated scene that rendering reads. The accelerator and the light table
/// are shared with the scenes an edit makes of this one where the edit leaves them alone.
pub struct RenderScene {
    pub(crate) accel: Arc<Accel>,
    materials: Vec<SurfaceMaterial>,
    pub(crate) lights: Arc<LightTable>,
    /// Per emitting entity in file order, how many lights it has: an edit that keeps this
    /// keeps the light indices baked into the accelerator.
    light_counts: Vec<(FileOrder, usize)>,
    /// Bounds of the large meshes with a BVH of their own, by geometry id: a rebuild takes
    /// them rather than going over the triangles again.
    own_bounds: Vec<(u64, (Vec3A, Vec3A))>,
    bounds: (Vec3A, Vec3A),
    /// Whether some material is cut out by an `alpha`: rays then go on past the surfaces
    /// it lets them through.
    has_cutouts: bool,
    /// The participating media and the camera's.
    media: Vec<Medium>,
    camera_medium: MediumId,
    /// Per material slot, the media its surfaces bound (empty without media): a material
    /// used by surfaces with different interfaces has one slot per interface.
    interfaces: Vec<Option<MediumInterface>>,
    pub stats: BuildStats,
}

/// The material table as the accelerator's primitives index it: the scene's materials, then
/// a copy of a material for each further medium interface the surfaces that use it bound.
struct Slots {
    materials: Vec<SurfaceMaterial>,
    interfaces: Vec<Option<MediumInterface>>,
    /// Each entity's slot, where it differs from its material's index.
    of: HashMap<Entity, u32>,
}

impl Slots {
    /// The slots of `scene`'s shaped and instanced entities, in file order.
    fn of_scene(scene: &LoadedScene) -> Slots {
        let mut slots = Slots {
            materials: scene.materials.clone(),
            interfaces: Vec::new(),
            of: HashMap::new(),
        };
        if scene.media.media.is_empty() {
            return slots;
        }
        slots.interfaces = vec![None; slots.materials.len()];
        let mut made: HashMap<(u32, [u32; 2]), u32> = HashMap::new();
        let mut bounded: Vec<(FileOrder, Entity, u32, MediumInterface)> = scene
            .world
            .query::<(Entity, &FileOrder, &MaterialRef, &MediumBoundary)>()
            .iter()
            .filter_map(|(e, order, m, b)| {
                let interface = scene.media.interface(&b.0).ok()?;
                Some((*order, e, m.0, interface))
            })
            .collect();
        bounded.sort_by_key(|b| b.0);
        for (_, entity, material, interface) in bounded {
            let key = (material, [interface.inside.0, interface.outside.0]);
            let slot = match made.get(&key) {
                Some(&slot) => slot,
                None if slots.interfaces[material as usize].is_none() => {
                    slots.interfaces[material as usize] = Some(interface);
                    material
                }
                None => {
                    slots
                        .materials
                        .push(slots.materials[material as usize].clone());
                    slots.interfaces.push(Some(interface));
                    (slots.materials.len() - 1) as u32
                }
            };
            made.insert(key, slot);
            slots.of.insert(entity, slot);
        }
        // A material some surfaces use without an interface and others with one: those
        // without keep the original slot only if no interface took it.
        let mut free: Vec<(FileOrder, Entity, u32)> = scene
            .world
            .query::<(Entity, &FileOrder, &MaterialRef)>()
            .without::<&MediumBoundary>()
            .iter()
            .filter(|(_, _, m)| slots.interfaces[m.0 as usize].is_some())
            .map(|(e, order, m)| (*order, e, m.0))
            .collect();
        free.sort_by_key(|f| f.0);
        let mut plain: HashMap<u32, u32> = HashMap::new();
        for (_, entity, material) in free {
            let slot = *plain.entry(material).or_insert_with(|| {
                slots
                    .materials
                    .push(slots.materials[material as usize].clone());
                slots.interfaces.push(None);
                (slots.materials.len() - 1) as u32
            });
            slots.of.insert(entity, slot);
        }
        slots
    }

    /// The slot of `entity`, whose material is `material`.
    fn slot(&self, entity: Entity, material: u32) -> u32 {
        self.of.get(&entity).copied().unwrap_or(material)
    }
}

impl RenderScene {
    /// [`RenderScene::build_with`] on `threads` worker threads (every core when `None`), so
    /// that `--threads` bounds the build as it bounds the render that follows.
    pub fn build_on_threads(
        scene: &LoadedScene,
        kind: AccelKind,
        threads: Option<usize>,
    ) -> anyhow::Result<RenderScene> {
        Self::build_reusing_on_threads(scene, kind, None, threads)
    }

    /// [`RenderScene::build_reusing`] on `threads` worker threads (every core when `None`).
    pub fn build_reusing_on_threads(
        scene: &LoadedScene,
        kind: AccelKind,
        previous: Option<&RenderScene>,
        threads: Option<usize>,
    ) -> anyhow::Result<RenderScene> {
        let build = || Self::build_reusing(scene, kind, previous);
        Ok(match threads {
            None => build(),
            Some(n) => rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| anyhow::anyhow!("cannot start {n} worker threads: {e}"))?
                .install(build),
        })
    }

    /// [`RenderScene::build_with`] raylab's own accelerator.
    pub fn build(scene: &LoadedScene) -> RenderScene {
        Self::build_with(scene, AccelKind::Raylab)
    }

    /// Builds the render scene from a loaded world over an accelerator of kind `kind`. The
    /// world must have been validated and baked (as [`crate::scene::load_scene`] does).
    pub fn build_with(scene: &LoadedScene, kind: AccelKind) -> RenderScene {
        Self::build_reusing(scene, kind, None)
    }

    /// [`RenderScene::build_with`], taking from `previous` (the scene built before an edit)
    /// the BVH of every mesh whose triangles it already had: the same result, sooner.
    pub fn build_reusing(
        scene: &LoadedScene,
        kind: AccelKind,
        previous: Option<&RenderScene>,
    ) -> RenderScene {
        let start = Instant::now();
        let world = &scene.world;

        // Lights: one table entry per emitting primitive (or quad), in file order.
        let (lights, light_of) = lights_of(scene);

        // The accelerator's input: shapes and instances in file order; large meshes that do
        // not emit become instances of their own mesh, placed by the identity.
        let mut query = world.query::<(
            Entity,
            &FileOrder,
            &WorldShape,
            &MaterialRef,
            Option<&GeometryId>,
        )>();
        let mut shaped: Vec<_> = query.iter().collect();
        shaped.sort_by_key(|(_, order, ..)| **order);
        let own_bvh = |(entity, _, shape, ..): &(Entity, &FileOrder, &WorldShape, _, _)| {
            matches!(shape, WorldShape::Triangles { triangles, .. }
                if triangles.len() >= OWN_BVH_TRIANGLES)
                && !light_of.contains_key(entity)
        };
        // SDF grids go to the accelerator's set of them, the rest to its BVHs.
        let (grids, shaped): (Vec<_>, Vec<_>) = shaped
            .into_iter()
            .partition(|(_, _, shape, ..)| matches!(shape, WorldShape::SdfGrid(_)));
        let slots = Slots::of_scene(scene);
        let sdf_grids = grids
            .iter()
            .filter_map(|(entity, _, shape, material, _)| match shape {
                WorldShape::SdfGrid(grid) => Some(accel::SdfInput {
                    grid: Arc::clone(grid),
                    material: slots.slot(*entity, material.0),
                }),
                _ => None,
            })
            .collect();
        let (mut own, mut flat): (Vec<_>, Vec<_>) = shaped.into_iter().partition(own_bvh);
        if own.len() == 1 && flat.is_empty() {
            // Nothing to keep apart from: one BVH, without the top level's cost per ray
            // (13% of the rays per second of a lone 1.3 M-triangle mesh).
            flat = std::mem::take(&mut own);
        }
        let shapes = flat
            .iter()
            .filter_map(|(entity, _, shape, material, _)| {
                Some(Shape {
                    geometry: match shape {
                        WorldShape::Triangles {
                            triangles,
                            normals,
                            uvs,
                            attributes,
                            ..
                        } => Geometry::Triangles(Mesh {
                            triangles,
                            normals: normals.as_deref(),
                            uvs: uvs.as_deref(),
                            attributes: attributes.as_deref(),
                            bounds: (Vec3A::ZERO, Vec3A::ZERO),
                        }),
                        WorldShape::Sphere {
                            center,
                            radius,
                            frame,
                        } => Geometry::Sphere {
                            center: *center,
                            radius: *radius,
                            frame: *frame,
                        },
                        WorldShape::Quadric(q) => Geometry::Quadric(*q),
                        WorldShape::Curves {
                            segments,
                            split_depth,
                        } => Geometry::Curves(accel::Curves {
                            segments,
                            split_depth: *split_depth,
                        }),
                        // Set apart above.
                        WorldShape::SdfGrid(_) => return None,
                    },
                    material: slots.slot(*entity, material.0),
                    // One light for the whole entity (a sphere, a quad), or one per triangle.
                    lights: match light_of.get(entity) {
                        None => ShapeLights::None,
                        Some(&(first, 1)) => ShapeLights::Whole(first),
                        Some(&(first, _)) => ShapeLights::PerTriangle(first),
                    },
                })
            })
            .collect();
        let mut instances: Vec<(FileOrder, InstanceDesc)> = world
            .query::<(Entity, &FileOrder, &Instanced, &MaterialRef, &Transform)>()
            .iter()
            .map(|(entity, order, inst, m, t)| {
                let desc = InstanceDesc {
                    mesh: inst.mesh,
                    material: slots.slot(entity, m.0),
                    local_to_world: t.matrix(),
                };
                (*order, desc)
            })
            .collect();
        let mut meshes: Vec<Mesh> = scene
            .meshes
            .iter()
            .map(|m| Mesh {
                triangles: &m.triangles,
                normals: m.normals.as_deref(),
                uvs: m.uvs.as_deref(),
                attributes: None,
                bounds: m.bounds,
            })
            .collect();
        let mut mesh_keys: Vec<u64> = scene.meshes.iter().map(|m| m.id).collect();
        let mut own_triangles = 0;
        let mut own_bounds = Vec::with_capacity(own.len());
        for (entity, order, shape, material, id) in &own {
            let WorldShape::Triangles {
                triangles,
                normals,
                uvs,
                attributes,
                ..
            } = shape
            else {
                continue;
            };
            // Baked geometry always has its key; `u64::MAX` is never kept.
            let key = id.map_or(u64::MAX, |g| g.0);
            let known = previous.and_then(|p| {
                p.own_bounds
                    .iter()
                    .find(|(k, _)| *k == key && key != u64::MAX)
            });
            let bounds = match known {
                Some(&(_, b)) => b,
                None => {
                    let mut b = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
                    for p in triangles.iter().flatten() {
                        b = (b.0.min(*p), b.1.max(*p));
                    }
                    b
                }
            };
            own_bounds.push((key, bounds));
            own_triangles += triangles.len();
            instances.push((
                **order,
                InstanceDesc {
                    mesh: meshes.len() as u32,
                    material: slots.slot(*entity, material.0),
                    local_to_world: glam::Affine3A::IDENTITY,
                },
            ));
            meshes.push(Mesh {
                triangles,
                normals: normals.as_deref(),
                uvs: uvs.as_deref(),
                attributes: attributes.as_deref(),
                bounds,
            });
            mesh_keys.push(key);
        }
        instances.sort_by_key(|(order, _)| *order);
        let input = accel::Input {
            shapes,
            meshes,
            mesh_keys,
            instances: instances.into_iter().map(|(_, d)| d).collect(),
            sdf_grids,
        };
        let accel = Accel::build_reusing(kind, &input, previous.map(|p| &*p.accel));

        // A scene without geometry: a point at the origin.
        let bounds = accel.bounds().unwrap_or((Vec3A::ZERO, Vec3A::ZERO));
        let light_counts = light_counts(scene, &light_of);
        let lights = table(lights, &light_of, scene, bounds);
        let a = accel.stats();
        // The large meshes with a BVH of their own are the scene's triangles, not instances.
        let stats = BuildStats {
            entities: world.len() as usize,
            triangles: a.triangles + own_triangles,
            spheres: a.spheres,
            quadrics: a.quadrics,
            curve_pieces: a.curve_pieces,
            lights: lights.len(),
            emitters: light_counts.len() + usize::from(scene.environment.is_some()),
            bvh_nodes: a.bvh_nodes,
            bvh_leaves: a.bvh_leaves,
            instances: a.instances - own.len(),
            instanced_triangles: a.instanced_triangles - own_triangles,
            placed_triangles: a.placed_triangles - own_triangles,
            own_bvh_meshes: own.len(),
            reused_bvhs: accel.mesh_bvhs().1,
            build_time: start.elapsed(),
        };
        RenderScene {
            accel: Arc::new(accel),
            has_cutouts: has_cutouts(&slots.materials),
            materials: slots.materials,
            interfaces: slots.interfaces,
            media: scene.media.media.clone(),
            camera_medium: scene.media.camera,
            lights: Arc::new(lights),
            light_counts,
            own_bounds,
            bounds,
            stats,
        }
    }

    /// This scene with the materials of `scene` (after an edit that changed no geometry and
    /// no material index): nothing rebuilt.
    pub fn with_materials(&self, scene: &LoadedScene) -> RenderScene {
        let slots = Slots::of_scene(scene);
        RenderScene {
            accel: Arc::clone(&self.accel),
            has_cutouts: has_cutouts(&slots.materials),
            materials: slots.materials,
            interfaces: slots.interfaces,
            media: scene.media.media.clone(),
            camera_medium: scene.media.camera,
            lights: Arc::clone(&self.lights),
            light_counts: self.light_counts.clone(),
            own_bounds: self.own_bounds.clone(),
            bounds: self.bounds,
            stats: BuildStats {
                reused_bvhs: self.accel.mesh_bvhs().0,
                build_time: Duration::ZERO,
                ..self.stats.clone()
            },
        }
    }

    /// This scene with the materials and lights of `scene`, if its emitting entities have as
    /// many lights each as this scene's (the indices baked into the accelerator stay right):
    /// only the light table is made again. `None` when the layout changed.
    pub fn with_lights(&self, scene: &LoadedScene) -> Option<RenderScene> {
        let start = Instant::now();
        let (lights, light_of) = lights_of(scene);
        let counts = light_counts(scene, &light_of);
        if counts != self.light_counts {
            return None;
        }
        let lights = table(lights, &light_of, scene, self.bounds);
        let same = self.with_materials(scene);
        Some(RenderScene {
            stats: BuildStats {
                lights: lights.len(),
                emitters: counts.len() + usize::from(scene.environment.is_some()),
                build_time: start.elapsed(),
                ..same.stats
            },
            lights: Arc::new(lights),
            ..same
        })
    }
}

/// Whether some material is cut out by an `alpha`.
fn has_cutouts(materials: &[SurfaceMaterial]) -> bool {
    materials.iter().any(|m| m.cutout().is_some())
}

/// Entity -> (first light, count), in the light list's order.
type LightsOf = HashMap<Entity, (u32, usize)>;

/// The lights of every emitting entity in file order, and where each entity's are.
fn lights_of(scene: &LoadedScene) -> (Vec<Light>, LightsOf) {
    let mut lights: Vec<Light> = Vec::new();
    let mut light_of = HashMap::new();
    for (entity, ls) in systems::collect_emitters(&scene.world) {
        light_of.insert(entity, (lights.len() as u32, ls.len()));
        lights.extend(ls);
    }
    (lights, light_of)
}

/// Which entities emit, in file order, and how many lights each has: the light indices the
/// accelerator's primitives carry follow from it.
fn light_counts(scene: &LoadedScene, light_of: &LightsOf) -> Vec<(FileOrder, usize)> {
    let mut counts: Vec<(FileOrder, usize)> = light_of
        .iter()
        .filter_map(|(&e, &(_, n))| Some((*scene.world.get::<&FileOrder>(e).ok()?, n)))
        .collect();
    counts.sort_unstable();
    counts
}

/// The light table of `lights` and the scene's constant environment, for geometry within
/// `bounds`.
fn table(
    mut lights: Vec<Light>,
    light_of: &LightsOf,
    scene: &LoadedScene,
    bounds: (Vec3A, Vec3A),
) -> LightTable {
    let radius = 0.5 * (bounds.1 - bounds.0).length();
    if let Some(env) = scene.environment {
        lights.push(Light::environment(env));
    }
    let powers = LightTable::powers(&lights, radius);
    // Uniform selection: each emitting entity (and the constant environment) alike, then
    // its lights by power: an entity's share is 1, spread over its parts.
    let mut uniform = powers.clone();
    let mut groups: Vec<(usize, usize)> =
        light_of.values().map(|&(s, n)| (s as usize, n)).collect();
    if scene.environment.is_some() {
        groups.push((lights.len() - 1, 1));
    }
    let mut grouped = vec![false; lights.len()];
    for (start, n) in groups {
        let part = &mut uniform[start..start + n];
        let total: f64 = part.iter().sum();
        for w in part.iter_mut() {
            *w = if total > 0.0 {
                *w / total
            } else {
                1.0 / n as f64
            };
        }
        grouped[start..start + n].fill(true);
    }
    // Lights no entity groups (none today) count one each.
    for (w, g) in uniform.iter_mut().zip(&grouped) {
        if !g {
            *w = 1.0;
        }
    }
    let selection = match scene.render.light_selection {
        LightSelection::Power => Selection::Power,
        LightSelection::Uniform => Selection::Uniform,
        LightSelection::Bvh => Selection::Bvh,
    };
    // What each light emits by wavelength, where its entity gave a spectrum.
    let mut spectra = vec![None; lights.len()];
    for (&entity, &(start, n)) in light_of {
        if let Ok(emitter) = scene.world.get::<&Emitter>(entity) {
            if let Some((curve, rgb)) = emitter.spectrum() {
                for s in &mut spectra[start as usize..start as usize + n] {
                    *s = Some(Emission {
                        curve: curve.clone(),
                        rgb,
                    });
                }
            }
        }
    }
    LightTable::build(lights, powers, uniform, selection).with_spectra(spectra)
}

impl RenderScene {
    /// Bytes held by the geometry, its per-primitive data and the BVHs (not the materials or
    /// lights): what a benchmark reports per triangle. Each instanced mesh counts once.
    pub fn memory_bytes(&self) -> usize {
        self.accel.memory_bytes()
    }

    /// How many mesh BVHs the accelerator holds (instanced assets and large meshes).
    pub fn accel_mesh_bvhs(&self) -> usize {
        self.accel.mesh_bvhs().0
    }

    /// Whether the scene has participating media.
    pub fn has_media(&self) -> bool {
        !self.media.is_empty()
    }

    /// Which accelerator the scene was built over.
    pub fn accel_kind(&self) -> AccelKind {
        self.accel.kind()
    }
}

impl RenderScene {
    /// The closest hit past the surfaces pbrt's `alpha` lets `ray` through.
    fn closest_through_cutouts(&self, ray: &Ray) -> Option<Hit> {
        raylab_integrators::cutout::closest_through_cutouts(
            ray,
            |r| self.accel.closest(r),
            |h| self.accel.parametrise(h),
            |m| &self.materials[m as usize],
        )
    }
}

impl Scene for RenderScene {
    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let hit = if self.has_cutouts {
            self.closest_through_cutouts(ray)
        } else {
            self.accel.closest(ray)
        };
        if self.interfaces.is_empty() {
            return hit;
        }
        // The media either side: the surface's own, or, where it bounds none, the ray's.
        hit.map(|mut h| {
            h.media = self.interfaces[h.material as usize].unwrap_or(MediumInterface {
                inside: ray.medium,
                outside: ray.medium,
            });
            h
        })
    }

    fn media(&self) -> &[Medium] {
        &self.media
    }

    fn camera_medium(&self) -> MediumId {
        self.camera_medium
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        if self.has_cutouts {
            return self.closest_through_cutouts(ray).is_some();
        }
        self.accel.occluded(ray)
    }

    fn intersect_all(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        if self.has_cutouts || !self.interfaces.is_empty() {
            for (ray, hit) in rays.iter().zip(hits) {
                *hit = self.intersect(ray);
            }
            return;
        }
        self.accel.closest_all(rays, hits);
    }

    fn occluded_all(&self, rays: &[Ray], blocked: &mut [bool]) {
        if self.has_cutouts {
            for (ray, b) in rays.iter().zip(blocked) {
                *b = self.occluded(ray);
            }
            return;
        }
        self.accel.occluded_all(rays, blocked);
    }

    fn material(&self, id: u32) -> &SurfaceMaterial {
        &self.materials[id as usize]
    }

    fn disperses(&self) -> bool {
        self.materials.iter().any(SurfaceMaterial::disperses)
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

/// The triangles of a loaded scene's own shapes (not its instances), in world space and file
/// order: the geometry `raylab bench` dumps and gives Embree. (The build gives the large ones a
/// BVH of their own, see the module's header.)
pub fn flat_triangles(scene: &LoadedScene) -> Vec<Triangle> {
    let mut query = scene.world.query::<(&FileOrder, &WorldShape)>();
    let mut shapes: Vec<(&FileOrder, &WorldShape)> = query.iter().collect();
    shapes.sort_by_key(|(order, _)| **order);
    shapes
        .iter()
        .flat_map(|(_, shape)| match shape {
            WorldShape::Triangles { triangles, .. } => triangles.as_slice(),
            WorldShape::Sphere { .. }
            | WorldShape::Quadric(_)
            | WorldShape::SdfGrid(_)
            | WorldShape::Curves { .. } => &[],
        })
        .map(|&[v0, v1, v2]| Triangle { v0, v1, v2 })
        .collect()
}

/// The spheres of a loaded scene as (centre, radius), in file order.
pub fn flat_spheres(scene: &LoadedScene) -> Vec<(Vec3A, f32)> {
    let mut spheres: Vec<(FileOrder, Vec3A, f32)> = scene
        .world
        .query::<(&FileOrder, &WorldShape)>()
        .iter()
        .filter_map(|(order, shape)| match shape {
            WorldShape::Sphere { center, radius, .. } => Some((*order, *center, *radius)),
            WorldShape::Triangles { .. }
            | WorldShape::Quadric(_)
            | WorldShape::SdfGrid(_)
            | WorldShape::Curves { .. } => None,
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
