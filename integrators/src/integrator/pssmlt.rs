//! `pssmlt`: primary-sample-space Metropolis light transport (Kelemen, Szirmay-Kalos, Antal,
//! Csonka 2002) over unidirectional path tracing (Mitsuba 0.6's `pssmlt`, Tungsten's).
//!
//! **Estimates** the image by Markov chains over the uniform numbers `path` (in a scene with
//! participating media, `volpath`) draws for one camera sample: the first two pick the film position anywhere on the image, the rest build
//! the path, and `path`'s estimate (next-event estimation, MIS, Russian roulette) is the
//! chain's target, its luminance the density the chain visits. A mutation moves every number
//! by a small Gaussian step or, with `large-step-probability`, draws all anew; it is accepted
//! with probability `min(1, y' / y)`. Where bright paths are rare and hard to find but lie
//! close to each other (light through a door ajar), a chain that found one stays near it.
//! The driver (bootstrap, chains, splats, why each pass is unbiased) is in `metropolis.rs`.
//!
//! **Parameters**: `max-depth` (default unlimited), `rr-depth` (3), `bootstrap` (0: a
//! quarter of the pixel count, per pass), `chains` (8 per pass), `mutations-per-pixel` (4 per pass),
//! `large-step-probability` (0.3), `sigma` (0.01).
//! **Bias**: none (each pass's bootstrap-normalised estimate is unbiased); truncation with a
//! finite `max-depth`. Its noise is correlated: a chain's splats cluster, so images look
//! blotchy before they look grainy.

use crate::integrator::metropolis::{Metropolis, PathSpace, PARAMS};
use crate::integrator::path::PathTracer;
use crate::integrator::volpath::VolPath;
use crate::integrator::{RayIntegrator, Tracer};
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, Params, SpectralSupport, MAX_DEPTH, RR_DEPTH,
};
use crate::spectrum::Wavelengths;
use crate::{Camera, Rgb, Sampler};
use glam::Vec2;

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "pssmlt",
    summary:
        "primary-sample-space Metropolis light transport (Kelemen et al. 2002) over path tracing",
    params: &[
        MAX_DEPTH, RR_DEPTH, PARAMS[0], PARAMS[1], PARAMS[2], PARAMS[3], PARAMS[4],
    ],
    build: |p: &Params| {
        let (max_depth, rr_depth) = (p.get_depth("max-depth"), p.get_u32("rr-depth"));
        Box::new(Metropolis::new(
            UnidirectionalPaths {
                // The chains pick lights as the scene says (their numbers are a chain's).
                path: PathTracer {
                    max_depth,
                    rr_depth,
                    lights: None,
                },
                volpath: VolPath {
                    max_depth,
                    rr_depth,
                    lights: None,
                },
            },
            p,
        ))
    },
    analytic: Some(Analytic {
        params: &[("bootstrap", "2000"), ("chains", "16")],
        furnace: expect(2.0, 40, 400),
        point_in_sphere: expect(1.0, 40, 400),
        sphere_under_sky: expect(1.2, 40, 400),
    }),
    media: MediaSupport::Full,
    spectral: SpectralSupport::PerProposal,
};

/// `path`'s camera samples as points of primary sample space; in a scene with media,
/// `volpath`'s.
struct UnidirectionalPaths {
    path: PathTracer,
    volpath: VolPath,
}

impl PathSpace for UnidirectionalPaths {
    fn streams(&self) -> u32 {
        1
    }

    fn classes(&self) -> u32 {
        1
    }

    fn evaluate(
        &self,
        _class: u32,
        camera: &Camera,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        spectral: bool,
    ) -> (Rgb, Vec2) {
        sampler.start_stream(0);
        // The film position, anywhere on the image, the wavelengths; then the path.
        let u = sampler.next_2d();
        let film = Vec2::new(u.x * camera.width as f32, u.y * camera.height as f32);
        let mut lambda = match spectral {
            true => Wavelengths::sample(sampler.next_1d()),
            false => Wavelengths::Rgb,
        };
        let ray = camera.ray(film.x, film.y);
        let l = if tracer.scene.has_media() {
            self.volpath.radiance(&ray, tracer, sampler, &mut lambda)
        } else {
            self.path.radiance(&ray, tracer, sampler, &mut lambda)
        };
        (lambda.to_rgb(l), film)
    }
}
