//! `path`: unidirectional path tracing with next-event estimation and multiple importance
//! sampling (Veach 1997), the modern baseline (pbrt-v4's and Mitsuba 3's `path`).
//!
//! **Estimates** the full rendering equation. At every non-specular hit, one light sample
//! (light chosen as `light-selection` says) and one BSDF sample both look for emitters; each is
//! weighted by the power heuristic against the other strategy's density, so neither small
//! bright lights nor glossy reflections of large ones are noisy. Specular bounces take the
//! emitter they reach with full weight. From `rr-depth` scattering events on, Russian roulette
//! ends paths with probability `1 - min(0.95, max(throughput))`.
//!
//! **Parameters**: `max-depth` (default unlimited), `rr-depth` (default 3),
//! `light-selection` (how the light sample picks its light: `scene`, the default, `uniform`,
//! `power` or `bvh`; emitters hit by BSDF samples are weighted with the same choice).
//! **Bias**: none with unlimited `max-depth`; truncation otherwise.

use crate::integrator::{
    emitted_at, escaped, sample_one_light, PathState, RayIntegrator, ShadingPoint, Tracer,
};
use crate::light::LightSelection;
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, Params, SpectralSupport, LIGHT_SELECTION,
    MAX_DEPTH, RR_DEPTH,
};
use crate::spectrum::Wavelengths;
use crate::Spectrum;
use crate::{Ray, Sampler};

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "path",
    summary: "path tracing: next-event estimation + BSDF sampling with MIS (power heuristic), Russian roulette",
    params: &[
        MAX_DEPTH,
        RR_DEPTH,
        LIGHT_SELECTION,
    ],
    build: |p: &Params| Box::new(PathTracer { max_depth: p.get_depth("max-depth"), rr_depth: p.get_u32("rr-depth"), lights: p.get_light_selection() }),
    analytic: Some(Analytic {
        params: &[],
        furnace: expect(2.0, 40, 500),
        point_in_sphere: expect(1.0, 40, 500),
        sphere_under_sky: expect(1.2, 40, 500),
    }),
    media: MediaSupport::None,
    spectral: SpectralSupport::PerSample,
};

pub(crate) struct PathTracer {
    pub(crate) max_depth: u32,
    pub(crate) rr_depth: u32,
    /// How light samples pick a light (`None`: the scene's choice).
    pub(crate) lights: Option<LightSelection>,
}

impl RayIntegrator for PathTracer {
    fn radiance(
        &self,
        camera_ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        let mut l = Spectrum::ZERO;
        let mut path = PathState::from_camera(*camera_ray).selecting_lights(self.lights);
        loop {
            // Trace the next segment.
            let Some(hit) = path.trace(tracer) else {
                // Escaped: environment light, MIS-weighted unless seen through specular.
                let le = escaped(tracer.scene, &path.ray, lambda);
                if le != Spectrum::ZERO {
                    l += path.beta * le * path.emission_weight(tracer, None);
                }
                break;
            };
            // Emission found by the BSDF sample (or the camera).
            if hit.light.is_some() {
                let le = emitted_at(tracer.scene, &hit, &path.ray, lambda);
                if le != Spectrum::ZERO {
                    l += path.beta * le * path.emission_weight(tracer, Some(&hit));
                }
            }
            if path.bounces >= self.max_depth {
                break;
            }
            let sp = ShadingPoint::new(&hit, path.ray.dir, tracer.scene, lambda);
            // Next-event estimation, MIS-weighted.
            if !sp.material.is_specular() {
                l += path.beta * sample_one_light(&sp, true, self.lights, tracer, sampler);
            }
            // BSDF sampling for the next segment, then Russian roulette.
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
    fn furnace_truncated_by_max_depth() {
        // Depth 2: Le (1 + a + a^2).
        expect_mean(
            "path",
            &[("max-depth", "2")],
            &furnace_sphere(0.5, 1.0),
            1.75,
            8000,
        );
    }

    #[test]
    fn inside_an_analytic_emitting_sphere_radiance_is_le_over_one_minus_a() {
        // pbrt-v4's furnace, written with a sphere whose normals are flipped; the unbiased
        // tracers reach Le / (1 - a), whitted Le (1 + a).
        for (a, le) in [(0.5, 1.0), (0.8, 0.5)] {
            let scene = furnace_emitting_sphere(a, le);
            expect_mean("path", &[], &scene, le / (1.0 - a), 8000);
            expect_mean("russian-roulette", &[], &scene, le / (1.0 - a), 8000);
            expect_mean("whitted", &[], &scene, le * (1.0 + a), 4000);
        }
    }

    #[test]
    fn paths_end_inside_a_closed_mirror() {
        // Unlimited depth and a throughput that never drops: Russian roulette must still end
        // every path (a regression: this used to loop forever).
        let (mean, _) = estimate("path", &[], &inside_a_mirror(), 2000);
        assert_eq!(mean, 0.0);
    }

    #[test]
    fn a_glass_ball_in_the_furnace_is_invisible() {
        // Looking at the ball: radiance through it equals the radiance everywhere.
        expect_mean("path", &[], &furnace_with_glass(0.5, 1.0), 2.0, 20000);
    }

    #[test]
    fn floor_under_a_sphere_light_and_one_sided_emission() {
        // Radiance a L (r/d)^2 = 0.5 * 4 * (0.5/2)^2 = 0.125 below a spherical light.
        expect_mean(
            "path",
            &[],
            &floor_under_sphere_light(0.5, 4.0, 0.5, 2.0),
            0.125,
            4000,
        );
        // A one-sided light facing away from the floor lights nothing, and its back is black.
        let (mean, _) = estimate("path", &[], &floor_under_light_facing_away(), 2000);
        assert_eq!(mean, 0.0);
    }
}
