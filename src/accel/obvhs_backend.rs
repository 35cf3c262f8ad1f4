//! The obvhs backend (`--accel obvhs`): the same geometry and hit records as [`super::WideBvh`],
//! traversed with the obvhs crate's compressed-wide BVH (CWBVH, Ylitie et al. 2017) built by
//! PLOC (`BvhBuildParams::medium_build`), one primitive test at a time.
//!
//! Triangles are tested with raylab's Möller–Trumbore ([`super::primitives`]), which counts a
//! barycentric of -0.0 as inside (obvhs's own test lets rays on a shared edge through), and
//! spheres, disks, cylinders and curves' pieces analytically; rays carry their exact inverse direction ([`super::bvh::ray`]).
//! Instances get a CWBVH per mesh asset and one over the instances' world boxes; a ray that
//! reaches an instance is moved into its space without renormalising its direction, as in
//! [`super::instances`], so that local and world distances agree.

use super::curves::{CurvePiece, CurveSegment};
use super::primitives::{intersect_sphere, intersect_triangle, occludes_triangle, Quadric};
use super::sdf_set::SdfSet;
use super::surface::{barycentrics, parametrisation, shading_normal, VertexData};
use super::{box_corners, bvh, AccelStats, Geometry, Input, ShapeLights};
use glam::{Affine3A, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::{builder::build_cwbvh, CwBvh};
use obvhs::ray::{Ray as BvhRay, RayHit};
use obvhs::BvhBuildParams;
use raylab_integrators::{Hit, Pending, Ray};
use std::time::Duration;

/// No light, as the lane data spells it.
const NONE: u32 = u32::MAX;

/// One primitive of the flat geometry, in the CWBVH's primitive order.
#[derive(Clone, Copy, Debug)]
enum Prim {
    Triangle {
        corners: [Vec3A; 3],
        /// Index into the vertex data, or [`NONE`].
        vertex_data: u32,
        material: u32,
        light: u32,
    },
    Sphere {
        center: Vec3A,
        radius: f32,
        frame: glam::Mat3A,
        material: u32,
        light: u32,
    },
    /// A disk or cylinder, by its index in [`ObvhsBvh::quadrics`].
    Quadric {
        index: u32,
        material: u32,
        light: u32,
    },
    /// A curve's piece, by its index in [`ObvhsBvh::curve_pieces`].
    Curve {
        index: u32,
        material: u32,
        light: u32,
    },
}

/// A mesh asset's triangles in the order of its CWBVH, with their vertex data if any.
struct MeshBvh {
    bvh: CwBvh,
    triangles: Vec<[Vec3A; 3]>,
    vertex_data: Vec<VertexData>,
    /// The mesh attribute at each triangle's corners (BVH order), or empty.
    attributes: Vec<[Vec3A; 3]>,
}

struct Instance {
    world_to_local: Affine3A,
    mesh: u32,
    material: u32,
}

/// The scene in obvhs's BVHs.
pub struct ObvhsBvh {
    flat: Option<CwBvh>,
    prims: Vec<Prim>,
    vertex_data: Vec<VertexData>,
    /// Beside `vertex_data`, the mesh attributes at the corners; empty when no mesh has any.
    attributes: Vec<[Vec3A; 3]>,
    quadrics: Vec<Quadric>,
    curve_segments: Vec<CurveSegment>,
    curve_pieces: Vec<CurvePiece>,
    tlas: Option<CwBvh>,
    /// In the TLAS's primitive order.
    instances: Vec<Instance>,
    meshes: Vec<MeshBvh>,
    /// The SDF grids' voxels (raylab's own BVH over them, searched last).
    sdf: SdfSet,
    bounds: Option<(Vec3A, Vec3A)>,
    pub stats: AccelStats,
}

/// A CWBVH over `boxes`, or `None` when there are none; its primitive indices say which box
/// each slot holds.
fn cwbvh(boxes: &[Aabb]) -> Option<CwBvh> {
    let mut build_time = Duration::ZERO;
    (!boxes.is_empty()).then(|| build_cwbvh(boxes, BvhBuildParams::medium_build(), &mut build_time))
}

fn node_count(bvh: &Option<CwBvh>) -> usize {
    bvh.as_ref().map_or(0, |b| b.nodes.len())
}

impl ObvhsBvh {
    /// How many mesh assets have a BVH of their own.
    pub fn mesh_count(&self) -> usize {
        self.meshes.len()
    }

    /// Builds the BVHs over `input`.
    pub fn build(input: &Input) -> ObvhsBvh {
        // The flat primitives in input order, and their boxes.
        let mut prims = Vec::new();
        let mut vertex_data = Vec::new();
        let mut attributes = Vec::new();
        let any_attributes = input
            .shapes
            .iter()
            .any(|s| matches!(s.geometry, Geometry::Triangles(m) if m.attributes.is_some()));
        let mut quadrics = Vec::new();
        let mut curve_segments: Vec<CurveSegment> = Vec::new();
        let mut curve_pieces = Vec::new();
        for shape in &input.shapes {
            let light = |i: usize| match shape.lights {
                ShapeLights::None => NONE,
                ShapeLights::Whole(first) => first,
                ShapeLights::PerTriangle(first) => first + i as u32,
            };
            match shape.geometry {
                Geometry::Triangles(mesh) => {
                    for (i, corners) in mesh.triangles.iter().enumerate() {
                        let index = match mesh.vertex_data(i) {
                            Some(d) => {
                                vertex_data.push(d);
                                if any_attributes {
                                    attributes.push(mesh.attribute(i));
                                }
                                vertex_data.len() as u32 - 1
                            }
                            None => NONE,
                        };
                        prims.push(Prim::Triangle {
                            corners: *corners,
                            vertex_data: index,
                            material: shape.material,
                            light: light(i),
                        });
                    }
                }
                Geometry::Sphere {
                    center,
                    radius,
                    frame,
                } => prims.push(Prim::Sphere {
                    center,
                    radius,
                    frame,
                    material: shape.material,
                    light: light(0),
                }),
                Geometry::Quadric(q) => {
                    quadrics.push(q);
                    prims.push(Prim::Quadric {
                        index: quadrics.len() as u32 - 1,
                        material: shape.material,
                        light: light(0),
                    });
                }
                Geometry::Curves(c) => {
                    let first = curve_segments.len() as u32;
                    curve_segments.extend_from_slice(c.segments);
                    for i in 0..c.pieces() {
                        let (s, u0, u1) = c.piece(i);
                        curve_pieces.push(CurvePiece {
                            segment: first + s as u32,
                            u0,
                            u1,
                        });
                        prims.push(Prim::Curve {
                            index: curve_pieces.len() as u32 - 1,
                            material: shape.material,
                            light: light(0),
                        });
                    }
                }
            }
        }
        let boxes: Vec<Aabb> = prims
            .iter()
            .map(|p| match *p {
                Prim::Triangle { corners, .. } => Aabb::from_points(&corners),
                Prim::Sphere { center, radius, .. } => {
                    Aabb::new(center - Vec3A::splat(radius), center + Vec3A::splat(radius))
                }
                Prim::Quadric { index, .. } => {
                    let (min, max) = quadrics[index as usize].bounds();
                    Aabb::new(min, max)
                }
                Prim::Curve { index, .. } => curve_pieces[index as usize].bounds(&curve_segments),
            })
            .collect();
        let flat = cwbvh(&boxes);
        // Reordered once, so that the traversal's index is the primitive's.
        if let Some(b) = &flat {
            prims = b
                .primitive_indices
                .iter()
                .map(|&i| prims[i as usize])
                .collect();
        }

        // Instances: a CWBVH per mesh asset (only when something places one), one over the
        // instances' world boxes.
        let mut meshes = Vec::new();
        let mut instance_boxes = Vec::new();
        if !input.instances.is_empty() {
            for mesh in &input.meshes {
                let boxes: Vec<Aabb> = mesh
                    .triangles
                    .iter()
                    .map(|t| Aabb::from_points(t))
                    .collect();
                let bvh = cwbvh(&boxes).unwrap_or_default();
                let order = &bvh.primitive_indices;
                meshes.push(MeshBvh {
                    triangles: order.iter().map(|&i| mesh.triangles[i as usize]).collect(),
                    vertex_data: order
                        .iter()
                        .filter_map(|&i| mesh.vertex_data(i as usize))
                        .collect(),
                    attributes: match mesh.attributes {
                        Some(a) => order.iter().map(|&i| a[i as usize]).collect(),
                        None => Vec::new(),
                    },
                    bvh,
                });
            }
            instance_boxes = input
                .instances
                .iter()
                .map(|inst| {
                    let corners = box_corners(input.meshes[inst.mesh as usize].bounds)
                        .map(|p| inst.local_to_world.transform_point3a(p));
                    Aabb::from_points(&corners)
                })
                .collect();
        }
        let tlas = cwbvh(&instance_boxes);
        let instances: Vec<Instance> = tlas.as_ref().map_or_else(Vec::new, |t| {
            t.primitive_indices
                .iter()
                .map(|&i| {
                    let inst = &input.instances[i as usize];
                    Instance {
                        world_to_local: inst.local_to_world.inverse(),
                        mesh: inst.mesh,
                        material: inst.material,
                    }
                })
                .collect()
        });

        let sdf = SdfSet::build(&input.sdf_grids);
        let mut bounds = Aabb::empty();
        for b in boxes
            .iter()
            .chain(&instance_boxes)
            .chain(sdf.bounds().as_ref())
        {
            bounds = bounds.union(b);
        }
        let spheres = prims
            .iter()
            .filter(|p| matches!(p, Prim::Sphere { .. }))
            .count();
        let mesh_triangles = |m: u32| meshes[m as usize].triangles.len();
        let stats = AccelStats {
            triangles: prims.len() - spheres - quadrics.len() - curve_pieces.len(),
            spheres,
            quadrics: quadrics.len(),
            curve_pieces: curve_pieces.len(),
            bvh_nodes: node_count(&flat)
                + node_count(&tlas)
                + meshes.iter().map(|m| m.bvh.nodes.len()).sum::<usize>(),
            bvh_leaves: flat.as_ref().map_or(0, |b| {
                b.nodes
                    .iter()
                    .map(|n| (0..8).filter(|&c| n.is_leaf(c)).count())
                    .sum()
            }),
            instances: instances.len(),
            instanced_triangles: meshes.iter().map(|m| m.triangles.len()).sum(),
            placed_triangles: instances.iter().map(|i| mesh_triangles(i.mesh)).sum(),
        };
        ObvhsBvh {
            flat,
            prims,
            vertex_data,
            attributes,
            quadrics,
            curve_segments,
            curve_pieces,
            tlas,
            instances,
            meshes,
            sdf,
            bounds: bounds.valid().then_some((bounds.min, bounds.max)),
            stats,
        }
    }

    /// Bounds (min, max) of all geometry, or `None` when there is none.
    pub fn bounds(&self) -> Option<(Vec3A, Vec3A)> {
        self.bounds
    }

    /// Bytes held by the primitives and the BVHs.
    pub fn memory_bytes(&self) -> usize {
        use std::mem::size_of;
        let bvh = |b: &CwBvh| {
            b.nodes.capacity() * size_of::<obvhs::cwbvh::node::CwBvhNode>()
                + b.primitive_indices.capacity() * 4
        };
        self.flat.as_ref().map_or(0, bvh)
            + self.tlas.as_ref().map_or(0, bvh)
            + self.prims.capacity() * size_of::<Prim>()
            + self.vertex_data.capacity() * size_of::<VertexData>()
            + self.attributes.capacity() * size_of::<[Vec3A; 3]>()
            + self.quadrics.capacity() * size_of::<Quadric>()
            + self.curve_segments.capacity() * size_of::<CurveSegment>()
            + self.curve_pieces.capacity() * size_of::<CurvePiece>()
            + self.instances.capacity() * size_of::<Instance>()
            + self.sdf.memory_bytes()
            + self
                .meshes
                .iter()
                .map(|m| {
                    bvh(&m.bvh)
                        + m.triangles.capacity() * size_of::<[Vec3A; 3]>()
                        + m.vertex_data.capacity() * size_of::<VertexData>()
                        + m.attributes.capacity() * size_of::<[Vec3A; 3]>()
                })
                .sum::<usize>()
    }

    fn bvh_ray(ray: &Ray) -> Option<BvhRay> {
        (ray.origin.is_finite() && ray.dir.is_finite() && !ray.tmax.is_nan())
            .then(|| bvh::ray(ray.origin, ray.dir, 0.0, ray.tmax))
    }

    /// The ray in instance `inst`'s space, with the same `t` range.
    fn local_ray(inst: &Instance, ray: &BvhRay) -> BvhRay {
        let m = &inst.world_to_local;
        bvh::ray(
            m.transform_point3a(ray.origin),
            m.transform_vector3a(ray.direction),
            ray.tmin,
            ray.tmax,
        )
    }

    /// The closest surface hit by `ray` with `t < ray.tmax`.
    pub fn closest(&self, ray: &Ray) -> Option<Hit> {
        let mut r = Self::bvh_ray(ray)?;
        // The flat geometry first, then instances nearer than its hit.
        let mut flat_hit = RayHit::none();
        let flat = self.flat.as_ref().is_some_and(|b| {
            b.ray_traverse(r, &mut flat_hit, |r, i| match self.prims[i] {
                Prim::Triangle { corners, .. } => intersect_triangle(&corners, r),
                Prim::Sphere { center, radius, .. } => intersect_sphere(center, radius, r),
                Prim::Quadric { index, .. } => self.quadrics[index as usize].intersect(r),
                Prim::Curve { index, .. } => {
                    self.curve_pieces[index as usize].intersect(&self.curve_segments, r, false)
                }
            })
        });
        if flat {
            r.tmax = flat_hit.t;
        }
        let mut instanced = None;
        if let Some(tlas) = &self.tlas {
            let mut found = None;
            let mut tlas_hit = RayHit::none();
            tlas.ray_traverse(r, &mut tlas_hit, |r, slot| {
                let inst = &self.instances[slot];
                let mesh = &self.meshes[inst.mesh as usize];
                let mut hit = RayHit::none();
                let lr = Self::local_ray(inst, r);
                if mesh.bvh.ray_traverse(lr, &mut hit, |lr, k| {
                    intersect_triangle(&mesh.triangles[k], lr)
                }) {
                    found = Some((slot, hit.primitive_id as usize, hit.t));
                    hit.t
                } else {
                    f32::INFINITY
                }
            });
            // Each instance hit the closure reports is nearer than the last: the last is it.
            if let Some((_, _, t)) = found {
                r.tmax = t;
            }
            instanced = found;
        }
        // Then the SDF grids, nearer than both.
        if !self.sdf.is_empty() {
            if let Some((k, t)) = self.sdf.closest(super::bvh::isa::Portable, &r) {
                return Some(self.sdf.hit_record(ray.origin, ray.dir, k, t));
            }
        }
        if let Some((slot, k, t)) = instanced {
            return Some(self.instance_hit(ray, slot, k, t));
        }
        flat.then(|| self.flat_hit(ray, flat_hit.primitive_id as usize, flat_hit.t))
    }

    /// True if any surface lies on `ray` with `t < ray.tmax`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        let Some(r) = Self::bvh_ray(ray) else {
            return false;
        };
        let hit_flat = self.flat.as_ref().is_some_and(|b| {
            !b.ray_traverse_miss(r, |r, i| match self.prims[i] {
                Prim::Triangle { corners, .. } => occludes_triangle(&corners, r),
                Prim::Sphere { center, radius, .. } => intersect_sphere(center, radius, r),
                Prim::Quadric { index, .. } => self.quadrics[index as usize].intersect(r),
                Prim::Curve { index, .. } => {
                    self.curve_pieces[index as usize].intersect(&self.curve_segments, r, true)
                }
            })
        });
        hit_flat
            || self.tlas.as_ref().is_some_and(|tlas| {
                !tlas.ray_traverse_miss(r, |r, slot| {
                    let inst = &self.instances[slot];
                    let mesh = &self.meshes[inst.mesh as usize];
                    let lr = Self::local_ray(inst, r);
                    if mesh
                        .bvh
                        .ray_traverse_miss(lr, |lr, k| occludes_triangle(&mesh.triangles[k], lr))
                    {
                        f32::INFINITY
                    } else {
                        r.tmin
                    }
                })
            })
            || (!self.sdf.is_empty() && self.sdf.any(super::bvh::isa::Portable, &r))
    }

    /// The surface record of flat primitive `k` hit at distance `t`, as [`super::WideBvh`]
    /// makes it.
    fn flat_hit(&self, ray: &Ray, k: usize, t: f32) -> Hit {
        let light = |l: u32| (l != NONE).then_some(l);
        match self.prims[k] {
            Prim::Sphere {
                center,
                radius,
                frame,
                material,
                light: l,
            } => Hit::on_oriented_sphere(ray, t, center, radius, frame, material, light(l)),
            Prim::Quadric {
                index,
                material,
                light: l,
            } => self.quadrics[index as usize].hit(ray.origin, ray.dir, t, material, light(l)),
            Prim::Curve {
                index,
                material,
                light: l,
            } => self.curve_pieces[index as usize].hit(
                &self.curve_segments,
                ray,
                t,
                material,
                light(l),
            ),
            Prim::Triangle {
                corners: [v0, v1, v2],
                vertex_data,
                material,
                light: l,
            } => {
                let (e1, e2) = (v1 - v0, v2 - v0);
                let ng = e1.cross(e2).normalize_or_zero();
                let p = ray.at(t);
                let ns = match self.vertex_data.get(vertex_data as usize) {
                    Some(d) if d.has_normals => {
                        shading_normal(ng, barycentrics(v0, e1, e2, p), d, |n| n)
                    }
                    _ => ng,
                };
                Hit {
                    pending: Pending::Triangle {
                        prim: k as u32,
                        instance: NONE,
                    },
                    ns,
                    ..Hit::new(t, p, ng, material, light(l))
                }
            }
        }
    }

    /// The surface record of triangle `k` of the instance in TLAS slot `slot`, as
    /// [`super::instances`] makes it.
    fn instance_hit(&self, ray: &Ray, slot: usize, k: usize, t: f32) -> Hit {
        let inst = &self.instances[slot];
        let mesh = &self.meshes[inst.mesh as usize];
        let [v0, v1, v2] = mesh.triangles[k];
        let (e1, e2) = (v1 - v0, v2 - v0);
        let normal_matrix = inst.world_to_local.matrix3.transpose();
        let ng = (normal_matrix * e1.cross(e2).normalize_or_zero()).normalize_or_zero();
        let ns = match mesh.vertex_data.get(k) {
            Some(d) if d.has_normals => {
                let w = &inst.world_to_local;
                let local_p = w.transform_point3a(ray.origin) + w.transform_vector3a(ray.dir) * t;
                let b = barycentrics(v0, e1, e2, local_p);
                shading_normal(ng, b, d, |n| (normal_matrix * n).normalize_or_zero())
            }
            _ => ng,
        };
        Hit {
            pending: Pending::Triangle {
                prim: k as u32,
                instance: slot as u32,
            },
            ns,
            ..Hit::new(t, ray.origin + ray.dir * t, ng, inst.material, None)
        }
    }

    /// Computes a hit's pending texture coordinates and tangents, as [`super::WideBvh`] does.
    pub fn parametrise(&self, hit: &mut Hit) {
        let Pending::Triangle { prim, instance } = hit.pending else {
            hit.parametrise_sphere();
            return;
        };
        let param = if instance == NONE {
            let Prim::Triangle {
                corners: [v0, v1, v2],
                vertex_data,
                ..
            } = self.prims[prim as usize]
            else {
                return;
            };
            let (e1, e2) = (v1 - v0, v2 - v0);
            let b = barycentrics(v0, e1, e2, hit.p);
            let k = vertex_data as usize;
            parametrisation(b, e1, e2, self.vertex_data.get(k), self.attributes.get(k))
        } else {
            let inst = &self.instances[instance as usize];
            let mesh = &self.meshes[inst.mesh as usize];
            let [v0, v1, v2] = mesh.triangles[prim as usize];
            let (e1, e2) = (v1 - v0, v2 - v0);
            let b = barycentrics(v0, e1, e2, inst.world_to_local.transform_point3a(hit.p));
            let k = prim as usize;
            parametrisation(b, e1, e2, mesh.vertex_data.get(k), mesh.attributes.get(k))
                .mapped(inst.world_to_local.matrix3.inverse())
        };
        param.write_to(hit);
    }
}
