//! `sppm-pixel`: stochastic progressive photon mapping with a radius per pixel (Hachisuka and
//! Jensen 2009, in pbrt-v4's form), beside `sppm`'s global radius.
//!
//! **Estimates** the full rendering equation, consistently. Every pass, each pixel traces a
//! camera path through specular bounces to its first non-specular surface, its visible
//! point, adding the emission met on the way and direct light there by next-event
//! estimation (`Ld`). Then a new set of photons is traced (landings after at least one
//! bounce), and each pixel gathers the photons within its own radius `R` at its visible
//! point: `M` photons bringing flux `Phi`. The pixel keeps a photon count `N` and a flux
//! `tau`, updated as Hachisuka and Jensen's progressive radiance estimate: `N' = N + gamma M`,
//! `R' = R sqrt(N' / (N + M))`, `tau' = (tau + beta Phi) (R' / R)^2`. Each pixel's radius thus
//! shrinks as fast as photons arrive there: bright, well-covered pixels sharpen quickly,
//! dark ones keep their blur (`sppm` shrinks one radius for all). After `n` passes a pixel's
//! estimate is `Ld / n + tau / (n pi R^2)`, with photon powers already divided by the
//! photons per pass.
//!
//! In participating media, photons walk media and land at real scattering events in them too
//! (see `photon_map`), and a camera path that scatters in a medium before reaching a
//! surface has its visible point there: direct light by a light sample through the media,
//! and the photons that landed in the medium within a ball of the pixel's radius
//! (`sum phase Phi / sigma_s`). A pixel keeps two progressive states, one for its visible
//! points on surfaces and one for those in media, each with its own radius, count and
//! flux (the ball's radius shrinks as `R' = R (N' / (N + M))^(1/3)` and its flux by
//! `(R' / R)^3`), since one pixel's camera paths may end on a wall in one pass and in fog
//! in the next; its estimate adds `tau_m / (n 4/3 pi R_m^3)`.
//!
//! The state lives in the pixels, not in the passes: the render loop averages what each pass
//! returns, so pass `n` returns `n E_n - (n - 1) E_{n-1}` (`E_n` the estimate after `n`
//! passes), whose average is exactly `E_n` with the box filter (the default; a wider filter
//! mixes neighbouring pixels' increments with the weights of each pass's film positions).
//! Per-pixel variances are therefore those of increments, not of independent samples. The
//! state is rebuilt from the seed after a resume (the passes are replayed), so resumed renders
//! equal direct ones. A render split into shards (`render --shard`) splits by bands of rows
//! ([`ShardBy::Rows`]): a pixel's state depends on its own visible points and the pass's
//! photons only, and each pixel gathers from a photon map whose cells are sized for its own
//! radius (levels `r0 / 2^k`), so a band computes exactly the bits the whole image does.
//!
//! **Parameters**: `photons` per pass (default 100000), `radius` (first radius per pixel in
//! scene units; 0 = 1% of the bounding-box diagonal), `gamma` (default 2/3: the fraction of
//! new photons kept), `max-depth` (default unlimited), `rr-depth` for the camera's specular
//! chain (default 3).
//! **Bias**: a blur of each pixel's radius, which shrinks as photons arrive (consistent, not
//! unbiased); truncation with a finite `max-depth`.

use crate::integrator::media_walk::{direct_light, Scatterer};
use crate::integrator::photon;
use crate::integrator::Work;
use crate::integrator::{Demand, Integrator, ShadingPoint};
use crate::integrator::{Stop, Tracer};
use crate::photon_map::{
    auto_radius, land, photon_map_bytes, scattered_within, split_by_place, trace_photons, Gather,
    GridIndex, Keep, Photon, PhotonMap, PhotonPass, Shared, Spot,
};
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, ParamKind, ParamSpec, Params, SpectralSupport,
    GATHER_RADIUS, MAX_DEPTH, PHOTONS, RR_DEPTH,
};
use crate::spectrum::of_rgb;
use crate::spectrum::Wavelengths;
use crate::{Camera, Ray, RayCounters, Rgb, Sampler, Scene};
use crate::{PassContext, SampleContext, Spectrum};
use glam::{Vec2, Vec3A};
use rayon::prelude::*;
use std::f32::consts::PI;

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "sppm-pixel",
    summary: "stochastic progressive photon mapping with a radius per pixel, shrinking as photons arrive there (pbrt-v4's SPPM); consistent",
    params: &[
        PHOTONS,
        GATHER_RADIUS
            .with_doc("first radius of every pixel, scene units (0 = 1% of the bounding-box diagonal)"),
        ParamSpec {
            name: "gamma",
            kind: ParamKind::Float,
            default: 2.0 / 3.0,
            min: 0.01,
            max: 1.0,
            doc: "fraction of a pass's photons a pixel keeps: N' = N + gamma M",
        },
        MAX_DEPTH.with_doc("scattering events per path, camera and photon sides together"),
        RR_DEPTH.with_doc("specular bounces of a camera path before Russian roulette starts"),
    ],
    build: |p: &Params| {
        Box::new(SppmPixel {
            photons: p.get_u32("photons"),
            radius: p.get("radius") as f32,
            gamma: p.get("gamma") as f32,
            max_depth: p.get_depth("max-depth"),
            rr_depth: p.get_u32("rr-depth"),
            pixels: Vec::new(),
            rows: None,
            passes: 0,
            spectral: false,
            seed: 0,
            camera: None,
        })
    },
    analytic: Some(Analytic {
        params: &[("photons", "20000")],
        furnace: expect(2.0, 40, 400),
        point_in_sphere: expect(1.0, 40, 400),
        sphere_under_sky: None,
    }),
    media: MediaSupport::Scattering,
    spectral: SpectralSupport::PerPass,
};

/// Pixels whose visible points are traced per parallel work item.
const BLOCK: usize = 256;

/// Seed offset separating the visible points' random numbers from the render loop's.
const VISIBLE_POINT_SEED: u64 = 0x7370_706d_7069_7865;

struct SppmPixel {
    photons: u32,
    /// First radius; 0 = automatic.
    radius: f32,
    gamma: f32,
    max_depth: u32,
    rr_depth: u32,
    /// Each pixel's state, row by row, of the rows rendered (all, or a shard's).
    pixels: Vec<Pixel>,
    /// The rows rendered; `None` for all.
    rows: Option<std::ops::Range<u32>>,
    /// Passes folded into `pixels` (0: none, or the state must be rebuilt).
    passes: u32,
    /// Whether passes carry sampled wavelengths (the render's mode).
    spectral: bool,
    /// The seed and camera they were rendered with.
    seed: u64,
    camera: Option<Camera>,
}

/// What a pixel keeps across passes, and this pass's visible point.
#[derive(Clone, Copy, Debug)]
struct Pixel {
    /// The progressive estimate of the light its visible points on surfaces gather (a disk
    /// of the radius) ...
    surface: Progress,
    /// ... and of what its visible points in media gather (a ball of the radius): a pixel's
    /// camera paths may end on a wall in one pass and in fog in the next, and the two kinds
    /// of density estimate shrink apart.
    medium: Progress,
    /// Emission and direct light summed over passes (`Ld`).
    direct: Rgb,
    /// The estimate after the passes so far, and after one pass fewer.
    estimate: Rgb,
    previous: Rgb,
    /// This pass's visible point.
    visible: Option<Visible>,
}

/// Hachisuka and Jensen's progressive statistics of one kind of density estimate.
#[derive(Clone, Copy, Debug)]
struct Progress {
    radius: f32,
    /// Photons counted so far (`N`).
    count: f32,
    /// Flux gathered so far, rescaled to the current radius (`tau`).
    flux: Rgb,
}

impl Progress {
    /// Folds in `m` photons bringing `flux` (already times the path's throughput) with the
    /// fraction `gamma` kept, in `dims` dimensions (2: a disk; 3: a ball).
    fn update(&mut self, flux: Rgb, m: u32, gamma: f32, dims: i32) {
        let m = m as f32;
        let kept = self.count + gamma * m;
        let ratio = kept / (self.count + m);
        let radius = if dims == 2 {
            self.radius * ratio.sqrt()
        } else {
            self.radius * ratio.cbrt()
        };
        let shrink = (radius / self.radius).powi(dims);
        self.flux = (self.flux + flux) * shrink;
        self.count = kept;
        self.radius = radius;
    }
}

/// Where a pass's visible point lies, with the ray that found it, the throughput to it and
/// the specular bounces before it.
#[derive(Clone, Copy, Debug)]
struct Visible {
    at: Spot,
    ray: Ray,
    beta: Spectrum,
    bounces: u32,
}

impl SppmPixel {
    /// Folds pass `pass` into every pixel's state.
    fn run_pass(
        &mut self,
        scene: &dyn Scene,
        camera: &Camera,
        seed: u64,
        pass: u32,
        stop: Stop,
    ) -> RayCounters {
        // The pass's wavelengths, which its visible points and photons carry; the pixels keep
        // what each pass adds as RGB (pbrt-v4's SPPM does the same).
        let lambda = Wavelengths::of_pass(self.spectral, seed, pass, scene.disperses());
        let (width, max_depth, rr_depth) = (camera.width as usize, self.max_depth, self.rr_depth);
        let first = self.first_row(camera) as usize * width;
        // Every pixel's visible point, with the emission and direct light on the way.
        let mut rays = RayCounters::default();
        let direct: Vec<(Vec<Rgb>, RayCounters)> = self
            .pixels
            .par_chunks_mut(BLOCK)
            .enumerate()
            .map(|(b, chunk)| {
                let mut tracer = Tracer::new(scene);
                let mut direct = Vec::with_capacity(chunk.len());
                for (k, px) in chunk.iter_mut().enumerate() {
                    if stop.requested() {
                        break;
                    }
                    let index = first + b * BLOCK + k;
                    let mut sampler =
                        Sampler::new(seed ^ VISIBLE_POINT_SEED, pass as u64, index as u64);
                    let film = Vec2::new((index % width) as f32, (index / width) as f32)
                        + sampler.next_2d();
                    let ray = camera.ray(film.x, film.y);
                    let mut l = Spectrum::ZERO;
                    px.visible = None;
                    let mut lambda = lambda;
                    let lambda = &mut lambda;
                    if let Some(x) = land(
                        ray,
                        true,
                        max_depth,
                        rr_depth,
                        Some(&mut l),
                        &mut tracer,
                        &mut sampler,
                        lambda,
                    ) {
                        if x.bounces < max_depth {
                            // Direct light by a light sample (through media, if any).
                            let (t, s) = (&mut tracer, &mut sampler);
                            l += x.beta
                                * match x.at {
                                    Spot::Surface(hit) => photon::direct(
                                        &ShadingPoint::new(&hit, x.ray.dir, scene, lambda),
                                        t,
                                        s,
                                    ),
                                    Spot::Medium(p) => {
                                        let (wo, medium) = (-x.ray.dir, x.ray.medium);
                                        direct_light(
                                            &Scatterer::Medium { p, wo, medium },
                                            t,
                                            lambda,
                                            s,
                                        )
                                    }
                                };
                            px.visible = Some(Visible {
                                at: x.at,
                                ray: x.ray,
                                beta: x.beta,
                                bounces: x.bounces,
                            });
                        }
                    }
                    direct.push(lambda.to_rgb(l));
                }
                (direct, tracer.counters)
            })
            .collect();
        if stop.requested() {
            return rays;
        }
        // This pass's photons (landings after one bounce or more), in maps whose cells depend
        // on a pixel's own radius alone: level k is built for the radius r0 / 2^k, and a pixel
        // gathers from the smallest level that holds its radius. (One map sized for the
        // widest pixel would make the order its photons are summed in, and so the bits of
        // its estimate, depend on which other pixels are rendered: a shard of rows would
        // differ from the whole image.)
        let r0 = self.first_radius(scene);
        // The levels the pixels' visible points on surfaces, and in media, need.
        let levels = |medium: bool| -> std::collections::BTreeSet<usize> {
            self.pixels
                .iter()
                .filter_map(|p| match p.visible?.at {
                    Spot::Surface(_) if !medium => Some(level_of(p.surface.radius, r0)),
                    Spot::Medium(_) if medium => Some(level_of(p.medium.radius, r0)),
                    _ => None,
                })
                .collect()
        };
        let (surface_levels, medium_levels) = (levels(false), levels(true));
        let max_bounces = self.max_depth.saturating_sub(1);
        let photon_pass = PhotonPass {
            count: self.photons,
            keep: Keep::Indirect,
            max_bounces,
            seed,
            stream: pass as u64,
            eye: camera.eye,
            lambda,
        };
        let (photons, photon_rays) = trace_photons(scene, &photon_pass, stop);
        rays.add(&photon_rays);
        if stop.requested() {
            return rays;
        }
        let (photons, in_media) = split_by_place(photons);
        // One array of photons for all levels, each level an index over it (12 bytes a photon
        // where a map of its own would copy them, 48). The array is sorted by level 0's
        // buckets, whose cells hold each finer level's, so that a gather's photons lie close
        // together in memory at every level. Level 0's radius is the scene's, not the pixels',
        // so a shard of rows sorts them as the whole image does.
        let levels_over = |photons: Vec<Photon>, levels: &std::collections::BTreeSet<usize>| {
            let sorted = PhotonMap::build(photons, level_radius(r0, 0));
            let mut index: Vec<Option<GridIndex>> = vec![None; levels.last().map_or(0, |l| l + 1)];
            for &level in levels {
                index[level] = Some(GridIndex::build(sorted.items(), level_radius(r0, level)));
            }
            (sorted, index)
        };
        let (photons, maps) = levels_over(photons, &surface_levels);
        let (in_media, volume_maps) = levels_over(in_media, &medium_levels);

        // Each pixel gathers the photons within its own radius and updates its estimate.
        let (gamma, n) = (self.gamma, pass as f32 + 1.0);
        let direct: Vec<Rgb> = direct
            .into_iter()
            .flat_map(|(d, r)| {
                rays.add(&r);
                d
            })
            .collect();
        // A pass cut short is abandoned by the render loop; should it not be, no pixel may
        // take another's direct light.
        if direct.len() != self.pixels.len() {
            return rays;
        }
        self.pixels
            .par_iter_mut()
            .zip(direct.par_iter())
            .for_each(|(px, &ld)| {
                // A non-finite value would stay in the pixel for good: it counts as black.
                if ld.is_finite() {
                    px.direct += ld;
                }
                // Every visible pixel's level has a map (built above from the same radii).
                if let Some(v) = px.visible {
                    let max_photon_bounces = max_depth.saturating_sub(v.bounces + 1);
                    match v.at {
                        Spot::Surface(hit) => {
                            let level = level_of(px.surface.radius, r0);
                            if let Some(map) = level_map(&maps, &photons, level) {
                                let mut at = lambda;
                                let sp = ShadingPoint::new(&hit, v.ray.dir, scene, &mut at);
                                let (flux, count) =
                                    gather(&map, &sp, px.surface.radius, max_photon_bounces);
                                let flux = at.to_rgb(v.beta * flux);
                                if count > 0 && flux.is_finite() {
                                    px.surface.update(flux, count, gamma, 2);
                                }
                            }
                        }
                        Spot::Medium(p) => {
                            let level = level_of(px.medium.radius, r0);
                            if let Some(map) = level_map(&volume_maps, &in_media, level) {
                                let (flux, count) = scattered_within(
                                    &map,
                                    scene,
                                    (p, -v.ray.dir, v.ray.medium),
                                    px.medium.radius,
                                    |ph| (ph.bounces as u32) <= max_photon_bounces,
                                );
                                let flux = lambda.to_rgb(v.beta * flux);
                                if count > 0 && flux.is_finite() {
                                    px.medium.update(flux, count, gamma, 3);
                                }
                            }
                        }
                    }
                }
                px.previous = px.estimate;
                let (s, m) = (&px.surface, &px.medium);
                px.estimate = px.direct / n
                    + s.flux / (n * PI * s.radius * s.radius)
                    + m.flux / (n * 4.0 / 3.0 * PI * m.radius.powi(3));
            });
        rays
    }
}

/// Levels of photon maps [`SppmPixel::demand`] counts: a pixel's radius shrinks by at most
/// `sqrt(gamma)` a pass and in practice far slower (`r ~ n^((gamma - 1) / 2)` where photons
/// arrive), so pixels spread over a few levels; each level more in use costs
/// [`GridIndex::BYTES_PER_POINT`] bytes a photon.
const LEVELS_COUNTED: u64 = 12;

/// Levels of photon maps below the first radius: 2^-40 of it is far below any radius a
/// render reaches.
const MAX_LEVEL: usize = 40;

/// Level `level`'s grid over `photons` (sorted as the grids were built over them), if the
/// level is in use.
fn level_map<'a>(
    maps: &'a [Option<GridIndex>],
    photons: &'a PhotonMap,
    level: usize,
) -> Option<Shared<'a, Photon>> {
    Some(Shared {
        index: maps.get(level)?.as_ref()?,
        items: photons.items(),
    })
}

/// The cell radius of photon-map level `level`: `r0 / 2^level`.
fn level_radius(r0: f32, level: usize) -> f32 {
    r0 * 0.5f32.powi(level as i32)
}

/// The smallest level whose radius holds `radius` (radii only shrink from `r0`).
fn level_of(radius: f32, r0: f32) -> usize {
    let mut level = 0;
    while level < MAX_LEVEL && level_radius(r0, level + 1) >= radius {
        level += 1;
    }
    level
}

/// The flux the photons within `radius` of the visible point `sp` bring towards its viewer
/// (`sum f Phi`), and their number; photons of more than `max_bounces` bounces are skipped.
fn gather(
    map: &impl Gather<Photon>,
    sp: &ShadingPoint,
    radius: f32,
    max_bounces: u32,
) -> (Spectrum, u32) {
    let (mut flux, mut count) = (Spectrum::ZERO, 0u32);
    let r2 = radius * radius;
    map.for_each_near(sp.hit.p, |ph| {
        if (ph.bounces as u32) > max_bounces
            || (Vec3A::from(ph.p) - sp.hit.p).length_squared() >= r2
        {
            return;
        }
        let wi = Vec3A::from(ph.wi);
        if !crate::integrator::stays_on_viewer_side(&sp.material, sp.hit.ng, sp.wo_world, wi) {
            return;
        }
        flux += sp.material.eval(sp.wo, sp.frame.to_local(wi)) * Spectrum::from_array(ph.power);
        count += 1;
    });
    (flux, count)
}

impl SppmPixel {
    /// The radius every pixel starts with.
    fn first_radius(&self, scene: &dyn Scene) -> f32 {
        if self.radius > 0.0 {
            self.radius
        } else {
            auto_radius(scene, 0.01)
        }
    }

    /// The first image row rendered.
    fn first_row(&self, camera: &Camera) -> u32 {
        self.rows.as_ref().map_or(0, |r| r.start.min(camera.height))
    }

    /// One past the last image row rendered.
    fn end_row(&self, camera: &Camera) -> u32 {
        self.rows
            .as_ref()
            .map_or(camera.height, |r| r.end.min(camera.height))
            .max(self.first_row(camera))
    }
}

impl Integrator for SppmPixel {
    fn sample(&self, cx: SampleContext) -> Spectrum {
        let SampleContext { pixel, lambda, .. } = cx;
        // The pixels hold RGB (each pass's spectra made RGB at its wavelengths).
        *lambda = Wavelengths::Rgb;
        // The increment that makes the render loop's average the estimate after this pass.
        let Some(camera) = self.camera.as_ref() else {
            return Spectrum::ZERO;
        };
        let Some(row) = pixel.y.checked_sub(self.first_row(camera)) else {
            return Spectrum::ZERO;
        };
        let index = row as usize * camera.width as usize + pixel.x as usize;
        let Some(px) = self.pixels.get(index) else {
            return Spectrum::ZERO;
        };
        let n = pixel.index as f32 + 1.0;
        of_rgb(px.estimate * n - px.previous * (n - 1.0))
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
        if self.spectral != lambda.is_spectral() {
            self.spectral = lambda.is_spectral();
            self.passes = 0;
        }
        // Only the rows rendered keep state (a shard's band); what they compute does not
        // depend on the other rows.
        if self.rows.as_ref() != Some(&cx.rows) {
            self.rows = Some(cx.rows.clone());
            self.passes = 0;
        }
        // A new render (or a resumed one, or one after an abandoned pass) starts the pixels
        // afresh and replays the passes before `pass`.
        let rows = self.first_row(camera)..self.end_row(camera);
        let count = camera.width as usize * rows.len();
        let fresh = self.passes == 0
            || pass + 1 < self.passes
            || self.seed != seed
            || self.camera.as_ref() != Some(camera)
            || self.pixels.len() != count;
        if fresh {
            let r0 = self.first_radius(scene);
            self.pixels = vec![
                Pixel {
                    surface: Progress {
                        radius: r0,
                        count: 0.0,
                        flux: Rgb::ZERO,
                    },
                    medium: Progress {
                        radius: r0,
                        count: 0.0,
                        flux: Rgb::ZERO,
                    },
                    direct: Rgb::ZERO,
                    estimate: Rgb::ZERO,
                    previous: Rgb::ZERO,
                    visible: None,
                };
                count
            ];
            self.seed = seed;
            self.camera = Some(camera.clone());
            self.passes = 0;
        }
        let mut rays = RayCounters::default();
        while self.passes <= pass {
            rays.add(&self.run_pass(scene, camera, seed, self.passes, stop));
            if stop.requested() {
                // The pixels hold part of a pass: rebuild them next time.
                self.passes = 0;
                return rays;
            }
            self.passes += 1;
        }
        rays
    }

    fn work(&self, _camera: &Camera) -> Work {
        Work::PixelState
    }

    fn demand(&self) -> Demand {
        Demand {
            rays_per_sample: 1.0,
            // The photons, held twice while sorted, and the levels' indices over them.
            memory: photon_map_bytes(self.photons as u64)
                + self.photons as u64 * LEVELS_COUNTED * GridIndex::BYTES_PER_POINT,
            memory_per_pixel: std::mem::size_of::<Pixel>() as u64 + 16,
            ..Demand::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{floor_under_sphere_light, furnace_sphere, TestScene};

    /// Every pixel's radius after `passes` passes of 20000 photons from a first radius of 0.1.
    fn radii_after(scene: &TestScene, camera: &Camera, passes: u32) -> Vec<f32> {
        let mut sppm = SppmPixel {
            photons: 20000,
            radius: 0.1,
            gamma: 2.0 / 3.0,
            max_depth: u32::MAX,
            rr_depth: 3,
            pixels: Vec::new(),
            rows: None,
            passes: 0,
            spectral: false,
            seed: 0,
            camera: None,
        };
        for pass in 0..passes {
            sppm.prepare_pass(&PassContext {
                scene,
                camera,
                seed: 1,
                pass,
                rows: 0..camera.height,
                stop: Stop::NEVER,
                lambda: Wavelengths::Rgb,
            });
        }
        assert!(sppm.pixels.iter().all(|p| p.estimate.is_finite()));
        sppm.pixels.iter().map(|p| p.surface.radius).collect()
    }

    #[test]
    fn radii_shrink_where_photons_arrive_and_nowhere_else() {
        // Inside the furnace every visible point receives bounced photons: every radius
        // shrinks, by sqrt(gamma) at the most per pass.
        let inside = Camera::look_at(Vec3A::ZERO, Vec3A::X, Vec3A::Z, 60.0, (8, 8));
        let radii = radii_after(&furnace_sphere(0.5, 1.0), &inside, 6);
        assert!(radii.iter().all(|&r| r < 0.09), "{radii:?}");
        assert!(
            radii
                .iter()
                .all(|&r| r >= 0.1 * (2.0f32 / 3.0).powf(3.0) - 1e-6),
            "{radii:?}"
        );
        // A floor lit only directly by a black sphere: no photon lands on it after a bounce,
        // so no pixel's radius moves.
        let above = Camera::look_at(
            Vec3A::new(3.0, 0.0, 1.0),
            Vec3A::ZERO,
            Vec3A::Z,
            20.0,
            (8, 8),
        );
        let radii = radii_after(&floor_under_sphere_light(0.5, 1.0, 0.2, 1.0), &above, 6);
        assert!(radii.iter().all(|&r| r == 0.1), "{radii:?}");
    }
}
