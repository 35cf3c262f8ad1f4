//! A light BVH (Conty Estevez & Kulla 2018, as pbrt-v4's `BVHLightSampler`): the scene's
//! bounded lights in a binary tree whose nodes bound their lights' positions, power and
//! emission directions. A light is chosen for a shading point by walking down the tree,
//! taking each child with probability proportional to an importance that bounds what the
//! child's lights could send towards the point (power over squared distance, times bounds of
//! the emitter's and the receiver's cosines). Lights at infinity are picked beside the tree,
//! uniformly, as pbrt-v4 does.
//!
//! The importance is conservative: it is zero only where no light of the node can reach the
//! point (behind every emitter's cone, below the receiver's horizon, both sides counted), so
//! every light that contributes keeps a non-zero probability and estimates stay unbiased.
//! [`LightBvh::pmf`] retraces the choice for a given light, for MIS.

use super::Light;
use glam::{Quat, Vec3A};
use std::f32::consts::PI;

/// Where a light is chosen for: the shading point, and its geometric normal (zero in a
/// medium, where no horizon limits what arrives).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightContext {
    pub p: Vec3A,
    pub n: Vec3A,
}

/// A cone of directions: its axis and the cosine of its half-angle (-1: every direction).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cone {
    w: Vec3A,
    cos_theta: f32,
}

impl Cone {
    const SPHERE: Cone = Cone {
        w: Vec3A::Z,
        cos_theta: -1.0,
    };

    /// The smallest cone holding both (pbrt-v4's `Union` of direction cones).
    fn union(a: Cone, b: Cone) -> Cone {
        let theta_a = a.cos_theta.clamp(-1.0, 1.0).acos();
        let theta_b = b.cos_theta.clamp(-1.0, 1.0).acos();
        let theta_d = angle_between(a.w, b.w);
        if (theta_d + theta_b).min(PI) <= theta_a {
            return a;
        }
        if (theta_d + theta_a).min(PI) <= theta_b {
            return b;
        }
        let theta_o = (theta_a + theta_d + theta_b) / 2.0;
        if theta_o >= PI {
            return Cone::SPHERE;
        }
        let axis = a.w.cross(b.w);
        if axis.length_squared() < 1e-12 {
            return Cone::SPHERE;
        }
        let rotation = Quat::from_axis_angle(axis.normalize().into(), theta_o - theta_a);
        Cone {
            w: Vec3A::from(rotation * glam::Vec3::from(a.w)).normalize(),
            cos_theta: theta_o.cos(),
        }
    }
}

/// The angle between unit vectors, accurate when they are nearly parallel or opposite.
fn angle_between(a: Vec3A, b: Vec3A) -> f32 {
    if a.dot(b) < 0.0 {
        PI - 2.0 * ((a + b).length() / 2.0).min(1.0).asin()
    } else {
        2.0 * ((b - a).length() / 2.0).min(1.0).asin()
    }
}

/// What a node's lights can emit: where (a box), how much (power), and towards where (every
/// emitter's normals within `theta_o` of `w`, each emitting within `theta_e` of its normal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    lo: Vec3A,
    hi: Vec3A,
    phi: f32,
    w: Vec3A,
    cos_theta_o: f32,
    cos_theta_e: f32,
    two_sided: bool,
}

/// `cos(max(0, a - b))` from the sines and cosines of `a` and `b`.
#[inline]
fn cos_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        1.0
    } else {
        cos_a * cos_b + sin_a * sin_b
    }
}

/// `sin(max(0, a - b))` from the sines and cosines of `a` and `b`.
#[inline]
fn sin_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        0.0
    } else {
        sin_a * cos_b - cos_a * sin_b
    }
}

#[inline]
fn sin_of(cos: f32) -> f32 {
    (1.0 - cos * cos).max(0.0).sqrt()
}

impl LightBounds {
    /// The bounds of `light` with power `phi`; `None` for lights at infinity (and lights
    /// without power, which are never chosen).
    pub fn of(light: &Light, phi: f64) -> Option<LightBounds> {
        if (phi.is_nan() || phi <= 0.0)
            || light.is_environment()
            || matches!(light, Light::Directional(_))
        {
            return None;
        }
        let phi = (phi as f32).min(f32::MAX);
        let point = |p: Vec3A, cone: Cone, cos_theta_e: f32| LightBounds {
            lo: p,
            hi: p,
            phi,
            w: cone.w,
            cos_theta_o: cone.cos_theta,
            cos_theta_e,
            two_sided: false,
        };
        // A point or sphere emits everywhere: the whole sphere of normals, each emitting
        // over its hemisphere.
        let everywhere = (Cone::SPHERE, 0.0);
        Some(match light {
            Light::Point(l) => point(l.position, everywhere.0, everywhere.1),
            // A spot emits nothing past its cutoff: normals in the cone, and (a point has no
            // surface) a sliver of spread so that the cone's inside keeps its importance.
            Light::Spot(l) => point(
                l.position,
                Cone {
                    w: l.axis.normalize(),
                    cos_theta: l.cutoff.min(PI).cos(),
                },
                1e-3f32.cos(),
            ),
            Light::Projector(l) => point(l.position, everywhere.0, everywhere.1),
            Light::Sphere(l) => {
                let r = Vec3A::splat(l.radius.abs());
                LightBounds {
                    lo: l.center - r,
                    hi: l.center + r,
                    ..point(l.center, everywhere.0, everywhere.1)
                }
            }
            Light::Cylinder(l) => {
                let (a, b) = (l.base, l.base + l.axis);
                let r = Vec3A::splat(l.radius.abs());
                LightBounds {
                    lo: a.min(b) - r,
                    hi: a.max(b) + r,
                    ..point(a, everywhere.0, everywhere.1)
                }
            }
            Light::Planar(l) => {
                let corners: [Vec3A; 4] = match l.shape {
                    super::PlanarShape::Triangle => [l.p0, l.p0 + l.e1, l.p0 + l.e2, l.p0],
                    super::PlanarShape::Parallelogram => {
                        [l.p0, l.p0 + l.e1, l.p0 + l.e2, l.p0 + l.e1 + l.e2]
                    }
                    // p0 is the centre; the disk lies in the parallelogram of +-e1 +-e2.
                    super::PlanarShape::Disk => [
                        l.p0 - l.e1 - l.e2,
                        l.p0 + l.e1 - l.e2,
                        l.p0 - l.e1 + l.e2,
                        l.p0 + l.e1 + l.e2,
                    ],
                };
                let lo = corners.iter().fold(corners[0], |m, c| m.min(*c));
                let hi = corners.iter().fold(corners[0], |m, c| m.max(*c));
                LightBounds {
                    lo,
                    hi,
                    phi,
                    w: l.n,
                    cos_theta_o: 1.0,
                    cos_theta_e: 0.0,
                    two_sided: l.two_sided,
                }
            }
            Light::Environment(_) | Light::EnvMap(_) | Light::Directional(_) => return None,
        })
    }

    fn union(a: LightBounds, b: LightBounds) -> LightBounds {
        let cone = Cone::union(
            Cone {
                w: a.w,
                cos_theta: a.cos_theta_o,
            },
            Cone {
                w: b.w,
                cos_theta: b.cos_theta_o,
            },
        );
        LightBounds {
            lo: a.lo.min(b.lo),
            hi: a.hi.max(b.hi),
            phi: (a.phi + b.phi).min(f32::MAX),
            w: cone.w,
            cos_theta_o: cone.cos_theta,
            cos_theta_e: a.cos_theta_e.min(b.cos_theta_e),
            two_sided: a.two_sided || b.two_sided,
        }
    }

    /// A bound of what the node's lights send to `ctx` (pbrt-v4's `LightBounds::Importance`):
    /// power over the squared distance to the box's centre (at least half its diagonal),
    /// times the cosine of the smallest angle any emitter could see the point under, and of
    /// the smallest angle the point's normal could see any of them under.
    pub fn importance(&self, ctx: &LightContext) -> f32 {
        let centre = (self.lo + self.hi) * 0.5;
        let d2 = ctx
            .p
            .distance_squared(centre)
            .max((self.hi - self.lo).length() * 0.5)
            .max(1e-12);
        let wi = (ctx.p - centre).normalize_or_zero();
        let mut cos_w = self.w.dot(wi);
        if self.two_sided {
            cos_w = cos_w.abs();
        }
        let sin_w = sin_of(cos_w);
        // The directions the box subtends from the point: all of them from inside its
        // bounding sphere.
        let radius2 = (self.hi - self.lo).length_squared() * 0.25;
        let dist2 = ctx.p.distance_squared(centre);
        let cos_b = if dist2 <= radius2 || wi == Vec3A::ZERO {
            -1.0
        } else {
            (1.0 - radius2 / dist2).max(0.0).sqrt()
        };
        let sin_b = sin_of(cos_b);
        // theta' = max(0, theta_w - theta_o - theta_b)
        let sin_o = sin_of(self.cos_theta_o);
        let cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, self.cos_theta_o);
        let sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, self.cos_theta_o);
        let cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
        if cos_p <= self.cos_theta_e {
            return 0.0;
        }
        let mut importance = self.phi * cos_p / d2;
        if ctx.n != Vec3A::ZERO {
            let cos_i = wi.dot(ctx.n).abs();
            let cos_pi = cos_sub_clamped(sin_of(cos_i), cos_i, sin_b, cos_b);
            importance *= cos_pi;
        }
        if importance.is_finite() {
            importance.max(0.0)
        } else {
            f32::MAX
        }
    }

    /// pbrt-v4's cost of a node with these bounds, split along `axis` of `extent` (the
    /// parent's): power times the measure of the emission cone times the box's area, longer
    /// boxes across the split cheaper.
    fn cost(&self, extent: Vec3A, axis: usize) -> f32 {
        let theta_o = self.cos_theta_o.clamp(-1.0, 1.0).acos();
        let theta_e = self.cos_theta_e.clamp(-1.0, 1.0).acos();
        let theta_w = (theta_o + theta_e).min(PI);
        let sin_o = sin_of(self.cos_theta_o);
        let m_omega = 2.0 * PI * (1.0 - self.cos_theta_o)
            + PI / 2.0
                * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o
                    + self.cos_theta_o);
        let kr = extent.max_element() / extent[axis].max(1e-12);
        let d = self.hi - self.lo;
        let area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
        self.phi * m_omega * kr * area.max(1e-12)
    }
}

/// A node: its bounds and either two children or one light. Nodes are stored depth first:
/// an interior node's first child is the next node, its second child's subtree follows the
/// first's.
#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: LightBounds,
    /// A leaf's light, or an interior node's second child.
    index: u32,
    leaf: bool,
}

/// The tree over a scene's bounded lights, and its lights at infinity.
#[derive(Clone, Debug, Default)]
pub struct LightBvh {
    nodes: Vec<Node>,
    /// Each light's leaf, if it has one.
    leaf_of: Vec<Option<u32>>,
    /// The lights at infinity (and directional ones), picked uniformly beside the tree.
    infinite: Vec<u32>,
}

/// Buckets per axis when choosing a split.
const BUCKETS: usize = 12;

/// Levels split by cost; below them, nodes are halved by count.
const MAX_COST_DEPTH: u32 = 32;

impl LightBvh {
    /// The tree over `lights`, whose powers are `powers` (lights without power are left
    /// out and never chosen).
    pub fn new(lights: &[Light], powers: &[f64]) -> LightBvh {
        let mut bounded: Vec<(u32, LightBounds)> = Vec::new();
        let mut infinite = Vec::new();
        for (i, (light, &phi)) in lights.iter().zip(powers).enumerate() {
            if light.is_environment() || matches!(light, Light::Directional(_)) {
                if phi > 0.0 {
                    infinite.push(i as u32);
                }
            } else if let Some(b) = LightBounds::of(light, phi) {
                bounded.push((i as u32, b));
            }
        }
        let mut bvh = LightBvh {
            nodes: Vec::with_capacity(2 * bounded.len()),
            leaf_of: vec![None; lights.len()],
            infinite,
        };
        if !bounded.is_empty() {
            bvh.build(&mut bounded, 0);
        }
        bvh
    }

    /// Builds the subtree of `items`, `depth` levels down; returns its node.
    fn build(&mut self, items: &mut [(u32, LightBounds)], depth: u32) -> u32 {
        let at = self.nodes.len() as u32;
        let bounds = items
            .iter()
            .skip(1)
            .fold(items[0].1, |b, (_, c)| LightBounds::union(b, *c));
        if items.len() == 1 {
            self.nodes.push(Node {
                bounds,
                index: items[0].0,
                leaf: true,
            });
            self.leaf_of[items[0].0 as usize] = Some(at);
            return at;
        }
        // Deep down (an unbalanced run of cheapest splits), halve by count instead, so that
        // the tree, and the recursion building it, stay shallow.
        let mid = if depth < MAX_COST_DEPTH {
            split(items, &bounds)
        } else {
            halve(items, &bounds)
        };
        self.nodes.push(Node {
            bounds,
            index: 0,
            leaf: false,
        });
        let (left, right) = items.split_at_mut(mid);
        self.build(left, depth + 1);
        let second = self.build(right, depth + 1);
        self.nodes[at as usize].index = second;
        at
    }

    /// The probability of choosing from the tree rather than from the lights at infinity.
    fn tree_share(&self) -> f32 {
        let tree = u32::from(!self.nodes.is_empty());
        let total = self.infinite.len() as u32 + tree;
        if total == 0 {
            0.0
        } else {
            tree as f32 / total as f32
        }
    }

    /// Chooses a light for `ctx` with `u` in `[0, 1)`: its index and probability. `None` when
    /// no light can reach the point.
    pub fn sample(&self, ctx: &LightContext, u: f32) -> Option<(u32, f32)> {
        let tree = self.tree_share();
        let p_infinite = 1.0 - tree;
        let mut u = u.clamp(0.0, 1.0 - f32::EPSILON / 2.0);
        if u < p_infinite {
            let n = self.infinite.len();
            let k = ((u / p_infinite * n as f32) as usize).min(n - 1);
            return Some((self.infinite[k], p_infinite / n as f32));
        }
        if self.nodes.is_empty() {
            return None;
        }
        u = ((u - p_infinite) / tree).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
        let mut pmf = tree;
        let mut at = 0usize;
        if self.nodes[0].bounds.importance(ctx) <= 0.0 {
            return None;
        }
        loop {
            let node = &self.nodes[at];
            if node.leaf {
                return Some((node.index, pmf));
            }
            let (a, b) = (at + 1, node.index as usize);
            let (ia, ib) = (
                self.nodes[a].bounds.importance(ctx),
                self.nodes[b].bounds.importance(ctx),
            );
            if ia <= 0.0 && ib <= 0.0 {
                return None;
            }
            let pa = share(ia, ib);
            if u < pa {
                u = (u / pa).min(1.0 - f32::EPSILON / 2.0);
                pmf *= pa;
                at = a;
            } else {
                u = ((u - pa) / (1.0 - pa)).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
                pmf *= 1.0 - pa;
                at = b;
            }
        }
    }

    /// The probability that [`LightBvh::sample`] chooses light `index` for `ctx`.
    pub fn pmf(&self, ctx: &LightContext, index: u32) -> f32 {
        let tree = self.tree_share();
        let Some(leaf) = self.leaf_of.get(index as usize).copied().flatten() else {
            return if self.infinite.contains(&index) {
                (1.0 - tree) / self.infinite.len() as f32
            } else {
                0.0
            };
        };
        if self.nodes[0].bounds.importance(ctx) <= 0.0 {
            return 0.0;
        }
        // The walk down to the leaf, with the ratios `sample` multiplies, in its order: the
        // leaf lies in the first child's subtree when it precedes the second child.
        let (mut pmf, mut at) = (tree, 0usize);
        while !self.nodes[at].leaf {
            let (a, b) = (at + 1, self.nodes[at].index as usize);
            let (ia, ib) = (
                self.nodes[a].bounds.importance(ctx),
                self.nodes[b].bounds.importance(ctx),
            );
            let first = (leaf as usize) < b;
            if (if first { ia } else { ib }) <= 0.0 {
                return 0.0;
            }
            pmf *= if first {
                share(ia, ib)
            } else {
                1.0 - share(ia, ib)
            };
            at = if first { a } else { b };
        }
        pmf
    }
}

/// The first child's share of a walk, `a / (a + b)`, in f64 so that two importances at the
/// top of f32's range do not overflow their sum.
#[inline]
fn share(a: f32, b: f32) -> f32 {
    (f64::from(a) / (f64::from(a) + f64::from(b))) as f32
}

/// Orders `items` for a split of the node `bounds` bounds and returns where it falls: the
/// cheapest of the bucket boundaries along the three axes by [`LightBounds::cost`], or the
/// middle by count when no boundary separates them.
fn split(items: &mut [(u32, LightBounds)], bounds: &LightBounds) -> usize {
    let centre = |b: &LightBounds| (b.lo + b.hi) * 0.5;
    let (clo, chi) = items.iter().fold(
        (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY)),
        |(lo, hi), (_, b)| (lo.min(centre(b)), hi.max(centre(b))),
    );
    let extent = bounds.hi - bounds.lo;
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in 0..3 {
        let (lo, hi) = (clo[axis], chi[axis]);
        if hi <= lo {
            continue;
        }
        let bucket = |b: &LightBounds| {
            (((centre(b)[axis] - lo) / (hi - lo) * BUCKETS as f32) as usize).min(BUCKETS - 1)
        };
        let mut buckets: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
        for (_, b) in items.iter() {
            let k = bucket(b);
            buckets[k] = Some(buckets[k].map_or(*b, |c| LightBounds::union(c, *b)));
        }
        for cut in 1..BUCKETS {
            let join = |range: &[Option<LightBounds>]| {
                range.iter().flatten().copied().reduce(LightBounds::union)
            };
            let (Some(a), Some(b)) = (join(&buckets[..cut]), join(&buckets[cut..])) else {
                continue;
            };
            let cost = a.cost(extent, axis) + b.cost(extent, axis);
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, cut));
            }
        }
    }
    match best {
        Some((_, axis, cut)) => {
            let (lo, hi) = (clo[axis], chi[axis]);
            let below = |b: &LightBounds| {
                ((((centre(b)[axis] - lo) / (hi - lo)) * BUCKETS as f32) as usize).min(BUCKETS - 1)
                    < cut
            };
            let mut k = 0;
            for i in 0..items.len() {
                if below(&items[i].1) {
                    items.swap(i, k);
                    k += 1;
                }
            }
            k.clamp(1, items.len() - 1)
        }
        None => items.len() / 2,
    }
}

/// Orders `items` around the median of their centres along the node's longest axis and
/// returns the middle.
fn halve(items: &mut [(u32, LightBounds)], bounds: &LightBounds) -> usize {
    let extent = bounds.hi - bounds.lo;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = items.len() / 2;
    let key = |b: &LightBounds| (b.lo[axis] + b.hi[axis]) * 0.5;
    items.select_nth_unstable_by(mid, |a, b| key(&a.1).total_cmp(&key(&b.1)));
    mid
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::SpotLight;
    use crate::random::{keyed_rng, unit_f32};
    use crate::Rgb;

    /// Sixty-odd lights of every bounded kind, one- and two-sided, with powers over six
    /// orders of magnitude, scattered in a 20-unit box; a sky and a sun beside them.
    fn zoo() -> Vec<Light> {
        let mut rng = keyed_rng(7, 0);
        let mut u = move || unit_f32(&mut rng);
        let mut v = |s: f32| Vec3A::new(u(), u(), u()) * s;
        let mut lights = Vec::new();
        for k in 0..64 {
            let p = v(20.0) - Vec3A::splat(10.0);
            let colour = Rgb::splat(10f32.powf(v(6.0).x - 3.0));
            let (e1, e2) = (v(1.0) - Vec3A::splat(0.5), v(1.0) - Vec3A::splat(0.5));
            lights.push(match k % 8 {
                0 => Light::triangle(p, p + e1, p + e2, colour, false),
                1 => Light::triangle(p, p + e1, p + e2, colour, true),
                2 => Light::parallelogram(p, e1, e2, colour, false),
                3 => Light::disk(p, e1, e2, colour, true),
                4 => Light::sphere(p, 0.3, colour),
                5 => Light::point(p, colour),
                6 => Light::Spot(
                    SpotLight::new(p, e1.normalize(), colour, 30.0 + 100.0 * v(1.0).x, 10.0)
                        .unwrap(),
                ),
                _ => Light::sphere_inward(p, 0.5, colour),
            });
        }
        lights.push(Light::environment(Rgb::splat(0.5)));
        lights
    }

    fn contexts() -> Vec<LightContext> {
        let mut rng = keyed_rng(11, 0);
        let mut u = move || unit_f32(&mut rng);
        (0..60)
            .map(|k| {
                let p = Vec3A::new(u(), u(), u()) * 24.0 - Vec3A::splat(12.0);
                let n = crate::sampling::uniform_sphere(glam::Vec2::new(u(), u()));
                LightContext {
                    p,
                    n: if k % 5 == 0 { Vec3A::ZERO } else { n },
                }
            })
            .collect()
    }

    /// Every leaf's probability by walking down the whole tree from the root, multiplying
    /// the ratios of the children's importances: the brute force. Also the probability of
    /// the walks that end at a node none of whose children can reach the point.
    fn brute_force(bvh: &LightBvh, ctx: &LightContext, lights: usize) -> (Vec<f64>, f64) {
        let mut out = vec![0.0f64; lights];
        let mut dead = 0.0;
        let tree = f64::from(bvh.tree_share());
        for &i in &bvh.infinite {
            out[i as usize] = (1.0 - tree) / bvh.infinite.len() as f64;
        }
        if bvh.nodes.is_empty() || bvh.nodes[0].bounds.importance(ctx) <= 0.0 {
            return (out, tree);
        }
        let mut stack = vec![(0usize, tree)];
        while let Some((at, p)) = stack.pop() {
            let node = &bvh.nodes[at];
            if node.leaf {
                out[node.index as usize] = p;
                continue;
            }
            let (a, b) = (at + 1, node.index as usize);
            let ia = f64::from(bvh.nodes[a].bounds.importance(ctx));
            let ib = f64::from(bvh.nodes[b].bounds.importance(ctx));
            if ia + ib > 0.0 {
                stack.push((a, p * ia / (ia + ib)));
                stack.push((b, p * ib / (ia + ib)));
            } else {
                dead += p;
            }
        }
        (out, dead)
    }

    /// The probabilities the tree gives each light match a brute-force walk of the whole
    /// tree, and with the walks that find no light (a node whose bounds reach the point while
    /// neither child's do: pbrt-v4's sampler returns no light then too) sum to one; they are
    /// what sampling returns, and sampling picks each light that often.
    #[test]
    fn pmf_sums_to_one_matches_brute_force_and_sampling() {
        let lights = zoo();
        let powers: Vec<f64> = lights.iter().map(|l| l.power(30.0)).collect();
        let bvh = LightBvh::new(&lights, &powers);
        assert_eq!(bvh.infinite.len(), 1);
        let (mut reached, mut lost) = (0, 0.0f64);
        for ctx in contexts() {
            let (brute, dead) = brute_force(&bvh, &ctx, lights.len());
            let pmf: Vec<f64> = (0..lights.len())
                .map(|i| f64::from(bvh.pmf(&ctx, i as u32)))
                .collect();
            for (i, (a, b)) in pmf.iter().zip(&brute).enumerate() {
                assert!(
                    (a - b).abs() <= 1e-5 * b.max(1e-3),
                    "light {i} at {ctx:?}: {a} vs {b}"
                );
            }
            let total: f64 = pmf.iter().sum();
            assert!(
                (total + dead - 1.0).abs() < 1e-4,
                "{total} + {dead} at {ctx:?}"
            );
            assert!((pmf[lights.len() - 1] - 0.5).abs() < 1e-6);
            if total > 0.5 {
                reached += 1;
            }
            lost = lost.max(dead);
            let n = 40_000;
            let mut counts = vec![0u32; lights.len()];
            for k in 0..n {
                let u = (k as f32 + 0.5) / n as f32;
                if let Some((i, p)) = bvh.sample(&ctx, u) {
                    assert_eq!(p, bvh.pmf(&ctx, i), "light {i} at {ctx:?}");
                    counts[i as usize] += 1;
                }
            }
            // Stratified u: each count within a few of its expectation (the walk maps
            // intervals of u to lights, up to rounding at their ends).
            for (i, (&c, &p)) in counts.iter().zip(&pmf).enumerate() {
                let expected = p * n as f64;
                assert!(
                    (f64::from(c) - expected).abs() <= 2.0 + 1e-3 * expected,
                    "light {i}: {c} picks, {expected:.1} expected"
                );
            }
        }
        assert!(
            reached > 40,
            "only {reached} contexts reached a bounded light"
        );
        eprintln!("the most a walk down the tree lost: {lost:.3}");
    }

    /// A light that sends something to a point (a sample with radiance, above the point's
    /// horizon on either side) has a non-zero probability there: the BVH leaves no light
    /// out, so estimates with it are unbiased.
    #[test]
    fn every_light_that_reaches_a_point_can_be_chosen() {
        let lights = zoo();
        let powers: Vec<f64> = lights.iter().map(|l| l.power(30.0)).collect();
        let bvh = LightBvh::new(&lights, &powers);
        let mut rng = keyed_rng(3, 0);
        let mut checked = 0;
        for ctx in contexts() {
            for (i, light) in lights.iter().enumerate() {
                let reaches = (0..64).any(|_| {
                    let u = glam::Vec2::new(unit_f32(&mut rng), unit_f32(&mut rng));
                    light
                        .sample_li(ctx.p, u, &crate::spectrum::Wavelengths::Rgb)
                        .is_some_and(|ls| {
                            ls.radiance != crate::Spectrum::ZERO
                                && (ctx.n == Vec3A::ZERO || ls.wi.dot(ctx.n) != 0.0)
                        })
                });
                if reaches {
                    checked += 1;
                    assert!(
                        bvh.pmf(&ctx, i as u32) > 0.0,
                        "light {i} ({light:?}) at {ctx:?}"
                    );
                }
            }
        }
        assert!(checked > 1000, "{checked}");
    }

    /// Half a million lights in a row, their powers growing geometrically (so that the
    /// cheapest split peels one light off at a time): the tree stays shallow and builds.
    #[test]
    fn a_lopsided_set_builds_a_shallow_tree() {
        let n = 500_000;
        let lights: Vec<Light> = (0..n)
            .map(|i| Light::point(Vec3A::new(i as f32, 0.0, 0.0), Rgb::splat(1.0)))
            .collect();
        let powers: Vec<f64> = (0..n).map(|i| 1.0001f64.powi(i)).collect();
        let bvh = LightBvh::new(&lights, &powers);
        let depth = |leaf: u32| {
            let (mut d, mut at) = (0, 0usize);
            while !bvh.nodes[at].leaf {
                let second = bvh.nodes[at].index as usize;
                at = if (leaf as usize) < second {
                    at + 1
                } else {
                    second
                };
                d += 1;
            }
            assert_eq!(at, leaf as usize);
            d
        };
        let deepest = bvh
            .leaf_of
            .iter()
            .flatten()
            .map(|&l| depth(l))
            .max()
            .unwrap();
        assert!(deepest <= MAX_COST_DEPTH + 20, "{deepest}");
        let ctx = LightContext {
            p: Vec3A::new(10.0, 1.0, 0.0),
            n: Vec3A::Y,
        };
        let (i, p) = bvh.sample(&ctx, 0.5).unwrap();
        assert_eq!(p, bvh.pmf(&ctx, i));
    }
}
