//! `russian-roulette`: what the report wished for (its section 4): one continuation ray per
//! hit instead of a branching tree, ended at random instead of at a fixed depth.
//!
//! **Estimates** the full rendering equation. At every non-specular hit: direct light from one
//! light chosen in proportion to power (one shadow ray), then one BSDF-sampled continuation
//! ray. Emitters reached by continuation rays count only after specular bounces (direct light
//! already covers them), so there is no multiple importance sampling: compare with `path`.
//! From `rr-depth` scattering events on, the path survives with probability
//! `min(0.95, max(throughput))` and its throughput is divided by that probability.
//!
//! **Parameters**: `rr-depth` (default 3), `max-depth` (default unlimited).
//! **Bias**: none with unlimited `max-depth` (Russian roulette is unbiased); truncation
//! otherwise.

use crate::integrator::{
    continue_path, emitted_at, escaped, russian_roulette, sample_one_light, RayIntegrator,
    ShadingPoint, Tracer,
};
use crate::registry::{expect, Analytic, IntegratorEntry, Params, MAX_DEPTH, RR_DEPTH};
use crate::{Ray, Rgb, Sampler};

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "russian-roulette",
    summary:
        "one continuation ray per hit, direct light by one shadow ray, Russian roulette (no MIS)",
    params: &[RR_DEPTH, MAX_DEPTH],
    build: |p: &Params| {
        Box::new(RussianRouletteTracer {
            rr_depth: p.get_u32("rr-depth"),
            max_depth: p.get_depth("max-depth"),
        })
    },
    analytic: Some(Analytic {
        params: &[],
        furnace: expect(2.0, 50, 1000),
        point_in_sphere: expect(1.0, 40, 500),
        sphere_under_sky: expect(1.2, 40, 500),
    }),
};

struct RussianRouletteTracer {
    rr_depth: u32,
    max_depth: u32,
}

impl RayIntegrator for RussianRouletteTracer {
    fn radiance(&self, camera_ray: &Ray, tracer: &mut Tracer, sampler: &mut Sampler) -> Rgb {
        let mut l = Rgb::ZERO;
        let mut beta = Rgb::ONE;
        let mut ray = *camera_ray;
        let mut count_emission = true;
        let mut bounces = 0u32;
        // Product of eta^2 over the path's refractions.
        let mut eta_scale = 1.0f32;
        loop {
            // Trace: the camera ray, then continuation rays.
            let hit = if bounces == 0 {
                tracer.camera(&ray)
            } else {
                tracer.extend(&ray)
            };
            let Some(hit) = hit else {
                if count_emission {
                    l += beta * escaped(tracer.scene, &ray);
                }
                break;
            };
            // Emission, when direct-light sampling could not have found it.
            if count_emission {
                l += beta * emitted_at(tracer.scene, &hit, &ray);
            }
            if bounces >= self.max_depth {
                break;
            }
            let sp = ShadingPoint::new(&hit, ray.dir, tracer.scene);
            // Direct light: one light, one shadow ray.
            if !sp.material.is_specular() {
                l += beta * sample_one_light(&sp, false, tracer, sampler);
            }
            // Continuation: one BSDF-sampled ray.
            let Some((next, bs)) = continue_path(&sp, &mut beta, sampler) else {
                break;
            };
            eta_scale *= bs.eta * bs.eta;
            count_emission = bs.specular;
            ray = next;
            bounces += 1;
            // Russian roulette on the throughput (without refraction's compression of
            // radiance).
            if bounces >= self.rr_depth {
                match russian_roulette(beta * eta_scale, sampler) {
                    Some(p) => beta /= p,
                    None => break,
                }
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
