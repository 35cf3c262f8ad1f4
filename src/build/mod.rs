//! The build step: flattens the ECS world into primitives, builds the BVH over triangles and
//! spheres together, lays the primitives out in [`packet::Packet`]s, one or two per BVH leaf (spheres'
//! centres and radii in arrays of their own), and collects emitters into the light table. Instances of mesh assets are not flattened:
//! they get a two-level BVH of their own ([`instances`]), traced after the flat BVH with the
//! ray shortened to its hit, and only when the scene has any. The result implements the
//! integrators' [`Scene`] trait and is immutable and `Sync`.

mod bvh;
mod instances;
mod packet;
mod primitives;

use crate::scene::components::{MaterialRef, Name, WorldShape};
use crate::scene::{systems, LoadedScene};
use arrayvec::ArrayVec;
use bvh::{isa, isa::Isa, Bvh};
use glam::Vec3A;
use hecs::Entity;
use instances::InstanceSet;
use obvhs::aabb::Aabb;
use obvhs::triangle::Triangle;
use packet::{Lane, LeafTest, Packet, PacketRay, Spheres, Stored, NONE};
use raylab_integrators::{Hit, Light, LightTable, Material, Ray, Scene};
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Counts and timings of a build, for `raylab validate` and reports.
#[derive(Clone, Debug, Default)]
pub struct BuildStats {
    pub entities: usize,
    pub triangles: usize,
    pub spheres: usize,
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

/// The flattened, BVH-backed scene that rendering reads.
pub struct RenderScene {
    bvh: Bvh,
    /// Per packet of a leaf's primitives (one or two per leaf): the packet and its lane data,
    /// side by side.
    packets: Vec<Stored>,
    /// Per-vertex normals of the triangles that have them ([`LaneData::smooth`]).
    smooth_normals: Vec<[Vec3A; 3]>,
    // Spheres' geometry, in BVH order; their materials and lights are in their lane data.
    sph_center: Vec<Vec3A>,
    sph_radius: Vec<f32>,

    /// Instanced meshes (a two-level BVH); empty in most scenes.
    instances: InstanceSet,

    materials: Vec<Material>,
    lights: LightTable,
    bounds: (Vec3A, Vec3A),
    /// Whether the processor has AVX2, for the traversal to use its AVX2 build.
    avx2: bool,
    pub stats: BuildStats,
}

/// One primitive before reordering: a reference into the world's baked shapes (12 bytes, so
/// that a million-triangle mesh is not copied before the BVH is built).
#[derive(Clone, Copy)]
struct Prim {
    /// Index into the build's list of shaped entities.
    shape: u32,
    /// Triangle index within the shape (0 for a sphere).
    index: u32,
    light: u32,
}

/// An entity with geometry: its shape and material, in entity order.
type Shaped<'w> = (Entity, &'w WorldShape, &'w MaterialRef);

impl Prim {
    fn aabb(self, shaped: &[Shaped]) -> Aabb {
        match shaped[self.shape as usize].1 {
            WorldShape::Triangles { triangles, .. } => {
                Aabb::from_points(&triangles[self.index as usize])
            }
            WorldShape::Sphere { center, radius } => Aabb::new(
                *center - Vec3A::splat(*radius),
                *center + Vec3A::splat(*radius),
            ),
        }
    }
}

impl RenderScene {
    /// [`RenderScene::build`] on `threads` worker threads (every core when `None`), so that
    /// `--threads` bounds the build as it bounds the render that follows.
    pub fn build_on_threads(
        scene: &LoadedScene,
        threads: Option<usize>,
    ) -> anyhow::Result<RenderScene> {
        Ok(match threads {
            None => Self::build(scene),
            Some(n) => rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| anyhow::anyhow!("cannot start {n} worker threads: {e}"))?
                .install(|| Self::build(scene)),
        })
    }

    /// Builds the render scene from a loaded world. The world must have been validated and
    /// baked (as [`crate::scene::load_scene`] does) and hold at least one shape.
    pub fn build(scene: &LoadedScene) -> RenderScene {
        let start = Instant::now();
        let world = &scene.world;

        // Lights: one table entry per emitting primitive (or quad), in entity order.
        let emitters = systems::collect_emitters(world);
        let mut lights: Vec<Light> = Vec::new();
        // Entity -> (first light, count).
        let mut light_of: std::collections::HashMap<Entity, (u32, usize)> =
            std::collections::HashMap::new();
        for (entity, ls) in &emitters {
            light_of.insert(*entity, (lights.len() as u32, ls.len()));
            lights.extend(ls.iter().cloned());
        }

        // Primitives in entity order.
        let mut query = world.query::<(Entity, &WorldShape, &MaterialRef)>();
        let mut shaped: Vec<Shaped> = query.iter().collect();
        shaped.sort_by_key(|(e, ..)| e.id());
        let count = |shape: &WorldShape| match shape {
            WorldShape::Triangles { triangles, .. } => triangles.len(),
            WorldShape::Sphere { .. } => 1,
        };
        let mut prims: Vec<Prim> =
            Vec::with_capacity(shaped.iter().map(|(_, s, _)| count(s)).sum());
        for (k, (entity, shape, _)) in shaped.iter().enumerate() {
            let light = light_of.get(entity);
            prims.extend((0..count(shape)).map(|i| Prim {
                shape: k as u32,
                index: i as u32,
                // One light for the whole entity (a sphere, a quad), or one per triangle.
                light: match light {
                    Some(&(first, 1)) => first,
                    Some(&(first, _)) => first + i as u32,
                    None => NONE,
                },
            }));
        }

        let instances = InstanceSet::build(scene);
        // BVH over every primitive's box, for leaves that test a packet at a time; then one or
        // two packets per leaf, the leaves numbered in the BVH's primitive order.
        let (mut bvh, order) = Bvh::build::<bvh::Packets>(prims.len(), |i| prims[i].aabb(&shaped));
        let leaves = bvh.number_leaves(packet::packets_for);
        let bounds = match bvh.bounds() {
            Some(b) => instances.bounds.union(&b),
            None => instances.bounds,
        };
        // A scene without geometry: a point at the origin.
        let bounds = if bounds.valid() {
            bounds
        } else {
            Aabb::default()
        };
        let radius = 0.5 * bounds.diagonal().length();
        if let Some(env) = scene.environment {
            lights.push(Light::Environment { radiance: env });
        }
        let lights = LightTable::new(lights, radius);

        // Each position of the BVH's order: its index among the smooth triangles or among the
        // spheres (a running count, cheap), for the lanes to refer to.
        let mut aux = Vec::with_capacity(order.len());
        let (mut smooth, mut sph_center, mut sph_radius) = (0u32, Vec::new(), Vec::new());
        for &original in &order {
            let p = prims[original as usize];
            aux.push(match shaped[p.shape as usize].1 {
                WorldShape::Triangles {
                    normals: Some(_), ..
                } => {
                    smooth += 1;
                    smooth - 1
                }
                WorldShape::Triangles { normals: None, .. } => NONE,
                WorldShape::Sphere { center, radius } => {
                    sph_center.push(*center);
                    sph_radius.push(*radius);
                    sph_center.len() as u32 - 1
                }
            });
        }
        // Then, in parallel and in order, the smooth normals and the packets.
        let smooth_normals: Vec<[Vec3A; 3]> = order
            .par_iter()
            .filter_map(|&original| {
                let p = prims[original as usize];
                match shaped[p.shape as usize].1 {
                    WorldShape::Triangles {
                        normals: Some(n), ..
                    } => Some(n[p.index as usize]),
                    _ => None,
                }
            })
            .collect();
        let lane = |k: u32| {
            let p = prims[order[k as usize] as usize];
            let (_, shape, material) = shaped[p.shape as usize];
            match shape {
                WorldShape::Triangles { triangles, .. } => Lane::Triangle {
                    corners: triangles[p.index as usize],
                    material: material.0,
                    light: p.light,
                    smooth: aux[k as usize],
                },
                WorldShape::Sphere { .. } => Lane::Sphere {
                    index: aux[k as usize],
                    material: material.0,
                    light: p.light,
                },
            }
        };
        let runs: Vec<(u32, u32)> = leaves
            .iter()
            .flat_map(|&(first, count)| packet::runs(first, count))
            .collect();
        let packets: Vec<Stored> = runs
            .par_iter()
            .map(|&(first, count)| {
                let lanes: ArrayVec<Lane, { packet::WIDTH }> =
                    (first..first + count).map(lane).collect();
                let (packet, data) = Packet::new(&lanes);
                Stored { packet, data }
            })
            .collect();
        let mut out = RenderScene {
            packets,
            smooth_normals,
            sph_center,
            sph_radius,
            materials: scene.materials.clone(),
            bounds: (bounds.min, bounds.max),
            avx2: has_avx2(),
            stats: BuildStats {
                entities: world.len() as usize,
                lights: lights.len(),
                emitters: emitters.len() + usize::from(scene.environment.is_some()),
                bvh_nodes: bvh.node_count() + instances.bvh_nodes(),
                bvh_leaves: leaves.len(),
                instances: instances.len(),
                instanced_triangles: instances.unique_triangles(),
                placed_triangles: instances.placed_triangles(),
                ..Default::default()
            },
            instances,
            lights,
            bvh,
        };
        out.stats.triangles = prims.len() - out.sph_center.len();
        out.stats.spheres = out.sph_center.len();
        out.stats.build_time = start.elapsed();
        out
    }

    /// Bytes held by the geometry, its per-primitive data and the BVHs (not the materials or
    /// lights): what a benchmark reports per triangle. Each instanced mesh counts once.
    pub fn memory_bytes(&self) -> usize {
        use std::mem::size_of;
        let v = |n: usize, each: usize| n * each;
        self.instances.memory_bytes()
            + v(self.packets.capacity(), size_of::<Stored>())
            + v(self.smooth_normals.capacity(), size_of::<[Vec3A; 3]>())
            + v(self.sph_center.capacity(), size_of::<Vec3A>())
            + v(self.sph_radius.capacity(), 4)
            + self.bvh.memory_bytes()
    }

    fn sphere_geometry(&self) -> Spheres<'_> {
        Spheres {
            center: &self.sph_center,
            radius: &self.sph_radius,
        }
    }

    fn to_bvh_ray(ray: &Ray) -> Option<obvhs::ray::Ray> {
        (ray.origin.is_finite() && ray.dir.is_finite() && !ray.tmax.is_nan())
            .then(|| bvh::ray(ray.origin, ray.dir, 0.0, ray.tmax))
    }

    /// The surface record for lane `id % WIDTH` of packet `id / WIDTH`, hit at distance `t`.
    fn hit_record(&self, ray: &Ray, id: u32, t: f32) -> Hit {
        let (p, lane) = (id as usize / packet::WIDTH, id as usize % packet::WIDTH);
        let (s, data) = (&self.packets[p].packet, &self.packets[p].data);
        if let Some(i) = s.sphere_index(lane, data) {
            let (c, r) = (self.sph_center[i], self.sph_radius[i]);
            let n = (ray.at(t) - c).normalize();
            Hit {
                t,
                // Re-project onto the surface: the ray's point carries the rounding of t.
                p: c + n * r,
                ng: n,
                ns: n,
                material: data.material(lane),
                light: data.light(lane),
            }
        } else {
            let ng = s.normal(lane);
            let ns = match data.smooth(lane) {
                None => ng,
                Some(k) => {
                    let (v0, a, b) = s.edges(lane);
                    let b = barycentrics(v0, a, b, ray.at(t));
                    let n = self.smooth_normals[k];
                    let s = (n[0] * b.x + n[1] * b.y + n[2] * b.z).normalize_or_zero();
                    if s == Vec3A::ZERO {
                        ng
                    } else if s.dot(ng) < 0.0 {
                        -s
                    } else {
                        s
                    }
                }
            };
            Hit {
                t,
                p: ray.at(t),
                ng,
                ns,
                material: data.material(lane),
                light: data.light(lane),
            }
        }
    }
}

/// Barycentric weights of `p` (on the triangle's plane) for v0, v1, v2, from the triangle's
/// `v0` and edges `e1 = v1 - v0`, `e2 = v2 - v0`.
fn barycentrics(v0: Vec3A, e1: Vec3A, e2: Vec3A, p: Vec3A) -> Vec3A {
    let d = p - v0;
    let n = e1.cross(e2);
    let inv = 1.0 / n.length_squared();
    let b1 = d.cross(e2).dot(n) * inv;
    let b2 = e1.cross(d).dot(n) * inv;
    Vec3A::new(1.0 - b1 - b2, b1, b2)
}

/// Whether the traversal may run its AVX2 build (x86-64 processors since 2013); elsewhere the
/// same code runs as compiled for the target (SSE2 on any x86-64, NEON on ARM).
fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The traversal built for AVX2: the same functions, inlined into these two and compiled
/// with AVX2 enabled, with the BVH's eight-lane box tests as single AVX operations
/// ([`bvh::isa`]). Both compute exactly what the portable build does.
#[cfg(target_arch = "x86_64")]
impl RenderScene {
    #[target_feature(enable = "avx2")]
    fn closest_hit_avx2(&self, ray: &Ray) -> Option<Hit> {
        self.closest_hit::<isa::Avx2>(ray)
    }

    #[target_feature(enable = "avx2")]
    fn any_hit_avx2(&self, ray: &Ray) -> bool {
        self.any_hit::<isa::Avx2>(ray)
    }
}

impl RenderScene {
    #[inline(always)]
    fn closest_hit<I: Isa + LeafTest>(&self, ray: &Ray) -> Option<Hit> {
        let bvh_ray = Self::to_bvh_ray(ray)?;
        let (lanes, spheres) = (PacketRay::new(&bvh_ray), self.sphere_geometry());
        let flat = self.bvh.closest::<I>(
            &bvh_ray,
            #[inline(always)]
            |r, first, count| {
                let leaf =
                    &self.packets[first as usize..(first + packet::packets_for(count)) as usize];
                let (k, t) = I::closest(leaf, &lanes, r, r.tmax, &spheres)?;
                Some((first * packet::WIDTH as u32 + k as u32, t))
            },
        );
        if !self.instances.is_empty() {
            // Instances only count nearer than the flat geometry's hit.
            let mut r = bvh_ray;
            if let Some((_, t)) = flat {
                r.tmax = t;
            }
            if let Some((slot, prim, t)) = self.instances.intersect::<I>(&r) {
                return Some(
                    self.instances
                        .hit_record(ray.origin, ray.dir, slot, prim, t),
                );
            }
        }
        flat.map(|(id, t)| self.hit_record(ray, id, t))
    }

    #[inline(always)]
    fn any_hit<I: Isa + LeafTest>(&self, ray: &Ray) -> bool {
        match Self::to_bvh_ray(ray) {
            Some(r) => {
                let (lanes, spheres) = (PacketRay::new(&r), self.sphere_geometry());
                self.bvh.any::<I>(
                    &r,
                    #[inline(always)]
                    |r, first, count| {
                        let end = first + packet::packets_for(count);
                        I::any(
                            &self.packets[first as usize..end as usize],
                            &lanes,
                            r,
                            &spheres,
                        )
                    },
                ) || (!self.instances.is_empty() && self.instances.occluded::<I>(&r))
            }
            None => false,
        }
    }
}

impl Scene for RenderScene {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the processor has AVX2 (`RenderScene::build`).
            return unsafe { self.closest_hit_avx2(ray) };
        }
        self.closest_hit::<isa::Portable>(ray)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: as in `intersect`.
            return unsafe { self.any_hit_avx2(ray) };
        }
        self.any_hit::<isa::Portable>(ray)
    }

    fn material(&self, id: u32) -> &Material {
        &self.materials[id as usize]
    }

    fn lights(&self) -> &LightTable {
        &self.lights
    }

    fn bounds(&self) -> (Vec3A, Vec3A) {
        self.bounds
    }
}

/// The flat (not instanced) triangles of a loaded scene, exactly as the build places them,
/// in entity order: the geometry `raylab bench` dumps and gives Embree.
pub fn flat_triangles(scene: &LoadedScene) -> Vec<Triangle> {
    let mut shapes: Vec<(Entity, &WorldShape)> = Vec::new();
    let mut query = scene.world.query::<(Entity, &WorldShape)>();
    shapes.extend(query.iter());
    shapes.sort_by_key(|(e, _)| e.id());
    shapes
        .iter()
        .flat_map(|(_, shape)| match shape {
            WorldShape::Triangles { triangles, .. } => triangles.as_slice(),
            WorldShape::Sphere { .. } => &[],
        })
        .map(|&[v0, v1, v2]| Triangle { v0, v1, v2 })
        .collect()
}

/// The spheres of a loaded scene as (centre, radius), in entity order.
pub fn flat_spheres(scene: &LoadedScene) -> Vec<(Vec3A, f32)> {
    let mut spheres: Vec<(u32, Vec3A, f32)> = scene
        .world
        .query::<(Entity, &WorldShape)>()
        .iter()
        .filter_map(|(e, shape)| match shape {
            WorldShape::Sphere { center, radius } => Some((e.id(), *center, *radius)),
            WorldShape::Triangles { .. } => None,
        })
        .collect();
    spheres.sort_by_key(|s| s.0);
    spheres.into_iter().map(|(_, c, r)| (c, r)).collect()
}

/// Names of the entities that emit, for reports.
pub fn emitter_names(scene: &LoadedScene) -> Vec<String> {
    let mut q = scene
        .world
        .query::<(Entity, &Name, &crate::scene::components::Emitter)>();
    let mut v: Vec<_> = q.iter().map(|(e, n, _)| (e.id(), n.0.clone())).collect();
    v.sort();
    v.into_iter().map(|(_, n)| n).collect()
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod instance_tests;
