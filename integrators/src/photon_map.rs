//! Photons: traced from the lights, stored at non-specular surfaces and, in participating
//! media, where they scatter in a medium, and gathered around a point to estimate the
//! radiance it reflects or scatters. Shared by the `photon` and `sppm` integrators.
//!
//! * **Emission.** A light is picked in proportion to its power ([`crate::LightTable`]), a ray
//!   leaves it by [`crate::Light::sample_le`], and the photon carries
//!   `Le cos / (pdf_pos pdf_dir pmf N)` watts per channel for `N` emitted photons, so the
//!   stored powers are an unbiased estimate of the flux arriving at surfaces.
//! * **Scattering.** BSDF sampling with importance-transport weights
//!   ([`crate::Material::importance_weight`]: refraction conserves power) and Veach's
//!   correction for shading normals; Russian roulette keeps a photon with probability
//!   `min(0.95, lum(beta') / lum(beta))`, so surviving photons keep about the same power.
//! * **Storage.** A hashed uniform grid (Teschner et al. 2003) whose cells are twice the
//!   gather radius wide, so a gather looks at 8 cells at most. Buckets are computed in
//!   parallel and photons counting-sorted by bucket: the map is two flat arrays and its build
//!   is linear and deterministic.
//! * **Media.** Photons walk media by delta tracking at one colour channel's rate
//!   ([`crate::integrator::media_walk::fly`]), scatter at real collisions with the albedo as
//!   weight and the phase function sampled, cross `Null` boundaries without an event, and
//!   carry `beta / mean(r_u)` (one-sample MIS over the channels); the roulette is capped so
//!   that a white fog ends photons too.
//! * **Estimate.** `L_r(x, wo) = sum_p f(wo, wi_p) Phi_p / (pi r^2)` over the photons within
//!   distance `r` of `x` (a uniform disk kernel), skipping photons that arrived on the other
//!   side of an opaque surface. In a medium, `sum_p phase(wo, wi_p) Phi_p / (4/3 pi r^3)`
//!   over the photons that landed in it estimates `sigma_s` times the in-scattered radiance.
//!
//! Work is split into blocks of photons traced in parallel (rayon); each photon has its own
//! [`Sampler`] seeded from (seed, stream, photon index), and blocks are concatenated in order,
//! so a map is the same whatever the thread count.

use crate::bsdf::TransportMode;
use crate::integrator::media_walk::{
    cross_null, fly, hero_channel, medium_at, over_sigma_s, positive, Flight,
};
use crate::integrator::volpath::LONG_PATH;
use crate::integrator::{
    emitted_at, escaped, stays_on_viewer_side, PathState, ShadingPoint, Stop, MAX_SURVIVAL,
};
use crate::spectrum::{average, Wavelengths};
use crate::{Hit, MediumId, Ray, RayCounters, Sampler, Scene, Spectrum, Tracer};
use glam::{Vec3, Vec3A};
use rayon::prelude::*;

/// One stored photon (48 bytes): a landing on a surface, or in a medium.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Photon {
    /// Where it landed.
    pub p: Vec3,
    /// Unit direction back towards where it came from (away from the surface).
    pub wi: Vec3,
    /// Power, watts per lane of a [`Spectrum`].
    pub power: [f32; 4],
    /// Scattering events between the light and this landing (0: straight from the light).
    pub bounces: u16,
    /// Every scattering before this landing was specular (and there was at least one): the
    /// photon took a caustic path `L S+ D`.
    pub caustic: bool,
    /// The medium it landed in (a real scattering event there; its power is then over
    /// `sigma_s` there), or `MediumId::VACUUM` for a landing on a surface.
    pub medium: MediumId,
}

impl Photon {
    /// Whether it landed in a medium.
    #[inline]
    pub fn in_medium(&self) -> bool {
        self.medium != MediumId::VACUUM
    }
}

/// Which landings a photon pass stores.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Keep {
    /// Every landing on a non-specular surface.
    All,
    /// Landings after at least one bounce: direct light is left to next-event estimation.
    Indirect,
    /// Only the first non-specular landing after one or more specular bounces (`L S+ D`); a
    /// photon ends there, or at any non-specular landing before it.
    Caustic,
}

/// Photons traced per parallel work item.
const BLOCK: u32 = 4096;

/// Seed offset separating photon streams from camera samples.
const PHOTON_SEED: u64 = 0x70_686f_746f_6e73;

/// What a photon pass traces.
#[derive(Clone, Copy, Debug)]
pub struct PhotonPass {
    /// Photons emitted.
    pub count: u32,
    /// Which landings are stored.
    pub keep: Keep,
    /// Scattering events a photon may make before its last stored landing (`u32::MAX`: no
    /// limit).
    pub max_bounces: u32,
    pub seed: u64,
    /// Separates independent photon sets under one seed (a pass number).
    pub stream: u64,
    /// The camera's position: in scenes with media, the medium a photon starts in is found
    /// by walking to its light from the camera's medium.
    pub eye: Vec3A,
    /// The wavelengths every photon of the pass carries (the camera paths that gather them
    /// carry the same).
    pub lambda: Wavelengths,
}

/// Traces a pass's photons from the scene's lights and returns the landings it keeps, with
/// the rays cast.
pub fn trace_photons(
    scene: &dyn Scene,
    pass: &PhotonPass,
    stop: Stop,
) -> (Vec<Photon>, RayCounters) {
    let count = pass.count;
    if scene.lights().is_empty() || count == 0 {
        return (Vec::new(), RayCounters::default());
    }
    let blocks = count.div_ceil(BLOCK);
    let results: Vec<(Vec<Photon>, RayCounters)> = (0..blocks)
        .into_par_iter()
        .map(|b| {
            let mut tracer = Tracer::new(scene);
            let mut photons = Vec::new();
            for i in b * BLOCK..((b + 1) * BLOCK).min(count) {
                if stop.requested() {
                    break;
                }
                let mut sampler = Sampler::new(pass.seed ^ PHOTON_SEED, pass.stream, i as u64);
                trace_one(&mut tracer, &mut sampler, pass, &mut photons);
            }
            (photons, tracer.counters)
        })
        .collect();
    let mut counters = RayCounters::default();
    let mut photons = Vec::with_capacity(results.iter().map(|r| r.0.len()).sum());
    for (p, c) in results {
        photons.extend(p);
        counters.add(&c);
    }
    (photons, counters)
}

/// A photon's state in media: the hero channel its free flights are sampled by and each
/// channel's density over the hero's (see [`crate::integrator::media_walk`]).
struct InMedia {
    hero: usize,
    r_u: Spectrum,
    /// The lanes of its spectra that hold values (`Wavelengths::lanes`).
    lanes: usize,
}

impl InMedia {
    /// The power the photon carries: one-sample MIS over the channels.
    #[inline]
    fn power(&self, beta: Spectrum) -> Spectrum {
        beta / average(self.r_u, self.lanes)
    }
}

/// Emits one photon of the pass and follows it, appending its stored landings to `out`.
fn trace_one(tracer: &mut Tracer, sampler: &mut Sampler, pass: &PhotonPass, out: &mut Vec<Photon>) {
    let scene = tracer.scene;
    let mut lambda = pass.lambda;
    let lambda = &mut lambda;
    let (keep, max_bounces) = (pass.keep, pass.max_bounces);
    // Emission: a light in proportion to power, a ray leaving it.
    let Some((_, pmf, emission)) = crate::integrator::emit_from_a_light(scene, sampler, lambda)
    else {
        return;
    };
    let mut beta = emission.weight / (pmf * pass.count as f32);
    let mut ray = emission.ray;
    let mut specular_so_far = true;
    let mut bounces = 0u32;
    // In media: the light's medium, walked to from the camera's.
    let mut media = None;
    if scene.has_media() {
        media = Some(InMedia {
            hero: hero_channel(sampler.next_1d(), lambda),
            r_u: Spectrum::ONE,
            lanes: lambda.lanes(),
        });
        ray.medium = medium_at(scene, pass.eye, scene.camera_medium(), ray.origin);
    }
    loop {
        // Find the next landing.
        let hit = tracer.light(&ray);
        if let Some(m) = media.as_mut() {
            let carried = lambda.brightness(m.power(beta));
            let tmax = hit.map_or(f32::INFINITY, |h| h.t);
            match fly(
                scene, &ray, tmax, m.hero, lambda, sampler, &mut beta, &mut m.r_u,
            ) {
                Flight::Ended => return,
                Flight::Through => {}
                Flight::Scattered(p) => {
                    // A landing in the medium: stored in the volume map (a caustic map keeps
                    // surface landings only, and the photon ends).
                    if keep == Keep::Caustic {
                        return;
                    }
                    let Some(medium) = scene.medium(ray.medium) else {
                        return;
                    };
                    if keep == Keep::All || bounces > 0 {
                        let sigma_s = medium.at(p, lambda).sigma_s;
                        out.push(Photon {
                            p: p.into(),
                            wi: (-ray.dir).into(),
                            power: over_sigma_s(m.power(beta), sigma_s).to_array(),
                            bounces: bounces.min(u16::MAX as u32) as u16,
                            caustic: specular_so_far && bounces > 0,
                            medium: ray.medium,
                        });
                    }
                    if bounces >= max_bounces || bounces >= u16::MAX as u32 {
                        return;
                    }
                    let ps = medium.phase().sample(-ray.dir, sampler.next_2d());
                    if !positive(ps.pdf) {
                        return;
                    }
                    beta *= ps.p / ps.pdf;
                    specular_so_far = false;
                    // Russian roulette on what the flight and the scattering left of the
                    // power (the albedo), so that photons keep about the same power: one that
                    // lost none (a white fog) plays only after `LONG_PATH` events, then
                    // capped as on surfaces, so that every photon ends. (A cap from the first
                    // event would multiply a long walk's power at each of its landings: a
                    // cluster of strong photons, the heavy tail of a fog's estimate.)
                    let ratio = lambda.brightness(m.power(beta)) / carried;
                    if ratio.is_nan() {
                        return;
                    }
                    if ratio < 1.0 || bounces >= LONG_PATH {
                        let survive = ratio.min(MAX_SURVIVAL);
                        if sampler.next_1d() >= survive {
                            return;
                        }
                        beta /= survive;
                    }
                    ray = Ray {
                        origin: p,
                        dir: ps.wi,
                        tmax: f32::INFINITY,
                        medium: ray.medium,
                    };
                    bounces += 1;
                    continue;
                }
            }
        }
        let Some(hit) = hit else {
            return;
        };
        // Textures do not change which lobes a material has.
        let material = scene.material(hit.material).bsdf();
        if media.is_some() {
            // A medium's boundary (or a mask's hole): crossed, no scattering event.
            let sp = ShadingPoint::new(&hit, ray.dir, scene, lambda);
            match cross_null(&sp, &ray, TransportMode::Importance, &mut beta, sampler) {
                Some(Some(next)) => {
                    ray = next;
                    continue;
                }
                Some(None) => return,
                None => {}
            }
        }
        let power = media.as_ref().map_or(beta, |m| m.power(beta));
        // Store it if this map wants it.
        if !material.is_specular() {
            // Caustic: every scattering event so far was a Dirac lobe.
            let caustic = specular_so_far && bounces > 0;
            let store = match keep {
                Keep::All => true,
                Keep::Indirect => bounces > 0,
                Keep::Caustic => caustic,
            };
            if store {
                out.push(Photon {
                    p: hit.p.into(),
                    wi: (-ray.dir).into(),
                    power: power.to_array(),
                    bounces: bounces.min(u16::MAX as u32) as u16,
                    caustic,
                    medium: MediumId::VACUUM,
                });
            }
            // A caustic photon ends here unless a Dirac lobe (a plastic's coating) may still
            // carry it on.
            if keep == Keep::Caustic && !material.has_delta_lobe() {
                return;
            }
        }
        // A further landing would exceed the depth limit.
        if bounces >= max_bounces || bounces >= u16::MAX as u32 {
            return;
        }
        // Scatter: BSDF sample, importance weight, shading-normal correction.
        let sp = ShadingPoint::new(&hit, ray.dir, scene, lambda);
        let Some(s) = sp.sample(
            sampler.next_1d(),
            sampler.next_2d(),
            TransportMode::Importance,
        ) else {
            return;
        };
        specular_so_far &= s.bsdf.specular;
        if keep == Keep::Caustic && !specular_so_far {
            return;
        }
        let next = s.throughput(beta);
        if !(next.is_finite() && next != Spectrum::ZERO) {
            return;
        }
        // Russian roulette, keeping the photon's power about constant.
        let survive = (lambda.brightness(next) / lambda.brightness(beta)).min(MAX_SURVIVAL);
        if survive.is_nan() || sampler.next_1d() >= survive {
            return;
        }
        beta = next / survive;
        ray = hit.spawn_ray(s.wi);
        bounces += 1;
    }
}

/// Where a path followed through specular bounces stops to gather.
#[derive(Clone, Copy, Debug)]
pub enum Spot {
    /// A non-specular surface.
    Surface(Hit),
    /// A real scattering event in the medium of the landing's ray, at this point.
    Medium(Vec3A),
}

/// A path followed through specular bounces to its first non-specular scattering point.
pub struct Landing {
    pub at: Spot,
    /// The ray that arrived there (in the medium it crossed).
    pub ray: Ray,
    /// Throughput from the path's start to there (in media, divided by the average of the
    /// channels' densities: an estimate in every channel).
    pub beta: Spectrum,
    /// Specular bounces before it.
    pub bounces: u32,
}

/// Follows `ray` through specular bounces (at most `max_bounces`, Russian roulette from
/// `rr_depth` on) to a non-specular surface, or in media to a real scattering event: where
/// photon integrators gather. With `emission`, adds the emission met on the way (and
/// escaping radiance) to it. A camera ray (`first_is_camera`) starts in the camera's medium.
#[allow(clippy::too_many_arguments)]
pub fn land(
    ray: Ray,
    first_is_camera: bool,
    max_bounces: u32,
    rr_depth: u32,
    emission: Option<&mut Spectrum>,
    tracer: &mut Tracer,
    sampler: &mut Sampler,
    lambda: &mut Wavelengths,
) -> Option<Landing> {
    let scene = tracer.scene;
    let mut l = emission;
    let mut path = if first_is_camera {
        PathState::from_camera(Ray {
            medium: scene.camera_medium(),
            ..ray
        })
    } else {
        PathState::from_surface(ray)
    };
    // In media: the hero channel of the free flights and each channel's density over it.
    let mut media = scene.has_media().then(|| InMedia {
        hero: hero_channel(sampler.next_1d(), lambda),
        r_u: Spectrum::ONE,
        lanes: lambda.lanes(),
    });
    loop {
        let hit = path.trace(tracer);
        if let Some(m) = media.as_mut() {
            let tmax = hit.map_or(f32::INFINITY, |h| h.t);
            let ray = path.ray;
            match fly(
                scene,
                &ray,
                tmax,
                m.hero,
                lambda,
                sampler,
                &mut path.beta,
                &mut m.r_u,
            ) {
                Flight::Ended => return None,
                Flight::Through => {}
                Flight::Scattered(p) => {
                    return Some(Landing {
                        at: Spot::Medium(p),
                        ray,
                        beta: m.power(path.beta),
                        bounces: path.bounces,
                    })
                }
            }
        }
        let carried = media.as_ref().map_or(path.beta, |m| m.power(path.beta));
        let Some(hit) = hit else {
            if let Some(l) = l.as_deref_mut() {
                *l += carried * escaped(scene, &path.ray, lambda);
            }
            return None;
        };
        if let Some(l) = l.as_deref_mut() {
            *l += carried * emitted_at(scene, &hit, &path.ray, lambda);
        }
        // A surface with Dirac lobes (all of them, or a plastic's coating over its base) sends
        // the path on through one of them with their probability `p`; otherwise the path
        // lands here, weighted by 1 / (1 - p), and is gathered with the rest of the BSDF.
        let landing = |beta| Landing {
            at: Spot::Surface(hit),
            ray: path.ray,
            beta,
            bounces: path.bounces,
        };
        if !scene.material(hit.material).may_have_delta_lobe() {
            return Some(landing(carried));
        }
        let sp = ShadingPoint::new(&hit, path.ray.dir, scene, lambda);
        if media.is_some() {
            // A medium's boundary (or a mask's hole): crossed, no scattering event.
            let (mut beta, ray) = (path.beta, path.ray);
            match cross_null(&sp, &ray, TransportMode::Radiance, &mut beta, sampler) {
                Some(Some(next)) => {
                    path.beta = beta;
                    path.ray = next;
                    continue;
                }
                Some(None) => return None,
                None => {}
            }
        }
        let p = sp.material.delta_probability(sp.wo);
        let u_lobe = if p > 0.0 { sampler.next_1d() } else { 1.0 };
        if u_lobe >= p {
            return Some(landing(carried / (1.0 - p)));
        }
        if path.bounces >= max_bounces {
            return None;
        }
        if !path.scatter_with_lobe(&sp, u_lobe, rr_depth, sampler) {
            return None;
        }
    }
}

/// About the memory a map of `photons` emitted photons takes while it is built: one landing
/// each (scenes of high albedo store several), held twice while sorted into buckets.
pub fn photon_map_bytes(photons: u64) -> u64 {
    photons * 2 * std::mem::size_of::<Photon>() as u64
}

/// Where an item of a [`PointGrid`] lies.
pub trait Located {
    fn position(&self) -> Vec3A;
}

impl Located for Photon {
    #[inline]
    fn position(&self) -> Vec3A {
        Vec3A::from(self.p)
    }
}

/// Points (photons, light-path vertices) in a hashed grid, for gathers of radius up to the
/// one the grid was built for.
#[derive(Clone, Debug)]
pub struct PointGrid<T> {
    /// Items sorted by bucket.
    items: Vec<T>,
    cells: Cells,
}

/// Photons in a hashed grid.
pub type PhotonMap = PointGrid<Photon>;

/// A hashed grid over points held elsewhere: the indices of a shared array's items, by bucket
/// (12 bytes per point with the buckets, where a [`PointGrid`] holds a copy of each). Grids of
/// several radii over one array share its points (`sppm-pixel`'s levels).
#[derive(Clone, Debug, Default)]
pub struct GridIndex {
    /// Indices into the shared array, sorted by bucket.
    order: Vec<u32>,
    cells: Cells,
}

/// The buckets of a hashed grid: `starts[b]..starts[b + 1]` are the places of bucket `b`'s
/// points in the grid's order.
#[derive(Clone, Debug, Default)]
struct Cells {
    starts: Vec<u32>,
    inv_cell: f32,
    radius: f32,
}

impl<T> Default for PointGrid<T> {
    fn default() -> Self {
        PointGrid {
            items: Vec::new(),
            cells: Cells::default(),
        }
    }
}

/// Integer coordinates of the grid cell containing `p`.
#[inline]
fn cell_of(p: Vec3A, inv_cell: f32) -> [i64; 3] {
    let c = (p * inv_cell).floor();
    [c.x as i64, c.y as i64, c.z as i64]
}

/// Bucket of a cell: Teschner et al.'s spatial hash, masked to a power-of-two table.
#[inline]
fn bucket_of(c: [i64; 3], mask: usize) -> usize {
    let h = (c[0].wrapping_mul(73_856_093))
        ^ (c[1].wrapping_mul(19_349_663))
        ^ (c[2].wrapping_mul(83_492_791));
    (h as u64 as usize) & mask
}

impl Cells {
    /// The buckets of `items` for gathers of radius `radius` (> 0), and the items' order by
    /// bucket: buckets in parallel, then a counting sort (linear, and stable, so the grid
    /// does not depend on the thread count).
    fn build<T: Located + Sync>(items: &[T], radius: f32) -> (Cells, Vec<u32>) {
        let radius = radius.max(f32::MIN_POSITIVE);
        let inv_cell = 1.0 / (2.0 * radius);
        let buckets = (items.len() * 2).next_power_of_two().max(1);
        let mask = buckets - 1;
        let keys: Vec<u32> = items
            .par_iter()
            .map(|ph| bucket_of(cell_of(ph.position(), inv_cell), mask) as u32)
            .collect();
        let mut starts = vec![0u32; buckets + 1];
        for &k in &keys {
            starts[k as usize + 1] += 1;
        }
        for b in 0..buckets {
            starts[b + 1] += starts[b];
        }
        let mut next = starts.clone();
        let mut order = vec![0u32; items.len()];
        for (i, &k) in keys.iter().enumerate() {
            order[next[k as usize] as usize] = i as u32;
            next[k as usize] += 1;
        }
        let cells = Cells {
            starts,
            inv_cell,
            radius,
        };
        (cells, order)
    }

    /// Calls `f` with the places (in the grid's order) of the points in every bucket a
    /// gather of the grid's radius around `p` touches, each bucket once.
    #[inline]
    fn for_each_bucket_near(&self, p: Vec3A, mut f: impl FnMut(std::ops::Range<usize>)) {
        if self.starts.len() < 2 {
            return;
        }
        let r = self.radius;
        let mask = self.starts.len() - 2;
        let (lo, hi) = (cell_of(p - r, self.inv_cell), cell_of(p + r, self.inv_cell));
        // Cells are 2r wide: at most 2 per axis. Distinct cells may share a bucket; visit
        // each bucket once.
        let mut seen = [usize::MAX; 8];
        let mut n_seen = 0;
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    let b = bucket_of([x, y, z], mask);
                    if seen[..n_seen].contains(&b) {
                        continue;
                    }
                    if n_seen < seen.len() {
                        seen[n_seen] = b;
                        n_seen += 1;
                    }
                    f(self.starts[b] as usize..self.starts[b + 1] as usize);
                }
            }
        }
    }
}

impl<T: Located + Copy + Send + Sync> PointGrid<T> {
    /// Builds the grid for gathers of radius `radius` (> 0).
    pub fn build(items: Vec<T>, radius: f32) -> PointGrid<T> {
        let (cells, order) = Cells::build(&items, radius);
        let sorted = order.iter().map(|&i| items[i as usize]).collect();
        PointGrid {
            items: sorted,
            cells,
        }
    }

    /// Number of items stored.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// True if nothing is stored.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// The gather radius the map was built for.
    pub fn radius(&self) -> f32 {
        self.cells.radius
    }

    /// The items, in the grid's order (sorted by bucket).
    pub fn items(&self) -> &[T] {
        &self.items
    }

    /// Calls `f` on every item within the grid's radius of `p`, each once.
    #[inline]
    pub fn for_each_near(&self, p: Vec3A, mut f: impl FnMut(&T)) {
        let r2 = self.cells.radius * self.cells.radius;
        self.cells.for_each_bucket_near(p, |range| {
            for ph in &self.items[range] {
                if (ph.position() - p).length_squared() < r2 {
                    f(ph);
                }
            }
        });
    }
}

/// Points gathered from by position: a grid that holds its points ([`PointGrid`]), or an
/// index over a shared array ([`Shared`]).
pub trait Gather<T> {
    /// Calls `f` on every point within the grid's radius of `p`, each once.
    fn for_each_near(&self, p: Vec3A, f: impl FnMut(&T));
}

impl<T: Located + Copy + Send + Sync> Gather<T> for PointGrid<T> {
    #[inline]
    fn for_each_near(&self, p: Vec3A, f: impl FnMut(&T)) {
        PointGrid::for_each_near(self, p, f)
    }
}

/// A [`GridIndex`] with the array it was built over.
pub struct Shared<'a, T> {
    pub index: &'a GridIndex,
    pub items: &'a [T],
}

impl<T: Located> Gather<T> for Shared<'_, T> {
    #[inline]
    fn for_each_near(&self, p: Vec3A, f: impl FnMut(&T)) {
        self.index.for_each_near(self.items, p, f)
    }
}

impl GridIndex {
    /// Builds the grid over `items` for gathers of radius `radius` (> 0).
    pub fn build<T: Located + Sync>(items: &[T], radius: f32) -> GridIndex {
        let (cells, order) = Cells::build(items, radius);
        GridIndex { order, cells }
    }

    /// Calls `f` on every item of `items` (the array the grid was built over) within the
    /// grid's radius of `p`, each once, in the order a [`PointGrid`] of the same items
    /// visits them.
    #[inline]
    pub fn for_each_near<T: Located>(&self, items: &[T], p: Vec3A, mut f: impl FnMut(&T)) {
        let r2 = self.cells.radius * self.cells.radius;
        self.cells.for_each_bucket_near(p, |range| {
            for &i in &self.order[range] {
                let ph = &items[i as usize];
                if (ph.position() - p).length_squared() < r2 {
                    f(ph);
                }
            }
        });
    }

    /// Bytes it holds per point (the index and two buckets).
    pub const BYTES_PER_POINT: u64 = 12;
}

impl PhotonMap {
    /// Radiance reflected at `hit` towards `wo` (local frame of `frame`) by the photons near it
    /// that `accept` admits: `sum f(wo, wi) Phi / (pi r^2)`.
    #[inline]
    pub fn radiance(&self, sp: &ShadingPoint, accept: impl Fn(&Photon) -> bool) -> Spectrum {
        let (frame, wo, material, hit) = (&sp.frame, sp.wo, &sp.material, &sp.hit);
        let wo_world = frame.to_world(wo);
        let mut sum = Spectrum::ZERO;
        self.for_each_near(hit.p, |ph| {
            let wi = Vec3A::from(ph.wi);
            if accept(ph) && stays_on_viewer_side(material, hit.ng, wo_world, wi) {
                sum += material.eval(wo, frame.to_local(wi)) * Spectrum::from_array(ph.power);
            }
        });
        sum / (std::f32::consts::PI * self.radius() * self.radius())
    }
}

impl PhotonMap {
    /// Radiance scattered towards `wo` (back along the ray that arrived) at `p`, in `medium`,
    /// by the photons that landed in that medium near `p` and that `accept` admits. A photon
    /// landing at a real scattering event carries `sigma_s L dw dV` in expectation, stored
    /// over `sigma_s` there, so `sum phase(wo, wi) Phi / (4/3 pi r^3)` estimates the
    /// in-scattered radiance `int phase L dw` (the caller's throughput to `p` holds the
    /// `sigma_s` of the scattering event). Photons of another medium within the radius (fog
    /// beside milk) are not counted.
    pub fn in_scattered(
        &self,
        scene: &dyn Scene,
        medium: MediumId,
        p: Vec3A,
        wo: Vec3A,
        accept: impl Fn(&Photon) -> bool,
    ) -> Spectrum {
        let (sum, _) = scattered_within(self, scene, (p, wo, medium), self.radius(), accept);
        sum / (4.0 / 3.0 * std::f32::consts::PI * self.radius().powi(3))
    }
}

/// The flux the photons of `grid` that landed in `medium` within `radius` (at most the
/// grid's) of `p` and that `accept` admits scatter towards `wo`, `sum phase(wo, wi) Phi`
/// (their powers over `sigma_s` where they landed), and their number.
pub fn scattered_within(
    grid: &impl Gather<Photon>,
    scene: &dyn Scene,
    (p, wo, medium): (Vec3A, Vec3A, MediumId),
    radius: f32,
    accept: impl Fn(&Photon) -> bool,
) -> (Spectrum, u32) {
    let Some(m) = scene.medium(medium) else {
        return (Spectrum::ZERO, 0);
    };
    let phase = m.phase();
    let (mut sum, mut count) = (Spectrum::ZERO, 0u32);
    let r2 = radius * radius;
    grid.for_each_near(p, |ph| {
        if ph.medium == medium && accept(ph) && (Vec3A::from(ph.p) - p).length_squared() < r2 {
            sum += phase.eval(wo, Vec3A::from(ph.wi)) * Spectrum::from_array(ph.power);
            count += 1;
        }
    });
    (sum, count)
}

/// A photon set split by where its photons landed: on surfaces, and in media (kept in the
/// same order, so the maps do not depend on the thread count).
pub fn split_by_place(photons: Vec<Photon>) -> (Vec<Photon>, Vec<Photon>) {
    photons.into_iter().partition(|p| !p.in_medium())
}

/// The default first gather radius: a fraction of the scene's bounding-box diagonal.
pub fn auto_radius(scene: &dyn Scene, fraction: f32) -> f32 {
    let (lo, hi) = scene.bounds();
    let diag = (hi - lo).length();
    if diag.is_finite() && diag > 0.0 {
        diag * fraction
    } else {
        1e-2
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{floor_under_sphere_light, furnace_sphere};

    fn pass(count: u32, keep: Keep, max_bounces: u32, seed: u64, stream: u64) -> PhotonPass {
        PhotonPass {
            count,
            keep,
            max_bounces,
            seed,
            stream,
            eye: Vec3A::ZERO,
            lambda: Wavelengths::Rgb,
        }
    }

    /// `n` photons scattered in [-1, 1]^3, each numbered by its power.
    fn numbered_photons(s: &mut Sampler, n: u32) -> Vec<Photon> {
        (0..n)
            .map(|i| Photon {
                p: Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 2.0 - 1.0,
                wi: Vec3::Z,
                power: [i as f32; 4],
                bounces: 0,
                caustic: false,
                medium: MediumId::VACUUM,
            })
            .collect()
    }

    #[test]
    fn grid_finds_exactly_the_photons_within_the_radius() {
        let mut s = Sampler::new(3, 0, 0);
        let photons = numbered_photons(&mut s, 5000);
        let map = PhotonMap::build(photons.clone(), 0.13);
        for _ in 0..200 {
            let q = Vec3A::new(s.next_1d(), s.next_1d(), s.next_1d()) * 2.4 - 1.2;
            let mut found: Vec<u32> = Vec::new();
            map.for_each_near(q, |p| found.push(p.power[0] as u32));
            found.sort_unstable();
            let expected: Vec<u32> = photons
                .iter()
                .filter(|p| (Vec3A::from(p.p) - q).length_squared() < 0.13 * 0.13)
                .map(|p| p.power[0] as u32)
                .collect();
            assert_eq!(found, expected, "around {q:?}");
        }
    }

    #[test]
    fn an_index_over_shared_photons_finds_what_a_grid_of_them_finds_in_its_order() {
        // `sppm-pixel`'s levels: indices of several radii over one array, each visiting
        // exactly the photons (and in the order) a grid holding its own copy visits.
        let mut s = Sampler::new(5, 0, 0);
        let shared = PhotonMap::build(numbered_photons(&mut s, 4000), 0.4);
        for radius in [0.4, 0.2, 0.1, 0.05] {
            let own = PhotonMap::build(shared.items().to_vec(), radius);
            let index = GridIndex::build(shared.items(), radius);
            let view = Shared {
                index: &index,
                items: shared.items(),
            };
            let mut nonempty = 0;
            for _ in 0..200 {
                let q = Vec3A::new(s.next_1d(), s.next_1d(), s.next_1d()) * 2.4 - 1.2;
                let (mut a, mut b) = (Vec::new(), Vec::new());
                own.for_each_near(q, |p| a.push(p.power[0] as u32));
                view.for_each_near(q, |p| b.push(p.power[0] as u32));
                assert_eq!(a, b, "radius {radius} around {q:?}");
                nonempty += usize::from(!a.is_empty());
            }
            assert!(
                nonempty > 20,
                "radius {radius}: {nonempty} gathers found photons"
            );
        }
    }

    #[test]
    fn photon_powers_add_up_to_the_power_reaching_surfaces() {
        // Inside the closed furnace every photon lands: the first landings carry the emitted
        // power, 2 pi Le A (both sides emit, the outward half escapes: pi Le A lands).
        let scene = furnace_sphere(0.5, 1.0);
        let (photons, _) = trace_photons(&scene, &pass(200_000, Keep::All, 0, 7, 0), Stop::NEVER);
        let first: f64 = photons.iter().map(|p| p.power[1] as f64).sum();
        let area: f64 = scene
            .lights()
            .lights()
            .iter()
            .map(|l| match l {
                crate::Light::Planar(l) => l.area as f64,
                _ => 0.0,
            })
            .sum();
        let expected = std::f64::consts::PI * area;
        assert!(
            (first / expected - 1.0).abs() < 0.01,
            "landed {first}, emitted inwards {expected}"
        );
    }

    #[test]
    fn density_estimate_matches_the_irradiance_below_a_sphere_light() {
        // Direct landings on the floor below a sphere light: a L (r/d)^2 = 0.125.
        let scene = floor_under_sphere_light(0.5, 4.0, 0.5, 2.0);
        let (photons, _) =
            trace_photons(&scene, &pass(1_000_000, Keep::All, 0, 11, 0), Stop::NEVER);
        // About 5,500 photons within r = 0.15: a 1.3% standard error; the irradiance falls
        // by 1% from the centre to the disk's edge.
        let map = PhotonMap::build(photons, 0.15);
        let hit = Hit::new(1.0, Vec3A::ZERO, Vec3A::Z, 0, None);
        let sp = ShadingPoint::new(&hit, -Vec3A::Z, &scene, &mut Wavelengths::Rgb);
        let l = map.radiance(&sp, |_| true);
        assert!((l.y - 0.125).abs() < 0.125 * 0.05, "{l:?}");
    }

    #[test]
    fn maps_do_not_depend_on_the_thread_count() {
        let scene = furnace_sphere(0.5, 1.0);
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    trace_photons(
                        &scene,
                        &pass(3 * BLOCK + 17, Keep::Indirect, 8, 5, 2),
                        Stop::NEVER,
                    )
                })
        };
        let (a, ca) = run(1);
        let (b, cb) = run(3);
        assert_eq!(a, b);
        assert_eq!(ca, cb);
    }
}
