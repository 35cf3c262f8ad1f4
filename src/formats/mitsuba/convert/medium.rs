//! Mitsuba's participating media: `homogeneous` and `heterogeneous` media with their phase
//! functions and volumes (`constvolume`, `gridvolume`), converted when a shape (`interior`,
//! `exterior`) or the sensor (`medium`) first refers to them.

use super::*;
use crate::formats::schema::{MediumDesc, PhaseDesc, VolumeDesc};

/// A volume as a medium's parameter: a constant (a `constvolume` placed by a `to_world`,
/// which bounds a heterogeneous medium), or a grid file placed by its `to_world`.
enum Coefficient {
    Constant(V3),
    Placed { value: V3, to_world: Affine3A },
    Grid { path: String, to_world: Affine3A },
}

impl Coefficient {
    /// The constant, if it is one.
    fn constant(&self) -> Option<V3> {
        match self {
            Coefficient::Constant(v) | Coefficient::Placed { value: v, .. } => Some(*v),
            Coefficient::Grid { .. } => None,
        }
    }
}

impl<'a, 'input> Converter<'a, 'input> {
    /// The medium at `node` (a `<medium>`, or a `<ref>` to one): its name in the media
    /// table, converted the first time.
    pub(super) fn medium(&mut self, node: Node<'a, 'input>) -> Result<String, Located> {
        let node = self.resolve(node)?;
        if node.tag_name().name() != "medium" {
            return Err(at(self.doc, node, "a <medium> is expected here"));
        }
        if let Some(name) = self.medium_of.get(&node.id()) {
            return Ok(name.clone());
        }
        let kind = self.kind(node)?;
        let mut name = attr(&self.params, self.doc, node, "id")?
            .unwrap_or_else(|| format!("{kind} medium #{}", self.media.len()));
        while self.media.iter().any(|(n, _)| *n == name) {
            name.push('\'');
        }
        let mut p = self.props(node)?;
        let scale = p.float("scale")?.unwrap_or(1.0);
        if p.boolean("sample_emitters")? == Some(false) {
            self.approximate(
                node,
                format!("{name}: sample_emitters false: raylab samples emitters from every medium"),
            )?;
        }
        // Whether Mitsuba may take the extinction to be one number: raylab follows the values.
        p.boolean("has_spectral_extinction")?;
        let mut phase = PhaseDesc::Isotropic;
        let mut volumes: Vec<(String, Node<'a, 'input>)> = Vec::new();
        for (child_name, child) in std::mem::take(&mut p.children) {
            let child = self.resolve(child)?;
            match child.tag_name().name() {
                "phase" => phase = self.phase(child)?,
                "volume" => volumes.push((child_name, child)),
                tag => {
                    return Err(at(
                        self.doc,
                        child,
                        format!("<{tag}> inside a medium is not supported"),
                    ))
                }
            }
        }
        let mut coefficient = |p: &mut Props<'a, 'input>,
                               this: &mut Self,
                               what: &str,
                               default: f32|
         -> Result<Coefficient, Located> {
            if let Some(i) = volumes.iter().position(|(n, _)| n == what) {
                let (_, v) = volumes.remove(i);
                return this.volume(v);
            }
            Ok(Coefficient::Constant(
                p.vector(what)?.unwrap_or([default; 3]),
            ))
        };
        let sigma_t = coefficient(&mut p, self, "sigma_t", 1.0)?;
        let albedo = coefficient(&mut p, self, "albedo", 0.75)?;
        if let Some((other, v)) = volumes.first() {
            return Err(at(
                self.doc,
                *v,
                format!("a medium's volume `{other}` is not one raylab reads (sigma_t, albedo)"),
            ));
        }
        p.finish(&[])?;
        let medium = match kind.as_str() {
            "homogeneous" => {
                // A homogeneous medium is unbounded: a constvolume's box does not matter.
                let (Some(sigma_t), Some(albedo)) = (sigma_t.constant(), albedo.constant()) else {
                    return Err(at(
                        self.doc,
                        node,
                        "a homogeneous medium's sigma_t and albedo are constants (a grid needs `heterogeneous`)",
                    ));
                };
                MediumDesc::Homogeneous {
                    sigma_t,
                    albedo,
                    scale,
                    phase,
                    emission: [0.0; 3],
                }
            }
            "heterogeneous" => self.heterogeneous(node, &name, sigma_t, albedo, scale, phase)?,
            other => {
                return Err(at(
                    self.doc,
                    node,
                    format!("medium `{other}` is not supported (homogeneous, heterogeneous are)"),
                ))
            }
        };
        self.media.push((name.clone(), medium));
        self.medium_of.insert(node.id(), name.clone());
        Ok(name)
    }

    /// Mitsuba's `heterogeneous`: vacuum outside the box of its `sigma_t` volume (the world
    /// box around the volume's unit cube), where the grids are placed.
    fn heterogeneous(
        &mut self,
        node: Node<'a, 'input>,
        name: &str,
        sigma_t: Coefficient,
        albedo: Coefficient,
        scale: f32,
        phase: PhaseDesc,
    ) -> Result<MediumDesc, Located> {
        let place = |c: &Coefficient| match c {
            Coefficient::Constant(_) => None,
            Coefficient::Placed { to_world, .. } | Coefficient::Grid { to_world, .. } => {
                Some(*to_world)
            }
        };
        // A constant sigma_t fills the unit cube its (absent) to_world places: Mitsuba's
        // constvolume has that box too.
        let to_world = place(&sigma_t).unwrap_or(Affine3A::IDENTITY);
        if let Some(other) = place(&albedo) {
            if other != to_world {
                return Err(at(
                    self.doc,
                    node,
                    "the albedo grid is placed differently from sigma_t's: raylab places a medium's grids together",
                ));
            }
        }
        let m = to_world.matrix3;
        let axis_aligned = [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)]
            .iter()
            .all(|&(c, r)| m.col(c)[r] == 0.0);
        if !axis_aligned {
            self.approximate(
                node,
                format!("{name}: a rotated volume: the medium fills the volume's own box, where Mitsuba's fills the axis-aligned box around it"),
            )?;
        }
        let volume = |c: Coefficient| match c {
            Coefficient::Constant(v) | Coefficient::Placed { value: v, .. } => {
                VolumeDesc::Constant(v)
            }
            Coefficient::Grid { path, .. } => VolumeDesc::Grid(path),
        };
        Ok(MediumDesc::Heterogeneous {
            sigma_t: Some(volume(sigma_t)),
            albedo: Some(volume(albedo)),
            sigma_a: None,
            sigma_s: None,
            scale,
            tint: [1.0; 3],
            phase,
            emission: [0.0; 3],
            emission_grid: None,
            transform: placed(&to_world),
            bounds: ([0.0; 3], [1.0; 3]),
        })
    }

    /// A `<volume>`: `constvolume` or `gridvolume`.
    fn volume(&mut self, node: Node<'a, 'input>) -> Result<Coefficient, Located> {
        let kind = self.kind(node)?;
        let mut p = self.props(node)?;
        let to_world = p.transform("to_world")?.unwrap_or(Affine3A::IDENTITY);
        let out = match kind.as_str() {
            "constvolume" => {
                let value = p.vector("value")?.unwrap_or([1.0; 3]);
                Coefficient::Placed { value, to_world }
            }
            "gridvolume" => {
                let path = p.string("filename")?.ok_or_else(|| {
                    at(
                        self.doc,
                        node,
                        "<volume type=\"gridvolume\"> needs `filename`",
                    )
                })?;
                let path = self.file_name(path);
                if p.boolean("use_grid_bbox")? == Some(true) {
                    return Err(at(
                        self.doc,
                        node,
                        "use_grid_bbox is not supported: place the grid with to_world",
                    ));
                }
                match p.string("filter_type")?.as_deref() {
                    None | Some("trilinear") => {}
                    Some(other) => {
                        return Err(at(
                            self.doc,
                            node,
                            format!("filter_type `{other}` is not supported (trilinear is)"),
                        ))
                    }
                }
                match p.string("wrap_mode")?.as_deref() {
                    None | Some("clamp") => {}
                    Some(other) => {
                        return Err(at(
                            self.doc,
                            node,
                            format!("wrap_mode `{other}` is not supported (clamp is)"),
                        ))
                    }
                }
                // RGB grids are read as stored in Mitsuba's RGB variants.
                p.boolean("raw")?;
                Coefficient::Grid { path, to_world }
            }
            other => {
                return Err(at(
                    self.doc,
                    node,
                    format!("volume `{other}` is not supported (constvolume, gridvolume are)"),
                ))
            }
        };
        p.finish(&[])?;
        Ok(out)
    }

    /// A `<phase>`: `isotropic` or `hg`.
    fn phase(&mut self, node: Node<'a, 'input>) -> Result<PhaseDesc, Located> {
        let kind = self.kind(node)?;
        let mut p = self.props(node)?;
        let phase = match kind.as_str() {
            "isotropic" => PhaseDesc::Isotropic,
            "hg" => {
                let g = p.float("g")?.unwrap_or(0.8);
                raylab_integrators::Phase::henyey_greenstein(g)
                    .map_err(|e| at(self.doc, node, e))?;
                PhaseDesc::HenyeyGreenstein(g)
            }
            other => {
                return Err(at(
                    self.doc,
                    node,
                    format!("phase function `{other}` is not supported (isotropic, hg are)"),
                ))
            }
        };
        p.finish(&[])?;
        Ok(phase)
    }
}
