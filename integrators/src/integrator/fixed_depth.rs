//! `fixed-depth`: the report's Monte Carlo tracer (its sections 1.3 and 2.4), faithfully.
//!
//! **Estimates** the rendering equation truncated at `depth` scattering events by branching:
//! at every non-specular hit, direct light from `shadow-grid x shadow-grid` stratified samples
//! on every light (next-event estimation), plus `branching` BSDF-sampled rays that gather
//! indirect light recursively. Specular surfaces (mirror, glass) continue with one ray. Light
//! reached by a branching ray is not counted again (it was sampled as direct light), except
//! after specular reflection, which direct-light sampling cannot see through.
//!
//! **Parameters**: `depth` (default 2), `branching` (default 20), `shadow-grid` (default 7):
//! the report's settings. Depth follows the crate's convention: `depth = 1` is direct light
//! only, `depth = 2` adds one bounce of indirect light, as the report's "2 bounces".
//!
//! **Cost** grows like `branching^(depth - 1)` rays per camera sample: that is the point.
//! **Bias**: truncation only (paths longer than `depth` are missing); unbiased below it.

use crate::bsdf::TransportMode::Radiance;
use crate::integrator::{emitted_at, escaped, Demand, RayIntegrator, ShadingPoint, Tracer};
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, ParamKind, ParamSpec, Params, SpectralSupport,
};
use crate::spectrum::Wavelengths;
use crate::Spectrum;
use crate::{Hit, Ray, Sampler};
use glam::Vec2;

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "fixed-depth",
    summary:
        "the report's tracer: branching hemisphere rays, fixed depth, NxN shadow rays per light",
    params: &[
        ParamSpec {
            name: "depth",
            kind: ParamKind::Int,
            default: 2.0,
            min: 0.0,
            max: 16.0,
            doc: "scattering events per path (1 = direct light only)",
        },
        ParamSpec {
            name: "branching",
            kind: ParamKind::Int,
            default: 20.0,
            min: 0.0,
            max: 1024.0,
            doc: "BSDF-sampled rays per non-specular hit",
        },
        ParamSpec {
            name: "shadow-grid",
            kind: ParamKind::Int,
            default: 7.0,
            min: 1.0,
            max: 64.0,
            doc: "N for NxN stratified shadow rays per light",
        },
    ],
    build: |p: &Params| {
        Box::new(FixedDepth {
            depth: p.get_u32("depth"),
            branching: p.get_u32("branching"),
            shadow_grid: p.get_u32("shadow-grid"),
        })
    },
    analytic: Some(Analytic {
        // Every one of the furnace's 320 triangles is a light: one shadow ray each.
        params: &[("depth", "2"), ("branching", "2"), ("shadow-grid", "1")],
        furnace: expect(1.75, 30, 20),
        point_in_sphere: expect(0.75, 40, 100),
        sphere_under_sky: expect(1.2, 40, 400),
    }),
    media: MediaSupport::None,
    spectral: SpectralSupport::PerSample,
};

struct FixedDepth {
    depth: u32,
    branching: u32,
    shadow_grid: u32,
}

impl FixedDepth {
    /// Direct light at the shading point from every light, `shadow_grid^2` stratified
    /// samples each.
    fn direct(&self, sp: &ShadingPoint, tracer: &mut Tracer, sampler: &mut Sampler) -> Spectrum {
        let mut l = Spectrum::ZERO;
        let lights = tracer.scene.lights();
        for (index, light) in lights.lights().iter().enumerate() {
            // A flat or convex emitter cannot light itself (no samples drawn for it).
            if !sp.can_receive(index as u32, lights) {
                continue;
            }
            let n = if light.is_delta() {
                1
            } else {
                self.shadow_grid
            };
            let mut sum = Spectrum::ZERO;
            for j in 0..n {
                for i in 0..n {
                    let u = (Vec2::new(i as f32, j as f32) + sampler.next_2d()) / n as f32;
                    if let Some((ls, f, cos)) = sp.connect_light(index as u32, u, tracer) {
                        sum += f * ls.radiance * (cos / ls.pdf);
                    }
                }
            }
            l += sum / (n * n) as f32;
        }
        l
    }

    /// Radiance along `ray` arriving from `hit`, after `bounces` scattering events.
    /// `count_emission` is false when direct-light sampling already counted this emitter.
    #[allow(clippy::too_many_arguments)]
    fn shade(
        &self,
        ray: &Ray,
        hit: &Hit,
        bounces: u32,
        count_emission: bool,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        // Emission seen directly or through specular surfaces.
        let mut l = if count_emission {
            emitted_at(tracer.scene, hit, ray, lambda)
        } else {
            Spectrum::ZERO
        };
        // Past the depth, or abandoned: the branching tree can take hours per sample.
        if bounces >= self.depth || tracer.stop.requested() {
            return l;
        }
        let sp = ShadingPoint::new(hit, ray.dir, tracer.scene, lambda);
        let material = &sp.material;

        // Specular surfaces: one continuation ray, emission at its end counts.
        if material.is_specular() {
            if let Some(s) = sp.sample(sampler.next_1d(), sampler.next_2d(), Radiance) {
                let next = hit.spawn_ray(s.wi);
                l += s.weight
                    * match tracer.extend(&next) {
                        Some(h) => {
                            self.shade(&next, &h, bounces + 1, true, tracer, sampler, lambda)
                        }
                        None => escaped(tracer.scene, &next, lambda),
                    };
            }
            return l;
        }

        // Direct light by NxN shadow rays per light.
        l += self.direct(&sp, tracer, sampler);

        // Indirect light: `branching` hemisphere rays, only if their hits can still add a
        // scattering event (direct light there is depth bounces + 2).
        if bounces + 2 <= self.depth && self.branching > 0 {
            let mut sum = Spectrum::ZERO;
            for _ in 0..self.branching {
                let Some(s) = sp.sample(sampler.next_1d(), sampler.next_2d(), Radiance) else {
                    continue;
                };
                let next = hit.spawn_ray(s.wi);
                // Misses carry no light here: the environment was sampled as direct light.
                if let Some(h) = tracer.extend(&next) {
                    sum += s.weight
                        * self.shade(
                            &next,
                            &h,
                            bounces + 1,
                            s.bsdf.specular,
                            tracer,
                            sampler,
                            lambda,
                        );
                }
            }
            l += sum / self.branching as f32;
        }
        l
    }
}

impl RayIntegrator for FixedDepth {
    fn demand(&self) -> Demand {
        // The branching tree's rays: sum over its levels of branching^level (shadow rays
        // come on top, per light).
        let b = self.branching as f64;
        let levels = self.depth.saturating_sub(1) as i32;
        Demand {
            rays_per_sample: (0..=levels).map(|k| b.powi(k)).sum(),
            memory: 0,
            ..Demand::default()
        }
    }

    fn radiance(
        &self,
        ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        match tracer.camera(ray) {
            Some(hit) => self.shade(ray, &hit, 0, true, tracer, sampler, lambda),
            None => escaped(tracer.scene, ray, lambda),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::testing::*;

    /// Le * (1 + a + ... + a^depth): the series truncated at `depth` scattering events.
    fn truncated(a: f32, le: f32, depth: u32) -> f32 {
        (0..=depth).map(|k| le * a.powi(k as i32)).sum()
    }

    #[test]
    fn furnace_gives_the_truncated_series() {
        for (a, depth) in [(0.5, 1), (0.5, 2), (0.8, 3)] {
            let scene = furnace_sphere(a, 1.0);
            let d = depth.to_string();
            // Every one of the furnace's 320 triangles is a light: keep the grid at 1x1.
            let params = [
                ("depth", d.as_str()),
                ("branching", "2"),
                ("shadow-grid", "1"),
            ];
            expect_mean(
                "fixed-depth",
                &params,
                &scene,
                truncated(a, 1.0, depth),
                600,
            );
        }
    }

    #[test]
    fn stratified_shadow_grid_is_unbiased() {
        // Direct light only, 3x3 strata per light: Le (1 + a).
        let params = [("depth", "1"), ("shadow-grid", "3")];
        expect_mean("fixed-depth", &params, &furnace_sphere(0.5, 1.0), 1.5, 100);
    }

    #[test]
    fn floor_under_a_sphere_light_and_one_sided_emission() {
        // Radiance a L (r/d)^2 = 0.5 * 4 * (0.5/2)^2 = 0.125 below a spherical light.
        expect_mean(
            "fixed-depth",
            &[("depth", "1"), ("shadow-grid", "2")],
            &floor_under_sphere_light(0.5, 4.0, 0.5, 2.0),
            0.125,
            4000,
        );
        // A one-sided light facing away from the floor lights nothing, and its back is black.
        let (mean, _) = estimate(
            "fixed-depth",
            &[("depth", "1"), ("shadow-grid", "2")],
            &floor_under_light_facing_away(),
            2000,
        );
        assert_eq!(mean, 0.0);
    }
}
