//! `direct`: emitted light plus one light sample at the first hit (next-event estimation
//! only): the example integrator of docs/new-integrator.md, which shows this file whole.
//!
//! **Estimates** the light reaching the camera after at most one scattering event: emission
//! seen directly, and direct illumination by one light chosen in proportion to power.
//! **Parameters**: none. **Bias**: truncated at depth 1 (no indirect light).

use raylab_integrators::integrator::{
    emitted_at, escaped, sample_one_light, RayIntegrator, ShadingPoint, Tracer,
};
use raylab_integrators::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, Params, SpectralSupport,
};
use raylab_integrators::spectrum::Wavelengths;
use raylab_integrators::{Ray, Sampler, Spectrum};

/// The registry entry: name, summary, parameters, constructor. In the crate, one line in
/// `REGISTRY` (integrators/src/integrator/registry.rs) makes it a `-i direct`.
pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "direct",
    summary: "emission plus one light sample at the first hit (no indirect light)",
    params: &[],
    build: |_: &Params| Box::new(Direct),
    // What it gives on the testing kit's analytic scenes, which the suite checks for every
    // registry entry: Le (1 + a) in the furnace, the point light's direct half, and the sky
    // seen in one bounce.
    analytic: Some(Analytic {
        params: &[],
        furnace: expect(1.5, 40, 100),
        point_in_sphere: expect(0.5, 10, 10),
        sphere_under_sky: expect(1.2, 40, 400),
    }),
    // Surfaces only: a scene with participating media is refused before rendering.
    media: MediaSupport::None,
    spectral: SpectralSupport::PerSample,
};

struct Direct;

impl RayIntegrator for Direct {
    fn radiance(
        &self,
        ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        // The first hit; a ray that escapes sees the environment. Light is carried at the
        // sample's wavelengths `lambda` (RGB's channels unless rendering spectrally).
        let Some(hit) = tracer.camera(ray) else {
            return escaped(tracer.scene, ray, lambda);
        };
        // Emission seen directly.
        let mut l = emitted_at(tracer.scene, &hit, ray, lambda);
        // One light sample, if the surface can reflect it (perfect mirrors and glass cannot).
        let sp = ShadingPoint::new(&hit, ray.dir, tracer.scene, lambda);
        if !sp.material.is_specular() {
            l += sample_one_light(&sp, false, None, tracer, sampler);
        }
        l
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use raylab_integrators::testing::{expect_mean_of, furnace_sphere, point_in_sphere};

    fn direct() -> Box<dyn raylab_integrators::Integrator> {
        (ENTRY.build)(&ENTRY.resolve(&[]).unwrap())
    }

    #[test]
    fn docs_new_integrator_md_shows_this_file_whole() {
        let doc = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/new-integrator.md"),
        )
        .unwrap();
        assert!(doc.contains(include_str!("new_integrator.rs")));
    }

    #[test]
    fn furnace_gives_emission_plus_one_bounce() {
        // Inside a sphere of albedo a emitting Le: Le (1 + a) up to depth 1.
        expect_mean_of(direct().as_mut(), &furnace_sphere(0.5, 1.0), 1.5, 20000);
    }

    #[test]
    fn point_light_in_a_sphere_is_all_direct_light() {
        // The analytic scene's radiance is 1, all of it from one bounce of the point light's.
        expect_mean_of(direct().as_mut(), &point_in_sphere(0.5), 0.5, 20000);
    }
}
