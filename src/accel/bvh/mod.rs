//! raylab's own bounding volume hierarchy: an 8-wide BVH with uncompressed boxes, built with
//! a binned SAH in parallel and traversed with one vector comparison per node.
//!
//! Why not obvhs's compressed wide BVH (CWBVH), which raylab used until it was measured:
//! - a CWBVH node stores its children's boxes quantised to 8 bits, so every node visit
//!   decodes them first; on a 1.3 M-triangle mesh, where rays visit many nodes that are not
//!   in cache, raylab traced at 0.4-0.6x Embree's rate, and a profile put the time in that
//!   decode and the traversal loop around it;
//! - its PLOC builder peaked at about 300 bytes per triangle and took 2.5-4x Embree's build
//!   time, single-threaded in its conversion to the wide tree.
//!
//! Here a node ([`Node`]) is 256 bytes, four cache lines: the eight children's boxes as six
//! planes of eight floats (a lane per child), the children's indices and primitive counts, and
//! a mask of which children are leaves. A ray tests all eight boxes at once ([`isa`]): with
//! one AVX operation per step where the processor has AVX2 (the scene dispatches to an AVX2
//! build of its traversal at run time), with two SSE (or NEON) operations elsewhere; both
//! give the same bits. Leaves hold up to [`MAX_LEAF`] consecutive primitives of the
//! reordered primitive array, so the caller lays out its own primitive data in the BVH's
//! order ([`Bvh::build`] returns that order, [`Bvh::number_leaves`] renumbers the leaves for
//! the caller's packets) and nothing is read through an index.
//!
//! Measured against the 4-wide BVH with single-triangle leaves that came before (`raylab
//! bench`, alternated rounds): on the 1.3 M-triangle mesh, four-triangle SIMD leaves gave
//! +20-55%, the eighth lanes with AVX another 10-20%; filling the lanes (leaves of up to
//! eight, splits chosen by SAH gain) cut the mesh's nodes from 122 k to 43 k.
//!
//! The builder ([`builder`]) opens each node eight ways by repeated binned-SAH splits, with
//! the children of large nodes built in parallel (rayon). Its result does not depend on the
//! number of threads. Traversal ([`traverse`]) keeps a fixed stack on the call stack: no ray
//! allocates.

mod builder;
pub mod isa;
mod traverse;

use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::ray::Ray;

/// Most primitives in one leaf, of any kind of [`Leaves`].
pub const MAX_LEAF: usize = 8;

/// What the leaves of a BVH hold, for the builder's cost model.
pub trait Leaves {
    /// Primitives a leaf tests at once: its SAH cost is the number of such blocks.
    const BLOCK: usize;
    /// Most primitives in one leaf (at most [`MAX_LEAF`]).
    const MAX: usize;
}

/// Packets of four triangles, one or two per leaf (the flat scene and instanced meshes).
pub struct Packets;

impl Leaves for Packets {
    const BLOCK: usize = 4;
    const MAX: usize = 8;
}

/// One primitive per leaf: instances, each a whole traversal of its mesh's BVH to test, far
/// costlier than a node visit.
pub struct Singles;

impl Leaves for Singles {
    const BLOCK: usize = 1;
    const MAX: usize = 1;
}

/// Children per node.
pub const LANES: usize = 8;

/// A ray for traversal: obvhs's [`Ray`] with the exact inverse of its direction.
///
/// obvhs's `Ray::new` replaces the inverse of every component of size up to `f32::EPSILON`
/// by `±1 / EPSILON`, which shortens the slab distances along that axis: a box whose face is
/// within about `t * EPSILON` of the origin was lost (a ray along +z from x = 0.5 missed a
/// triangle at z = 20 whose box ends at x = 0.500001). Here a zero component's inverse is
/// `±f32::MAX` instead of infinity, so that `(plane - origin) * inverse` is never
/// `0 * inf = NaN`.
#[inline(always)]
pub fn ray(origin: Vec3A, direction: Vec3A, tmin: f32, tmax: f32) -> Ray {
    // Built field by field: `Ray::new` would first compute its own inverse, three scalar
    // divisions that this one replaces, for every ray and every instance a ray enters.
    let inv = direction.recip();
    Ray {
        origin,
        direction,
        inv_direction: Vec3A::select(
            inv.is_finite_mask(),
            inv,
            Vec3A::splat(f32::MAX).copysign(direction),
        ),
        tmin,
        tmax,
    }
}

/// Marks an empty child slot (its box is empty, so no ray reaches it).
const EMPTY: u32 = u32::MAX;

/// One plane of the children's boxes: a lane per child.
type Plane = [f32; LANES];

/// One node: eight children's boxes, a lane per child, and where each child is.
///
/// `planes[0]` holds the boxes' minima and `planes[1]` their maxima, by axis; an unused child
/// has an empty box (+inf minima, -inf maxima), which no ray can enter. A child with
/// `count[i] == 0` is the node `child[i]`; otherwise it is a leaf of `count[i]` primitives
/// starting at `child[i]` in the BVH's order. `leaves` has bit `i` set for leaf children, so
/// that traversal splits a hit mask into leaves and nodes in one operation.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct Node {
    planes: [[Plane; 3]; 2],
    child: [u32; LANES],
    count: [u8; LANES],
    leaves: u8,
}

impl Node {
    const EMPTY: Node = Node {
        planes: [[[f32::INFINITY; LANES]; 3], [[f32::NEG_INFINITY; LANES]; 3]],
        child: [EMPTY; LANES],
        count: [0; LANES],
        leaves: 0,
    };

    /// Sets `leaves` from the counts.
    fn mark_leaves(&mut self) {
        self.leaves = (0..LANES).fold(0, |m, c| m | u8::from(self.count[c] != 0) << c);
    }

    /// Sets child `c`'s box.
    fn set_box(&mut self, c: usize, min: Vec3A, max: Vec3A) {
        for axis in 0..3 {
            self.planes[0][axis][c] = min[axis];
            self.planes[1][axis][c] = max[axis];
        }
    }

    /// Child `c`'s box.
    fn get_box(&self, c: usize) -> Aabb {
        let lane =
            |p: usize| Vec3A::from_array(std::array::from_fn(|axis| self.planes[p][axis][c]));
        Aabb::new(lane(0), lane(1))
    }
}

/// An 8-wide BVH over primitives numbered in the order [`Bvh::build`] returned.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bvh {
    nodes: Vec<Node>,
}

impl Bvh {
    /// Number of nodes (for reports).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes held by the nodes.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node>()
    }

    /// The box around every primitive, or `None` when empty.
    pub fn bounds(&self) -> Option<Aabb> {
        let root = self.nodes.first()?;
        let mut b = Aabb::empty();
        for c in (0..LANES).filter(|&c| root.child[c] != EMPTY) {
            b = b.union(&root.get_box(c));
        }
        Some(b)
    }

    /// Renumbers the leaves for an array of the caller's that holds `slots(count)` entries
    /// per leaf of `count` primitives, leaf after leaf in the primitive order (packets of
    /// triangles, say): afterwards a leaf's `first` is the index of its first entry there,
    /// and its `count` is kept. Returns each leaf's primitives as `(first, count)`, in the
    /// primitive order (the order of their entries).
    pub fn number_leaves(&mut self, slots: impl Fn(u32) -> u32) -> Vec<(u32, u32)> {
        // Children are in the order of their primitives (the builder splits ranges in place
        // and keeps the halves in order), so a depth-first walk taking the children in lane
        // order meets the leaves in the primitive order.
        fn walk(
            nodes: &mut [Node],
            i: usize,
            next: &mut u32,
            slots: &impl Fn(u32) -> u32,
            runs: &mut Vec<(u32, u32)>,
        ) {
            for c in 0..LANES {
                let (child, count) = (nodes[i].child[c], u32::from(nodes[i].count[c]));
                if count != 0 {
                    debug_assert!(runs.last().is_none_or(|&(f, k)| f + k == child));
                    runs.push((child, count));
                    nodes[i].child[c] = *next;
                    *next += slots(count);
                } else if child != EMPTY {
                    walk(nodes, child as usize, next, slots, runs);
                }
            }
        }
        let mut runs = Vec::new();
        if !self.nodes.is_empty() {
            walk(&mut self.nodes, 0, &mut 0, &slots, &mut runs);
        }
        runs
    }

    /// Depth of the tree (1 for a root alone, 0 when empty): what the traversal stack bounds.
    #[cfg(test)]
    pub fn depth(&self) -> usize {
        fn depth_of(nodes: &[Node], i: usize) -> usize {
            let n = &nodes[i];
            1 + (0..LANES)
                .filter(|&c| n.count[c] == 0 && n.child[c] != EMPTY)
                .map(|c| depth_of(nodes, n.child[c] as usize))
                .max()
                .unwrap_or(0)
        }
        if self.nodes.is_empty() {
            0
        } else {
            depth_of(&self.nodes, 0)
        }
    }
}

#[cfg(test)]
mod tests;
