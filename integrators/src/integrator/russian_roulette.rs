//! `russian-roulette`: what the report wished for (its section 4): one continuation ray per
//! hit instead of a branching tree, ended at random instead of at a fixed depth.
//!
//! **Estimates** the full rendering equation. At every non-specular hit: direct light from one
//! light chosen as `light-selection` says (one shadow ray), then one BSDF-sampled continuation
//! ray. Emitters reached by continuation rays count only after specular bounces (direct light
//! already covers them), so there is no multiple importance sampling: compare with `path`.
//! From `rr-depth` scattering events on, the path survives with probability
//! `min(0.95, max(throughput))` and its throughput is divided by that probability.
//!
//! **Parameters**: `rr-depth` (default 3), `max-depth` (default unlimited),
//! `light-selection` (`scene`, the default, `uniform`, `power` or `bvh`).
//! **Bias**: none with unlimited `max-depth` (Russian roulette is unbiased); truncation
//! otherwise.

use crate::integrator::{
    emitted_at, escaped, sample_one_light, PathState, RayIntegrator, ShadingPoint, Tracer,
};
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, Params, SpectralSupport, LIGHT_SELECTION,
    MAX_DEPTH, RR_DEPTH,
};
use crate::spectrum::Wavelengths;
use crate::Spectrum;
use crate::{Ray, Sampler};

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "russian-roulette",
    summary:
        "one continuation ray per hit, direct light by one shadow ray, Russian roulette (no MIS)",
    params: &[RR_DEPTH, MAX_DEPTH, LIGHT_SELECTION],
    build: |p: &Params| {
        Box::new(RussianRouletteTracer {
            rr_depth: p.get_u32("rr-depth"),
            max_depth: p.get_depth("max-depth"),
            lights: p.get_light_selection(),
        })
    },
    analytic: Some(Analytic {
        params: &[],
        furnace: expect(2.0, 50, 1000),
        point_in_sphere: expect(1.0, 40, 500),
        sphere_under_sky: expect(1.2, 40, 500),
    }),
    media: MediaSupport::None,
    spectral: SpectralSupport::PerSample,
};

struct RussianRouletteTracer {
    rr_depth: u32,
    max_depth: u32,
    /// How light samples pick a light (`None`: the scene's choice).
    lights: Option<crate::light::LightSelection>,
}

impl RayIntegrator for RussianRouletteTracer {
    fn radiance(
        &self,
        camera_ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        let mut l = Spectrum::ZERO;
        let mut path = PathState::from_camera(*camera_ray);
        loop {
            // Trace: the camera ray, then continuation rays. Emission counts only when
            // direct-light sampling could not have found it: seen directly or through
            // specular bounces.
            let Some(hit) = path.trace(tracer) else {
                if path.specular {
                    l += path.beta * escaped(tracer.scene, &path.ray, lambda);
                }
                break;
            };
            if path.specular {
                l += path.beta * emitted_at(tracer.scene, &hit, &path.ray, lambda);
            }
            if path.bounces >= self.max_depth {
                break;
            }
            let sp = ShadingPoint::new(&hit, path.ray.dir, tracer.scene, lambda);
            // Direct light: one light, one shadow ray.
            if !sp.material.is_specular() {
                l += path.beta * sample_one_light(&sp, false, self.lights, tracer, sampler);
            }
            // Continuation: one BSDF-sampled ray, then Russian roulette.
            if !path.scatter(&sp, self.rr_depth, sampler) {
                break;
            }
        }
        l
    }
}

#[cfg(test)]
mod tests {
    use crate::testing::*;

    #[test]
    fn paths_end_inside_a_closed_mirror() {
        // Unlimited depth and a throughput that never drops: Russian roulette must still end
        // every path (a regression: this used to loop forever).
        let (mean, _) = estimate("russian-roulette", &[], &inside_a_mirror(), 2000);
        assert_eq!(mean, 0.0);
    }

    #[test]
    fn a_glass_ball_in_the_furnace_is_invisible() {
        // Looking at the ball: radiance through it equals the radiance everywhere.
        expect_mean(
            "russian-roulette",
            &[],
            &furnace_with_glass(0.5, 1.0),
            2.0,
            30000,
        );
    }

    #[test]
    fn floor_under_a_sphere_light_and_one_sided_emission() {
        // Radiance a L (r/d)^2 = 0.5 * 4 * (0.5/2)^2 = 0.125 below a spherical light.
        expect_mean(
            "russian-roulette",
            &[],
            &floor_under_sphere_light(0.5, 4.0, 0.5, 2.0),
            0.125,
            4000,
        );
        // A one-sided light facing away from the floor lights nothing, and its back is black.
        let (mean, _) = estimate(
            "russian-roulette",
            &[],
            &floor_under_light_facing_away(),
            2000,
        );
        assert_eq!(mean, 0.0);
    }
}
