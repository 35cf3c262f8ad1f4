//! The accelerator: raylab's own BVH over the scene's primitives, and every SIMD routine and
//! `unsafe` block of the project.
//!
//! It takes geometry as plain data ([`Input`]: triangles, spheres, disks and cylinders,
//! curves ([`curves`]: pbrt-v4's, each Bézier segment split into pieces the BVH bounds), mesh
//! assets and their instances, each primitive with a material and light index to report) and
//! answers closest hits and occlusion. Triangles and analytic shapes share one 8-wide BVH
//! ([`bvh`]); the primitives are laid out in [`packet::Packet`]s, one or two per BVH leaf (the
//! analytic shapes' geometry in arrays of their own). Instances of mesh assets are not flattened: they get a two-level BVH
//! of their own ([`instances`]), traced after the flat BVH with the ray shortened to its hit,
//! and only when the scene has any. Traversal runs an AVX2 build where the processor has it
//! (chosen at run time through the [`isa::Avx2`] capability token), with the same bits as the
//! portable one. Flattening the ECS world into this input is the scene's side
//! (`crate::scene::flatten`).

mod bvh;
mod curves;
mod huge_pages;
mod instances;
mod obvhs_backend;
mod packet;
mod primitives;
pub mod sdf_grid;
mod sdf_set;
mod surface;

pub use obvhs_backend::ObvhsBvh;

use arrayvec::ArrayVec;
use bvh::{isa, isa::Isa, Bvh};
pub use curves::{CurveKind, CurvePiece, CurveSegment, Curves};
use glam::{Affine3A, Vec2, Vec3A};
use instances::InstanceSet;
use obvhs::aabb::Aabb;
use packet::{Analytic, AnalyticIndex, Lane, LeafTest, Packet, PacketRay, Stored, NONE};
pub use primitives::{Quadric, QuadricKind};
use raylab_integrators::{Hit, Pending, Ray};
use rayon::prelude::*;
pub use sdf_set::SdfInput;
use sdf_set::SdfSet;
use surface::{barycentrics, parametrisation, shading_normal, VertexData};

/// Triangles in their own space, with optional per-triangle vertex normals (smooth shading)
/// and texture coordinates, and their bounds (min, max).
#[derive(Clone, Copy, Debug)]
pub struct Mesh<'a> {
    pub triangles: &'a [[Vec3A; 3]],
    pub normals: Option<&'a [[Vec3A; 3]]>,
    pub uvs: Option<&'a [[Vec2; 3]]>,
    /// Per triangle, the mesh attribute at its corners (a face's value at all three).
    pub attributes: Option<&'a [[Vec3A; 3]]>,
    pub bounds: (Vec3A, Vec3A),
}

impl Mesh<'_> {
    /// Whether its triangles carry vertex data.
    fn has_vertex_data(&self) -> bool {
        self.normals.is_some() || self.uvs.is_some() || self.attributes.is_some()
    }

    /// Triangle `i`'s attribute at its corners (zero without attributes): the array beside
    /// the vertex data, in its order, where some mesh has attributes.
    pub(crate) fn attribute(&self, i: usize) -> [Vec3A; 3] {
        self.attributes.map_or([Vec3A::ZERO; 3], |a| a[i])
    }

    /// Triangle `i`'s vertex data, if the mesh has any.
    fn vertex_data(&self, i: usize) -> Option<VertexData> {
        VertexData::of(self.normals, self.uvs, i).or_else(|| {
            // Attributes alone: the vertex data holds the triangle's place beside them.
            self.attributes.map(|_| VertexData {
                normals: [Vec3A::ZERO; 3],
                uvs: surface::DEFAULT_UVS,
                has_normals: false,
                has_uvs: false,
            })
        })
    }
}

/// The geometry of one shape.
#[derive(Clone, Copy, Debug)]
pub enum Geometry<'a> {
    /// World-space triangles (their `bounds` are not used).
    Triangles(Mesh<'a>),
    Sphere {
        center: Vec3A,
        radius: f32,
        /// Its own axes in the world, which orient its parametrisation.
        frame: glam::Mat3A,
    },
    /// A disk or an open cylinder.
    Quadric(Quadric),
    /// World-space curves, each of their segments split into pieces.
    Curves(Curves<'a>),
}

/// Which light a shape's primitives report when hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShapeLights {
    None,
    /// One light for the whole shape (a sphere, a quad).
    Whole(u32),
    /// Light `first + i` for triangle `i` (a mesh emitter).
    PerTriangle(u32),
}

/// One shape of the flat (not instanced) geometry.
#[derive(Clone, Copy, Debug)]
pub struct Shape<'a> {
    pub geometry: Geometry<'a>,
    pub material: u32,
    pub lights: ShapeLights,
}

/// One placement of mesh asset `mesh`.
#[derive(Clone, Copy, Debug)]
pub struct InstanceDesc {
    pub mesh: u32,
    pub material: u32,
    pub local_to_world: Affine3A,
}

/// Everything the accelerator is built over.
#[derive(Clone, Debug, Default)]
pub struct Input<'a> {
    pub shapes: Vec<Shape<'a>>,
    /// Mesh assets, in the order instances refer to them.
    pub meshes: Vec<Mesh<'a>>,
    /// Per mesh asset, a key that only the same triangles ever carry: a rebuild
    /// ([`Accel::build_reusing`]) takes the BVH of a mesh whose key it already had from the
    /// accelerator before, instead of building it again.
    pub mesh_keys: Vec<u64>,
    pub instances: Vec<InstanceDesc>,
    /// SDF grids (Mitsuba's `sdfgrid`), placed.
    pub sdf_grids: Vec<SdfInput>,
}

/// The eight corners of the box `(min, max)`.
pub fn box_corners((min, max): (Vec3A, Vec3A)) -> [Vec3A; 8] {
    std::array::from_fn(|i| {
        Vec3A::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        )
    })
}

/// Counts of what the accelerator holds, for reports.
#[derive(Clone, Copy, Debug, Default)]
pub struct AccelStats {
    pub triangles: usize,
    pub spheres: usize,
    /// Disks and cylinders.
    pub quadrics: usize,
    /// Pieces of curves (each segment's `2^split_depth` parts).
    pub curve_pieces: usize,
    pub bvh_nodes: usize,
    /// Leaves of the flat geometry's BVH.
    pub bvh_leaves: usize,
    /// Instances of mesh assets, the triangles of those assets (each once) and the triangles
    /// the instances place (each asset once per instance).
    pub instances: usize,
    pub instanced_triangles: usize,
    pub placed_triangles: usize,
}

/// What an accelerator answers: closest hits and occlusion over the geometry it was built over.
pub trait Accelerator: Sync {
    /// The closest surface hit by `ray` with `t < ray.tmax`.
    fn closest(&self, ray: &Ray) -> Option<Hit>;
    /// True if any surface lies on `ray` with `t < ray.tmax`.
    fn occluded(&self, ray: &Ray) -> bool;
    /// [`Accelerator::closest`] of every ray of `rays`, into `hits`.
    fn closest_all(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        for (ray, hit) in rays.iter().zip(hits) {
            *hit = self.closest(ray);
        }
    }
    /// [`Accelerator::occluded`] of every ray of `rays`, into `blocked`.
    fn occluded_all(&self, rays: &[Ray], blocked: &mut [bool]) {
        for (ray, b) in rays.iter().zip(blocked) {
            *b = self.occluded(ray);
        }
    }
    /// Bounds (min, max) of all geometry, or `None` when there is none.
    fn bounds(&self) -> Option<(Vec3A, Vec3A)>;
    fn stats(&self) -> AccelStats;
    /// Bytes held by the geometry, its per-primitive data and the BVHs.
    fn memory_bytes(&self) -> usize;
    /// Computes `hit`'s pending texture coordinates and tangents (as this accelerator's
    /// `closest` left them).
    fn parametrise(&self, hit: &mut Hit);
}

/// The accelerators raylab offers (`--accel`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AccelKind {
    /// raylab's own 8-wide BVH with packet leaves ([`WideBvh`]).
    #[default]
    Raylab,
    /// The obvhs crate's CWBVH ([`ObvhsBvh`]).
    Obvhs,
}

/// The accelerators by name, as `--accel` takes them.
pub const ACCEL_NAMES: [&str; 2] = ["raylab", "obvhs"];

impl std::str::FromStr for AccelKind {
    type Err = String;

    fn from_str(name: &str) -> Result<AccelKind, String> {
        match name {
            "raylab" => Ok(AccelKind::Raylab),
            "obvhs" => Ok(AccelKind::Obvhs),
            _ => Err(format!(
                "unknown accelerator `{name}`; valid accelerators: {}",
                ACCEL_NAMES.join(", ")
            )),
        }
    }
}

impl std::fmt::Display for AccelKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            AccelKind::Raylab => "raylab",
            AccelKind::Obvhs => "obvhs",
        })
    }
}

/// One accelerator of either kind: dispatched by a match, not a second virtual call per ray.
pub enum Accel {
    Raylab(WideBvh),
    Obvhs(ObvhsBvh),
}

impl Accel {
    /// Builds the accelerator of kind `kind` over `input`.
    pub fn build(kind: AccelKind, input: &Input) -> Accel {
        Self::build_reusing(kind, input, None)
    }

    /// [`Accel::build`], taking from `previous` the BVH of every mesh asset whose key
    /// (`input.mesh_keys`) it holds: the same triangles give the same BVH, so the result is
    /// the one a build from nothing gives. (raylab's own accelerator only; the obvhs backend
    /// builds everything.)
    pub fn build_reusing(kind: AccelKind, input: &Input, previous: Option<&Accel>) -> Accel {
        match kind {
            AccelKind::Raylab => {
                let previous = match previous {
                    Some(Accel::Raylab(p)) => Some(&p.instances),
                    _ => None,
                };
                Accel::Raylab(WideBvh::build_reusing(input, previous))
            }
            AccelKind::Obvhs => Accel::Obvhs(ObvhsBvh::build(input)),
        }
    }

    /// How many mesh BVHs the accelerator holds, and how many of them it took from the
    /// accelerator it was built from.
    pub fn mesh_bvhs(&self) -> (usize, usize) {
        match self {
            Accel::Raylab(a) => (a.instances.mesh_count(), a.instances.reused),
            Accel::Obvhs(a) => (a.mesh_count(), 0),
        }
    }

    pub fn kind(&self) -> AccelKind {
        match self {
            Accel::Raylab(_) => AccelKind::Raylab,
            Accel::Obvhs(_) => AccelKind::Obvhs,
        }
    }
}

impl Accelerator for Accel {
    #[inline]
    fn closest(&self, ray: &Ray) -> Option<Hit> {
        match self {
            Accel::Raylab(a) => a.closest(ray),
            Accel::Obvhs(a) => a.closest(ray),
        }
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        match self {
            Accel::Raylab(a) => a.occluded(ray),
            Accel::Obvhs(a) => a.occluded(ray),
        }
    }

    fn closest_all(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        match self {
            Accel::Raylab(a) => a.closest_all(rays, hits),
            Accel::Obvhs(a) => rays.iter().zip(hits).for_each(|(r, h)| *h = a.closest(r)),
        }
    }

    fn occluded_all(&self, rays: &[Ray], blocked: &mut [bool]) {
        match self {
            Accel::Raylab(a) => a.occluded_all(rays, blocked),
            Accel::Obvhs(a) => rays
                .iter()
                .zip(blocked)
                .for_each(|(r, b)| *b = a.occluded(r)),
        }
    }

    fn bounds(&self) -> Option<(Vec3A, Vec3A)> {
        match self {
            Accel::Raylab(a) => a.bounds(),
            Accel::Obvhs(a) => a.bounds(),
        }
    }

    fn stats(&self) -> AccelStats {
        match self {
            Accel::Raylab(a) => a.stats,
            Accel::Obvhs(a) => a.stats,
        }
    }

    fn memory_bytes(&self) -> usize {
        match self {
            Accel::Raylab(a) => a.memory_bytes(),
            Accel::Obvhs(a) => a.memory_bytes(),
        }
    }

    fn parametrise(&self, hit: &mut Hit) {
        match self {
            Accel::Raylab(a) => a.parametrise(hit),
            Accel::Obvhs(a) => a.parametrise(hit),
        }
    }
}

/// raylab's own BVH over triangles and analytic shapes, and the instances' two-level BVH.
pub struct WideBvh {
    pub(crate) bvh: Bvh,
    /// Per packet of a leaf's primitives (one or two per leaf): the packet and its lane data,
    /// side by side.
    pub(crate) packets: Vec<Stored>,
    /// Vertex data of the triangles that have any ([`packet::LaneData::vertex_data`]).
    pub(crate) vertex_data: Vec<VertexData>,
    /// Beside `vertex_data`, index for index, the mesh attributes at the corners; empty when
    /// no mesh has any.
    pub(crate) attributes: Vec<[Vec3A; 3]>,
    // Spheres' geometry, in BVH order; their materials and lights are in their lane data.
    pub(crate) sph_center: Vec<Vec3A>,
    pub(crate) sph_radius: Vec<f32>,
    /// Each sphere's own axes (its parametrisation's frame).
    pub(crate) sph_frame: Vec<glam::Mat3A>,
    /// Disks and cylinders, in BVH order.
    pub(crate) quadrics: Vec<Quadric>,
    /// The curves' segments, shape after shape, and their pieces in BVH order.
    pub(crate) curve_segments: Vec<CurveSegment>,
    pub(crate) curve_pieces: Vec<CurvePiece>,
    /// Instanced meshes (a two-level BVH); empty in most scenes.
    instances: InstanceSet,
    /// The SDF grids' voxels; empty in most scenes.
    sdf: SdfSet,
    /// Bounds of everything, or `None` without geometry.
    bounds: Option<(Vec3A, Vec3A)>,
    /// The AVX2 build of the traversal, where the processor has AVX2.
    pub(crate) avx2: Option<isa::Avx2>,
    /// Nodes from which batches of rays walk the tree as a stream ([`WideBvh::streams`]).
    pub(crate) stream_from: usize,
    pub stats: AccelStats,
}

/// One primitive before reordering: a reference into the input's shapes (12 bytes, so that a
/// million-triangle mesh is not copied before the BVH is built).
#[derive(Clone, Copy)]
struct Prim {
    /// Index into the input's shapes.
    shape: u32,
    /// Triangle index, or curve piece index, within the shape (0 for another analytic shape).
    index: u32,
    light: u32,
}

impl Prim {
    fn aabb(self, shapes: &[Shape]) -> Aabb {
        match shapes[self.shape as usize].geometry {
            Geometry::Triangles(mesh) => Aabb::from_points(&mesh.triangles[self.index as usize]),
            Geometry::Sphere { center, radius, .. } => {
                Aabb::new(center - Vec3A::splat(radius), center + Vec3A::splat(radius))
            }
            Geometry::Quadric(q) => {
                let (min, max) = q.bounds();
                Aabb::new(min, max)
            }
            Geometry::Curves(c) => {
                let (s, u0, u1) = c.piece(self.index as usize);
                c.segments[s].bounds(u0, u1)
            }
        }
    }
}

/// Primitives the geometry `g` makes.
fn primitive_count(g: &Geometry) -> usize {
    match g {
        Geometry::Triangles(mesh) => mesh.triangles.len(),
        Geometry::Sphere { .. } | Geometry::Quadric(_) => 1,
        Geometry::Curves(c) => c.pieces(),
    }
}

/// The input's curve segments, shape after shape, and where each shape's start among them.
fn curve_segments(shapes: &[Shape]) -> (Vec<CurveSegment>, Vec<u32>) {
    let mut segments = Vec::new();
    let mut first = Vec::with_capacity(shapes.len());
    for shape in shapes {
        first.push(segments.len() as u32);
        if let Geometry::Curves(c) = shape.geometry {
            segments.extend_from_slice(c.segments);
        }
    }
    (segments, first)
}

impl WideBvh {
    /// Builds the BVHs over `input` (in parallel on rayon's current pool, with the same result
    /// at any thread count).
    pub fn build(input: &Input) -> WideBvh {
        Self::build_reusing(input, None)
    }

    /// [`WideBvh::build`], taking the BVHs of mesh assets whose keys `previous` holds from it.
    fn build_reusing(input: &Input, previous: Option<&InstanceSet>) -> WideBvh {
        let shapes = &input.shapes;
        let count = primitive_count;
        let (curve_segments, first_segment) = curve_segments(shapes);
        // Read at random while the packets are made: on huge pages (see `huge_pages`).
        let mut prims: Vec<Prim> =
            huge_pages::with_capacity(shapes.iter().map(|s| count(&s.geometry)).sum());
        for (k, shape) in shapes.iter().enumerate() {
            prims.extend((0..count(&shape.geometry)).map(|i| Prim {
                shape: k as u32,
                index: i as u32,
                light: match shape.lights {
                    ShapeLights::None => NONE,
                    ShapeLights::Whole(first) => first,
                    ShapeLights::PerTriangle(first) => first + i as u32,
                },
            }));
        }

        let instances =
            InstanceSet::build(&input.meshes, &input.mesh_keys, &input.instances, previous);
        let sdf = SdfSet::build(&input.sdf_grids);
        // BVH over every primitive's box, for leaves that test a packet at a time; then one or
        // two packets per leaf, the leaves numbered in the BVH's primitive order.
        let (mut bvh, order) = Bvh::build::<bvh::Packets>(prims.len(), |i| prims[i].aabb(shapes));
        let leaves = bvh.number_leaves(packet::packets_for);
        let mut bounds = match bvh.bounds() {
            Some(b) => instances.bounds.union(&b),
            None => instances.bounds,
        };
        if let Some(b) = sdf.bounds() {
            bounds = bounds.union(&b);
        }

        // Each position of the BVH's order: its primitive, read from `prims` once here (in
        // this order the reads are random; the passes below then read `placed` in turn),
        // and its index among the triangles with vertex data, the spheres or the quadrics
        // (a running count, cheap), for the lanes to refer to.
        let mut placed: Vec<Prim> = huge_pages::with_capacity(order.len());
        let mut aux = Vec::with_capacity(order.len());
        let (mut with_data, mut sph_center, mut sph_radius) = (0u32, Vec::new(), Vec::new());
        let mut sph_frame = Vec::new();
        let mut quadrics = Vec::new();
        let mut curve_pieces = Vec::new();
        for &original in &order {
            let p = prims[original as usize];
            placed.push(p);
            aux.push(match shapes[p.shape as usize].geometry {
                Geometry::Triangles(mesh) if mesh.has_vertex_data() => {
                    with_data += 1;
                    with_data - 1
                }
                Geometry::Triangles(_) => NONE,
                Geometry::Sphere {
                    center,
                    radius,
                    frame,
                } => {
                    sph_center.push(center);
                    sph_radius.push(radius);
                    sph_frame.push(frame);
                    sph_center.len() as u32 - 1
                }
                Geometry::Quadric(q) => {
                    quadrics.push(q);
                    quadrics.len() as u32 - 1
                }
                Geometry::Curves(c) => {
                    let (s, u0, u1) = c.piece(p.index as usize);
                    curve_pieces.push(CurvePiece {
                        segment: first_segment[p.shape as usize] + s as u32,
                        u0,
                        u1,
                    });
                    curve_pieces.len() as u32 - 1
                }
            });
        }
        // The primitives in their original order are not needed again (the build's peak).
        drop(prims);
        // Then, in parallel and in order, the vertex data (when any triangle has some) and
        // the packets.
        let vertex_data: Vec<VertexData> = if with_data == 0 {
            Vec::new()
        } else {
            placed
                .par_iter()
                .filter_map(|p| match shapes[p.shape as usize].geometry {
                    Geometry::Triangles(mesh) => mesh.vertex_data(p.index as usize),
                    Geometry::Sphere { .. } | Geometry::Quadric(_) | Geometry::Curves(_) => None,
                })
                .collect()
        };
        let any_attributes = shapes
            .iter()
            .any(|s| matches!(s.geometry, Geometry::Triangles(m) if m.attributes.is_some()));
        let attributes: Vec<[Vec3A; 3]> = if any_attributes {
            placed
                .par_iter()
                .filter_map(|p| match shapes[p.shape as usize].geometry {
                    Geometry::Triangles(mesh) if mesh.has_vertex_data() => {
                        Some(mesh.attribute(p.index as usize))
                    }
                    _ => None,
                })
                .collect()
        } else {
            Vec::new()
        };
        let lane = |k: u32| {
            let p = placed[k as usize];
            let shape = &shapes[p.shape as usize];
            match shape.geometry {
                Geometry::Triangles(mesh) => Lane::Triangle {
                    corners: mesh.triangles[p.index as usize],
                    material: shape.material,
                    light: p.light,
                    vertex_data: aux[k as usize],
                },
                Geometry::Sphere { .. } => Lane::Sphere {
                    index: aux[k as usize],
                    material: shape.material,
                    light: p.light,
                },
                Geometry::Quadric(_) => Lane::Quadric {
                    index: aux[k as usize],
                    material: shape.material,
                    light: p.light,
                },
                Geometry::Curves(_) => Lane::Curve {
                    index: aux[k as usize],
                    material: shape.material,
                    light: p.light,
                },
            }
        };
        let runs: Vec<(u32, u32)> = leaves
            .iter()
            .flat_map(|&(first, count)| packet::runs(first, count))
            .collect();
        let packets: Vec<Stored> = huge_pages::collect(runs.par_iter().map(|&(first, count)| {
            let lanes: ArrayVec<Lane, { packet::WIDTH }> =
                (first..first + count).map(lane).collect();
            let (packet, data) = Packet::new(&lanes);
            Stored { packet, data }
        }));
        let stats = AccelStats {
            triangles: placed.len() - sph_center.len() - quadrics.len() - curve_pieces.len(),
            spheres: sph_center.len(),
            quadrics: quadrics.len(),
            curve_pieces: curve_pieces.len(),
            bvh_nodes: bvh.node_count() + instances.bvh_nodes(),
            bvh_leaves: leaves.len(),
            instances: instances.len(),
            instanced_triangles: instances.unique_triangles(),
            placed_triangles: instances.placed_triangles(),
        };
        WideBvh {
            bvh,
            packets,
            vertex_data,
            attributes,
            sph_center,
            sph_radius,
            sph_frame,
            quadrics,
            curve_segments,
            curve_pieces,
            instances,
            sdf,
            bounds: bounds.valid().then_some((bounds.min, bounds.max)),
            avx2: isa::Avx2::detect(),
            stream_from: STREAM_NODES,
            stats,
        }
    }

    /// Bounds (min, max) of all geometry, or `None` when there is none.
    pub fn bounds(&self) -> Option<(Vec3A, Vec3A)> {
        self.bounds
    }

    /// Bytes held by the geometry, its per-primitive data and the BVHs (not the materials or
    /// lights): what a benchmark reports per triangle. Each instanced mesh counts once.
    pub fn memory_bytes(&self) -> usize {
        use std::mem::size_of;
        let v = |n: usize, each: usize| n * each;
        self.instances.memory_bytes()
            + v(self.packets.capacity(), size_of::<Stored>())
            + v(self.vertex_data.capacity(), size_of::<VertexData>())
            + v(self.attributes.capacity(), size_of::<[Vec3A; 3]>())
            + self.sdf.memory_bytes()
            + v(self.sph_center.capacity(), size_of::<Vec3A>())
            + v(self.sph_radius.capacity(), 4)
            + v(self.quadrics.capacity(), size_of::<Quadric>())
            + v(self.curve_segments.capacity(), size_of::<CurveSegment>())
            + v(self.curve_pieces.capacity(), size_of::<CurvePiece>())
            + self.bvh.memory_bytes()
    }

    fn analytic(&self) -> Analytic<'_> {
        Analytic {
            center: &self.sph_center,
            radius: &self.sph_radius,
            quadrics: &self.quadrics,
            curves: &self.curve_pieces,
            segments: &self.curve_segments,
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
        let (material, light) = (data.material(lane), data.light(lane));
        if let Some(shape) = s.analytic_index(lane, data) {
            match shape {
                AnalyticIndex::Sphere(i) => {
                    let (c, r) = (self.sph_center[i], self.sph_radius[i]);
                    Hit::on_oriented_sphere(ray, t, c, r, self.sph_frame[i], material, light)
                }
                AnalyticIndex::Quadric(i) => {
                    self.quadrics[i].hit(ray.origin, ray.dir, t, material, light)
                }
                AnalyticIndex::Curve(i) => {
                    self.curve_pieces[i].hit(&self.curve_segments, ray, t, material, light)
                }
            }
        } else {
            let ng = s.normal(lane);
            let p = ray.at(t);
            let vertex = data.vertex_data(lane).map(|k| &self.vertex_data[k]);
            // Flat shading unless the triangle has vertex normals.
            let ns = match vertex {
                Some(d) if d.has_normals => {
                    let (v0, e1, e2) = s.edges(lane);
                    shading_normal(ng, barycentrics(v0, e1, e2, p), d, |n| n)
                }
                _ => ng,
            };
            Hit {
                pending: Pending::Triangle {
                    prim: id,
                    instance: NONE,
                },
                ns,
                ..Hit::new(t, p, ng, material, light)
            }
        }
    }

    /// Computes a hit's pending texture coordinates and tangents ([`Pending`]).
    pub fn parametrise(&self, hit: &mut Hit) {
        let Pending::Triangle { prim, instance } = hit.pending else {
            hit.parametrise_sphere();
            return;
        };
        let param = if instance == NONE {
            let (p, lane) = (prim as usize / packet::WIDTH, prim as usize % packet::WIDTH);
            let (s, data) = (&self.packets[p].packet, &self.packets[p].data);
            let (v0, e1, e2) = s.edges(lane);
            let k = data.vertex_data(lane);
            let vertex = k.map(|k| &self.vertex_data[k]);
            let attribute = k.and_then(|k| self.attributes.get(k));
            parametrisation(barycentrics(v0, e1, e2, hit.p), e1, e2, vertex, attribute)
        } else {
            self.instances.parametrisation(instance, prim, hit.p)
        };
        param.write_to(hit);
    }
}

/// The traversal built for AVX2: the same functions, inlined into these two and compiled
/// with AVX2 enabled, with the BVH's eight-lane box tests as single AVX operations
/// ([`bvh::isa`]). Both compute exactly what the portable build does.
#[cfg(target_arch = "x86_64")]
impl WideBvh {
    #[target_feature(enable = "avx2")]
    fn closest_hit_avx2(&self, avx2: isa::Avx2, ray: &Ray) -> Option<Hit> {
        self.closest_hit(avx2, ray)
    }

    #[target_feature(enable = "avx2")]
    fn any_hit_avx2(&self, avx2: isa::Avx2, ray: &Ray) -> bool {
        self.any_hit(avx2, ray)
    }

    /// A batch of closest hits in one AVX2 function: no dispatch per ray, and one ray's
    /// traversal can start while the last one's hit record is still being written.
    #[target_feature(enable = "avx2")]
    fn closest_hits_avx2(&self, avx2: isa::Avx2, rays: &[Ray], hits: &mut [Option<Hit>]) {
        self.closest_hits(avx2, rays, hits);
    }

    /// A batch of occlusion tests in one AVX2 function.
    #[target_feature(enable = "avx2")]
    fn any_hits_avx2(&self, avx2: isa::Avx2, rays: &[Ray], blocked: &mut [bool]) {
        self.any_hits(avx2, rays, blocked);
    }
}

/// Nodes from which a tree is walked as a stream ([`WideBvh::streams`]): 2 MiB of nodes, more
/// than a core's L2 cache holds. The 1.31 M-triangle mesh of `raylab bench` has 43 k nodes;
/// small scenes have one to a few hundred.
const STREAM_NODES: usize = 8192;

impl WideBvh {
    /// Whether a batch of rays is better walked as a stream (four rays at once,
    /// `Bvh::closest_stream`) than one by one: where the tree is too large for the cache, so
    /// that overlapping the rays' node loads pays. Measured on the 1.31 M-triangle mesh's
    /// incoherent rays (`raylab bench`, 1 thread, alternated): 1.04-1.16x closest, 1.08-1.15x
    /// occlusion; where the nodes are in cache (its coherent rays, the Cornell box), the
    /// stream's bookkeeping costs 5-12%.
    fn streams(&self) -> bool {
        self.bvh.node_count() >= self.stream_from
    }

    /// The closest hits of `rays`, walked as a stream where [`WideBvh::streams`] says so and
    /// the scene is one flat tree (instances and SDF grids go ray by ray).
    #[inline(always)]
    fn closest_hits<I: Isa + LeafTest>(&self, isa: I, rays: &[Ray], hits: &mut [Option<Hit>]) {
        if !self.streams() || !self.instances.is_empty() || !self.sdf.is_empty() {
            for (ray, hit) in rays.iter().zip(hits) {
                *hit = self.closest_hit(isa, ray);
            }
            return;
        }
        let shapes = self.analytic();
        // Rays that cannot be traced (not finite) hit nothing.
        hits.iter_mut().for_each(|h| *h = None);
        let mut queue = rays.iter().enumerate();
        let next =
            || queue.find_map(|(i, ray)| Self::to_bvh_ray(ray).map(|r| (i, r, PacketRay::new(&r))));
        self.bvh.closest_stream(
            isa,
            next,
            #[inline(always)]
            |lanes, r, first, count| {
                let leaf =
                    &self.packets[first as usize..(first + packet::packets_for(count)) as usize];
                let (k, t) = isa.closest(leaf, lanes, r, r.tmax, &shapes)?;
                Some((first * packet::WIDTH as u32 + k as u32, t))
            },
            |i, hit| hits[i] = hit.map(|(id, t)| self.hit_record(&rays[i], id, t)),
        );
    }

    /// Whether each ray of `rays` is blocked, the flat tree walked as a stream where
    /// [`WideBvh::streams`] says so (instances and SDF grids then ray by ray).
    #[inline(always)]
    fn any_hits<I: Isa + LeafTest>(&self, isa: I, rays: &[Ray], blocked: &mut [bool]) {
        if !self.streams() {
            for (ray, b) in rays.iter().zip(blocked) {
                *b = self.any_hit(isa, ray);
            }
            return;
        }
        let shapes = self.analytic();
        blocked.iter_mut().for_each(|b| *b = false);
        let mut queue = rays.iter().enumerate();
        let next =
            || queue.find_map(|(i, ray)| Self::to_bvh_ray(ray).map(|r| (i, r, PacketRay::new(&r))));
        self.bvh.any_stream(
            isa,
            next,
            #[inline(always)]
            |lanes, r, first, count| {
                let end = first + packet::packets_for(count);
                isa.any(
                    &self.packets[first as usize..end as usize],
                    lanes,
                    r,
                    &shapes,
                )
            },
            |i, hit| blocked[i] = hit,
        );
        if self.instances.is_empty() && self.sdf.is_empty() {
            return;
        }
        for (ray, b) in rays.iter().zip(blocked) {
            if let (false, Some(r)) = (*b, Self::to_bvh_ray(ray)) {
                *b = (!self.instances.is_empty() && self.instances.occluded(isa, &r))
                    || (!self.sdf.is_empty() && self.sdf.any(isa, &r));
            }
        }
    }

    #[inline(always)]
    fn closest_hit<I: Isa + LeafTest>(&self, isa: I, ray: &Ray) -> Option<Hit> {
        let bvh_ray = Self::to_bvh_ray(ray)?;
        let (lanes, shapes) = (PacketRay::new(&bvh_ray), self.analytic());
        let flat = self.bvh.closest(
            isa,
            &bvh_ray,
            #[inline(always)]
            |r, first, count| {
                let leaf =
                    &self.packets[first as usize..(first + packet::packets_for(count)) as usize];
                let (k, t) = isa.closest(leaf, &lanes, r, r.tmax, &shapes)?;
                Some((first * packet::WIDTH as u32 + k as u32, t))
            },
        );
        // Instances, then SDF grids, only count nearer than the hit so far.
        let mut r = bvh_ray;
        if let Some((_, t)) = flat {
            r.tmax = t;
        }
        let mut instanced = None;
        if !self.instances.is_empty() {
            if let Some((slot, prim, t)) = self.instances.intersect(isa, &r) {
                instanced = Some((slot, prim));
                r.tmax = t;
            }
        }
        if !self.sdf.is_empty() {
            if let Some((k, t)) = self.sdf.closest(isa, &r) {
                return Some(self.sdf.hit_record(ray.origin, ray.dir, k, t));
            }
        }
        if let Some((slot, prim)) = instanced {
            return Some(
                self.instances
                    .hit_record(ray.origin, ray.dir, slot, prim, r.tmax),
            );
        }
        flat.map(|(id, t)| self.hit_record(ray, id, t))
    }

    #[inline(always)]
    fn any_hit<I: Isa + LeafTest>(&self, isa: I, ray: &Ray) -> bool {
        match Self::to_bvh_ray(ray) {
            Some(r) => {
                let (lanes, shapes) = (PacketRay::new(&r), self.analytic());
                self.bvh.any(
                    isa,
                    &r,
                    #[inline(always)]
                    |r, first, count| {
                        let end = first + packet::packets_for(count);
                        isa.any(
                            &self.packets[first as usize..end as usize],
                            &lanes,
                            r,
                            &shapes,
                        )
                    },
                ) || (!self.instances.is_empty() && self.instances.occluded(isa, &r))
                    || (!self.sdf.is_empty() && self.sdf.any(isa, &r))
            }
            None => false,
        }
    }
}

impl WideBvh {
    /// The closest surface hit by `ray` with `t < ray.tmax`.
    #[inline]
    pub fn closest(&self, ray: &Ray) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = self.avx2 {
            // SAFETY: the function is compiled for AVX2, and the token exists only where the
            // processor has it (`Avx2::detect`).
            return unsafe { self.closest_hit_avx2(avx2, ray) };
        }
        self.closest_hit(isa::Portable, ray)
    }

    /// True if any surface lies on `ray` with `t < ray.tmax`.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = self.avx2 {
            // SAFETY: as in `closest`.
            return unsafe { self.any_hit_avx2(avx2, ray) };
        }
        self.any_hit(isa::Portable, ray)
    }

    /// [`WideBvh::closest`] of every ray of `rays`, into `hits`.
    pub fn closest_all(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = self.avx2 {
            // SAFETY: as in `closest`.
            return unsafe { self.closest_hits_avx2(avx2, rays, hits) };
        }
        self.closest_hits(isa::Portable, rays, hits);
    }

    /// [`WideBvh::occluded`] of every ray of `rays`, into `blocked`.
    pub fn occluded_all(&self, rays: &[Ray], blocked: &mut [bool]) {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = self.avx2 {
            // SAFETY: as in `closest`.
            return unsafe { self.any_hits_avx2(avx2, rays, blocked) };
        }
        self.any_hits(isa::Portable, rays, blocked);
    }
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod instance_tests;
