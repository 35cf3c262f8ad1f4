//! The graphics state's materials and textures: named and current materials, and
//! `Texture` directives.

use super::*;
use crate::formats::texture_desc::{CheckerboardDesc, ImageDesc, TextureDesc};

/// A `Texture` directive's value, by the type it was declared with.
enum Made {
    Spectrum(ColorDesc),
    Float(FloatDesc),
}

impl Made {
    /// A constant of the declared type (a float texture takes the first part).
    fn constant(ty: &str, c: [f32; 3]) -> Made {
        if ty == "float" {
            Made::Float(FloatDesc::Constant(c[0]))
        } else {
            Made::Spectrum(ColorDesc::Constant(c))
        }
    }

    fn texture(ty: &str, t: TextureDesc) -> Made {
        if ty == "float" {
            Made::Float(FloatDesc::Texture(t))
        } else {
            Made::Spectrum(ColorDesc::Texture(t))
        }
    }
}

impl<'a> Converter<'a> {
    pub(super) fn material(
        &mut self,
        kind: &str,
        p: &mut ParamList,
    ) -> Result<Option<MaterialDesc>, Located> {
        // The textures are lent out while the converter takes the notes.
        let textures = std::mem::take(&mut self.textures);
        let out = materials::material(kind, p, &textures, self);
        self.textures = textures;
        let out = out?;
        p.finish()?;
        Ok(out)
    }

    /// Adds a material under `name` (or a variant of it that is free) and returns the name.
    pub(super) fn add_material(&mut self, name: &str, desc: MaterialDesc) -> String {
        let mut name = name.to_string();
        while self.material_descs.contains_key(&name) {
            name.push('\'');
        }
        self.material_descs.insert(name.clone(), desc.clone());
        self.material_by_desc
            .entry(material_key(&desc))
            .or_insert_with(|| name.clone());
        self.materials.push((name.clone(), desc));
        name
    }

    /// The description of the current material, `None` for `interface`.
    pub(super) fn current_material_desc(&self) -> Option<&MaterialDesc> {
        match &self.state.material {
            Current::Desc { desc, .. } => desc.as_deref(),
            Current::Named(name) => self.material_descs.get(name),
        }
    }

    /// The name of the current material in the scene's table, `None` for `interface`. An
    /// anonymous material joins the table when a shape first uses it, shared with any alike.
    pub(super) fn current_material(&mut self) -> Option<String> {
        let (desc, kind, key) = match &self.state.material {
            Current::Named(name) => return Some(name.clone()),
            Current::Desc { desc: None, .. } => return None,
            Current::Desc {
                desc: Some(desc),
                kind,
                key,
            } => (desc, kind, key),
        };
        if let Some(name) = self.material_by_desc.get(key) {
            return Some(name.clone());
        }
        let (desc, name) = (
            (**desc).clone(),
            format!("{kind} {}", self.materials.len() + 1),
        );
        Some(self.add_material(&name, desc))
    }

    /// The texture `name` of type `ty` (`float` or `spectrum`).
    fn named_texture(&self, ty: &str, name: &str, pos: Pos, what: &str) -> Result<Made, Located> {
        let missing = || (pos, format!("{what}: no {ty} texture is named \"{name}\""));
        if ty == "float" {
            let t = self.textures.float.get(name).ok_or_else(missing)?;
            Ok(Made::Float(t.clone()))
        } else {
            let t = self.textures.spectrum.get(name).ok_or_else(missing)?;
            Ok(Made::Spectrum(t.clone()))
        }
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
        let made = match class.as_str() {
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
                // pbrt-v4 (Image::Read): a PNG is decoded as `encoding` says (default sRGB);
                // what stb_image reads (TGA, JPEG, BMP, ...) always as sRGB, whatever
                // `encoding` says; EXR, PFM and HDR hold linear floats.
                let lower = file.to_ascii_lowercase();
                let float = [".exr", ".pfm", ".hdr"].iter().any(|e| lower.ends_with(e));
                let linear = match p.string("encoding")?.as_deref() {
                    _ if float => true,
                    _ if !lower.ends_with(".png") => false,
                    None | Some("sRGB") => false,
                    Some("linear") => true,
                    Some(e) => return Err((d.pos, format!("{what}: encoding \"{e}\" is not supported (sRGB, linear are)"))),
                };
                if p.boolean("invert")? == Some(true) {
                    return Err((d.pos, format!("{what}: `invert` is not supported on image textures")));
                }
                let scale = match p.float("scale")? {
                    None => 1.0,
                    Some(s) if s.is_finite() && s >= 0.0 => s as f32,
                    Some(s) => return Err((d.pos, format!("{what}: `scale` must be finite and not negative, got {s}"))),
                };
                p.ignore(&["maxanisotropy"]);
                // pbrt-v4 looks images up at (s, 1 - t); raylab at (u, v) from the top row.
                let image = ImageDesc {
                    path: file,
                    filter: filter.into(),
                    wrap: wrap.into(),
                    raw: Some(linear),
                    uv_scale: [su as f32, -sv as f32],
                    uv_offset: [du as f32, (1.0 - dv) as f32],
                    scale,
                };
                Made::texture(&ty, TextureDesc::Image(image))
            }
            "checkerboard" => {
                if p.integer("dimension")?.is_some_and(|n| n != 2) {
                    return Err((d.pos, format!("{what}: only the 2D checkerboard is supported")));
                }
                let [su, sv, du, dv] = mapping(&mut p)?;
                let side = |p: &mut ParamList, name: &str, default: f64| -> Result<[f32; 3], Located> {
                    let c = if ty == "float" { p.float_or_texture(name)? } else { p.colour(name)? };
                    match c {
                        None => Ok([default as f32; 3]),
                        Some((Colour::Rgb(v), _)) => Ok(v.map(|x| x as f32)),
                        Some((_, pos)) => Err((pos, format!("{what}: `{name}` must be a constant colour (raylab's checkerboard has no nested textures)"))),
                    }
                };
                let (t1, t2) = (side(&mut p, "tex1", 1.0)?, side(&mut p, "tex2", 0.0)?);
                // pbrt-v4's squares are one unit wide; Mitsuba's (raylab's) half a unit, with
                // color0 where floor(s) + floor(t) is even as pbrt's tex1.
                let checks = CheckerboardDesc {
                    color0: t1,
                    color1: t2,
                    uv_scale: [(su * 0.5) as f32, (sv * 0.5) as f32],
                    uv_offset: [(du * 0.5) as f32, (dv * 0.5) as f32],
                };
                Made::texture(&ty, TextureDesc::Checkerboard(checks))
            }
            "constant" => {
                let c = if ty == "float" { p.float_or_texture("value")? } else { p.colour("value")? };
                match c {
                    None => Made::constant(&ty, [1.0; 3]),
                    Some((Colour::Texture(t), pos)) => self.named_texture(&ty, &t, pos, &what)?,
                    Some((Colour::Rgb(v), _)) if ty == "float" => Made::constant(&ty, [v[0] as f32; 3]),
                    Some((c, pos)) => {
                        let textures = std::mem::take(&mut self.textures);
                        let r = materials::colour(&c, pos, &what, &textures, self);
                        self.textures = textures;
                        match r? {
                            ColorDesc::Constant(c) => Made::constant(&ty, c),
                            ColorDesc::Texture(t) => Made::texture(&ty, t),
                            ColorDesc::Spectrum(p) => Made::constant(&ty, ColorDesc::spectrum_colour(&p)),
                        }
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
                        Made::constant(&ty, [(a[0] * s[0]) as f32; 3])
                    }
                    (Some((Colour::Rgb(a), _)), Some((Colour::Rgb(s), _))) => {
                        Made::constant(&ty, [a[0] * s[0], a[1] * s[0], a[2] * s[0]].map(|x| x as f32))
                    }
                    (Some((Colour::Texture(t), pos)), s) if unit(&s) => {
                        self.named_texture(&ty, &t, pos, &what)?
                    }
                    (Some((Colour::Texture(t), pos)), Some((Colour::Rgb(s), _))) if s[0] >= 0.0 && s[0].is_finite() => {
                        match self.named_texture(&ty, &t, pos, &what)? {
                            Made::Spectrum(ColorDesc::Texture(t)) => Made::Spectrum(ColorDesc::Texture(t.scaled(s[0] as f32))),
                            Made::Float(FloatDesc::Texture(t)) => Made::Float(FloatDesc::Texture(t.scaled(s[0] as f32))),
                            Made::Spectrum(ColorDesc::Constant(c)) => Made::constant(&ty, c.map(|x| x * s[0] as f32)),
                            Made::Spectrum(c @ ColorDesc::Spectrum(_)) => Made::Spectrum(c.scaled(s[0] as f32)),
                            Made::Float(FloatDesc::Constant(c)) => Made::constant(&ty, [c * s[0] as f32; 3]),
                        }
                    }
                    _ => return Err((d.pos, format!("{what}: a scale texture is supported for a constant or a texture times a constant (not negative)"))),
                }
            }
            other => return Err((d.pos, format!("{what}: texture \"{other}\" is not supported (imagemap, checkerboard, constant, scale are)"))),
        };
        p.finish()?;
        match (ty.as_str(), made) {
            ("spectrum", Made::Spectrum(c)) => {
                self.textures.spectrum.insert(name, c);
            }
            ("float", Made::Float(f)) => {
                self.textures.float.insert(name, f);
            }
            (other, _) => {
                return Err((
                    d.pos,
                    format!(
                        "Texture \"{name}\": type \"{other}\" must be \"spectrum\" or \"float\""
                    ),
                ))
            }
        }
        Ok(())
    }
}

/// What makes two materials the same for sharing one entry of the table: their
/// description, written out (a description is not hashable; its `Debug` text is exact).
pub(super) fn material_key(desc: &MaterialDesc) -> String {
    format!("{desc:?}")
}
