//! Participating media: what fills the space between surfaces (fog, smoke, the inside of a
//! glass of milk). A medium absorbs (`sigma_a`), scatters (`sigma_s`, by its [`Phase`]) and
//! may emit (`Le`, radiance per unit length times `sigma_a`); `sigma_t = sigma_a + sigma_s`
//! is its extinction, per unit length of the scene.
//!
//! Light transport through a medium is sampled against a **majorant** `sigma_maj >= sigma_t`
//! ([`Medium::majorant`]): tentative collisions are drawn at rate `sigma_maj` along a ray, and
//! each is real (absorption, scattering) or null by the ratios of the coefficients there
//! (delta and ratio tracking; pbrt-v4's `SampleT_maj`, [`tracking`]). A homogeneous medium's
//! majorant is its extinction, so every collision is real; a grid in a box has a coarse grid
//! of majorants ([`majorant`]), walked cell by cell.
//!
//! Rays carry the medium they travel in ([`crate::Ray::medium`]); surfaces carry the media on
//! their two sides ([`crate::MediumInterface`]).

pub mod majorant;
pub mod phase;
pub mod tracking;
pub mod volume;

use majorant::MajorantGrid;

pub use phase::{Phase, PhaseSample};
pub use volume::{DensityGrid, GridEdge, Volume};

use crate::spectrum::of_rgb;
use crate::spectrum::Wavelengths;
use crate::{Ray, Rgb, Spectrum};
use glam::{Affine3A, Vec3A};

/// A participating medium.
#[derive(Clone, Debug, PartialEq)]
pub enum Medium {
    /// The same coefficients everywhere.
    Homogeneous(Homogeneous),
    /// Coefficients that vary over space, within a box (boxed: a scene's media are few).
    Heterogeneous(Box<Heterogeneous>),
}

/// A medium with the same coefficients everywhere (Mitsuba 3's `homogeneous`, pbrt-v4's
/// `homogeneous`).
#[derive(Clone, Debug, PartialEq)]
pub struct Homogeneous {
    pub sigma_a: Rgb,
    pub sigma_s: Rgb,
    /// Emitted radiance (the medium adds `sigma_a * le` per unit length).
    pub le: Rgb,
    pub phase: Phase,
}

/// A medium whose coefficients vary over space (Mitsuba 3's `heterogeneous`, pbrt-v4's
/// `uniformgrid` and `rgbgrid`): inside the box `region` maps onto the unit cube, and vacuum
/// outside it.
#[derive(Clone, Debug, PartialEq)]
pub struct Heterogeneous {
    pub coefficients: Coefficients,
    /// Emitted radiance over space (the medium adds `sigma_a * le` per unit length).
    pub le: Volume,
    pub phase: Phase,
    /// World to the unit cube of the box the medium fills; `None`: everywhere.
    pub region: Option<Affine3A>,
    /// The largest extinction anywhere.
    majorant: Rgb,
    /// The largest extinction in each cell of the box (with a box and a grid).
    majorants: Option<MajorantGrid>,
    /// The same in spectral mode (one value for every wavelength).
    majorant_spectral: f32,
    majorants_spectral: Option<MajorantGrid>,
}

/// How a heterogeneous medium gives its coefficients over space.
#[derive(Clone, Debug, PartialEq)]
pub enum Coefficients {
    /// Extinction and single-scattering albedo (Mitsuba 3's `heterogeneous`, pbrt-v4's
    /// `uniformgrid`): `sigma_s = albedo sigma_t`, the albedo clamped into `[0, 1]`.
    Albedo { sigma_t: Volume, albedo: Volume },
    /// Absorption and scattering each on its own (pbrt-v4's `rgbgrid`).
    Separate { sigma_a: Volume, sigma_s: Volume },
}

impl Coefficients {
    /// `(sigma_a, sigma_s)` at `p` (world).
    #[inline]
    fn at(&self, p: Vec3A) -> (Rgb, Rgb) {
        match self {
            Coefficients::Albedo { sigma_t, albedo } => {
                let sigma_t = sigma_t.at(p);
                let sigma_s = sigma_t * albedo.at(p).clamp(Rgb::ZERO, Rgb::ONE);
                (sigma_t - sigma_s, sigma_s)
            }
            Coefficients::Separate { sigma_a, sigma_s } => (sigma_a.at(p), sigma_s.at(p)),
        }
    }

    /// A bound on the extinction anywhere in the convex hull of `corners` (world), or
    /// anywhere at all for `None`.
    fn max_extinction(&self, corners: Option<&[Vec3A; 8]>) -> Rgb {
        let max = |v: &Volume| corners.map_or_else(|| v.max(), |c| v.max_in(c));
        match self {
            Coefficients::Albedo { sigma_t, .. } => max(sigma_t),
            Coefficients::Separate { sigma_a, sigma_s } => max(sigma_a) + max(sigma_s),
        }
    }

    /// Whether a grid gives any of them.
    /// A bound on the extinction at any wavelength in spectral mode: an unbounded value
    /// upsampled never exceeds twice its largest channel ([`crate::spectrum::RgbSpectrum`]).
    fn max_extinction_spectral(&self, corners: Option<&[Vec3A; 8]>) -> f32 {
        let max = |v: &Volume| {
            corners
                .map_or_else(|| v.max(), |c| v.max_in(c))
                .max_element()
        };
        match self {
            Coefficients::Albedo { sigma_t, .. } => 2.0 * max(sigma_t),
            Coefficients::Separate { sigma_a, sigma_s } => 2.0 * (max(sigma_a) + max(sigma_s)),
        }
    }

    /// [`Coefficients::at`] at the wavelengths `lambda`: extinction and the coefficients as
    /// unbounded spectra, albedo as a reflectance.
    #[inline]
    fn at_spectral(&self, p: Vec3A, lambda: &Wavelengths) -> (Spectrum, Spectrum) {
        match self {
            Coefficients::Albedo { sigma_t, albedo } => {
                let sigma_t = lambda.unbounded(sigma_t.at(p));
                let sigma_s = sigma_t * lambda.reflectance(albedo.at(p));
                (sigma_t - sigma_s, sigma_s)
            }
            Coefficients::Separate { sigma_a, sigma_s } => (
                lambda.unbounded(sigma_a.at(p)),
                lambda.unbounded(sigma_s.at(p)),
            ),
        }
    }

    fn has_grid(&self) -> bool {
        let grid = |v: &Volume| matches!(v, Volume::Grid { .. });
        match self {
            Coefficients::Albedo { sigma_t, .. } => grid(sigma_t),
            Coefficients::Separate { sigma_a, sigma_s } => grid(sigma_a) || grid(sigma_s),
        }
    }
}

/// The coefficients of a medium at a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MediumPoint {
    pub sigma_a: Spectrum,
    pub sigma_s: Spectrum,
    /// Emitted radiance (the medium adds `sigma_a * le` per unit length).
    pub le: Spectrum,
}

/// A stretch `[t0, t1)` of a ray over which the majorant is `sigma_maj`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub t0: f32,
    pub t1: f32,
    pub sigma_maj: Spectrum,
}

impl Homogeneous {
    /// A medium of extinction `sigma_t` and single-scattering albedo `albedo` (in `[0, 1]`).
    pub fn new(sigma_t: Rgb, albedo: Rgb, le: Rgb, phase: Phase) -> Homogeneous {
        let sigma_s = sigma_t * albedo;
        Homogeneous {
            sigma_a: sigma_t - sigma_s,
            sigma_s,
            le,
            phase,
        }
    }
}

impl Homogeneous {
    /// The absorption and scattering coefficients at `lambda`: the extinction as an unbounded
    /// spectrum, the albedo as a reflectance (Mitsuba 3's `sigma_t` and `albedo`).
    fn spectral(&self, lambda: &Wavelengths) -> (Spectrum, Spectrum) {
        let sigma_t = self.sigma_a + self.sigma_s;
        let albedo = Vec3A::select(
            sigma_t.cmpgt(Vec3A::ZERO),
            self.sigma_s / sigma_t,
            Vec3A::ZERO,
        );
        let sigma_t = lambda.unbounded(sigma_t);
        let sigma_s = sigma_t * lambda.reflectance(albedo);
        (sigma_t - sigma_s, sigma_s)
    }
}

impl Heterogeneous {
    /// A medium of `coefficients` and emission `le` over space, within `region` (world to
    /// the unit cube of the box; `None`: everywhere).
    pub fn new(
        coefficients: Coefficients,
        le: Volume,
        phase: Phase,
        region: Option<Affine3A>,
    ) -> Heterogeneous {
        let grid = |bound: &dyn Fn(&[Vec3A; 8]) -> Rgb| match &region {
            Some(to_unit) if coefficients.has_grid() => MajorantGrid::build(to_unit, bound),
            _ => None,
        };
        let majorants = grid(&|corners| coefficients.max_extinction(Some(corners)));
        let majorants_spectral =
            grid(&|corners| Rgb::splat(coefficients.max_extinction_spectral(Some(corners))));
        Heterogeneous {
            majorant: coefficients.max_extinction(None),
            majorants,
            majorant_spectral: coefficients.max_extinction_spectral(None),
            majorants_spectral,
            coefficients,
            le,
            phase,
            region,
        }
    }
}

impl Medium {
    /// How the medium scatters.
    #[inline]
    pub fn phase(&self) -> Phase {
        match self {
            Medium::Homogeneous(m) => m.phase,
            Medium::Heterogeneous(m) => m.phase,
        }
    }

    /// Whether the medium emits light.
    pub fn is_emissive(&self) -> bool {
        match self {
            Medium::Homogeneous(m) => m.le != Rgb::ZERO && m.sigma_a != Rgb::ZERO,
            Medium::Heterogeneous(m) => m.le.max() != Rgb::ZERO,
        }
    }

    /// Whether the extinction differs between channels somewhere (a coloured medium, which
    /// the trackers sample by one channel and weight by all).
    pub fn is_chromatic(&self) -> bool {
        let c = self.majorant_rgb();
        c.x != c.y || c.y != c.z
    }

    fn majorant_rgb(&self) -> Rgb {
        match self {
            Medium::Homogeneous(m) => m.sigma_a + m.sigma_s,
            Medium::Heterogeneous(m) => m.majorant,
        }
    }

    /// The coefficients at `p` (world), at the wavelengths `lambda`.
    #[inline]
    pub fn at(&self, p: Vec3A, lambda: &Wavelengths) -> MediumPoint {
        if lambda.is_spectral() {
            return self.at_spectral(p, lambda);
        }
        match self {
            Medium::Homogeneous(m) => MediumPoint {
                sigma_a: of_rgb(m.sigma_a),
                sigma_s: of_rgb(m.sigma_s),
                le: of_rgb(m.le),
            },
            Medium::Heterogeneous(m) => {
                let (sigma_a, sigma_s) = m.coefficients.at(p);
                MediumPoint {
                    sigma_a: of_rgb(sigma_a),
                    sigma_s: of_rgb(sigma_s),
                    le: of_rgb(m.le.at(p)),
                }
            }
        }
    }

    /// [`Medium::at`] in spectral mode.
    #[inline(never)]
    fn at_spectral(&self, p: Vec3A, lambda: &Wavelengths) -> MediumPoint {
        match self {
            Medium::Homogeneous(m) => {
                let (sigma_a, sigma_s) = m.spectral(lambda);
                MediumPoint {
                    sigma_a,
                    sigma_s,
                    le: lambda.illuminant(m.le),
                }
            }
            Medium::Heterogeneous(m) => {
                let (sigma_a, sigma_s) = m.coefficients.at_spectral(p, lambda);
                MediumPoint {
                    sigma_a,
                    sigma_s,
                    le: lambda.illuminant(m.le.at(p)),
                }
            }
        }
    }

    /// The stretches of `ray` before `tmax` over which the medium may be dense, in order,
    /// each with its majorant; none where the ray misses it. A medium in a box with a grid
    /// gives one stretch per cell of its majorant grid the ray crosses; the others one
    /// stretch, with the largest extinction anywhere.
    #[inline]
    pub fn majorant(&self, ray: &Ray, tmax: f32, lambda: &Wavelengths) -> Majorants<'_> {
        let spectral = lambda.is_spectral();
        match self {
            Medium::Homogeneous(m) => Majorants::One(Some(Segment {
                t0: 0.0,
                t1: tmax,
                sigma_maj: match spectral {
                    false => of_rgb(m.sigma_a + m.sigma_s),
                    true => {
                        let (a, s) = m.spectral(lambda);
                        a + s
                    }
                },
            })),
            Medium::Heterogeneous(m) => match (
                &m.region,
                if spectral {
                    &m.majorants_spectral
                } else {
                    &m.majorants
                },
            ) {
                (Some(to_unit), Some(grid)) => Majorants::Grid(grid.segments(to_unit, ray, tmax)),
                (region, _) => {
                    let stretch = match region {
                        None => Some((0.0, tmax)),
                        Some(to_unit) => unit_cube_overlap(to_unit, ray, tmax),
                    };
                    Majorants::One(stretch.map(|(t0, t1)| Segment {
                        t0,
                        t1,
                        sigma_maj: match spectral {
                            false => of_rgb(m.majorant),
                            true => Spectrum::splat(m.majorant_spectral),
                        },
                    }))
                }
            },
        }
    }
}

/// The stretches of a ray with their majorants ([`Medium::majorant`]).
pub enum Majorants<'g> {
    One(Option<Segment>),
    Grid(majorant::Segments<'g>),
}

impl Iterator for Majorants<'_> {
    type Item = Segment;

    #[inline]
    fn next(&mut self) -> Option<Segment> {
        match self {
            Majorants::One(one) => one.take(),
            Majorants::Grid(cells) => cells.next(),
        }
    }
}

/// The stretch `[t0, t1)` of `ray` (before `tmax`) inside the unit cube that `to_unit` maps
/// the box onto: the ray is taken into the cube's space unnormalised, so that `t` keeps its
/// meaning.
pub(crate) fn unit_cube_overlap(to_unit: &Affine3A, ray: &Ray, tmax: f32) -> Option<(f32, f32)> {
    let o = to_unit.transform_point3a(ray.origin);
    let d = to_unit.transform_vector3a(ray.dir);
    let (mut t0, mut t1) = (0.0f32, tmax);
    for axis in 0..3 {
        let inv = 1.0 / d[axis];
        let (mut near, mut far) = ((0.0 - o[axis]) * inv, (1.0 - o[axis]) * inv);
        if near > far {
            std::mem::swap(&mut near, &mut far);
        }
        // A ray parallel to a slab and outside it gives NaN bounds: missed.
        if near.is_nan() || far.is_nan() {
            return None;
        }
        t0 = t0.max(near);
        t1 = t1.min(far);
    }
    (t0 < t1).then_some((t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_unit_cube_overlap_keeps_distances_of_the_world() {
        // A box [-1, 3]^3: world to the unit cube scales by 1/4 after moving by 1.
        let to_unit = Affine3A::from_scale(glam::Vec3::splat(0.25))
            * Affine3A::from_translation(glam::Vec3::splat(1.0));
        let ray = Ray::new(Vec3A::new(-5.0, 0.0, 0.0), Vec3A::X);
        let (t0, t1) = unit_cube_overlap(&to_unit, &ray, f32::INFINITY).unwrap();
        assert!(
            (t0 - 4.0).abs() < 1e-5 && (t1 - 8.0).abs() < 1e-5,
            "{t0} {t1}"
        );
        assert!(unit_cube_overlap(&to_unit, &ray, 3.0).is_none());
        let (_, t1) = unit_cube_overlap(&to_unit, &ray, 6.0).unwrap();
        assert_eq!(t1, 6.0);
        let parallel_outside = Ray::new(Vec3A::new(-5.0, 5.0, 0.0), Vec3A::X);
        assert!(unit_cube_overlap(&to_unit, &parallel_outside, f32::INFINITY).is_none());
        let parallel_inside = Ray::new(Vec3A::new(-5.0, 0.5, 0.5), Vec3A::X);
        assert!(unit_cube_overlap(&to_unit, &parallel_inside, f32::INFINITY).is_some());
    }
}
