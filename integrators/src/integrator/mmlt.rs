//! `mmlt`: multiplexed Metropolis light transport (Hachisuka, Kaplanyan, Dachsbacher 2014;
//! pbrt-v4's `mlt`), Markov chains over the strategies of bidirectional path tracing.
//!
//! **Estimates** the image by chains in primary sample space whose state is one strategy
//! `(s, t)` of `bdpt` for a path of fixed depth `d` (scattering events): the first number
//! picks the strategy among the `d + 2` that build paths of that depth, the next two the film
//! position, the rest the camera subpath (stream 0), the light subpath (stream 1) and the
//! join (stream 2). The target is the strategy's MIS-weighted contribution times `d + 2`, so
//! the chain moves between strategies as well as paths, and spends its time where the
//! strategy that sees a path best sees it brightly. Each depth has its own bootstrap samples;
//! a chain keeps the depth it started with (chosen with its bootstrap sample). Subpaths take
//! no Russian roulette: they must reach their length. The driver (bootstrap, chains, splats,
//! why each pass is unbiased) is in `metropolis.rs`. Needs a pinhole camera (`t = 1`
//! strategies join light vertices to the lens).
//!
//! **Parameters**: `max-depth` (30, the most it takes: as good as the unlimited default of
//! `path` and `pssmlt`, where 10 left a closed white box 4% short in red), `bootstrap` (0: a
//! quarter of the pixel count per pass, shared by the depths), `chains` (8 per pass),
//! `mutations-per-pixel` (4 per pass), `large-step-probability` (0.3), `sigma` (0.01).
//! **Bias**: truncation at `max-depth`, otherwise none.

use crate::integrator::bdpt::Bdpt;
use crate::integrator::metropolis::{Metropolis, PathSpace, PARAMS};
use crate::integrator::Tracer;
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, Params, SpectralSupport, MAX_DEPTH,
};
use crate::spectrum::Wavelengths;
use crate::{Camera, Rgb, Sampler};
use glam::Vec2;

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "mmlt",
    summary:
        "multiplexed Metropolis light transport (Hachisuka et al. 2014) over bdpt's strategies",
    params: &[
        MAX_DEPTH
            .with_default(30.0)
            .with_max(30.0)
            .with_doc("scattering events per path (at most 30; one bootstrap per depth)"),
        PARAMS[0],
        PARAMS[1],
        PARAMS[2],
        PARAMS[3],
        PARAMS[4],
    ],
    build: |p: &Params| {
        let max_depth = p.get_depth("max-depth").min(30);
        Box::new(Metropolis::new(
            Strategies {
                bdpt: Bdpt::all_strategies(max_depth),
                max_depth,
            },
            p,
        ))
    },
    analytic: Some(Analytic {
        // Depth 12: the furnace gives 2 (1 - 2^-13), the point in the sphere 1 - 2^-12.
        params: &[("bootstrap", "500"), ("chains", "16"), ("max-depth", "12")],
        furnace: expect(1.999_755_9, 40, 400),
        point_in_sphere: expect(0.999_755_86, 40, 400),
        sphere_under_sky: None,
    }),
    media: MediaSupport::Scattering,
    spectral: SpectralSupport::PerProposal,
};

/// `bdpt`'s strategies, one depth per class, as points of primary sample space.
struct Strategies {
    bdpt: Bdpt,
    max_depth: u32,
}

impl PathSpace for Strategies {
    fn streams(&self) -> u32 {
        3
    }

    fn classes(&self) -> u32 {
        self.max_depth + 1
    }

    fn needs_pinhole(&self) -> bool {
        true
    }

    fn evaluate(
        &self,
        depth: u32,
        camera: &Camera,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        spectral: bool,
    ) -> (Rgb, Vec2) {
        sampler.start_stream(0);
        // The strategy: depth 0 has one ((0, 2): an emitter seen directly), depth d has d + 2.
        let u = sampler.next_1d();
        let (s, strategies) = if depth == 0 {
            (0, 1)
        } else {
            let n = depth as usize + 2;
            (((u * n as f32) as usize).min(n - 1), n)
        };
        let t = depth as usize + 2 - s;
        // The film position, then the subpaths and their join.
        let uv = sampler.next_2d();
        let film = Vec2::new(uv.x * camera.width as f32, uv.y * camera.height as f32);
        if !camera.is_pinhole() {
            return (Rgb::ZERO, film);
        }
        // The wavelengths both subpaths carry, from the camera's stream.
        let mut lambda = match spectral {
            true => Wavelengths::sample(sampler.next_1d()),
            false => Wavelengths::Rgb,
        };
        let (l, at) = self
            .bdpt
            .one_strategy(s, t, film, camera, tracer, sampler, &mut lambda);
        (lambda.to_rgb(l * strategies as f32), at)
    }
}
