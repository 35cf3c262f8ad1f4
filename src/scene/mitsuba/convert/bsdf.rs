//! Mitsuba's BSDF plugins as raylab's materials, with their textures and colours; nested
//! and referenced BSDFs (each converted once).

use super::*;

/// The constant albedo of a `Lambert` material's RON, if it is one.
fn lambert_albedo(ron: &str) -> Option<[f32; 3]> {
    let inner = ron.strip_prefix("Lambert(albedo: ")?.strip_suffix(')')?;
    let numbers: Vec<f32> = inner
        .trim_matches(|c| c == '(' || c == ')')
        .split(',')
        .map(|x| x.trim().parse().ok())
        .collect::<Option<_>>()?;
    match numbers[..] {
        [g] => Some([g; 3]),
        [r, g, b] => Some([r, g, b]),
        _ => None,
    }
}

impl<'a, 'input> Converter<'a, 'input> {
    /// A colour parameter: a constant, or a `bitmap` / `checkerboard` texture given nested
    /// or by reference.
    pub(super) fn colour(
        &self,
        props: &mut Props<'a, 'input>,
        name: &str,
        default: Option<[f32; 3]>,
    ) -> Result<Option<String>, Located> {
        if let Some(v) = props.vector(name)? {
            return Ok(Some(v3(v)));
        }
        let Some(i) = props.children.iter().position(|(n, _)| n == name) else {
            return Ok(default.map(v3));
        };
        let (_, node) = props.children.remove(i);
        let node = self.resolve(node)?;
        if node.tag_name().name() != "texture" {
            return Err(at(
                self.doc,
                node,
                format!("`{name}` must be a colour or a <texture>"),
            ));
        }
        self.texture(node).map(Some)
    }

    pub(super) fn texture(&self, node: Node<'a, 'input>) -> Result<String, Located> {
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
        let (scale, offset) = match p.transform("to_uv")? {
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
        let uv = format!(
            "uv_scale: ({}, {}), uv_offset: ({}, {})",
            num(scale[0]),
            num(scale[1]),
            num(offset[0]),
            num(offset[1])
        );
        let out = match kind.as_str() {
            "bitmap" => {
                let file = self.file_name(p.string("filename")?.ok_or_else(|| {
                    at(self.doc, node, "<texture type=\"bitmap\"> needs `filename`")
                })?);
                let filter = p
                    .string("filter_type")?
                    .unwrap_or_else(|| "bilinear".into());
                let wrap = p.string("wrap_mode")?.unwrap_or_else(|| "repeat".into());
                let raw = p.boolean("raw")?.unwrap_or(false);
                format!(
                    "Image(path: {}, filter: {}, wrap: {}, raw: {raw}, {uv})",
                    quote(&file),
                    quote(&filter),
                    quote(&wrap)
                )
            }
            "checkerboard" => {
                let c0 = p.vector("color0")?.unwrap_or([0.4; 3]);
                let c1 = p.vector("color1")?.unwrap_or([0.2; 3]);
                format!("Checkerboard(color0: {}, color1: {}, {uv})", v3(c0), v3(c1))
            }
            other => {
                return Err(at(
                    self.doc,
                    node,
                    format!("texture type `{other}` is not supported (bitmap, checkerboard are)"),
                ))
            }
        };
        p.finish(&[])?;
        Ok(out)
    }

    /// The RON of a BSDF. A BSDF that holds itself (a `<ref>` to a BSDF it is inside) is a
    /// cycle, refused; so is nesting deeper than [`crate::scene::mitsuba::include::MAX_NESTING`] through
    /// references.
    pub(super) fn bsdf(&mut self, node: Node<'a, 'input>) -> Result<String, Located> {
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
        if self.bsdfs_open.len() >= crate::scene::mitsuba::include::MAX_NESTING {
            return Err(at(
                self.doc,
                node,
                format!(
                    "BSDFs nest deeper than {} (through references)",
                    crate::scene::mitsuba::include::MAX_NESTING
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

    pub(super) fn bsdf_plugin(&mut self, node: Node<'a, 'input>) -> Result<String, Located> {
        let kind = self.kind(node)?;
        let mut p = self.props(node)?;
        let rough = |p: &mut Props<'a, 'input>, out: &mut String| -> Result<(), Located> {
            if let Some((v, n)) = p.take("distribution") {
                match v {
                    Value::String(d) if matches!(d.as_str(), "ggx" | "beckmann") => {
                        let _ = write!(out, ", distribution: {}", quote(&d));
                    }
                    _ => {
                        return Err(at(
                            p.doc,
                            n,
                            "`distribution` must be \"ggx\" or \"beckmann\"",
                        ))
                    }
                }
            }
            for name in ["alpha", "alpha_u", "alpha_v"] {
                if let Some(a) = p.float(name)? {
                    let _ = write!(out, ", {name}: {}", num(a));
                }
            }
            Ok(())
        };
        let iors = |p: &mut Props<'a, 'input>, out: &mut String| -> Result<(), Located> {
            for name in ["int_ior", "ext_ior"] {
                if let Some(v) = p.ior(name)? {
                    let _ = write!(out, ", {name}: {v}");
                }
            }
            Ok(())
        };
        let out = match kind.as_str() {
            "diffuse" => {
                let albedo = self
                    .colour(&mut p, "reflectance", Some([0.5; 3]))?
                    .unwrap_or_default();
                format!("Lambert(albedo: {albedo})")
            }
            "conductor" | "roughconductor" => {
                let mut out = String::from(if kind == "conductor" {
                    "Conductor("
                } else {
                    "RoughConductor("
                });
                let metal = match p.take("material") {
                    None => None,
                    Some((Value::String(m), n)) => {
                        raylab_integrators::bsdf::ior::metal(&m).map_err(|e| at(self.doc, n, e))?;
                        Some(m)
                    }
                    Some((_, n)) => return Err(at(self.doc, n, "`material` must be a string")),
                };
                match (metal, p.optical_constant("eta")?, p.optical_constant("k")?) {
                    (Some(m), None, None) => {
                        let _ = write!(out, "metal: {}", quote(&m));
                    }
                    (None, Some(eta), Some(k)) => {
                        let _ = write!(out, "eta: {}, k: {}", v3(eta), v3(k));
                    }
                    (None, None, None) => out.push_str("metal: \"none\""),
                    _ => {
                        return Err(at(
                            self.doc,
                            node,
                            "a conductor takes `material`, or `eta` and `k`",
                        ))
                    }
                }
                if let Some(c) = self.colour(&mut p, "specular_reflectance", None)? {
                    let _ = write!(out, ", specular_reflectance: {c}");
                }
                if kind == "roughconductor" {
                    rough(&mut p, &mut out)?;
                }
                out + ")"
            }
            "dielectric" | "roughdielectric" | "thindielectric" => {
                let mut out = match kind.as_str() {
                    "dielectric" => "Dielectric(".to_string(),
                    "roughdielectric" => "RoughDielectric(".to_string(),
                    _ => "ThinDielectric(".to_string(),
                };
                let mut fields = String::new();
                iors(&mut p, &mut fields)?;
                for name in ["specular_reflectance", "specular_transmittance"] {
                    if let Some(c) = self.colour(&mut p, name, None)? {
                        let _ = write!(fields, ", {name}: {c}");
                    }
                }
                if kind == "roughdielectric" {
                    rough(&mut p, &mut fields)?;
                }
                out.push_str(fields.trim_start_matches(", "));
                out + ")"
            }
            "plastic" | "roughplastic" => {
                let mut fields = String::new();
                for name in ["diffuse_reflectance", "specular_reflectance"] {
                    if let Some(c) = self.colour(&mut p, name, None)? {
                        let _ = write!(fields, ", {name}: {c}");
                    }
                }
                iors(&mut p, &mut fields)?;
                if let Some(b) = p.boolean("nonlinear")? {
                    let _ = write!(fields, ", nonlinear: {b}");
                }
                if kind == "roughplastic" {
                    rough(&mut p, &mut fields)?;
                }
                let name = if kind == "plastic" {
                    "Plastic"
                } else {
                    "RoughPlastic"
                };
                format!("{name}({})", fields.trim_start_matches(", "))
            }
            "twosided" => {
                let inner: Vec<Node> = p.children.iter().map(|(_, n)| *n).collect();
                p.children.clear();
                let [inner] = inner[..] else {
                    return Err(at(self.doc, node, "<bsdf type=\"twosided\"> with two BSDFs (one per side) is not supported: give one"));
                };
                let inner = self.resolve(inner)?;
                if inner.tag_name().name() == "bsdf" && inner.attribute("type") == Some("twosided")
                {
                    return Err(at(
                        self.doc,
                        inner,
                        "a two-sided BSDF inside another (Mitsuba refuses it too): give the inner one alone",
                    ));
                }
                format!("TwoSided({})", self.bsdf(inner)?)
            }
            "normalmap" | "bumpmap" => {
                // One nested BSDF and one texture (nested or referenced).
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
                let (material, texture) = (self.bsdf(inner)?, self.texture(texture)?);
                if kind == "normalmap" {
                    format!("NormalMap(texture: {texture}, material: {material})")
                } else {
                    let scale = p.float("scale")?.unwrap_or(1.0);
                    format!(
                        "BumpMap(texture: {texture}, scale: {}, material: {material})",
                        num(scale)
                    )
                }
            }
            "blendbsdf" => {
                // (1 - weight) f_a + weight f_b, which raylab's materials hold when the weight
                // picks one, both are the same, or both are constant diffuse reflectances.
                let weight = self.constant_weight(&mut p, node, "weight")?;
                let inner = self.nested_bsdfs(&mut p, node, 2)?;
                let (a, b) = (self.bsdf(inner[0])?, self.bsdf(inner[1])?);
                let w = weight.unwrap_or(0.5);
                match (weight, lambert_albedo(&a), lambert_albedo(&b)) {
                    (Some(0.0), ..) => a,
                    (Some(1.0), ..) => b,
                    _ if a == b => a,
                    (Some(w), Some(ka), Some(kb)) => format!(
                        "Lambert(albedo: {})",
                        v3(std::array::from_fn(|i| {
                            let w = w as f64;
                            ((1.0 - w) * ka[i] as f64 + w * kb[i] as f64) as f32
                        }))
                    ),
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
                }
            }
            "mask" => {
                // Mitsuba's cut-out: the BSDF where opaque, nothing where not. raylab has no
                // transparent surfaces, so only a fully opaque mask is exact.
                let opacity = self.constant_weight(&mut p, node, "opacity")?;
                let inner = self.nested_bsdfs(&mut p, node, 1)?;
                let material = self.bsdf(inner[0])?;
                if opacity != Some(1.0) {
                    self.approximate(
                        node,
                        "<bsdf type=\"mask\"> with an opacity below 1: raylab has no see-through surfaces; rendered opaque".to_string(),
                    )?;
                }
                material
            }
            other => {
                let message = format!("BSDF `{other}` is not supported (diffuse, conductor, roughconductor, dielectric, roughdielectric, thindielectric, plastic, roughplastic, twosided, normalmap, bumpmap, blendbsdf and mask where raylab's materials hold them are)");
                self.approximate(
                    node,
                    format!("{message}: replaced by Mitsuba's default, diffuse 0.5"),
                )?;
                return Ok("Lambert(albedo: 0.5)".into());
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

    /// A blend weight or opacity in `[0, 1]`: the number, `None` when it is a texture (the
    /// texture is consumed), Mitsuba's 0.5 when absent.
    pub(super) fn constant_weight(
        &mut self,
        p: &mut Props<'a, 'input>,
        node: Node<'a, 'input>,
        name: &str,
    ) -> Result<Option<f32>, Located> {
        if let Some(i) = p.children.iter().position(|(n, _)| n == name) {
            p.children.remove(i);
            return Ok(None);
        }
        let w = p.float(name)?.unwrap_or(0.5);
        if !(0.0..=1.0).contains(&w) {
            return Err(at(
                self.doc,
                node,
                format!("`{name}` must lie in [0, 1], not {w}"),
            ));
        }
        Ok(Some(w))
    }

    /// Exactly `n` nested (or referenced) BSDFs of `node`.
    pub(super) fn nested_bsdfs(
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

    /// The material name for a BSDF node (written once, however many shapes use it).
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
        let desc = self.bsdf(node)?;
        let kind = self.kind(node)?;
        if matches!(
            kind.as_str(),
            "diffuse" | "conductor" | "roughconductor" | "plastic" | "roughplastic"
        ) {
            self.report.push(format!(
                "{name}: Mitsuba's `{kind}` is one-sided (black from behind); raylab's opaque \
                 materials are two-sided (as inside `twosided`)"
            ));
        }
        self.materials.push((name.clone(), desc));
        self.origins
            .push((false, name.clone(), position(self.doc, node)));
        self.material_of.insert(node.id(), name.clone());
        Ok(name)
    }
}
