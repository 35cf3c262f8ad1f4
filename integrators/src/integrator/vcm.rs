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
//! **In participating media** (photon points, as SmallUPBP's point-to-point estimator):
//! both subpaths walk media by delta tracking (one channel's rate, each channel's density
//! riding along as in `volpath`), make a vertex at every real scattering event in a medium
//! and cross `Null` boundaries without one. Medium vertices connect (to the lens, to light
//! samples, to each other) through ratio-tracked transmittance, with the phase function in
//! place of the BSDF, and merge with the light vertices in media within the radius: `sum
//! phase beta / (sigma_s 4/3 pi r^3 N)`. In the MIS weights a medium vertex is a surface
//! vertex without cosines, merges there count as `4/3 pi r^3 N` samples' worth, and each
//! vertex's own kernel enters the weights (a subpath's `dVM` is rescaled by the ratio of the
//! kernels where it passes from a surface to a medium vertex or back), so one path's
//! weights still sum to one; distances' densities and transmittance are left out of them, as
//! in `bdpt`. Media that emit are refused.
//!
//! The radius shrinks as SmallVCM's: `r_i = r_0 / (i + 1)^((1 - alpha) / 2)` in pass `i`.
//!
//! Connections to the lens need a pinhole camera: an orthographic one is refused.
//!
//! **Parameters**: `max-depth` (scattering events, default unlimited), `rr-depth` (default
//! 3), `radius` (first merging radius in scene units; 0 = SmallVCM's default, 0.3% of the
//! scene's bounding radius), `volume-radius` (first merging radius in media; 0 = `radius`
//! for `vcm`, 5 times it for `bpm`; it shrinks as `(i + 1)^((alpha - 1) / 3)`), `alpha`
//! (default 0.75).
//! **Bias**: merges blur by the radius `r_i` of their pass, which vanishes as passes
//! accumulate (consistent, not unbiased; in media also a darkening within `r_i` of a
//! medium's boundary); MIS gives merges weight mostly where connections are poor (caustics
//! seen directly or through specular surfaces, volumetric caustics). Truncation with a
//! finite `max-depth`.

use crate::bsdf::TransportMode;
use crate::integrator::media_walk::{
    cross_null, fly, hero_channel, medium_at, over_sigma_s, ray_from_point, transmittance, Flight,
};
use crate::integrator::volpath::LONG_PATH;
use crate::integrator::{
    emit_from_a_light, emitted_at, escaped, scene_radius, stays_on_viewer_side, Demand, Integrator,
    PixelSample, ShadingPoint, Tracer, MAX_SURVIVAL,
};
use crate::medium::Phase;
use crate::photon_map::{Located, PointGrid};
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, ParamKind, ParamSpec, Params, SpectralSupport,
    GATHER_RADIUS, MAX_DEPTH, RR_DEPTH,
};
use crate::spectrum::Wavelengths;
use crate::{
    Camera, Hit, Light, MediumId, MediumInterface, Ray, RayCounters, Sampler, Scene, Spectrum,
};
use crate::{PassContext, SampleContext};
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
    media: MediaSupport::Scattering,
    spectral: SpectralSupport::PerPass,
};

/// The parameters of `vcm` and `bpm`.
pub(super) const PARAMS: &[ParamSpec] = &[
    MAX_DEPTH,
    RR_DEPTH,
    GATHER_RADIUS.with_doc(
        "first merging radius, scene units (0 = 0.3% of the scene's bounding radius, as SmallVCM)",
    ),
    GATHER_RADIUS.with_name("volume-radius").with_doc(
        "first merging radius in media, scene units (0 = the first merging radius for vcm, 5 times it for bpm)",
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

/// `bpm`'s default first merging radius in media, relative to the first radius on surfaces:
/// a ball of the surfaces' radius in a thin fog holds few light vertices, and merges, its
/// only strategy, would be fireflies there (fog room at 10 s: relMSE 83.7 with the surfaces'
/// radius, 1.09 with five times it). `vcm` keeps the surfaces' radius: connections carry
/// most of the light in fog, and merges the volumetric caustics, which a wider ball blurs
/// (volumetric caustic: relMSE 0.0032 against 0.0047 at five times).
const BPM_VOLUME_RADIUS_FACTOR: f32 = 5.0;

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
    /// First radius in media; 0 = automatic.
    volume_radius: f32,
    alpha: f32,
    pass: Pass,
}

/// What one pass's camera samples share: the light subpaths and their merging grids.
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
    splats: Vec<(Vec2, Spectrum)>,
    splat_ends: Vec<u32>,
    /// Every stored light vertex on a surface, for merging.
    grid: PointGrid<MergeVertex>,
    /// Every stored light vertex in a medium, for merging there.
    volume: PointGrid<MergeVertex>,
    /// The wavelengths every subpath of the pass carries, light and camera alike (merging
    /// joins a camera subpath to any light subpath).
    lambda: Wavelengths,
}

/// The constants of a pass's MIS weights, for merges of one kind (the report's eq. 20, with
/// one light subpath per camera subpath for connections and `N` for merges).
#[derive(Clone, Copy, Debug, Default)]
struct Kernel {
    /// `mis(eta)`, `eta` the kernel's size times `N` (`pi r^2 N` on surfaces, `4/3 pi r^3 N`
    /// in media): a merge against a connection.
    vm: f64,
    /// `mis(1 / eta)` with connections, 0 without: a connection against a merge.
    vc: f64,
    /// `1 / eta`: the density estimate's normalisation.
    normalization: f32,
}

impl Kernel {
    fn new(eta: f64, connect: bool) -> Kernel {
        Kernel {
            vm: mis(eta),
            vc: if connect { mis(1.0 / eta) } else { 0.0 },
            normalization: (1.0 / eta) as f32,
        }
    }
}

/// The MIS constants of merges at surface vertices and at medium vertices. Each vertex's own
/// kernel enters the weights of the strategies that merge there, so the weights of one
/// path still sum to one.
#[derive(Clone, Copy, Debug, Default)]
struct Weights {
    surface: Kernel,
    medium: Kernel,
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
    /// arriving with `|cos|` `cos` at a surface (1 at a medium vertex); `d2` is left out for
    /// a light subpath's first segment from a light at infinity.
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

/// The kind of vertex a subpath's `vm` is relative to merging at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Left {
    Surface,
    Medium,
}

impl Partial {
    /// Makes `vm`, relative to merging at a vertex of kind `left` (the one the subpath
    /// left, whose kernel the update used), relative to merging at `at`: times the ratio of
    /// their kernels where the kinds differ (a path's merges at surface and medium vertices
    /// weigh by their own kernels, `pi r^2 N` and `4/3 pi r^3 N`).
    #[inline]
    fn merge_here(&mut self, left: &mut Left, at: &At, w: &Weights) {
        let here = match at {
            At::Surface(_) => Left::Surface,
            At::Medium(_) => Left::Medium,
        };
        if here != *left {
            let from = match left {
                Left::Surface => &w.surface,
                Left::Medium => &w.medium,
            };
            self.vm *= from.vm / at.kernel(w).vm;
            *left = here;
        }
    }
}

/// A point in a medium where a subpath scattered.
#[derive(Clone, Copy, Debug)]
struct InMedium {
    p: Vec3A,
    /// Unit direction back along the ray that arrived.
    wo: Vec3A,
    medium: MediumId,
    phase: Phase,
}

/// A subpath's scattering point: a surface, or a real collision in a medium. In the MIS
/// weights a medium vertex is a surface vertex without cosines; distances' densities and
/// transmittance are left out of them (as `bdpt`'s), which keeps every path's weights
/// summing to one.
enum At<'s, 'a> {
    Surface(&'s ShadingPoint<'a>),
    Medium(InMedium),
}

impl At<'_, '_> {
    #[inline]
    fn p(&self) -> Vec3A {
        match self {
            At::Surface(sp) => sp.hit.p,
            At::Medium(m) => m.p,
        }
    }

    /// The hit to spawn a connection from (a medium vertex: a point with no offset normal,
    /// in its medium).
    fn hit(&self) -> Hit {
        match self {
            At::Surface(sp) => sp.hit,
            At::Medium(m) => medium_hit(m.p, m.medium),
        }
    }

    /// Whether every lobe is a Dirac delta (nothing to connect or merge).
    #[inline]
    fn is_specular(&self) -> bool {
        match self {
            At::Surface(sp) => sp.material.is_specular(),
            At::Medium(_) => false,
        }
    }

    /// The BSDF with `|cos|` and the shading-normal correction in `mode`, or the phase
    /// function, towards `wi` (world).
    #[inline]
    fn f(&self, wi: Vec3A, mode: TransportMode) -> Spectrum {
        match self {
            At::Surface(sp) => sp.connection_factor(wi, mode),
            At::Medium(m) => Spectrum::splat(m.phase.eval(m.wo, wi)),
        }
    }

    /// The solid-angle density of sampling `wi` (world) from the arriving direction.
    #[inline]
    fn pdf_to(&self, wi: Vec3A) -> f32 {
        match self {
            At::Surface(sp) => sp.material.pdf(sp.wo, sp.frame.to_local(wi)),
            At::Medium(m) => m.phase.eval(m.wo, wi),
        }
    }

    /// The reverse: the density of sampling the arriving direction from `wi` (world).
    #[inline]
    fn pdf_from(&self, wi: Vec3A) -> f32 {
        match self {
            At::Surface(sp) => sp.material.pdf(sp.frame.to_local(wi), sp.wo),
            At::Medium(m) => m.phase.eval(wi, m.wo),
        }
    }

    /// `|cos|` of `dir` at a surface; 1 in a medium.
    #[inline]
    fn cos(&self, dir: Vec3A) -> f32 {
        match self {
            At::Surface(sp) => sp.hit.ng.dot(dir).abs(),
            At::Medium(_) => 1.0,
        }
    }

    /// The merging constants of this kind of vertex.
    #[inline]
    fn kernel<'w>(&self, w: &'w Weights) -> &'w Kernel {
        match self {
            At::Surface(_) => &w.surface,
            At::Medium(_) => &w.medium,
        }
    }
}

/// A point in `medium` as a hit to spawn rays from.
fn medium_hit(p: Vec3A, medium: MediumId) -> Hit {
    Hit {
        media: MediumInterface {
            inside: medium,
            outside: medium,
        },
        ..Hit::new(0.0, p, Vec3A::ZERO, 0, None)
    }
}

/// Where a light-subpath vertex kept for connections lies.
#[derive(Clone, Copy, Debug)]
enum Stored {
    /// On a surface: the hit as found (the material is looked up again when it is
    /// connected) and the direction the subpath arrived along.
    Surface {
        hit: Hit,
        dir: Vec3A,
    },
    Medium(InMedium),
}

impl Stored {
    #[inline]
    fn p(&self) -> Vec3A {
        match self {
            Stored::Surface { hit, .. } => hit.p,
            Stored::Medium(m) => m.p,
        }
    }

    /// The surface's shading point, for [`At::Surface`] to borrow (`None` in a medium).
    fn shading<'a>(&self, scene: &'a dyn Scene, lambda: &Wavelengths) -> Option<ShadingPoint<'a>> {
        match *self {
            Stored::Surface { hit, dir } => {
                Some(ShadingPoint::new(&hit, dir, scene, &mut { *lambda }))
            }
            Stored::Medium(_) => None,
        }
    }

    /// The vertex, with the shading point [`Stored::shading`] made (`None`: a surface's is
    /// missing).
    fn at<'s, 'a>(&self, shading: &'s Option<ShadingPoint<'a>>) -> Option<At<'s, 'a>> {
        match (self, shading) {
            (_, Some(sp)) => Some(At::Surface(sp)),
            (Stored::Medium(m), None) => Some(At::Medium(*m)),
            (Stored::Surface { .. }, None) => None,
        }
    }
}

/// A light-subpath vertex kept for connections: where it lies, its power and its weights.
#[derive(Clone, Copy, Debug)]
struct LightVertex {
    at: Stored,
    /// Power (in media, over the average of the channels' densities).
    beta: Spectrum,
    /// Segments from the light.
    length: u32,
    mis: Partial,
}

/// A light-subpath vertex as merging needs it (64 bytes).
#[derive(Clone, Copy, Debug)]
struct MergeVertex {
    p: Vec3,
    /// Unit direction back along the subpath (away from the surface).
    wi: Vec3,
    /// Its power; in a medium over `sigma_s` there (so that a merge blurs the in-scattered
    /// radiance, not the medium's coefficient), per lane of a [`Spectrum`].
    beta: [f32; 4],
    length: u32,
    /// The medium it lies in (`MediumId::VACUUM` on a surface).
    medium: MediumId,
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
    volume: Vec<MergeVertex>,
    splats: Vec<(Vec2, Spectrum)>,
    splat_ends: Vec<u32>,
    rays: RayCounters,
}

/// A subpath's state in media: the hero channel of its free flights and each channel's
/// density over the hero's (see `media_walk`).
struct Walk {
    hero: usize,
    r_u: Spectrum,
}

impl Walk {
    fn new(sampler: &mut Sampler, lambda: &Wavelengths) -> Walk {
        Walk {
            hero: hero_channel(sampler.next_1d(), lambda),
            r_u: Spectrum::ONE,
        }
    }
}

impl VertexMerging {
    pub(super) fn new(p: &Params, connect: bool) -> Self {
        VertexMerging {
            connect,
            max_depth: p.get_depth("max-depth"),
            rr_depth: p.get_u32("rr-depth"),
            radius: p.get("radius") as f32,
            volume_radius: p.get("volume-radius") as f32,
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
        let r = self.first_radius(scene) / (pass as f32 + 1.0).powf(0.5 * (1.0 - self.alpha));
        r.max(1e-7)
    }

    fn first_radius(&self, scene: &dyn Scene) -> f32 {
        if self.radius > 0.0 {
            self.radius
        } else {
            RADIUS_FACTOR * scene_radius(scene)
        }
    }

    /// The merging radius in media of pass `pass`: it shrinks as `(i + 1)^((alpha - 1) / 3)`,
    /// the three-dimensional form of the surfaces' schedule (Knaus and Zwicker).
    fn volume_radius_of_pass(&self, scene: &dyn Scene, pass: u32) -> f32 {
        let r0 = if self.volume_radius > 0.0 {
            self.volume_radius
        } else {
            let factor = if self.connect {
                1.0
            } else {
                BPM_VOLUME_RADIUS_FACTOR
            };
            factor * self.first_radius(scene)
        };
        let r = r0 / (pass as f32 + 1.0).powf((1.0 - self.alpha) / 3.0);
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
        let mut lambda = self.pass.lambda;
        let lambda = &mut lambda;
        // Emission: a light in proportion to power, a ray leaving it; the weights' start
        // (the report's eqs. 31-33, with delta lights as eqs. 48-50).
        let Some((index, pmf, le)) = emit_from_a_light(scene, sampler, lambda) else {
            return;
        };
        let light = scene.lights().get(index);
        let infinite = at_infinity(&light);
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
        weights.vm = weights.vc * w.surface.vc;
        let mut beta = le.weight / pmf;
        let start = beta.max_element();
        let mut ray = le.ray;
        let mut length = 1u32;
        // In media: the light's medium (walked to from the camera's), the walk's channels,
        // and the last vertex (a segment may cross `Null` boundaries on its way).
        let mut walk = None;
        if scene.has_media() {
            walk = Some(Walk::new(sampler, lambda));
            ray.medium = medium_at(scene, camera.eye, scene.camera_medium(), ray.origin);
        }
        let mut from = ray.origin;
        // The kind of vertex `weights.vm` is relative to merging at (the start's: a surface).
        let mut left = Left::Surface;
        loop {
            // The next vertex, and the weights completed with the segment to it.
            let found = tracer.light(&ray);
            let mut at = None;
            if let Some(walk) = walk.as_mut() {
                let tmax = found.map_or(f32::INFINITY, |h| h.t);
                match fly(
                    scene,
                    &ray,
                    tmax,
                    walk.hero,
                    lambda,
                    sampler,
                    &mut beta,
                    &mut walk.r_u,
                ) {
                    Flight::Ended => return,
                    Flight::Through => {}
                    Flight::Scattered(p) => {
                        let phase = match scene.medium(ray.medium) {
                            Some(m) => m.phase(),
                            None => return,
                        };
                        let wo = -ray.dir;
                        at = Some(At::Medium(InMedium {
                            p,
                            wo,
                            medium: ray.medium,
                            phase,
                        }));
                    }
                }
            }
            // The hit as found (a shading point parametrises its copy).
            let raw = found;
            let sp;
            let at = match at {
                Some(at) => at,
                None => {
                    let Some(hit) = found else {
                        return;
                    };
                    sp = ShadingPoint::new(&hit, ray.dir, scene, lambda);
                    if walk.is_some() {
                        // A medium's boundary (or a mask's hole): crossed, no vertex.
                        match cross_null(&sp, &ray, TransportMode::Importance, &mut beta, sampler) {
                            Some(Some(next)) => {
                                ray = next;
                                continue;
                            }
                            Some(None) => return,
                            None => {}
                        }
                    }
                    At::Surface(&sp)
                }
            };
            let p = at.p();
            let d2 = (!infinite || length > 1).then(|| (p - from).length_squared());
            weights.arrive(d2, at.cos(ray.dir));
            weights.merge_here(&mut left, &at, w);
            // The power this vertex carries (in media, over the channels' average density).
            let power = walk
                .as_ref()
                .map_or(beta, |walk| beta / lambda.average(walk.r_u));
            // Keep it (for merges, and connections) and connect it to the lens, unless its
            // BSDF is all Dirac lobes.
            if !at.is_specular() {
                let (merged, medium) = match &at {
                    At::Surface(_) => (power, MediumId::VACUUM),
                    At::Medium(m) => {
                        let sigma_s = scene
                            .medium(m.medium)
                            .map_or(Spectrum::ZERO, |md| md.at(p, lambda).sigma_s);
                        (over_sigma_s(power, sigma_s), m.medium)
                    }
                };
                let kept = MergeVertex {
                    p: Vec3::from(p),
                    wi: Vec3::from(-ray.dir),
                    beta: merged.to_array(),
                    length,
                    medium,
                    vcm: weights.vcm,
                    vm: weights.vm,
                };
                match &at {
                    At::Surface(_) => out.merge.push(kept),
                    At::Medium(_) => out.volume.push(kept),
                }
                if self.connect {
                    out.vertices.push(LightVertex {
                        at: match (&at, raw) {
                            (At::Surface(_), Some(hit)) => Stored::Surface { hit, dir: ray.dir },
                            (At::Surface(sp), None) => Stored::Surface {
                                hit: sp.hit,
                                dir: ray.dir,
                            },
                            (At::Medium(m), _) => Stored::Medium(*m),
                        },
                        beta: power,
                        length,
                        mis: weights,
                    });
                    if length < max {
                        let seen = to_lens(
                            &at,
                            power,
                            &weights,
                            w,
                            camera,
                            tracer,
                            &mut *sampler,
                            lambda,
                        );
                        if let Some(s) = seen {
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
                &at,
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
            // The segment's start: the vertex (a segment may cross `Null` boundaries in
            // media), or as without media the ray's offset origin.
            from = if walk.is_some() { p } else { ray.origin };
            // Russian roulette, relative to the power the subpath left the light with. In
            // media a subpath that lost nothing (a white fog) plays only after `LONG_PATH`
            // events: a cap from the first would make its vertices' powers heavy-tailed.
            if length >= self.rr_depth {
                let carried = match walk.as_ref() {
                    Some(walk) => (beta / lambda.average(walk.r_u)).max_element(),
                    None => beta.max_element(),
                };
                let ratio = carried / start;
                if walk.is_none() || ratio < 1.0 || length >= LONG_PATH || ratio.is_nan() {
                    let survive = ratio.min(MAX_SURVIVAL);
                    if survive.is_nan() || sampler.next_1d() >= survive {
                        return;
                    }
                    beta /= survive;
                }
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
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        let scene = tracer.scene;
        let w = &self.pass.weights;
        let max = self.max_segments();
        let mut ray = camera.ray(pixel.film.x, pixel.film.y);
        let (_, pdf_dir) = camera.pdf_we(ray.dir);
        if pdf_dir <= 0.0 {
            return Spectrum::ZERO;
        }
        // One light subpath per pixel: the ratio of the two is 1/pdf (eqs. 31-33).
        let mut weights = Partial {
            vcm: mis(1.0 / pdf_dir),
            vc: 0.0,
            vm: 0.0,
        };
        let mut beta = Spectrum::ONE;
        let mut specular_path = true;
        let mut length = 1u32;
        let mut l = Spectrum::ZERO;
        // In media: the walk's channels, from the camera's medium.
        let mut walk = None;
        if scene.has_media() {
            walk = Some(Walk::new(sampler, lambda));
            ray.medium = scene.camera_medium();
        }
        let mut from = ray.origin;
        let mut left = Left::Surface;
        let mut first = true;
        loop {
            let found = if first {
                tracer.camera(&ray)
            } else {
                tracer.extend(&ray)
            };
            first = false;
            let mut at = None;
            if let Some(walk) = walk.as_mut() {
                let tmax = found.map_or(f32::INFINITY, |h| h.t);
                match fly(
                    scene,
                    &ray,
                    tmax,
                    walk.hero,
                    lambda,
                    sampler,
                    &mut beta,
                    &mut walk.r_u,
                ) {
                    Flight::Ended => return l,
                    Flight::Through => {}
                    Flight::Scattered(p) => {
                        let Some(medium) = scene.medium(ray.medium) else {
                            return l;
                        };
                        at = Some(At::Medium(InMedium {
                            p,
                            wo: -ray.dir,
                            medium: ray.medium,
                            phase: medium.phase(),
                        }));
                    }
                }
            }
            // This vertex's throughput (in media, over the channels' average density).
            let carried = walk
                .as_ref()
                .map_or(beta, |walk| beta / lambda.average(walk.r_u));
            let sp;
            let at = match at {
                Some(at) => at,
                None => {
                    let Some(hit) = found else {
                        // Escaped: the environment, weighed before any distance is applied.
                        if let Some(env) = scene.lights().environment() {
                            let e = escaped(scene, &ray, lambda);
                            l += carried
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
                    sp = ShadingPoint::new(&hit, ray.dir, scene, lambda);
                    if walk.is_some() {
                        // A medium's boundary (or a mask's hole): crossed, no vertex.
                        match cross_null(&sp, &ray, TransportMode::Radiance, &mut beta, sampler) {
                            Some(Some(next)) => {
                                ray = next;
                                continue;
                            }
                            Some(None) => return l,
                            None => {}
                        }
                    }
                    At::Surface(&sp)
                }
            };
            weights.arrive(Some((at.p() - from).length_squared()), at.cos(ray.dir));
            weights.merge_here(&mut left, &at, w);
            // Emission found (s = 0).
            if let At::Surface(sp) = &at {
                if let Some(i) = sp.hit.light {
                    let e = emitted_at(scene, &sp.hit, &ray, lambda);
                    l += carried
                        * e
                        * self.emission_weight(
                            scene,
                            i,
                            Some(&sp.hit),
                            &ray,
                            &weights,
                            length,
                            specular_path,
                            e,
                        );
                }
            }
            if length >= max {
                return l;
            }
            if !at.is_specular() {
                if self.connect {
                    // A light sample (s = 1), then this pixel's light vertices (s > 1).
                    l += carried * light_sample(&at, &weights, w, tracer, sampler, lambda);
                    for v in light {
                        if v.length.saturating_add(length) >= max {
                            break;
                        }
                        l += carried
                            * v.beta
                            * connect(&at, &weights, v, w, tracer, sampler, lambda);
                    }
                }
                // Merges with every light vertex within the radius.
                l += carried * merge(&at, &weights, length, max, &self.pass);
            }
            // Scatter, and Russian roulette.
            let Some(specular) = scatter(
                &at,
                TransportMode::Radiance,
                w,
                &mut beta,
                &mut weights,
                &mut ray,
                sampler,
            ) else {
                return l;
            };
            from = if walk.is_some() { at.p() } else { ray.origin };
            specular_path &= specular;
            if length >= self.rr_depth {
                let survive = match walk.as_ref() {
                    Some(walk) => {
                        let rr = (beta / lambda.average(walk.r_u)).max_element();
                        if rr >= 1.0 && length < LONG_PATH {
                            1.0
                        } else {
                            rr.min(MAX_SURVIVAL)
                        }
                    }
                    None => beta.max_element().min(MAX_SURVIVAL),
                };
                if survive.is_nan() || survive < 1.0 {
                    if survive.is_nan() || sampler.next_1d() >= survive {
                        return l;
                    }
                    beta /= survive;
                }
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
        e: Spectrum,
    ) -> f32 {
        if e == Spectrum::ZERO || length == 1 {
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
            lambda,
        } = cx;
        if !camera.is_pinhole() {
            return Spectrum::ZERO;
        }
        // This pixel's light subpath: its connections to the lens, its vertices; the
        // camera subpath carries the pass's wavelengths.
        let pass = &self.pass;
        *lambda = pass.lambda;
        let index = (pixel.y as usize) * (pass.width as usize) + pixel.x as usize;
        let range = |ends: &[u32]| match index {
            0 => 0..ends.first().copied().unwrap_or(0) as usize,
            i if i < ends.len() => ends[i - 1] as usize..ends[i] as usize,
            _ => 0..0,
        };
        for &(film, l) in &pass.splats[range(&pass.splat_ends)] {
            splats.add(film, l, &pass.lambda);
        }
        let light = &pass.vertices[range(&pass.vertex_ends)];
        self.camera_subpath(pixel, camera, light, tracer, sampler, lambda)
    }

    fn prepare_pass(&mut self, cx: &PassContext) -> RayCounters {
        let PassContext {
            scene,
            camera,
            seed,
            pass,
            stop,
            lambda,
            ..
        } = *cx;
        // The pass's radius and weights: one light subpath per pixel.
        let count = camera.width as usize * camera.height as usize;
        let radius = self.radius_of_pass(scene, pass);
        let volume_radius = self.volume_radius_of_pass(scene, pass);
        let (r, rv) = (radius as f64, volume_radius as f64);
        let pi = std::f64::consts::PI;
        let weights = Weights {
            surface: Kernel::new(pi * r.powi(2) * count as f64, self.connect),
            medium: Kernel::new(4.0 / 3.0 * pi * rv.powi(3) * count as f64, self.connect),
        };
        self.pass = Pass {
            width: camera.width,
            weights,
            lambda,
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
        let mut volume = Vec::with_capacity(blocks.iter().map(|b| b.volume.len()).sum());
        let p = &mut self.pass;
        for mut b in blocks {
            let (v0, s0) = (p.vertices.len() as u32, p.splats.len() as u32);
            p.vertex_ends.extend(b.vertex_ends.iter().map(|e| e + v0));
            p.splat_ends.extend(b.splat_ends.iter().map(|e| e + s0));
            p.vertices.append(&mut b.vertices);
            p.splats.append(&mut b.splats);
            merge.append(&mut b.merge);
            volume.append(&mut b.volume);
            rays.add(&b.rays);
        }
        // A pass cut short is abandoned by the render loop; should it not be, no pixel may be
        // paired with another's light subpath.
        if p.vertex_ends.len() != count {
            *p = Pass::default();
            return rays;
        }
        p.grid = PointGrid::build(merge, radius);
        p.volume = PointGrid::build(volume, volume_radius);
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

/// Whether the segment `ray` is clear, and in media its transmittance (through media and
/// `Null` boundaries): what a connection along it carries.
fn visible(
    ray: &Ray,
    tracer: &mut Tracer,
    sampler: &mut Sampler,
    lambda: &Wavelengths,
) -> Spectrum {
    if tracer.scene.has_media() {
        transmittance(tracer, ray, lambda, sampler)
    } else {
        tracer.counters.connection += 1;
        if tracer.scene.occluded(ray) {
            Spectrum::ZERO
        } else {
            Spectrum::ONE
        }
    }
}

/// The light vertex `at` (power `beta`, weights `weights`) connected to the lens (`t = 1`,
/// the report's eqs. 46-47): the film position and the MIS-weighted radiance it sends there,
/// as `lighttracer`'s connections.
#[allow(clippy::too_many_arguments)]
fn to_lens(
    at: &At,
    beta: Spectrum,
    weights: &Partial,
    w: &Weights,
    camera: &Camera,
    tracer: &mut Tracer,
    sampler: &mut Sampler,
    lambda: &Wavelengths,
) -> Option<(Vec2, Spectrum)> {
    let cs = camera.sample_wi(at.p())?;
    let f = at.f(cs.wi, TransportMode::Importance);
    if f == Spectrum::ZERO || cs.pdf <= 0.0 {
        return None;
    }
    // The area density of the camera's ray reaching this point, against this subpath.
    let rev = mis(at.pdf_from(cs.wi));
    let (_, pdf_lens) = camera.pdf_we(-cs.wi);
    let camera_area = pdf_lens * at.cos(cs.wi) / (cs.dist * cs.dist);
    let w_light = mis(camera_area) * (at.kernel(w).vm + weights.vcm + weights.vc * rev);
    let weight = finite_or_zero(1.0 / (w_light + 1.0));
    let l = beta * f * (cs.we * (weight / cs.pdf));
    if l == Spectrum::ZERO || !l.is_finite() {
        return None;
    }
    let ray = match at {
        At::Surface(sp) => sp.hit.spawn_ray_to(cs.point),
        At::Medium(m) => Ray {
            origin: m.p,
            dir: cs.wi,
            tmax: cs.dist * (1.0 - 1e-4),
            medium: m.medium,
        },
    };
    let l = l * visible(&ray, tracer, sampler, lambda);
    (l != Spectrum::ZERO && l.is_finite()).then_some((cs.raster, l))
}

/// A light sample at camera vertex `at` (`s = 1`, the report's eqs. 44-45): its
/// MIS-weighted contribution, before the camera subpath's throughput.
fn light_sample(
    at: &At,
    weights: &Partial,
    w: &Weights,
    tracer: &mut Tracer,
    sampler: &mut Sampler,
    lambda: &Wavelengths,
) -> Spectrum {
    let scene = tracer.scene;
    let (u_light, u) = (sampler.next_1d(), sampler.next_2d());
    let lights = scene.lights();
    let Some((index, pmf)) = lights.sample(u_light) else {
        return Spectrum::ZERO;
    };
    let light = lights.get(index);
    if let At::Surface(sp) = at {
        if !sp.can_receive(index, lights) {
            return Spectrum::ZERO;
        }
    }
    let Some(ls) = light.sample_li(at.p(), u, lambda) else {
        return Spectrum::ZERO;
    };
    if ls.pdf <= 0.0 || ls.radiance == Spectrum::ZERO {
        return Spectrum::ZERO;
    }
    let f = at.f(ls.wi, TransportMode::Radiance);
    if f == Spectrum::ZERO {
        return Spectrum::ZERO;
    }
    // The BSDF's densities towards the light (a delta light cannot be hit) and back.
    let bsdf_dir = if light.is_delta() {
        0.0
    } else {
        at.pdf_to(ls.wi)
    };
    let bsdf_rev = mis(at.pdf_from(ls.wi));
    let cos_here = at.cos(ls.wi);
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
    let w_camera = mis(ratio) * (at.kernel(w).vm + weights.vcm + weights.vc * bsdf_rev);
    let weight = finite_or_zero(1.0 / (w_light + 1.0 + w_camera));
    let c = f * ls.radiance * (weight / (pmf * ls.pdf));
    if c == Spectrum::ZERO || !c.is_finite() {
        return Spectrum::ZERO;
    }
    match at {
        At::Surface(sp) if !scene.has_media() => {
            if tracer.unoccluded(&sp.hit, &ls) {
                c
            } else {
                Spectrum::ZERO
            }
        }
        _ => {
            let ray = match at {
                At::Surface(sp) if ls.dist.is_finite() => sp.hit.spawn_ray_to(ls.point),
                At::Surface(sp) => sp.hit.spawn_ray(ls.wi),
                At::Medium(m) => ray_from_point(m.p, &ls, m.medium),
            };
            tracer.counters.shadow += 1;
            c * transmittance(tracer, &ray, lambda, sampler)
        }
    }
}

/// Camera vertex `at` connected to light vertex `v` (the report's eqs. 40-41): the
/// MIS-weighted contribution, before either subpath's throughput.
fn connect(
    at: &At,
    weights: &Partial,
    v: &LightVertex,
    w: &Weights,
    tracer: &mut Tracer,
    sampler: &mut Sampler,
    lambda: &Wavelengths,
) -> Spectrum {
    let to = v.at.p() - at.p();
    let d2 = to.length_squared();
    if d2.is_nan() || d2 <= 0.0 {
        return Spectrum::ZERO;
    }
    let dir = to / d2.sqrt();
    let f_camera = at.f(dir, TransportMode::Radiance);
    if f_camera == Spectrum::ZERO {
        return Spectrum::ZERO;
    }
    let shading = v.at.shading(tracer.scene, lambda);
    let Some(lv) = v.at.at(&shading) else {
        return Spectrum::ZERO;
    };
    let f_light = lv.f(-dir, TransportMode::Importance);
    if f_light == Spectrum::ZERO {
        return Spectrum::ZERO;
    }
    // Each side's densities along the connection and back, the former as area densities at
    // the other vertex.
    let camera_area = at.pdf_to(dir) * lv.cos(dir) / d2;
    let light_area = lv.pdf_to(-dir) * at.cos(dir) / d2;
    let camera_rev = mis(at.pdf_from(dir));
    let light_rev = mis(lv.pdf_from(-dir));
    let w_light = mis(camera_area) * (lv.kernel(w).vm + v.mis.vcm + v.mis.vc * light_rev);
    let w_camera = mis(light_area) * (at.kernel(w).vm + weights.vcm + weights.vc * camera_rev);
    let weight = finite_or_zero(1.0 / (w_light + 1.0 + w_camera));
    let c = f_camera * f_light * (weight / d2);
    if c == Spectrum::ZERO || !c.is_finite() {
        return Spectrum::ZERO;
    }
    match (at, &lv) {
        (At::Surface(a), At::Surface(b)) if !tracer.scene.has_media() => {
            if tracer.connected_to(&b.hit, &a.hit) {
                c
            } else {
                Spectrum::ZERO
            }
        }
        _ => {
            c * visible(
                &lv.hit().spawn_ray_between(&at.hit()),
                tracer,
                sampler,
                lambda,
            )
        }
    }
}

/// Camera vertex `at`, `length` segments from the lens, merged with every light vertex of
/// the pass of its kind (in a medium: of its medium) within its radius (the report's eqs.
/// 37-39): the MIS-weighted density estimate, before the camera subpath's throughput. A
/// light vertex in a medium is a real scattering event, and carries its power over `sigma_s`
/// there: the estimate is of the in-scattered radiance (the camera's throughput holds the
/// vertex's own `sigma_s`).
fn merge(at: &At, weights: &Partial, length: u32, max: u32, pass: &Pass) -> Spectrum {
    let w = &pass.weights;
    let kernel = at.kernel(w);
    let grid = match at {
        At::Surface(_) => &pass.grid,
        At::Medium(_) => &pass.volume,
    };
    let mut sum = Spectrum::ZERO;
    // The value and the densities towards a light vertex's direction and back.
    let eval = |wi: Vec3A| -> Option<(Spectrum, f32, f32)> {
        match at {
            At::Surface(sp) => {
                if !stays_on_viewer_side(&sp.material, sp.hit.ng, sp.wo_world, wi) {
                    return None;
                }
                let local = sp.frame.to_local(wi);
                let f = sp.material.eval(sp.wo, local);
                if f == Spectrum::ZERO {
                    return None;
                }
                let to = sp.material.pdf(sp.wo, local);
                Some((f, to, sp.material.pdf(local, sp.wo)))
            }
            At::Medium(m) => {
                let p = m.phase.eval(m.wo, wi);
                (p > 0.0).then(|| (Spectrum::splat(p), p, m.phase.eval(wi, m.wo)))
            }
        }
    };
    let medium = match at {
        At::Surface(_) => MediumId::VACUUM,
        At::Medium(m) => m.medium,
    };
    grid.for_each_near(at.p(), |v| {
        if v.length.saturating_add(length) > max || v.medium != medium {
            return;
        }
        let Some((f, to, from)) = eval(Vec3A::from(v.wi)) else {
            return;
        };
        let w_light = v.vcm * kernel.vc + v.vm * mis(to);
        let w_camera = weights.vcm * kernel.vc + weights.vm * mis(from);
        let weight = finite_or_zero(1.0 / (w_light + 1.0 + w_camera));
        sum += f * Spectrum::from_array(v.beta) * weight;
    });
    sum * kernel.normalization
}

/// Light at infinity: the environment and directional lights.
#[inline]
fn at_infinity(light: &Light) -> bool {
    light.is_environment() || matches!(light, Light::Directional(_))
}

/// One BSDF (or phase function) sample continuing a subpath in `mode`: the throughput, the
/// next ray, and the weights for the next vertex (the report's eqs. 34-36, specular bounces
/// as eqs. 53-55; the kernel of merges at the vertex left is its own kind's). Whether the
/// sample was specular; `None` ends the subpath.
#[inline]
fn scatter(
    at: &At,
    mode: TransportMode,
    w: &Weights,
    beta: &mut Spectrum,
    weights: &mut Partial,
    ray: &mut Ray,
    sampler: &mut Sampler,
) -> Option<bool> {
    let kernel = at.kernel(w);
    let (wi, fwd, specular) = match at {
        At::Surface(sp) => {
            let s = sp.sample(sampler.next_1d(), sampler.next_2d(), mode)?;
            *beta = s.throughput(*beta);
            (s.wi, s.bsdf.pdf, s.bsdf.specular)
        }
        At::Medium(m) => {
            let ps = m.phase.sample(m.wo, sampler.next_2d());
            *beta *= ps.p / ps.pdf;
            (ps.wi, ps.pdf, false)
        }
    };
    let cos = at.cos(wi);
    if specular {
        weights.vcm = 0.0;
        weights.vc *= mis(cos);
        weights.vm *= mis(cos);
    } else {
        if fwd.is_nan() || fwd <= 0.0 {
            return None;
        }
        let rev = mis(at.pdf_from(wi));
        let g = mis(cos / fwd);
        let next = Partial {
            vc: g * (weights.vc * rev + weights.vcm + kernel.vm),
            vm: g * (weights.vm * rev + weights.vcm * kernel.vc + 1.0),
            vcm: mis(1.0 / fwd),
        };
        *weights = next;
    }
    if !(beta.is_finite() && *beta != Spectrum::ZERO) {
        return None;
    }
    *ray = match at {
        At::Surface(sp) => sp.hit.spawn_ray(wi),
        At::Medium(m) => Ray {
            origin: m.p,
            dir: wi,
            tmax: f32::INFINITY,
            medium: m.medium,
        },
    };
    Some(specular)
}
