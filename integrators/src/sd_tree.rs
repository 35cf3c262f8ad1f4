//! The spatio-directional tree (SD-tree) of Müller, Gross and Novák, "Practical Path Guiding
//! for Efficient Light-Transport Simulation" (EGSR 2017): a learned approximation of the
//! incident radiance field, sampled to guide the directions a path tracer continues in.
//!
//! * **Space.** A binary tree over a cube enclosing the scene (slightly enlarged). A node is
//!   split at its midpoint; the axis alternates `x`, `y`, `z` with depth. Every spatial leaf
//!   holds two directional distributions: the *sampling* one (learned in the last iteration,
//!   used through [`SdTree::at`]: [`Guide::sample`] and [`Guide::pdf`]) and the *building*
//!   one (gathering this iteration's records).
//! * **Directions.** A quadtree over the unit square, mapped to the sphere by the cylindrical
//!   (equal-area) map `dir = (sqrt(1 - c^2) cos phi, sqrt(1 - c^2) sin phi, c)` with
//!   `c = 2 s.x - 1` and `phi = 2 pi s.y`, whose Jacobian is the constant `4 pi`. Each node
//!   splits its square into four quadrants (`x` half in bit 0, `y` half in bit 1) and keeps
//!   the energy recorded in each. Sampling descends choosing quadrants in proportion to their
//!   energy; a node with no energy at all is uniform.
//! * **Training.** Rendering alternates between [`SdTree::record`] (Monte Carlo estimates of
//!   incident radiance over the density of their direction) and [`SdTree::refine`], which
//!   makes the gathered energy the sampling distribution, splits spatial leaves that received
//!   more than `c sqrt(2^iteration)` records (children copy the parent's distribution), and
//!   rebuilds each quadtree for the next iteration: quadrants holding more than a fraction
//!   `flux_threshold` of their leaf's energy are subdivided (to depth 20), the others are
//!   collapsed.
//! * **Determinism.** Nothing here uses threads or hashing: records are applied one after
//!   another in the caller's order (so the caller must pass them in a fixed order, e.g.
//!   sorted by pixel and sample), energies are summed in `f64`, and refinement visits leaves
//!   and nodes in a fixed order. The same records give the same tree bit for bit, whatever
//!   the thread count of the renderer.
//!
//! Records are deposited in the one leaf and the one quadrant they fall in (the paper's
//! nearest-neighbour splatting; the box filters of the authors' later code are not used).
//! Sampling and density evaluation never allocate.

use glam::{Vec2, Vec3A};

/// Deepest level of a directional quadtree (the paper's 20): its finest cells are `2^-20`
/// of the square on a side.
const MAX_DIRECTIONAL_DEPTH: u32 = 20;
/// Smallest flux threshold [`SdTree::refine`] uses (smaller ones, and NaN, are raised to it),
/// which bounds a quadtree to about `MAX_DIRECTIONAL_DEPTH / MIN_FLUX_THRESHOLD` nodes.
const MIN_FLUX_THRESHOLD: f64 = 1e-4;
/// The paper's flux threshold, which shapes the first gathering tree (16 x 16 cells).
const FIRST_FLUX_THRESHOLD: f64 = 0.01;
/// Deepest level of the spatial tree: 20 splits per axis, a millionth of the cube's side.
const MAX_SPATIAL_DEPTH: u32 = 60;
/// Relative enlargement of the cube around the scene's box (as the paper does).
const BOX_MARGIN: f32 = 0.01;
/// The largest `f32` below 1.
const ONE_BELOW_F32: f32 = 1.0 - f32::EPSILON / 2.0;
/// The largest `f64` below 1.
const ONE_BELOW_F64: f64 = 1.0 - f64::EPSILON / 2.0;
/// Density conversion from the unit square to the sphere: the map's Jacobian is `4 pi`.
const INV_FOUR_PI: f64 = 0.25 * std::f64::consts::FRAC_1_PI;
/// Marks a quadrant without a child node (the root, index 0, is nobody's child).
const LEAF: u32 = 0;

/// One training record: at point `p`, radiance arriving from direction `dir` (unit, world
/// space), as the Monte Carlo estimate `value` = luminance(L_i) / pdf(dir) (pdf the
/// solid-angle density with which dir was sampled). `value` >= 0 and finite (others are
/// skipped).
#[derive(Clone, Copy, Debug)]
pub struct Record {
    /// Where the radiance arrives (world space).
    pub p: Vec3A,
    /// Where it comes from: a unit direction pointing away from `p` (world space).
    pub dir: Vec3A,
    /// Luminance of the incident radiance over the solid-angle density of `dir`.
    pub value: f32,
}

/// A spatio-directional tree: a binary tree over space whose leaves hold quadtrees over
/// directions (see the module documentation).
#[derive(Clone, Debug)]
pub struct SdTree {
    /// The cube's minimum corner.
    origin: Vec3A,
    /// One over the cube's side.
    inv_side: f32,
    /// The spatial tree; node 0 is the root.
    nodes: Vec<SpatialNode>,
    /// The directional distributions of the spatial leaves.
    leaves: Vec<Directions>,
}

/// A node of the spatial tree.
#[derive(Clone, Copy, Debug)]
enum SpatialNode {
    /// A leaf, with the index of its distributions in [`SdTree::leaves`].
    Leaf(u32),
    /// Split at the midpoint along `axis` (0, 1, 2 for `x`, `y`, `z`): `children[0]` below
    /// it, `children[1]` above.
    Split { axis: u8, children: [u32; 2] },
}

/// What a spatial leaf holds.
#[derive(Clone, Debug)]
struct Directions {
    /// The distribution learned in the last iteration, used for sampling.
    sampling: DTree,
    /// The distribution gathering this iteration's records.
    building: DTree,
    /// Records received this iteration (including those of zero value).
    records: u64,
}

impl Directions {
    /// Both distributions uniform, no records; the first records gather into a uniform
    /// tree a few levels deep (the authors' first iteration), not into four quadrants.
    fn new() -> Directions {
        Directions {
            sampling: DTree::uniform(),
            building: DTree::uniform().rebuilt(MAX_DIRECTIONAL_DEPTH, FIRST_FLUX_THRESHOLD),
            records: 0,
        }
    }
}

/// A node of a directional quadtree: four quadrants, each a leaf or a child node, and the
/// energy recorded in each.
#[derive(Clone, Copy, Debug)]
struct QuadNode {
    /// Child node of each quadrant, or [`LEAF`].
    children: [u32; 4],
    /// Energy recorded in each quadrant (the whole subtree's).
    sums: [f64; 4],
}

impl QuadNode {
    /// Four leaf quadrants without energy.
    const EMPTY: QuadNode = QuadNode {
        children: [LEAF; 4],
        sums: [0.0; 4],
    };

    /// The energy of the node: left column plus right column, the same sums `sample` uses.
    #[inline]
    fn total(&self) -> f64 {
        (self.sums[0] + self.sums[2]) + (self.sums[1] + self.sums[3])
    }

    /// The density factor of quadrant `q` relative to the node's square: four times its share
    /// of the energy, or 1 when the node has none (uniform).
    #[inline]
    fn factor(&self, q: usize) -> f64 {
        let total = self.total();
        if total > 0.0 && total.is_finite() {
            4.0 * self.sums[q] / total
        } else {
            1.0
        }
    }
}

/// Where a node of a rebuilt quadtree takes its energy from (to decide on subdivision).
#[derive(Clone, Copy, Debug)]
enum Source {
    /// A node of the old tree.
    Node(usize),
    /// A quadrant of the old tree of this energy, without a node: spread evenly.
    Spread(f64),
}

/// A directional distribution: a quadtree over the unit square, node 0 the root.
#[derive(Clone, Debug)]
struct DTree {
    nodes: Vec<QuadNode>,
}

impl DTree {
    /// One node without energy: the uniform distribution.
    fn uniform() -> DTree {
        DTree {
            nodes: vec![QuadNode::EMPTY],
        }
    }

    /// Adds `value` to every quadrant on the way from the root to the leaf holding `s`.
    fn record(&mut self, s: [f32; 2], value: f64) {
        let [mut x, mut y] = s;
        let mut index = 0usize;
        // A path visits each node at most once.
        for _ in 0..self.nodes.len() {
            let Some(node) = self.nodes.get_mut(index) else {
                return;
            };
            let q = descend(&mut x, &mut y);
            node.sums[q] += value;
            match node.children[q] {
                LEAF => return,
                child => index = child as usize,
            }
        }
    }

    /// A point of the unit square for `u` and its density per unit area; `None` if the
    /// density underflows (a degenerate distribution).
    fn sample(&self, u: Vec2) -> Option<([f64; 2], f64)> {
        // Work in f64: every level rescales u, spending one bit per axis.
        let mut u = [f64::from(clamp01(u.x)), f64::from(clamp01(u.y))];
        let (mut origin, mut size, mut density) = ([0.0f64; 2], 1.0f64, 1.0f64);
        let mut index = 0usize;
        for _ in 0..self.nodes.len() {
            let node = self.nodes.get(index)?;
            let s = node.sums;
            let total = node.total();
            // The column in proportion to its energy, then the row within it; a node without
            // energy halves u.
            let (col, row) = if total > 0.0 && total.is_finite() {
                let col = choose(&mut u[0], (s[0] + s[2]) / total);
                let column = s[col] + s[col + 2];
                let p_low = if column > 0.0 { s[col] / column } else { 0.5 };
                (col, choose(&mut u[1], p_low))
            } else {
                (choose(&mut u[0], 0.5), choose(&mut u[1], 0.5))
            };
            let q = col | (row << 1);
            density *= node.factor(q);
            size *= 0.5;
            origin[0] += col as f64 * size;
            origin[1] += row as f64 * size;
            match node.children[q] {
                LEAF => {
                    // Uniform within the leaf quadrant.
                    let point = [origin[0] + u[0] * size, origin[1] + u[1] * size];
                    return (density > 0.0 && density.is_finite()).then_some((point, density));
                }
                child => index = child as usize,
            }
        }
        None
    }

    /// The density per unit area with which [`DTree::sample`] returns `s`.
    fn pdf(&self, s: [f32; 2]) -> f64 {
        let [mut x, mut y] = s;
        let (mut density, mut index) = (1.0f64, 0usize);
        for _ in 0..self.nodes.len() {
            let Some(node) = self.nodes.get(index) else {
                return 0.0;
            };
            let q = descend(&mut x, &mut y);
            density *= node.factor(q);
            match node.children[q] {
                LEAF => return density,
                child => index = child as usize,
            }
        }
        0.0
    }

    /// The structure for the next iteration, without energy: a quadrant is subdivided when
    /// its share of this tree's energy exceeds `threshold` (and its level is below
    /// `max_depth`), where a quadrant that was a leaf here spreads its energy evenly over
    /// its new children. Without energy, the share of a quadrant at level `d` is taken as
    /// `4^-d`, which gives a uniform tree a few levels deep.
    fn rebuilt(&self, max_depth: u32, threshold: f64) -> DTree {
        let total = self.nodes.first().map_or(0.0, QuadNode::total);
        let has_energy = total > 0.0 && total.is_finite();
        let mut nodes = vec![QuadNode::EMPTY];
        // (node of the new tree, its energy's source, the level of its quadrants)
        let mut stack = vec![(0usize, Source::Node(0), 1u32)];
        while let Some((new, source, level)) = stack.pop() {
            // Each quadrant's energy and the source of its child's.
            let quadrants: [(f64, Source); 4] = match source {
                Source::Node(i) => match self.nodes.get(i) {
                    Some(old) => std::array::from_fn(|q| {
                        let energy = old.sums[q];
                        match old.children[q] {
                            LEAF => (energy, Source::Spread(energy)),
                            child => (energy, Source::Node(child as usize)),
                        }
                    }),
                    None => [(0.0, Source::Spread(0.0)); 4],
                },
                Source::Spread(e) => [(0.25 * e, Source::Spread(0.25 * e)); 4],
            };
            for (q, (energy, child_source)) in quadrants.into_iter().enumerate() {
                let share = if has_energy {
                    energy / total
                } else {
                    0.25f64.powi(level as i32)
                };
                // (Neither is NaN: the energies are finite and the threshold was clamped.)
                if level >= max_depth || share <= threshold {
                    continue;
                }
                let Ok(child) = u32::try_from(nodes.len()) else {
                    continue;
                };
                nodes.push(QuadNode::EMPTY);
                if let Some(node) = nodes.get_mut(new) {
                    node.children[q] = child;
                }
                stack.push((child as usize, child_source, level + 1));
            }
        }
        DTree { nodes }
    }
}

/// The quadrant of `(x, y)` (both in `[0, 1)`), rescaling them to the quadrant (exactly:
/// doubling and subtracting 1 lose nothing).
#[inline]
fn descend(x: &mut f32, y: &mut f32) -> usize {
    let (bx, by) = (*x >= 0.5, *y >= 0.5);
    *x = 2.0 * *x - if bx { 1.0 } else { 0.0 };
    *y = 2.0 * *y - if by { 1.0 } else { 0.0 };
    usize::from(bx) | (usize::from(by) << 1)
}

/// Chooses the first of two parts of `[0, 1)` (of probability `p_first`) or the second by
/// `u`, and rescales `u` to the chosen part.
#[inline]
fn choose(u: &mut f64, p_first: f64) -> usize {
    if *u < p_first {
        *u = (*u / p_first).min(ONE_BELOW_F64);
        0
    } else {
        *u = ((*u - p_first) / (1.0 - p_first)).clamp(0.0, ONE_BELOW_F64);
        1
    }
}

/// `x` clamped to `[0, 1)`; NaN becomes 0.
#[inline]
fn clamp01(x: f32) -> f32 {
    if x >= 0.0 {
        x.min(ONE_BELOW_F32)
    } else {
        0.0
    }
}

/// The direction of a point of the unit square (the cylindrical equal-area map).
fn square_to_dir(s: [f64; 2]) -> Vec3A {
    let c = (2.0 * s[0] - 1.0).clamp(-1.0, 1.0);
    let r = (1.0 - c * c).max(0.0).sqrt();
    let (sin, cos) = (std::f64::consts::TAU * s[1]).sin_cos();
    Vec3A::new((r * cos) as f32, (r * sin) as f32, c as f32)
}

/// The point of the unit square (clamped to `[0, 1)^2`) of a direction, which need not be
/// normalised; `None` for a zero or non-finite vector.
fn dir_to_square(d: Vec3A) -> Option<[f32; 2]> {
    if !d.is_finite() {
        return None;
    }
    // Scaled first so that the length cannot overflow.
    let m = d.abs().max_element();
    if m <= 0.0 {
        return None;
    }
    let d = d / m;
    let z = (d.z / d.length()).clamp(-1.0, 1.0);
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += std::f32::consts::TAU;
    }
    Some([
        clamp01(0.5 * (z + 1.0)),
        clamp01(phi * (1.0 / std::f32::consts::TAU)),
    ])
}

impl SdTree {
    /// A tree over the box `[lo, hi]` (made a cube around the box's centre, its side the
    /// largest extent enlarged by 1%, as the paper does) with one spatial leaf whose
    /// directional distribution is uniform over the sphere. Corners in either order are
    /// accepted; a flat or point-like box gets a small cube; a non-finite box becomes
    /// `[-1, 1]^3`.
    pub fn new(lo: Vec3A, hi: Vec3A) -> SdTree {
        let (lo, hi) = if lo.is_finite() && hi.is_finite() {
            (lo.min(hi), lo.max(hi))
        } else {
            (Vec3A::splat(-1.0), Vec3A::ONE)
        };
        // The cube, never of zero side, and the fallback if the box is too large for f32.
        let center = 0.5 * lo + 0.5 * hi;
        let floor = 1e-4 * (1.0 + center.abs().max_element());
        let side = ((hi - lo).max_element() * (1.0 + BOX_MARGIN)).max(floor);
        let origin = center - Vec3A::splat(0.5 * side);
        let (origin, side) = if side.is_finite() && origin.is_finite() {
            (origin, side)
        } else {
            (Vec3A::splat(-1.0), 2.0)
        };
        SdTree {
            origin,
            inv_side: 1.0 / side,
            nodes: vec![SpatialNode::Leaf(0)],
            leaves: vec![Directions::new()],
        }
    }

    /// Adds records to the statistics being gathered (does not change the sampling
    /// distribution). Sequential and order-deterministic: the caller passes records in a
    /// fixed order. Records with non-finite `p`/`dir`/`value` or `value < 0` (or a zero
    /// `dir`) are ignored; positions outside the box are clamped into it.
    pub fn record(&mut self, records: &[Record]) {
        for r in records {
            if !(r.p.is_finite() && r.value.is_finite() && r.value >= 0.0) {
                continue;
            }
            let Some(s) = dir_to_square(r.dir) else {
                continue;
            };
            let Some(leaf) = self.locate(r.p).and_then(|l| self.leaves.get_mut(l)) else {
                continue;
            };
            // Zero-valued records count towards the spatial split but add no energy.
            leaf.records += 1;
            if r.value > 0.0 {
                leaf.building.record(s, f64::from(r.value));
            }
        }
    }

    /// Ends a training iteration (`iteration` = 0, 1, 2, ... counting refinements): the
    /// gathered statistics become the sampling distribution, then the structure is refined
    /// for the next iteration. Spatial leaves that received more than
    /// `spatial_threshold * sqrt(2^iteration)` records (the paper's `c` is 12000) split at
    /// the midpoint along alternating axes, the children copying the parent's directional
    /// distribution and each taking half its record count (so that a leaf far above the
    /// threshold splits again). Each directional quadtree is then rebuilt from its gathered
    /// energy: a quadrant is subdivided when its share of the leaf's energy exceeds
    /// `flux_threshold` (the paper's 0.01), up to depth 20, and quadrants below it are
    /// collapsed. Statistics are reset to zero. A distribution that gathered no energy
    /// becomes uniform.
    ///
    /// Odd thresholds do not explode the tree: a spatial threshold below 1 is taken as 1 and
    /// a NaN one as infinite (no split); a flux threshold below 1e-4 (or NaN) is taken as
    /// 1e-4. Deterministic: leaves and nodes are visited in a fixed order.
    pub fn refine(&mut self, iteration: u32, spatial_threshold: f32, flux_threshold: f32) {
        // The gathered energy becomes the sampling distribution; keep the record counts.
        let mut counts = Vec::with_capacity(self.leaves.len());
        for leaf in &mut self.leaves {
            leaf.sampling = std::mem::replace(&mut leaf.building, DTree::uniform());
            counts.push(leaf.records as f64);
            leaf.records = 0;
        }
        // Split the spatial leaves that saw enough records.
        let threshold = if spatial_threshold.is_nan() {
            f64::INFINITY
        } else {
            let growth = (0.5 * f64::from(iteration.min(4096))).exp2();
            (f64::from(spatial_threshold) * growth).max(1.0)
        };
        self.split_leaves(&counts, threshold);
        // Rebuild every quadtree for the next iteration from the energy it gathered.
        let flux = f64::from(flux_threshold).max(MIN_FLUX_THRESHOLD);
        for leaf in &mut self.leaves {
            leaf.building = leaf.sampling.rebuilt(MAX_DIRECTIONAL_DEPTH, flux);
        }
    }

    /// Splits, depth first from the root, every spatial leaf whose count (`counts` by leaf
    /// index, or half its parent's for a leaf made here) exceeds `threshold`.
    fn split_leaves(&mut self, counts: &[f64], threshold: f64) {
        // (node, depth, count inherited from a leaf split here)
        let mut stack: Vec<(usize, u32, Option<f64>)> = vec![(0, 0, None)];
        while let Some((index, depth, inherited)) = stack.pop() {
            let Some(&node) = self.nodes.get(index) else {
                continue;
            };
            let leaf = match node {
                SpatialNode::Split { children, .. } => {
                    for child in children {
                        stack.push((child as usize, depth + 1, None));
                    }
                    continue;
                }
                SpatialNode::Leaf(leaf) => leaf,
            };
            let count =
                inherited.unwrap_or_else(|| counts.get(leaf as usize).copied().unwrap_or(0.0));
            if !(count > threshold && depth < MAX_SPATIAL_DEPTH) {
                continue;
            }
            // The leaf keeps its distributions as the lower child; the upper one gets a copy.
            let Some(copy) = self.leaves.get(leaf as usize).map(|l| l.sampling.clone()) else {
                continue;
            };
            let (Ok(twin), Ok(first)) = (
                u32::try_from(self.leaves.len()),
                u32::try_from(self.nodes.len()),
            ) else {
                continue;
            };
            let Some(second) = first.checked_add(1) else {
                continue;
            };
            self.leaves.push(Directions {
                sampling: copy,
                building: DTree::uniform(),
                records: 0,
            });
            self.nodes.push(SpatialNode::Leaf(leaf));
            self.nodes.push(SpatialNode::Leaf(twin));
            if let Some(n) = self.nodes.get_mut(index) {
                *n = SpatialNode::Split {
                    axis: (depth % 3) as u8,
                    children: [first, second],
                };
            }
            stack.push((first as usize, depth + 1, Some(0.5 * count)));
            stack.push((second as usize, depth + 1, Some(0.5 * count)));
        }
    }

    /// Index (into `leaves`) of the spatial leaf containing `p`, clamped into the cube (NaN
    /// coordinates go to the cube's low side).
    fn locate(&self, p: Vec3A) -> Option<usize> {
        let q = (p - self.origin) * self.inv_side;
        let mut x = [clamp01(q.x), clamp01(q.y), clamp01(q.z)];
        let mut index = 0usize;
        for _ in 0..self.nodes.len() {
            match *self.nodes.get(index)? {
                SpatialNode::Leaf(leaf) => return Some(leaf as usize),
                SpatialNode::Split { axis, children } => {
                    // Exact, as in the quadtree: doubling and subtracting 1 lose nothing.
                    let a = usize::from(axis).min(2);
                    let v = 2.0 * x[a];
                    let upper = v >= 1.0;
                    x[a] = if upper { v - 1.0 } else { v };
                    index = children[usize::from(upper)] as usize;
                }
            }
        }
        None
    }

    /// The directional distribution of the spatial leaf containing `p` (clamped into the
    /// cube): a point's guide, looked up once and then sampled and evaluated.
    pub fn at(&self, p: Vec3A) -> Option<Guide<'_>> {
        let leaf = self.leaves.get(self.locate(p)?)?;
        Some(Guide(&leaf.sampling))
    }

    /// The number of spatial leaves and the total number of directional quadtree nodes of the
    /// sampling distributions (for a listing and tests). A new tree is `(1, 1)`.
    pub fn size(&self) -> (usize, usize) {
        let nodes = self.leaves.iter().map(|l| l.sampling.nodes.len()).sum();
        (self.leaves.len(), nodes)
    }
}

/// The learned directional distribution at one point ([`SdTree::at`]).
#[derive(Clone, Copy, Debug)]
pub struct Guide<'a>(&'a DTree);

impl Guide<'_> {
    /// A direction (unit, world space) for `u` in `[0, 1)^2` (other values are clamped into
    /// it) and its solid-angle density (> 0); `None` only if the distribution is degenerate.
    pub fn sample(&self, u: Vec2) -> Option<(Vec3A, f32)> {
        let (s, density) = self.0.sample(u)?;
        let pdf = (density * INV_FOUR_PI) as f32;
        (pdf > 0.0 && pdf.is_finite()).then(|| (square_to_dir(s), pdf))
    }

    /// The solid-angle density with which [`Guide::sample`] returns `dir` (0 for a zero or
    /// non-finite `dir`; `dir` need not be normalised).
    pub fn pdf(&self, dir: Vec3A) -> f32 {
        dir_to_square(dir).map_or(0.0, |s| (self.0.pdf(s) * INV_FOUR_PI) as f32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{uniform_sphere, UNIFORM_SPHERE_PDF};
    use crate::testing::chi2::{assert_chi2, dir, Grid, SAMPLES};
    use crate::Sampler;

    /// The tests' shorthands: a point's guide sampled and evaluated in one call.
    impl SdTree {
        fn sample(&self, p: Vec3A, u: Vec2) -> Option<(Vec3A, f32)> {
            self.at(p)?.sample(u)
        }

        fn pdf(&self, p: Vec3A, dir: Vec3A) -> f32 {
            self.at(p).map_or(0.0, |g| g.pdf(dir))
        }
    }

    /// Relative closeness.
    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol * a.abs().max(b.abs())
    }

    /// `n` records at points drawn by `point` in the radiance field `radiance`, directions
    /// drawn uniformly over the sphere (so value = radiance * 4 pi).
    fn uniform_records(
        s: &mut Sampler,
        n: usize,
        point: impl Fn(&mut Sampler) -> Vec3A,
        radiance: impl Fn(Vec3A) -> f32,
    ) -> Vec<Record> {
        (0..n)
            .map(|_| {
                let p = point(&mut *s);
                let w = uniform_sphere(s.next_2d());
                Record {
                    p,
                    dir: w,
                    value: radiance(w) / UNIFORM_SPHERE_PDF,
                }
            })
            .collect()
    }

    /// The lobe of the trained tree (away from cell boundaries of the square).
    fn lobe() -> Vec3A {
        dir(55.0, 40.0)
    }

    /// Radiance 1 within 0.25 rad of [`lobe`], 0.01 elsewhere.
    fn lobe_field(w: Vec3A) -> f32 {
        if w.dot(lobe()) > 0.25f32.cos() {
            1.0
        } else {
            0.01
        }
    }

    /// A tree trained for four iterations on [`lobe_field`] at the centre of the unit box,
    /// without spatial splits.
    fn trained_tree() -> SdTree {
        let mut tree = SdTree::new(Vec3A::ZERO, Vec3A::ONE);
        for iteration in 0..4u32 {
            let mut s = Sampler::new(7, u64::from(iteration), 0);
            let records = uniform_records(&mut s, 40_000, |_| Vec3A::splat(0.5), lobe_field);
            tree.record(&records);
            tree.refine(iteration, f32::INFINITY, 0.01);
        }
        tree
    }

    /// The lobes of the two halves (x < 0.5 and x > 0.5) of the split test, in different
    /// quadrants of the square.
    fn half_lobes() -> (Vec3A, Vec3A) {
        (dir(55.0, 50.0), dir(125.0, 230.0))
    }

    /// `n` records alternating between the two halves of the unit box, each half seeing its
    /// own narrow lobe.
    fn split_records(s: &mut Sampler, n: usize) -> Vec<Record> {
        let (a, b) = half_lobes();
        (0..n)
            .map(|k| {
                let low = k % 2 == 0;
                let x = (if low { 0.02 } else { 0.52 }) + 0.46 * s.next_1d();
                let p = Vec3A::new(x, s.next_1d(), s.next_1d());
                let center = if low { a } else { b };
                let w = (center + 0.15 * uniform_sphere(s.next_2d())).normalize();
                Record {
                    p,
                    dir: w,
                    value: 1.0,
                }
            })
            .collect()
    }

    /// Three iterations of [`split_records`] with a spatial threshold of 1000, records passed
    /// in one call or in chunks.
    fn split_tree(chunked: bool) -> SdTree {
        let mut tree = SdTree::new(Vec3A::ZERO, Vec3A::ONE);
        for iteration in 0..3u32 {
            let mut s = Sampler::new(11, u64::from(iteration), 0);
            let records = split_records(&mut s, 20_000);
            if chunked {
                for chunk in records.chunks(777) {
                    tree.record(chunk);
                }
            } else {
                tree.record(&records);
            }
            tree.refine(iteration, 1000.0, 0.01);
        }
        tree
    }

    /// Asserts that the tree is uniform at `p`: sampled and evaluated densities are 1/(4 pi).
    fn assert_uniform(tree: &SdTree, p: Vec3A, s: &mut Sampler) {
        let (w, pdf) = tree.sample(p, s.next_2d()).expect("a uniform sample");
        assert!((w.length() - 1.0).abs() < 1e-5, "{w}");
        assert!(close(pdf, UNIFORM_SPHERE_PDF, 1e-6), "{pdf}");
        assert_eq!(tree.pdf(p, w), pdf);
        let other = uniform_sphere(s.next_2d());
        assert!(close(tree.pdf(p, other), UNIFORM_SPHERE_PDF, 1e-6));
    }

    #[test]
    fn new_tree_is_uniform() {
        let tree = SdTree::new(Vec3A::new(-1.0, -2.0, -3.0), Vec3A::new(4.0, 5.0, 6.0));
        assert_eq!(tree.size(), (1, 1));
        let mut s = Sampler::new(1, 0, 0);
        for _ in 0..1000 {
            let p = Vec3A::new(s.next_1d(), s.next_1d(), s.next_1d()) * 12.0 - 4.0;
            assert_uniform(&tree, p, &mut s);
        }
    }

    #[test]
    fn learns_a_lobe_and_stays_normalised() {
        let tree = trained_tree();
        let p = Vec3A::splat(0.5);
        let peak = tree.pdf(p, lobe());
        assert!(peak > 10.0 * UNIFORM_SPHERE_PDF, "peak {peak}");
        let away = tree.pdf(p, -lobe());
        assert!(away < UNIFORM_SPHERE_PDF, "away {away}");
        // The midpoint rule on a 512 x 512 grid of the square is exact for cells down to
        // 2^-9; the square's Jacobian is 4 pi.
        let n = 512;
        let mut integral = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let s = [(i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64];
                integral += f64::from(tree.pdf(p, square_to_dir(s)));
            }
        }
        integral *= 4.0 * std::f64::consts::PI / (n * n) as f64;
        assert!((integral - 1.0).abs() < 2e-3, "integral {integral}");
        // Sampled densities are the evaluated ones.
        let mut s = Sampler::new(3, 0, 0);
        let mut mismatches = 0;
        for _ in 0..10_000 {
            let (w, pdf) = tree.sample(p, s.next_2d()).expect("a sample");
            assert!((w.length() - 1.0).abs() < 1e-5, "{w}");
            assert!(pdf > 0.0 && pdf.is_finite());
            if !close(tree.pdf(p, w), pdf, 1e-5) {
                mismatches += 1;
            }
        }
        // Only a sample rounded across a cell boundary may disagree.
        assert!(mismatches <= 10, "{mismatches} mismatches");
    }

    #[test]
    fn chi2_trained_tree() {
        let tree = trained_tree();
        let p = Vec3A::splat(0.5);
        // Rows are uniform in cos(theta) and columns in phi, so 32 x 32 cells (integrated
        // with 16 x 16 nodes each) line up with the quadtree's cells.
        assert_chi2(
            "SD-tree (trained)",
            &Grid::sphere(32, 32),
            SAMPLES,
            1701,
            |s| tree.sample(p, s.next_2d()).map(|(w, _)| w),
            |w| tree.pdf(p, w),
        );
    }

    #[test]
    fn spatial_split_learns_two_halves() {
        let tree = split_tree(false);
        // 20000 records halve to 625 after five splits (1250 > 1000 > 625); later
        // iterations' leaves stay below their thresholds.
        assert_eq!(tree.size().0, 32);
        let (a, b) = half_lobes();
        for k in 0..8 {
            let t = (k as f32 + 0.5) / 8.0;
            let low = Vec3A::new(0.25, t, 1.0 - t);
            let high = Vec3A::new(0.75, 1.0 - t, t);
            let (la, lb) = (tree.pdf(low, a), tree.pdf(low, b));
            let (ha, hb) = (tree.pdf(high, a), tree.pdf(high, b));
            assert!(
                la > 10.0 * UNIFORM_SPHERE_PDF && la > 10.0 * lb,
                "{low}: {la} {lb}"
            );
            assert!(
                hb > 10.0 * UNIFORM_SPHERE_PDF && hb > 10.0 * ha,
                "{high}: {ha} {hb}"
            );
        }
    }

    #[test]
    fn training_is_deterministic() {
        let (a, b) = (split_tree(false), split_tree(true));
        assert_eq!(a.size(), b.size());
        let mut s = Sampler::new(5, 0, 0);
        for _ in 0..2000 {
            let p = Vec3A::new(s.next_1d(), s.next_1d(), s.next_1d());
            let w = uniform_sphere(s.next_2d());
            assert_eq!(a.pdf(p, w).to_bits(), b.pdf(p, w).to_bits());
            let u = s.next_2d();
            let (sa, sb) = (a.sample(p, u), b.sample(p, u));
            let bits = |x: Option<(Vec3A, f32)>| {
                x.map(|(w, pdf)| (w.to_array().map(f32::to_bits), pdf.to_bits()))
            };
            assert_eq!(bits(sa), bits(sb));
        }
    }

    #[test]
    fn forgets_without_records() {
        let mut tree = trained_tree();
        assert!(tree.pdf(Vec3A::splat(0.5), lobe()) > 10.0 * UNIFORM_SPHERE_PDF);
        tree.refine(4, f32::INFINITY, 0.01);
        let mut s = Sampler::new(9, 0, 0);
        for _ in 0..100 {
            assert_uniform(&tree, Vec3A::splat(0.5), &mut s);
        }
    }

    #[test]
    fn odd_input_does_not_panic() {
        let (nan, inf) = (f32::NAN, f32::INFINITY);
        let mut tree = SdTree::new(Vec3A::ZERO, Vec3A::ONE);
        let at = |p: Vec3A, dir: Vec3A, value: f32| Record { p, dir, value };
        let c = Vec3A::splat(0.5);
        let bad = [
            at(Vec3A::splat(nan), Vec3A::Z, 1.0),
            at(Vec3A::new(inf, 0.5, 0.5), Vec3A::Z, 1.0),
            at(c, Vec3A::splat(nan), 1.0),
            at(c, Vec3A::new(0.0, inf, 0.0), 1.0),
            at(c, Vec3A::ZERO, 1.0),
            at(c, Vec3A::Z, nan),
            at(c, Vec3A::Z, inf),
            at(c, Vec3A::Z, -1.0),
        ];
        tree.record(&bad);
        tree.refine(0, 0.0, 0.01);
        // Nothing counted: one leaf, still uniform.
        assert_eq!(tree.size().0, 1);
        let mut s = Sampler::new(13, 0, 0);
        assert_uniform(&tree, c, &mut s);

        // Positions outside the box are clamped in; directions need not be unit.
        let far = [
            at(
                Vec3A::new(1e30, -1e30, 5.0),
                Vec3A::new(1e30, 1e30, 0.0),
                2.0,
            ),
            at(Vec3A::new(-7.0, 0.5, 0.5), Vec3A::new(-3.0, 0.0, 0.0), 1.0),
            at(Vec3A::splat(f32::MAX), Vec3A::X, f32::MAX),
            at(Vec3A::splat(f32::MIN), Vec3A::new(0.0, 1e-40, 0.0), 0.0),
        ];
        for iteration in 0..3 {
            tree.record(&far);
            tree.record(&bad);
            tree.refine(iteration, nan, nan);
            tree.record(&far);
            tree.refine(iteration + 10, -1.0, -1.0);
        }
        let (leaves, nodes) = tree.size();
        assert!(leaves >= 1 && nodes >= leaves);

        let points = [
            Vec3A::splat(nan),
            Vec3A::splat(inf),
            Vec3A::splat(-inf),
            Vec3A::new(1e30, 0.5, -1e30),
            c,
        ];
        let us = [
            Vec2::splat(nan),
            Vec2::ONE,
            Vec2::new(-0.5, 2.0),
            Vec2::new(0.3, 0.7),
            Vec2::ZERO,
        ];
        let dirs = [
            Vec3A::splat(nan),
            Vec3A::ZERO,
            Vec3A::splat(inf),
            Vec3A::X,
            Vec3A::new(0.0, 0.0, -2.0),
        ];
        for &p in &points {
            for &u in &us {
                if let Some((w, pdf)) = tree.sample(p, u) {
                    assert!((w.length() - 1.0).abs() < 1e-5, "{w}");
                    assert!(pdf > 0.0 && pdf.is_finite(), "{pdf}");
                }
            }
            for &w in &dirs {
                let pdf = tree.pdf(p, w);
                assert!(pdf >= 0.0 && pdf.is_finite(), "{pdf}");
            }
            assert_eq!(tree.pdf(p, Vec3A::splat(nan)), 0.0);
            assert_eq!(tree.pdf(p, Vec3A::ZERO), 0.0);
        }

        // Odd boxes.
        for (lo, hi) in [
            (Vec3A::splat(nan), Vec3A::ONE),
            (Vec3A::ONE, Vec3A::ZERO),
            (Vec3A::splat(2.0), Vec3A::splat(2.0)),
            (Vec3A::splat(-inf), Vec3A::splat(inf)),
            (Vec3A::splat(-3e38), Vec3A::splat(3e38)),
        ] {
            let mut tree = SdTree::new(lo, hi);
            tree.record(&far);
            tree.record(&[at(Vec3A::splat(2.0), Vec3A::Y, 1.0)]);
            tree.refine(0, 1.0, 0.01);
            for &p in &points {
                let (w, pdf) = tree.sample(p, Vec2::new(0.4, 0.6)).expect("a sample");
                assert!((w.length() - 1.0).abs() < 1e-5 && pdf > 0.0 && pdf.is_finite());
            }
        }
    }
}
