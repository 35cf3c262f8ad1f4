//! `LightSource` and `AreaLightSource`: pbrt-v4's lights as raylab's emitters.

use super::*;
use crate::formats::texture_desc::narrow;
use raylab_integrators::spectrum::curve::Curve;
use raylab_integrators::spectrum::named;

impl<'a> Converter<'a> {
    /// An emitter's colour: `rgb` as it is (pbrt-v4 normalises the illuminant, so rgb
    /// (1, 1, 1) renders as 1), any other spectrum normalised to luminance 1 as pbrt-v4
    /// normalises it, times `scale` and the camera's exposure time.
    pub(super) fn light_colour(
        &mut self,
        p: &mut ParamList,
        name: &str,
    ) -> Result<[f64; 3], Located> {
        Ok(self.light_emission(p, name)?.0)
    }

    /// [`Self::light_colour`], and where the colour was given as a spectrum (by wavelength,
    /// by name or by temperature) that spectrum of luminance 1 as (nm, value) pairs with the
    /// factor the colour was scaled by.
    #[allow(clippy::type_complexity)]
    pub(super) fn light_emission(
        &mut self,
        p: &mut ParamList,
        name: &str,
    ) -> Result<([f64; 3], Option<(Vec<(f64, f64)>, f64)>), Located> {
        let scale = p.float("scale")?.unwrap_or(1.0);
        let (c, spectrum) = self.emitted(p, name)?.unwrap_or(([1.0; 3], None));
        if c.iter().any(|x| *x < 0.0) || scale < 0.0 {
            return Err((p.at, format!("{}: negative emission", p.what)));
        }
        let s = scale * self.exposure;
        Ok((c.map(|x| x * s), spectrum.map(|pairs| (pairs, s))))
    }

    /// The emitted colour `name` as written (`None` if absent), read as pbrt-v4 reads an
    /// illuminant spectrum: `rgb` as it is, `stdillum-D65` as white, any other spectrum as
    /// its colour at luminance 1.
    pub(super) fn emitted_rgb(
        &mut self,
        p: &mut ParamList,
        name: &str,
    ) -> Result<Option<[f64; 3]>, Located> {
        Ok(self.emitted(p, name)?.map(|(c, _)| c))
    }

    /// [`Self::emitted_rgb`], with the spectrum of luminance 1 behind a colour given as one.
    #[allow(clippy::type_complexity)]
    fn emitted(
        &mut self,
        p: &mut ParamList,
        name: &str,
    ) -> Result<Option<([f64; 3], Option<Vec<(f64, f64)>>)>, Located> {
        let (curve, what, pos) = match p.colour(name)? {
            None => return Ok(None),
            Some((Colour::Rgb(v), _)) => return Ok(Some((v, None))),
            Some((Colour::Named(n), _)) if n == "stdillum-D65" => {
                // sRGB's white is D65 of luminance 1: raylab's white, in both modes.
                self.report(format!(
                    "{}: stdillum-D65 as white of luminance 1, as pbrt-v4 renders it",
                    p.what
                ));
                return Ok(Some(([1.0; 3], None)));
            }
            Some((Colour::Texture(t), pos)) => {
                return Err((
                    pos,
                    format!("{}: `{name}` cannot be a texture (\"{t}\")", p.what),
                ))
            }
            Some((Colour::Named(n), pos)) => {
                let curve = named::pbrt(&n).ok_or_else(|| {
                    (
                        pos,
                        format!(
                            "{}: `{name}`: pbrt-v4 has no spectrum named \"{n}\"",
                            p.what
                        ),
                    )
                })?;
                (curve, format!("the spectrum \"{n}\""), pos)
            }
            Some((Colour::Blackbody(t), pos)) => {
                if !(t.is_finite() && t > 0.0) {
                    return Err((pos, format!("{}: a blackbody of {t} K", p.what)));
                }
                let curve = Curve::Blackbody {
                    kelvin: t as f32,
                    scale: 1.0,
                };
                (curve, format!("a blackbody of {t} K"), pos)
            }
            Some((Colour::Sampled(pairs), pos)) => {
                let curve = Curve::table(&narrow(&pairs))
                    .map_err(|e| (pos, format!("{}: `{name}`: {e}", p.what)))?;
                (curve, "a spectrum by wavelength".to_string(), pos)
            }
        };
        let y = named::luminance(&curve);
        if !(y.is_finite() && y > 0.0) {
            return Err((
                pos,
                format!("{}: `{name}` ({what}) emits no visible light", p.what),
            ));
        }
        let pairs = curve.scaled(1.0 / y).pairs();
        // Its colour as every emitter's spectrum gets one (negative channels cut).
        let rgb = crate::formats::spectra::to_srgb(&pairs, crate::formats::spectra::Use::Emission)
            .map_err(|e| (pos, format!("{}: `{name}`: {e}", p.what)))?
            .map(|c| c.max(0.0));
        self.report(format!(
            "{}: `{name}` is {what}, normalised to luminance 1 as pbrt-v4 does: colour ({:.4}, {:.4}, {:.4}) in RGB mode",
            p.what, rgb[0], rgb[1], rgb[2]
        ));
        Ok(Some((rgb, Some(pairs))))
    }

    pub(super) fn light(&mut self, d: &mut Directive) -> Result<(), Located> {
        let kind = d.strings[0].clone();
        let mut p = self.params(d)?;
        // pbrt-v4 looks up every light's medium (the outside one), though only point-like
        // lights use it.
        self.note_light_medium();
        let name = format!("{kind} light ({})", self.place(d.pos));
        let m = self.state.ctm;
        // The colour times `k`, or where a spectrum was given, a grey scale and the spectrum.
        #[allow(clippy::type_complexity)]
        let emitted = |(rgb, spectrum): ([f64; 3], Option<(Vec<(f64, f64)>, f64)>),
                       k: f64|
         -> ([f32; 3], Option<Vec<(f64, f64)>>) {
            match spectrum {
                Some((pairs, s)) => ([(s * k) as f32; 3], Some(pairs)),
                None => (rgb.map(|x| (x * k) as f32), None),
            }
        };
        let (emitter, transform) = match kind.as_str() {
            "point" => {
                let light = self.light_emission(&mut p, "I")?;
                let k = match p.float("power")? {
                    Some(power) => power / (4.0 * std::f64::consts::PI),
                    None => 1.0,
                };
                let (intensity, spectrum) = emitted(light, k);
                let from = p.point("from")?.unwrap_or([0.0; 3]);
                let at = m * DMat4::from_translation(d3(from));
                let a = affine(&at).ok_or_else(|| (d.pos, "a projective transform".to_string()))?;
                (
                    EmitterDesc::Point {
                        intensity,
                        spectrum,
                    },
                    placed(&a),
                )
            }
            "spot" => {
                let (intensity, spectrum) = emitted(self.light_emission(&mut p, "I")?, 1.0);
                let from = d3(p.point("from")?.unwrap_or([0.0; 3]));
                let to = d3(p.point("to")?.unwrap_or([0.0, 0.0, 1.0]));
                let cone = p.float("coneangle")?.unwrap_or(30.0);
                let delta = p.float("conedeltaangle")?.unwrap_or(5.0);
                // pbrt-v4's falloff: a smoothstep in the cosine over the same cone.
                let pos = m.transform_point3(from);
                let target = m.transform_point3(to);
                let spot = EmitterDesc::Spot {
                    intensity,
                    look_at: Some(f3(target)),
                    cutoff_angle: cone as f32,
                    beam_width: Some((cone - delta).max(0.0) as f32),
                    falloff: Some("smoothstep".into()),
                    texture: None,
                    spectrum,
                };
                let at = TransformDesc {
                    translate: f3(pos),
                    ..TransformDesc::default()
                };
                (spot, at)
            }
            "distant" => {
                let light = self.light_emission(&mut p, "L")?;
                let k = p.float("illuminance")?.unwrap_or(1.0);
                let (irradiance, spectrum) = emitted(light, k);
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
                    irradiance,
                    spectrum,
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
        let (l, spectrum) = self.light_emission(&mut p, "L")?;
        let two = p.boolean("twosided")?.unwrap_or(false);
        let power = p.float("power")?;
        p.finish()?;
        self.state.area = Some(AreaLight {
            radiance: l,
            spectrum,
            two_sided: two,
            power,
            pos: d.pos,
        });
        Ok(())
    }
}
