//! What paths from the lights need to walk participating media, shared by the integrators
//! that trace them: which medium a point sits in, free flights to the next real scattering
//! event (delta tracking against the majorant, one colour channel setting the rate), and the
//! transmittance of a connection between two vertices (ratio tracking, through the surfaces
//! a ray can cross).
//!
//! Throughputs are carried as in `volpath`: `beta` over the hero channel's density, and
//! `r_u`, each channel's density over the hero's; an estimate divides by the average of
//! `r_u`, one-sample MIS over the channels that keeps coloured media from being noisy.

use crate::integrator::{stays_on_viewer_side, ShadingPoint, Tracer};
use crate::medium::tracking::sample_t_maj;
use crate::spectrum::Wavelengths;
use crate::{Hit, LightSample, MediumId, Ray, Sampler, Scene, Spectrum};
use glam::Vec3A;

/// How many surfaces a walk crosses before it gives up (a bound on one ray's work).
const MAX_CROSSINGS: usize = 256;

/// Whether `x` is above zero (false for NaN).
#[inline]
pub fn positive(x: f32) -> bool {
    x > 0.0
}

/// `v / sigma_s` per channel, 0 in a channel that does not scatter: what a point landed in
/// a medium carries into a density estimate, so that the estimate blurs the in-scattered
/// radiance and not the medium's scattering coefficient with it.
#[inline]
pub fn over_sigma_s(v: Spectrum, sigma_s: Spectrum) -> Spectrum {
    let per = |c: usize| {
        if positive(sigma_s[c]) {
            v[c] / sigma_s[c]
        } else {
            0.0
        }
    };
    Spectrum::new(per(0), per(1), per(2), per(3))
}

/// The hero channel of a path (a lane of its [`Spectrum`]), from one uniform number.
#[inline]
pub fn hero_channel(u: f32, lambda: &Wavelengths) -> usize {
    let n = lambda.lanes();
    ((u * n as f32) as usize).min(n - 1)
}

/// The medium at `to`, found by walking the segment from `from`, which lies in `medium`,
/// across every surface between them that bounds media (a light's medium, from the camera's).
pub fn medium_at(scene: &dyn Scene, from: Vec3A, medium: MediumId, to: Vec3A) -> MediumId {
    let mut medium = medium;
    let mut origin = from;
    for _ in 0..MAX_CROSSINGS {
        let d = to - origin;
        let dist = d.length();
        if !(positive(dist) && dist.is_finite()) {
            return medium;
        }
        let ray = Ray {
            tmax: dist,
            medium,
            ..Ray::new(origin, d / dist)
        };
        let Some(hit) = scene.intersect(&ray) else {
            return medium;
        };
        medium = hit.media.towards(hit.ng, ray.dir);
        origin = hit.spawn_ray(ray.dir).origin;
    }
    medium
}

/// Where a free flight ends.
pub enum Flight {
    /// A real scattering event at `p` in the ray's medium (`beta` and `r_u` updated).
    Scattered(Vec3A),
    /// The surface the ray was going to, or nothing: no scattering on the way.
    Through,
    /// The path ends (absorbed to nothing).
    Ended,
}

/// The free flight of `ray` (in its medium) up to `tmax`: delta tracking at channel `hero`'s
/// rate; a real collision scatters with the albedo as weight. Updates `beta` and `r_u`.
#[allow(clippy::too_many_arguments)]
pub fn fly(
    scene: &dyn Scene,
    ray: &Ray,
    tmax: f32,
    hero: usize,
    lambda: &Wavelengths,
    sampler: &mut Sampler,
    beta: &mut Spectrum,
    r_u: &mut Spectrum,
) -> Flight {
    let Some(medium) = scene.medium(ray.medium) else {
        return Flight::Through;
    };
    let mut scattered = None;
    let mut ended = false;
    let t_maj = sample_t_maj(medium, ray, tmax, hero, lambda, sampler, |c, sampler| {
        let pt = &c.point;
        let sigma_t = pt.sigma_a + pt.sigma_s;
        if sampler.next_1d() < sigma_t[hero] / c.sigma_maj[hero] {
            let pdf = c.t_maj[hero] * sigma_t[hero];
            *beta *= c.t_maj * pt.sigma_s / pdf;
            *r_u *= c.t_maj * sigma_t / pdf;
            scattered = Some(c.p);
            return false;
        }
        let sigma_n = (c.sigma_maj - sigma_t).max(Spectrum::ZERO);
        let pdf = c.t_maj[hero] * sigma_n[hero];
        if !positive(pdf) {
            ended = true;
            return false;
        }
        *beta *= c.t_maj * sigma_n / pdf;
        *r_u *= c.t_maj * sigma_n / pdf;
        true
    });
    let alive =
        |b: &Spectrum, r: &Spectrum| b.is_finite() && *b != Spectrum::ZERO && *r != Spectrum::ZERO;
    if let Some(p) = scattered {
        return if alive(beta, r_u) {
            Flight::Scattered(p)
        } else {
            Flight::Ended
        };
    }
    let end = t_maj[hero];
    if ended || !positive(end) {
        return Flight::Ended;
    }
    *beta *= t_maj / end;
    *r_u *= t_maj / end;
    if alive(beta, r_u) {
        Flight::Through
    } else {
        Flight::Ended
    }
}

/// The transmittance along `ray` (in its medium, up to its `tmax`): through media by ratio
/// tracking (unbiased in every channel), and through the surfaces
/// that are no surface at all (a `Null` boundary; a mask of opacity 0); zero where any other
/// surface lies on it. A thin dielectric or a partial mask blocks it: light subpaths make a
/// vertex there (a Dirac lobe), so a join that went through one would count again, under
/// other MIS weights, the paths with that vertex. Each ray cast counts as a connection.
pub fn transmittance(
    tracer: &mut Tracer,
    ray: &Ray,
    lambda: &Wavelengths,
    sampler: &mut Sampler,
) -> Spectrum {
    let scene: &dyn Scene = tracer.scene;
    let target = ray.at(ray.tmax);
    let mut ray = *ray;
    let mut tr = Spectrum::ONE;
    for _ in 0..MAX_CROSSINGS {
        tracer.counters.connection += 1;
        let hit = scene.intersect(&ray);
        let Some(h) = hit else {
            if let Some(medium) = scene.medium(ray.medium) {
                tr *= crate::medium::tracking::ratio_tracking(
                    medium, &ray, ray.tmax, lambda, sampler,
                );
            }
            return tr;
        };
        if !crosses(scene, &h, &ray) {
            return Spectrum::ZERO;
        }
        if let Some(medium) = scene.medium(ray.medium) {
            tr *= crate::medium::tracking::ratio_tracking(medium, &ray, h.t, lambda, sampler);
        }
        if tr == Spectrum::ZERO || !tr.is_finite() {
            return Spectrum::ZERO;
        }
        ray = next_towards(&h, &ray, target);
    }
    Spectrum::ZERO
}

/// Whether a walk crosses the surface at `h` without a vertex: no surface at all (only a
/// straight-on null event).
pub fn crosses(scene: &dyn Scene, h: &Hit, ray: &Ray) -> bool {
    // Most surfaces are surfaces, known without shading them.
    if scene.material(h.material).opacity().is_none() {
        return false;
    }
    // What is asked is the material's kind and a straight-on transmittance of exactly one,
    // the same in either mode: looked at in RGB.
    let sp = ShadingPoint::new(h, ray.dir, scene, &mut Wavelengths::Rgb);
    sp.material.lobes() == crate::bsdf::Lobes::DELTA_TRANSMISSION
        && sp.material.null_transmission(sp.wo) == Spectrum::ONE
}

/// What a light-path walk in media does at the surface `sp` (reached along `ray`): a
/// boundary that is no surface at all (`Null`, a mask's hole) is crossed without a vertex, its
/// straight-on null event sampled in `mode` and carried by `beta`: `Some(Some(next ray))`;
/// `Some(None)` ends the walk (no such event); `None`: a surface to make a vertex at.
pub fn cross_null(
    sp: &ShadingPoint,
    ray: &Ray,
    mode: crate::bsdf::TransportMode,
    beta: &mut Spectrum,
    sampler: &mut Sampler,
) -> Option<Option<Ray>> {
    if sp.material.lobes() != crate::bsdf::Lobes::DELTA_TRANSMISSION {
        return None;
    }
    let s = sp.sample(sampler.next_1d(), sampler.next_2d(), mode);
    Some(match s {
        Some(s) if s.bsdf.is_straight_through(sp.wo) => {
            *beta = s.throughput(*beta);
            Some(sp.hit.spawn_ray(ray.dir))
        }
        _ => None,
    })
}

/// The ray on from a crossed surface `h` towards `target` (or along `ray` past a target at
/// infinity), in the medium on the far side.
fn next_towards(h: &Hit, ray: &Ray, target: Vec3A) -> Ray {
    if ray.tmax.is_finite() {
        h.spawn_ray_to(target)
    } else {
        h.spawn_ray(ray.dir)
    }
}

/// A scattering point a light sample is taken at: a surface, or a point in a medium.
pub enum Scatterer<'s, 'a> {
    Surface(&'s ShadingPoint<'a>),
    /// At `p` in `medium`, `wo` back along the ray that reached it.
    Medium {
        p: Vec3A,
        wo: Vec3A,
        medium: MediumId,
    },
}

/// Direct light at `at` from one light sample (a light chosen as the scene says), with no
/// MIS: `f Tr Le / pdf`, `f` the BSDF and cosine or the phase function, `Tr` the
/// transmittance to the light ([`transmittance`]: through media and `Null` boundaries only,
/// so that it never counts light a path through a Dirac lobe counts). The photon gathers'
/// next-event estimation in media.
pub fn direct_light(
    at: &Scatterer,
    tracer: &mut Tracer,
    lambda: &Wavelengths,
    sampler: &mut Sampler,
) -> Spectrum {
    let scene: &dyn Scene = tracer.scene;
    let (u_light, u) = (sampler.next_1d(), sampler.next_2d());
    let ctx = match at {
        Scatterer::Surface(sp) => sp.light_context(),
        Scatterer::Medium { p, .. } => crate::light::LightContext {
            p: *p,
            n: Vec3A::ZERO,
        },
    };
    let Some((index, pmf)) = scene.lights().sample_for(None, &ctx, u_light) else {
        return Spectrum::ZERO;
    };
    let light = scene.lights().get(index);
    let (ls, f, ray) = match at {
        Scatterer::Surface(sp) => {
            let Some((ls, ray)) = light_at_surface(sp, index, u, scene) else {
                return Spectrum::ZERO;
            };
            let wi = sp.frame.to_local(ls.wi);
            (ls, sp.material.eval(sp.wo, wi) * wi.z.abs(), ray)
        }
        Scatterer::Medium { p, wo, medium } => {
            let Some(m) = scene.medium(*medium) else {
                return Spectrum::ZERO;
            };
            let Some(ls) = light.sample_li(*p, u, lambda) else {
                return Spectrum::ZERO;
            };
            let f = Spectrum::splat(m.phase().eval(*wo, ls.wi));
            (ls, f, ray_from_point(*p, &ls, *medium))
        }
    };
    if !positive(ls.pdf) || ls.radiance == Spectrum::ZERO || f == Spectrum::ZERO {
        return Spectrum::ZERO;
    }
    let l = f * ls.radiance / (pmf * ls.pdf) * transmittance(tracer, &ray, lambda, sampler);
    if l.is_finite() {
        l
    } else {
        Spectrum::ZERO
    }
}

/// One sample of light `index` (placed by `u`) seen from the surface `sp`, with the shadow
/// ray towards it (stopping short of it); `None` where the light cannot light the point's
/// viewer side: the emitter the point lies on, no sample, a sample across an opaque surface.
pub fn light_at_surface(
    sp: &ShadingPoint,
    index: u32,
    u: glam::Vec2,
    scene: &dyn Scene,
) -> Option<(LightSample, Ray)> {
    if !sp.can_receive(index, scene.lights()) {
        return None;
    }
    let ls = scene
        .lights()
        .get(index)
        .sample_li(sp.hit.p, u, &sp.lambda)?;
    if !stays_on_viewer_side(&sp.material, sp.hit.ng, sp.wo_world, ls.wi) {
        return None;
    }
    let ray = if ls.dist.is_finite() {
        sp.hit.spawn_ray_to(ls.point)
    } else {
        sp.hit.spawn_ray(ls.wi)
    };
    Some((ls, ray))
}

/// The shadow ray from a point in a medium towards a light sample, stopping short of it.
pub fn ray_from_point(p: Vec3A, ls: &LightSample, medium: MediumId) -> Ray {
    let tmax = if ls.dist.is_finite() {
        (ls.dist * (1.0 - 1e-4) - 1e-5 * (1.0 + ls.point.abs().max_element())).max(0.0)
    } else {
        f32::INFINITY
    };
    Ray {
        origin: p,
        dir: ls.wi,
        tmax,
        medium,
    }
}
