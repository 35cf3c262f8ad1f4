//! `LightSource` and `AreaLightSource`: pbrt-v4's lights as raylab's emitters.

use super::*;

impl<'a> Converter<'a> {
    /// An emitter's colour: `rgb` as it is (pbrt-v4 normalises the illuminant, so rgb
    /// (1, 1, 1) renders as 1), any other spectrum as white of luminance 1 (pbrt-v4
    /// normalises it so; raylab does not reproduce its colour), times `scale` and the
    /// camera's exposure time.
    pub(super) fn light_colour(
        &mut self,
        p: &mut ParamList,
        name: &str,
    ) -> Result<[f64; 3], Located> {
        let scale = p.float("scale")?.unwrap_or(1.0);
        let c = self.emitted_rgb(p, name)?.unwrap_or([1.0; 3]);
        if c.iter().any(|x| *x < 0.0) || scale < 0.0 {
            return Err((p.at, format!("{}: negative emission", p.what)));
        }
        Ok(c.map(|x| x * scale * self.exposure))
    }

    /// The emitted colour `name` as written (`None` if absent), read as pbrt-v4 reads an
    /// illuminant spectrum: `rgb` as it is, `stdillum-D65` as white, any other spectrum as
    /// white of luminance 1 (with `--approximate`).
    pub(super) fn emitted_rgb(
        &mut self,
        p: &mut ParamList,
        name: &str,
    ) -> Result<Option<[f64; 3]>, Located> {
        Ok(Some(match p.colour(name)? {
            None => return Ok(None),
            Some((Colour::Rgb(v), _)) => v,
            Some((Colour::Named(n), _)) if n == "stdillum-D65" => {
                self.report(format!(
                    "{}: stdillum-D65 as white of luminance 1, as pbrt-v4 renders it",
                    p.what
                ));
                [1.0; 3]
            }
            Some((Colour::Texture(t), pos)) => {
                return Err((
                    pos,
                    format!("{}: `{name}` cannot be a texture (\"{t}\")", p.what),
                ))
            }
            Some((c, pos)) => {
                let what = match c {
                    Colour::Named(n) => format!("the spectrum \"{n}\""),
                    Colour::Blackbody(t) => format!("a blackbody of {t} K"),
                    _ => "a spectrum by wavelength".to_string(),
                };
                self.approximate(
                    pos,
                    format!("{}: `{name}` is {what}, which pbrt-v4 normalises to luminance 1: rendered white (its colour is not reproduced)", p.what),
                )?;
                [1.0; 3]
            }
        }))
    }

    pub(super) fn light(&mut self, d: &mut Directive) -> Result<(), Located> {
        let kind = d.strings[0].clone();
        let mut p = self.params(d)?;
        // pbrt-v4 looks up every light's medium (the outside one), though only point-like
        // lights use it.
        self.note_light_medium();
        let name = format!("{kind} light ({})", self.place(d.pos));
        let m = self.state.ctm;
        let f32s = |c: [f64; 3]| c.map(|x| x as f32);
        let (emitter, transform) = match kind.as_str() {
            "point" => {
                let mut i = self.light_colour(&mut p, "I")?;
                if let Some(power) = p.float("power")? {
                    i = i.map(|x| x * power / (4.0 * std::f64::consts::PI));
                }
                let from = p.point("from")?.unwrap_or([0.0; 3]);
                let at = m * DMat4::from_translation(d3(from));
                let a = affine(&at).ok_or_else(|| (d.pos, "a projective transform".to_string()))?;
                (EmitterDesc::Point { intensity: f32s(i) }, placed(&a))
            }
            "spot" => {
                let i = self.light_colour(&mut p, "I")?;
                let from = d3(p.point("from")?.unwrap_or([0.0; 3]));
                let to = d3(p.point("to")?.unwrap_or([0.0, 0.0, 1.0]));
                let cone = p.float("coneangle")?.unwrap_or(30.0);
                let delta = p.float("conedeltaangle")?.unwrap_or(5.0);
                // pbrt-v4's falloff: a smoothstep in the cosine over the same cone.
                let pos = m.transform_point3(from);
                let target = m.transform_point3(to);
                let spot = EmitterDesc::Spot {
                    intensity: f32s(i),
                    look_at: Some(f3(target)),
                    cutoff_angle: cone as f32,
                    beam_width: Some((cone - delta).max(0.0) as f32),
                    falloff: Some("smoothstep".into()),
                    texture: None,
                };
                let at = TransformDesc {
                    translate: f3(pos),
                    ..TransformDesc::default()
                };
                (spot, at)
            }
            "distant" => {
                let mut e = self.light_colour(&mut p, "L")?;
                if let Some(illum) = p.float("illuminance")? {
                    e = e.map(|x| x * illum);
                }
                let from = d3(p.point("from")?.unwrap_or([0.0; 3]));
                let to = d3(p.point("to")?.unwrap_or([0.0, 0.0, 1.0]));
                let dir = m.transform_vector3(to - from);
                if dir.length() == 0.0 {
                    return Err((
                        d.pos,
                        "LightSource \"distant\": from and to coincide".into(),
                    ));
                }
                let sun = EmitterDesc::Directional {
                    direction: f3(dir.normalize()),
                    irradiance: f32s(e),
                };
                (sun, TransformDesc::default())
            }
            "infinite" => {
                if let Some((file, pos)) = p.string_at("filename")? {
                    if p.present("L").is_some() || p.present("illuminance").is_some() {
                        return Err((pos, "LightSource \"infinite\": give `filename`, or `L` (and `illuminance`), not both".into()));
                    }
                    let scale = p.float("scale")?.unwrap_or(1.0) * self.exposure;
                    if let Some(portal) = p.present("portal") {
                        p.ignore(&["portal"]);
                        self.report(format!(
                            "{}: portal ignored at line {} (a sampling aid)",
                            p.what, portal.line
                        ));
                    }
                    p.finish()?;
                    // raylab's map frame has +y up where pbrt's light frame has +z: the
                    // resampled map is read through that turn, so the placement carries it.
                    let turn = DMat4::from_cols(DVec4::X, DVec4::Z, -DVec4::Y, DVec4::W);
                    let placed = affine(&(m * turn)).ok_or_else(|| {
                        (
                            d.pos,
                            "LightSource \"infinite\": a projective transform".to_string(),
                        )
                    })?;
                    self.report(format!("{}: pbrt-v4's equal-area octahedral map resampled at load into a latitude-longitude map (its nearest pixels, 4 texels across per map pixel)", p.what));
                    self.entities.push(EntityDesc::light(
                        name,
                        super::placed(&placed),
                        EmitterDesc::Environment {
                            path: file,
                            scale: scale as f32,
                            mapping: Some("octahedral".into()),
                        },
                    ));
                    return Ok(());
                }
                let mut l = self.light_colour(&mut p, "L")?;
                if let Some(illum) = p.float("illuminance")? {
                    l = l.map(|x| x * illum / std::f64::consts::PI);
                }
                if let Some(pos) = p.present("portal") {
                    p.ignore(&["portal"]);
                    self.report(format!(
                        "{}: portal ignored at {} (a sampling aid)",
                        p.what, pos.line
                    ));
                }
                p.finish()?;
                if let Some(prev) = self.environment {
                    l = [prev[0] + l[0], prev[1] + l[1], prev[2] + l[2]];
                }
                self.environment = Some(l);
                return Ok(());
            }
            other => {
                return Err((
                    d.pos,
                    format!(
                    "LightSource \"{other}\" is not supported (point, spot, distant, infinite are)"
                ),
                ))
            }
        };
        p.finish()?;
        self.entities
            .push(EntityDesc::light(name, transform, emitter));
        Ok(())
    }

    pub(super) fn area_light(&mut self, d: &mut Directive) -> Result<(), Located> {
        if d.strings[0] != "diffuse" {
            return Err((
                d.pos,
                format!(
                    "AreaLightSource \"{}\" is not supported (diffuse is)",
                    d.strings[0]
                ),
            ));
        }
        let mut p = self.params(d)?;
        if let Some(pos) = p.present("filename") {
            return Err((
                pos,
                "AreaLightSource: an emission image is not supported".into(),
            ));
        }
        let l = self.light_colour(&mut p, "L")?;
        let two = p.boolean("twosided")?.unwrap_or(false);
        let power = p.float("power")?;
        p.finish()?;
        self.state.area = Some((l, two, power, d.pos));
        Ok(())
    }
}
