//! The lane kernels of `path-wavefront`: one stage's arithmetic for every diffuse shading
//! point of a batch at once, over columns of numbers (structure of arrays), eight rows per
//! instruction ([`wide::f32x8`]: two SSE operations on every x86-64, one AVX operation where
//! the build targets it), every branch a select.
//!
//! Each row's results depend on its own inputs only (the operations are IEEE's, lane by
//! lane), so a path's estimate is the same whatever other paths share its batch. Rows past
//! the last in use are computed too, on stale numbers, and ignored.

use crate::geometry::{ABSOLUTE_OFFSET, RELATIVE_OFFSET};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_4};
use wide::f32x8;

/// Rows of a kernel: the paths a batch walks together.
pub const LANES: usize = 64;

/// Rows per SIMD operation.
const W: usize = 8;

/// One number per row.
pub type Col = [f32x8; LANES / W];

/// Three columns: a vector per row.
pub type Col3 = [Col; 3];

/// Four columns: a [`crate::Spectrum`] per row.
pub type Col4 = [Col; 4];

/// Sets row `m` of `col`.
#[inline(always)]
pub fn set(col: &mut Col, m: usize, v: f32) {
    col[m / W].as_mut_array()[m % W] = v;
}

/// Row `m` of `col`.
#[inline(always)]
pub fn get(col: &Col, m: usize) -> f32 {
    col[m / W].as_array()[m % W]
}

const ZERO: Col = [f32x8::ZERO; LANES / W];

/// Diffuse shading points (a plain Lambert material: no map, no mask), one per row, with what
/// the bounce needs: the point, its frames, the path's throughput, its random numbers and
/// the light sample drawn for it.
pub struct DiffuseRows {
    /// Rows in use.
    pub len: usize,
    /// The batch lane (path) of each row.
    pub lane: [u16; LANES],
    /// Hit position, geometric normal, and how far spawned rays leave it.
    pub p: Col3,
    pub ng: Col3,
    pub eps: Col,
    /// The shading frame.
    pub s: Col3,
    pub t: Col3,
    pub n: Col3,
    /// `z` of the direction back along the arriving ray, in the shading frame.
    pub wo_z: Col,
    /// That direction against the geometric normal, `ng . wo`.
    pub wo_ng: Col,
    /// 1 where the material is seen from the front only (Mitsuba's one-sided BSDFs), else 0.
    pub front_only: Col,
    pub albedo: Col4,
    /// The path's throughput before this bounce.
    pub beta: Col4,
    /// The product of `eta^2` over the path's refractions (the roulette's scale).
    pub eta_scale: Col,
    /// 1 where Russian roulette plays after this bounce, else 0.
    pub roulette: Col,
    /// The numbers that place the BSDF sample, and the roulette's.
    pub u: [Col; 2],
    pub u_rr: Col,
    /// The light sample: direction, point, distance (infinite for lights at infinity),
    /// arriving radiance, density (selection probability times the sample's solid-angle
    /// density; 0 where there is none) and 1 for a delta light.
    pub ls_wi: Col3,
    pub ls_point: Col3,
    pub ls_dist: Col,
    pub ls_le: Col4,
    pub ls_pdf: Col,
    pub ls_delta: Col,
}

impl DiffuseRows {
    pub fn new() -> DiffuseRows {
        DiffuseRows {
            len: 0,
            lane: [0; LANES],
            p: [ZERO; 3],
            ng: [ZERO; 3],
            eps: ZERO,
            s: [ZERO; 3],
            t: [ZERO; 3],
            n: [ZERO; 3],
            wo_z: ZERO,
            wo_ng: ZERO,
            front_only: ZERO,
            albedo: [ZERO; 4],
            beta: [ZERO; 4],
            eta_scale: ZERO,
            roulette: ZERO,
            u: [ZERO; 2],
            u_rr: ZERO,
            ls_wi: [ZERO; 3],
            ls_point: [ZERO; 3],
            ls_dist: ZERO,
            ls_le: [ZERO; 4],
            ls_pdf: ZERO,
            ls_delta: ZERO,
        }
    }
}

/// The light samples' contributions, if unoccluded, and their shadow rays.
pub struct ShadowRows {
    pub contrib: Col4,
    pub origin: Col3,
    pub dir: Col3,
    pub tmax: Col,
    /// 1 where the sample carries light (a shadow ray is cast), else 0.
    pub live: Col,
}

impl ShadowRows {
    pub fn new() -> ShadowRows {
        ShadowRows {
            contrib: [ZERO; 4],
            origin: [ZERO; 3],
            dir: [ZERO; 3],
            tmax: ZERO,
            live: ZERO,
        }
    }
}

/// The BSDF samples: the next ray, its density, the throughput after the roulette, and 1
/// where the path goes on.
pub struct ScatterRows {
    pub origin: Col3,
    pub dir: Col3,
    pub pdf: Col,
    pub beta: Col4,
    pub alive: Col,
}

impl ScatterRows {
    pub fn new() -> ScatterRows {
        ScatterRows {
            origin: [ZERO; 3],
            dir: [ZERO; 3],
            pdf: ZERO,
            beta: [ZERO; 4],
            alive: ZERO,
        }
    }
}

type V3 = [f32x8; 3];

#[inline(always)]
fn dot(a: V3, b: V3) -> f32x8 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
fn block3(c: &Col3, b: usize) -> V3 {
    [c[0][b], c[1][b], c[2][b]]
}

/// Where a direction at `z` in the shading frame passes a diffuse material seen from `wo_z`:
/// both on one side, and above the normal where it is seen from the front only.
#[inline(always)]
fn passes(wo_z: f32x8, z: f32x8, front_only: f32x8) -> f32x8 {
    let zero = f32x8::ZERO;
    let above = wo_z.simd_gt(zero) & z.simd_gt(zero);
    (wo_z * z).simd_gt(zero) & (front_only.simd_eq(zero) | above)
}

/// `(sin a, cos a)` for `|a| <= pi/4`: [`crate::sampling`]'s Taylor polynomials, lane by lane.
#[inline(always)]
fn sin_cos_quarter(a: f32x8) -> (f32x8, f32x8) {
    let a2 = a * a;
    let c = f32x8::splat;
    let sin = a
        * (c(1.0)
            + a2 * (c(-1.0 / 6.0)
                + a2 * (c(1.0 / 120.0) + a2 * (c(-1.0 / 5040.0) + a2 * c(1.0 / 362_880.0)))));
    let cos = c(1.0)
        + a2 * (c(-0.5)
            + a2 * (c(1.0 / 24.0)
                + a2 * (c(-1.0 / 720.0) + a2 * (c(1.0 / 40_320.0) + a2 * c(-1.0 / 3_628_800.0)))));
    (sin, cos)
}

/// Next-event estimation at diffuse points: the BSDF towards each light sample, weighted by
/// the power heuristic against cosine sampling with `mis` (1 for delta lights, and 1 for all
/// without), times the path's
/// throughput, over the sample's density; and the shadow ray that decides it (as
/// [`crate::Hit::spawn_ray_to`] for a point, [`crate::Hit::spawn_ray`] for a direction).
#[inline(never)]
pub fn light_samples(d: &DiffuseRows, mis: bool, out: &mut ShadowRows) {
    let (zero, one) = (f32x8::ZERO, f32x8::ONE);
    for b in 0..d.len.div_ceil(W).min(LANES / W) {
        let p = block3(&d.p, b);
        let ng = block3(&d.ng, b);
        let wi = block3(&d.ls_wi, b);
        let wi_ng = dot(ng, wi);
        let wi_z = dot(block3(&d.n, b), wi);
        let light_pdf = d.ls_pdf[b];
        let cos = wi_z.abs();
        let bsdf_pdf = cos * FRAC_1_PI;
        let (pa, pb) = (light_pdf * light_pdf, bsdf_pdf * bsdf_pdf);
        let balanced = (pa + pb).simd_eq(zero).select(zero, pa / (pa + pb));
        let unweighted = d.ls_delta[b].simd_ne(zero) | pa.is_inf();
        let mis = match mis {
            true => unweighted.select(one, balanced),
            false => one,
        };
        let ok = light_pdf.simd_gt(zero)
            & (d.wo_ng[b] * wi_ng).simd_gt(zero)
            & passes(d.wo_z[b], wi_z, d.front_only[b]);
        let scale = ok.select(cos * mis / light_pdf * FRAC_1_PI, zero);
        let mut carried = f32x8::splat(0.0).simd_ne(zero);
        for c in 0..4 {
            let v = d.beta[c][b] * d.albedo[c][b] * d.ls_le[c][b] * scale;
            out.contrib[c][b] = v;
            carried |= v.simd_ne(zero);
        }
        out.live[b] = carried.select(one, zero);
        // The shadow ray, leaving on the sample's side of the surface.
        let point = block3(&d.ls_point, b);
        let finite = d.ls_dist[b].is_finite();
        let towards: V3 = [0, 1, 2].map(|k| finite.select(point[k] - p[k], wi[k]));
        let side = dot(ng, towards).simd_ge(zero).select(one, -one);
        let push = d.eps[b] * side;
        let o: V3 = [0, 1, 2].map(|k| p[k] + ng[k] * push);
        let to: V3 = [0, 1, 2].map(|k| point[k] - o[k]);
        let dist = dot(to, to).sqrt();
        let reach = point[0].abs().max(point[1].abs()).max(point[2].abs());
        let margin = (f32x8::splat(2.0)
            * (f32x8::splat(ABSOLUTE_OFFSET) + reach * RELATIVE_OFFSET))
            .max(dist * 1e-4);
        for k in 0..3 {
            out.origin[k][b] = o[k];
            out.dir[k][b] = finite.select(to[k] / dist, wi[k]);
        }
        out.tmax[b] = finite.select((dist - margin).max(zero), f32x8::splat(f32::INFINITY));
    }
}

/// Cosine-weighted sampling of the diffuse points (Shirley-Chiu's concentric map, mirrored to
/// the side the path arrives from), the next ray, the throughput times the albedo (the
/// sample's exact weight), then Russian roulette where it plays: survival with probability
/// `min(0.95, max(beta * eta_scale))`, the survivors' throughput divided by it.
#[inline(never)]
pub fn bsdf_samples(d: &DiffuseRows, out: &mut ScatterRows) {
    let (zero, one) = (f32x8::ZERO, f32x8::ONE);
    for b in 0..d.len.div_ceil(W).min(LANES / W) {
        // The concentric map.
        let ox = d.u[0][b] * 2.0 - one;
        let oy = d.u[1][b] * 2.0 - one;
        let centre = ox.simd_eq(zero) & oy.simd_eq(zero);
        let x_major = ox.abs().simd_gt(oy.abs());
        let r = x_major.select(ox, oy);
        let (num, den) = (x_major.select(oy, ox), x_major.select(ox, oy));
        let a = centre.select(zero, (num / den) * FRAC_PI_4);
        let (sin, cos) = sin_cos_quarter(a);
        let dx = centre.select(zero, x_major.select(r * cos, r * sin));
        let dy = centre.select(zero, x_major.select(r * sin, r * cos));
        let z0 = (one - dx * dx - dy * dy).max(zero).sqrt();
        let wo_z = d.wo_z[b];
        let z = wo_z.simd_lt(zero).select(-z0, z0);
        let pdf = z0 * FRAC_1_PI;
        // To world space, and off the surface on the sample's side.
        let wi: V3 = [0, 1, 2].map(|k| d.s[k][b] * dx + d.t[k][b] * dy + d.n[k][b] * z);
        let ng = block3(&d.ng, b);
        let wi_ng = dot(ng, wi);
        let push = d.eps[b] * wi_ng.simd_ge(zero).select(one, -one);
        for k in 0..3 {
            out.origin[k][b] = d.p[k][b] + ng[k] * push;
            out.dir[k][b] = wi[k];
        }
        out.pdf[b] = pdf;
        let ok = pdf.simd_gt(zero)
            & (d.wo_ng[b] * wi_ng).simd_gt(zero)
            & passes(wo_z, z, d.front_only[b]);
        // Throughput, then the roulette on it.
        let beta: [f32x8; 4] = [0, 1, 2, 3].map(|c| d.beta[c][b] * d.albedo[c][b]);
        let carried = beta[0].simd_ne(zero)
            | beta[1].simd_ne(zero)
            | beta[2].simd_ne(zero)
            | beta[3].simd_ne(zero);
        let scale = d.eta_scale[b];
        let q = (beta[0] * scale)
            .max(beta[1] * scale)
            .max(beta[2] * scale)
            .max(beta[3] * scale)
            .min(f32x8::splat(crate::integrator::MAX_SURVIVAL));
        let plays = d.roulette[b].simd_ne(zero);
        let survives = !plays | d.u_rr[b].simd_lt(q);
        for (column, beta) in out.beta.iter_mut().zip(beta) {
            column[b] = plays.select(beta / q, beta);
        }
        out.alive[b] = (ok & carried & survives).select(one, zero);
    }
}
