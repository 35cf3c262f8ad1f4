//! The build step: flattens the ECS world into primitives, builds the BVH over triangles and
//! spheres together, lays the primitives out in the BVH's order as [`slot::Slot`]s (spheres'
//! centres, radii and ids in arrays of their own), and collects emitters into the light table. Instances of mesh assets are not flattened:
//! they get a two-level BVH of their own ([`instances`]), traced after the flat BVH with the
//! ray shortened to its hit, and only when the scene has any. The result implements the
//! integrators' [`Scene`] trait and is immutable and `Sync`.

mod bvh4;
mod instances;
mod primitives;
mod slot;

use crate::scene::components::{MaterialRef, Name, WorldShape};
use crate::scene::{systems, LoadedScene};
use bvh4::Bvh4;
use glam::Vec3A;
use hecs::Entity;
use instances::InstanceSet;
use obvhs::aabb::Aabb;
use obvhs::triangle::Triangle;
use primitives::{flat_normal, intersect_sphere, intersect_triangle, occludes_triangle};
use raylab_integrators::{Hit, Light, LightTable, Material, Ray, Scene};
use slot::{Slot, NONE};
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
    /// Instances of mesh assets, the triangles of those assets (each once) and the triangles
    /// the instances place (each asset once per instance).
    pub instances: usize,
    pub instanced_triangles: usize,
    pub placed_triangles: usize,
    pub build_time: Duration,
}

/// The flattened, BVH-backed scene that rendering reads.
pub struct RenderScene {
    bvh: Bvh4,
    /// Per BVH primitive slot: a triangle and its shading data, or a sphere's index.
    slots: Vec<Slot>,
    /// Per-vertex normals of the triangles that have them ([`Slot::smooth`]).
    smooth_normals: Vec<[Vec3A; 3]>,
    // Spheres, likewise in BVH order.
    sph_center: Vec<Vec3A>,
    sph_radius: Vec<f32>,
    sph_material: Vec<u32>,
    sph_light: Vec<u32>,

    /// Instanced meshes (a two-level BVH); empty in most scenes.
    instances: InstanceSet,

    materials: Vec<Material>,
    lights: LightTable,
    bounds: (Vec3A, Vec3A),
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
        // BVH over every primitive's box; then lay the slots out in the BVH's order.
        let (bvh, order) = Bvh4::build(prims.len(), |i| prims[i].aabb(&shaped));
        let bounds = match bvh.bounds() {
            Some(b) => instances.bounds.union(&b),
            None => instances.bounds,
        };
        let radius = 0.5 * bounds.diagonal().length();
        if let Some(env) = scene.environment {
            lights.push(Light::Environment { radiance: env });
        }
        let lights = LightTable::new(lights, radius);

        // The slots (and smooth normals) at their exact size: no growth, nothing to give back
        // (the sphere arrays, a handful of entries, grow as usual).
        let n = prims.len();
        let smooth: usize = shaped
            .iter()
            .filter_map(|(_, s, _)| match s {
                WorldShape::Triangles {
                    normals: Some(n), ..
                } => Some(n.len()),
                _ => None,
            })
            .sum();
        let mut out = RenderScene {
            slots: Vec::with_capacity(n),
            smooth_normals: Vec::with_capacity(smooth),
            sph_center: Vec::new(),
            sph_radius: Vec::new(),
            sph_material: Vec::new(),
            sph_light: Vec::new(),
            materials: scene.materials.clone(),
            bounds: (bounds.min, bounds.max),
            stats: BuildStats {
                entities: world.len() as usize,
                lights: lights.len(),
                emitters: emitters.len() + usize::from(scene.environment.is_some()),
                bvh_nodes: bvh.node_count() + instances.bvh_nodes(),
                instances: instances.len(),
                instanced_triangles: instances.unique_triangles(),
                placed_triangles: instances.placed_triangles(),
                ..Default::default()
            },
            instances,
            lights,
            bvh,
        };
        for &original in &order {
            let p = prims[original as usize];
            let (_, shape, material) = shaped[p.shape as usize];
            match shape {
                WorldShape::Triangles {
                    triangles, normals, ..
                } => {
                    let smooth = match normals {
                        Some(n) => {
                            out.smooth_normals.push(n[p.index as usize]);
                            out.smooth_normals.len() as u32 - 1
                        }
                        None => NONE,
                    };
                    out.slots.push(Slot::triangle(
                        &triangles[p.index as usize],
                        material.0,
                        p.light,
                        smooth,
                    ));
                }
                WorldShape::Sphere { center, radius } => {
                    out.slots.push(Slot::sphere(out.sph_center.len() as u32));
                    out.sph_center.push(*center);
                    out.sph_radius.push(*radius);
                    out.sph_material.push(material.0);
                    out.sph_light.push(p.light);
                }
            }
        }
        out.stats.triangles = out.slots.len() - out.sph_center.len();
        out.stats.spheres = out.sph_center.len();
        out.stats.build_time = start.elapsed();
        out
    }

    /// The triangles, in BVH order (for benchmark dumps).
    pub fn triangles(&self) -> Vec<Triangle> {
        self.slots
            .iter()
            .filter(|s| s.sphere_index().is_none())
            .map(|s| {
                let [v0, v1, v2] = s.corners();
                Triangle { v0, v1, v2 }
            })
            .collect()
    }

    /// The spheres as (centre, radius), in BVH order.
    pub fn spheres(&self) -> Vec<(Vec3A, f32)> {
        self.sph_center
            .iter()
            .copied()
            .zip(self.sph_radius.iter().copied())
            .collect()
    }

    /// Bytes held by the geometry, its per-primitive data and the BVHs (not the materials or
    /// lights): what a benchmark reports per triangle. Each instanced mesh counts once.
    pub fn memory_bytes(&self) -> usize {
        use std::mem::size_of;
        let v = |n: usize, each: usize| n * each;
        self.instances.memory_bytes()
            + v(self.slots.capacity(), size_of::<Slot>())
            + v(self.smooth_normals.capacity(), size_of::<[Vec3A; 3]>())
            + v(self.sph_center.capacity(), size_of::<Vec3A>())
            + v(
                self.sph_radius.capacity()
                    + self.sph_material.capacity()
                    + self.sph_light.capacity(),
                4,
            )
            + self.bvh.memory_bytes()
    }

    /// Distance to primitive slot `slot` along `ray`, or infinity; `OCCLUSION` picks the
    /// triangle test tuned for occlusion queries ([`primitives::occludes_triangle`]).
    #[inline(always)]
    fn intersect_slot<const OCCLUSION: bool>(&self, ray: &obvhs::ray::Ray, slot: usize) -> f32 {
        let s = &self.slots[slot];
        if let Some(i) = s.sphere_index() {
            intersect_sphere(self.sph_center[i], self.sph_radius[i], ray)
        } else if OCCLUSION {
            occludes_triangle(&s.corners(), ray)
        } else {
            intersect_triangle(&s.corners(), ray)
        }
    }

    fn to_bvh_ray(ray: &Ray) -> Option<obvhs::ray::Ray> {
        (ray.origin.is_finite() && ray.dir.is_finite() && !ray.tmax.is_nan())
            .then(|| obvhs::ray::Ray::new(ray.origin, ray.dir, 0.0, ray.tmax))
    }

    /// The surface record for slot `slot` hit at distance `t`.
    fn hit_record(&self, ray: &Ray, slot: usize, t: f32) -> Hit {
        let s = &self.slots[slot];
        if let Some(i) = s.sphere_index() {
            let (c, r) = (self.sph_center[i], self.sph_radius[i]);
            let n = (ray.at(t) - c).normalize();
            Hit {
                t,
                // Re-project onto the surface: the ray's point carries the rounding of t.
                p: c + n * r,
                ng: n,
                ns: n,
                material: self.sph_material[i],
                light: (self.sph_light[i] != NONE).then_some(self.sph_light[i]),
            }
        } else {
            let tri = s.corners();
            // Computed per hit rather than stored: 16 bytes a triangle saved for a cross product.
            let ng = flat_normal(&tri);
            let ns = match s.smooth() {
                None => ng,
                Some(k) => {
                    let b = barycentrics(&tri, ray.at(t));
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
                material: s.material(),
                light: s.light(),
            }
        }
    }
}

/// Barycentric weights of `p` (on the triangle's plane) for v0, v1, v2.
fn barycentrics(t: &[Vec3A; 3], p: Vec3A) -> Vec3A {
    let (e1, e2, d) = (t[1] - t[0], t[2] - t[0], p - t[0]);
    let n = e1.cross(e2);
    let inv = 1.0 / n.length_squared();
    let b1 = d.cross(e2).dot(n) * inv;
    let b2 = e1.cross(d).dot(n) * inv;
    Vec3A::new(1.0 - b1 - b2, b1, b2)
}

impl Scene for RenderScene {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let bvh_ray = Self::to_bvh_ray(ray)?;
        let flat = self
            .bvh
            .closest(&bvh_ray, |r, slot| self.intersect_slot::<false>(r, slot));
        if !self.instances.is_empty() {
            // Instances only count nearer than the flat geometry's hit.
            let mut r = bvh_ray;
            if let Some((_, t)) = flat {
                r.tmax = t;
            }
            if let Some((slot, prim, t)) = self.instances.intersect(&r) {
                return Some(
                    self.instances
                        .hit_record(ray.origin, ray.dir, slot, prim, t),
                );
            }
        }
        flat.map(|(slot, t)| self.hit_record(ray, slot, t))
    }

    fn occluded(&self, ray: &Ray) -> bool {
        match Self::to_bvh_ray(ray) {
            Some(r) => {
                self.bvh.any(&r, |r, slot| {
                    self.intersect_slot::<true>(r, slot).is_finite()
                }) || (!self.instances.is_empty() && self.instances.occluded(&r))
            }
            None => false,
        }
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
