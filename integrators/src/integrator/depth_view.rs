//! `depth`: debug view of the distance to the first hit divided by the diagonal of the scene
//! bounds (so 1 is the scene's size), grey. Misses are black. Not radiance.

use crate::integrator::{RayIntegrator, Tracer};
use crate::registry::{IntegratorEntry, MediaSupport, Params, SpectralSupport};
use crate::spectrum::Wavelengths;
use crate::Spectrum;
use crate::{Ray, Sampler};

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "depth",
    summary: "debug view: distance to the first hit / scene bounds diagonal, as grey",
    params: &[],
    build: |_: &Params| Box::new(DepthView),
    analytic: None,
    media: MediaSupport::None,
    spectral: SpectralSupport::Spectrum,
};

struct DepthView;

impl RayIntegrator for DepthView {
    fn radiance(
        &self,
        ray: &Ray,
        tracer: &mut Tracer,
        _sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        // A view of the scene, not light: RGB in either mode.
        *lambda = Wavelengths::Rgb;
        let Some(hit) = tracer.camera(ray) else {
            return Spectrum::ZERO;
        };
        let (lo, hi) = tracer.scene.bounds();
        let diagonal = (hi - lo).length().max(f32::MIN_POSITIVE);
        Spectrum::splat(hit.t / diagonal)
    }
}
