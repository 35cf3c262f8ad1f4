//! The binned-SAH builder of [`Bvh`].
//!
//! Each primitive is one 32-byte [`Item`] (its box, with its index in a spare lane), and the
//! items are partitioned in place: the build needs no other per-primitive memory, and the
//! final order of the items is the leaf order returned to the caller.
//!
//! A node is opened into up to eight children by splitting, again and again, the child whose
//! split the surface area heuristic (SAH, 16 bins per axis, leaf costs counted in the blocks
//! its kind of leaf tests at once, [`Leaves`]) says saves most (`build_node`). Below
//! [`MEDIAN_DEPTH`] nodes split at the object median instead, so that no input (every box
//! equal, say) makes the tree deeper than the traversal stack allows.
//! Children of nodes with at least [`PARALLEL_MIN`] primitives are built in parallel, and
//! the bounds and bins of larger ranges are gathered in parallel; every reduction is a
//! min, max or integer sum, so the tree is the same whatever the thread count.

use super::{Bvh, Leaves, Node, EMPTY, LANES, MAX_LEAF};
use crate::accel::huge_pages;
use glam::{BVec4A, Vec3A, Vec4};
use obvhs::aabb::Aabb;
use rayon::prelude::*;

/// Most SAH bins per axis (a range of fewer items uses one bin per item).
const BINS: usize = 16;
/// Depth from which nodes split at the object median, in equal parts by count: [`MAX_DEPTH`]
/// then holds for any input of up to 2^32 primitives.
const MEDIAN_DEPTH: usize = 12;
/// Deepest possible tree: 12 levels of SAH, then median splits that divide by [`LANES`].
pub(super) const MAX_DEPTH: usize = MEDIAN_DEPTH + 32usize.div_ceil(LANES.ilog2() as usize) + 1;
/// Nodes with at least this many primitives build their children in parallel.
const PARALLEL_MIN: usize = 4096;
/// Ranges with at least this many primitives gather their bounds and bins in parallel.
const PARALLEL_SCAN_MIN: usize = 1 << 15;
/// Items per parallel task in those scans.
const SCAN_CHUNK: usize = 1 << 13;
/// SAH cost of visiting a node, relative to testing one block of a leaf (a packet of four
/// triangles, [`Leaves::BLOCK`]). 1 (smaller leaves) traced the 1.3 M-triangle mesh's
/// incoherent rays at 0.62-0.82x Embree's rate in runs where 2 gave 0.81-0.91x.
const TRAVERSAL_COST: f32 = 2.0;

/// One primitive during the build: its box, with its index as the bits of `lo`'s fourth lane.
#[derive(Clone, Copy)]
struct Item {
    lo: Vec4,
    hi: Vec3A,
}

impl Item {
    fn new(b: &Aabb, id: u32) -> Item {
        Item {
            lo: b.min.extend(f32::from_bits(id)),
            hi: b.max,
        }
    }

    /// The box's minimum, the index lane zeroed (read as a float the index is a denormal, and
    /// arithmetic on denormals takes microcode assists).
    #[inline(always)]
    fn min(&self) -> Vec3A {
        Vec3A::from_vec4(Vec4::select(
            BVec4A::new(true, true, true, false),
            self.lo,
            Vec4::ZERO,
        ))
    }

    fn id(&self) -> u32 {
        self.lo.w.to_bits()
    }

    /// Twice the box's centre (the factor does not change any split).
    #[inline(always)]
    fn centroid2(&self) -> Vec3A {
        self.min() + self.hi
    }
}

/// An axis-aligned box, empty as +inf/-inf.
#[derive(Clone, Copy, Debug)]
struct Bounds {
    min: Vec3A,
    max: Vec3A,
}

impl Bounds {
    const EMPTY: Bounds = Bounds {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
    };

    #[inline(always)]
    fn grow(&mut self, min: Vec3A, max: Vec3A) {
        self.min = self.min.min(min);
        self.max = self.max.max(max);
    }

    fn union(self, o: Bounds) -> Bounds {
        Bounds {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Half the surface area (0 for an empty box).
    fn half_area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3A::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

/// The boxes' bounds and their centres' (doubled) bounds over a range of items.
#[derive(Clone, Copy)]
struct Summary {
    boxes: Bounds,
    centres: Bounds,
}

impl Summary {
    const EMPTY: Summary = Summary {
        boxes: Bounds::EMPTY,
        centres: Bounds::EMPTY,
    };

    fn of(items: &[Item]) -> Summary {
        if items.len() >= PARALLEL_SCAN_MIN {
            return items
                .par_chunks(SCAN_CHUNK)
                .map(Summary::of)
                .reduce(|| Summary::EMPTY, Summary::merge);
        }
        let mut s = Summary::EMPTY;
        for it in items {
            s.add(it, it.centroid2());
        }
        s
    }

    /// Adds one item, whose doubled centre is `c2`.
    #[inline(always)]
    fn add(&mut self, it: &Item, c2: Vec3A) {
        self.boxes.grow(it.min(), it.hi);
        self.centres.grow(c2, c2);
    }

    fn merge(self, o: Summary) -> Summary {
        Summary {
            boxes: self.boxes.union(o.boxes),
            centres: self.centres.union(o.centres),
        }
    }
}

/// Maps doubled centres to bins along each axis.
#[derive(Clone, Copy, Debug)]
struct Binning {
    /// Bins in use per axis (at most [`BINS`]).
    bins: usize,
    origin: Vec3A,
    /// Bins per unit along each axis; 0 along an axis where every centre is equal.
    scale: Vec3A,
    /// The last bin's index, as a float.
    last: f32,
}

/// 2^23: adding it to a float in `[0, 2^22)` rounds it to an integer held in the low bits of
/// the sum's mantissa, a float-to-integer conversion with no range checks to pay for.
const TO_INTEGER: f32 = 8_388_608.0;

impl Binning {
    fn new(centres: &Bounds, items: usize) -> Binning {
        let bins = items.clamp(2, BINS);
        let extent = centres.max - centres.min;
        let scale = Vec3A::select(
            extent.cmpgt(Vec3A::ZERO),
            Vec3A::splat(bins as f32 * (1.0 - 1e-6)) / extent,
            Vec3A::ZERO,
        );
        Binning {
            bins,
            origin: centres.min,
            scale,
            last: (bins - 1) as f32,
        }
    }

    /// The bins of centre `c2` along the three axes. Bin `k` holds the centres whose offset,
    /// in bins, is in `[k, k + 1)` (up to rounding at the boundary: binning and
    /// partitioning use this same function, which is all a split needs).
    #[inline(always)]
    fn bins(&self, c2: Vec3A) -> [usize; 3] {
        let offset = (c2 - self.origin) * self.scale - Vec3A::splat(0.5);
        let clamped = offset.max(Vec3A::ZERO).min(Vec3A::splat(self.last));
        (clamped + Vec3A::splat(TO_INTEGER))
            .to_array()
            .map(|x| (x.to_bits() & 0xff) as usize)
    }

    /// The bin of centre `c2` along `axis`: the same as [`Binning::bins`]'s, lane by lane.
    #[inline(always)]
    fn bin(&self, c2: Vec3A, axis: usize) -> usize {
        self.bins(c2)[axis]
    }
}

#[derive(Clone, Copy)]
struct Bin {
    bounds: Bounds,
    count: u32,
}

impl Bin {
    const EMPTY: Bin = Bin {
        bounds: Bounds::EMPTY,
        count: 0,
    };

    fn merge(&mut self, o: &Bin) {
        self.bounds = self.bounds.union(o.bounds);
        self.count += o.count;
    }
}

/// `B` bins per axis.
type Bins<const B: usize> = [[Bin; B]; 3];

/// Adds `items` to `bins` (the caller's, filled with [`Bin::EMPTY`], at least as many per axis
/// as the binning uses). The caller sizes them to the range: most ranges are small, and
/// filling sixteen bins per axis (2.3 kB) for a handful of items cost more than binning them.
fn bin_items<const B: usize>(items: &[Item], binning: &Binning, bins: &mut Bins<B>) {
    if items.len() >= PARALLEL_SCAN_MIN {
        let parts = items
            .par_chunks(SCAN_CHUNK)
            .map(|c| {
                let mut b = [[Bin::EMPTY; B]; 3];
                bin_items(c, binning, &mut b);
                b
            })
            .collect::<Vec<_>>();
        for part in &parts {
            for (axis, axis_part) in bins.iter_mut().zip(part) {
                for (x, y) in axis.iter_mut().zip(axis_part) {
                    x.merge(y);
                }
            }
        }
        return;
    }
    for it in items {
        let (min, c) = (it.min(), it.centroid2());
        for (axis_bins, bin) in bins.iter_mut().zip(binning.bins(c)) {
            let b = &mut axis_bins[bin];
            b.bounds.grow(min, it.hi);
            b.count += 1;
        }
    }
}

/// How to split a range of items in two.
#[derive(Clone, Copy, Debug)]
enum Plan {
    /// A single item.
    None,
    /// Items whose centre falls in bins `..=bin` along `axis` go left.
    Split {
        axis: usize,
        bin: usize,
        binning: Binning,
    },
    /// Split at the median centre along `axis`.
    Median { axis: usize },
}

/// A contiguous range of the node's items, with its bounds, whether it is best left a leaf,
/// and how to split it.
#[derive(Clone, Copy, Debug)]
struct Range {
    start: usize,
    end: usize,
    bounds: Bounds,
    leaf: bool,
    plan: Plan,
    /// What splitting in two would save, in SAH units (area x leaf cost), if both halves
    /// stayed leaves in the same node: how much a leaf gains from taking a free lane.
    split_gain: f32,
}

impl Range {
    fn len(&self) -> usize {
        self.end - self.start
    }

    /// Which child to open next: the largest by area, or by count for median splits, so that
    /// seven median splits divide a node into eighths and the depth bound holds.
    fn priority(&self) -> f32 {
        match self.plan {
            Plan::Median { .. } => self.len() as f32,
            _ => self.bounds.half_area(),
        }
    }

    /// Summarises `items[start..end]` and decides its plan at `depth`.
    fn new<L: Leaves>(items: &[Item], start: usize, end: usize, depth: u32) -> Range {
        Range::summarised::<L>(items, start, end, depth, Summary::of(&items[start..end]))
    }

    /// [`Range::new`] for a range whose summary `s` is already known.
    fn summarised<L: Leaves>(
        items: &[Item],
        start: usize,
        end: usize,
        depth: u32,
        s: Summary,
    ) -> Range {
        let slice = &items[start..end];
        let n = slice.len();
        let extent = s.centres.max - s.centres.min;
        let widest = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let (leaf, plan, split_gain) = if n == 1 {
            (true, Plan::None, 0.0)
        } else if depth as usize >= MEDIAN_DEPTH {
            (n <= L::MAX, Plan::Median { axis: widest }, 0.0)
        } else {
            // Bins sized to the range (see `bin_items`).
            match n {
                ..=4 => sah_plan::<L, 4>(slice, &s, n, widest),
                5..=8 => sah_plan::<L, 8>(slice, &s, n, widest),
                _ => sah_plan::<L, BINS>(slice, &s, n, widest),
            }
        };
        Range {
            start,
            end,
            bounds: s.boxes,
            leaf,
            plan,
            split_gain,
        }
    }
}

/// SAH cost of testing `n` primitives in a leaf, which tests them `L::BLOCK` at a time.
#[inline(always)]
fn leaf_cost<L: Leaves>(n: u32) -> f32 {
    n.div_ceil(L::BLOCK as u32) as f32
}

/// The cheapest binned split of `items` by the SAH, whether a leaf (if allowed) is cheaper,
/// and what the split would save a leaf that has a free lane to split into
/// ([`Range::split_gain`]).
fn sah_plan<L: Leaves, const B: usize>(
    items: &[Item],
    s: &Summary,
    n: usize,
    widest: usize,
) -> (bool, Plan, f32) {
    let binning = Binning::new(&s.centres, n.min(B));
    let nb = binning.bins;
    let mut bins = [[Bin::EMPTY; B]; 3];
    bin_items(items, &binning, &mut bins);
    let mut best: Option<(f32, usize, usize)> = None;
    for (axis, axis_bins) in bins.iter().enumerate() {
        if binning.scale[axis] == 0.0 {
            continue;
        }
        // Right-hand costs (area x count of bins k..) from the right, then the sweep.
        let mut right = [0.0f32; B];
        let (mut rb, mut rc) = (Bounds::EMPTY, 0u32);
        for k in (1..nb).rev() {
            rb = rb.union(axis_bins[k].bounds);
            rc += axis_bins[k].count;
            right[k] = rb.half_area() * leaf_cost::<L>(rc);
        }
        let (mut lb, mut lc) = (Bounds::EMPTY, 0u32);
        for k in 0..nb - 1 {
            lb = lb.union(axis_bins[k].bounds);
            lc += axis_bins[k].count;
            if lc == 0 || lc as usize == n {
                continue;
            }
            let cost = lb.half_area() * leaf_cost::<L>(lc) + right[k + 1];
            if best.is_none_or(|(c, ..)| cost < c) {
                best = Some((cost, axis, k));
            }
        }
    }
    let area = s.boxes.half_area();
    match best {
        Some((cost, axis, bin)) => {
            let split_cost = TRAVERSAL_COST + cost / area.max(f32::MIN_POSITIVE);
            let leaf = n <= L::MAX && leaf_cost::<L>(n as u32) <= split_cost;
            let gain = area * leaf_cost::<L>(n as u32) - cost;
            (leaf, Plan::Split { axis, bin, binning }, gain)
        }
        // Every centre in one bin (equal centres): any order is as good as another.
        None => (n <= L::MAX, Plan::Median { axis: widest }, 0.0),
    }
}

/// Carries out `r`'s plan (not a leaf) on `items`: the two halves as ranges at `depth`.
fn split<L: Leaves>(items: &mut [Item], r: &Range, depth: u32) -> (Range, Range) {
    let slice = &mut items[r.start..r.end];
    // The halves' summaries, gathered by the partition when it visits each item anyway.
    let mut halves = None;
    let mid = match r.plan {
        Plan::Split { axis, bin, binning } => {
            let left = |c2: Vec3A| binning.bin(c2, axis) <= bin;
            // In-place partition, left items first; each item is classified once, and
            // added to its side's summary then.
            let (mut ls, mut rs) = (Summary::EMPTY, Summary::EMPTY);
            let (mut i, mut j) = (0, slice.len());
            loop {
                while i < j {
                    let c2 = slice[i].centroid2();
                    if !left(c2) {
                        break;
                    }
                    ls.add(&slice[i], c2);
                    i += 1;
                }
                while i < j {
                    let c2 = slice[j - 1].centroid2();
                    if left(c2) {
                        break;
                    }
                    rs.add(&slice[j - 1], c2);
                    j -= 1;
                }
                if i >= j {
                    break;
                }
                // slice[i] goes right and slice[j - 1] left (i < j - 1: they differ).
                rs.add(&slice[i], slice[i].centroid2());
                ls.add(&slice[j - 1], slice[j - 1].centroid2());
                slice.swap(i, j - 1);
                i += 1;
                j -= 1;
            }
            halves = Some((ls, rs));
            i
        }
        Plan::Median { axis } => {
            let mid = slice.len() / 2;
            slice.select_nth_unstable_by(mid, |a, b| {
                a.centroid2()[axis].total_cmp(&b.centroid2()[axis])
            });
            mid
        }
        Plan::None => unreachable!("a single item is never split"),
    };
    // A split plan puts items on both sides by construction; guard anyway.
    let (mid, halves) = if mid == 0 || mid == slice.len() {
        (slice.len() / 2, None)
    } else {
        (mid, halves)
    };
    let mid = r.start + mid;
    let (ls, rs) = halves.unwrap_or_else(|| {
        (
            Summary::of(&items[r.start..mid]),
            Summary::of(&items[mid..r.end]),
        )
    });
    (
        Range::summarised::<L>(items, r.start, mid, depth, ls),
        Range::summarised::<L>(items, mid, r.end, depth, rs),
    )
}

/// Builds the subtree of `r` (not a leaf) over `items` (the node's range, whose first item
/// is at `offset` in the whole array) into `out`, returning its root's index in `out`.
fn build_node<L: Leaves>(
    items: &mut [Item],
    offset: usize,
    r: Range,
    depth: u32,
    out: &mut Vec<Node>,
) -> u32 {
    // Open the node into up to eight children, one split at a time. Below the SAH levels
    // the child with the most primitives is split. Otherwise the split that saves most:
    // splitting a child that would be a node saves that node's visit (its area times the
    // traversal cost), splitting a leaf saves its `split_gain` (two walls of a room in one
    // leaf make a box the size of the room, which every ray enters).
    let mut kids = [r; LANES];
    let mut len = 1;
    while len < LANES {
        let gain = |k: &Range| match k.plan {
            Plan::None => None,
            Plan::Median { .. } if k.leaf => None,
            Plan::Median { .. } => Some(k.priority()),
            Plan::Split { .. } if k.leaf => (k.split_gain > 0.0).then_some(k.split_gain),
            Plan::Split { .. } => Some(k.bounds.half_area() * TRAVERSAL_COST),
        };
        let best = (0..len)
            .filter_map(|i| gain(&kids[i]).map(|g| (i, g)))
            .max_by(|a, b| a.1.total_cmp(&b.1));
        let Some((i, _)) = best else {
            break;
        };
        let (a, b) = split::<L>(items, &kids[i], depth + 1);
        kids.copy_within(i + 1..len, i + 2);
        kids[i] = a;
        kids[i + 1] = b;
        len += 1;
    }
    let kids = &kids[..len];

    let index = out.len();
    out.push(Node::EMPTY);
    let mut node = Node::EMPTY;
    for (c, k) in kids.iter().enumerate() {
        node.set_box(c, k.bounds.min, k.bounds.max);
        if k.leaf {
            node.child[c] = (offset + k.start) as u32;
            node.count[c] = k.len() as u8;
        }
    }

    if r.len() >= PARALLEL_MIN {
        // Children's subtrees in parallel, each into its own array, then appended in order.
        let mut jobs = Vec::with_capacity(LANES);
        let mut rest = &mut items[..];
        let mut taken = 0;
        for (c, k) in kids.iter().enumerate() {
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(k.end - taken);
            rest = tail;
            let own = &mut head[k.start - taken..];
            taken = k.end;
            if !k.leaf {
                let local = Range {
                    start: 0,
                    end: k.len(),
                    ..*k
                };
                jobs.push((c, own, offset + k.start, local));
            }
        }
        let subtrees: Vec<(usize, Vec<Node>)> = jobs
            .into_par_iter()
            .map(|(c, own, off, local)| {
                let mut v = Vec::new();
                build_node::<L>(own, off, local, depth + 1, &mut v);
                (c, v)
            })
            .collect();
        for (c, mut v) in subtrees {
            let base = out.len() as u32;
            for n in &mut v {
                for i in 0..LANES {
                    if n.count[i] == 0 && n.child[i] != EMPTY {
                        n.child[i] += base;
                    }
                }
            }
            node.child[c] = base;
            out.append(&mut v);
        }
    } else {
        for (c, k) in kids.iter().enumerate() {
            if !k.leaf {
                let local = Range {
                    start: 0,
                    end: k.len(),
                    ..*k
                };
                node.child[c] = build_node::<L>(
                    &mut items[k.start..k.end],
                    offset + k.start,
                    local,
                    depth + 1,
                    out,
                );
            }
        }
    }
    out[index] = node;
    index as u32
}

impl Bvh {
    /// Builds the BVH over `n` primitives whose boxes `box_of` gives, on the current rayon
    /// pool, for leaves of the kind `L` (how many primitives they hold and test at once: the
    /// SAH counts a leaf's cost in such blocks). Returns it with the primitives' order: leaf
    /// entries refer to positions in that order, so primitive `order[k]` must be stored at
    /// position `k`.
    pub fn build<L: Leaves>(n: usize, box_of: impl Fn(usize) -> Aabb + Sync) -> (Bvh, Vec<u32>) {
        const { assert!(L::MAX >= 1 && L::MAX <= MAX_LEAF && L::BLOCK >= 1) };
        if n == 0 {
            return (Bvh::default(), Vec::new());
        }
        let mut items: Vec<Item> = huge_pages::collect(
            (0..n)
                .into_par_iter()
                .map(|i| Item::new(&box_of(i), i as u32)),
        );
        let root = Range::new::<L>(&items, 0, n, 0);
        let mut nodes = Vec::new();
        if root.leaf {
            // A handful of primitives: one node with one leaf.
            let mut node = Node::EMPTY;
            node.set_box(0, root.bounds.min, root.bounds.max);
            node.child[0] = 0;
            node.count[0] = n as u8;
            nodes.push(node);
        } else {
            build_node::<L>(&mut items, 0, root, 0, &mut nodes);
        }
        for node in &mut nodes {
            node.mark_leaves();
        }
        let nodes = huge_pages::copy_of(nodes);
        let order = items.iter().map(Item::id).collect();
        (Bvh { nodes }, order)
    }
}
