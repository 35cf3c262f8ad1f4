//! `whitted`: Whitted ray tracing (Whitted 1980; the report's section 1.2).
//!
//! **Estimates** emitted radiance seen directly or through chains of perfect mirror
//! reflections and glass refractions, plus direct illumination at the first non-specular
//! surface: `L = Le + sum over lights of f * Li * cos` with one shadow-ray sample per light
//! (area lights are sampled, so shadows are soft and converge with spp). At glass both the
//! reflected and the refracted ray are traced, weighted by Fresnel; every Dirac lobe is
//! followed (a plastic's smooth coating too, beside the direct light on its base).
//! Glossy materials (rough metal, rough glass and plastic, Phong) are lit directly, as the
//! report lit Phong: their highlights of light sources appear, their reflections of other
//! surfaces do not.
//!
//! **Parameters**: `max-depth` (default 5): scattering events allowed on a path (see the
//! depth convention in the crate docs), specular ones included.
//!
//! **Bias**: no indirect light at non-specular surfaces (no colour bleeding); the result is
//! the truncated series `Le + direct`. Unbiased for that truncated quantity.

use crate::integrator::{emitted_at, escaped, specular_lobes, RayIntegrator, ShadingPoint, Tracer};
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, Params, SpectralSupport, MAX_DEPTH,
};
use crate::spectrum::Wavelengths;
use crate::Spectrum;
use crate::{Hit, Ray, Sampler};

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "whitted",
    summary: "Whitted ray tracing: direct light with shadow rays, mirror and glass recursion",
    params: &[MAX_DEPTH.with_default(5.0).with_max(32.0).with_doc(
        "scattering events per path, specular ones included (glass doubles the rays per level)",
    )],
    build: |p: &Params| {
        Box::new(Whitted {
            max_depth: p.get_depth("max-depth"),
        })
    },
    analytic: Some(Analytic {
        params: &[],
        furnace: expect(1.5, 40, 100),
        point_in_sphere: expect(0.5, 10, 10),
        sphere_under_sky: expect(1.2, 40, 400),
    }),
    media: MediaSupport::None,
    spectral: SpectralSupport::PerSample,
};

struct Whitted {
    max_depth: u32,
}

impl Whitted {
    /// Radiance arriving along `ray`, which hit `hit` after `bounces` scattering events.
    fn shade(
        &self,
        ray: &Ray,
        hit: &Hit,
        bounces: u32,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        // Emission: always counted, since light is never reached by sampling a BSDF here.
        let mut l = emitted_at(tracer.scene, hit, ray, lambda);
        if bounces >= self.max_depth {
            return l;
        }
        let sp = ShadingPoint::new(hit, ray.dir, tracer.scene, lambda);
        let material = &sp.material;

        if material.has_delta_lobe() {
            // Specular recursion: follow every delta lobe (mirror; glass reflection and
            // refraction; a plastic's coating).
            for (wi, weight) in specular_lobes(material, sp.wo).into_iter().flatten() {
                let next = hit.spawn_ray(sp.frame.to_world(wi));
                l += weight
                    * match tracer.extend(&next) {
                        Some(h) => self.shade(&next, &h, bounces + 1, tracer, sampler, lambda),
                        None => escaped(tracer.scene, &next, lambda),
                    };
            }
            if material.is_specular() {
                return l;
            }
        }

        // Direct light: one shadow ray to every light.
        for index in 0..tracer.scene.lights().len() as u32 {
            // A flat or convex emitter cannot light itself (no sample drawn for it).
            if !sp.can_receive(index, tracer.scene.lights()) {
                continue;
            }
            if let Some((ls, f, cos)) = sp.connect_light(index, sampler.next_2d(), tracer) {
                l += f * ls.radiance * (cos / ls.pdf);
            }
        }
        l
    }
}

impl RayIntegrator for Whitted {
    fn radiance(
        &self,
        ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        match tracer.camera(ray) {
            Some(hit) => self.shade(ray, &hit, 0, tracer, sampler, lambda),
            None => escaped(tracer.scene, ray, lambda),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::testing::*;

    #[test]
    fn furnace_gives_emission_plus_one_bounce() {
        // Le + a * Le: direct light only at the first diffuse hit.
        for (a, le) in [(0.5, 1.0), (0.8, 1.0)] {
            let scene = furnace_sphere(a, le);
            expect_mean("whitted", &[], &scene, le * (1.0 + a), 4000);
        }
    }

    #[test]
    fn max_depth_zero_sees_only_emitters() {
        let scene = furnace_sphere(0.5, 1.0);
        expect_mean("whitted", &[("max-depth", "0")], &scene, 1.0, 500);
    }

    #[test]
    fn floor_under_a_sphere_light_and_one_sided_emission() {
        // Radiance a L (r/d)^2 = 0.5 * 4 * (0.5/2)^2 = 0.125 below a spherical light.
        expect_mean(
            "whitted",
            &[],
            &floor_under_sphere_light(0.5, 4.0, 0.5, 2.0),
            0.125,
            4000,
        );
        // A one-sided light facing away from the floor lights nothing, and its back is black.
        let (mean, _) = estimate("whitted", &[], &floor_under_light_facing_away(), 2000);
        assert_eq!(mean, 0.0);
    }
}
