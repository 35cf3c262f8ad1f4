//! Traversal of [`Bvh`]: closest hit (front to back, with the children's entry distances
//! kept on the stack to skip subtrees beyond the closest hit found) and any hit.
//!
//! Both take the leaf test as a closure over a leaf's `(first, count)`, so the caller decides
//! what a leaf holds: a packet of triangles for the flat scene
//! ([`Bvh::number_leaves`]), a run of instances for the top level of instancing.

use super::builder::MAX_DEPTH;
use super::isa::Isa;
use super::{Bvh, LANES};
use arrayvec::ArrayVec;
use obvhs::ray::Ray;

/// Traversal stack entries: a node pushes at most `LANES - 1` (one child is visited next),
/// and the builder bounds the depth.
const STACK: usize = (LANES - 1) * MAX_DEPTH + 1;

impl Bvh {
    /// The closest hit on `ray` within `[ray.tmin, ray.tmax]`, as the leaf test gave it:
    /// `leaf(r, first, count)` returns the nearest hit in that leaf with a distance below
    /// `r.tmax` (the closest found so far), as (an identifier of the caller's, distance).
    // Always inlined: into the AVX2 build of the scene's traversal, it becomes AVX2 code.
    #[inline(always)]
    pub fn closest<I: Isa>(
        &self,
        ray: &Ray,
        mut leaf: impl FnMut(&Ray, u32, u32) -> Option<(u32, f32)>,
    ) -> Option<(u32, f32)> {
        if self.nodes.is_empty() {
            return None;
        }
        let boxes = I::prepare(ray);
        let mut r = *ray;
        let mut best = None;
        // Uninitialised until pushed: zero-filling it cost small scenes 10% of their rate.
        let mut stack: ArrayVec<(f32, u32), STACK> = ArrayVec::new();
        let mut node = 0u32;
        loop {
            // Test the node's eight boxes at once.
            let n = &self.nodes[node as usize];
            let (mask, entry) = I::hits(&boxes, n, r.tmin, r.tmax);
            // Leaves hit are tested now; inner children hit are gathered.
            let mut inner = [(0.0f32, 0u32); LANES];
            let mut k = 0;
            let mut m = mask;
            while m != 0 {
                let c = m.trailing_zeros() as usize;
                m &= m - 1;
                let (first, count) = (n.child[c], n.count[c]);
                if count == 0 {
                    inner[k] = (entry[c], first);
                    k += 1;
                } else if let Some((id, t)) = leaf(&r, first, count) {
                    r.tmax = t;
                    best = Some(id);
                }
            }
            // The nearest inner child next, the others onto the stack (farthest deepest).
            match k {
                0 => {}
                1 => {
                    if inner[0].0 <= r.tmax {
                        node = inner[0].1;
                        continue;
                    }
                }
                _ => {
                    let inner = &mut inner[..k];
                    sort_descending(inner);
                    stack.extend(inner[..k - 1].iter().copied());
                    let (t, next) = inner[k - 1];
                    if t <= r.tmax {
                        node = next;
                        continue;
                    }
                }
            }
            // Otherwise the nearest pushed node still nearer than the closest hit.
            loop {
                let Some((t, next)) = stack.pop() else {
                    return best.map(|id| (id, r.tmax));
                };
                if t <= r.tmax {
                    node = next;
                    break;
                }
            }
        }
    }

    /// Whether the leaf test `leaf(ray, first, count)` is true for any leaf that `ray`
    /// reaches within `[ray.tmin, ray.tmax]`. Stops at the first.
    #[inline(always)]
    pub fn any<I: Isa>(&self, ray: &Ray, mut leaf: impl FnMut(&Ray, u32, u32) -> bool) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let boxes = I::prepare(ray);
        let mut stack: ArrayVec<u32, STACK> = ArrayVec::new();
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            let (mut mask, _) = I::hits(&boxes, n, ray.tmin, ray.tmax);
            while mask != 0 {
                let c = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let (first, count) = (n.child[c], n.count[c]);
                if count == 0 {
                    stack.push(first);
                } else if leaf(ray, first, count) {
                    return true;
                }
            }
            match stack.pop() {
                Some(next) => node = next,
                None => return false,
            }
        }
    }
}

/// Sorts (distance, node) entries by distance, farthest first.
#[inline(always)]
fn sort_descending(e: &mut [(f32, u32)]) {
    #[inline(always)]
    fn order(e: &mut [(f32, u32)], a: usize, b: usize) {
        if e[a].0 < e[b].0 {
            e.swap(a, b);
        }
    }
    match e.len() {
        0 | 1 => {}
        2 => order(e, 0, 1),
        3 => {
            order(e, 0, 1);
            order(e, 1, 2);
            order(e, 0, 1);
        }
        4 => {
            // A sorting network of five comparisons for four.
            order(e, 0, 1);
            order(e, 2, 3);
            order(e, 0, 2);
            order(e, 1, 3);
            order(e, 1, 2);
        }
        _ => e.sort_unstable_by(|a, b| b.0.total_cmp(&a.0)),
    }
}
