//! `sppm`: stochastic progressive photon mapping, in Knaus and Zwicker's probabilistic form
//! ("Progressive Photon Mapping: A Probabilistic Approach", 2011).
//!
//! **Estimates** the full rendering equation, consistently: the error goes to zero as passes
//! accumulate. Every pass traces a new set of photons (landings after at least one bounce)
//! and takes one camera sample per pixel. The camera path follows specular bounces to its
//! first non-specular surface, where it adds direct light by next-event estimation and the
//! photons within the pass's radius `r_i` (a density estimate). Radii shrink as
//! `r_{i+1}^2 = r_i^2 (i + alpha) / (i + 1)`, the global-radius form of Hachisuka and Jensen's
//! SPPM update: every pass is an independent photon-mapping image whose bias shrinks, and the
//! image is their plain mean, so passes, `--time`, Ctrl-C, checkpoints and thread counts
//! behave exactly as for every other integrator. (pbrt-v4 shrinks a radius per pixel instead,
//! which adapts faster but keeps state per pixel.)
//!
//! In participating media, photons walk media by delta tracking and are also stored where
//! they scatter in a medium; a camera path that scatters in a medium before reaching a
//! surface gathers there: direct light by a light sample through the media, the rest from
//! the photons in the medium within `r_i` (`sum phase Phi / (sigma_s 4/3 pi r_i^3)`, the
//! volume photon map's estimate), whose ball shrinks as `r_i^3 ~ i^(alpha - 1)` (the same
//! first radius), so that it is consistent at every `alpha`. Media that emit are refused.
//!
//! Caustics seen directly or through mirrors and glass (`L S+ D S* E`), which path tracing
//! finds only by hitting a light with a BSDF sample, come from photons and converge quickly.
//!
//! **Parameters**: `photons` per pass (default 100000), `radius` (first gather radius in scene
//! units; 0 = 1% of the scene's bounding-box diagonal), `alpha` (default 2/3), `max-depth`
//! (default unlimited), `photon-depth` (-1, the default: the camera and photon sides share
//! `max-depth`; else the bounces a photon makes before landing, counted apart from the
//! camera side, which `max-depth` then bounds alone: pbrt-v4's convention, `maxdepth - 1`),
//! `rr-depth` for the camera's specular chain (default 3).
//! **Bias**: a blur of radius `r_i` in pass `i`, vanishing as passes grow (consistent, not
//! unbiased; in media also a darkening within `r_i` of a medium's boundary, vanishing with
//! it); truncation with a finite `max-depth`.

use crate::integrator::media_walk::{direct_light, Scatterer};
use crate::integrator::photon::direct;
use crate::integrator::{Demand, RayIntegrator, ShadingPoint, Tracer};
use crate::photon_map::{
    auto_radius, land, photon_map_bytes, split_by_place, trace_photons, Keep, Photon, PhotonMap,
    PhotonPass, Spot,
};
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, ParamKind, ParamSpec, Params, SpectralSupport,
    GATHER_RADIUS, MAX_DEPTH, PHOTONS, RR_DEPTH,
};
use crate::spectrum::Wavelengths;
use crate::{PassContext, Spectrum};
use crate::{Ray, RayCounters, Sampler};

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "sppm",
    summary: "stochastic progressive photon mapping: photons per pass, shrinking radius, consistent; strong on caustics",
    params: &[
        PHOTONS,
        GATHER_RADIUS
            .with_doc("first gather radius, scene units (0 = 1% of the bounding-box diagonal)"),
        ParamSpec {
            name: "alpha",
            kind: ParamKind::Float,
            default: 2.0 / 3.0,
            min: 0.01,
            max: 1.0,
            doc: "radius reduction: r^2 shrinks by (i + alpha) / (i + 1) per pass",
        },
        MAX_DEPTH.with_doc("scattering events per path, camera and photon sides together (with photon-depth: the camera side's)"),
        ParamSpec {
            name: "photon-depth",
            kind: ParamKind::Int,
            default: -1.0,
            min: -1.0,
            max: 1e6,
            doc: "bounces of a photon before it lands, counted apart from the camera side (-1: shared with max-depth; pbrt-v4: maxdepth - 1)",
        },
        RR_DEPTH.with_doc("specular bounces of a camera path before Russian roulette starts"),
    ],
    build: |p: &Params| {
        Box::new(Sppm {
            photons: p.get_u32("photons"),
            radius: p.get("radius") as f32,
            alpha: p.get("alpha"),
            max_depth: p.get_depth("max-depth"),
            photon_depth: (p.get("photon-depth") >= 0.0).then(|| p.get_u32("photon-depth")),
            rr_depth: p.get_u32("rr-depth"),
            map: PhotonMap::default(),
            volume: PhotonMap::default(),
            lambda: Wavelengths::Rgb,
        })
    },
    analytic: Some(Analytic {
        params: &[("photons", "20000")],
        furnace: expect(2.0, 40, 500),
        point_in_sphere: expect(1.0, 40, 500),
        sphere_under_sky: None,
    }),
    media: MediaSupport::Scattering,
    spectral: SpectralSupport::PerPass,
};

struct Sppm {
    photons: u32,
    /// First radius; 0 = automatic.
    radius: f32,
    alpha: f64,
    max_depth: u32,
    /// Photon bounces counted apart from the camera side, if so.
    photon_depth: Option<u32>,
    rr_depth: u32,
    /// This pass's photons on surfaces, built for this pass's radius.
    map: PhotonMap,
    /// This pass's photons in media, likewise.
    volume: PhotonMap,
    /// The pass's wavelengths, which its photons and camera paths carry.
    lambda: Wavelengths,
}

/// `r_pass / r_0` for pass `pass` (0-based): `prod_{i=1}^{pass} (i + alpha) / (i + 1)`, square
/// rooted.
fn radius_scale(pass: u32, alpha: f64) -> f32 {
    let mut r2 = 1.0f64;
    for i in 1..=pass as u64 {
        r2 *= (i as f64 + alpha) / (i as f64 + 1.0);
    }
    r2.sqrt() as f32
}

impl RayIntegrator for Sppm {
    fn demand(&self) -> Demand {
        Demand {
            rays_per_sample: 1.0,
            memory: photon_map_bytes(self.photons as u64),
            ..Demand::default()
        }
    }

    fn prepare_pass(&mut self, cx: &PassContext) -> RayCounters {
        let PassContext {
            scene,
            camera,
            seed,
            pass,
            stop,
            lambda,
            ..
        } = *cx;
        self.lambda = lambda;
        // This pass's radius and photons (landings after one bounce or more).
        let r0 = if self.radius > 0.0 {
            self.radius
        } else {
            auto_radius(scene, 0.01)
        };
        let radius = r0 * radius_scale(pass, self.alpha);
        // A photon landing after b bounces, gathered after at least one camera-side
        // scattering, makes a path of depth >= b + 1.
        let max_bounces = self
            .photon_depth
            .unwrap_or(self.max_depth.saturating_sub(1));
        let photon_pass = PhotonPass {
            count: self.photons,
            keep: Keep::Indirect,
            max_bounces,
            seed,
            stream: pass as u64,
            eye: camera.eye,
            lambda,
        };
        let (photons, rays) = trace_photons(scene, &photon_pass, stop);
        if !stop.requested() {
            let (surface, volume) = split_by_place(photons);
            self.map = PhotonMap::build(surface, radius);
            // In media the ball's radius shrinks as `r_i^3 ~ i^(alpha - 1)`, the 3-D form of
            // the schedule, so that the volume estimate converges at every `alpha`.
            let volume_radius = r0 * radius_scale(pass, self.alpha).powf(2.0 / 3.0);
            self.volume = PhotonMap::build(volume, volume_radius);
        }
        rays
    }

    fn radiance(
        &self,
        camera_ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        *lambda = self.lambda;
        let mut l = Spectrum::ZERO;
        // Follow the camera path through specular bounces to its visible point, adding the
        // emission seen on the way (nothing else finds it).
        let Some(x) = land(
            *camera_ray,
            true,
            self.max_depth,
            self.rr_depth,
            Some(&mut l),
            tracer,
            sampler,
            lambda,
        ) else {
            return l;
        };
        if x.bounces >= self.max_depth {
            return l;
        }
        // A photon that landed after b bounces makes a path of depth x.bounces + 1 + b.
        let max_photon_bounces = self
            .photon_depth
            .unwrap_or(self.max_depth.saturating_sub(x.bounces + 1));
        let accept = |p: &Photon| (p.bounces as u32) <= max_photon_bounces;
        let hit = match x.at {
            Spot::Surface(hit) => hit,
            Spot::Medium(p) => {
                // In a medium: direct light by next-event estimation, the rest from the
                // photons that landed in the medium within the radius.
                let (wo, medium) = (-x.ray.dir, x.ray.medium);
                l += x.beta
                    * direct_light(
                        &Scatterer::Medium { p, wo, medium },
                        tracer,
                        lambda,
                        sampler,
                    );
                let scene = tracer.scene;
                l += x.beta * self.volume.in_scattered(scene, medium, p, wo, accept);
                return l;
            }
        };
        let sp = ShadingPoint::new(&hit, x.ray.dir, tracer.scene, lambda);
        // Direct light by next-event estimation (no BSDF sample looks for emitters here, so
        // no MIS) ...
        l += x.beta * direct(&sp, tracer, sampler);
        // ... and everything else from this pass's photons, within the depth limit.
        l += x.beta * self.map.radiance(&sp, accept);
        l
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{
        estimate_passes, expect_mean_passes, floor_under_light_facing_away, furnace_sphere,
        furnace_with_glass, inside_a_mirror,
    };

    #[test]
    fn radius_shrinks_as_knaus_and_zwicker_prescribe() {
        assert_eq!(radius_scale(0, 2.0 / 3.0), 1.0);
        // r_2^2 = r_1^2 (1 + 2/3) / 2.
        assert!((radius_scale(1, 2.0 / 3.0).powi(2) - 5.0 / 6.0).abs() < 1e-6);
        // Asymptotically r_n^2 ~ n^(alpha - 1): from pass 1000 to 8000, r^2 falls by 8^(-1/3).
        let ratio = (radius_scale(8000, 2.0 / 3.0) / radius_scale(1000, 2.0 / 3.0)).powi(2);
        assert!((ratio - 0.5).abs() < 0.01, "{ratio}");
    }

    /// With `photon-depth`, the photon side counts its bounces alone (pbrt-v4's SPPM): depth
    /// 1 on the camera side (emission and direct light: Le (1 + a)) and photons of up to two
    /// bounces (a^2 + a^3) make Le (1 + a + a^2 + a^3).
    #[test]
    fn furnace_with_the_photon_depth_apart() {
        expect_mean_passes(
            "sppm",
            &[
                ("photons", "20000"),
                ("max-depth", "1"),
                ("photon-depth", "2"),
            ],
            &furnace_sphere(0.5, 1.0),
            1.875,
            40,
            500,
        );
    }

    #[test]
    fn furnace_truncated_by_max_depth() {
        // Depth 2: Le (1 + a + a^2); the photons must respect the camera's depth too.
        expect_mean_passes(
            "sppm",
            &[("photons", "20000"), ("max-depth", "2")],
            &furnace_sphere(0.5, 1.0),
            1.75,
            40,
            500,
        );
    }

    #[test]
    fn a_glass_ball_in_the_furnace_is_invisible() {
        // Photons through glass carry power (no 1/eta^2); the camera's radiance through it
        // does carry 1/eta^2. Both must hold for the ball to vanish.
        expect_mean_passes(
            "sppm",
            &[("photons", "20000")],
            &furnace_with_glass(0.5, 1.0),
            2.0,
            40,
            500,
        );
    }

    #[test]
    fn dark_scenes_stay_black_and_mirror_chains_end() {
        let (mean, _) = estimate_passes("sppm", &[], &inside_a_mirror(), 2, 500);
        assert_eq!(mean, 0.0);
        let (mean, _) = estimate_passes("sppm", &[], &floor_under_light_facing_away(), 2, 500);
        assert_eq!(mean, 0.0);
    }
}
