//! `direct`: direct illumination by light sampling, BSDF sampling, or both combined by
//! multiple importance sampling (Mitsuba 3's `direct`; the three images of Veach's MIS figure,
//! thesis fig. 9.2).
//!
//! **Estimates** the emitted radiance seen along the camera ray plus the radiance reflected
//! once towards it at the first surface: `Le + integral of f Le cos`, light reaching the
//! surface straight from an emitter (through no other surface). At the first hit it takes
//! `emitter-samples` light samples (a light chosen as `light-selection` says, a point on it) and
//! `bsdf-samples` BSDF samples whose rays look for an emitter; each sample of a strategy is
//! weighted by the power heuristic over the two strategies' densities, each scaled by its
//! share of the samples (Veach's multi-sample model), so 0 samples of one strategy gives the
//! other alone: `bsdf-samples=0` is light sampling, `emitter-samples=0` BSDF sampling. Delta
//! lights are reached by light samples only, mirror and glass lobes by BSDF samples only
//! (each with full weight): with one strategy turned off they go dark, as in Mitsuba.
//!
//! **Parameters**: `emitter-samples` (default 1), `bsdf-samples` (default 1),
//! `light-selection` (`scene`, the default, `uniform`, `power` or `bvh`).
//! **Bias**: none for direct illumination; it leaves out all indirect light by design.

use crate::integrator::{emitted_at, escaped, Demand, RayIntegrator, ShadingPoint, Tracer};
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, ParamKind, ParamSpec, Params, SpectralSupport,
    LIGHT_SELECTION,
};
use crate::sampling::power_heuristic;
use crate::spectrum::Wavelengths;
use crate::Spectrum;
use crate::{Ray, Sampler};

const SAMPLES: ParamSpec = ParamSpec {
    name: "emitter-samples",
    kind: ParamKind::Int,
    default: 1.0,
    min: 0.0,
    max: 1024.0,
    doc: "light samples at the first hit",
};

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "direct",
    summary: "direct illumination: light and BSDF samples combined by MIS (power heuristic); either alone with 0 of the other",
    params: &[
        SAMPLES,
        SAMPLES
            .with_name("bsdf-samples")
            .with_doc("BSDF samples at the first hit"),
        LIGHT_SELECTION,
    ],
    build: |p: &Params| {
        Box::new(Direct {
            emitter_samples: p.get_u32("emitter-samples"),
            bsdf_samples: p.get_u32("bsdf-samples"),
            lights: p.get_light_selection(),
        })
    },
    analytic: Some(Analytic {
        params: &[],
        // Le and one bounce: 1 + 0.5.
        furnace: expect(1.5, 40, 500),
        point_in_sphere: expect(0.5, 40, 500),
        sphere_under_sky: expect(1.2, 40, 500),
    }),
    media: MediaSupport::None,
    spectral: SpectralSupport::PerSample,
};

struct Direct {
    emitter_samples: u32,
    bsdf_samples: u32,
    /// How light samples pick a light (`None`: the scene's choice).
    lights: Option<crate::light::LightSelection>,
}

impl Direct {
    /// Each strategy's share of the samples (the `n_i / N` of the multi-sample power
    /// heuristic).
    fn shares(&self) -> (f32, f32) {
        let total = (self.emitter_samples + self.bsdf_samples).max(1) as f32;
        (
            self.emitter_samples as f32 / total,
            self.bsdf_samples as f32 / total,
        )
    }
}

impl RayIntegrator for Direct {
    fn radiance(
        &self,
        camera_ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        // Emission seen by the camera.
        let Some(hit) = tracer.camera(camera_ray) else {
            return escaped(tracer.scene, camera_ray, lambda);
        };
        let mut l = emitted_at(tracer.scene, &hit, camera_ray, lambda);
        let sp = ShadingPoint::new(&hit, camera_ray.dir, tracer.scene, lambda);
        let (share_light, share_bsdf) = self.shares();
        let lights = tracer.scene.lights();
        let ctx = sp.light_context();
        // Light samples: a light as `light-selection` says, a point on it, one shadow ray
        // each.
        if !sp.material.is_specular() {
            for _ in 0..self.emitter_samples {
                let (u_light, u) = (sampler.next_1d(), sampler.next_2d());
                let Some((index, pmf)) = lights.sample_for(self.lights, &ctx, u_light) else {
                    continue;
                };
                let Some((ls, f, cos)) = sp.connect_light(index, u, tracer) else {
                    continue;
                };
                let light_pdf = pmf * ls.pdf;
                let weight = if ls.delta {
                    1.0
                } else {
                    let bsdf_pdf = sp.material.pdf(sp.wo, sp.frame.to_local(ls.wi));
                    power_heuristic(light_pdf * share_light, bsdf_pdf * share_bsdf)
                };
                l += f * ls.radiance * (cos * weight / (light_pdf * self.emitter_samples as f32));
            }
        }
        // BSDF samples: each ray counts the emitter it reaches (or the sky it escapes to).
        for _ in 0..self.bsdf_samples {
            let u_lobe = sampler.next_1d();
            let Some(s) = sp.sample(
                u_lobe,
                sampler.next_2d(),
                crate::bsdf::TransportMode::Radiance,
            ) else {
                continue;
            };
            let ray = sp.hit.spawn_ray(s.wi);
            let next = tracer.extend(&ray);
            let (le, light) = match &next {
                Some(h) => (emitted_at(tracer.scene, h, &ray, lambda), h.light),
                None => (escaped(tracer.scene, &ray, lambda), lights.environment()),
            };
            let Some(index) = light.filter(|_| le != Spectrum::ZERO) else {
                continue;
            };
            let weight = if s.bsdf.specular {
                1.0
            } else {
                let q = next.as_ref().map_or(sp.hit.p, |h| h.p);
                let light_pdf = lights.pmf_for(self.lights, &ctx, index)
                    * lights.get(index).pdf_li(sp.hit.p, ray.dir, q);
                power_heuristic(s.bsdf.pdf * share_bsdf, light_pdf * share_light)
            };
            l += s.weight * le * (weight / self.bsdf_samples as f32);
        }
        l
    }

    fn demand(&self) -> Demand {
        Demand {
            rays_per_sample: 1.0 + (self.emitter_samples + self.bsdf_samples) as f64,
            memory: 0,
            ..Demand::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::testing::*;

    #[test]
    fn each_strategy_alone_and_any_mix_give_the_same_direct_light() {
        // A ball of albedo 0.6 under a sky of 2 (1.2), and a floor under a sphere light
        // (0.125): light sampling alone, BSDF sampling alone, and uneven mixes.
        for params in [
            [("emitter-samples", "1"), ("bsdf-samples", "0")],
            [("emitter-samples", "0"), ("bsdf-samples", "1")],
            [("emitter-samples", "3"), ("bsdf-samples", "1")],
            [("emitter-samples", "1"), ("bsdf-samples", "4")],
        ] {
            expect_mean("direct", &params, &sphere_under_sky(0.6, 2.0), 1.2, 20000);
            expect_mean(
                "direct",
                &params,
                &floor_under_sphere_light(0.5, 4.0, 0.5, 2.0),
                0.125,
                150000,
            );
        }
    }

    #[test]
    fn a_point_light_needs_light_samples() {
        // A delta light: found by light samples only.
        expect_mean(
            "direct",
            &[("bsdf-samples", "0")],
            &point_in_sphere(0.5),
            0.5,
            2000,
        );
        let (mean, _) = estimate(
            "direct",
            &[("emitter-samples", "0")],
            &point_in_sphere(0.5),
            500,
        );
        assert_eq!(mean, 0.0);
    }

    #[test]
    fn no_indirect_light_in_the_furnace() {
        // Le + a Le, never a^2 Le.
        expect_mean(
            "direct",
            &[("emitter-samples", "2"), ("bsdf-samples", "2")],
            &furnace_sphere(0.5, 1.0),
            1.5,
            4000,
        );
    }
}
