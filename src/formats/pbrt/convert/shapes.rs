//! `Shape` and `ObjectInstance`: pbrt-v4's shapes as raylab's entities, with their area
//! lights and the areas their power divides by; inline meshes. (Curves: [`super::curves`].)

use super::textures::material_key;
use super::*;
use crate::formats::schema::MeshNormals;

/// What an area light's `power` needs: the area pbrt-v4 divides by. pbrt makes one light
/// per triangle or patch, each of its own world-space area, and a quadric's light takes the
/// quadric's unplaced area.
enum Area {
    Known(f64),
    PerPrimitive(Vec<f64>),
    Unknown,
}

impl Area {
    /// The one area every light of the shape divides by, if there is one.
    pub(super) fn single(&self) -> Result<f64, &'static str> {
        match self {
            Area::Known(a) => Ok(*a),
            Area::PerPrimitive(areas) => {
                let first = areas.first().copied().unwrap_or(0.0);
                if areas.iter().all(|a| (a - first).abs() <= 1e-4 * first) {
                    Ok(first)
                } else {
                    Err("its triangles differ in area, and pbrt-v4 gives each the radiance of its own area")
                }
            }
            Area::Unknown => Err("its area is not known before loading"),
        }
    }
}

/// An inline mesh, with the world-space area of each of its primitives (triangles, or
/// bilinear patches).
struct Mesh {
    shape: ShapeDesc,
    areas: Vec<f64>,
}

/// How a mesh is written: where it faces from, and whether it needs pbrt's default texture
/// coordinates.
struct MeshFrame {
    /// The placement its areas are measured after.
    world: DMat4,
    /// The space its facing is decided in: the world for a shape, the object's own space for
    /// a shape of an object definition (an instance's placement turns its normals as
    /// normals, which keeps their side).
    orient: DMat4,
    /// Write pbrt-v4's default texture coordinates when the file gives none.
    default_uvs: bool,
}

impl<'a> Converter<'a> {
    pub(super) fn shape(&mut self, d: &mut Directive) -> Result<(), Located> {
        let kind = d.strings[0].clone();
        let mut p = self.params(d)?;
        let what = p.what.clone();
        let alpha = self.alpha(&mut p)?;
        if kind == "curve" {
            return self.curve(d, p, alpha);
        }
        let world = self.state.ctm;
        let swaps = world.determinant() < 0.0;
        // pbrt-v4 turns a shape's normal around under ReverseOrientation and under a
        // transform that swaps handedness; raylab's flip_normals turns it around.
        let mut flip = self.state.reverse ^ swaps;
        let textured = self
            .current_material_desc()
            .is_some_and(MaterialDesc::is_textured);
        if textured && matches!(kind.as_str(), "sphere" | "disk" | "cylinder") {
            self.approximate(d.pos, format!("{what}: a texture on a {kind} is looked up at Mitsuba's texture coordinates of it, not pbrt-v4's"))?;
        }
        let (shape, local, is_mesh, area) = match kind.as_str() {
            "sphere" => {
                let r = p.float("radius")?.unwrap_or(1.0);
                let partial = p.float("zmin")?.is_some_and(|z| z > -r)
                    | p.float("zmax")?.is_some_and(|z| z < r)
                    | p.float("phimax")?.is_some_and(|a| a < 360.0);
                if partial {
                    return Err((d.pos, format!("{what}: a partial sphere (zmin, zmax, phimax) is not supported")));
                }
                let sphere = ShapeDesc::Sphere { center: [0.0; 3], radius: r as f32 };
                (sphere, DMat4::IDENTITY, false, Area::Known(4.0 * std::f64::consts::PI * r * r))
            }
            "disk" => {
                let h = p.float("height")?.unwrap_or(0.0);
                let r = p.float("radius")?.unwrap_or(1.0);
                if p.float("innerradius")?.is_some_and(|x| x > 0.0) | p.float("phimax")?.is_some_and(|a| a < 360.0) {
                    return Err((d.pos, format!("{what}: an annulus or a partial disk is not supported")));
                }
                let local = DMat4::from_translation(DVec3::new(0.0, 0.0, h)) * DMat4::from_scale(DVec3::new(r, r, 1.0));
                (ShapeDesc::Disk, local, false, Area::Known(std::f64::consts::PI * r * r))
            }
            "cylinder" => {
                let r = p.float("radius")?.unwrap_or(1.0);
                let (za, zb) = (p.float("zmin")?.unwrap_or(-1.0), p.float("zmax")?.unwrap_or(1.0));
                let (z0, z1) = (za.min(zb), za.max(zb));
                if p.float("phimax")?.is_some_and(|a| a < 360.0) {
                    return Err((d.pos, format!("{what}: a partial cylinder is not supported")));
                }
                let cylinder = ShapeDesc::Cylinder {
                    p0: [0.0, 0.0, z0 as f32],
                    p1: [0.0, 0.0, z1 as f32],
                    radius: r as f32,
                };
                (cylinder, DMat4::IDENTITY, false, Area::Known(2.0 * std::f64::consts::PI * r * (z1 - z0)))
            }
            "trianglemesh" | "bilinearmesh" => {
                let frame = MeshFrame {
                    world,
                    orient: if self.defining.is_some() { DMat4::IDENTITY } else { world },
                    default_uvs: textured,
                };
                let mesh = self.mesh(&kind, &mut p, &frame)?;
                // Each triangle already faces where pbrt-v4's does.
                flip = false;
                (mesh.shape, DMat4::IDENTITY, true, Area::PerPrimitive(mesh.areas))
            }
            "plymesh" => {
                let file = p.string("filename")?.ok_or_else(|| (d.pos, format!("{what} needs \"string filename\"")))?;
                if let Some(pos) = p.present("displacement") {
                    self.approximate(pos, format!("{what}: displacement ignored"))?;
                    p.ignore(&["displacement", "edgelength"]);
                }
                if self.defining.is_some() && flip {
                    return Err((d.pos, format!("{what}: a PLY mesh turned around (ReverseOrientation or a mirroring transform) inside an object definition is not supported")));
                }
                self.report(format!("{what}: faces by its winding; pbrt-v4 faces a PLY mesh with normals towards them"));
                let ply = ShapeDesc::Ply { path: file, normals: MeshNormals::File, attribute: None };
                (ply, DMat4::IDENTITY, true, Area::Unknown)
            }
            other => return Err((d.pos, format!("Shape \"{other}\" is not supported (sphere, disk, cylinder, trianglemesh, bilinearmesh, plymesh, curve are)"))),
        };
        p.ignore(&["emissionfilename"]);
        p.finish()?;
        let medium = self.shape_media();
        // A shape with the `interface` material: a `Null` surface where it bounds a medium,
        // without its area light or alpha.
        let (material, area_light, alpha) = match self.current_material() {
            Some(material) => (material, self.state.area.clone(), alpha),
            None => {
                let bounds_medium = medium.is_some();
                let null = self.interface_material(d.pos, &what, bounds_medium, alpha.is_some())?;
                let Some(null) = null else {
                    return Ok(());
                };
                (null, None, None)
            }
        };
        let material = match alpha {
            None => material,
            Some(_) if area_light.is_some() => {
                return Err((
                    d.pos,
                    format!("{what}: an alpha cut-out on an area light is not supported"),
                ))
            }
            Some(alpha) => self.cut_out(material, alpha),
        };
        let placed = world * local;
        let name = format!("{kind} ({})", self.place(d.pos));
        if let Some((shapes_name, _, _)) = &self.defining {
            if area_light.is_some() {
                return Err((d.pos, format!("{what}: an area light inside the object \"{shapes_name}\" (pbrt-v4 does not support them either)")));
            }
            let shape = ObjectShape {
                shape,
                is_mesh,
                material,
                ctm: placed,
                flip,
                name,
                medium,
            };
            if let Some((_, shapes, _)) = &mut self.defining {
                shapes.push(shape);
            }
            return Ok(());
        }
        let a =
            affine(&placed).ok_or_else(|| (d.pos, format!("{what}: a projective transform")))?;
        let mut emitter = None;
        if let Some(light) = area_light {
            let (two, mut k) = (light.two_sided, 1.0);
            if let Some(power) = light.power {
                let area = area.single().map_err(|why| {
                    (
                        light.pos,
                        format!("AreaLightSource: `power` on this {kind} is not supported: {why}"),
                    )
                })?;
                k = power / ((if two { 2.0 } else { 1.0 }) * area * std::f64::consts::PI);
            }
            // A spectrum is emitted as given, its scale a grey radiance.
            let (radiance, spectrum) = match light.spectrum {
                Some((pairs, s)) => ([s * k; 3], Some(pairs)),
                None => (light.radiance.map(|x| x * k), None),
            };
            emitter = Some(EmitterDesc::Area {
                radiance: radiance.map(|x| x as f32),
                two_sided: two,
                texture: None,
                spectrum,
            });
        }
        let transform = if a != Affine3A::IDENTITY {
            crate::formats::import::placed(&a)
        } else {
            TransformDesc::default()
        };
        self.entities.push(EntityDesc {
            name: Some(name),
            transform,
            shape: Some(shape),
            material: Some(material),
            emitter,
            medium,
            flip_normals: flip,
        });
        crate::formats::import::check_entities_made(self.entities.len(), &self.room)
            .map_err(|e| (d.pos, e))?;
        Ok(())
    }

    /// A shape's `alpha`: `None` where it is opaque (absent, or a number of at least 1).
    fn alpha(&self, p: &mut ParamList) -> Result<Option<FloatDesc>, Located> {
        Ok(match p.float_or_texture("alpha")? {
            None => None,
            Some((Colour::Rgb(v), _)) if v[0] >= 1.0 => None,
            Some((Colour::Rgb(v), _)) => Some(FloatDesc::Constant(v[0] as f32)),
            Some((Colour::Texture(t), pos)) => {
                let tex = self.textures.float.get(&t).cloned().ok_or_else(|| {
                    (
                        pos,
                        format!("{}: no float texture is named \"{t}\" (`alpha`)", p.what),
                    )
                })?;
                Some(tex)
            }
            Some((_, pos)) => {
                return Err((
                    pos,
                    format!("{}: `alpha` must be a float or a float texture", p.what),
                ))
            }
        })
    }

    /// The material `material` cut out by `alpha`, made once per pair.
    pub(super) fn cut_out(&mut self, material: String, alpha: FloatDesc) -> String {
        let inner = self.material_descs.get(&material).cloned();
        let Some(inner) = inner else {
            return material;
        };
        let desc = MaterialDesc::Cutout {
            alpha,
            material: Box::new(inner),
        };
        if let Some(name) = self.material_by_desc.get(&material_key(&desc)) {
            return name.clone();
        }
        self.add_material(&format!("{material} (alpha)"), desc)
    }

    pub(super) fn instance(&mut self, d: &Directive) -> Result<(), Located> {
        let name = &d.strings[0];
        let shapes = self.objects.get(name).ok_or_else(|| {
            (
                d.pos,
                format!(
                    "ObjectInstance: no object is named \"{name}\" (ObjectBegin must come before)"
                ),
            )
        })?;
        let ctm = self.state.ctm;
        let mut entities = Vec::new();
        let mut new_meshes = Vec::new();
        for (i, s) in shapes.iter().enumerate() {
            let placed = ctm * s.ctm;
            let a = affine(&placed)
                .ok_or_else(|| (d.pos, "ObjectInstance: a projective transform".to_string()))?;
            let shape = if s.is_mesh {
                let mesh = format!("{name}/{i}");
                if self.mesh_names.insert(mesh.clone()) {
                    new_meshes.push((mesh.clone(), s.shape.clone()));
                }
                ShapeDesc::Instance { mesh }
            } else {
                s.shape.clone()
            };
            entities.push(EntityDesc {
                name: Some(format!("{name} @ {} / {}", self.place(d.pos), s.name)),
                transform: crate::formats::import::placed(&a),
                shape: Some(shape),
                material: Some(s.material.clone()),
                emitter: None,
                medium: s.medium.clone(),
                flip_normals: s.flip && !s.is_mesh,
            });
        }
        self.meshes.extend(new_meshes);
        crate::formats::import::check_entities(self.entities.len() + entities.len(), &self.room)
            .map_err(|e| (d.pos, format!("ObjectInstance: {e}")))?;
        self.entities.extend(entities);
        Ok(())
    }

    /// `trianglemesh` or `bilinearmesh` as a `Mesh` whose triangles each face where
    /// pbrt-v4's do (towards the given normals, else by winding, turned by ReverseOrientation
    /// and by a mirroring transform).
    fn mesh(&mut self, kind: &str, p: &mut ParamList, frame: &MeshFrame) -> Result<Mesh, Located> {
        let what = p.what.clone();
        let at = p.at;
        let (pts, ppos) = p
            .numbers("P", &["point3", "point"])?
            .ok_or_else(|| (at, format!("{what} needs \"point3 P\"")))?;
        if pts.len() % 3 != 0 {
            return Err((
                ppos,
                format!("{what}: P has {} numbers, not a multiple of 3", pts.len()),
            ));
        }
        let n = pts.len() / 3;
        let corners = if kind == "bilinearmesh" { 4 } else { 3 };
        let indices: Vec<usize> = match p.numbers("indices", &["integer"])? {
            Some((v, pos)) => {
                if v.len() % corners != 0 || v.is_empty() {
                    return Err((pos, format!("{what}: indices has {} entries, not a multiple of {corners}", v.len())));
                }
                let mut out = Vec::with_capacity(v.len());
                for i in v {
                    if i < 0.0 || i >= n as f64 || i.fract() != 0.0 {
                        return Err((pos, format!("{what}: index {i} is not one of the {n} points")));
                    }
                    out.push(i as usize);
                }
                out
            }
            None if n == corners => (0..corners).collect(),
            None => return Err((at, format!("{what} needs \"integer indices\" (only a mesh of exactly {corners} points may leave them out)"))),
        };
        let per_vertex = |p: &mut ParamList,
                          name: &str,
                          types: &[&str],
                          dim: usize|
         -> Result<Option<Vec<f64>>, Located> {
            match p.numbers(name, types)? {
                None => Ok(None),
                Some((v, _)) if v.len() == n * dim => Ok(Some(v)),
                Some((v, pos)) => Err((
                    pos,
                    format!(
                        "{what}: {name} has {} numbers for {n} points (needs {})",
                        v.len(),
                        n * dim
                    ),
                )),
            }
        };
        let normals = per_vertex(p, "N", &["normal", "normal3"], 3)?;
        let uvs = per_vertex(p, "uv", &["point2", "float"], 2)?;
        p.ignore(&["S", "faceIndices"]);
        let point = |i: usize| DVec3::new(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
        // pbrt-v4 turns the given normals around under ReverseOrientation.
        let sign = if self.state.reverse { -1.0 } else { 1.0 };
        let normal = |i: usize| {
            normals
                .as_ref()
                .map(|nv| sign * DVec3::new(nv[3 * i], nv[3 * i + 1], nv[3 * i + 2]))
        };
        let uv = |i: usize| uvs.as_ref().map(|u| [u[2 * i], u[2 * i + 1]]);
        let orient = frame.orient;
        let inv_t = orient.inverse().transpose();
        let flip = self.state.reverse ^ (orient.determinant() < 0.0);
        let default_uvs = frame.default_uvs && uvs.is_none();
        // The vertices written: the file's, or, for pbrt's default texture coordinates, each
        // primitive's own corners (pbrt gives every triangle (0,0) (1,0) (1,1) and every
        // patch its bilinear (u, v)).
        let mut verts: Vec<(usize, Option<[f64; 2]>)> = if default_uvs {
            Vec::with_capacity(indices.len())
        } else {
            (0..n).map(|i| (i, uv(i))).collect()
        };
        let mut tris: Vec<[usize; 3]> = Vec::with_capacity(indices.len() / corners * 2);
        let mut areas = Vec::with_capacity(indices.len() / corners);
        for c in indices.chunks(corners) {
            let c: Vec<usize> = if default_uvs {
                let corner_uvs: &[[f64; 2]] = if corners == 4 {
                    &[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]
                } else {
                    &[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]
                };
                let start = verts.len();
                verts.extend(c.iter().zip(corner_uvs).map(|(&i, &t)| (i, Some(t))));
                (start..start + corners).collect()
            } else {
                c.to_vec()
            };
            let at_point = |v: usize| point(verts[v].0);
            let parts: Vec<[usize; 3]> = if corners == 4 {
                // pbrt-v4's patch p00 p10 p01 p11: its normal is (p10 - p00) x (p01 - p00).
                let (a, b, c2, d) = (c[0], c[1], c[2], c[3]);
                let plane = (at_point(b) - at_point(a)).cross(at_point(c2) - at_point(a));
                let off = plane
                    .normalize_or_zero()
                    .dot(at_point(d) - at_point(a))
                    .abs();
                let size = (at_point(d) - at_point(a)).length().max(1e-30);
                if off > 1e-4 * size {
                    self.approximate(
                        at,
                        format!("{what}: a curved bilinear patch split into two flat triangles"),
                    )?;
                }
                vec![[a, b, d], [a, d, c2]]
            } else {
                vec![[c[0], c[1], c[2]]]
            };
            let mut area = 0.0;
            for t in parts {
                let w = t.map(|v| frame.world.transform_point3(at_point(v)));
                area += 0.5 * (w[1] - w[0]).cross(w[2] - w[0]).length();
                let o = t.map(|v| orient.transform_point3(at_point(v)));
                let cross = (o[1] - o[0]).cross(o[2] - o[0]);
                // pbrt-v4's front: towards the interpolated normal if given, else by the
                // winding (turned by ReverseOrientation and a mirroring transform).
                let ns = t.map(|v| normal(verts[v].0));
                let front = match ns {
                    [Some(a), Some(b), Some(c)] => {
                        (inv_t.transform_vector3(a + b + c)).dot(cross) >= 0.0
                    }
                    _ => !flip,
                };
                tris.push(if front { t } else { [t[0], t[2], t[1]] });
            }
            areas.push(area);
        }
        let shape = ShapeDesc::Mesh {
            positions: verts.iter().map(|v| f3(point(v.0))).collect(),
            indices: tris.iter().map(|t| t.map(|i| i as u32)).collect(),
            normals: normals
                .is_some()
                .then(|| verts.iter().filter_map(|v| normal(v.0).map(f3)).collect()),
            uvs: (verts.iter().all(|v| v.1.is_some()) && !verts.is_empty()).then(|| {
                verts
                    .iter()
                    .filter_map(|v| v.1)
                    .map(|t| [t[0] as f32, t[1] as f32])
                    .collect()
            }),
        };
        Ok(Mesh { shape, areas })
    }
}
