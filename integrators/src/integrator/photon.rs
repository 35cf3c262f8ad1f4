//! `photon`: photon mapping with a caustic map, a global map and final gathering (Jensen,
//! "Global Illumination Using Photon Maps", 1996), the method the report's sections 1.1 and
//! 2.1 describe.
//!
//! **Estimates** the rendering equation split by path type. Before the first pass two maps are
//! traced from the lights: the caustic map keeps photons that reached a non-specular surface
//! through mirrors and glass only (`L S+ D`), the global map keeps every non-specular landing.
//! A camera path follows specular bounces to its first non-specular point `x` and adds:
//! * emission seen directly or through specular bounces;
//! * direct light by next-event estimation (one light sample);
//! * caustics, by a density estimate in the caustic map at `x`;
//! * the rest of the indirect light by final gathering: `gather` BSDF-sampled rays from `x`,
//!   through any specular bounces, to a non-specular point `y` where the global map estimates
//!   the radiance leaving `y` (emission and caustic paths are skipped there: the two terms
//!   above count them). With `gather = 0`, the global map is read at `x` directly instead
//!   (fast, blotchy).
//!
//! The maps are built once, from the seed alone, so every pass reuses them.
//!
//! **In participating media** (Jensen and Christensen's volume photon map, 1998): photons
//! walk media by delta tracking and the global pass also stores a photon at every real
//! scattering event in a medium (a volume map). A camera or gather path that scatters in a
//! medium before reaching a surface stops there: direct light by a light sample with the
//! transmittance to the light, and everything else (volumetric caustics included) from the
//! volume map, `sum phase Phi / (sigma_s 4/3 pi r^3)` over the photons within the global
//! radius; no final gathering from a point in a medium. Media that emit are refused.
//!
//! **Parameters**: `photons` (global map, default 200000), `caustic-photons` (emitted for the
//! caustic map, default 1000000), `radius` (caustic gather radius; 0 = 0.5% of the scene's
//! bounding-box diagonal), `global-radius` (0 = 1% of it), `gather` (final-gather rays,
//! default 8), `max-depth` (default unlimited).
//! **Bias**: density estimation blurs light over the gather radii and does not vanish with
//! more passes (use `sppm` for a consistent estimate); in media, the volume kernel also
//! reaches past a medium's boundary, where no photon lands (darker within a radius of it);
//! truncation with a finite `max-depth`.

use crate::integrator::media_walk::{direct_light, Scatterer};
use crate::integrator::{
    continue_path, sample_one_light, Demand, RayIntegrator, ShadingPoint, Tracer,
};
use crate::photon_map::{
    auto_radius, land, photon_map_bytes, split_by_place, trace_photons, Keep, Photon, PhotonMap,
    PhotonPass, Spot,
};
use crate::registry::{
    IntegratorEntry, MediaSupport, ParamKind, ParamSpec, Params, SpectralSupport, GATHER_RADIUS,
    MAX_DEPTH, PHOTONS,
};
use crate::spectrum::Wavelengths;
use crate::{PassContext, Spectrum};
use crate::{Ray, RayCounters, Sampler};

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "photon",
    summary: "photon mapping: caustic map + global map with final gathering (Jensen 1996); biased",
    params: &[
        PHOTONS
            .with_min(0.0)
            .with_default(200_000.0)
            .with_doc("photons emitted for the global map"),
        PHOTONS
            .with_name("caustic-photons")
            .with_min(0.0)
            .with_default(1_000_000.0)
            .with_doc("photons emitted for the caustic map (only L S+ D landings are kept)"),
        GATHER_RADIUS
            .with_doc("caustic gather radius, scene units (0 = 0.5% of the bounding-box diagonal)"),
        GATHER_RADIUS.with_name("global-radius").with_doc(
            "global-map gather radius, scene units (0 = 1% of the bounding-box diagonal)",
        ),
        ParamSpec {
            name: "gather",
            kind: ParamKind::Int,
            default: 8.0,
            min: 0.0,
            max: 1e5,
            doc: "final-gather rays per camera sample (0 = read the global map directly)",
        },
        MAX_DEPTH.with_doc("scattering events per path, camera and photon sides together"),
    ],
    build: |p: &Params| {
        Box::new(PhotonMapping {
            photons: p.get_u32("photons"),
            caustic_photons: p.get_u32("caustic-photons"),
            radius: p.get("radius") as f32,
            global_radius: p.get("global-radius") as f32,
            gather: p.get_u32("gather"),
            max_depth: p.get_depth("max-depth"),
            maps: None,
        })
    },
    analytic: None,
    media: MediaSupport::Scattering,
    spectral: SpectralSupport::PerPass,
};

/// Specular bounces a camera or gather path follows before Russian roulette may end it.
const RR_DEPTH: u32 = 3;

struct PhotonMapping {
    photons: u32,
    caustic_photons: u32,
    radius: f32,
    global_radius: f32,
    gather: u32,
    max_depth: u32,
    maps: Option<Maps>,
}

struct Maps {
    caustic: PhotonMap,
    global: PhotonMap,
    /// The global map's landings in media.
    volume: PhotonMap,
    /// The wavelengths its photons carry, which the camera paths that gather them take.
    lambda: Wavelengths,
}

impl RayIntegrator for PhotonMapping {
    fn demand(&self) -> Demand {
        Demand {
            rays_per_sample: 1.0,
            memory: photon_map_bytes(self.photons as u64 + self.caustic_photons as u64),
            ..Demand::default()
        }
    }

    fn prepare_pass(&mut self, cx: &PassContext) -> RayCounters {
        let PassContext {
            scene,
            camera,
            seed,
            stop,
            pass,
            lambda,
            ..
        } = *cx;
        // Both maps, once, from the seed alone (streams 0 and 1); in spectral mode anew each
        // pass at the pass's wavelengths (streams 2p and 2p + 1), as maps made at three
        // wavelengths would never see the others.
        let spectral = lambda.is_spectral();
        if self
            .maps
            .as_ref()
            .is_some_and(|m| !spectral && !m.lambda.is_spectral())
        {
            return RayCounters::default();
        }
        let first_stream = if spectral { 2 * pass as u64 } else { 0 };
        let pick = |r: f32, fraction: f32| {
            if r > 0.0 {
                r
            } else {
                auto_radius(scene, fraction)
            }
        };
        let max_bounces = self.max_depth.saturating_sub(1);
        let pass = |count, keep, stream| PhotonPass {
            count,
            keep,
            max_bounces,
            seed,
            stream: first_stream + stream,
            eye: camera.eye,
            lambda,
        };
        let (caustic, mut rays) =
            trace_photons(scene, &pass(self.caustic_photons, Keep::Caustic, 0), stop);
        let (global, global_rays) = trace_photons(scene, &pass(self.photons, Keep::All, 1), stop);
        rays.add(&global_rays);
        if stop.requested() {
            // Cut short: not the maps of this seed, and never to be reused.
            return rays;
        }
        let global_radius = pick(self.global_radius, 0.01);
        let (global, volume) = split_by_place(global);
        self.maps = Some(Maps {
            caustic: PhotonMap::build(caustic, pick(self.radius, 0.005)),
            global: PhotonMap::build(global, global_radius),
            volume: PhotonMap::build(volume, global_radius),
            lambda,
        });
        rays
    }

    fn radiance(
        &self,
        camera_ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        let Some(maps) = &self.maps else {
            return Spectrum::ZERO;
        };
        *lambda = maps.lambda;
        let mut l = Spectrum::ZERO;
        // Follow the camera path through specular bounces, collecting emission.
        let Some(x) = land(
            *camera_ray,
            true,
            self.max_depth,
            RR_DEPTH,
            Some(&mut l),
            tracer,
            sampler,
            lambda,
        ) else {
            return l;
        };
        let depth = x.bounces;
        if depth >= self.max_depth {
            return l;
        }
        let scene = tracer.scene;
        // Photons that landed after b bounces make paths of depth depth + 1 + b.
        let photon_budget = self.max_depth.saturating_sub(depth + 1);
        let hit = match x.at {
            Spot::Surface(hit) => hit,
            Spot::Medium(p) => {
                // In a medium: direct light by next-event estimation, the rest (caustics
                // included) from the volume map, read directly.
                let (wo, medium) = (-x.ray.dir, x.ray.medium);
                l += x.beta
                    * direct_light(
                        &Scatterer::Medium { p, wo, medium },
                        tracer,
                        lambda,
                        sampler,
                    );
                l += x.beta
                    * maps.volume.in_scattered(scene, medium, p, wo, |ph| {
                        ph.bounces >= 1 && (ph.bounces as u32) <= photon_budget
                    });
                return l;
            }
        };
        let sp = ShadingPoint::new(&hit, x.ray.dir, scene, lambda);
        // Direct light by next-event estimation.
        l += x.beta * direct(&sp, tracer, sampler);
        // Caustics from the caustic map: photons that landed after b >= 1 specular bounces.
        l += x.beta
            * maps
                .caustic
                .radiance(&sp, |p| (p.bounces as u32) <= photon_budget);
        if photon_budget == 0 {
            return l;
        }
        if self.gather == 0 {
            // The global map at x, without what the two terms above already count.
            l += x.beta
                * maps.global.radiance(&sp, |p| {
                    p.bounces >= 1 && !p.caustic && (p.bounces as u32) <= photon_budget
                });
            return l;
        }
        // Final gathering: the global maps' estimate of the light leaving the first
        // non-specular point each gather ray reaches, on a surface or in a medium.
        let mut gathered = Spectrum::ZERO;
        for _ in 0..self.gather {
            let mut weight = Spectrum::ONE;
            let Some((ray, _)) = continue_path(&sp, &mut weight, sampler) else {
                continue;
            };
            let budget = self.max_depth.saturating_sub(depth + 2);
            let Some(y) = land(ray, false, budget, RR_DEPTH, None, tracer, sampler, lambda) else {
                continue;
            };
            // Reaching y took `y.bounces` specular bounces: y's photons may have scattered
            // max-depth - (depth + 1 + y.bounces + 1) times.
            let Some(photon_budget) = budget.checked_sub(y.bounces) else {
                continue;
            };
            let accept = |p: &Photon| (p.bounces as u32) <= photon_budget;
            gathered += weight
                * y.beta
                * match y.at {
                    Spot::Surface(hit) => {
                        let y_sp = ShadingPoint::new(&hit, y.ray.dir, scene, lambda);
                        maps.global.radiance(&y_sp, accept)
                    }
                    Spot::Medium(p) => {
                        maps.volume
                            .in_scattered(scene, y.ray.medium, p, -y.ray.dir, accept)
                    }
                };
        }
        l + x.beta * gathered / self.gather as f32
    }
}

/// Direct light at a surface by one light sample (through media where the scene has them).
pub(super) fn direct(sp: &ShadingPoint, tracer: &mut Tracer, sampler: &mut Sampler) -> Spectrum {
    if tracer.scene.has_media() {
        direct_light(&Scatterer::Surface(sp), tracer, &sp.lambda, sampler)
    } else {
        sample_one_light(sp, false, None, tracer, sampler)
    }
}

#[cfg(test)]
mod tests {
    use crate::testing::{
        estimate, floor_under_light_facing_away, furnace_sphere, furnace_with_glass,
        inside_a_mirror, point_in_sphere,
    };

    /// The photon maps' blur is a bias that does not average out, so these tests allow 2%.
    fn expect_close(params: &[(&str, &str)], scene: &crate::testing::TestScene, expected: f64) {
        let mut given = vec![("caustic-photons", "100000")];
        given.extend_from_slice(params);
        let (mean, se) = estimate("photon", &given, scene, 4000);
        assert!(
            (mean - expected).abs() < 0.02 * expected + 4.0 * se,
            "photon {params:?}: {mean:.4} +- {se:.4}, expected {expected}"
        );
    }

    #[test]
    fn furnace_with_and_without_final_gathering() {
        let scene = furnace_sphere(0.5, 1.0);
        expect_close(&[("photons", "100000")], &scene, 2.0);
        expect_close(&[("photons", "100000"), ("gather", "0")], &scene, 2.0);
        // Depth 2: Le (1 + a + a^2).
        expect_close(&[("photons", "100000"), ("max-depth", "2")], &scene, 1.75);
        expect_close(
            &[("photons", "100000"), ("max-depth", "2"), ("gather", "0")],
            &scene,
            1.75,
        );
    }

    #[test]
    fn point_light_and_glass() {
        expect_close(&[("photons", "100000")], &point_in_sphere(0.5), 1.0);
        expect_close(&[("photons", "100000")], &furnace_with_glass(0.5, 1.0), 2.0);
    }

    #[test]
    fn dark_scenes_stay_black() {
        assert_eq!(estimate("photon", &[], &inside_a_mirror(), 500).0, 0.0);
        assert_eq!(
            estimate("photon", &[], &floor_under_light_facing_away(), 500).0,
            0.0
        );
    }
}
