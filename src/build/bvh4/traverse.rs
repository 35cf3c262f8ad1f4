//! Traversal of [`Bvh4`]: closest hit (front to back, with the children's entry distances
//! kept on the stack to skip subtrees beyond the closest hit found) and any hit.

use super::builder::MAX_DEPTH;
use super::{Bvh4, Node, GROUPS, LANES};
use arrayvec::ArrayVec;
use glam::Vec4;
use obvhs::ray::Ray;

/// Traversal stack entries: a node pushes at most `LANES - 1` (one child is visited next),
/// and the builder bounds the depth.
const STACK: usize = (LANES - 1) * MAX_DEPTH + 1;

/// Slab test margin: each box's exit distance is scaled by 1 + 2 gamma(3) (Ize, "Robust BVH
/// Ray Traversal", 2013), so that rounding in the distances never loses a box the ray grazes.
const EXIT_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// A ray prepared for box tests: origin and inverse direction splatted across lanes, and for
/// each axis which plane set (minima or maxima) the ray meets first.
struct BoxRay {
    origin: [Vec4; 3],
    inv_dir: [Vec4; 3],
    near: [usize; 3],
}

impl BoxRay {
    #[inline(always)]
    fn new(ray: &Ray) -> BoxRay {
        // obvhs's rays carry a finite inverse direction (a zero component's is huge), so
        // (plane - origin) * inverse is never 0 * inf = NaN.
        let inv = ray.inv_direction.to_array();
        BoxRay {
            origin: [
                Vec4::splat(ray.origin.x),
                Vec4::splat(ray.origin.y),
                Vec4::splat(ray.origin.z),
            ],
            inv_dir: inv.map(Vec4::splat),
            near: inv.map(|i| usize::from(i < 0.0)),
        }
    }

    /// Which of the node's boxes the ray meets within `[tmin, tmax]` (bit per child), and
    /// each box's entry distance.
    #[inline(always)]
    fn hits(&self, n: &Node, tmin: f32, tmax: f32) -> (u32, [f32; LANES]) {
        let mut mask = 0;
        let mut entries = [0.0; LANES];
        for g in 0..GROUPS {
            let slab = |axis: usize| {
                let near = n.planes[self.near[axis]][axis][g];
                let far = n.planes[1 - self.near[axis]][axis][g];
                (
                    (near - self.origin[axis]) * self.inv_dir[axis],
                    (far - self.origin[axis]) * self.inv_dir[axis],
                )
            };
            let (nx, fx) = slab(0);
            let (ny, fy) = slab(1);
            let (nz, fz) = slab(2);
            let entry = nx.max(ny).max(nz.max(Vec4::splat(tmin)));
            let exit = (fx.min(fy).min(fz) * EXIT_SCALE).min(Vec4::splat(tmax));
            mask |= entry.cmple(exit).bitmask() << (4 * g);
            entries[4 * g..4 * g + 4].copy_from_slice(&entry.to_array());
        }
        (mask, entries)
    }
}

impl Bvh4 {
    /// The closest primitive on `ray` within `[ray.tmin, ray.tmax]`, as (position in the
    /// BVH's order, distance). `test(r, k)` gives primitive `k`'s distance along `r` or
    /// infinity; `r.tmax` is the closest distance found so far.
    #[inline]
    pub fn closest(
        &self,
        ray: &Ray,
        mut test: impl FnMut(&Ray, usize) -> f32,
    ) -> Option<(usize, f32)> {
        if self.nodes.is_empty() {
            return None;
        }
        let boxes = BoxRay::new(ray);
        let mut r = *ray;
        let mut best = None;
        // Uninitialised until pushed: zero-filling it cost small scenes 10% of their rate.
        let mut stack: ArrayVec<(f32, u32), STACK> = ArrayVec::new();
        let mut node = 0u32;
        loop {
            // Test the node's four boxes at once.
            let n = &self.nodes[node as usize];
            let (mut mask, entry) = boxes.hits(n, r.tmin, r.tmax);
            // Leaves hit are intersected now; inner children hit are gathered.
            let mut inner = [(0.0f32, 0u32); LANES];
            let mut k = 0;
            while mask != 0 {
                let c = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let (first, count) = (n.child[c], n.count[c]);
                if count == 0 {
                    inner[k] = (entry[c], first);
                    k += 1;
                } else {
                    for p in first as usize..(first + count) as usize {
                        let t = test(&r, p);
                        if t < r.tmax {
                            r.tmax = t;
                            best = Some(p);
                        }
                    }
                }
            }
            // Nearest inner child next, the others onto the stack, farthest deepest.
            if k > 0 {
                let inner = &mut inner[..k];
                inner.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
                for &e in &inner[..k - 1] {
                    stack.push(e);
                }
                let (t, next) = inner[k - 1];
                if t <= r.tmax {
                    node = next;
                    continue;
                }
            }
            // Otherwise the nearest pushed node still nearer than the closest hit.
            loop {
                let Some((t, next)) = stack.pop() else {
                    return best.map(|p| (p, r.tmax));
                };
                if t <= r.tmax {
                    node = next;
                    break;
                }
            }
        }
    }

    /// Whether any primitive is on `ray` within `[ray.tmin, ray.tmax]`; `test(r, k)` says
    /// whether primitive `k` is. Stops at the first.
    #[inline]
    pub fn any(&self, ray: &Ray, mut test: impl FnMut(&Ray, usize) -> bool) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let boxes = BoxRay::new(ray);
        let mut stack: ArrayVec<u32, STACK> = ArrayVec::new();
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            let (mut mask, _) = boxes.hits(n, ray.tmin, ray.tmax);
            while mask != 0 {
                let c = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let (first, count) = (n.child[c], n.count[c]);
                if count == 0 {
                    stack.push(first);
                } else if (first..first + count).any(|p| test(ray, p as usize)) {
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
