//! Material descriptions to materials: each model's constructor checks its constant
//! parameters; textured ones are checked over their whole range, and the material's constant
//! form takes their means (as Mitsuba 3 makes its sampling weights from them).

use super::textures::{Role, TextureLoader};
use crate::formats::schema::{MaterialDesc, Metal};
use crate::formats::texture_desc::{ColorDesc, FloatDesc};
use glam::Vec3A;
use raylab_integrators::bsdf::spectral::MaterialSpectra;
use raylab_integrators::bsdf::{
    checks, relative_ior, Burley, ComplexIor, Conductor, Dielectric, DiffuseTransmission,
    Distribution, Hair, Lambert, MapOptions, MaterialTextures, Microfacet, OrenNayar, Perturbation,
    Phong, Plastic, Principled, PrincipledRates, PrincipledTextures, PrincipledThin,
    RoughConductor, RoughDielectric, RoughPlastic, RoughnessTextures, SurfaceMaterial,
    ThinDielectric, ThinRates,
};
use raylab_integrators::spectrum::curve::Curve;
use raylab_integrators::spectrum::{named, of_rgb, rgb_of};
use raylab_integrators::texture::Texture;
use raylab_integrators::Material;
use raylab_integrators::Spectrum;

fn v3(a: [f32; 3]) -> Vec3A {
    Vec3A::from_array(a)
}

/// A colour as the materials hold it (RGB mode's [`Spectrum`]).
fn s3(a: [f32; 3]) -> Spectrum {
    of_rgb(v3(a))
}

/// Turns a material description into the scene's material, reading its textures with
/// `textures`.
pub fn material_from_desc(
    desc: &MaterialDesc,
    textures: &mut TextureLoader,
) -> Result<SurfaceMaterial, String> {
    let mut t = MaterialTextures::default();
    let mut s = MaterialSpectra::default();
    // A colour parameter: its constant (a texture's mean, a spectrum's colour), its texture
    // kept in `slot`, a spectrum given by wavelength in `spectrum`.
    let mut colour =
        |desc: &ColorDesc, role: Role, slot: &mut Option<Texture>, spectrum: &mut Option<Curve>| {
            let (c, texture, curve) = textures.colour_or_spectrum(desc, role)?;
            *slot = texture;
            *spectrum = curve;
            Ok::<_, String>(of_rgb(c))
        };
    let bsdf = match desc {
        MaterialDesc::Null => return Ok(SurfaceMaterial::null()),
        MaterialDesc::Lambert { albedo } => Material::Lambert(Lambert::new(colour(
            albedo,
            Role::Reflectance,
            &mut t.diffuse,
            &mut s.diffuse,
        )?)?),
        MaterialDesc::DiffuseTransmission {
            reflectance,
            transmittance,
        } => {
            let r = colour(
                reflectance,
                Role::Reflectance,
                &mut t.diffuse,
                &mut s.diffuse,
            )?;
            let tr = colour(
                transmittance,
                Role::Reflectance,
                &mut t.transmittance,
                &mut s.transmittance,
            )?;
            // Energy holds at every point: the largest reflectance + transmittance.
            let max =
                |tex: &Option<Texture>, c: Spectrum| tex.as_ref().map_or(rgb_of(c), |x| x.max());
            if (max(&t.diffuse, r) + max(&t.transmittance, tr)).max_element() > 1.0 + 1e-6 {
                return Err("reflectance + transmittance exceed 1 (somewhere): diffuse transmission would create energy".into());
            }
            Material::DiffuseTransmission(DiffuseTransmission::new(r, tr)?)
        }
        MaterialDesc::OrenNayar { albedo, sigma } => Material::OrenNayar(OrenNayar::checked(
            colour(albedo, Role::Reflectance, &mut t.diffuse, &mut s.diffuse)?,
            *sigma,
        )?),
        MaterialDesc::Phong { kd, ks, exponent } => {
            let kd = colour(kd, Role::Reflectance, &mut t.diffuse, &mut s.diffuse)?;
            let ks = colour(ks, Role::Reflectance, &mut t.specular, &mut s.specular)?;
            // Energy holds at every point: the largest kd + ks, not the means'.
            let max =
                |tex: &Option<Texture>, c: Spectrum| tex.as_ref().map_or(rgb_of(c), |x| x.max());
            if (t.diffuse.is_some() || t.specular.is_some())
                && (max(&t.diffuse, kd) + max(&t.specular, ks)).max_element() > 1.0 + 1e-6
            {
                return Err(
                    "the textures' kd + ks exceed 1 somewhere: Phong would create energy".into(),
                );
            }
            Material::Phong(Phong::new(kd, ks, *exponent)?)
        }
        MaterialDesc::Mirror { tint } => Material::Conductor(Conductor::new(
            None,
            checks::reflectance("tint", s3(*tint))?,
        )?),
        MaterialDesc::Glass { ior, tint } => {
            Material::Dielectric(Dielectric::new(*ior, s3(*tint), s3(*tint))?)
        }
        MaterialDesc::Dielectric {
            int_ior,
            ext_ior,
            specular_reflectance: r,
            specular_transmittance: tr,
            dispersion,
        } => {
            if let Some(d) = dispersion {
                s.ior = Some((d.curve()?, ext_ior.0));
            }
            Material::Dielectric(Dielectric::new(
                relative_ior(int_ior.0, ext_ior.0)?,
                colour(r, Role::Reflectance, &mut t.specular, &mut s.specular)?,
                colour(
                    tr,
                    Role::Reflectance,
                    &mut t.transmittance,
                    &mut s.transmittance,
                )?,
            )?)
        }
        MaterialDesc::RoughDielectric {
            int_ior,
            ext_ior,
            specular_reflectance: r,
            specular_transmittance: tr,
            distribution,
            alpha,
            alpha_u,
            alpha_v,
        } => {
            let r = colour(r, Role::Reflectance, &mut t.specular, &mut s.specular)?;
            let tr = colour(
                tr,
                Role::Reflectance,
                &mut t.transmittance,
                &mut s.transmittance,
            )?;
            Material::RoughDielectric(RoughDielectric::new(
                relative_ior(int_ior.0, ext_ior.0)?,
                r,
                tr,
                microfacet(*distribution, [alpha, alpha_u, alpha_v], textures, &mut t)?,
            )?)
        }
        MaterialDesc::ThinDielectric {
            int_ior,
            ext_ior,
            specular_reflectance: r,
            specular_transmittance: tr,
        } => Material::ThinDielectric(ThinDielectric::new(
            relative_ior(int_ior.0, ext_ior.0)?,
            colour(r, Role::Reflectance, &mut t.specular, &mut s.specular)?,
            colour(
                tr,
                Role::Reflectance,
                &mut t.transmittance,
                &mut s.transmittance,
            )?,
        )?),
        MaterialDesc::Conductor {
            metal,
            eta,
            k,
            specular_reflectance,
        } => Material::Conductor(Conductor::new(
            complex_ior(*metal, *eta, *k, &mut s)?,
            colour(
                specular_reflectance,
                Role::Reflectance,
                &mut t.specular,
                &mut s.specular,
            )?,
        )?),
        MaterialDesc::RoughConductor {
            metal,
            eta,
            k,
            specular_reflectance,
            distribution,
            alpha,
            alpha_u,
            alpha_v,
        } => {
            let r = colour(
                specular_reflectance,
                Role::Reflectance,
                &mut t.specular,
                &mut s.specular,
            )?;
            Material::RoughConductor(RoughConductor::new(
                complex_ior(*metal, *eta, *k, &mut s)?,
                r,
                microfacet(*distribution, [alpha, alpha_u, alpha_v], textures, &mut t)?,
            )?)
        }
        MaterialDesc::Plastic {
            diffuse_reflectance,
            specular_reflectance,
            int_ior,
            ext_ior,
            nonlinear,
        } => Material::Plastic(Plastic::new(
            colour(
                diffuse_reflectance,
                Role::Reflectance,
                &mut t.diffuse,
                &mut s.diffuse,
            )?,
            colour(
                specular_reflectance,
                Role::Reflectance,
                &mut t.specular,
                &mut s.specular,
            )?,
            relative_ior(int_ior.0, ext_ior.0)?,
            *nonlinear,
        )?),
        MaterialDesc::RoughPlastic {
            diffuse_reflectance,
            specular_reflectance,
            int_ior,
            ext_ior,
            nonlinear,
            distribution,
            alpha,
        } => {
            let FloatDesc::Constant(alpha) = *alpha else {
                return Err(
                    "RoughPlastic's alpha must be a number: the coating's tables are \
                            made for one roughness, as in Mitsuba's roughplastic"
                        .into(),
                );
            };
            Material::RoughPlastic(RoughPlastic::new(
                colour(
                    diffuse_reflectance,
                    Role::Reflectance,
                    &mut t.diffuse,
                    &mut s.diffuse,
                )?,
                colour(
                    specular_reflectance,
                    Role::Reflectance,
                    &mut t.specular,
                    &mut s.specular,
                )?,
                relative_ior(int_ior.0, ext_ior.0)?,
                *nonlinear,
                alphas(*distribution, (alpha, alpha))?,
            )?)
        }
        MaterialDesc::Principled {
            base_color,
            roughness,
            anisotropic,
            metallic,
            spec_trans,
            spec_tint,
            sheen,
            sheen_tint,
            flatness,
            clearcoat,
            clearcoat_gloss,
            eta,
            specular,
        } => {
            let mut p = PrincipledTextures::default();
            let (burley, transmits) = burley(
                BurleyDescs {
                    base_color,
                    roughness,
                    anisotropic,
                    spec_trans,
                    spec_tint,
                    sheen,
                    sheen_tint,
                    flatness,
                },
                textures,
                (&mut t.diffuse, &mut s.diffuse),
                &mut p,
            )?;
            let metallic = weight(metallic, textures, &mut p.metallic, 1.0)?;
            let clearcoat = weight(clearcoat, textures, &mut p.clearcoat, 1.0)?;
            let gloss = weight(clearcoat_gloss, textures, &mut p.clearcoat_gloss, 1.0)?;
            let eta = match (eta, specular) {
                (Some(_), Some(_)) => return Err("give `eta` or `specular`, not both".into()),
                (Some(eta), None) => *eta,
                (None, specular) => {
                    let s = specular.unwrap_or(0.5);
                    if !(0.0..=1.0).contains(&s) {
                        return Err(format!("`specular` must lie in [0, 1], got {s}"));
                    }
                    Principled::eta_from_specular(s, transmits)
                }
            };
            t.principled = p.any().then(|| Box::new(p));
            Material::Principled(Principled::new(
                burley,
                metallic,
                clearcoat,
                gloss,
                eta,
                transmits,
                PrincipledRates::default(),
            )?)
        }
        MaterialDesc::PrincipledThin {
            base_color,
            roughness,
            anisotropic,
            spec_trans,
            spec_tint,
            sheen,
            sheen_tint,
            flatness,
            diff_trans,
            eta,
        } => {
            let mut p = PrincipledTextures::default();
            let (burley, _) = burley(
                BurleyDescs {
                    base_color,
                    roughness,
                    anisotropic,
                    spec_trans,
                    spec_tint,
                    sheen,
                    sheen_tint,
                    flatness,
                },
                textures,
                (&mut t.diffuse, &mut s.diffuse),
                &mut p,
            )?;
            let diff_trans = weight(diff_trans, textures, &mut p.diff_trans, 2.0)?;
            t.principled = p.any().then(|| Box::new(p));
            Material::PrincipledThin(PrincipledThin::new(
                burley,
                diff_trans,
                *eta,
                ThinRates::default(),
            )?)
        }
        MaterialDesc::Hair {
            sigma_a,
            reflectance,
            eumelanin,
            pheomelanin,
            eta,
            beta_m,
            beta_n,
            alpha,
        } => Material::Hair(Hair::new(
            0.0,
            *eta,
            hair_absorption(*sigma_a, *reflectance, *eumelanin, *pheomelanin, *beta_n)?,
            *beta_m,
            *beta_n,
            *alpha,
        )?),
        MaterialDesc::OneSided(inner) => {
            let m = material_from_desc(inner, textures)?;
            if m.bsdf().is_transmissive() {
                return Err(
                    "OneSided holds an opaque material: a dielectric has two sides of its own"
                        .into(),
                );
            }
            return Ok(m.with_one_sided());
        }
        MaterialDesc::TwoSided(inner) => {
            let m = material_from_desc(inner, textures)?;
            if m.bsdf().is_transmissive() {
                return Err(
                    "TwoSided cannot hold a dielectric: it has two sides of its own".into(),
                );
            }
            return Ok(m);
        }
        MaterialDesc::NormalMap {
            texture,
            material,
            flip_invalid_normals,
            shadowing,
        } => {
            let map = match texture {
                ColorDesc::Constant(c) => Texture::Constant(v3(*c)),
                ColorDesc::Spectrum(p) => Texture::Constant(v3(ColorDesc::spectrum_colour(p))),
                ColorDesc::Texture(t) => textures.texture(t, Role::Data)?,
            };
            let options = MapOptions {
                flip_invalid_normals: *flip_invalid_normals,
                shadowing: *shadowing,
            };
            return perturbed(material, Perturbation::NormalMap(map), options, textures);
        }
        MaterialDesc::Mask { opacity, material } => {
            let opacity = match opacity {
                FloatDesc::Constant(a) if (0.0..=1.0).contains(a) => {
                    Texture::Constant(Vec3A::splat(*a))
                }
                FloatDesc::Constant(a) => {
                    return Err(format!("a mask's opacity must lie in [0, 1], got {a}"))
                }
                FloatDesc::Texture(t) => textures.texture(t, Role::Reflectance)?,
            };
            let m = material_from_desc(material, textures)?;
            if m.opacity().is_some() {
                return Err("a material takes one mask, not one inside another".into());
            }
            return Ok(m.with_opacity(opacity));
        }
        MaterialDesc::Cutout { alpha, material } => {
            let alpha = match alpha {
                FloatDesc::Constant(a) if a.is_finite() => Texture::Constant(Vec3A::splat(*a)),
                FloatDesc::Constant(a) => {
                    return Err(format!("an alpha cut-out must be a finite number, got {a}"))
                }
                FloatDesc::Texture(t) => textures.texture(t, Role::Reflectance)?,
            };
            let m = material_from_desc(material, textures)?;
            if m.cutout().is_some() {
                return Err("a material takes one alpha cut-out, not one inside another".into());
            }
            return Ok(m.with_cutout(alpha));
        }
        MaterialDesc::BumpMap {
            texture,
            scale,
            material,
            flip_invalid_normals,
            shadowing,
        } => {
            if !scale.is_finite() {
                return Err(format!("a bump map's scale must be finite, got {scale}"));
            }
            let height = match texture {
                FloatDesc::Constant(x) => Texture::Constant(Vec3A::splat(*x)),
                FloatDesc::Texture(t) => textures.texture(t, Role::Data)?,
            };
            let map = Perturbation::BumpMap {
                height,
                scale: *scale,
            };
            let options = MapOptions {
                flip_invalid_normals: *flip_invalid_normals,
                shadowing: *shadowing,
            };
            return perturbed(material, map, options, textures);
        }
    };
    Ok(SurfaceMaterial::new(bsdf, t, None).with_spectra(s))
}

/// A hair fibre's absorption from the one way the description gives it: `sigma_a` itself, a
/// `reflectance` (Chiang's fit, for azimuthal roughness `beta_n`), or the melanin
/// concentrations; none is eumelanin 1.3, pbrt-v4's brown.
fn hair_absorption(
    sigma_a: Option<[f32; 3]>,
    reflectance: Option<[f32; 3]>,
    eumelanin: Option<f32>,
    pheomelanin: Option<f32>,
    beta_n: f32,
) -> Result<Spectrum, String> {
    let melanin = eumelanin.is_some() || pheomelanin.is_some();
    let given = [sigma_a.is_some(), reflectance.is_some(), melanin];
    if given.iter().filter(|g| **g).count() > 1 {
        return Err(
            "a hair's absorption comes from one of `sigma_a`, `reflectance`, or \
             `eumelanin` and `pheomelanin`: give one"
                .into(),
        );
    }
    if let Some(s) = sigma_a {
        return checks::colour("hair's sigma_a", s3(s));
    }
    if let Some(r) = reflectance {
        let r = checks::reflectance("hair's reflectance", s3(r))?;
        checks::finite("hair's beta_n", &[beta_n])?;
        return Ok(Hair::sigma_a_from_reflectance(r, beta_n.clamp(0.0, 1.0)));
    }
    let (e, p) = (eumelanin.unwrap_or(0.0), pheomelanin.unwrap_or(0.0));
    for (what, c) in [("eumelanin", e), ("pheomelanin", p)] {
        if !(c.is_finite() && c >= 0.0) {
            return Err(format!(
                "hair's {what} concentration must be finite and not negative, got {c}"
            ));
        }
    }
    Ok(if melanin {
        Hair::sigma_a_from_concentration(e, p)
    } else {
        Hair::sigma_a_from_concentration(1.3, 0.0)
    })
}

/// The principled models' shared parameters as the description gives them.
struct BurleyDescs<'a> {
    base_color: &'a ColorDesc,
    roughness: &'a FloatDesc,
    anisotropic: &'a Option<FloatDesc>,
    spec_trans: &'a Option<FloatDesc>,
    spec_tint: &'a Option<FloatDesc>,
    sheen: &'a Option<FloatDesc>,
    sheen_tint: &'a Option<FloatDesc>,
    flatness: &'a Option<FloatDesc>,
}

/// The base layer of a principled model, its textures kept in `base` (with the base colour's
/// spectrum, if given by wavelength) and `p`, and whether it transmits (`spec_trans` given and
/// not the number 0, as Mitsuba decides).
fn burley(
    d: BurleyDescs,
    textures: &mut TextureLoader,
    base: (&mut Option<Texture>, &mut Option<Curve>),
    p: &mut PrincipledTextures,
) -> Result<(Burley, bool), String> {
    let (base_color, texture, spectrum) =
        textures.colour_or_spectrum(d.base_color, Role::Reflectance)?;
    *base.0 = texture;
    *base.1 = spectrum;
    let (roughness, texture) = textures.scalar(d.roughness, Role::Roughness)?;
    if let Some(t) = &texture {
        if t.max().max_element() > 1.0 + 1e-6 {
            return Err("`roughness` must lie in [0, 1]; its texture exceeds 1".into());
        }
    }
    p.roughness = texture;
    let transmits = match d.spec_trans {
        None => false,
        Some(FloatDesc::Constant(x)) => *x != 0.0,
        Some(FloatDesc::Texture(_)) => true,
    };
    let burley = Burley {
        base_color: of_rgb(base_color),
        roughness,
        anisotropic: weight(d.anisotropic, textures, &mut p.anisotropic, 1.0)?,
        spec_trans: weight(d.spec_trans, textures, &mut p.spec_trans, 1.0)?,
        spec_tint: weight(d.spec_tint, textures, &mut p.spec_tint, 1.0)?,
        sheen: weight(d.sheen, textures, &mut p.sheen, 1.0)?,
        sheen_tint: weight(d.sheen_tint, textures, &mut p.sheen_tint, 1.0)?,
        flatness: weight(d.flatness, textures, &mut p.flatness, 1.0)?,
    };
    burley.check()?;
    Ok((burley, transmits))
}

/// A principled weight in `[0, max]` (0 when absent): its constant (a texture's mean), its
/// texture kept in `slot`.
fn weight(
    desc: &Option<FloatDesc>,
    textures: &mut TextureLoader,
    slot: &mut Option<Texture>,
    max: f32,
) -> Result<f32, String> {
    let Some(desc) = desc else {
        return Ok(0.0);
    };
    let role = if max > 1.0 {
        Role::Roughness
    } else {
        Role::Reflectance
    };
    let (x, texture) = textures.scalar(desc, role)?;
    if let Some(t) = &texture {
        if t.max().max_element() > max + 1e-6 {
            return Err(format!("a principled weight's texture exceeds {max}"));
        }
    }
    *slot = texture;
    Ok(x)
}

/// `inner` under the normal or bump map `map`: one map per material.
fn perturbed(
    inner: &MaterialDesc,
    map: Perturbation,
    options: MapOptions,
    textures: &mut TextureLoader,
) -> Result<SurfaceMaterial, String> {
    let m = material_from_desc(inner, textures)?;
    if m.perturbation().is_some() {
        return Err("a material takes one normal or bump map, not one inside another".into());
    }
    Ok(m.with_perturbation(map, options))
}

/// The microfacet distribution of roughnesses `(alpha_u, alpha_v)`.
fn alphas(distribution: Distribution, (u, v): (f32, f32)) -> Result<Microfacet, String> {
    Microfacet::new(distribution, u, v)
}

/// The roughness of a rough material from `[alpha, alpha_u, alpha_v]`: `alpha`, or `alpha_u`
/// and `alpha_v` (anisotropic), or Mitsuba's default 0.1; textured ones are kept in `t`, and
/// the distribution made from their means.
fn microfacet(
    distribution: Distribution,
    [alpha, alpha_u, alpha_v]: [&Option<FloatDesc>; 3],
    textures: &mut TextureLoader,
    t: &mut MaterialTextures,
) -> Result<Microfacet, String> {
    let mut scalar = |d: &FloatDesc| textures.scalar(d, Role::Roughness);
    let ((u, tu), (v, tv)) = match (alpha, alpha_u, alpha_v) {
        (Some(a), None, None) => {
            let (a, texture) = scalar(a)?;
            // One texture for both tangents, looked up once per hit.
            t.alpha = texture.map(RoughnessTextures::Isotropic);
            ((a, t.alpha.is_some()), (a, t.alpha.is_some()))
        }
        (None, Some(u), Some(v)) => {
            let ((u, tu), (v, tv)) = (scalar(u)?, scalar(v)?);
            let textured = (tu.is_some(), tv.is_some());
            if tu.is_some() || tv.is_some() {
                t.alpha = Some(RoughnessTextures::Anisotropic { u: tu, v: tv });
            }
            ((u, textured.0), (v, textured.1))
        }
        (None, None, None) => ((0.1, false), (0.1, false)),
        (Some(_), _, _) => return Err("give alpha, or alpha_u and alpha_v, not both".into()),
        _ => return Err("an anisotropic roughness needs both alpha_u and alpha_v".into()),
    };
    // A texture's mean may be 0 (a black roughness map); its lookups are kept at the
    // smallest roughness, and so is its constant form.
    let floor = |a: f32, textured: bool| {
        if textured {
            a.max(raylab_integrators::bsdf::microfacet::MIN_ALPHA)
        } else {
            a
        }
    };
    alphas(distribution, (floor(u, tu), floor(v, tv)))
}

/// A conductor's complex IOR: a named `metal` (with its measured spectra in `spectra`
/// where there are some), or `eta` and `k`, or (neither) a perfect mirror.
fn complex_ior(
    metal: Option<Metal>,
    eta: Option<[f32; 3]>,
    k: Option<[f32; 3]>,
    spectra: &mut MaterialSpectra,
) -> Result<Option<ComplexIor>, String> {
    match (metal, eta, k) {
        (Some(m), None, None) => {
            if let Some((eta, k)) = named::metal(m.name) {
                spectra.eta = Some(eta);
                spectra.k = Some(k);
            }
            Ok(m.ior)
        }
        (None, Some(eta), Some(k)) => Ok(Some(ComplexIor::new(s3(eta), s3(k))?)),
        (None, None, None) => Ok(None),
        (Some(_), _, _) => Err("give a metal by name, or eta and k, not both".into()),
        _ => Err("a conductor's IOR needs both eta and k".into()),
    }
}
