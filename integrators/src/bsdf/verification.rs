//! Tests of the microfacet materials as a set: values against Mitsuba 3, Nori's reference
//! albedos, white furnaces, reciprocity and energy bounds, and chi-square tests of every
//! sampling routine at several roughnesses and incidences including grazing.

use super::microfacet::{reflect, refract};
use super::*;
use crate::testing::chi2::{
    assert_chi2, check_sample_matches_eval, dir, directional_albedo, Grid, SAMPLES,
};
use crate::{Sampler, Spectrum};

const GGX: Distribution = Distribution::Ggx;
const BECKMANN: Distribution = Distribution::Beckmann;

fn mf(d: Distribution, a: f32) -> Microfacet {
    Microfacet::new(d, a, a).unwrap()
}

/// Mitsuba 3's default plastic IOR: polypropylene (1.49) over air (1.000277).
fn plastic_ior() -> f32 {
    ior::dielectric("polypropylene").unwrap() / ior::dielectric("air").unwrap()
}

// ---------------------------------------------------------------------------------------------
// Against Mitsuba 3.

/// The direction pairs at which Mitsuba 3 (3.7, `scalar_rgb`) was asked for `eval` and `pdf`,
/// as `(wo, wi)` in raylab's convention (Mitsuba's `si.wi` is raylab's `wo`): polar and
/// azimuthal angles in degrees.
const PAIRS: [((f32, f32), (f32, f32)); 5] = [
    ((0.0, 0.0), (0.0, 0.0)),
    ((30.0, 0.0), (30.0, 180.0)),
    ((60.0, 0.0), (45.0, 180.0)),
    ((60.0, 0.0), (20.0, 90.0)),
    ((80.0, 0.0), (70.0, 180.0)),
];

/// Mitsuba's `eval` (which includes `cos(wi)`) and `pdf` for each of [`PAIRS`].
struct Reference {
    eval: [[f32; 3]; 5],
    pdf: [f32; 5],
}

fn assert_matches_mitsuba(name: &str, m: &Material, r: &Reference, tolerance: f32) {
    for (i, ((to, po), (ti, pi))) in PAIRS.iter().enumerate() {
        let (wo, wi) = (dir(*to, *po), dir(*ti, *pi));
        let f = m.eval(wo, wi) * wi.z;
        let pdf = m.pdf(wo, wi);
        let close = |a: f32, b: f32| (a - b).abs() <= tolerance * b.abs() + 1e-6;
        for c in 0..3 {
            assert!(
                close(f[c], r.eval[i][c]),
                "{name}, pair {i}: eval {f} vs Mitsuba {:?}",
                r.eval[i]
            );
        }
        assert!(
            close(pdf, r.pdf[i]),
            "{name}, pair {i}: pdf {pdf} vs Mitsuba {}",
            r.pdf[i]
        );
        // Opposite sides: nothing (opaque materials).
        assert_eq!(m.eval(wo, -wi), Spectrum::ZERO);
    }
    println!("{name}: eval and pdf match Mitsuba 3 within {tolerance}");
}

fn grey(v: [f32; 5]) -> [[f32; 3]; 5] {
    v.map(|x| [x; 3])
}

#[test]
fn smooth_plastic_matches_mitsuba() {
    let ior = plastic_ior();
    let default =
        Material::Plastic(Plastic::new(Spectrum::splat(0.5), Spectrum::ONE, ior, false).unwrap());
    let pdf = [0.294_607, 0.254_371, 0.188_878, 0.251_004, 0.048_238_3];
    assert_matches_mitsuba(
        "plastic",
        &default,
        &Reference {
            eval: grey([0.161_866, 0.139_742, 0.107_505, 0.144_346, 0.030_567]),
            pdf,
        },
        2e-3,
    );
    let rgb = crate::spectrum::rgb(0.8, 0.3, 0.1);
    let pdf = [0.289_222, 0.249_552, 0.181_576, 0.241_302, 0.042_343];
    let nonlinear = Material::Plastic(Plastic::new(rgb, Spectrum::ONE, ior, true).unwrap());
    assert_matches_mitsuba(
        "plastic, nonlinear",
        &nonlinear,
        &Reference {
            eval: [
                [0.201_017, 0.048_334_6, 0.014_089_4],
                [0.173_543, 0.041_728_4, 0.012_163_7],
                [0.133_508, 0.032_102_1, 0.009_357_69],
                [0.179_26, 0.043_103_2, 0.012_564_5],
                [0.037_960_4, 0.009_127_6, 0.002_660_67],
            ],
            pdf,
        },
        2e-3,
    );
}

#[test]
fn rough_plastic_matches_mitsuba() {
    let ior = plastic_ior();
    let default = Material::RoughPlastic(
        RoughPlastic::new(
            Spectrum::splat(0.5),
            Spectrum::ONE,
            ior,
            false,
            mf(BECKMANN, 0.1),
        )
        .unwrap(),
    );
    assert_matches_mitsuba(
        "roughplastic",
        &default,
        &Reference {
            eval: grey([0.463_594, 0.503_617, 0.281_958, 0.138_694, 5.464_93]),
            pdf: [0.887_218, 0.968_328, 0.665_119, 0.250_105, 11.435],
        },
        5e-3,
    );
    let ggx = Material::RoughPlastic(
        RoughPlastic::new(
            crate::spectrum::rgb(0.8, 0.3, 0.1),
            Spectrum::ONE,
            ior,
            false,
            mf(GGX, 0.3),
        )
        .unwrap(),
    );
    assert_matches_mitsuba(
        "roughplastic, ggx 0.3",
        &ggx,
        &Reference {
            eval: [
                [0.211_056, 0.100_517, 0.056_302],
                [0.191_063, 0.096_906_2, 0.059_243_3],
                [0.185_951, 0.115_171, 0.086_858_7],
                [0.158_358, 0.062_024_7, 0.023_491_5],
                [0.688_118, 0.661_808, 0.651_284],
            ],
            pdf: [0.378_516, 0.366_74, 0.461_439, 0.252_501, 1.370_22],
        },
        5e-3,
    );
}

#[test]
fn rough_conductor_matches_mitsuba() {
    let mirror = Material::RoughConductor(
        RoughConductor::new(None, Spectrum::ONE, mf(BECKMANN, 0.1)).unwrap(),
    );
    let values = [7.957_75, 9.188_82, 2.910_79, 2.185_85e-17, 21.643_3];
    assert_matches_mitsuba(
        "roughconductor",
        &mirror,
        &Reference {
            eval: grey(values),
            pdf: values,
        },
        2e-3,
    );
    let gold = Material::RoughConductor(
        RoughConductor::new(ior::metal("Au").unwrap(), Spectrum::ONE, mf(GGX, 0.2)).unwrap(),
    );
    assert_matches_mitsuba(
        "roughconductor, Au, ggx 0.2",
        &gold,
        &Reference {
            eval: [
                [1.923_15, 1.595_55, 0.644_819],
                [2.205_38, 1.829_33, 0.744_342],
                [1.859_32, 1.545_45, 0.671_732],
                [0.057_178_8, 0.047_428_3, 0.019_317],
                [5.846_98, 5.127_02, 3.021_96],
            ],
            pdf: [1.989_44, 2.289_6, 1.947_72, 0.059_246_4, 6.525_11],
        },
        2e-3,
    );
}

#[test]
fn rough_dielectric_matches_mitsuba_in_reflection_and_refraction() {
    let eta = ior::dielectric("bk7").unwrap() / ior::dielectric("air").unwrap();
    let glass = RoughDielectric::new(eta, Spectrum::ONE, Spectrum::ONE, mf(BECKMANN, 0.1)).unwrap();
    let m = Material::RoughDielectric(glass);
    let values = [0.322_578, 0.386_553, 0.185_131, 9.2474e-19, 5.493_97];
    for (i, ((to, po), (ti, pi))) in PAIRS.iter().enumerate() {
        let (wo, wi) = (dir(*to, *po), dir(*ti, *pi));
        let (f, pdf) = (m.eval(wo, wi).x * wi.z, m.pdf(wo, wi));
        assert!((f - values[i]).abs() <= 2e-3 * values[i] + 1e-6, "{i}: {f}");
        assert!(
            (pdf - values[i]).abs() <= 2e-3 * values[i] + 1e-6,
            "{i}: {pdf}"
        );
    }
    // Refraction from 30 degrees outside to 20 degrees inside, in radiance mode.
    let (wo, wi) = (dir(30.0, 0.0), -dir(20.0, 0.0));
    let (f, pdf) = (m.eval(wo, wi).x * wi.z.abs(), m.pdf(wo, wi));
    assert!((f - 91.4234).abs() < 2e-3 * 91.4234, "{f}");
    assert!((pdf - 206.852).abs() < 2e-3 * 206.852, "{pdf}");
}

// ---------------------------------------------------------------------------------------------
// Nori.

/// Nori's `ttest-microfacet.xml`: the luminance of the directional albedo of Nori's microfacet
/// BRDF (Lambertian `kd` plus `ks = 1 - max(kd)` times a Beckmann microfacet lobe with a
/// dielectric Fresnel term, alpha 0.1, IOR 1.5 over 1.000277) at 0, 45, 60, 80 and 85
/// degrees, estimated here with the Beckmann sampler: its D, G1, Fresnel term and sampling
/// density must all be right to land within the t-test's tolerance.
#[test]
fn nori_microfacet_albedos() {
    let references = [0.207_067, 0.215_733, 0.247_884, 0.430_936, 0.519_016];
    let kd = crate::spectrum::rgb(0.1, 0.2, 0.15);
    let ks = 1.0 - kd.max_element();
    let eta = 1.5 / 1.000_277;
    let lum = |c: Spectrum| 0.212_671 * c.x + 0.715_160 * c.y + 0.072_169 * c.z;
    let beckmann = mf(BECKMANN, 0.1);
    for (theta, reference) in [0.0f32, 45.0, 60.0, 80.0, 85.0].iter().zip(references) {
        let wo = dir(*theta, 0.0);
        let mut s = Sampler::new(1301, 0, 0);
        let n = 400_000;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let m = beckmann.sample(wo, s.next_2d());
            let wi = reflect(wo, m);
            if wi.z <= 0.0 || wo.dot(m) <= 0.0 {
                continue;
            }
            let f = beckmann.d(m) * beckmann.g(wo, wi, m) * fresnel_dielectric(wi.dot(m), eta)
                / (4.0 * wo.z * wi.z);
            let pdf = beckmann.pdf(wo, m) / (4.0 * wo.dot(m));
            let w = (f * wi.z / pdf) as f64;
            sum += w;
            sum2 += w * w;
        }
        let mean = sum / n as f64;
        let err = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
        let albedo = lum(kd) as f64 + ks as f64 * mean;
        println!(
            "Nori microfacet at {theta}: {albedo:.6} (reference {reference}, +- {:.6})",
            ks as f64 * err
        );
        assert!(
            (albedo - reference).abs() < 3e-3 + 4.0 * ks as f64 * err,
            "at {theta} degrees: {albedo} vs Nori's {reference}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Energy.

/// `integral g(m) D_wo(m) dm` over the visible normals, by a fine midpoint rule in
/// `(theta_m, phi_m)` with `tan(theta_m)` stretched to the lobe.
fn over_visible_normals(m: &Microfacet, wo: Vec3A, g: impl Fn(Vec3A) -> f64) -> f64 {
    let (nt, np) = (600, 300);
    let s = 8.0 * m.alpha_u.max(m.alpha_v) as f64;
    let mut sum = 0.0;
    for i in 0..nt {
        let u = (i as f64 + 0.5) / nt as f64;
        let theta = (s * u / (1.0 - u)).atan();
        let dtheta = s / ((1.0 - u).powi(2) + (s * u).powi(2)) / nt as f64;
        for j in 0..np {
            let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
            let n = Vec3A::new(
                (theta.sin() * phi.cos()) as f32,
                (theta.sin() * phi.sin()) as f32,
                theta.cos() as f32,
            );
            let visible = (m.g1(wo, n) * wo.dot(n).max(0.0) * m.d(n) / wo.z) as f64;
            if visible > 0.0 {
                sum +=
                    visible * g(n) * theta.sin() * dtheta * 2.0 * std::f64::consts::PI / np as f64;
            }
        }
    }
    sum
}

/// A white rough conductor (perfect mirrors) loses exactly what single scattering loses:
/// the albedo its sampling estimates equals the fraction of visible microfacets whose
/// reflection is not shadowed, `integral D_wo(m) G1(reflect(wo, m), m) dm`, computed here
/// over the normals. It is 1 for smooth surfaces and drops with roughness and at grazing
/// angles (GGX alpha 1 at normal incidence keeps 0.31: half its normals send light below the
/// horizon).
#[test]
fn white_furnace_rough_conductor_loses_only_multiple_scattering() {
    for d in [GGX, BECKMANN] {
        for alpha in [0.05f32, 0.3, 1.0] {
            for theta in [0.0f32, 60.0, 85.0] {
                let m = mf(d, alpha);
                let c = RoughConductor::new(None, Spectrum::ONE, m).unwrap();
                let wo = dir(theta, 20.0);
                let expected = over_visible_normals(&m, wo, |n| {
                    let wi = reflect(wo, n);
                    if wi.z > 0.0 {
                        m.g1(wi, n) as f64
                    } else {
                        0.0
                    }
                });
                let (mean, err) = directional_albedo(&c, wo, 200_000, 1401);
                println!("furnace {d:?} alpha {alpha} at {theta}: {:.4} +- {:.4} (integral {expected:.4})", mean.x, err.x);
                assert!(
                    (mean.x - expected).abs() < 4.5 * err.x + 2e-3,
                    "{d:?} {alpha} {theta}: {} vs {expected}",
                    mean.x
                );
                assert!(mean.x <= 1.0 + 4.5 * err.x);
                if alpha == 0.05 && theta < 80.0 {
                    assert!(mean.x > 0.99, "smooth surfaces lose almost nothing");
                }
            }
        }
    }
}

/// A lossless rough dielectric conserves energy up to the same single-scattering loss: the
/// reflected plus transmitted power (importance weights) equals the integral over visible
/// normals of `F G1(reflected) + (1 - F) G1(refracted)`, from either side.
#[test]
fn white_furnace_rough_dielectric() {
    for d in [GGX, BECKMANN] {
        for alpha in [0.1f32, 0.5] {
            for (theta, outside) in [(0.0f32, true), (60.0, true), (30.0, false), (80.0, false)] {
                let m = mf(d, alpha);
                let glass = Material::RoughDielectric(
                    RoughDielectric::new(1.5, Spectrum::ONE, Spectrum::ONE, m).unwrap(),
                );
                let up = dir(theta, 40.0);
                let (wo, eta) = if outside { (up, 1.5) } else { (-up, 1.0 / 1.5) };
                let expected = over_visible_normals(&m, up, |n| {
                    let f = fresnel_dielectric(wo.dot(n), 1.5) as f64;
                    let r = reflect(up, n);
                    let reflected = if r.z > 0.0 {
                        f * m.g1(r, n) as f64
                    } else {
                        0.0
                    };
                    let transmitted = match refract(up, n, eta) {
                        Some(t) if t.z < 0.0 => (1.0 - f) * m.g1(t, n) as f64,
                        _ => 0.0,
                    };
                    reflected + transmitted
                });
                let mut s = Sampler::new(1402, 0, 0);
                let n = 200_000;
                let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    if let Some(b) = glass.sample(wo, s.next_1d(), s.next_2d()) {
                        let w = glass.sample_weight(wo, &b, TransportMode::Importance).x as f64;
                        sum += w;
                        sum2 += w * w;
                    }
                }
                let mean = sum / n as f64;
                let err = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                println!("furnace dielectric {d:?} {alpha} {theta} outside {outside}: {mean:.4} +- {err:.4} (integral {expected:.4})");
                assert!(
                    (mean - expected).abs() < 4.5 * err + 3e-3,
                    "{mean} vs {expected}"
                );
                assert!(mean <= 1.0 + 4.5 * err + 1e-4);
            }
        }
    }
}

/// The materials every generic check runs on.
fn all_materials() -> Vec<(&'static str, Material)> {
    let gold = ior::metal("Au").unwrap();
    let rgb = crate::spectrum::rgb(0.8, 0.4, 0.2);
    vec![
        (
            "roughconductor ggx .3 Au",
            Material::RoughConductor(
                RoughConductor::new(gold, Spectrum::ONE, mf(GGX, 0.3)).unwrap(),
            ),
        ),
        (
            "roughconductor beckmann .05",
            Material::RoughConductor(
                RoughConductor::new(None, Spectrum::ONE, mf(BECKMANN, 0.05)).unwrap(),
            ),
        ),
        (
            "roughconductor ggx .1/.6",
            Material::RoughConductor(
                RoughConductor::new(gold, Spectrum::ONE, Microfacet::new(GGX, 0.1, 0.6).unwrap())
                    .unwrap(),
            ),
        ),
        (
            "roughplastic ggx .2",
            Material::RoughPlastic(
                RoughPlastic::new(rgb, Spectrum::ONE, 1.5, false, mf(GGX, 0.2)).unwrap(),
            ),
        ),
        (
            "roughplastic beckmann .5 nonlinear",
            Material::RoughPlastic(
                RoughPlastic::new(rgb, Spectrum::ONE, 1.5, true, mf(BECKMANN, 0.5)).unwrap(),
            ),
        ),
        (
            "plastic",
            Material::Plastic(Plastic::new(rgb, Spectrum::ONE, 1.5, false).unwrap()),
        ),
        (
            "diffusetransmission",
            Material::DiffuseTransmission(
                DiffuseTransmission::new(rgb * 0.5, crate::spectrum::rgb(0.1, 0.5, 0.7)).unwrap(),
            ),
        ),
        (
            "roughdielectric ggx .3",
            Material::RoughDielectric(
                RoughDielectric::new(1.5, Spectrum::ONE, Spectrum::ONE, mf(GGX, 0.3)).unwrap(),
            ),
        ),
        (
            "roughdielectric beckmann .2",
            Material::RoughDielectric(
                RoughDielectric::new(1.33, Spectrum::ONE, Spectrum::ONE, mf(BECKMANN, 0.2))
                    .unwrap(),
            ),
        ),
    ]
}

/// Reciprocity `f(wo, wi) = f(wi, wo)` for reflection, and Walter's reciprocity for
/// refraction `f(wo, wi) / eta_i^2 = f(wi, wo) / eta_o^2` (the radiance form carries the
/// squared IOR of the side light arrives from).
#[test]
fn every_material_is_reciprocal() {
    let mut s = Sampler::new(1403, 0, 0);
    for (name, m) in all_materials() {
        for _ in 0..20_000 {
            let wo = crate::sampling::uniform_sphere(s.next_2d());
            let wi = crate::sampling::uniform_sphere(s.next_2d());
            let (a, b) = (m.eval(wo, wi), m.eval(wi, wo));
            let ratio = if wo.z * wi.z < 0.0 {
                let ior = match &m {
                    Material::RoughDielectric(d) => d.ior,
                    _ => 1.0,
                };
                // eta of wi's side over wo's side, squared.
                let eta = if wo.z > 0.0 { ior } else { 1.0 / ior };
                // Light grazing its microfacet refracts at the critical angle on the other
                // side, where the Fresnel term's slope is infinite: float rounding there
                // breaks the symmetry by up to a percent. Skip those pairs.
                let h = (wo + wi * eta).normalize();
                if wo.dot(h).abs() < 0.02 || wi.dot(h).abs() < 0.02 {
                    continue;
                }
                eta * eta
            } else {
                1.0
            };
            let (a, b) = (a * ratio, b);
            assert!(
                (a - b).abs().max_element() <= 2e-3 * a.max_element().max(b.max_element()) + 1e-6,
                "{name}: f({wo}, {wi}) = {a} vs {b}"
            );
        }
    }
}

/// No material reflects (and transmits) more power than arrives, at any incidence.
#[test]
fn every_material_conserves_energy() {
    for (name, m) in all_materials() {
        for theta in [0.0f32, 30.0, 60.0, 80.0, 89.0] {
            for side in [1.0f32, -1.0] {
                let wo = dir(theta, 70.0) * side;
                let mut s = Sampler::new(1404, 0, 0);
                let n = 50_000;
                let mut sum = Spectrum::ZERO;
                for _ in 0..n {
                    if let Some(b) = m.sample(wo, s.next_1d(), s.next_2d()) {
                        sum += m.sample_weight(wo, &b, TransportMode::Importance);
                    }
                }
                let mean = sum / n as f32;
                assert!(
                    mean.max_element() < 1.01,
                    "{name} at {theta} side {side}: {mean}"
                );
            }
        }
    }
}

/// The sampled `f` and `pdf` are exactly what `eval` and `pdf` say for the sampled direction.
#[test]
fn every_material_samples_what_it_evaluates() {
    for (name, m) in all_materials() {
        for wo in [
            dir(0.0, 0.0),
            dir(45.0, 30.0),
            dir(85.0, 200.0),
            -dir(40.0, 10.0),
        ] {
            let mut s = Sampler::new(1405, 0, 0);
            for _ in 0..5000 {
                let Some(b) = m.sample(wo, s.next_1d(), s.next_2d()) else {
                    continue;
                };
                if b.specular {
                    continue;
                }
                let (f, pdf) = (m.eval(wo, b.wi), m.pdf(wo, b.wi));
                assert!(
                    (pdf - b.pdf).abs() <= 1e-3 * pdf,
                    "{name}: pdf {pdf} vs {}",
                    b.pdf
                );
                assert!(
                    (f - b.f).abs().max_element() <= 1e-3 * f.max_element() + 1e-7,
                    "{name}"
                );
                assert!(b.weight().is_finite());
            }
        }
    }
    // The Bxdf-level helper on the upper side.
    let c = RoughConductor::new(None, Spectrum::ONE, mf(GGX, 0.4)).unwrap();
    check_sample_matches_eval(&c, dir(50.0, 10.0), 20_000, 1406);
}

// ---------------------------------------------------------------------------------------------
// Chi-square tests of the sampling routines (named chi2_*: counted in chi2::CHI2_TESTS).

fn chi2_material(name: &str, m: &Material, wo: Vec3A, grid: &Grid, seed: u64) {
    assert_chi2(
        name,
        grid,
        SAMPLES,
        seed,
        |s| {
            m.sample(wo, s.next_1d(), s.next_2d())
                .filter(|b| !b.specular)
                .map(|b| b.wi)
        },
        |w| m.pdf(wo, w),
    );
}

fn rough_conductor(d: Distribution, au: f32, av: f32) -> Material {
    Material::RoughConductor(
        RoughConductor::new(None, Spectrum::ONE, Microfacet::new(d, au, av).unwrap()).unwrap(),
    )
}

#[test]
fn chi2_rough_conductor_ggx() {
    let m = rough_conductor(GGX, 0.5, 0.5);
    chi2_material(
        "roughconductor ggx .5 wo 60",
        &m,
        dir(60.0, 30.0),
        &Grid::hemisphere(20, 40),
        1501,
    );
}

#[test]
fn chi2_rough_conductor_ggx_narrow() {
    let m = rough_conductor(GGX, 0.05, 0.05);
    let wo = dir(30.0, 0.0);
    let r = Vec3A::new(-wo.x, -wo.y, wo.z);
    chi2_material(
        "roughconductor ggx .05 wo 30",
        &m,
        wo,
        &Grid::new(r, 0.05, 20, 40),
        1502,
    );
}

#[test]
fn chi2_rough_conductor_anisotropic_grazing() {
    let m = rough_conductor(GGX, 0.1, 0.4);
    chi2_material(
        "roughconductor ggx .1/.4 wo 85",
        &m,
        dir(85.0, 60.0),
        &Grid::hemisphere(30, 60),
        1503,
    );
}

#[test]
fn chi2_rough_conductor_beckmann() {
    let m = rough_conductor(BECKMANN, 0.3, 0.3);
    chi2_material(
        "roughconductor beckmann .3 wo 45",
        &m,
        dir(45.0, 90.0),
        &Grid::hemisphere(20, 40),
        1504,
    );
}

#[test]
fn chi2_rough_conductor_beckmann_grazing() {
    let m = rough_conductor(BECKMANN, 0.2, 0.2);
    chi2_material(
        "roughconductor beckmann .2 wo 80",
        &m,
        dir(80.0, 10.0),
        &Grid::hemisphere(30, 60),
        1505,
    );
}

fn rough_dielectric(d: Distribution, a: f32, ior: f32) -> Material {
    Material::RoughDielectric(
        RoughDielectric::new(ior, Spectrum::ONE, Spectrum::ONE, mf(d, a)).unwrap(),
    )
}

#[test]
fn chi2_rough_dielectric_from_outside() {
    let m = rough_dielectric(GGX, 0.3, 1.5);
    chi2_material(
        "roughdielectric ggx .3 outside wo 40",
        &m,
        dir(40.0, 0.0),
        &Grid::sphere(30, 40),
        1506,
    );
}

#[test]
fn chi2_rough_dielectric_from_inside() {
    let m = rough_dielectric(BECKMANN, 0.2, 1.5);
    chi2_material(
        "roughdielectric beckmann .2 inside wo 20",
        &m,
        -dir(20.0, 50.0),
        &Grid::sphere(30, 40),
        1507,
    );
}

#[test]
fn chi2_rough_dielectric_grazing() {
    let m = rough_dielectric(GGX, 0.5, 1.33);
    chi2_material(
        "roughdielectric ggx .5 outside wo 85",
        &m,
        dir(85.0, 120.0),
        &Grid::sphere(30, 40),
        1508,
    );
}

#[test]
fn chi2_rough_plastic() {
    let m = Material::RoughPlastic(
        RoughPlastic::new(
            crate::spectrum::rgb(0.5, 0.4, 0.3),
            Spectrum::ONE,
            1.5,
            false,
            mf(GGX, 0.2),
        )
        .unwrap(),
    );
    chi2_material(
        "roughplastic ggx .2 wo 30",
        &m,
        dir(30.0, 0.0),
        &Grid::hemisphere(20, 40),
        1509,
    );
}

#[test]
fn chi2_rough_plastic_grazing() {
    let m = Material::RoughPlastic(
        RoughPlastic::new(
            Spectrum::splat(0.3),
            Spectrum::ONE,
            1.5,
            true,
            mf(BECKMANN, 0.5),
        )
        .unwrap(),
    );
    chi2_material(
        "roughplastic beckmann .5 wo 80",
        &m,
        dir(80.0, 0.0),
        &Grid::hemisphere(20, 40),
        1510,
    );
}

#[test]
fn chi2_plastic_base() {
    // The coating's reflection is a delta (not histogrammed: it counts as rejected), so the
    // base's density integrates to the probability of choosing it.
    let m =
        Material::Plastic(Plastic::new(Spectrum::splat(0.5), Spectrum::ONE, 1.5, false).unwrap());
    chi2_material(
        "plastic base wo 50",
        &m,
        dir(50.0, 0.0),
        &Grid::hemisphere(20, 40),
        1511,
    );
}

/// Every model's declared lobes say what it does: it sends paths to the other side exactly
/// when it declares a transmission lobe, it samples a delta lobe exactly when it declares one,
/// and a lobe with a density exactly when it declares a non-delta lobe. (The lobes are what integrators ask: a new model that declared them wrong
/// would be traced wrong.)
#[test]
fn every_model_declares_the_lobes_it_samples() {
    let rgb = crate::spectrum::rgb(0.8, 0.4, 0.2);
    let mut materials = all_materials();
    materials.extend([
        ("lambert", Material::Lambert(Lambert::new(rgb).unwrap())),
        ("oren-nayar", Material::OrenNayar(OrenNayar::new(rgb, 20.0))),
        (
            "phong",
            Material::Phong(Phong {
                kd: rgb * 0.5,
                ks: Spectrum::splat(0.3),
                exponent: 20.0,
            }),
        ),
        (
            "dielectric",
            Material::Dielectric(Dielectric::new(1.5, Spectrum::ONE, Spectrum::ONE).unwrap()),
        ),
        (
            "thindielectric",
            Material::ThinDielectric(
                ThinDielectric::new(1.5, Spectrum::ONE, Spectrum::ONE).unwrap(),
            ),
        ),
        (
            "conductor",
            Material::Conductor(Conductor::new(None, Spectrum::ONE).unwrap()),
        ),
        ("hair", Material::Hair(Hair::default().with_h(0.3))),
    ]);
    for (name, m) in &materials {
        let lobes = m.lobes();
        let (mut through, mut delta, mut smooth) = (false, false, false);
        let mut s = Sampler::new(7, 0, 0);
        let wo = dir(35.0, 20.0);
        for _ in 0..4000 {
            let (u_lobe, u) = (s.next_1d(), s.next_2d());
            let Some(b) = m.sample(wo, u_lobe, u) else {
                continue;
            };
            through |= b.wi.z * wo.z < 0.0;
            if b.specular {
                delta = true;
            } else {
                // A sample of a non-delta lobe has the density the model evaluates.
                assert!(
                    m.pdf(wo, b.wi) > 0.0,
                    "{name}: a smooth sample of no density"
                );
                smooth = true;
            }
        }
        assert_eq!(
            through,
            lobes.any(Lobes::TRANSMISSION),
            "{name}: transmission"
        );
        assert_eq!(delta, lobes.any(Lobes::DELTA), "{name}: delta lobes");
        assert_eq!(smooth, !lobes.only(Lobes::DELTA), "{name}: non-delta lobes");
    }
}
