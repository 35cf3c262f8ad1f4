//! Instanced geometry: a two-level BVH. Each mesh asset gets one bottom-level [`Bvh`] over its
//! triangles in its own space (built once, however many instances place it); a top-level
//! one holds the instances' world-space boxes. A ray reaching an instance is moved into the
//! instance's space by the stored world-to-local affine map, *without* renormalising its
//! direction, so that the local hit distance `t` is the world one: `o' + t d' = M^-1 (o + t d)`.
//! Normals go back to world space by the inverse transpose, `(M^-1)^T`.
//!
//! An instance placed by the identity (a large mesh of the flat scene given a BVH of its own,
//! see `crate::scene::flatten`) takes the world ray as it is.
//!
//! Traversal nests two BVH traversals; both keep their stacks on the call stack, so no ray
//! allocates.

use super::bvh::{isa::Isa, Bvh, Packets, Singles};
use super::packet::{self, Lane, LeafTest, Packet, PacketRay, Stored, NONE, NO_ANALYTIC};
use super::surface::{barycentrics, parametrisation, shading_normal, Parametrisation, VertexData};
use super::{box_corners, huge_pages, InstanceDesc, Mesh};
use glam::{Affine3A, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::ray::Ray;
use raylab_integrators::{Hit, Pending};
use rayon::prelude::*;
use std::sync::Arc;

/// One mesh asset's triangles as packets, one or two per leaf of their BVH.
struct MeshBlas {
    /// The mesh's key ([`super::Input::mesh_keys`]).
    key: u64,
    bvh: Bvh,
    /// Each lane's `vertex_data` index is the triangle's place in the BVH's order.
    packets: Vec<Stored>,
    /// Vertex data per triangle (BVH order), or empty when the mesh has none.
    vertex_data: Vec<VertexData>,
    /// The mesh attribute at each triangle's corners (BVH order), or empty.
    attributes: Vec<[Vec3A; 3]>,
    triangles: usize,
}

/// One placement of a mesh asset.
#[derive(Clone, Copy)]
struct Instance {
    world_to_local: Affine3A,
    /// Placed by the identity: rays are not transformed.
    identity: bool,
    mesh: u32,
    material: u32,
}

/// Every instance of the scene, over their shared meshes.
pub struct InstanceSet {
    tlas: Bvh,
    /// In TLAS order: slot `i` of the TLAS is `instances[i]`.
    instances: Vec<Instance>,
    /// Shared with the sets built from this one that kept a mesh.
    meshes: Vec<Arc<MeshBlas>>,
    /// World bounds of all instances (empty when there are none).
    pub bounds: Aabb,
    /// How many of `meshes` were taken from the set this one was built from.
    pub reused: usize,
}

impl Default for InstanceSet {
    fn default() -> Self {
        InstanceSet {
            tlas: Bvh::default(),
            instances: Vec::new(),
            meshes: Vec::new(),
            bounds: Aabb::empty(),
            reused: 0,
        }
    }
}

impl MeshBlas {
    fn build(mesh: &Mesh, key: u64) -> MeshBlas {
        let (mut bvh, order) = Bvh::build::<Packets>(mesh.triangles.len(), |i| {
            Aabb::from_points(&mesh.triangles[i])
        });
        // As the flat BVH's: the runs first, then the packets in parallel, in order and into a
        // vector of exactly their number.
        let runs: Vec<(u32, u32)> = bvh
            .number_leaves(packet::packets_for)
            .iter()
            .flat_map(|&(first, count)| packet::runs(first, count))
            .collect();
        let packets = huge_pages::collect(runs.par_iter().map(|&(first, count)| {
            let lanes: arrayvec::ArrayVec<Lane, { packet::WIDTH }> = (first..first + count)
                .map(|k| Lane::Triangle {
                    corners: mesh.triangles[order[k as usize] as usize],
                    material: 0,
                    light: NONE,
                    vertex_data: k,
                })
                .collect();
            let (packet, data) = Packet::new(&lanes);
            Stored { packet, data }
        }));
        let vertex_data = order
            .par_iter()
            .filter_map(|&i| mesh.vertex_data(i as usize))
            .collect();
        let attributes = match mesh.attributes {
            Some(a) => order.iter().map(|&i| a[i as usize]).collect(),
            None => Vec::new(),
        };
        MeshBlas {
            key,
            bvh,
            packets,
            vertex_data,
            attributes,
            triangles: order.len(),
        }
    }

    fn memory_bytes(&self) -> usize {
        use std::mem::size_of;
        self.bvh.memory_bytes()
            + self.packets.capacity() * size_of::<Stored>()
            + self.vertex_data.capacity() * size_of::<VertexData>()
            + self.attributes.capacity() * size_of::<[Vec3A; 3]>()
    }
}

impl InstanceSet {
    /// Builds the BLAS of every mesh asset (`keys[i]` is mesh `i`'s key), or takes it from
    /// `previous` where that holds a mesh of the same key, and the TLAS over `instances` (in
    /// the given order); nothing when there are no instances.
    pub fn build(
        meshes: &[Mesh],
        keys: &[u64],
        instances: &[InstanceDesc],
        previous: Option<&InstanceSet>,
    ) -> InstanceSet {
        if instances.is_empty() {
            return InstanceSet::default();
        }
        let mut reused = 0;
        let blas: Vec<Arc<MeshBlas>> = meshes
            .iter()
            .enumerate()
            .map(|(i, mesh)| {
                // `u64::MAX` marks a mesh without a key: never taken.
                let key = keys.get(i).copied().filter(|&k| k != u64::MAX);
                let kept = previous
                    .zip(key)
                    .and_then(|(p, key)| p.meshes.iter().find(|m| m.key == key).map(Arc::clone));
                match kept {
                    Some(m) => {
                        reused += 1;
                        m
                    }
                    // A mesh without a key is never taken by a later build.
                    None => Arc::new(MeshBlas::build(mesh, key.unwrap_or(u64::MAX))),
                }
            })
            .collect();
        let boxes: Vec<Aabb> = instances
            .iter()
            .map(|inst| {
                let m = inst.local_to_world;
                let corners =
                    box_corners(meshes[inst.mesh as usize].bounds).map(|p| m.transform_point3a(p));
                Aabb::from_points(&corners)
            })
            .collect();
        let mut bounds = Aabb::empty();
        for b in &boxes {
            bounds = bounds.union(b);
        }
        // One instance per leaf.
        let (tlas, order) = Bvh::build::<Singles>(boxes.len(), |i| boxes[i]);
        let instances = order
            .iter()
            .map(|&i| {
                let inst = &instances[i as usize];
                Instance {
                    world_to_local: inst.local_to_world.inverse(),
                    identity: inst.local_to_world == Affine3A::IDENTITY,
                    mesh: inst.mesh,
                    material: inst.material,
                }
            })
            .collect();
        InstanceSet {
            tlas,
            instances,
            meshes: blas,
            bounds,
            reused,
        }
    }

    /// How many mesh assets have a BVH here.
    pub fn mesh_count(&self) -> usize {
        self.meshes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.instances.is_empty()
    }

    pub fn len(&self) -> usize {
        self.instances.len()
    }

    /// Triangles over all mesh assets, each counted once.
    pub fn unique_triangles(&self) -> usize {
        self.meshes.iter().map(|m| m.triangles).sum()
    }

    /// Triangles as placed in the scene (each mesh counted once per instance).
    pub fn placed_triangles(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes[i.mesh as usize].triangles)
            .sum()
    }

    pub fn bvh_nodes(&self) -> usize {
        self.tlas.node_count()
            + self
                .meshes
                .iter()
                .map(|m| m.bvh.node_count())
                .sum::<usize>()
    }

    /// Bytes held by the meshes (once each), their BVHs, the TLAS and the instances.
    pub fn memory_bytes(&self) -> usize {
        use std::mem::size_of;
        self.meshes.iter().map(|m| m.memory_bytes()).sum::<usize>()
            + self.tlas.memory_bytes()
            + self.instances.capacity() * size_of::<Instance>()
    }

    /// The ray in instance `inst`'s space, with the same `t` range.
    #[inline(always)]
    fn local_ray(inst: &Instance, ray: &Ray) -> Ray {
        if inst.identity {
            return *ray;
        }
        let m = &inst.world_to_local;
        super::bvh::ray(
            m.transform_point3a(ray.origin),
            m.transform_vector3a(ray.direction),
            ray.tmin,
            ray.tmax,
        )
    }

    /// Closest hit with `t < ray.tmax`: (instance slot, hit within its mesh, t), the hit as
    /// the packet's index times [`packet::WIDTH`] plus the lane.
    #[inline(always)]
    pub fn intersect<I: Isa + LeafTest>(&self, isa: I, ray: &Ray) -> Option<(u32, u32, f32)> {
        let mut best_prim = 0u32;
        // The closures are inlined into the AVX2 build's caller: left as functions of their
        // own, they are compiled without AVX2 and every intrinsic in them becomes a call.
        let (slot, t) = self.tlas.closest(
            isa,
            ray,
            #[inline(always)]
            |r, first, count| {
                let mut best = None;
                let mut r = *r;
                for slot in first..first + count {
                    let inst = &self.instances[slot as usize];
                    let mesh = &self.meshes[inst.mesh as usize];
                    // `r.tmax` is the closest hit so far: the local traversal only looks nearer.
                    let lr = Self::local_ray(inst, &r);
                    let lanes = PacketRay::new(&lr);
                    if let Some((id, t)) = mesh.bvh.closest(
                        isa,
                        &lr,
                        #[inline(always)]
                        |lr, first, count| {
                            let end = first + packet::packets_for(count);
                            let leaf = &mesh.packets[first as usize..end as usize];
                            let (k, t) = isa.closest(leaf, &lanes, lr, lr.tmax, &NO_ANALYTIC)?;
                            Some((first * packet::WIDTH as u32 + k as u32, t))
                        },
                    ) {
                        best_prim = id;
                        best = Some((slot, t));
                        r.tmax = t;
                    }
                }
                best
            },
        )?;
        Some((slot, best_prim, t))
    }

    /// True if any instance has a surface on `ray` before `ray.tmax`.
    #[inline(always)]
    pub fn occluded<I: Isa + LeafTest>(&self, isa: I, ray: &Ray) -> bool {
        // Inlined for the reason `intersect` gives.
        self.tlas.any(
            isa,
            ray,
            #[inline(always)]
            |r, first, count| {
                // A loop, not `Iterator::any`: its closure would be compiled inside a
                // function of the standard library's, without AVX2.
                for slot in first..first + count {
                    let inst = &self.instances[slot as usize];
                    let mesh = &self.meshes[inst.mesh as usize];
                    let lr = Self::local_ray(inst, r);
                    let lanes = PacketRay::new(&lr);
                    let blocked = mesh.bvh.any(
                        isa,
                        &lr,
                        #[inline(always)]
                        |lr, first, count| {
                            let end = first + packet::packets_for(count);
                            isa.any(
                                &mesh.packets[first as usize..end as usize],
                                &lanes,
                                lr,
                                &NO_ANALYTIC,
                            )
                        },
                    );
                    if blocked {
                        return true;
                    }
                }
                false
            },
        )
    }

    /// The world-space surface record of hit `prim` (as [`InstanceSet::intersect`] gives it)
    /// of instance `slot`, hit at `t` by the world ray `origin + t dir`.
    pub fn hit_record(&self, origin: Vec3A, dir: Vec3A, slot: u32, prim: u32, t: f32) -> Hit {
        let inst = &self.instances[slot as usize];
        let mesh = &self.meshes[inst.mesh as usize];
        let (p, lane) = (prim as usize / packet::WIDTH, prim as usize % packet::WIDTH);
        let Stored { packet, data } = &mesh.packets[p];
        // Normals transform by the inverse transpose of the local-to-world map.
        let normal_matrix = inst.world_to_local.matrix3.transpose();
        let ng = (normal_matrix * packet.normal(lane)).normalize_or_zero();
        // The lane's index is the triangle's place in the BVH's order, where `vertex_data`
        // keeps its normals and texture coordinates (when the mesh has them).
        let vertex = data.vertex_data(lane).and_then(|k| mesh.vertex_data.get(k));
        let ns = match vertex {
            Some(d) if d.has_normals => {
                let local_p = inst.world_to_local.transform_point3a(origin)
                    + inst.world_to_local.transform_vector3a(dir) * t;
                let (v0, e1, e2) = packet.edges(lane);
                let b = barycentrics(v0, e1, e2, local_p);
                // Each vertex normal to world space, then interpolated: as the flattened
                // build does, so an instance shades like its flattened copy under
                // non-uniform scales.
                shading_normal(ng, b, d, |n| (normal_matrix * n).normalize_or_zero())
            }
            _ => ng,
        };
        Hit {
            pending: Pending::Triangle {
                prim,
                instance: slot,
            },
            ns,
            ..Hit::new(t, origin + dir * t, ng, inst.material, None)
        }
    }

    /// The world-space parametrisation at world point `p` of triangle `prim` of the instance
    /// in slot `slot`.
    pub fn parametrisation(&self, slot: u32, prim: u32, p: Vec3A) -> Parametrisation {
        let inst = &self.instances[slot as usize];
        let mesh = &self.meshes[inst.mesh as usize];
        let (k, lane) = (prim as usize / packet::WIDTH, prim as usize % packet::WIDTH);
        let Stored { packet, data } = &mesh.packets[k];
        let index = data.vertex_data(lane);
        let vertex = index.and_then(|i| mesh.vertex_data.get(i));
        let attribute = index.and_then(|i| mesh.attributes.get(i));
        let (v0, e1, e2) = packet.edges(lane);
        let b = barycentrics(v0, e1, e2, inst.world_to_local.transform_point3a(p));
        // Tangents go back to world space by the local-to-world map (rarely needed: inverted
        // here rather than stored beside every instance the traversal reads).
        parametrisation(b, e1, e2, vertex, attribute).mapped(inst.world_to_local.matrix3.inverse())
    }
}
