//! `vcm`: vertex connection and merging (Georgiev, Křivánek, Davidovič and Slusallek 2012;
//! the same estimator as Hachisuka, Pantaleoni and Jensen's unified path sampling), in the
//! form of Georgiev's report "Implementing Vertex Connection and Merging" and SmallVCM. This
//! file is also the engine of `bpm`, which merges only.
//!
//! **Estimates** the measurement equation with every bidirectional strategy at once. Each
//! pass traces one light subpath per pixel of the image (from a light chosen in proportion to
//! power, in importance mode), keeps its non-specular vertices, and puts them in a hashed
//! grid of the pass's radius. Then every pixel's camera sample traces a camera subpath, and
//! at each vertex:
//! * emission it finds (`s = 0`), and at non-specular vertices a light sample (`s = 1`);
//! * connections to every vertex of the light subpath numbered like its pixel (BDPT's
//!   `s, t > 1`: vertex connection);
//! * merges with every stored light vertex of the pass within the radius: a photon density
//!   estimate at every camera vertex, with the light subpath's own power (vertex merging).
//!
//! The light subpaths also connect each vertex to the lens (`t = 1`), splatted with the
//! camera sample of their pixel. One power-heuristic MIS weighs every connection and every
//! merge against all the others that could build the same path, merges counting as
//! `pi r^2 N` light subpaths' worth of samples (`N` = pixels). The weights come from three
//! numbers each subpath carries, updated at each vertex (the report's `dVCM`, `dVC`, `dVM`),
//! so a weight costs O(1) whatever the path's length. As in `bdpt`, a light sample's density
//! is taken as uniform over the light's area in the weights (not the cone a sphere is sampled
//! by), which keeps the weights summing to 1; Russian roulette is left out of them.
//!
//! The radius shrinks as SmallVCM's: `r_i = r_0 / (i + 1)^((1 - alpha) / 2)` in pass `i`.
//!
//! Connections to the lens need a pinhole camera: an orthographic one is refused.
//!
//! **Parameters**: `max-depth` (scattering events, default unlimited), `rr-depth` (default
//! 3), `radius` (first merging radius in scene units; 0 = SmallVCM's default, 0.3% of the
//! scene's bounding radius), `alpha` (default 0.75).
//! **Bias**: merges blur by the radius `r_i` of their pass, which vanishes as passes
//! accumulate (consistent, not unbiased); MIS gives merges weight mostly where connections
//! are poor (caustics seen directly or through specular surfaces). Truncation with a finite
//! `max-depth`.

use crate::bsdf::TransportMode;
use crate::integrator::{
    emit_from_a_light, emitted_at, escaped, scene_radius, stays_on_viewer_side, Demand, Integrator,
    PixelSample, ShadingPoint, Tracer, MAX_SURVIVAL,
};
use crate::photon_map::{Located, PointGrid};
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, ParamKind, ParamSpec, Params, GATHER_RADIUS,
    MAX_DEPTH, RR_DEPTH,
};
use crate::{Camera, Hit, Light, Ray, RayCounters, Rgb, Sampler, Scene};
use crate::{PassContext, SampleContext, Spectrum};
use glam::{Vec2, Vec3, Vec3A};
use rayon::prelude::*;

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "vcm",
    summary: "vertex connection and merging: BDPT's connections and photon merging at every camera vertex under one MIS, shrinking radius (SmallVCM)",
    params: PARAMS,
    build: |p: &Params| Box::new(VertexMerging::new(p, true)),
    // The analytic scenes' radiance is uniform where merges happen: a wide radius costs no
    // bias there.
    analytic: Some(Analytic {
        params: &[("radius", "0.05")],
        furnace: expect(2.0, 40, 900),
        point_in_sphere: expect(1.0, 40, 900),
        sphere_under_sky: expect(1.2, 40, 1600),
    }),
    media: MediaSupport::None,
};

/// The parameters of `vcm` and `bpm`.
pub(super) const PARAMS: &[ParamSpec] = &[
    MAX_DEPTH,
    RR_DEPTH,
    GATHER_RADIUS.with_doc(
        "first merging radius, scene units (0 = 0.3% of the scene's bounding radius, as SmallVCM)",
    ),
    ParamSpec {
        name: "alpha",
        kind: ParamKind::Float,
        default: 0.75,
        min: 0.01,
        max: 1.0,
        doc: "radius reduction: r_i = r_0 / (i + 1)^((1 - alpha) / 2) in pass i",
    },
];

/// Light subpaths traced per parallel work item.
const BLOCK: usize = 1024;

/// Seed offset separating light subpaths from camera samples.
const LIGHT_PATH_SEED: u64 = 0x7663_6d5f_6c69_6768;

/// SmallVCM's default first radius, relative to the scene's bounding radius.
const RADIUS_FACTOR: f32 = 0.003;

/// The power heuristic's exponent applied to a density or a ratio of densities, in f64:
/// the weights multiply squares of distances, densities and `pi r^2 N` along a whole path,
/// beyond f32's range in large scenes.
#[inline]
fn mis(x: impl Into<f64>) -> f64 {
    let x = x.into();
    x * x
}

/// The engine of `vcm` and `bpm`.
pub(super) struct VertexMerging {
    /// Connections (`vcm`); without them only merges and emission seen along specular
    /// chains (`bpm`).
    connect: bool,
    max_depth: u32,
    rr_depth: u32,
    /// First radius; 0 = automatic.
    radius: f32,
    alpha: f32,
    pass: Pass,
}

/// What one pass's camera samples share: the light subpaths and their merging grid.
#[derive(Default)]
struct Pass {
    /// Width of the image whose pixels number the light subpaths.
    width: u32,
    weights: Weights,
    /// Light vertices for connections, subpath by subpath (`vcm` only).
    vertices: Vec<LightVertex>,
    /// `vertex_ends[i]`: the end of subpath `i`'s vertices (its start is `vertex_ends[i - 1]`).
    vertex_ends: Vec<u32>,
    /// Connections of the light subpaths to the lens, subpath by subpath.
    splats: Vec<(Vec2, Rgb)>,
    splat_ends: Vec<u32>,
    /// Every stored light vertex, for merging.
    grid: PointGrid<MergeVertex>,
}

/// The constants of a pass's MIS weights (the report's eq. 20, with one light subpath per
/// camera subpath for connections and `N` for merges).
#[derive(Clone, Copy, Debug, Default)]
struct Weights {
    /// `mis(pi r^2 N)`: a merge against a connection.
    vm: f64,
    /// `mis(1 / (pi r^2 N))` with connections, 0 without: a connection against a merge.
    vc: f64,
    /// `1 / (pi r^2 N)`: the density estimate's normalisation.
    normalization: f32,
}

/// The partial MIS weights a subpath carries (the report's `dVCM`, `dVC`, `dVM`).
#[derive(Clone, Copy, Debug, Default)]
struct Partial {
    vcm: f64,
    vc: f64,
    vm: f64,
}

impl Partial {
    /// Completes the quantities with the segment just traced, of squared length `d2`,
    /// arriving with `|cos|` `cos` at a surface; `d2` is left out for a light subpath's
    /// first segment from a light at infinity.
    #[inline]
    fn arrive(&mut self, d2: Option<f32>, cos: f32) {
        if let Some(d2) = d2 {
            self.vcm *= mis(d2);
        }
        let c = mis(cos);
        self.vcm /= c;
        self.vc /= c;
        self.vm /= c;
    }
}

/// A light-subpath vertex kept for connections: the hit as found (the material is looked up
/// again when it is connected), how the subpath arrived, its power and its weights.
#[derive(Clone, Copy, Debug)]
struct LightVertex {
    hit: Hit,
    dir: Vec3A,
    beta: Rgb,
    /// Segments from the light.
    length: u32,
    mis: Partial,
}

/// A light-subpath vertex as merging needs it (56 bytes).
#[derive(Clone, Copy, Debug)]
struct MergeVertex {
    p: Vec3,
    /// Unit direction back along the subpath (away from the surface).
    wi: Vec3,
    beta: Vec3,
    length: u32,
    vcm: f64,
    vm: f64,
}

impl Located for MergeVertex {
    #[inline]
    fn position(&self) -> Vec3A {
        Vec3A::from(self.p)
    }
}

/// One light subpath's output, appended to a block's.
#[derive(Default)]
struct Traced {
    vertices: Vec<LightVertex>,
    vertex_ends: Vec<u32>,
    merge: Vec<MergeVertex>,
    splats: Vec<(Vec2, Rgb)>,
    splat_ends: Vec<u32>,
    rays: RayCounters,
}

impl VertexMerging {
    pub(super) fn new(p: &Params, connect: bool) -> Self {
        VertexMerging {
            connect,
            max_depth: p.get_depth("max-depth"),
            rr_depth: p.get_u32("rr-depth"),
            radius: p.get("radius") as f32,
            alpha: p.get("alpha") as f32,
            pass: Pass::default(),
        }
    }

    /// The longest path, in segments.
    fn max_segments(&self) -> u32 {
        self.max_depth.saturating_add(1)
    }

    /// The merging radius of pass `pass`.
    fn radius_of_pass(&self, scene: &dyn Scene, pass: u32) -> f32 {
        let r0 = if self.radius > 0.0 {
            self.radius
        } else {
            RADIUS_FACTOR * scene_radius(scene)
        };
        let r = r0 / (pass as f32 + 1.0).powf(0.5 * (1.0 - self.alpha));
        r.max(1e-7)
    }

    /// Traces light subpath `index` of the pass, appending to `out`.
    fn light_subpath(
        &self,
        camera: &Camera,
        w: &Weights,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        out: &mut Traced,
    ) {
        let scene = tracer.scene;
        let max = self.max_segments();
        // Emission: a light in proportion to power, a ray leaving it; the weights' start
        // (the report's eqs. 31-33, with delta lights as eqs. 48-50).
        let Some((index, pmf, le)) = emit_from_a_light(scene, sampler) else {
            return;
        };
        let light = scene.lights().get(index);
        let infinite = at_infinity(light);
        let emission = pmf * le.pdf_pos * le.pdf_dir;
        let direct = pmf * if infinite { le.pdf_dir } else { le.pdf_pos };
        if emission <= 0.0 || direct <= 0.0 {
            return;
        }
        let cos = if le.normal == Vec3A::ZERO {
            1.0
        } else {
            le.normal.dot(le.ray.dir).abs()
        };
        let mut weights = Partial {
            vcm: mis(direct / emission),
            vc: if light.is_delta() {
                0.0
            } else {
                mis(cos / emission)
            },
            vm: 0.0,
        };
        weights.vm = weights.vc * w.vc;
        let mut beta = le.weight / pmf;
        let start = beta.max_element();
        let mut ray = le.ray;
        let mut length = 1u32;
        loop {
            // The next vertex, and the weights completed with the segment to it.
            let Some(hit) = tracer.light(&ray) else {
                return;
            };
            let d2 = (!infinite || length > 1).then(|| (hit.p - ray.origin).length_squared());
            weights.arrive(d2, hit.ng.dot(ray.dir).abs());
            let sp = ShadingPoint::new(&hit, ray.dir, scene);
            // Keep it (for merges, and connections) and connect it to the lens, unless its
            // BSDF is all Dirac lobes.
            if !sp.material.is_specular() {
                out.merge.push(MergeVertex {
                    p: Vec3::from(hit.p),
                    wi: Vec3::from(-ray.dir),
                    beta: Vec3::from(beta),
                    length,
                    vcm: weights.vcm,
                    vm: weights.vm,
                });
                if self.connect {
                    out.vertices.push(LightVertex {
                        hit,
                        dir: ray.dir,
                        beta,
                        length,
                        mis: weights,
                    });
                    if length < max {
                        if let Some(s) = to_lens(&sp, beta, &weights, w, camera, tracer) {
                            out.splats.push(s);
                        }
                    }
                }
            }
            // Scatter, unless no longer path could be connected or merged.
            if length.saturating_add(2) > max {
                return;
            }
            let scattered = scatter(
                &sp,
                TransportMode::Importance,
                w,
                &mut beta,
                &mut weights,
                &mut ray,
                sampler,
            );
            if scattered.is_none() {
                return;
            }
            // Russian roulette, relative to the power the subpath left the light with.
            if length >= self.rr_depth {
                let survive = (beta.max_element() / start).min(MAX_SURVIVAL);
                if survive.is_nan() || sampler.next_1d() >= survive {
                    return;
                }
                beta /= survive;
            }
            length += 1;
        }
    }

    /// The camera subpath of one sample and everything it gathers: emission, light samples,
    /// connections to `light` (its pixel's light subpath) and merges.
    fn camera_subpath(
        &self,
        pixel: &PixelSample,
        camera: &Camera,
        light: &[LightVertex],
        tracer: &mut Tracer,
        sampler: &mut Sampler,
    ) -> Rgb {
        let scene = tracer.scene;
        let w = &self.pass.weights;
        let max = self.max_segments();
        let mut ray = camera.ray(pixel.film.x, pixel.film.y);
        let (_, pdf_dir) = camera.pdf_we(ray.dir);
        if pdf_dir <= 0.0 {
            return Rgb::ZERO;
        }
        // One light subpath per pixel: the ratio of the two is 1/pdf (eqs. 31-33).
        let mut weights = Partial {
            vcm: mis(1.0 / pdf_dir),
            vc: 0.0,
            vm: 0.0,
        };
        let mut beta = Rgb::ONE;
        let mut specular_path = true;
        let mut length = 1u32;
        let mut l = Rgb::ZERO;
        loop {
            let found = if length == 1 {
                tracer.camera(&ray)
            } else {
                tracer.extend(&ray)
            };
            let Some(hit) = found else {
                // Escaped: the environment, weighed before any distance is applied.
                if let Some(env) = scene.lights().environment() {
                    let e = escaped(scene, &ray);
                    l += beta
                        * e
                        * self.emission_weight(
                            scene,
                            env,
                            None,
                            &ray,
                            &weights,
                            length,
                            specular_path,
                            e,
                        );
                }
                return l;
            };
            weights.arrive(
                Some((hit.p - ray.origin).length_squared()),
                hit.ng.dot(ray.dir).abs(),
            );
            let sp = ShadingPoint::new(&hit, ray.dir, scene);
            // Emission found (s = 0).
            if let Some(i) = hit.light {
                let e = emitted_at(scene, &hit, &ray);
                l += beta
                    * e
                    * self.emission_weight(
                        scene,
                        i,
                        Some(&hit),
                        &ray,
                        &weights,
                        length,
                        specular_path,
                        e,
                    );
            }
            if length >= max {
                return l;
            }
            if !sp.material.is_specular() {
                if self.connect {
                    // A light sample (s = 1), then this pixel's light vertices (s > 1).
                    l += beta * light_sample(&sp, &weights, w, tracer, sampler);
                    for v in light {
                        if v.length.saturating_add(length) >= max {
                            break;
                        }
                        l += beta * v.beta * connect(&sp, &weights, v, w, tracer);
                    }
                }
                // Merges with every light vertex within the radius.
                l += beta * merge(&sp, &weights, length, max, &self.pass);
            }
            // Scatter, and Russian roulette.
            let Some(specular) = scatter(
                &sp,
                TransportMode::Radiance,
                w,
                &mut beta,
                &mut weights,
                &mut ray,
                sampler,
            ) else {
                return l;
            };
            specular_path &= specular;
            if length >= self.rr_depth {
                let survive = beta.max_element().min(MAX_SURVIVAL);
                if survive.is_nan() || sampler.next_1d() >= survive {
                    return l;
                }
                beta /= survive;
            }
            length += 1;
        }
    }

    /// The MIS weight of emission `e` from light `index` found by a camera subpath of
    /// `length` segments along `ray`, at `hit` (`None`: the environment) (the report's eq.
    /// 43; for the environment, `weights` are those before the escaping segment).
    #[allow(clippy::too_many_arguments)]
    fn emission_weight(
        &self,
        scene: &dyn Scene,
        index: u32,
        hit: Option<&Hit>,
        ray: &Ray,
        weights: &Partial,
        length: u32,
        specular_path: bool,
        e: Rgb,
    ) -> f32 {
        if e == Rgb::ZERO || length == 1 {
            // Seen directly: no other strategy makes it.
            return 1.0;
        }
        if !self.connect {
            // Merges make every path but those with only specular bounces before the light.
            return if specular_path { 1.0 } else { 0.0 };
        }
        // The densities with which a light sample (`direct`) and a light subpath
        // (`emission`) start this path here, with the light's selection probability.
        let lights = scene.lights();
        let (light, pmf) = (lights.get(index), lights.pmf(index));
        let (direct, emission) = match hit {
            Some(h) => {
                let n = light.emitting_normal_at(h.p);
                let (pos, dir) = light.pdf_le(n, -ray.dir, scene_radius(scene));
                (pmf * pos, pmf * pos * dir)
            }
            None => {
                let (disk, dir) = light.pdf_le(Vec3A::ZERO, -ray.dir, scene_radius(scene));
                (pmf * dir, pmf * disk * dir)
            }
        };
        let w_camera = mis(direct) * weights.vcm + mis(emission) * weights.vc;
        finite_or_zero(1.0 / (1.0 + w_camera))
    }
}

impl Integrator for VertexMerging {
    fn sample(&self, cx: SampleContext) -> Spectrum {
        let SampleContext {
            pixel,
            camera,
            tracer,
            sampler,
            splats,
        } = cx;
        if !camera.is_pinhole() {
            return Rgb::ZERO;
        }
        // This pixel's light subpath: its connections to the lens, its vertices.
        let pass = &self.pass;
        let index = (pixel.y as usize) * (pass.width as usize) + pixel.x as usize;
        let range = |ends: &[u32]| match index {
            0 => 0..ends.first().copied().unwrap_or(0) as usize,
            i if i < ends.len() => ends[i - 1] as usize..ends[i] as usize,
            _ => 0..0,
        };
        for &(film, l) in &pass.splats[range(&pass.splat_ends)] {
            splats.add(film, l);
        }
        let light = &pass.vertices[range(&pass.vertex_ends)];
        self.camera_subpath(pixel, camera, light, tracer, sampler)
    }

    fn prepare_pass(&mut self, cx: &PassContext) -> RayCounters {
        let PassContext {
            scene,
            camera,
            seed,
            pass,
            stop,
            ..
        } = *cx;
        // The pass's radius and weights: one light subpath per pixel.
        let count = camera.width as usize * camera.height as usize;
        let radius = self.radius_of_pass(scene, pass);
        let eta = std::f64::consts::PI * (radius as f64).powi(2) * count as f64;
        let weights = Weights {
            vm: mis(eta),
            vc: if self.connect { mis(1.0 / eta) } else { 0.0 },
            normalization: (1.0 / eta) as f32,
        };
        self.pass = Pass {
            width: camera.width,
            weights,
            ..Pass::default()
        };
        if !camera.is_pinhole() || scene.lights().is_empty() {
            return RayCounters::default();
        }
        // The light subpaths, blocks in parallel, each subpath with its own random numbers.
        let this = &*self;
        let blocks: Vec<Traced> = (0..count.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let mut tracer = Tracer::new(scene);
                let mut out = Traced::default();
                for i in b * BLOCK..((b + 1) * BLOCK).min(count) {
                    if stop.requested() {
                        break;
                    }
                    let mut sampler = Sampler::new(seed ^ LIGHT_PATH_SEED, pass as u64, i as u64);
                    this.light_subpath(camera, &weights, &mut tracer, &mut sampler, &mut out);
                    out.vertex_ends.push(out.vertices.len() as u32);
                    out.splat_ends.push(out.splats.len() as u32);
                }
                out.rays = tracer.counters;
                out
            })
            .collect();
        // Joined in block order, so the pass does not depend on the thread count.
        let mut rays = RayCounters::default();
        let mut merge = Vec::with_capacity(blocks.iter().map(|b| b.merge.len()).sum());
        let p = &mut self.pass;
        for mut b in blocks {
            let (v0, s0) = (p.vertices.len() as u32, p.splats.len() as u32);
            p.vertex_ends.extend(b.vertex_ends.iter().map(|e| e + v0));
            p.splat_ends.extend(b.splat_ends.iter().map(|e| e + s0));
            p.vertices.append(&mut b.vertices);
            p.splats.append(&mut b.splats);
            merge.append(&mut b.merge);
            rays.add(&b.rays);
        }
        // A pass cut short is abandoned by the render loop; should it not be, no pixel may be
        // paired with another's light subpath.
        if p.vertex_ends.len() != count {
            *p = Pass::default();
            return rays;
        }
        p.grid = PointGrid::build(merge, radius);
        rays
    }

    fn demand(&self) -> Demand {
        // About three stored vertices per light subpath, the merging copies held twice while
        // the grid is built.
        let per_vertex = std::mem::size_of::<MergeVertex>() * 2
            + if self.connect {
                std::mem::size_of::<LightVertex>()
            } else {
                0
            };
        Demand {
            rays_per_sample: 2.0,
            memory_per_pixel: 3 * per_vertex as u64 + 16,
            pinhole: true,
            ..Demand::default()
        }
    }
}

/// `x` as f32, or 0 where it is not finite (a weight whose densities overflowed even f64).
#[inline]
fn finite_or_zero(x: f64) -> f32 {
    if x.is_finite() {
        x as f32
    } else {
        0.0
    }
}

/// The light vertex `sp` (power `beta`, weights `weights`) connected to the lens (`t = 1`,
/// the report's eqs. 46-47): the film position and the MIS-weighted radiance it sends there,
/// as `lighttracer`'s connections.
fn to_lens(
    sp: &ShadingPoint,
    beta: Rgb,
    weights: &Partial,
    w: &Weights,
    camera: &Camera,
    tracer: &mut Tracer,
) -> Option<(Vec2, Rgb)> {
    let cs = camera.sample_wi(sp.hit.p)?;
    let f = sp.connection_factor(cs.wi, TransportMode::Importance);
    if f == Rgb::ZERO || cs.pdf <= 0.0 {
        return None;
    }
    // The area density of the camera's ray reaching this point, against this subpath.
    let rev = mis(sp.material.pdf(sp.frame.to_local(cs.wi), sp.wo));
    let (_, pdf_lens) = camera.pdf_we(-cs.wi);
    let camera_area = pdf_lens * sp.hit.ng.dot(cs.wi).abs() / (cs.dist * cs.dist);
    let w_light = mis(camera_area) * (w.vm + weights.vcm + weights.vc * rev);
    let weight = finite_or_zero(1.0 / (w_light + 1.0));
    let l = beta * f * (cs.we * (weight / cs.pdf));
    (l != Rgb::ZERO && l.is_finite() && tracer.connected(&sp.hit, cs.point))
        .then_some((cs.raster, l))
}

/// A light sample at camera vertex `sp` (`s = 1`, the report's eqs. 44-45): its MIS-weighted
/// contribution, before the camera subpath's throughput.
fn light_sample(
    sp: &ShadingPoint,
    weights: &Partial,
    w: &Weights,
    tracer: &mut Tracer,
    sampler: &mut Sampler,
) -> Rgb {
    let scene = tracer.scene;
    let (u_light, u) = (sampler.next_1d(), sampler.next_2d());
    let lights = scene.lights();
    let Some((index, pmf)) = lights.sample(u_light) else {
        return Rgb::ZERO;
    };
    let light = lights.get(index);
    if !sp.can_receive(index, lights) {
        return Rgb::ZERO;
    }
    let Some(ls) = light.sample_li(sp.hit.p, u) else {
        return Rgb::ZERO;
    };
    if ls.pdf <= 0.0 || ls.radiance == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let f = sp.connection_factor(ls.wi, TransportMode::Radiance);
    if f == Rgb::ZERO {
        return Rgb::ZERO;
    }
    // The BSDF's densities towards the light (a delta light cannot be hit) and back.
    let local = sp.frame.to_local(ls.wi);
    let bsdf_dir = if light.is_delta() {
        0.0
    } else {
        sp.material.pdf(sp.wo, local)
    };
    let bsdf_rev = mis(sp.material.pdf(local, sp.wo));
    let cos_here = sp.hit.ng.dot(ls.wi).abs();
    let radius = scene_radius(scene);
    // `w_light`: hitting the light by a BSDF sample against this light sample; `ratio`: the
    // area density of a light subpath reaching this point against the light sample's
    // density of the light point.
    let (w_light, ratio) = if ls.dist.is_finite() {
        let n = light.emitting_normal_at(ls.point);
        let (pos, dir) = light.pdf_le(n, -ls.wi, radius);
        let d2 = ls.dist * ls.dist;
        let w_light = if light.is_delta() {
            0.0
        } else {
            mis(bsdf_dir * n.dot(ls.wi).abs() / (pmf * pos * d2))
        };
        (w_light, dir * cos_here / d2)
    } else {
        let (disk, dir) = light.pdf_le(Vec3A::ZERO, -ls.wi, radius);
        let w_light = if light.is_delta() {
            0.0
        } else {
            mis(bsdf_dir / (pmf * dir))
        };
        (w_light, disk * cos_here)
    };
    let w_camera = mis(ratio) * (w.vm + weights.vcm + weights.vc * bsdf_rev);
    let weight = finite_or_zero(1.0 / (w_light + 1.0 + w_camera));
    let c = f * ls.radiance * (weight / (pmf * ls.pdf));
    if c == Rgb::ZERO || !c.is_finite() || !tracer.unoccluded(&sp.hit, &ls) {
        return Rgb::ZERO;
    }
    c
}

/// Camera vertex `sp` connected to light vertex `v` (the report's eqs. 40-41): the
/// MIS-weighted contribution, before either subpath's throughput.
fn connect(
    sp: &ShadingPoint,
    weights: &Partial,
    v: &LightVertex,
    w: &Weights,
    tracer: &mut Tracer,
) -> Rgb {
    let to = v.hit.p - sp.hit.p;
    let d2 = to.length_squared();
    if d2.is_nan() || d2 <= 0.0 {
        return Rgb::ZERO;
    }
    let dir = to / d2.sqrt();
    let f_camera = sp.connection_factor(dir, TransportMode::Radiance);
    if f_camera == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let lsp = ShadingPoint::new(&v.hit, v.dir, tracer.scene);
    let f_light = lsp.connection_factor(-dir, TransportMode::Importance);
    if f_light == Rgb::ZERO {
        return Rgb::ZERO;
    }
    // Each side's BSDF densities along the connection and back, the former as area
    // densities at the other vertex.
    let (cl, ll) = (sp.frame.to_local(dir), lsp.frame.to_local(-dir));
    let camera_area = sp.material.pdf(sp.wo, cl) * lsp.hit.ng.dot(dir).abs() / d2;
    let light_area = lsp.material.pdf(lsp.wo, ll) * sp.hit.ng.dot(dir).abs() / d2;
    let camera_rev = mis(sp.material.pdf(cl, sp.wo));
    let light_rev = mis(lsp.material.pdf(ll, lsp.wo));
    let w_light = mis(camera_area) * (w.vm + v.mis.vcm + v.mis.vc * light_rev);
    let w_camera = mis(light_area) * (w.vm + weights.vcm + weights.vc * camera_rev);
    let weight = finite_or_zero(1.0 / (w_light + 1.0 + w_camera));
    let c = f_camera * f_light * (weight / d2);
    if c == Rgb::ZERO || !c.is_finite() || !tracer.connected_to(&lsp.hit, &sp.hit) {
        return Rgb::ZERO;
    }
    c
}

/// Camera vertex `sp`, `length` segments from the lens, merged with every light vertex of
/// the pass within its radius (the report's eqs. 37-39): the MIS-weighted density estimate,
/// before the camera subpath's throughput.
fn merge(sp: &ShadingPoint, weights: &Partial, length: u32, max: u32, pass: &Pass) -> Rgb {
    let w = &pass.weights;
    let mut sum = Rgb::ZERO;
    pass.grid.for_each_near(sp.hit.p, |v| {
        if v.length.saturating_add(length) > max {
            return;
        }
        let wi = Vec3A::from(v.wi);
        if !stays_on_viewer_side(&sp.material, sp.hit.ng, sp.wo_world, wi) {
            return;
        }
        let local = sp.frame.to_local(wi);
        let f = sp.material.eval(sp.wo, local);
        if f == Rgb::ZERO {
            return;
        }
        let w_light = v.vcm * w.vc + v.vm * mis(sp.material.pdf(sp.wo, local));
        let w_camera = weights.vcm * w.vc + weights.vm * mis(sp.material.pdf(local, sp.wo));
        let weight = finite_or_zero(1.0 / (w_light + 1.0 + w_camera));
        sum += f * Vec3A::from(v.beta) * weight;
    });
    sum * w.normalization
}

/// Light at infinity: the environment and directional lights.
#[inline]
fn at_infinity(light: &Light) -> bool {
    light.is_environment() || matches!(light, Light::Directional(_))
}

/// One BSDF sample continuing a subpath in `mode`: the throughput, the next ray, and the
/// weights for the next vertex (the report's eqs. 34-36, specular bounces as eqs. 53-55).
/// Whether the sample was specular; `None` ends the subpath.
#[inline]
fn scatter(
    sp: &ShadingPoint,
    mode: TransportMode,
    w: &Weights,
    beta: &mut Rgb,
    weights: &mut Partial,
    ray: &mut Ray,
    sampler: &mut Sampler,
) -> Option<bool> {
    let s = sp.sample(sampler.next_1d(), sampler.next_2d(), mode)?;
    let cos = sp.hit.ng.dot(s.wi).abs();
    if s.bsdf.specular {
        weights.vcm = 0.0;
        weights.vc *= mis(cos);
        weights.vm *= mis(cos);
    } else {
        let fwd = s.bsdf.pdf;
        if fwd.is_nan() || fwd <= 0.0 {
            return None;
        }
        let rev = mis(sp.material.pdf(sp.frame.to_local(s.wi), sp.wo));
        let g = mis(cos / fwd);
        let next = Partial {
            vc: g * (weights.vc * rev + weights.vcm + w.vm),
            vm: g * (weights.vm * rev + weights.vcm * w.vc + 1.0),
            vcm: mis(1.0 / fwd),
        };
        *weights = next;
    }
    *beta = s.throughput(*beta);
    if !(beta.is_finite() && *beta != Rgb::ZERO) {
        return None;
    }
    *ray = sp.hit.spawn_ray(s.wi);
    Some(s.bsdf.specular)
}
