//! pbrt-v4's materials and textures as raylab's materials and colours (pbrt-v4's
//! `materials.cpp`: each material's `Create` and its parameters' defaults).

use super::params::{Colour, Located, ParamList};
use super::tokens::Pos;
use crate::formats::schema::{
    self, ColorDesc, DispersionDesc, FloatDesc, Ior, MaterialDesc, Metal,
};
use raylab_integrators::bsdf::Distribution;
use std::collections::HashMap;

/// What the conversion notes: a changed convention (report) or an approximation (report and
/// warning, and only with `--approximate`).
pub trait Notes {
    fn report(&mut self, line: String);
    /// An approximation at `pos`: an error unless `--approximate`, else noted.
    fn approximate(&mut self, pos: Pos, what: String) -> Result<(), Located>;
}

/// The named textures: colours (spectrum textures) and numbers or textures (float
/// textures), by name.
#[derive(Default)]
pub struct Textures {
    pub spectrum: HashMap<String, ColorDesc>,
    pub float: HashMap<String, FloatDesc>,
}

/// A rough model's roughness: pbrt-v4's is GGX's, isotropic or not.
pub struct Roughness {
    pub alpha: Option<FloatDesc>,
    pub alpha_u: Option<FloatDesc>,
    pub alpha_v: Option<FloatDesc>,
}

/// A colour of three equal parts.
fn grey(x: f32) -> ColorDesc {
    ColorDesc::Constant([x; 3])
}

/// pbrt-v4's named glasses by their refractive index at the sodium d-line (587.6 nm): what
/// RGB mode uses for all wavelengths. Spectral mode disperses light through a smooth
/// dielectric of these by pbrt-v4's measured tables, as pbrt-v4 does.
const GLASSES: [(&str, f32); 7] = [
    ("glass-BK7", 1.5168),
    ("glass-BAF10", 1.6700),
    ("glass-FK51A", 1.4866),
    ("glass-LASF9", 1.8503),
    ("glass-F5", 1.6034),
    ("glass-F10", 1.7283),
    ("glass-F11", 1.7847),
];

/// pbrt-v4's named metals (`metal-Cu-eta` / `metal-Cu-k`): all seven are in raylab's metal
/// table, with pbrt-v4's measured spectra for spectral mode.
const METALS: [&str; 7] = raylab_integrators::spectrum::named::METALS;

/// A colour: a constant or a texture of `textures`.
pub fn colour(
    c: &Colour,
    pos: Pos,
    what: &str,
    textures: &Textures,
    notes: &mut dyn Notes,
) -> Result<ColorDesc, Located> {
    Ok(match c {
        Colour::Rgb(rgb) => ColorDesc::Constant(rgb.map(|x| x as f32)),
        Colour::Texture(name) => textures.spectrum.get(name).cloned().ok_or_else(|| {
            (pos, format!("{what}: no spectrum texture is named \"{name}\" (textures must be defined before they are used)"))
        })?,
        Colour::Sampled(pairs) if pairs.iter().all(|p| p.1 == pairs[0].1) => {
            grey(pairs[0].1 as f32)
        }
        Colour::Sampled(pairs) if pairs.iter().all(|p| (0.0..=1.0).contains(&p.1)) => {
            raylab_integrators::spectrum::curve::Curve::table(&crate::formats::texture_desc::narrow(pairs))
                .map_err(|e| (pos, format!("{what}: {e}")))?;
            ColorDesc::Spectrum(pairs.clone())
        }
        Colour::Sampled(pairs) => {
            let rgb = crate::formats::spectra::to_srgb(pairs, crate::formats::spectra::Use::Reflectance)
                .map_err(|e| (pos, format!("{what}: {e}")))?;
            notes.approximate(
                pos,
                format!("{what}: a spectrum by wavelength above 1, rendered as its RGB under D65, clamped ({:.4}, {:.4}, {:.4})", rgb[0], rgb[1], rgb[2]),
            )?;
            ColorDesc::Constant(rgb.map(|x| x as f32))
        }
        Colour::Named(name) => {
            return Err((pos, format!("{what}: the named spectrum \"{name}\" is not a colour raylab has")))
        }
        Colour::Blackbody(t) => {
            notes.approximate(pos, format!("{what}: a blackbody of {t} K, replaced by white (raylab has no blackbody spectra yet)"))?;
            grey(1.0)
        }
    })
}

/// A roughness parameter (`roughness`, `uroughness`, `vroughness`) as an alpha, remapped by
/// pbrt-v4's `RoughnessToAlpha` (the square root) when `remap`; with the constant's value
/// (1 for a texture).
fn alpha(
    p: &mut ParamList,
    name: &str,
    remap: bool,
    textures: &Textures,
) -> Result<Option<(FloatDesc, f64)>, Located> {
    match p.float_or_texture(name)? {
        None => Ok(None),
        Some((Colour::Rgb(v), _)) => {
            let a = if remap { v[0].max(0.0).sqrt() } else { v[0] };
            Ok(Some((FloatDesc::Constant(a as f32), a)))
        }
        Some((Colour::Texture(t), pos)) => {
            if remap {
                return Err((pos, format!("{}: a roughness texture with remaproughness true is not supported (give \"bool remaproughness\" false and a texture of alphas)", p.what)));
            }
            let tex = textures.float.get(&t).cloned().ok_or_else(|| {
                (
                    pos,
                    format!("{}: no float texture is named \"{t}\"", p.what),
                )
            })?;
            Ok(Some((tex, 1.0)))
        }
        Some((_, pos)) => Err((
            pos,
            format!("{}: `{name}` must be a float or a texture", p.what),
        )),
    }
}

/// The `alpha`, or `alpha_u` and `alpha_v`, of a rough material; `None` when smooth.
fn roughness(p: &mut ParamList, textures: &Textures) -> Result<Option<Roughness>, Located> {
    let remap = p.boolean("remaproughness")?.unwrap_or(true);
    let r = alpha(p, "roughness", remap, textures)?;
    let u = alpha(p, "uroughness", remap, textures)?;
    let v = alpha(p, "vroughness", remap, textures)?;
    let (u, v) = match (u, v) {
        (None, None) => match r {
            None => return Ok(None),
            Some(r) => (r.clone(), r),
        },
        (u, v) => {
            let r = r.unwrap_or((FloatDesc::Constant(0.0), 0.0));
            (u.unwrap_or_else(|| r.clone()), v.unwrap_or(r))
        }
    };
    if u.1 == 0.0 && v.1 == 0.0 {
        return Ok(None);
    }
    Ok(Some(if u.0 == v.0 {
        Roughness {
            alpha: Some(u.0),
            alpha_u: None,
            alpha_v: None,
        }
    } else {
        Roughness {
            alpha: None,
            alpha_u: Some(u.0),
            alpha_v: Some(v.0),
        }
    }))
}

/// A dielectric's `eta`, and its dispersion where it is one of pbrt-v4's named glasses.
fn eta(p: &mut ParamList, notes: &mut dyn Notes) -> Result<(Ior, Option<DispersionDesc>), Located> {
    let given = p.colour("eta")?;
    if let Some((Colour::Named(name), _)) = &given {
        if let Some((_, nd)) = GLASSES.iter().find(|g| g.0 == name.as_str()) {
            notes.report(format!("{}: \"{name}\": its index {nd} at 587.6 nm in RGB, pbrt-v4's measured dispersion in spectral mode", p.what));
            return Ok((Ior(*nd), Some(DispersionDesc::Glass(name.clone()))));
        }
    }
    Ok((eta_constant(given, &p.what, notes)?, None))
}

/// A dielectric's `eta` as one index.
fn eta_constant(
    given: Option<(Colour, Pos)>,
    what: &str,
    notes: &mut dyn Notes,
) -> Result<Ior, Located> {
    match given {
        None => Ok(Ior(1.5)),
        Some((Colour::Rgb(v), pos)) => {
            if v[0] != v[1] || v[1] != v[2] {
                return Err((pos, format!("{}: `eta` must be one number", what)));
            }
            Ok(Ior(v[0] as f32))
        }
        Some((Colour::Named(name), pos)) => {
            let (_, ior) = GLASSES.iter().find(|g| g.0 == name).ok_or_else(|| {
                (
                    pos,
                    format!(
                        "{}: unknown glass \"{name}\" (pbrt-v4 has {})",
                        what,
                        GLASSES.map(|g| g.0).join(", ")
                    ),
                )
            })?;
            notes.approximate(pos, format!("{}: \"{name}\" disperses light in pbrt-v4; raylab uses its index {ior} at 587.6 nm for every colour", what))?;
            Ok(Ior(*ior))
        }
        Some((Colour::Sampled(pairs), pos)) => {
            let i = pairs
                .iter()
                .min_by(|a, b| (a.0 - 587.6).abs().total_cmp(&(b.0 - 587.6).abs()))
                .map_or(1.5, |p| p.1);
            notes.approximate(
                pos,
                format!(
                    "{}: a dispersive `eta`, replaced by its value {i} nearest 587.6 nm",
                    what
                ),
            )?;
            Ok(Ior(i as f32))
        }
        Some((_, pos)) => Err((
            pos,
            format!("{}: `eta` must be a number or a named glass", what),
        )),
    }
}

/// A pbrt-v4 material of `kind` with parameters `p` (its `type` already read); `None` for
/// `interface` (no surface).
pub fn material(
    kind: &str,
    p: &mut ParamList,
    textures: &Textures,
    notes: &mut dyn Notes,
) -> Result<Option<MaterialDesc>, Located> {
    let what = p.what.clone();
    let at = p.at;
    let col = |p: &mut ParamList,
               name: &str,
               notes: &mut dyn Notes|
     -> Result<Option<ColorDesc>, Located> {
        match p.colour(name)? {
            None => Ok(None),
            Some((c, pos)) => {
                colour(&c, pos, &format!("{what}: `{name}`"), textures, notes).map(Some)
            }
        }
    };
    // pbrt-v4's normal map: an image of tangent-space normals (2 rgb - 1 in the frame of
    // dpdu and the shading normal), looked up at (u, 1 - v), bilinear, repeating; read as
    // pbrt-v4's Image::Read reads it (a PNG as linear, what stb_image reads as sRGB, floats as
    // they are); without Mitsuba 3.7's corrections. A displacement, if any, wins, as in pbrt.
    let normal_map = p.string("normalmap")?.map(|file| {
        let lower = file.to_ascii_lowercase();
        let linear = [".png", ".exr", ".pfm", ".hdr"]
            .iter()
            .any(|e| lower.ends_with(e));
        crate::formats::texture_desc::TextureDesc::Image(crate::formats::texture_desc::ImageDesc {
            path: file,
            filter: "bilinear".into(),
            wrap: "repeat".into(),
            raw: Some(linear),
            uv_scale: [1.0, -1.0],
            uv_offset: [0.0, 1.0],
            scale: 1.0,
        })
    });
    // pbrt-v4's bump map: the surface displaced along its shading normal by the float
    // texture (scene units), shaded with the displaced surface's normal turned to the
    // geometric normal's side; neither of Mitsuba 3.7's corrections.
    let displacement = match p.float_or_texture("displacement")? {
        None => None,
        Some((Colour::Rgb(v), _)) => Some(FloatDesc::Constant(v[0] as f32)),
        Some((Colour::Texture(t), pos)) => {
            Some(textures.float.get(&t).cloned().ok_or_else(|| {
                (
                    pos,
                    format!("{what}: no float texture is named \"{t}\" (`displacement`)"),
                )
            })?)
        }
        Some((_, pos)) => {
            return Err((
                pos,
                format!("{what}: `displacement` must be a float or a float texture"),
            ))
        }
    };
    let out = match kind {
        "diffuse" => MaterialDesc::Lambert {
            albedo: col(p, "reflectance", notes)?.unwrap_or_else(|| grey(0.5)),
        },
        "coateddiffuse" => {
            let diffuse = col(p, "reflectance", notes)?.unwrap_or_else(|| grey(0.5));
            let given = p.colour("eta")?;
            let ior = eta_constant(given, &p.what.clone(), notes)?;
            let rough = roughness(p, textures)?;
            if let Some((c, pos)) = p.colour("albedo")? {
                if c != Colour::Rgb([0.0; 3]) {
                    return Err((pos, format!("{what}: a coating with a scattering medium (`albedo` above 0) is not supported")));
                }
            }
            p.ignore(&["thickness", "g", "maxdepth", "nsamples", "seed"]);
            notes.report(format!("{what}: pbrt-v4's coateddiffuse (a stochastic layered BSDF) as raylab's plastic, Mitsuba's model of a diffuse base under a dielectric coating (nonlinear, with internal reflections): the nearest raylab has"));
            match rough {
                None => MaterialDesc::Plastic {
                    diffuse_reflectance: diffuse,
                    specular_reflectance: schema::white_colour(),
                    int_ior: ior,
                    ext_ior: Ior(1.0),
                    nonlinear: true,
                },
                Some(Roughness {
                    alpha: Some(alpha), ..
                }) => MaterialDesc::RoughPlastic {
                    diffuse_reflectance: diffuse,
                    specular_reflectance: schema::white_colour(),
                    int_ior: ior,
                    ext_ior: Ior(1.0),
                    nonlinear: true,
                    distribution: Distribution::Ggx,
                    alpha,
                },
                Some(_) => return Err((at, format!("{what}: an anisotropic rough coating is not supported (raylab's rough plastic is isotropic)"))),
            }
        }
        "conductor" => {
            let (eta, k, refl) = (p.colour("eta")?, p.colour("k")?, p.colour("reflectance")?);
            let base = match (eta, k, refl) {
                (None, None, Some((Colour::Rgb(r), _))) => {
                    // pbrt-v4: eta 1 and k = 2 sqrt(r) / sqrt(1 - r), a metal of reflectance r
                    // at normal incidence.
                    let k = r.map(|r| {
                        let r = r.clamp(0.0, 0.9999);
                        (2.0 * r.sqrt() / (1.0 - r).sqrt()) as f32
                    });
                    (None, Some([1.0; 3]), Some(k))
                }
                (None, None, Some((_, pos))) => return Err((pos, format!("{what}: `reflectance` must be an rgb constant"))),
                (eta, k, None) => {
                    let named = |c: &Option<(Colour, Pos)>, part: &str| match c {
                        None => Ok(Some("Cu".to_string())),
                        Some((Colour::Named(n), pos)) => {
                            let metal = n.strip_prefix("metal-").and_then(|m| m.strip_suffix(&format!("-{part}")));
                            match metal {
                                Some(m) if METALS.contains(&m) => Ok(Some(m.to_string())),
                                _ => Err((*pos, format!("{what}: unknown metal spectrum \"{n}\" (raylab has metal-X-{part} for X in {})", METALS.join(", ")))),
                            }
                        }
                        Some(_) => Ok(None),
                    };
                    match (named(&eta, "eta")?, named(&k, "k")?) {
                        (Some(a), Some(b)) if a == b => {
                            notes.report(format!("{what}: metal-{a}: pbrt-v4's measured spectra with --spectral, their RGB constants (as Mitsuba 3's RGB variants make them) in RGB mode"));
                            let metal = Metal::named(&a).map_err(|e| (at, format!("{what}: {e}")))?;
                            (Some(metal), None, None)
                        }
                        (Some(a), Some(b)) => return Err((at, format!("{what}: `eta` of {a} with `k` of {b} is not supported (give both of one metal, or both as rgb)"))),
                        _ => match (eta, k) {
                            (Some((Colour::Rgb(e), _)), Some((Colour::Rgb(k), _))) => (
                                None,
                                Some(e.map(|x| x as f32)),
                                Some(k.map(|x| x as f32)),
                            ),
                            _ => return Err((at, format!("{what}: `eta` and `k` must both be rgb, or both named spectra of one metal"))),
                        },
                    }
                }
                (_, _, Some((_, pos))) => return Err((pos, format!("{what}: give `reflectance` or `eta` and `k`, not both"))),
            };
            let (metal, eta, k) = base;
            match roughness(p, textures)? {
                None => MaterialDesc::Conductor {
                    metal,
                    eta,
                    k,
                    specular_reflectance: schema::white_colour(),
                },
                Some(r) => MaterialDesc::RoughConductor {
                    metal,
                    eta,
                    k,
                    specular_reflectance: schema::white_colour(),
                    distribution: Distribution::Ggx,
                    alpha: r.alpha,
                    alpha_u: r.alpha_u,
                    alpha_v: r.alpha_v,
                },
            }
        }
        "dielectric" | "thindielectric" => {
            let (ior, dispersion) = eta(p, notes)?;
            let rough = if kind == "dielectric" { roughness(p, textures)? } else { None };
            if dispersion.is_some() && (kind == "thindielectric" || rough.is_some()) {
                notes.approximate(at, format!("{what}: a rough or thin dielectric does not disperse in raylab: its index at 587.6 nm for every wavelength"))?;
            }
            let (int_ior, ext_ior) = (ior, Ior(1.0));
            let (specular_reflectance, specular_transmittance) =
                (schema::white_colour(), schema::white_colour());
            match (kind, rough) {
                ("thindielectric", _) => MaterialDesc::ThinDielectric {
                    int_ior,
                    ext_ior,
                    specular_reflectance,
                    specular_transmittance,
                },
                (_, None) => MaterialDesc::Dielectric {
                    int_ior,
                    ext_ior,
                    specular_reflectance,
                    specular_transmittance,
                    dispersion,
                },
                (_, Some(r)) => MaterialDesc::RoughDielectric {
                    int_ior,
                    ext_ior,
                    specular_reflectance,
                    specular_transmittance,
                    distribution: Distribution::Ggx,
                    alpha: r.alpha,
                    alpha_u: r.alpha_u,
                    alpha_v: r.alpha_v,
                },
            }
        }
        "diffusetransmission" => {
            // pbrt-v4: reflectance and transmittance default to 0.25, each times `scale` and
            // clamped to [0, 1].
            let scale = p.float("scale")?.unwrap_or(1.0);
            if !(scale.is_finite() && scale >= 0.0) {
                return Err((at, format!("{what}: `scale` must be finite and not negative, got {scale}")));
            }
            let mut side = |p: &mut ParamList, name: &str| -> Result<ColorDesc, Located> {
                Ok(match p.colour(name)? {
                    None => grey((0.25 * scale).clamp(0.0, 1.0) as f32),
                    Some((Colour::Rgb(v), _)) => {
                        ColorDesc::Constant(v.map(|x| (x * scale).clamp(0.0, 1.0) as f32))
                    }
                    Some((c, pos)) => match colour(&c, pos, &format!("{what}: `{name}`"), textures, notes)?.without_spectrum() {
                        ColorDesc::Texture(t) => ColorDesc::Texture(t.scaled(scale as f32)),
                        ColorDesc::Constant(v) => ColorDesc::Constant(v.map(|x| (x * scale as f32).clamp(0.0, 1.0))),
                        c @ ColorDesc::Spectrum(_) => c.scaled(scale as f32),
                    },
                })
            };
            MaterialDesc::DiffuseTransmission {
                reflectance: side(p, "reflectance")?,
                transmittance: side(p, "transmittance")?,
            }
        }
        "hair" => {
            let hair = hair(p, notes)?;
            if displacement.is_some() || normal_map.is_some() {
                notes.report(format!("{what}: `displacement` and `normalmap` ignored on hair, as pbrt-v4 ignores them"));
            }
            return Ok(Some(hair));
        }
        "interface" => return Ok(None),
        "" | "none" => {
            notes.report(format!("{what}: material \"{kind}\" is read as `interface`, as pbrt-v4 reads it (it warns that the name is deprecated)"));
            return Ok(None);
        }
        other => {
            return Err((at, format!("material `{other}` is not supported (diffuse, coateddiffuse, conductor, dielectric, thindielectric, diffusetransmission, hair, interface are)")))
        }
    };
    Ok(Some(match displacement {
        None => match normal_map {
            None => out,
            Some(texture) => MaterialDesc::NormalMap {
                texture: ColorDesc::Texture(texture),
                material: Box::new(out),
                flip_invalid_normals: false,
                shadowing: false,
            },
        },
        // A constant displacement moves the surface without tilting it (and, as any
        // displacement in pbrt-v4, takes the normal map's place).
        Some(FloatDesc::Constant(_)) => out,
        Some(texture) => MaterialDesc::BumpMap {
            texture,
            scale: 1.0,
            material: Box::new(out),
            flip_invalid_normals: false,
            shadowing: false,
        },
    }))
}

/// A number of a hair material: a `float` (raylab's hair takes no textures).
fn hair_number(p: &mut ParamList, name: &str) -> Result<Option<(f64, Pos)>, Located> {
    match p.float_or_texture(name)? {
        None => Ok(None),
        Some((Colour::Rgb(v), pos)) if v[0].is_finite() => Ok(Some((v[0], pos))),
        Some((Colour::Rgb(v), pos)) => Err((
            pos,
            format!("{}: `{name}` must be finite, got {}", p.what, v[0]),
        )),
        Some((_, pos)) => Err((
            pos,
            format!(
                "{}: a texture for `{name}` is not supported (raylab's hair takes numbers)",
                p.what
            ),
        )),
    }
}

/// A colour of a hair material: `rgb` (or a grey `float`), finite.
fn hair_colour(p: &mut ParamList, name: &str) -> Result<Option<([f64; 3], Pos)>, Located> {
    match p.colour(name)? {
        None => Ok(None),
        Some((Colour::Rgb(v), pos)) if v.iter().all(|x| x.is_finite()) => Ok(Some((v, pos))),
        Some((Colour::Rgb(v), pos)) => Err((
            pos,
            format!("{}: `{name}` must be finite, got {v:?}", p.what),
        )),
        Some((_, pos)) => Err((
            pos,
            format!(
                "{}: `{name}` must be rgb (a texture or a spectrum is not supported on hair)",
                p.what
            ),
        )),
    }
}

/// pbrt-v4's `hair` (`HairMaterial::Create`): the absorption from `sigma_a`, else
/// `reflectance` (or `color`), else `eumelanin` and `pheomelanin`, else pbrt's brown
/// (eumelanin 1.3, the description's default); the parameters not used noted, as pbrt warns.
/// Values are clamped as pbrt-v4's `GetBxDF` clamps them (absorption and concentrations not
/// negative, a reflectance in [0, 1], `beta_m` and `beta_n` in [0.01, 1]); an `eta` below 1
/// or a scale tilt `alpha` beyond 90 degrees is an error.
fn hair(p: &mut ParamList, notes: &mut dyn Notes) -> Result<MaterialDesc, Located> {
    let what = p.what.clone();
    let sigma_a = hair_colour(p, "sigma_a")?;
    let mut reflectance = hair_colour(p, "reflectance")?.map(|r| (r, "reflectance"));
    if reflectance.is_none() {
        reflectance = hair_colour(p, "color")?.map(|r| (r, "color"));
    } else if p.present("color").is_some() {
        hair_colour(p, "color")?;
        notes.report(format!(
            "{what}: `color` ignored since `reflectance` is given (as pbrt-v4)"
        ));
    }
    let eumelanin = hair_number(p, "eumelanin")?;
    let pheomelanin = hair_number(p, "pheomelanin")?;
    let eta = hair_number(p, "eta")?;
    let beta_m = hair_number(p, "beta_m")?;
    let beta_n = hair_number(p, "beta_n")?;
    let alpha = hair_number(p, "alpha")?;
    let ignored = |names: &[(&str, bool)], winner: &str, notes: &mut dyn Notes| {
        for (name, given) in names {
            if *given {
                notes.report(format!(
                    "{what}: `{name}` ignored since `{winner}` is given (as pbrt-v4)"
                ));
            }
        }
    };
    let melanin = eumelanin.is_some() || pheomelanin.is_some();
    let clamped = |x: f64, lo: f64, hi: f64, name: &str, notes: &mut dyn Notes| {
        let c = x.clamp(lo, hi);
        if c != x {
            notes.report(format!(
                "{what}: `{name}` {x} clamped to {c}, as pbrt-v4 clamps it"
            ));
        }
        c as f32
    };
    let (mut desc_sigma_a, mut desc_reflectance) = (None, None);
    let (mut desc_eumelanin, mut desc_pheomelanin) = (None, None);
    if let Some((s, _)) = sigma_a {
        ignored(
            &[
                (
                    reflectance.map_or("reflectance", |r| r.1),
                    reflectance.is_some(),
                ),
                ("eumelanin", eumelanin.is_some()),
                ("pheomelanin", pheomelanin.is_some()),
            ],
            "sigma_a",
            notes,
        );
        desc_sigma_a = Some(s.map(|x| clamped(x, 0.0, f64::MAX, "sigma_a", notes)));
    } else if let Some(((r, _), name)) = reflectance {
        ignored(
            &[
                ("eumelanin", eumelanin.is_some()),
                ("pheomelanin", pheomelanin.is_some()),
            ],
            name,
            notes,
        );
        desc_reflectance = Some(r.map(|x| clamped(x, 0.0, 1.0, name, notes)));
    } else if melanin {
        desc_eumelanin = eumelanin.map(|(e, _)| clamped(e, 0.0, f64::MAX, "eumelanin", notes));
        desc_pheomelanin =
            pheomelanin.map(|(e, _)| clamped(e, 0.0, f64::MAX, "pheomelanin", notes));
    }
    let eta_value = match eta {
        Some((e, pos)) if e < 1.0 => {
            return Err((
                pos,
                format!(
                    "{what}: `eta`, the fibre's index of refraction, must be at least 1, got {e}"
                ),
            ))
        }
        Some((e, _)) => e as f32,
        None => 1.55,
    };
    let alpha_value = match alpha {
        Some((a, pos)) if a.abs() > 90.0 => {
            return Err((
                pos,
                format!(
                    "{what}: `alpha`, the scales' tilt, must lie in [-90, 90] degrees, got {a}"
                ),
            ))
        }
        Some((a, _)) => a as f32,
        None => 2.0,
    };
    let beta = |b: Option<(f64, Pos)>, name: &str, notes: &mut dyn Notes| {
        b.map_or(0.3, |(b, _)| clamped(b, 0.01, 1.0, name, notes))
    };
    Ok(MaterialDesc::Hair {
        sigma_a: desc_sigma_a,
        reflectance: desc_reflectance,
        eumelanin: desc_eumelanin,
        pheomelanin: desc_pheomelanin,
        eta: eta_value,
        beta_m: beta(beta_m, "beta_m", notes),
        beta_n: beta(beta_n, "beta_n", notes),
        alpha: alpha_value,
    })
}
