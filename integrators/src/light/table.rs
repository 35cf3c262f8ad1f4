//! The light sampler: picks an emitter for a shading point. Three ways, as a scene or an
//! integrator chooses ([`LightSelection`]): in proportion to power, uniformly (over emitting
//! entities, then their parts by power, as Mitsuba 3; over lights when nothing groups them),
//! or by a light BVH that weighs each light by what it could send to the point
//! ([`super::bvh`]). Paths that start on a light (photons, light subpaths) have no point to
//! choose for: they pick by power, or uniformly when that is the scene's choice.

use super::bvh::{LightBvh, LightContext};
use super::{LeSample, Light, LightSample};
use crate::spectrum::curve::Curve;
use crate::spectrum::Wavelengths;
use crate::{Rgb, Spectrum};
use glam::{Vec2, Vec3A};

/// How a light sample picks an emitter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum LightSelection {
    /// Uniformly: each emitting entity alike, then its parts in proportion to their power.
    Uniform,
    /// In proportion to power.
    #[default]
    Power,
    /// By the light BVH, for the shading point (power where there is none).
    Bvh,
}

impl LightSelection {
    /// Every selection, by its name.
    pub const ALL: [(&'static str, LightSelection); 3] = [
        ("uniform", LightSelection::Uniform),
        ("power", LightSelection::Power),
        ("bvh", LightSelection::Bvh),
    ];

    /// The selection's name, as `light-selection` takes it.
    pub fn name(self) -> &'static str {
        crate::named::name_of(&Self::ALL, self)
    }

    /// The selection named `name`.
    pub fn parse(name: &str) -> Result<LightSelection, String> {
        crate::named::parse_named(&Self::ALL, name, ("light selection", "light selections"))
    }
}

impl std::fmt::Display for LightSelection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A discrete distribution over the lights: probabilities and their running sums.
#[derive(Clone, Debug, Default)]
struct Pick {
    pmf: Vec<f32>,
    cdf: Vec<f32>,
}

impl Pick {
    /// Proportional to `weights` (finite, not negative; uniform if they are all zero).
    fn new(weights: &[f64]) -> Pick {
        let total: f64 = weights.iter().sum();
        let pmf: Vec<f32> = if total > 0.0 && total.is_finite() {
            weights.iter().map(|&p| (p / total) as f32).collect()
        } else {
            vec![1.0 / weights.len().max(1) as f32; weights.len()]
        };
        // Running sum in f64; a light with zero probability gets the same cdf value as its
        // predecessor, so the search below can never land on it. Everything from the last
        // light with a non-zero probability on is pinned to exactly 1.
        let mut cdf = Vec::with_capacity(pmf.len());
        let norm = sum_or_one(&pmf);
        let mut sum = 0.0f64;
        for &p in &pmf {
            sum += p as f64;
            cdf.push((sum / norm) as f32);
        }
        if let Some(last) = pmf.iter().rposition(|&p| p > 0.0) {
            for c in &mut cdf[last..] {
                *c = 1.0;
            }
        }
        Pick { pmf, cdf }
    }

    fn sample(&self, u: f32) -> Option<(u32, f32)> {
        if self.pmf.is_empty() {
            return None;
        }
        // Clamp into [0, 1) (NaN -> 0): the cdf reaches exactly 1 at the last light with a
        // non-zero probability, so the search stops there at the latest.
        let u = if u > 0.0 {
            u.min(1.0 - f32::EPSILON / 2.0)
        } else {
            0.0
        };
        let i = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.pmf.len() - 1);
        Some((i as u32, self.pmf[i]))
    }
}

/// All emitters of a scene with the distributions that pick them.
#[derive(Clone, Debug, Default)]
pub struct LightTable {
    lights: Vec<Light>,
    power: Pick,
    uniform: Pick,
    /// Each light's power, which the BVH is built from.
    powers: Vec<f64>,
    /// Built the first time a light is chosen by it: a scene whose integrators never ask
    /// pays nothing for it.
    bvh: std::sync::OnceLock<LightBvh>,
    /// The scene's selection, which integrators use unless they choose another.
    selection: LightSelection,
    environment: Option<u32>,
    /// What a light emits where the scene gave it by wavelength (a measured emitter, a
    /// blackbody), beside the colour that stands for it in RGB mode; one entry per light.
    spectra: Vec<Option<Emission>>,
}

/// An emitter's spectrum, and the colour it is in RGB mode.
#[derive(Clone, Debug, PartialEq)]
pub struct Emission {
    pub curve: Curve,
    /// The light's colour as given (its RGB mode's value at the scale the curve has).
    pub rgb: Rgb,
}

impl LightTable {
    /// Builds the table; selection is proportional to [`Light::power`] (uniform if every
    /// power is zero), and `uniform` is over the lights. At most one environment light: if
    /// there are several, the first one is the one [`LightTable::environment`] reports.
    pub fn new(lights: Vec<Light>, scene_radius: f32) -> LightTable {
        let powers = Self::powers(&lights, scene_radius);
        let uniform = vec![1.0; lights.len()];
        Self::build(lights, powers, uniform, LightSelection::Power)
    }

    /// Each light's [`Light::power`], 0 where it is not a finite positive number.
    pub fn powers(lights: &[Light], scene_radius: f32) -> Vec<f64> {
        lights
            .iter()
            .map(|l| {
                let p = l.power(scene_radius);
                if p.is_finite() && p > 0.0 {
                    p
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// Builds the table from each light's power and its weight under uniform selection (one
    /// per light, finite and not negative), choosing by `selection` unless an integrator
    /// says otherwise. A light without power is never chosen by power or the BVH.
    pub fn build(
        lights: Vec<Light>,
        powers: Vec<f64>,
        uniform: Vec<f64>,
        selection: LightSelection,
    ) -> LightTable {
        debug_assert_eq!(lights.len(), powers.len());
        debug_assert_eq!(lights.len(), uniform.len());
        let environment = lights
            .iter()
            .position(Light::is_environment)
            .and_then(|i| u32::try_from(i).ok());
        LightTable {
            bvh: std::sync::OnceLock::new(),
            power: Pick::new(&powers),
            powers,
            uniform: Pick::new(&uniform),
            spectra: vec![None; lights.len()],
            lights,
            selection,
            environment,
        }
    }

    /// The table with light `i` emitting `spectra[i]` where given (see [`LightRef`]).
    pub fn with_spectra(mut self, spectra: Vec<Option<Emission>>) -> LightTable {
        debug_assert_eq!(spectra.len(), self.lights.len());
        self.spectra = spectra;
        self
    }

    /// The emitters, in the order their indices refer to.
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// Number of emitters.
    pub fn len(&self) -> usize {
        self.lights.len()
    }

    /// True if the scene has no emitters.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// Light `index`. Panics if `index` is out of range (indices come from the table itself).
    pub fn get(&self, index: u32) -> LightRef<'_> {
        LightRef {
            light: &self.lights[index as usize],
            spectrum: self.spectra.get(index as usize).and_then(Option::as_ref),
        }
    }

    /// The scene's selection.
    pub fn selection(&self) -> LightSelection {
        self.selection
    }

    /// The distribution a choice without a point draws from.
    fn pointless(&self) -> &Pick {
        match self.selection {
            LightSelection::Uniform => &self.uniform,
            LightSelection::Power | LightSelection::Bvh => &self.power,
        }
    }

    /// Picks a light with `u` in `[0, 1)` without a point to light (a path starting on a
    /// light): by the scene's selection, power for the BVH. Its index and selection
    /// probability; `None` if the table is empty; never a light whose probability is zero.
    pub fn sample(&self, u: f32) -> Option<(u32, f32)> {
        self.pointless().sample(u)
    }

    /// Probability that [`LightTable::sample`] picks light `index`.
    pub fn pmf(&self, index: u32) -> f32 {
        self.pointless().pmf[index as usize]
    }

    /// Picks a light to light `ctx` with `u` in `[0, 1)` by `choice` (the scene's when
    /// `None`): its index and probability. `None` when there is none to pick (no lights, or
    /// under the BVH none that can reach the point).
    #[inline]
    pub fn sample_for(
        &self,
        choice: Option<LightSelection>,
        ctx: &LightContext,
        u: f32,
    ) -> Option<(u32, f32)> {
        match choice.unwrap_or(self.selection) {
            LightSelection::Uniform => self.uniform.sample(u),
            LightSelection::Power => self.power.sample(u),
            LightSelection::Bvh => self.bvh().sample(ctx, u),
        }
    }

    /// Probability that [`LightTable::sample_for`] picks light `index` for `ctx`.
    #[inline]
    pub fn pmf_for(&self, choice: Option<LightSelection>, ctx: &LightContext, index: u32) -> f32 {
        match choice.unwrap_or(self.selection) {
            LightSelection::Uniform => self.uniform.pmf[index as usize],
            LightSelection::Power => self.power.pmf[index as usize],
            LightSelection::Bvh => self.bvh().pmf(ctx, index),
        }
    }

    /// The light BVH, built on first use.
    fn bvh(&self) -> &LightBvh {
        self.bvh
            .get_or_init(|| LightBvh::new(&self.lights, &self.powers))
    }

    /// Index of the environment light, if the scene has one.
    pub fn environment(&self) -> Option<u32> {
        self.environment
    }
}

/// Sum of the (f32) probabilities in f64, or 1 when it is not positive.
fn sum_or_one(pmf: &[f32]) -> f64 {
    let s: f64 = pmf.iter().map(|&p| p as f64).sum();
    if s > 0.0 {
        s
    } else {
        1.0
    }
}

/// A light of the table, with its spectrum where the scene gave one: what it emits at a
/// sample's wavelengths is the curve's there, times the factor by which the light's colour
/// at that point and direction differs from its nominal colour (its falloff, its profile;
/// for an emitter given by wavelength this factor is the same in every channel). Everything
/// else is the light's ([`Light`], through `Deref`).
#[derive(Clone, Copy, Debug)]
pub struct LightRef<'t> {
    pub light: &'t Light,
    pub spectrum: Option<&'t Emission>,
}

impl std::ops::Deref for LightRef<'_> {
    type Target = Light;
    fn deref(&self) -> &Light {
        self.light
    }
}

impl LightRef<'_> {
    /// `rgb`, the light's colour somewhere (as RGB mode's spectrum), at `lambda`: the
    /// spectrum's values scaled as `rgb` is from the nominal colour, or `None` to convert the
    /// colour itself.
    #[inline]
    fn spectral(&self, rgb: Spectrum, lambda: &Wavelengths) -> Option<Spectrum> {
        let e = self.spectrum?;
        if !lambda.is_spectral() {
            return None;
        }
        let rgb = crate::spectrum::rgb_of(rgb);
        let nominal = crate::luminance(e.rgb);
        let factor = if nominal > 0.0 {
            crate::luminance(rgb) / nominal
        } else {
            0.0
        };
        Some(lambda.map(rgb, |nm| e.curve.at(nm)) * factor)
    }

    /// [`Light::sample_li`], with the light's spectrum.
    #[inline]
    pub fn sample_li(&self, p: Vec3A, u: Vec2, lambda: &Wavelengths) -> Option<LightSample> {
        if self.spectrum.is_none() || !lambda.is_spectral() {
            return self.light.sample_li(p, u, lambda);
        }
        let mut s = self.light.sample_li(p, u, &Wavelengths::Rgb)?;
        s.radiance = self.spectral(s.radiance, lambda)?;
        Some(s)
    }

    /// [`Light::emitted`], with the light's spectrum.
    #[inline]
    pub fn emitted(&self, n: Vec3A, w: Vec3A, lambda: &Wavelengths) -> Spectrum {
        match self.spectral(self.light.emitted(n, w, &Wavelengths::Rgb), lambda) {
            Some(s) => s,
            None => self.light.emitted(n, w, lambda),
        }
    }

    /// [`Light::emitted_at`], with the light's spectrum.
    #[inline]
    pub fn emitted_at(&self, q: Vec3A, n: Vec3A, w: Vec3A, lambda: &Wavelengths) -> Spectrum {
        if self.spectrum.is_none() || !lambda.is_spectral() {
            return self.light.emitted_at(q, n, w, lambda);
        }
        let rgb = self.light.emitted_at(q, n, w, &Wavelengths::Rgb);
        self.spectral(rgb, lambda).unwrap_or(rgb)
    }

    /// [`Light::emitted_from`], with the light's spectrum.
    #[inline]
    pub fn emitted_from(&self, q: Vec3A, w: Vec3A, lambda: &Wavelengths) -> Spectrum {
        if self.spectrum.is_none() || !lambda.is_spectral() {
            return self.light.emitted_from(q, w, lambda);
        }
        let rgb = self.light.emitted_from(q, w, &Wavelengths::Rgb);
        self.spectral(rgb, lambda).unwrap_or(rgb)
    }

    /// [`Light::sample_le`], with the light's spectrum.
    #[inline]
    pub fn sample_le(
        &self,
        u_pos: Vec2,
        u_dir: Vec2,
        u_side: f32,
        scene_center: Vec3A,
        scene_radius: f32,
        lambda: &Wavelengths,
    ) -> Option<LeSample> {
        let light = self.light;
        if self.spectrum.is_none() || !lambda.is_spectral() {
            return light.sample_le(u_pos, u_dir, u_side, scene_center, scene_radius, lambda);
        }
        let rgb = &Wavelengths::Rgb;
        let mut s = light.sample_le(u_pos, u_dir, u_side, scene_center, scene_radius, rgb)?;
        s.radiance = self.spectral(s.radiance, lambda)?;
        s.weight = self.spectral(s.weight, lambda)?;
        Some(s)
    }
}
