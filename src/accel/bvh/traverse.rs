//! Traversal of [`Bvh`]: closest hit (front to back, with the children's entry distances
//! kept on the stack to skip subtrees beyond the closest hit found) and any hit.
//!
//! Both take the leaf test as a closure over a leaf's `(first, count)`, so the caller decides
//! what a leaf holds: a packet of triangles for the flat scene
//! ([`Bvh::number_leaves`]), a run of instances for the top level of instancing.

use super::builder::MAX_DEPTH;
use super::isa::Isa;
use super::{Bvh, LANES};
use obvhs::ray::Ray;
use std::mem::MaybeUninit;

/// Traversal stack entries: a node pushes at most `LANES - 1` (one child is visited next),
/// and the builder bounds the depth.
const STACK: usize = (LANES - 1) * MAX_DEPTH + 1;

/// A fixed stack on the call stack, left uninitialised: zero-filling its 1.3 kB for every ray
/// would cost small scenes, whose rays visit two or three nodes, more than their traversal.
struct Stack<T: Copy> {
    items: [MaybeUninit<T>; STACK],
    len: usize,
}

impl<T: Copy> Stack<T> {
    #[inline(always)]
    fn new() -> Self {
        Stack {
            items: [const { MaybeUninit::uninit() }; STACK],
            len: 0,
        }
    }

    /// Pushes `item` (the depth bound makes room; indexing checks it all the same).
    #[inline(always)]
    fn push(&mut self, item: T) {
        self.items[self.len].write(item);
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<T> {
        self.len = self.len.checked_sub(1)?;
        // SAFETY: entries below the old `len` were all written by `push`.
        Some(unsafe { self.items[self.len].assume_init() })
    }

    /// The last `n` entries pushed.
    #[inline(always)]
    fn top_mut(&mut self, n: usize) -> &mut [MaybeUninit<T>] {
        let len = self.len;
        &mut self.items[len - n..len]
    }
}

/// Rays a stream walks at once ([`Bvh::closest_stream`]).
pub const STREAM: usize = 4;

/// One ray's closest-hit traversal between two node visits.
pub struct ClosestWalk<B, P> {
    boxes: B,
    /// The ray, its `tmax` the closest hit so far.
    r: Ray,
    best: Option<u32>,
    stack: Stack<(f32, u32)>,
    /// The node to visit next.
    node: u32,
    live: bool,
    /// The caller's data for the ray's leaf tests.
    p: P,
}

/// One ray's any-hit traversal between two node visits.
pub struct AnyWalk<B, P> {
    boxes: B,
    r: Ray,
    stack: Stack<u32>,
    node: u32,
    /// Whether the walk goes on; `hit` once it has ended.
    live: bool,
    hit: bool,
    p: P,
}

impl<B, P> ClosestWalk<B, P> {
    /// The hit found: (the leaf test's identifier, distance).
    #[inline(always)]
    fn result(&self) -> Option<(u32, f32)> {
        self.best.map(|id| (id, self.r.tmax))
    }
}

impl Bvh {
    /// The closest hit on `ray` within `[ray.tmin, ray.tmax]`, as the leaf test gave it:
    /// `leaf(r, first, count)` returns the nearest hit in that leaf with a distance below
    /// `r.tmax` (the closest found so far), as (an identifier of the caller's, distance).
    // Always inlined: into the AVX2 build of the scene's traversal, it becomes AVX2 code.
    #[inline(always)]
    pub fn closest<I: Isa>(
        &self,
        isa: I,
        ray: &Ray,
        mut leaf: impl FnMut(&Ray, u32, u32) -> Option<(u32, f32)>,
    ) -> Option<(u32, f32)> {
        if self.nodes.is_empty() {
            return None;
        }
        let boxes = isa.prepare(ray);
        let mut r = *ray;
        let mut best = None;
        let mut stack: Stack<(f32, u32)> = Stack::new();
        let mut node = 0u32;
        loop {
            // Test the node's eight boxes at once.
            let n = &self.nodes[node as usize];
            let (mask, entry) = isa.hits(&boxes, n, r.tmin, r.tmax);
            let mask = mask as u8;
            // Leaves hit are tested now, shortening the ray before the nodes are ordered.
            let mut leaves = mask & n.leaves;
            while leaves != 0 {
                let c = leaves.trailing_zeros() as usize;
                leaves &= leaves - 1;
                if let Some((id, t)) = leaf(&r, n.child[c], n.count[c].into()) {
                    r.tmax = t;
                    best = Some(id);
                }
            }
            // Inner children hit: the nearest next, the others onto the stack, farthest
            // deepest. One and two, the usual cases, without sorting.
            let mut inner = mask & !n.leaves;
            if inner != 0 {
                let a = inner.trailing_zeros() as usize;
                inner &= inner - 1;
                if inner == 0 {
                    if entry[a] <= r.tmax {
                        node = n.child[a];
                        continue;
                    }
                } else {
                    let b = inner.trailing_zeros() as usize;
                    inner &= inner - 1;
                    let (near, far) = if entry[b] < entry[a] { (b, a) } else { (a, b) };
                    if inner == 0 {
                        stack.push((entry[far], n.child[far]));
                        if entry[near] <= r.tmax {
                            node = n.child[near];
                            continue;
                        }
                    } else {
                        let mut k = 2;
                        stack.push((entry[far], n.child[far]));
                        stack.push((entry[near], n.child[near]));
                        while inner != 0 {
                            let c = inner.trailing_zeros() as usize;
                            inner &= inner - 1;
                            stack.push((entry[c], n.child[c]));
                            k += 1;
                        }
                        sort_descending(stack.top_mut(k));
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

    /// The closest hits of a stream of rays, [`STREAM`] walked at once: each step visits one
    /// node of each walk in turn, so that one ray's node loads are on their way while the
    /// others' boxes are tested (on a large mesh most node visits miss the cache). Each ray's
    /// walk is [`Bvh::closest`]'s, operation for operation, so each finds the same hit.
    ///
    /// `next()` gives the stream's next ray with the caller's per-ray data `P` (what its leaf
    /// tests need) and a tag; `leaf(p, r, first, count)` is `closest`'s leaf test; `done(tag,
    /// hit)` takes each ray's result, in the order the walks end.
    #[inline(always)]
    pub fn closest_stream<I: Isa, P, T: Copy>(
        &self,
        isa: I,
        mut next: impl FnMut() -> Option<(T, Ray, P)>,
        mut leaf: impl FnMut(&P, &Ray, u32, u32) -> Option<(u32, f32)>,
        mut done: impl FnMut(T, Option<(u32, f32)>),
    ) {
        self.stream(
            #[inline(always)]
            || next().map(|(tag, ray, p)| (tag, self.start_closest(isa, &ray, p))),
            #[inline(always)]
            |walk| self.step_closest(isa, walk, &mut leaf),
            #[inline(always)]
            |tag, walk| done(tag, walk.result()),
        );
    }

    /// Whether each ray of a stream reaches a leaf whose test is true: [`Bvh::any`] over
    /// [`STREAM`] rays at once, as [`Bvh::closest_stream`] walks them. `done(tag, hit)` takes
    /// each ray's answer.
    #[inline(always)]
    pub fn any_stream<I: Isa, P, T: Copy>(
        &self,
        isa: I,
        mut next: impl FnMut() -> Option<(T, Ray, P)>,
        mut leaf: impl FnMut(&P, &Ray, u32, u32) -> bool,
        mut done: impl FnMut(T, bool),
    ) {
        self.stream(
            #[inline(always)]
            || next().map(|(tag, ray, p)| (tag, self.start_any(isa, &ray, p))),
            #[inline(always)]
            |walk| self.step_any(isa, walk, &mut leaf),
            #[inline(always)]
            |tag, walk| done(tag, walk.hit),
        );
    }

    /// Drives [`STREAM`] walks at once: `start()` begins the stream's next walk (with its
    /// tag), `step(walk)` visits a walk's next node and says whether it goes on, `done(tag,
    /// walk)` takes each walk that has ended. Each turn steps every walk once, and a slot
    /// whose walk ended takes the next ray at once.
    #[inline(always)]
    fn stream<W, T: Copy>(
        &self,
        mut start: impl FnMut() -> Option<(T, W)>,
        mut step: impl FnMut(&mut W) -> bool,
        mut done: impl FnMut(T, &W),
    ) {
        // Filled in a loop, not through `array::from_fn`: a closure that is not inlined is
        // compiled without the caller's target features, and its intrinsics become calls.
        let mut slots: [Option<(T, W)>; STREAM] = [const { None }; STREAM];
        for slot in &mut slots {
            *slot = start();
        }
        loop {
            let mut any = false;
            for slot in &mut slots {
                let Some((tag, walk)) = slot else { continue };
                any = true;
                if step(walk) {
                    continue;
                }
                done(*tag, walk);
                *slot = start();
            }
            if !any {
                return;
            }
        }
    }

    /// An any-hit walk of `ray` about to visit the root.
    #[inline(always)]
    fn start_any<I: Isa, P>(&self, isa: I, ray: &Ray, p: P) -> AnyWalk<I::BoxRay, P> {
        AnyWalk {
            boxes: isa.prepare(ray),
            r: *ray,
            stack: Stack::new(),
            node: 0,
            live: !self.nodes.is_empty(),
            hit: false,
            p,
        }
    }

    /// Visits the walk's next node, as [`Bvh::any`] does. False once the walk has ended.
    #[inline(always)]
    fn step_any<I: Isa, P, L: FnMut(&P, &Ray, u32, u32) -> bool>(
        &self,
        isa: I,
        w: &mut AnyWalk<I::BoxRay, P>,
        leaf: &mut L,
    ) -> bool {
        if !w.live {
            return false;
        }
        let n = &self.nodes[w.node as usize];
        let (mask, _) = isa.hits(&w.boxes, n, w.r.tmin, w.r.tmax);
        let mask = mask as u8;
        let mut leaves = mask & n.leaves;
        while leaves != 0 {
            let c = leaves.trailing_zeros() as usize;
            leaves &= leaves - 1;
            if leaf(&w.p, &w.r, n.child[c], n.count[c].into()) {
                (w.live, w.hit) = (false, true);
                return false;
            }
        }
        let mut inner = mask & !n.leaves;
        while inner != 0 {
            let c = inner.trailing_zeros() as usize;
            inner &= inner - 1;
            w.stack.push(n.child[c]);
        }
        match w.stack.pop() {
            Some(next) => w.node = next,
            None => w.live = false,
        }
        w.live
    }

    /// A closest-hit walk of `ray` about to visit the root, with the caller's data `p`.
    #[inline(always)]
    fn start_closest<I: Isa, P>(&self, isa: I, ray: &Ray, p: P) -> ClosestWalk<I::BoxRay, P> {
        ClosestWalk {
            boxes: isa.prepare(ray),
            r: *ray,
            best: None,
            stack: Stack::new(),
            node: 0,
            live: !self.nodes.is_empty(),
            p,
        }
    }

    /// Visits the walk's next node: tests its boxes, its leaves, and chooses the node after
    /// it. False once the walk has ended ([`ClosestWalk::result`] holds its hit).
    #[inline(always)]
    fn step_closest<I: Isa, P, L: FnMut(&P, &Ray, u32, u32) -> Option<(u32, f32)>>(
        &self,
        isa: I,
        w: &mut ClosestWalk<I::BoxRay, P>,
        leaf: &mut L,
    ) -> bool {
        if !w.live {
            return false;
        }
        // Test the node's eight boxes at once.
        let n = &self.nodes[w.node as usize];
        let (mask, entry) = isa.hits(&w.boxes, n, w.r.tmin, w.r.tmax);
        let mask = mask as u8;
        // Leaves hit are tested now, shortening the ray before the nodes are ordered.
        let mut leaves = mask & n.leaves;
        while leaves != 0 {
            let c = leaves.trailing_zeros() as usize;
            leaves &= leaves - 1;
            if let Some((id, t)) = leaf(&w.p, &w.r, n.child[c], n.count[c].into()) {
                w.r.tmax = t;
                w.best = Some(id);
            }
        }
        // Inner children hit: the nearest next, the others onto the stack, farthest
        // deepest. One and two, the usual cases, without sorting.
        let mut inner = mask & !n.leaves;
        if inner != 0 {
            let a = inner.trailing_zeros() as usize;
            inner &= inner - 1;
            if inner == 0 {
                if entry[a] <= w.r.tmax {
                    w.node = n.child[a];
                    return true;
                }
            } else {
                let b = inner.trailing_zeros() as usize;
                inner &= inner - 1;
                let (near, far) = if entry[b] < entry[a] { (b, a) } else { (a, b) };
                if inner == 0 {
                    w.stack.push((entry[far], n.child[far]));
                    if entry[near] <= w.r.tmax {
                        w.node = n.child[near];
                        return true;
                    }
                } else {
                    let mut k = 2;
                    w.stack.push((entry[far], n.child[far]));
                    w.stack.push((entry[near], n.child[near]));
                    while inner != 0 {
                        let c = inner.trailing_zeros() as usize;
                        inner &= inner - 1;
                        w.stack.push((entry[c], n.child[c]));
                        k += 1;
                    }
                    sort_descending(w.stack.top_mut(k));
                }
            }
        }
        // Otherwise the nearest pushed node still nearer than the closest hit.
        while let Some((t, next)) = w.stack.pop() {
            if t <= w.r.tmax {
                w.node = next;
                return true;
            }
        }
        w.live = false;
        false
    }

    /// Whether the leaf test `leaf(ray, first, count)` is true for any leaf that `ray`
    /// reaches within `[ray.tmin, ray.tmax]`. Stops at the first.
    #[inline(always)]
    pub fn any<I: Isa>(
        &self,
        isa: I,
        ray: &Ray,
        mut leaf: impl FnMut(&Ray, u32, u32) -> bool,
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let boxes = isa.prepare(ray);
        let mut stack: Stack<u32> = Stack::new();
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            let (mask, _) = isa.hits(&boxes, n, ray.tmin, ray.tmax);
            let mask = mask as u8;
            let mut leaves = mask & n.leaves;
            while leaves != 0 {
                let c = leaves.trailing_zeros() as usize;
                leaves &= leaves - 1;
                if leaf(ray, n.child[c], n.count[c].into()) {
                    return true;
                }
            }
            let mut inner = mask & !n.leaves;
            while inner != 0 {
                let c = inner.trailing_zeros() as usize;
                inner &= inner - 1;
                stack.push(n.child[c]);
            }
            match stack.pop() {
                Some(next) => node = next,
                None => return false,
            }
        }
    }
}

/// Sorts two to eight pushed (distance, child) entries by distance, farthest first (an
/// insertion sort: the runs are short).
#[inline(always)]
fn sort_descending(e: &mut [MaybeUninit<(f32, u32)>]) {
    // SAFETY: the caller passes entries it has just pushed, all written.
    let read = |e: &[MaybeUninit<(f32, u32)>], i: usize| unsafe { e[i].assume_init() };
    for i in 1..e.len() {
        let x = read(e, i);
        let mut j = i;
        while j > 0 && read(e, j - 1).0 < x.0 {
            e[j] = e[j - 1];
            j -= 1;
        }
        e[j].write(x);
    }
}
