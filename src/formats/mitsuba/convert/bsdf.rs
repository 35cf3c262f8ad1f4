//! Mitsuba's BSDF plugins as raylab's materials, one method per plugin family, with their
//! textures and colours; nested and referenced BSDFs (each converted once).

use super::*;
use crate::formats::schema::{self, Metal};
use crate::formats::texture_desc::{
    AttributeDesc, CheckerboardDesc, ImageDesc, MixDesc, TextureDesc,
};
use raylab_integrators::bsdf::Distribution;

/// A microfacet model's distribution and roughness as Mitsuba gives them.
struct Rough {
    distribution: Distribution,
    alpha: Option<FloatDesc>,
    alpha_u: Option<FloatDesc>,
    alpha_v: Option<FloatDesc>,
}

/// A dielectric interface's indices of refraction and tints, Mitsuba's defaults where absent.
struct Interface {
    int_ior: Ior,
    ext_ior: Ior,
    specular_reflectance: ColorDesc,
    specular_transmittance: ColorDesc,
}

/// A texture parameter's value: a constant (`rawconstant`) or a texture to look up.
enum TextureValue {
    Constant([f32; 3]),
    Texture(TextureDesc),
}

impl TextureValue {
    fn colour(self) -> ColorDesc {
        match self {
            TextureValue::Constant(c) => ColorDesc::Constant(c),
            TextureValue::Texture(t) => ColorDesc::Texture(t),
        }
    }

    /// As a scalar: a constant's first part. A checkerboard read as a scalar (Mitsuba 3's
    /// `eval_1`) has `color0` where the parities of `u` and `v` differ, the opposite of its
    /// colour lookup (`eval`), in every version to 3.9; Mitsuba's own references (the
    /// textured rough conductor's checkerboard roughness) are rendered so, and so is this.
    fn float(self) -> FloatDesc {
        match self {
            TextureValue::Constant(c) => FloatDesc::Constant(c[0]),
            TextureValue::Texture(TextureDesc::Checkerboard(c)) => {
                FloatDesc::Texture(TextureDesc::Checkerboard(CheckerboardDesc {
                    color0: c.color1,
                    color1: c.color0,
                    ..c
                }))
            }
            TextureValue::Texture(t) => FloatDesc::Texture(t),
        }
    }
}

/// The constant albedo of a `Lambert` material, if it is one.
fn lambert_albedo(m: &MaterialDesc) -> Option<V3> {
    match m {
        MaterialDesc::Lambert {
            albedo: ColorDesc::Constant(c),
        } => Some(*c),
        MaterialDesc::Lambert {
            albedo: ColorDesc::Spectrum(p),
        } => Some(ColorDesc::spectrum_colour(p)),
        _ => None,
    }
}

/// Whether Mitsuba sees the material from its front only: an opaque model not inside a
/// `twosided` (through maps, masks and blends, which keep their BSDFs' sides).
fn one_sided(m: &MaterialDesc) -> bool {
    use MaterialDesc::*;
    match m {
        Lambert { .. }
        | OrenNayar { .. }
        | Phong { .. }
        | Mirror { .. }
        | Conductor { .. }
        | RoughConductor { .. }
        | Plastic { .. }
        | RoughPlastic { .. } => true,
        Principled { spec_trans, .. } => {
            !matches!(spec_trans, Some(FloatDesc::Texture(_)))
                && !matches!(spec_trans, Some(FloatDesc::Constant(x)) if *x != 0.0)
        }
        NormalMap { material, .. }
        | BumpMap { material, .. }
        | Mask { material, .. }
        | Cutout { material, .. } => one_sided(material),
        TwoSided(_) | OneSided(_) => false,
        Glass { .. }
        | Dielectric { .. }
        | RoughDielectric { .. }
        | ThinDielectric { .. }
        | DiffuseTransmission { .. }
        | PrincipledThin { .. }
        | Hair { .. }
        | Null => false,
    }
}

/// Mitsuba's default BSDF: diffuse 0.5.
pub(super) fn default_bsdf() -> MaterialDesc {
    MaterialDesc::Lambert {
        albedo: ColorDesc::Constant([0.5; 3]),
    }
}

impl<'a, 'input> Converter<'a, 'input> {
    /// A colour parameter: a constant, or a texture given nested or by reference.
    pub(super) fn colour(
        &self,
        props: &mut Props<'a, 'input>,
        name: &str,
        default: Option<[f32; 3]>,
    ) -> Result<Option<ColorDesc>, Located> {
        // A spectrum given by wavelength stays one.
        if let Some(pairs) = props.spectrum(name) {
            props.vector(name)?;
            return Ok(Some(ColorDesc::Spectrum(pairs)));
        }
        if let Some(v) = props.vector(name)? {
            return Ok(Some(ColorDesc::Constant(v)));
        }
        Ok(match self.texture_child(props, name, "a colour")? {
            Some(t) => Some(t.colour()),
            None => default.map(ColorDesc::Constant),
        })
    }

    /// A scalar parameter (a roughness): a number, or a texture given nested or by reference.
    fn float_param(
        &self,
        props: &mut Props<'a, 'input>,
        name: &str,
    ) -> Result<Option<FloatDesc>, Located> {
        if let Some(v) = props.float(name)? {
            return Ok(Some(FloatDesc::Constant(v)));
        }
        Ok(self
            .texture_child(props, name, "a number")?
            .map(TextureValue::float))
    }

    /// The texture given as parameter `name` (nested or by reference), taken out of
    /// `props`; anything else there is an error (`what` the parameter may be besides).
    fn texture_child(
        &self,
        props: &mut Props<'a, 'input>,
        name: &str,
        what: &str,
    ) -> Result<Option<TextureValue>, Located> {
        let Some(i) = props.children.iter().position(|(n, _)| n == name) else {
            return Ok(None);
        };
        let (_, node) = props.children.remove(i);
        let node = self.resolve(node)?;
        if node.tag_name().name() != "texture" {
            return Err(at(
                self.doc,
                node,
                format!("`{name}` must be {what} or a <texture>"),
            ));
        }
        self.texture_value(node).map(Some)
    }

    /// A texture node's value: a `rawconstant`'s constant (taken as it is, no colour
    /// conversion: in raylab's RGB, a constant), or a texture to look up.
    fn texture_value(&self, node: Node<'a, 'input>) -> Result<TextureValue, Located> {
        if self.kind(node)? != "rawconstant" {
            return self.texture(node).map(TextureValue::Texture);
        }
        let mut p = self.props(node)?;
        let value = p.vector("value")?.ok_or_else(|| {
            at(
                self.doc,
                node,
                "<texture type=\"rawconstant\"> needs a `value`",
            )
        })?;
        p.finish(&[])?;
        Ok(TextureValue::Constant(value))
    }

    pub(super) fn texture(&self, node: Node<'a, 'input>) -> Result<TextureDesc, Located> {
        let kind = self.kind(node)?;
        let mut p = self.props(node)?;
        let legacy_uv = if self.params.legacy {
            let mut get = |name: &str, default: f32| p.float(name).map(|v| v.unwrap_or(default));
            let (u, v) = (get("uoffset", 0.0)?, get("voffset", 0.0)?);
            let (su, sv) = (get("uscale", 1.0)?, get("vscale", 1.0)?);
            ([su, sv], [u, v])
        } else {
            ([1.0, 1.0], [0.0, 0.0])
        };
        let (uv_scale, uv_offset) = match p.transform("to_uv")? {
            // Mitsuba 0.x's `uoffset`... become to_uv = translate(offset) then scale.
            None if self.params.legacy => (
                legacy_uv.0,
                [
                    legacy_uv.0[0] * legacy_uv.1[0],
                    legacy_uv.0[1] * legacy_uv.1[1],
                ],
            ),
            None => ([1.0, 1.0], [0.0, 0.0]),
            Some(m) => {
                let c = m.matrix3;
                if c.x_axis.y != 0.0 || c.y_axis.x != 0.0 {
                    return Err(at(self.doc, node, "`to_uv`: only a scale and a translation of the texture coordinates are supported"));
                }
                ([c.x_axis.x, c.y_axis.y], [m.translation.x, m.translation.y])
            }
        };
        let out = match kind.as_str() {
            "bitmap" => {
                let path = self.file_name(p.string("filename")?.ok_or_else(|| {
                    at(self.doc, node, "<texture type=\"bitmap\"> needs `filename`")
                })?);
                let filter = p
                    .string("filter_type")?
                    .unwrap_or_else(|| "bilinear".into());
                let wrap = p.string("wrap_mode")?.unwrap_or_else(|| "repeat".into());
                let raw = p.boolean("raw")?.unwrap_or(false);
                TextureDesc::Image(ImageDesc {
                    path,
                    filter,
                    wrap,
                    raw: Some(raw),
                    uv_scale,
                    uv_offset,
                    scale: 1.0,
                })
            }
            "mesh_attribute" => TextureDesc::Attribute(AttributeDesc {
                name: p.string("name")?.ok_or_else(|| {
                    at(
                        self.doc,
                        node,
                        "<texture type=\"mesh_attribute\"> needs `name`",
                    )
                })?,
                scale: p.float("scale")?.unwrap_or(1.0),
            }),
            "checkerboard" => TextureDesc::Checkerboard(CheckerboardDesc {
                color0: p.vector("color0")?.unwrap_or([0.4; 3]),
                color1: p.vector("color1")?.unwrap_or([0.2; 3]),
                uv_scale,
                uv_offset,
            }),
            other => {
                return Err(at(
                    self.doc,
                    node,
                    format!("texture type `{other}` is not supported (bitmap, checkerboard, mesh_attribute are)"),
                ))
            }
        };
        // `format`: the precision Mitsuba keeps the bitmap in, not what it looks up.
        p.finish(&["format"])?;
        Ok(out)
    }

    /// The material of a BSDF. A BSDF that holds itself (a `<ref>` to a BSDF it is inside) is
    /// a cycle, refused; so is nesting deeper than
    /// [`crate::formats::mitsuba::include::MAX_NESTING`] through references.
    pub(super) fn bsdf(&mut self, node: Node<'a, 'input>) -> Result<MaterialDesc, Located> {
        // A BSDF referenced from several places is converted once (a chain of BSDFs each
        // referring twice to the one before would otherwise take 2^depth conversions).
        if let Some(done) = self.bsdf_of.get(&node.id()) {
            return Ok(done.clone());
        }
        if self.bsdfs_open.contains(&node.id()) {
            let id = node.attribute("id").unwrap_or_default();
            return Err(at(
                self.doc,
                node,
                format!("<bsdf id=\"{id}\"> holds a <ref> to itself (a cycle of references)"),
            ));
        }
        if self.bsdfs_open.len() >= crate::formats::mitsuba::include::MAX_NESTING {
            return Err(at(
                self.doc,
                node,
                format!(
                    "BSDFs nest deeper than {} (through references)",
                    crate::formats::mitsuba::include::MAX_NESTING
                ),
            ));
        }
        self.bsdfs_open.push(node.id());
        let out = self.bsdf_plugin(node);
        self.bsdfs_open.pop();
        if let Ok(desc) = &out {
            self.bsdf_of.insert(node.id(), desc.clone());
        }
        out
    }

    /// One BSDF plugin, by its family; what it leaves unread is an error.
    fn bsdf_plugin(&mut self, node: Node<'a, 'input>) -> Result<MaterialDesc, Located> {
        let kind = self.kind(node)?;
        let mut p = self.props(node)?;
        let out = match kind.as_str() {
            "null" => MaterialDesc::Null,
            "diffuse" => MaterialDesc::Lambert {
                albedo: self
                    .colour(&mut p, "reflectance", Some([0.5; 3]))?
                    .unwrap_or_else(schema::half_colour),
            },
            "conductor" | "roughconductor" => self.conductor(&mut p, node, &kind)?,
            "dielectric" | "roughdielectric" | "thindielectric" => {
                self.dielectric(&mut p, &kind)?
            }
            "plastic" | "roughplastic" => self.plastic(&mut p, &kind)?,
            "twosided" => self.two_sided(&mut p, node)?,
            "normalmap" | "bumpmap" => self.normal_or_bump_map(&mut p, node, &kind)?,
            "blendbsdf" => self.blend(&mut p, node)?,
            "mask" => self.mask(&mut p, node)?,
            "principled" | "principledthin" => self.principled(&mut p, node, &kind)?,
            other => {
                let message = format!("BSDF `{other}` is not supported (diffuse, conductor, roughconductor, dielectric, roughdielectric, thindielectric, plastic, roughplastic, principled, principledthin, twosided, normalmap, bumpmap, blendbsdf and mask where raylab's materials hold them are)");
                self.approximate(
                    node,
                    format!("{message}: replaced by Mitsuba's default, diffuse 0.5"),
                )?;
                return Ok(default_bsdf());
            }
        };
        if let Some((name, child)) = p.children.first() {
            return Err(at(
                self.doc,
                *child,
                format!("<bsdf type=\"{kind}\">: `{name}` is not supported here"),
            ));
        }
        p.finish(&[])?;
        Ok(out)
    }

    /// `distribution`, `alpha`, `alpha_u` and `alpha_v` of a rough model.
    fn rough(&self, p: &mut Props<'a, 'input>) -> Result<Rough, Located> {
        let distribution = match p.take("distribution") {
            None => Distribution::default(),
            Some((Value::String(d), _)) if d == "ggx" => Distribution::Ggx,
            Some((Value::String(d), _)) if d == "beckmann" => Distribution::Beckmann,
            Some((_, n)) => {
                return Err(at(
                    p.doc,
                    n,
                    "`distribution` must be \"ggx\" or \"beckmann\"",
                ))
            }
        };
        Ok(Rough {
            distribution,
            alpha: self.float_param(p, "alpha")?,
            alpha_u: self.float_param(p, "alpha_u")?,
            alpha_v: self.float_param(p, "alpha_v")?,
        })
    }

    /// `conductor` and `roughconductor`: a named `material`, or `eta` and `k`.
    fn conductor(
        &mut self,
        p: &mut Props<'a, 'input>,
        node: Node<'a, 'input>,
        kind: &str,
    ) -> Result<MaterialDesc, Located> {
        let metal = match p.take("material") {
            None => None,
            Some((Value::String(m), n)) => Some(Metal::named(&m).map_err(|e| at(self.doc, n, e))?),
            Some((_, n)) => return Err(at(self.doc, n, "`material` must be a string")),
        };
        let (metal, eta, k) = match (metal, p.optical_constant("eta")?, p.optical_constant("k")?) {
            (Some(m), None, None) => (Some(m), None, None),
            (None, Some(eta), Some(k)) => (None, Some(eta), Some(k)),
            (None, None, None) => (
                Some(Metal::named("none").map_err(|e| at(self.doc, node, e))?),
                None,
                None,
            ),
            _ => {
                return Err(at(
                    self.doc,
                    node,
                    "a conductor takes `material`, or `eta` and `k`",
                ))
            }
        };
        let specular_reflectance = self
            .colour(p, "specular_reflectance", None)?
            .unwrap_or_else(schema::white_colour);
        if kind == "conductor" {
            return Ok(MaterialDesc::Conductor {
                metal,
                eta,
                k,
                specular_reflectance,
            });
        }
        let r = self.rough(p)?;
        Ok(MaterialDesc::RoughConductor {
            metal,
            eta,
            k,
            specular_reflectance,
            distribution: r.distribution,
            alpha: r.alpha,
            alpha_u: r.alpha_u,
            alpha_v: r.alpha_v,
        })
    }

    /// A dielectric interface's IORs and tints.
    fn interface(&self, p: &mut Props<'a, 'input>) -> Result<Interface, Located> {
        let int_ior = p.ior("int_ior")?.unwrap_or_else(schema::bk7);
        let ext_ior = p.ior("ext_ior")?.unwrap_or_else(schema::air);
        let mut tint = |name: &str| {
            self.colour(p, name, None)
                .map(|c| c.unwrap_or_else(schema::white_colour))
        };
        Ok(Interface {
            int_ior,
            ext_ior,
            specular_reflectance: tint("specular_reflectance")?,
            specular_transmittance: tint("specular_transmittance")?,
        })
    }

    /// `dielectric`, `roughdielectric` and `thindielectric`.
    fn dielectric(
        &mut self,
        p: &mut Props<'a, 'input>,
        kind: &str,
    ) -> Result<MaterialDesc, Located> {
        let i = self.interface(p)?;
        Ok(match kind {
            "dielectric" => MaterialDesc::Dielectric {
                int_ior: i.int_ior,
                ext_ior: i.ext_ior,
                specular_reflectance: i.specular_reflectance,
                specular_transmittance: i.specular_transmittance,
                dispersion: None,
            },
            "roughdielectric" => {
                let r = self.rough(p)?;
                MaterialDesc::RoughDielectric {
                    int_ior: i.int_ior,
                    ext_ior: i.ext_ior,
                    specular_reflectance: i.specular_reflectance,
                    specular_transmittance: i.specular_transmittance,
                    distribution: r.distribution,
                    alpha: r.alpha,
                    alpha_u: r.alpha_u,
                    alpha_v: r.alpha_v,
                }
            }
            _ => MaterialDesc::ThinDielectric {
                int_ior: i.int_ior,
                ext_ior: i.ext_ior,
                specular_reflectance: i.specular_reflectance,
                specular_transmittance: i.specular_transmittance,
            },
        })
    }

    /// `plastic` and `roughplastic` (an isotropic `alpha` only: the coating's tables depend
    /// on it).
    fn plastic(&mut self, p: &mut Props<'a, 'input>, kind: &str) -> Result<MaterialDesc, Located> {
        let diffuse_reflectance = self
            .colour(p, "diffuse_reflectance", None)?
            .unwrap_or_else(schema::half_colour);
        let specular_reflectance = self
            .colour(p, "specular_reflectance", None)?
            .unwrap_or_else(schema::white_colour);
        let int_ior = p.ior("int_ior")?.unwrap_or_else(schema::polypropylene);
        let ext_ior = p.ior("ext_ior")?.unwrap_or_else(schema::air);
        let nonlinear = p.boolean("nonlinear")?.unwrap_or(false);
        if kind == "plastic" {
            return Ok(MaterialDesc::Plastic {
                diffuse_reflectance,
                specular_reflectance,
                int_ior,
                ext_ior,
                nonlinear,
            });
        }
        let r = self.rough(p)?;
        if r.alpha_u.is_some() || r.alpha_v.is_some() {
            let n = p.node;
            return Err(at(
                self.doc,
                n,
                "<bsdf type=\"roughplastic\">: `alpha_u` and `alpha_v` are not supported (an isotropic `alpha` is)",
            ));
        }
        Ok(MaterialDesc::RoughPlastic {
            diffuse_reflectance,
            specular_reflectance,
            int_ior,
            ext_ior,
            nonlinear,
            distribution: r.distribution,
            alpha: r.alpha.unwrap_or_else(schema::default_alpha),
        })
    }

    /// `principled` and `principledthin` (Burley's model as Mitsuba 3 has it). Their
    /// sampling rates change how lobes are sampled, not the image: raylab samples with
    /// Mitsuba's default weights and says so.
    fn principled(
        &mut self,
        p: &mut Props<'a, 'input>,
        node: Node<'a, 'input>,
        kind: &str,
    ) -> Result<MaterialDesc, Located> {
        let base_color = self
            .colour(p, "base_color", None)?
            .unwrap_or_else(schema::half_colour);
        let roughness = self
            .float_param(p, "roughness")?
            .unwrap_or_else(schema::half_float);
        let anisotropic = self.float_param(p, "anisotropic")?;
        let spec_trans = self.float_param(p, "spec_trans")?;
        let spec_tint = self.float_param(p, "spec_tint")?;
        let sheen = self.float_param(p, "sheen")?;
        let sheen_tint = self.float_param(p, "sheen_tint")?;
        let flatness = self.float_param(p, "flatness")?;
        let rates: &[&str] = if kind == "principled" {
            &[
                "main_specular_sampling_rate",
                "clearcoat_sampling_rate",
                "diffuse_reflectance_sampling_rate",
            ]
        } else {
            &[
                "specular_reflectance_sampling_rate",
                "specular_transmittance_sampling_rate",
                "diffuse_reflectance_sampling_rate",
                "diffuse_transmittance_sampling_rate",
            ]
        };
        for rate in rates {
            if p.float(rate)?.is_some() {
                self.report.push(format!(
                    "<bsdf type=\"{kind}\">: `{rate}` changes only how lobes are sampled; raylab samples with Mitsuba's default weights (the same image)"
                ));
            }
        }
        if kind == "principledthin" {
            let eta = match self.float_param(p, "eta")? {
                None => 1.5,
                Some(FloatDesc::Constant(eta)) => eta,
                Some(FloatDesc::Texture(_)) => {
                    return Err(at(
                        self.doc,
                        node,
                        "<bsdf type=\"principledthin\">: a textured `eta` is not supported (a number is)",
                    ))
                }
            };
            return Ok(MaterialDesc::PrincipledThin {
                base_color,
                roughness,
                anisotropic,
                spec_trans,
                spec_tint,
                sheen,
                sheen_tint,
                flatness,
                diff_trans: self.float_param(p, "diff_trans")?,
                eta,
            });
        }
        let (eta, specular) = (p.float("eta")?, p.float("specular")?);
        if eta.is_some() && specular.is_some() {
            return Err(at(
                self.doc,
                node,
                "<bsdf type=\"principled\">: give `eta` or `specular`, not both (as Mitsuba)",
            ));
        }
        Ok(MaterialDesc::Principled {
            base_color,
            roughness,
            anisotropic,
            metallic: self.float_param(p, "metallic")?,
            spec_trans,
            spec_tint,
            sheen,
            sheen_tint,
            flatness,
            clearcoat: self.float_param(p, "clearcoat")?,
            clearcoat_gloss: self.float_param(p, "clearcoat_gloss")?,
            eta,
            specular,
        })
    }

    /// `twosided` with one BSDF for both faces.
    fn two_sided(
        &mut self,
        p: &mut Props<'a, 'input>,
        node: Node<'a, 'input>,
    ) -> Result<MaterialDesc, Located> {
        let inner: Vec<Node> = p.children.iter().map(|(_, n)| *n).collect();
        p.children.clear();
        let [inner] = inner[..] else {
            return Err(at(
                self.doc,
                node,
                "<bsdf type=\"twosided\"> with two BSDFs (one per side) is not supported: give one",
            ));
        };
        let inner = self.resolve(inner)?;
        if inner.tag_name().name() == "bsdf" && inner.attribute("type") == Some("twosided") {
            return Err(at(
                self.doc,
                inner,
                "a two-sided BSDF inside another (Mitsuba refuses it too): give the inner one alone",
            ));
        }
        Ok(MaterialDesc::TwoSided(Box::new(self.bsdf(inner)?)))
    }

    /// `normalmap` and `bumpmap`: one nested BSDF and one texture (nested or referenced).
    fn normal_or_bump_map(
        &mut self,
        p: &mut Props<'a, 'input>,
        node: Node<'a, 'input>,
        kind: &str,
    ) -> Result<MaterialDesc, Located> {
        let mut inner = None;
        let mut texture = None;
        for (_, child) in std::mem::take(&mut p.children) {
            let child = self.resolve(child)?;
            match child.tag_name().name() {
                "bsdf" if inner.is_none() => inner = Some(child),
                "texture" if texture.is_none() => texture = Some(child),
                tag => return Err(at(self.doc, child, format!("<bsdf type=\"{kind}\"> takes one <bsdf> and one <texture>, not this <{tag}>"))),
            }
        }
        let (Some(inner), Some(texture)) = (inner, texture) else {
            return Err(at(
                self.doc,
                node,
                format!("<bsdf type=\"{kind}\"> needs a nested <bsdf> and a <texture>"),
            ));
        };
        let material = Box::new(self.bsdf(inner)?);
        let texture = self.texture_value(texture)?;
        let flip_invalid_normals = p.boolean("flip_invalid_normals")?.unwrap_or(true);
        let shadowing = p.boolean("use_shadowing_function")?.unwrap_or(true);
        Ok(if kind == "normalmap" {
            MaterialDesc::NormalMap {
                texture: texture.colour(),
                material,
                flip_invalid_normals,
                shadowing,
            }
        } else {
            MaterialDesc::BumpMap {
                texture: texture.float(),
                scale: p.float("scale")?.unwrap_or(1.0),
                material,
                flip_invalid_normals,
                shadowing,
            }
        })
    }

    /// `blendbsdf`: (1 - weight) f_a + weight f_b, which raylab's materials hold when the
    /// weight picks one, both are the same, or both are constant diffuse reflectances.
    fn blend(
        &mut self,
        p: &mut Props<'a, 'input>,
        node: Node<'a, 'input>,
    ) -> Result<MaterialDesc, Located> {
        // Mitsuba reads the weight as a scalar (eval_1); default 0.5.
        let (weight, textured) = match self.float_param(p, "weight")? {
            Some(FloatDesc::Texture(t)) => (None, Some(t)),
            Some(FloatDesc::Constant(w)) if !(0.0..=1.0).contains(&w) => {
                return Err(at(
                    self.doc,
                    node,
                    format!("`weight` must lie in [0, 1], not {w}"),
                ))
            }
            Some(FloatDesc::Constant(w)) => (Some(w), None),
            None => (Some(0.5), None),
        };
        let inner = self.nested_bsdfs(p, node, 2)?;
        let (a, b) = (self.bsdf(inner[0])?, self.bsdf(inner[1])?);
        // Two diffuse reflectances blended by a texture: one diffuse of the mixed colour.
        if let (
            Some(amount),
            MaterialDesc::Lambert { albedo: ka },
            MaterialDesc::Lambert { albedo: kb },
        ) = (&textured, &a, &b)
        {
            return Ok(MaterialDesc::Lambert {
                albedo: ColorDesc::Texture(TextureDesc::Mix(Box::new(MixDesc {
                    tex0: ka.clone(),
                    tex1: kb.clone(),
                    amount: FloatDesc::Texture(amount.clone()),
                }))),
            });
        }
        let w = weight.unwrap_or(0.5);
        Ok(match (weight, lambert_albedo(&a), lambert_albedo(&b)) {
            (Some(0.0), ..) => a,
            (Some(1.0), ..) => b,
            _ if a == b => a,
            (Some(w), Some(ka), Some(kb)) => MaterialDesc::Lambert {
                albedo: ColorDesc::Constant(std::array::from_fn(|i| {
                    let w = w as f64;
                    ((1.0 - w) * ka[i] as f64 + w * kb[i] as f64) as f32
                })),
            },
            _ => {
                self.approximate(
                    node,
                    format!("<bsdf type=\"blendbsdf\"> of these BSDFs (with this weight) has no raylab material; replaced by the one weighted more ({})", if w > 0.5 { "the second" } else { "the first" }),
                )?;
                if w > 0.5 {
                    b
                } else {
                    a
                }
            }
        })
    }

    /// `mask`: Mitsuba's cut-out, the BSDF where opaque, a null event (straight through)
    /// where not.
    fn mask(
        &mut self,
        p: &mut Props<'a, 'input>,
        node: Node<'a, 'input>,
    ) -> Result<MaterialDesc, Located> {
        // Mitsuba reads the opacity as a scalar (eval_1); default 0.5.
        let opacity = match self.float_param(p, "opacity")? {
            None => FloatDesc::Constant(0.5),
            Some(FloatDesc::Constant(a)) if !(0.0..=1.0).contains(&a) => {
                return Err(at(
                    self.doc,
                    node,
                    format!("`opacity` must lie in [0, 1], not {a}"),
                ))
            }
            Some(o) => o,
        };
        let inner = self.nested_bsdfs(p, node, 1)?;
        let material = self.bsdf(inner[0])?;
        Ok(match opacity {
            FloatDesc::Constant(1.0) => material,
            opacity => MaterialDesc::Mask {
                opacity,
                material: Box::new(material),
            },
        })
    }

    /// Exactly `n` nested (or referenced) BSDFs of `node`.
    fn nested_bsdfs(
        &mut self,
        p: &mut Props<'a, 'input>,
        node: Node<'a, 'input>,
        n: usize,
    ) -> Result<Vec<Node<'a, 'input>>, Located> {
        let mut inner = Vec::new();
        for (_, child) in std::mem::take(&mut p.children) {
            let child = self.resolve(child)?;
            if child.tag_name().name() != "bsdf" {
                return Err(at(
                    self.doc,
                    child,
                    format!("<{}> is not a BSDF", child.tag_name().name()),
                ));
            }
            inner.push(child);
        }
        if inner.len() != n {
            let kind = self.kind(node)?;
            return Err(at(
                self.doc,
                node,
                format!(
                    "<bsdf type=\"{kind}\"> takes {n} nested BSDF(s), not {}",
                    inner.len()
                ),
            ));
        }
        Ok(inner)
    }

    /// The material name for a BSDF node (made once, however many shapes use it).
    pub(super) fn material(
        &mut self,
        node: Node<'a, 'input>,
        fallback: &str,
    ) -> Result<String, Located> {
        let node = self.resolve(node)?;
        if let Some(name) = self.material_of.get(&node.id()) {
            return Ok(name.clone());
        }
        let mut name =
            attr(&self.params, self.doc, node, "id")?.unwrap_or_else(|| fallback.to_string());
        while self.materials.iter().any(|(n, _)| *n == name) {
            name.push('\'');
        }
        let mut desc = self.bsdf(node)?;
        // Mitsuba's opaque BSDFs reflect nothing from behind unless inside a `twosided`.
        if one_sided(&desc) {
            desc = MaterialDesc::OneSided(Box::new(desc));
        }
        self.materials.push((name.clone(), desc));
        self.origins
            .push((false, name.clone(), position(self.doc, node)));
        self.material_of.insert(node.id(), name.clone());
        Ok(name)
    }
}
