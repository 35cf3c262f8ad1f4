//! The graphics state's materials and textures: named and current materials, and
//! `Texture` directives, as RON.

use super::*;

impl<'a> Converter<'a> {
    pub(super) fn material(
        &mut self,
        kind: &str,
        p: &mut ParamList,
    ) -> Result<Option<String>, Located> {
        // The textures are lent out while the converter takes the notes.
        let textures = std::mem::take(&mut self.textures);
        let out = materials::material(kind, p, &textures, self);
        self.textures = textures;
        let out = out?;
        p.finish()?;
        Ok(out)
    }

    /// Adds a material under `name` (or a variant of it that is free) and returns the name.
    pub(super) fn add_material(&mut self, name: &str, ron: String) -> String {
        let mut name = name.to_string();
        while self.material_rons.contains_key(&name) {
            name.push('\'');
        }
        self.material_rons.insert(name.clone(), ron.clone());
        self.material_by_ron
            .entry(ron.clone())
            .or_insert_with(|| name.clone());
        self.materials.push((name.clone(), ron));
        name
    }

    /// The RON description of the current material, `None` for `interface`.
    pub(super) fn current_material_ron(&self) -> Option<String> {
        match &self.state.material {
            Current::Desc { ron, .. } => ron.clone(),
            Current::Named(name) => self.material_rons.get(name).cloned(),
        }
    }

    /// The RON name of the current material, `None` for `interface`.
    pub(super) fn current_material(&mut self) -> Option<String> {
        match self.state.material.clone() {
            Current::Named(name) => Some(name),
            Current::Desc { ron: None, .. } => None,
            Current::Desc {
                ron: Some(ron),
                kind,
            } => {
                if let Some(name) = self.material_by_ron.get(&ron) {
                    return Some(name.clone());
                }
                let count = self.materials.len() + 1;
                Some(self.add_material(&format!("{kind} {count}"), ron))
            }
        }
    }

    /// The RON of the texture `name` of type `ty` (`float` or `spectrum`).
    pub(super) fn named_texture(
        &self,
        ty: &str,
        name: &str,
        pos: Pos,
        what: &str,
    ) -> Result<String, Located> {
        let map = if ty == "float" {
            &self.textures.float
        } else {
            &self.textures.spectrum
        };
        map.get(name)
            .cloned()
            .ok_or_else(|| (pos, format!("{what}: no {ty} texture is named \"{name}\"")))
    }

    pub(super) fn texture(&mut self, d: &mut Directive) -> Result<(), Located> {
        let (name, ty, class) = (
            d.strings[0].clone(),
            d.strings[1].clone(),
            d.strings[2].clone(),
        );
        let mut p = self.params(d)?;
        let what = p.what.clone();
        let mapping = |p: &mut ParamList| -> Result<[f64; 4], Located> {
            if let Some((m, pos)) = p.string_at("mapping")? {
                if m != "uv" {
                    return Err((
                        pos,
                        format!("{what}: mapping \"{m}\" is not supported (uv is)"),
                    ));
                }
            }
            Ok([
                p.float("uscale")?.unwrap_or(1.0),
                p.float("vscale")?.unwrap_or(1.0),
                p.float("udelta")?.unwrap_or(0.0),
                p.float("vdelta")?.unwrap_or(0.0),
            ])
        };
        let ron = match class.as_str() {
            "imagemap" => {
                let file = p.string("filename")?.ok_or_else(|| (d.pos, format!("{what} needs \"string filename\"")))?;
                let [su, sv, du, dv] = mapping(&mut p)?;
                let filter = match p.string("filter")?.as_deref() {
                    None | Some("bilinear") => "bilinear",
                    Some("point") => "nearest",
                    Some(f @ ("trilinear" | "ewa" | "EWA")) => {
                        self.report(format!("{what}: filter \"{f}\" as bilinear (raylab does not prefilter textures)"));
                        "bilinear"
                    }
                    Some(f) => return Err((d.pos, format!("{what}: filter \"{f}\" is not known"))),
                };
                let wrap = match p.string("wrap")?.as_deref() {
                    None | Some("repeat") => "repeat",
                    Some("clamp") => "clamp",
                    Some("octahedralsphere") | Some("black") | Some(_) => {
                        return Err((d.pos, format!("{what}: only \"repeat\" and \"clamp\" wraps are supported")))
                    }
                };
                let linear = match p.string("encoding")?.as_deref() {
                    None => {
                        let lower = file.to_ascii_lowercase();
                        ![".png", ".jpg", ".jpeg", ".tga", ".bmp"].iter().any(|e| lower.ends_with(e))
                    }
                    Some("linear") => true,
                    Some("sRGB") => false,
                    Some(e) => return Err((d.pos, format!("{what}: encoding \"{e}\" is not supported (sRGB, linear are)"))),
                };
                if p.float("scale")?.is_some_and(|s| s != 1.0) || p.boolean("invert")? == Some(true) {
                    return Err((d.pos, format!("{what}: `scale` and `invert` are not supported on image textures")));
                }
                p.ignore(&["maxanisotropy"]);
                // pbrt-v4 looks images up at (s, 1 - t); raylab at (u, v) from the top row.
                format!(
                    "Image(path: {}, filter: \"{filter}\", wrap: \"{wrap}\", raw: {linear}, uv_scale: ({}, {}), uv_offset: ({}, {}))",
                    quote(&file), num(su as f32), num(-sv as f32), num(du as f32), num((1.0 - dv) as f32)
                )
            }
            "checkerboard" => {
                if p.integer("dimension")?.is_some_and(|n| n != 2) {
                    return Err((d.pos, format!("{what}: only the 2D checkerboard is supported")));
                }
                let [su, sv, du, dv] = mapping(&mut p)?;
                let side = |p: &mut ParamList, name: &str, default: f64| -> Result<String, Located> {
                    let c = if ty == "float" { p.float_or_texture(name)? } else { p.colour(name)? };
                    match c {
                        None => Ok(num(default as f32)),
                        Some((Colour::Rgb(v), _)) => Ok(v3(v.map(|x| x as f32))),
                        Some((_, pos)) => Err((pos, format!("{what}: `{name}` must be a constant colour (raylab's checkerboard has no nested textures)"))),
                    }
                };
                let (t1, t2) = (side(&mut p, "tex1", 1.0)?, side(&mut p, "tex2", 0.0)?);
                // pbrt-v4's squares are one unit wide; Mitsuba's (raylab's) half a unit, with
                // color0 where floor(s) + floor(t) is even as pbrt's tex1.
                format!(
                    "Checkerboard(color0: {t1}, color1: {t2}, uv_scale: ({}, {}), uv_offset: ({}, {}))",
                    num((su * 0.5) as f32), num((sv * 0.5) as f32), num((du * 0.5) as f32), num((dv * 0.5) as f32)
                )
            }
            "constant" => {
                let c = if ty == "float" { p.float_or_texture("value")? } else { p.colour("value")? };
                match c {
                    None => "1.0".to_string(),
                    Some((Colour::Texture(t), pos)) => self.named_texture(&ty, &t, pos, &what)?,
                    Some((Colour::Rgb(v), _)) if ty == "float" => num(v[0] as f32),
                    Some((c, pos)) => {
                        let textures = std::mem::take(&mut self.textures);
                        let r = materials::colour(&c, pos, &what, &textures, self);
                        self.textures = textures;
                        r?
                    }
                }
            }
            "scale" => {
                // Both default to 1.
                let one = |c: Option<(Colour, Pos)>| c.or(Some((Colour::Rgb([1.0; 3]), d.pos)));
                let tex = one(if ty == "float" { p.float_or_texture("tex")? } else { p.colour("tex")? });
                let scale = one(p.float_or_texture("scale")?);
                let unit = |s: &Option<(Colour, Pos)>| match s {
                    None => true,
                    Some((Colour::Rgb(v), _)) => v[0] == 1.0,
                    _ => false,
                };
                match (tex, scale) {
                    (Some((Colour::Rgb(a), _)), Some((Colour::Rgb(s), _))) if ty == "float" => {
                        num((a[0] * s[0]) as f32)
                    }
                    (Some((Colour::Rgb(a), _)), Some((Colour::Rgb(s), _))) => {
                        v3([a[0] * s[0], a[1] * s[0], a[2] * s[0]].map(|x| x as f32))
                    }
                    (Some((Colour::Texture(t), pos)), s) if unit(&s) => {
                        self.named_texture(&ty, &t, pos, &what)?
                    }
                    _ => return Err((d.pos, format!("{what}: a scale texture is supported for a constant times a constant, or a texture times 1"))),
                }
            }
            other => return Err((d.pos, format!("{what}: texture \"{other}\" is not supported (imagemap, checkerboard, constant, scale are)"))),
        };
        p.finish()?;
        match ty.as_str() {
            "spectrum" => self.textures.spectrum.insert(name, ron),
            "float" => self.textures.float.insert(name, ron),
            other => {
                return Err((
                    d.pos,
                    format!(
                        "Texture \"{name}\": type \"{other}\" must be \"spectrum\" or \"float\""
                    ),
                ))
            }
        };
        Ok(())
    }
}
