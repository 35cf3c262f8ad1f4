//! `bdpt`: bidirectional path tracing (Veach and Guibas 1995; Veach's thesis, chapter 10;
//! pbrt-v4's `bdpt`, whose structure this follows).
//!
//! **Estimates** the measurement equation by every way of building a path from two
//! subpaths. Each camera sample traces a camera subpath (from the lens, radiance mode) and a
//! light subpath (from a light chosen in proportion to power, importance mode), then joins
//! every prefix of one with every prefix of the other: strategy `(s, t)` takes `s` light
//! vertices and `t` camera vertices, for paths of `s + t - 2` scattering events.
//! * `s = 0`: the camera subpath reached an emitter (or escaped to the environment);
//! * `s = 1`: a camera vertex connected to a new sample on a light (next-event estimation);
//! * `t = 1`: a light vertex connected to the lens, splatted where it lands (light tracing);
//! * otherwise a light vertex and a camera vertex joined by a segment.
//!
//! Every strategy's estimate is weighted by the power heuristic over the densities with which
//! each strategy could have made the same path, computed by Veach's recursive ratios of the
//! vertices' forward and reverse area densities (pbrt-v4's `MISWeight`). Vertices sampled
//! from Dirac lobes cannot be joined, delta lights cannot be hit (no `s = 0`) and a
//! directional light's vertex cannot be joined either; the weights leave out the strategies
//! that would need to. The `s = 1` strategy's weight takes the light point's density as
//! uniform in area (as pbrt-v4's does) although spheres are sampled by their cone: the
//! weights still add up to 1, so this costs variance, never bias. Subpaths take Russian roulette from `rr-depth` on.
//!
//! To look at one strategy, `-p strategy-s=S -p strategy-t=T` keeps only the contribution of
//! `(S, T)` (one of the two keeps every strategy with that many vertices on its side) (pbrt-v4's `visualizestrategies`/`visualizeweights`): MIS-weighted, so that the
//! strategies' images add up to the full image, or with `-p mis=0` unweighted, an image of its
//! own estimate of every path of `S + T - 2` scattering events it can build. Every strategy is
//! still computed (the random numbers stay those of the full image).
//!
//! With `-p write-strategies=1` every strategy's MIS-weighted contribution also goes into an
//! image of its own, written beside the output as `OUT_sS_tT` (pbrt-v4's
//! `visualizestrategies`): with the box filter they add up to the image.
//!
//! In participating media both subpaths fly by delta tracking (one colour channel, the
//! hero, chosen per sample, sets the rate; each channel's density rides along and every
//! estimate divides by their average) and scatter at medium vertices by the phase function;
//! medium vertices join like surface ones, without a cosine, and every join carries the
//! transmittance of its segment (ratio tracking) instead of a visibility test. Boundaries
//! that do not scatter (`Null`) are crossed without a vertex. The MIS densities are those of
//! directions and areas, without transmittance (as pbrt-v4's): still weights that sum to 1.
//! Media that emit are refused (no subpath starts in one).
//!
//! Connections to the lens need a pinhole camera: an orthographic one is refused.
//!
//! **Parameters**: `max-depth` (scattering events, default 16, at most 128), `rr-depth`
//! (default 3), `strategy-s` and `strategy-t` (default -1: every strategy), `mis` (1; 0
//! leaves the one strategy unweighted), `write-strategies` (0).
//! **Bias**: truncation at `max-depth`, otherwise none.

use crate::bsdf::TransportMode;
use crate::integrator::media_walk::{
    self, cross_null, fly, hero_channel, medium_at, transmittance, Flight,
};
use crate::integrator::{
    emit_from_a_light, escaped, scene_radius, Demand, Integrator, ShadingPoint, Tracer,
    MAX_SURVIVAL,
};
use crate::medium::Phase;
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, ParamKind, ParamSpec, Params, SpectralSupport,
    MAX_DEPTH, RR_DEPTH,
};
use crate::spectrum::Wavelengths;
use crate::SampleContext;
use crate::{Camera, Hit, MediumId, MediumInterface, Ray, Sampler, Scene, Spectrum};
use arrayvec::ArrayVec;
use glam::Vec3A;
use std::f32::consts::PI;

/// The deepest paths `bdpt` builds: its subpaths live in fixed arrays on the stack (no
/// allocation; only the vertices a path reaches are written), 130 vertices each.
pub const DEPTH_LIMIT: u32 = 128;
/// Vertices of a camera subpath: the lens and up to `DEPTH_LIMIT + 1` more.
const MAX_VERTICES: usize = DEPTH_LIMIT as usize + 2;

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "bdpt",
    summary: "bidirectional path tracing: every (s, t) join of a camera and a light subpath, MIS (power heuristic)",
    params: &[
        MAX_DEPTH
            .with_default(16.0)
            .with_max(DEPTH_LIMIT as f64)
            .with_doc("scattering events per path (at most 128)"),
        RR_DEPTH,
        STRATEGY,
        STRATEGY
            .with_name("strategy-t")
            .with_doc("keep only the strategies of t camera vertices (-1: all)"),
        ParamSpec {
            name: "mis",
            kind: ParamKind::Int,
            default: 1.0,
            min: 0.0,
            max: 1.0,
            doc: "1: the kept strategy MIS-weighted; 0: unweighted",
        },
        ParamSpec {
            name: "write-strategies",
            kind: ParamKind::Int,
            default: 0.0,
            min: 0.0,
            max: 1.0,
            doc: "1: also write each strategy's MIS-weighted image beside the output (OUT_sS_tT)",
        },
    ],
    build: |p: &Params| {
        let chosen = |name| (p.get(name) >= 0.0).then(|| p.get(name) as usize);
        Box::new(Bdpt {
            max_depth: p.get_depth("max-depth"),
            rr_depth: p.get_u32("rr-depth"),
            only_s: chosen("strategy-s"),
            only_t: chosen("strategy-t"),
            mis: p.get("mis") != 0.0,
            write_strategies: p.get("write-strategies") != 0.0,
        })
    },
    analytic: Some(Analytic {
        params: &[],
        furnace: expect(2.0, 40, 1600),
        point_in_sphere: expect(1.0, 40, 400),
        sphere_under_sky: expect(1.2, 40, 1600),
    }),
    media: MediaSupport::Scattering,
    spectral: SpectralSupport::PerSample,
};

const STRATEGY: ParamSpec = ParamSpec {
    name: "strategy-s",
    kind: ParamKind::Int,
    default: -1.0,
    min: -1.0,
    max: DEPTH_LIMIT as f64 + 2.0,
    doc: "keep only the strategies of s light vertices (-1: all)",
};

pub(crate) struct Bdpt {
    max_depth: u32,
    rr_depth: u32,
    /// Keep only the strategies with this many light (`s`) and camera (`t`) vertices.
    only_s: Option<usize>,
    only_t: Option<usize>,
    /// Weight them by MIS (always, when every strategy is kept).
    mis: bool,
    /// Splat every strategy's weighted contribution into a layer of its own too.
    write_strategies: bool,
}

/// The layer of strategy `(s, t)` (see [`Integrator::layers`]).
fn strategy_layer(s: usize, t: usize) -> u32 {
    (s * 256 + t) as u32
}

/// What a vertex is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// The lens (a pinhole).
    Camera,
    /// A point on a light where a light subpath starts, or a new light sample (`s = 1`), or
    /// the environment a camera subpath escaped to.
    Light,
    /// A surface hit.
    Surface,
    /// A scattering event in a participating medium (no surface: no normal, no cosine).
    Medium,
}

/// One vertex of a subpath (pbrt-v4's `Vertex`).
#[derive(Clone, Debug)]
struct Vertex<'a> {
    kind: Kind,
    p: Vec3A,
    /// Geometric normal; for a light its emitting normal (zero for point and spot lights; for
    /// lights at infinity, see `infinite`).
    ng: Vec3A,
    /// Surfaces: the shading point (hit, frame, direction back along the subpath, BSDF).
    sp: Option<ShadingPoint<'a>>,
    /// The light this vertex lies on or is (lights, and surfaces that emit).
    light: Option<u32>,
    /// A light at infinity (the environment, a directional light): `ng` is then the
    /// direction its light travels into the scene (the sky lies towards `-ng`), and `p` only
    /// a point along the way, never used for directions.
    infinite: bool,
    /// Throughput from the subpath's start up to this vertex.
    beta: Spectrum,
    /// Area density of sampling this vertex from the previous one, and of sampling it from
    /// the next one in the reverse direction.
    pdf_fwd: f32,
    pdf_rev: f32,
    /// Sampled from a Dirac lobe (or, for a light, a delta light).
    delta: bool,
    /// The medium the vertex sits in (the lens, lights and medium vertices; a surface's
    /// segments leave into the media its hit reports).
    medium: MediumId,
    /// A medium vertex's phase function.
    phase: Phase,
    /// Each colour channel's density of the subpath up to here over the hero channel's (all
    /// ones without media): an estimate divides by their average ([`media_walk`]).
    r_u: Spectrum,
}

type Subpath<'a> = ArrayVec<Vertex<'a>, MAX_VERTICES>;

impl<'a> Vertex<'a> {
    fn new(kind: Kind, p: Vec3A, ng: Vec3A, beta: Spectrum) -> Self {
        Vertex {
            kind,
            p,
            ng,
            sp: None,
            light: None,
            infinite: false,
            beta,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
            delta: false,
            medium: MediumId::VACUUM,
            phase: Phase::Isotropic,
            r_u: Spectrum::ONE,
        }
    }

    /// True where an area density and a cosine make sense: surfaces and area lights.
    fn on_surface(&self) -> bool {
        match self.kind {
            Kind::Surface => true,
            Kind::Light => !self.infinite && self.ng != Vec3A::ZERO,
            Kind::Camera | Kind::Medium => false,
        }
    }

    /// True when a segment may end here: not a mirror or glass, not a directional light.
    fn connectible(&self, scene: &dyn Scene) -> bool {
        match self.kind {
            Kind::Camera | Kind::Medium => true,
            Kind::Surface => self
                .sp
                .as_ref()
                .is_some_and(|sp| !sp.material.is_specular()),
            Kind::Light => !(self.infinite && self.is_delta_light(scene)),
        }
    }

    fn is_delta_light(&self, scene: &dyn Scene) -> bool {
        self.kind == Kind::Light && self.light.is_some_and(|i| scene.lights().get(i).is_delta())
    }

    /// The hit to spawn a segment from (lights, the lens and medium vertices: a point with no
    /// offset normal, in the vertex's medium).
    fn hit(&self) -> Hit {
        match &self.sp {
            Some(sp) => sp.hit,
            None => Hit {
                media: MediumInterface {
                    inside: self.medium,
                    outside: self.medium,
                },
                ..Hit::new(0.0, self.p, Vec3A::ZERO, 0, None)
            },
        }
    }

    /// Whether this is a surface or a medium vertex (a scattering event).
    fn scatters(&self) -> bool {
        matches!(self.kind, Kind::Surface | Kind::Medium)
    }

    /// Converts a solid-angle density at this vertex towards `next` into an area density
    /// at `next` (unchanged when `next` is at infinity).
    fn to_area(&self, pdf: f32, next: &Vertex) -> f32 {
        if next.infinite {
            return pdf;
        }
        let w = next.p - self.p;
        let d2 = w.length_squared();
        if d2.is_nan() || d2 <= 0.0 {
            return 0.0;
        }
        let mut pdf = pdf / d2;
        if next.on_surface() {
            pdf *= next.ng.dot(w).abs() / d2.sqrt();
        }
        pdf
    }

    /// Area density at `next` with which this vertex samples it, having been reached from
    /// `prev` (pbrt-v4's `Vertex::PDF`).
    fn pdf(&self, scene: &dyn Scene, camera: &Camera, prev: Option<&Vertex>, next: &Vertex) -> f32 {
        if self.kind == Kind::Light {
            return self.pdf_light(scene, next);
        }
        // Towards the sky, the direction the vertex keeps (never rebuilt from positions).
        let w = if next.infinite {
            -next.ng
        } else {
            (next.p - self.p).normalize_or_zero()
        };
        let pdf = match (&self.sp, self.kind) {
            (_, Kind::Camera) => camera.pdf_we(w).1,
            (_, Kind::Medium) => {
                let Some(prev) = prev else { return 0.0 };
                self.phase.eval((prev.p - self.p).normalize_or_zero(), w)
            }
            (Some(sp), _) => {
                let Some(prev) = prev else { return 0.0 };
                let wo = sp.frame.to_local((prev.p - self.p).normalize_or_zero());
                sp.material.pdf(wo, sp.frame.to_local(w))
            }
            _ => 0.0,
        };
        self.to_area(pdf, next)
    }

    /// Area density at `v` of a light subpath leaving this light vertex towards it (without
    /// the light's selection probability): the direction density over the squared distance,
    /// or for lights at infinity the density of the disk the rays start from.
    fn pdf_light(&self, scene: &dyn Scene, v: &Vertex) -> f32 {
        let Some(index) = self.light else { return 0.0 };
        let radius = scene_radius(scene);
        if self.infinite {
            let mut pdf = 1.0 / (PI * radius * radius);
            if v.on_surface() {
                pdf *= v.ng.dot(self.ng).abs();
            }
            return pdf;
        }
        let w = v.p - self.p;
        let d2 = w.length_squared();
        if d2.is_nan() || d2 <= 0.0 {
            return 0.0;
        }
        let w = w / d2.sqrt();
        // The light's own emitting normal (a surface vertex's `ng` is the geometry's, which
        // an inward-emitting sphere or tube turns the other way).
        let light = scene.lights().get(index);
        let (_, dir) = light.pdf_le(light.emitting_normal_at(self.p), w, radius);
        let mut pdf = dir / d2;
        if v.on_surface() {
            pdf *= v.ng.dot(w).abs();
        }
        pdf
    }

    /// Density of this light vertex as the start of a light subpath aimed at `v`: the
    /// light's selection probability times its position density (for the environment, the
    /// density of its direction).
    fn pdf_light_origin(&self, scene: &dyn Scene, v: &Vertex) -> f32 {
        let Some(index) = self.light else { return 0.0 };
        let lights = scene.lights();
        let light = lights.get(index);
        if self.infinite {
            return lights.pmf(index) * light.pdf_li(v.p, -self.ng, self.p);
        }
        let w = (v.p - self.p).normalize_or_zero();
        let (pos, _) = light.pdf_le(light.emitting_normal_at(self.p), w, scene_radius(scene));
        lights.pmf(index) * pos
    }

    /// Radiance this emitting vertex sends towards `v`.
    fn le(&self, scene: &dyn Scene, v: &Vertex, lambda: &Wavelengths) -> Spectrum {
        let Some(index) = self.light else {
            return Spectrum::ZERO;
        };
        if self.infinite {
            let ray = crate::Ray::new(v.p, -self.ng);
            return escaped(scene, &ray, lambda);
        }
        let w = (v.p - self.p).normalize_or_zero();
        scene
            .lights()
            .get(index)
            .emitted_at(self.p, self.ng, w, lambda)
    }
}

/// `x`, or 1 where it is 0 (a density that does not exist leaves a ratio unchanged).
#[inline]
fn remap0(x: f32) -> f32 {
    if x != 0.0 {
        x
    } else {
        1.0
    }
}

/// The BSDF factor of joining surface vertex `v` to the point `to`, times `|cos|` at `v`
/// (see [`ShadingPoint::connection_factor`]); for a medium vertex, its phase function
/// between the direction it was reached from (`from`, the previous vertex) and `to`.
fn joined(v: &Vertex, from: Option<&Vertex>, to: Vec3A, mode: TransportMode) -> Spectrum {
    match (&v.sp, v.kind, from) {
        (Some(sp), _, _) => sp.connection_factor((to - v.p).normalize_or_zero(), mode),
        (None, Kind::Medium, Some(prev)) => Spectrum::splat(v.phase.eval(
            (prev.p - v.p).normalize_or_zero(),
            (to - v.p).normalize_or_zero(),
        )),
        _ => Spectrum::ZERO,
    }
}

impl Integrator for Bdpt {
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
        let scene = tracer.scene;
        // The two subpaths.
        let mut cam: Subpath = ArrayVec::new();
        let mut light: Subpath = ArrayVec::new();
        let depth = self.max_depth.min(DEPTH_LIMIT);
        // In media, both subpaths sample distances by one colour channel, the hero.
        let hero = if scene.has_media() {
            hero_channel(sampler.next_1d(), lambda)
        } else {
            0
        };
        self.camera_subpath(
            pixel.film,
            camera,
            depth + 1,
            hero,
            tracer,
            sampler,
            lambda,
            &mut cam,
        );
        self.light_subpath(depth, camera, hero, tracer, sampler, lambda, &mut light);
        // Every join is made at the wavelengths both walks leave (pbrt-v4's): if either met a
        // dispersive surface, only the hero.
        let lambda = *lambda;
        let paths = Subpaths {
            scene,
            camera,
            light: &light,
            cam: &cam,
            lambda,
        };
        // Every join of a camera prefix (t vertices) and a light prefix (s vertices).
        let mut l = Spectrum::ZERO;
        for t in 1..=cam.len() {
            // s = 1 samples a light of its own: it runs even when the light subpath is empty.
            for s in 0..=light.len().max(1) {
                let depth = (s + t) as i64 - 2;
                if (s == 1 && t == 1) || depth < 0 || depth > self.max_depth as i64 {
                    continue;
                }
                let (c, weight, raster) = paths.connect(s, t, tracer, sampler);
                // A strategy that overflowed is dropped alone, not with the whole sample.
                if c == Spectrum::ZERO || !c.is_finite() || weight <= 0.0 {
                    continue;
                }
                if self.write_strategies {
                    let film = raster.unwrap_or(pixel.film);
                    splats.add_to_layer(strategy_layer(s, t), film, c * weight, &lambda);
                }
                let kept = self.only_s.is_none_or(|k| k == s) && self.only_t.is_none_or(|k| k == t);
                let c = match (kept, self.mis || (self.only_s, self.only_t) == (None, None)) {
                    (false, _) => continue,
                    (true, true) => c * weight,
                    (true, false) => c,
                };
                match raster {
                    Some(film) => splats.add(film, c, &lambda),
                    None => l += c,
                }
            }
        }
        l
    }

    fn demand(&self) -> Demand {
        Demand {
            rays_per_sample: 2.0,
            pinhole: true,
            ..Demand::default()
        }
    }

    /// With `write-strategies`, one layer per strategy `(s, t)` of at most `max-depth`
    /// scattering events (pbrt-v4's `visualizestrategies`).
    fn layers(&self) -> Vec<(u32, String)> {
        if !self.write_strategies {
            return Vec::new();
        }
        let mut layers = Vec::new();
        for depth in 0..=self.max_depth.min(DEPTH_LIMIT) as usize {
            for s in 0..=depth + 1 {
                let t = depth + 2 - s;
                if !(s == 1 && t == 1) {
                    layers.push((strategy_layer(s, t), format!("s{s}_t{t}")));
                }
            }
        }
        layers
    }
}

impl Bdpt {
    /// Every strategy of paths up to `max_depth` scattering events, MIS-weighted, without
    /// Russian roulette (for `mmlt`, whose paths must reach their length).
    pub(crate) fn all_strategies(max_depth: u32) -> Bdpt {
        Bdpt {
            max_depth: max_depth.min(DEPTH_LIMIT),
            rr_depth: u32::MAX,
            only_s: None,
            only_t: None,
            mis: true,
            write_strategies: false,
        }
    }

    /// Strategy `(s, t)` alone (pbrt-v4's `MLTIntegrator::L`): a camera subpath of exactly `t`
    /// vertices through `film` (numbers of stream 0, continued), a light subpath of exactly
    /// `s` (stream 1) and their join (stream 2). Returns the MIS-weighted contribution (zero
    /// when a subpath ends early) and the film position it lands at.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn one_strategy(
        &self,
        s: usize,
        t: usize,
        film: glam::Vec2,
        camera: &Camera,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> (Spectrum, glam::Vec2) {
        const NONE: Spectrum = Spectrum::ZERO;
        if t == 0 || s + t < 2 || (s == 1 && t == 1) || s + t > MAX_VERTICES {
            return (NONE, film);
        }
        let mut cam: Subpath = ArrayVec::new();
        let hero = if tracer.scene.has_media() {
            hero_channel(sampler.next_1d(), lambda)
        } else {
            0
        };
        self.camera_subpath(
            film,
            camera,
            t as u32 - 1,
            hero,
            tracer,
            sampler,
            lambda,
            &mut cam,
        );
        if cam.len() != t {
            return (NONE, film);
        }
        let mut light: Subpath = ArrayVec::new();
        sampler.start_stream(1);
        // s = 1 samples its light vertex anew in the join.
        if s >= 2 {
            self.light_subpath(
                s as u32 - 1,
                camera,
                hero,
                tracer,
                sampler,
                lambda,
                &mut light,
            );
            if light.len() != s {
                return (NONE, film);
            }
        }
        sampler.start_stream(2);
        let paths = Subpaths {
            scene: tracer.scene,
            camera,
            light: &light,
            cam: &cam,
            lambda: *lambda,
        };
        let (c, weight, raster) = paths.connect(s, t, tracer, sampler);
        if !c.is_finite() || weight.is_nan() || weight <= 0.0 {
            return (NONE, film);
        }
        (c * weight, raster.unwrap_or(film))
    }

    /// The camera subpath: the lens, then up to `max_vertices` vertices from the ray through
    /// the film position `film`.
    #[allow(clippy::too_many_arguments)]
    fn camera_subpath<'a>(
        &self,
        film: glam::Vec2,
        camera: &Camera,
        max_vertices: u32,
        hero: usize,
        tracer: &mut Tracer<'a>,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
        path: &mut Subpath<'a>,
    ) {
        let medium = tracer.scene.camera_medium();
        let ray = Ray {
            medium,
            ..camera.ray(film.x, film.y)
        };
        let (_, pdf_dir) = camera.pdf_we(ray.dir);
        let mut lens = Vertex::new(Kind::Camera, camera.eye, camera.normal(), Spectrum::ONE);
        lens.pdf_fwd = 1.0;
        lens.medium = medium;
        path.push(lens);
        let walk = Walk {
            mode: TransportMode::Radiance,
            hero,
            max_vertices,
            pdf_dir,
        };
        self.random_walk(ray, Spectrum::ONE, &walk, tracer, sampler, lambda, path);
    }

    /// The light subpath: a point on a light chosen in proportion to power, then up to
    /// `max_vertices` vertices along the ray it emits.
    #[allow(clippy::too_many_arguments)]
    fn light_subpath<'a>(
        &self,
        max_vertices: u32,
        camera: &Camera,
        hero: usize,
        tracer: &mut Tracer<'a>,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
        path: &mut Subpath<'a>,
    ) {
        let scene = tracer.scene;
        let Some((index, pmf, mut le)) = emit_from_a_light(scene, sampler, lambda) else {
            return;
        };
        let light = scene.lights().get(index);
        let infinite = light.is_environment() || matches!(*light, crate::Light::Directional(_));
        let mut start = Vertex::new(Kind::Light, le.ray.origin, le.normal, le.radiance);
        start.light = Some(index);
        start.infinite = infinite;
        start.pdf_fwd = le.pdf_pos * pmf;
        if scene.has_media() {
            // The light's medium, walked from the camera's.
            le.ray.medium = medium_at(scene, camera.eye, scene.camera_medium(), le.ray.origin);
            start.medium = le.ray.medium;
        }
        // For lights at infinity `le.normal` is the rays' direction, as `infinite` asks.
        path.push(start);
        let walk = Walk {
            mode: TransportMode::Importance,
            hero,
            max_vertices,
            pdf_dir: le.pdf_dir,
        };
        self.random_walk(
            le.ray,
            le.weight / pmf,
            &walk,
            tracer,
            sampler,
            lambda,
            path,
        );
        if infinite {
            // A ray from infinity: its first vertex's density is that of the disk it starts
            // from, and the light's "position" density that of its direction.
            if path.len() > 1 {
                let first = &mut path[1];
                first.pdf_fwd = le.pdf_pos;
                if first.on_surface() {
                    first.pdf_fwd *= le.ray.dir.dot(first.ng).abs();
                }
            }
            path[0].pdf_fwd = if light.is_delta() {
                0.0
            } else {
                pmf * light.pdf_li(Vec3A::ZERO, -le.ray.dir, Vec3A::ZERO)
            };
        }
    }

    /// Extends `path` from its last vertex along `ray` (direction density `walk.pdf_dir`): up to
    /// `walk.max_vertices` more vertices, each BSDF- or phase-sampled in `walk.mode`, with the
    /// densities MIS needs (pbrt-v4's `RandomWalk`). In media, free flights end in medium
    /// vertices (delta tracking at the hero channel's rate); boundaries that do not scatter
    /// (`Null`) are crossed without a vertex. A camera subpath that escapes ends at the
    /// environment when the scene has one.
    #[allow(clippy::too_many_arguments)]
    fn random_walk<'a>(
        &self,
        mut ray: crate::Ray,
        mut beta: Spectrum,
        walk: &Walk,
        tracer: &mut Tracer<'a>,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
        path: &mut Subpath<'a>,
    ) {
        let (mode, max_vertices) = (walk.mode, walk.max_vertices);
        let scene = tracer.scene;
        let media = scene.has_media();
        let start = beta.max_element();
        let mut r_u = Spectrum::ONE;
        let mut pdf_fwd = walk.pdf_dir;
        let mut added = 0u32;
        while added < max_vertices && !path.is_full() {
            // Trace the next segment.
            let found = match (mode, path.len()) {
                (TransportMode::Radiance, 1) => tracer.camera(&ray),
                (TransportMode::Radiance, _) => tracer.extend(&ray),
                (TransportMode::Importance, _) => tracer.light(&ray),
            };
            if media {
                let tmax = found.map_or(f32::INFINITY, |h| h.t);
                match fly(
                    scene, &ray, tmax, walk.hero, lambda, sampler, &mut beta, &mut r_u,
                ) {
                    Flight::Ended => return,
                    Flight::Through => {}
                    Flight::Scattered(p) => {
                        let Some(medium) = scene.medium(ray.medium) else {
                            return;
                        };
                        let mut v = Vertex::new(Kind::Medium, p, Vec3A::ZERO, beta);
                        v.medium = ray.medium;
                        v.phase = medium.phase();
                        v.r_u = r_u;
                        let prev = path.len() - 1;
                        v.pdf_fwd = path[prev].to_area(pdf_fwd, &v);
                        path.push(v);
                        added += 1;
                        if added >= max_vertices || path.is_full() {
                            return;
                        }
                        // Scatter by the phase function (symmetric: the reverse density is
                        // the same).
                        let last = path.len() - 1;
                        let ps = path[last].phase.sample(-ray.dir, sampler.next_2d());
                        if !media_walk::positive(ps.pdf) {
                            return;
                        }
                        beta *= ps.p / ps.pdf;
                        pdf_fwd = ps.pdf;
                        path[last - 1].pdf_rev = path[last].to_area(ps.pdf, &path[last - 1]);
                        if !self.roulette(added, &mut beta, start, r_u, sampler, lambda) {
                            return;
                        }
                        ray = Ray {
                            origin: p,
                            dir: ps.wi,
                            tmax: f32::INFINITY,
                            medium: ray.medium,
                        };
                        continue;
                    }
                }
            }
            let Some(hit) = found else {
                // Escaped: the environment, for camera subpaths.
                if let (TransportMode::Radiance, Some(env)) = (mode, scene.lights().environment()) {
                    let mut v = Vertex::new(Kind::Light, ray.origin + ray.dir, -ray.dir, beta);
                    v.light = Some(env);
                    v.infinite = true;
                    v.pdf_fwd = pdf_fwd;
                    v.r_u = r_u;
                    path.push(v);
                }
                return;
            };
            let sp = ShadingPoint::new(&hit, ray.dir, scene, lambda);
            if media {
                // A medium's boundary (or a mask's hole): crossed, no vertex.
                match cross_null(&sp, &ray, mode, &mut beta, sampler) {
                    Some(Some(next)) => {
                        ray = next;
                        continue;
                    }
                    Some(None) => return,
                    None => {}
                }
            }
            let mut v = Vertex::new(Kind::Surface, sp.hit.p, sp.hit.ng, beta);
            v.light = hit.light;
            v.r_u = r_u;
            let prev = path.len() - 1;
            v.pdf_fwd = path[prev].to_area(pdf_fwd, &v);
            v.sp = Some(sp);
            path.push(v);
            added += 1;
            if added >= max_vertices || path.is_full() {
                return;
            }
            // Scatter: a BSDF sample, and the density of the reverse direction.
            let last = path.len() - 1;
            let Some(sp) = path[last].sp.as_ref() else {
                return;
            };
            let Some(s) = sp.sample(sampler.next_1d(), sampler.next_2d(), mode) else {
                return;
            };
            beta = s.throughput(beta);
            if !(beta.is_finite() && beta != Spectrum::ZERO) {
                return;
            }
            let wi_local = sp.frame.to_local(s.wi);
            let (mut fwd, mut rev) = (s.bsdf.pdf, sp.material.pdf(wi_local, sp.wo));
            let next_origin = sp.hit.spawn_ray(s.wi);
            if s.bsdf.specular {
                path[last].delta = true;
                fwd = 0.0;
                rev = 0.0;
            }
            let rev_area = path[last].to_area(rev, &path[last - 1]);
            path[last - 1].pdf_rev = rev_area;
            pdf_fwd = fwd;
            if !self.roulette(added, &mut beta, start, r_u, sampler, lambda) {
                return;
            }
            ray = next_origin;
        }
    }

    /// Russian roulette from `rr-depth` vertices on, relative to what the subpath started
    /// with (the throughput over the channels' average density in media); false ends it.
    fn roulette(
        &self,
        added: u32,
        beta: &mut Spectrum,
        start: f32,
        r_u: Spectrum,
        sampler: &mut Sampler,
        lambda: &Wavelengths,
    ) -> bool {
        if added < self.rr_depth {
            return true;
        }
        let survive = (beta.max_element() / lambda.average(r_u) / start).min(MAX_SURVIVAL);
        if survive.is_nan() || sampler.next_1d() >= survive {
            return false;
        }
        *beta /= survive;
        true
    }
}

/// How a subpath walks: radiance (from the camera) or importance (from a light), the hero
/// colour channel of its media, how many vertices it may add, and the density of the
/// direction of its first ray.
struct Walk {
    mode: TransportMode,
    hero: usize,
    max_vertices: u32,
    pdf_dir: f32,
}

/// A camera sample's two subpaths, with what joining them needs.
struct Subpaths<'p, 'a> {
    scene: &'p dyn Scene,
    camera: &'p Camera,
    light: &'p Subpath<'a>,
    cam: &'p Subpath<'a>,
    /// The wavelengths every join is made at.
    lambda: Wavelengths,
}

impl Subpaths<'_, '_> {
    /// Strategy `(s, t)`: its contribution, its MIS weight, and the film position for `t = 1`
    /// (a splat), `None` for the sample's own pixel.
    fn connect(
        &self,
        s: usize,
        t: usize,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
    ) -> (Spectrum, f32, Option<glam::Vec2>) {
        let (scene, camera, light, cam) = (self.scene, self.camera, self.light, self.cam);
        const NONE: (Spectrum, f32, Option<glam::Vec2>) = (Spectrum::ZERO, 0.0, None);
        let pt = &cam[t - 1];
        // A camera vertex that lies on the environment can only be taken whole (s = 0).
        if pt.infinite && s > 0 {
            return NONE;
        }
        let mut raster = None;
        let mut sampled = None;
        let contribution = if s == 0 {
            // The camera subpath found an emitter.
            if pt.light.is_none() || t < 2 {
                return NONE;
            }
            let c = pt.beta * pt.le(scene, &cam[t - 2], &self.lambda);
            if c == Spectrum::ZERO {
                return NONE;
            }
            c
        } else if t == 1 {
            // A light vertex joined to the lens.
            let qs = &light[s - 1];
            if !qs.connectible(scene) || !qs.scatters() {
                return NONE;
            }
            let Some(cs) = camera.sample_wi(qs.p) else {
                return NONE;
            };
            let mut lens = Vertex::new(Kind::Camera, cs.point, camera.normal(), cs.we / cs.pdf);
            lens.pdf_fwd = 1.0;
            let from = s.checked_sub(2).map(|i| &light[i]);
            let c = qs.beta * joined(qs, from, cs.point, TransportMode::Importance) * lens.beta;
            let c = if scene.has_media() {
                self.through(c, qs.hit().spawn_ray_to(cs.point), tracer, sampler)
            } else if c != Spectrum::ZERO && tracer.connected(&qs.hit(), cs.point) {
                c
            } else {
                Spectrum::ZERO
            };
            if c == Spectrum::ZERO {
                return NONE;
            }
            raster = Some(cs.raster);
            sampled = Some(lens);
            c
        } else if s == 1 {
            // A camera vertex joined to a new sample on a light.
            if !pt.connectible(scene) || !pt.scatters() {
                return NONE;
            }
            let (u_light, u) = (sampler.next_1d(), sampler.next_2d());
            let lights = scene.lights();
            let Some((index, pmf)) = lights.sample(u_light) else {
                return NONE;
            };
            let light_ref = lights.get(index);
            if pt
                .sp
                .as_ref()
                .is_some_and(|sp| !sp.can_receive(index, lights))
            {
                return NONE;
            }
            let Some(ls) = light_ref.sample_li(pt.p, u, &self.lambda) else {
                return NONE;
            };
            if ls.pdf <= 0.0 || ls.radiance == Spectrum::ZERO {
                return NONE;
            }
            let infinite = !ls.dist.is_finite();
            let mut v = Vertex::new(
                Kind::Light,
                if infinite { pt.p + ls.wi } else { ls.point },
                if infinite {
                    -ls.wi
                } else {
                    light_ref.emitting_normal_at(ls.point)
                },
                ls.radiance / (ls.pdf * pmf),
            );
            v.light = Some(index);
            v.infinite = infinite;
            v.pdf_fwd = v.pdf_light_origin(scene, pt);
            let from = t.checked_sub(2).map(|i| &cam[i]);
            let c = pt.beta * joined(pt, from, pt.p + ls.wi, TransportMode::Radiance) * v.beta;
            if c == Spectrum::ZERO {
                return NONE;
            }
            let c = if scene.has_media() {
                let hit = pt.hit();
                let ray = if infinite {
                    hit.spawn_ray(ls.wi)
                } else {
                    hit.spawn_ray_to(ls.point)
                };
                self.through(c, ray, tracer, sampler)
            } else if pt
                .sp
                .as_ref()
                .is_some_and(|sp| tracer.unoccluded(&sp.hit, &ls))
            {
                c
            } else {
                Spectrum::ZERO
            };
            if c == Spectrum::ZERO {
                return NONE;
            }
            sampled = Some(v);
            c
        } else {
            // A light vertex and a camera vertex joined by a segment.
            let qs = &light[s - 1];
            if !qs.connectible(scene) || !pt.connectible(scene) || !qs.scatters() {
                return NONE;
            }
            if !pt.scatters() {
                return NONE;
            }
            let d2 = (qs.p - pt.p).length_squared();
            if d2.is_nan() || d2 <= 0.0 {
                return NONE;
            }
            let (q_from, p_from) = (&light[s - 2], &cam[t - 2]);
            let c = qs.beta
                * joined(qs, Some(q_from), pt.p, TransportMode::Importance)
                * joined(pt, Some(p_from), qs.p, TransportMode::Radiance)
                * pt.beta
                / d2;
            let c = if scene.has_media() {
                self.through(c, qs.hit().spawn_ray_between(&pt.hit()), tracer, sampler)
            } else if c != Spectrum::ZERO && tracer.connected_to(&qs.hit(), &pt.hit()) {
                c
            } else {
                Spectrum::ZERO
            };
            if c == Spectrum::ZERO {
                return NONE;
            }
            c
        };
        // In media: the channels' densities of both subpaths, averaged (one-sample MIS over
        // the channels: `media_walk`).
        let r_u = |path: &Subpath, n: usize, fresh: bool| {
            if fresh || n == 0 {
                Spectrum::ONE
            } else {
                path[n - 1].r_u
            }
        };
        let r_u = r_u(cam, t, t == 1) * r_u(light, s, s == 1);
        let contribution = contribution / self.lambda.average(r_u);
        let weight = self.mis_weight(s, t, sampled.as_ref());
        (contribution, weight, raster)
    }

    /// A connection's contribution `c` in media, carried along `ray`: times its
    /// transmittance through media and crossable surfaces (zero where a surface blocks it).
    fn through(
        &self,
        c: Spectrum,
        ray: Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
    ) -> Spectrum {
        if c == Spectrum::ZERO {
            return c;
        }
        c * transmittance(tracer, &ray, &self.lambda, sampler)
    }

    /// The power-heuristic weight of strategy `(s, t)` against every other strategy that could
    /// have built the same path (pbrt-v4's `MISWeight`, squared ratios): walking from the join
    /// towards each end, each step multiplies the ratio by the vertex's reverse over forward
    /// density; steps at Dirac vertices and delta lights add nothing. `sampled` is the vertex
    /// a strategy sampled anew (`s = 1`: on a light; `t = 1`: the lens).
    fn mis_weight(&self, s: usize, t: usize, sampled: Option<&Vertex>) -> f32 {
        let (scene, camera, light, cam) = (self.scene, self.camera, self.light, self.cam);
        if s + t == 2 {
            return 1.0;
        }
        // The join's vertices, the new vertex in place of a subpath's end.
        let qs = if s == 1 {
            sampled.or(light.first())
        } else {
            s.checked_sub(1).map(|i| &light[i])
        };
        let pt = if t == 1 {
            sampled.unwrap_or(&cam[0])
        } else {
            &cam[t - 1]
        };
        let qs_minus = if s >= 2 { Some(&light[s - 2]) } else { None };
        let pt_minus = if t >= 2 { Some(&cam[t - 2]) } else { None };

        // The reverse densities the join creates.
        let pt_rev = match qs {
            Some(qs) => qs.pdf(scene, camera, qs_minus, pt),
            None => pt.pdf_light_origin(scene, pt_minus.unwrap_or(pt)),
        };
        let pt_minus_rev = pt_minus.map(|pm| match qs {
            Some(qs) => pt.pdf(scene, camera, Some(qs), pm),
            None => pt.pdf_light(scene, pm),
        });
        let qs_rev = qs.map(|qs| pt.pdf(scene, camera, pt_minus, qs));
        let qs_minus_rev = qs_minus.and_then(|qm| qs.map(|qs| qs.pdf(scene, camera, Some(pt), qm)));

        let mut sum = 0.0f32;
        // Camera side: the strategies with fewer camera vertices.
        let mut ri = 1.0f32;
        for i in (1..t).rev() {
            let (rev, fwd) = if i == t - 1 {
                (pt_rev, pt.pdf_fwd)
            } else if i + 2 == t {
                (pt_minus_rev.unwrap_or(0.0), cam[i].pdf_fwd)
            } else {
                (cam[i].pdf_rev, cam[i].pdf_fwd)
            };
            ri *= remap0(rev) / remap0(fwd);
            let delta_here = i != t - 1 && cam[i].delta;
            let delta_before = cam[i - 1].delta;
            if !delta_here && !delta_before {
                sum += ri * ri;
            }
        }
        // Light side: the strategies with fewer light vertices.
        ri = 1.0;
        for i in (0..s).rev() {
            let vertex = match qs {
                Some(qs) if i == s - 1 => qs,
                _ => &light[i],
            };
            let rev = if i == s - 1 {
                qs_rev.unwrap_or(0.0)
            } else if i + 2 == s {
                qs_minus_rev.unwrap_or(0.0)
            } else {
                vertex.pdf_rev
            };
            ri *= remap0(rev) / remap0(vertex.pdf_fwd);
            let delta_here = i != s - 1 && vertex.delta;
            let delta_before = if i > 0 {
                light[i - 1].delta
            } else {
                vertex.is_delta_light(scene)
            };
            if !delta_here && !delta_before {
                sum += ri * ri;
            }
        }
        let w = 1.0 / (1.0 + sum);
        if w.is_finite() {
            w
        } else {
            0.0
        }
    }
}
