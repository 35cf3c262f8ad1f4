//! Mitsuba's shape and emitter plugins: shapes with their materials and area lights,
//! shapegroups and their instances, and the lights that are not shapes.

use super::*;
use crate::formats::schema::{MediumInterfaceDesc, MeshNormals};

/// A shape as the pieces of an entity.
struct ShapeParts {
    name: String,
    shape: ShapeDesc,
    to_world: Affine3A,
    material: Option<String>,
    emitter: Option<EmitterDesc>,
    /// The media it bounds (`interior`, `exterior`), if any.
    medium: Option<MediumInterfaceDesc>,
    flip: bool,
}

impl<'a, 'input> Converter<'a, 'input> {
    pub(super) fn shape(&mut self, node: Node<'a, 'input>, index: usize) -> Result<(), Located> {
        let parts = self.shape_parts(node, index)?;
        self.origins
            .push((true, parts.name.clone(), position(self.doc, node)));
        self.entities.push(EntityDesc {
            name: Some(parts.name),
            transform: placed(&parts.to_world),
            shape: Some(parts.shape),
            material: parts.material,
            emitter: parts.emitter,
            medium: parts.medium,
            flip_normals: parts.flip,
        });
        crate::formats::import::check_entities_made(self.entities.len(), &self.room)
            .map_err(|e| at(self.doc, node, e))?;
        Ok(())
    }

    /// An `instance` of a `shapegroup`: each shape of the group placed by the instance's
    /// `to_world` after its own, a mesh (`obj`, `ply`, `rectangle`, `cube`) as an instance of
    /// one mesh asset shared by every instance, an analytic shape as an entity of its own.
    pub(super) fn instance(&mut self, node: Node<'a, 'input>, index: usize) -> Result<(), Located> {
        let name = attr(&self.params, self.doc, node, "id")?
            .unwrap_or_else(|| format!("instance #{index}"));
        let mut p = self.props(node)?;
        let to_world = p.transform("to_world")?.unwrap_or(Affine3A::IDENTITY);
        let refs: Vec<Node> = std::mem::take(&mut p.children)
            .into_iter()
            .map(|(_, n)| n)
            .collect();
        p.finish(&[])?;
        let [group] = refs[..] else {
            return Err(at(
                self.doc,
                node,
                "<shape type=\"instance\"> takes one shapegroup (a <ref> to it)",
            ));
        };
        let group = self.resolve(group)?;
        if group.tag_name().name() != "shape" || self.kind(group)? != "shapegroup" {
            return Err(at(
                self.doc,
                group,
                "an instance places a <shape type=\"shapegroup\">",
            ));
        }
        let gid = attr(&self.params, self.doc, group, "id")?.unwrap_or_else(|| name.clone());
        let shapes: Vec<Node> = group.children().filter(Node::is_element).collect();
        for (i, child) in shapes.into_iter().enumerate() {
            if child.tag_name().name() != "shape" {
                return Err(at(self.doc, child, "a shapegroup holds shapes only"));
            }
            let kind = self.kind(child)?;
            let parts = self.shape_parts(child, i)?;
            if parts.emitter.is_some() {
                return Err(at(
                    self.doc,
                    child,
                    "a shape of a shapegroup cannot emit light (in Mitsuba neither)",
                ));
            }
            let placed_to_world = to_world * parts.to_world;
            let shape = if matches!(kind.as_str(), "obj" | "ply" | "rectangle" | "cube") {
                if parts.flip {
                    return Err(at(self.doc, child, "a mesh of a shapegroup turned around (flip_normals, or a mirrored rectangle) is not supported"));
                }
                let mesh = format!("{gid}/{i}");
                if !self.meshes.iter().any(|(n, _)| *n == mesh) {
                    self.meshes.push((mesh.clone(), parts.shape.clone()));
                }
                ShapeDesc::Instance { mesh }
            } else {
                parts.shape.clone()
            };
            let entity = format!("{name} / {}", parts.name);
            self.origins
                .push((true, entity.clone(), position(self.doc, child)));
            let flip_normals = parts.flip && !matches!(shape, ShapeDesc::Instance { .. });
            self.entities.push(EntityDesc {
                name: Some(entity),
                transform: placed(&placed_to_world),
                shape: Some(shape),
                material: parts.material,
                emitter: None,
                medium: parts.medium.clone(),
                flip_normals,
            });
            crate::formats::import::check_entities_made(self.entities.len(), &self.room)
                .map_err(|e| at(self.doc, node, e))?;
        }
        Ok(())
    }

    /// A shape's parts: its shape, placement, material, emitter and orientation.
    fn shape_parts(&mut self, node: Node<'a, 'input>, index: usize) -> Result<ShapeParts, Located> {
        let kind = self.kind(node)?;
        let name =
            attr(&self.params, self.doc, node, "id")?.unwrap_or_else(|| format!("{kind} #{index}"));
        let mut p = self.props(node)?;
        let to_world = p.transform("to_world")?.unwrap_or(Affine3A::IDENTITY);
        let file = |p: &mut Props<'a, 'input>| -> Result<String, Located> {
            p.string("filename")?.ok_or_else(|| {
                at(
                    self.doc,
                    node,
                    format!("<shape type=\"{kind}\"> needs `filename`"),
                )
            })
        };
        // Mitsuba shades a mesh with its file's normals, or with normals it computes when the
        // file has none; flat with `face_normals`.
        let normals = |p: &mut Props<'a, 'input>| -> Result<MeshNormals, Located> {
            Ok(match p.boolean("face_normals")? {
                Some(true) => MeshNormals::Flat,
                _ => MeshNormals::Smooth,
            })
        };
        let shape = match kind.as_str() {
            "obj" | "ply" => {
                let path = self.file_name(file(&mut p)?);
                let normals = normals(&mut p)?;
                if kind == "obj" {
                    ShapeDesc::Obj { path, normals }
                } else {
                    ShapeDesc::Ply {
                        path,
                        normals,
                        attribute: None,
                    }
                }
            }
            "serialized" => {
                let path = self.file_name(file(&mut p)?);
                let index = p.integer("shape_index")?.unwrap_or(0);
                let shape_index = u32::try_from(index).map_err(|_| {
                    at(self.doc, node, format!("shape_index {index} must be 0 or more"))
                })?;
                let normals = normals(&mut p)?;
                ShapeDesc::Serialized {
                    path,
                    shape_index,
                    normals,
                }
            }
            "sdfgrid" => {
                let path = self.file_name(file(&mut p)?);
                let smooth_normals = match p.string("normals")?.as_deref() {
                    None | Some("smooth") => true,
                    Some("analytic") => false,
                    Some(other) => {
                        return Err(at(
                            self.doc,
                            node,
                            format!("<shape type=\"sdfgrid\">: `normals` must be \"smooth\" or \"analytic\", not \"{other}\""),
                        ))
                    }
                };
                ShapeDesc::SdfGrid {
                    path,
                    smooth_normals,
                }
            }
            "rectangle" => ShapeDesc::Rectangle,
            "cube" => mitsuba_cube(),
            "disk" => ShapeDesc::Disk,
            "sphere" => ShapeDesc::Sphere {
                center: p.vector("center")?.unwrap_or([0.0; 3]),
                radius: p.float("radius")?.unwrap_or(1.0),
            },
            "cylinder" => ShapeDesc::Cylinder {
                p0: p.vector("p0")?.unwrap_or([0.0; 3]),
                p1: p.vector("p1")?.unwrap_or([0.0, 0.0, 1.0]),
                radius: p.float("radius")?.unwrap_or(1.0),
            },
            other => {
                return Err(at(self.doc, node, format!("shape `{other}` is not supported (obj, ply, serialized, rectangle, cube, disk, sphere, cylinder, sdfgrid are)")))
            }
        };
        let mut flip = p.boolean("flip_normals")?.unwrap_or(false);
        // Mitsuba's rectangle faces its inverse transpose's +z; raylab's Rectangle is two
        // triangles facing their winding, which a mirroring to_world turns the other way.
        // A mesh with vertex normals under a mirroring to_world: Mitsuba's shading normals
        // (the object's, by the inverse transpose) face where the winding does not, and its
        // BSDFs see the side the shading normal gives; raylab keeps a shading normal on its
        // triangle's side, so the triangles are turned to face with them.
        let normals_of_shape = match &shape {
            ShapeDesc::Obj { normals, .. }
            | ShapeDesc::Ply { normals, .. }
            | ShapeDesc::Serialized { normals, .. } => *normals != MeshNormals::Flat,
            ShapeDesc::Mesh { normals, .. } => normals.is_some(),
            _ => false,
        };
        if (kind == "rectangle" || normals_of_shape) && to_world.matrix3.determinant() < 0.0 {
            flip = !flip;
            self.report.push(format!(
                "{name}: a mirroring to_world: its faces turned to face where Mitsuba's do"
            ));
        }
        let (mut material, mut emitter) = (None, None);
        let mut medium: Option<MediumInterfaceDesc> = None;
        for (child_name, given) in std::mem::take(&mut p.children) {
            let child = self.resolve(given)?;
            match child.tag_name().name() {
                "medium" => {
                    let m = self.medium(child)?;
                    let sides = medium.get_or_insert_with(MediumInterfaceDesc::default);
                    match child_name.as_str() {
                        "interior" if sides.inside.is_none() => sides.inside = Some(m),
                        "exterior" if sides.outside.is_none() => sides.outside = Some(m),
                        "interior" | "exterior" => {
                            return Err(at(
                                self.doc,
                                given,
                                format!("a shape's {child_name} medium is given twice"),
                            ))
                        }
                        other => {
                            return Err(at(
                                self.doc,
                                given,
                                format!(
                                "a shape's medium is its `interior` or `exterior`, not `{other}`"
                            ),
                            ))
                        }
                    }
                }
                "bsdf" if material.is_none() => {
                    material = Some(self.material(child, &format!("{name} material"))?)
                }
                "emitter" if emitter.is_none() => {
                    let k = self.kind(child)?;
                    if k != "area" {
                        return Err(at(
                            self.doc,
                            child,
                            format!("a shape's emitter must be `area`, not `{k}`"),
                        ));
                    }
                    let mut e = self.props(child)?;
                    // A spectrum given by wavelength stays one (its colour is made where the
                    // scene is loaded).
                    let spectrum = e.spectrum("radiance");
                    // A constant or a texture; Mitsuba's default is 1.
                    let (radiance, texture) = match e.emission("radiance")? {
                        Some(_) if spectrum.is_some() => ([1.0; 3], None),
                        Some(r) => (r, None),
                        None => match self.colour(&mut e, "radiance", None)? {
                            Some(ColorDesc::Texture(t)) => ([1.0; 3], Some(ColorDesc::Texture(t))),
                            Some(ColorDesc::Constant(c)) => (c, None),
                            Some(ColorDesc::Spectrum(p)) => (ColorDesc::spectrum_colour(&p), None),
                            None => ([1.0; 3], None),
                        },
                    };
                    e.finish(&[])?;
                    emitter = Some(EmitterDesc::Area {
                        radiance,
                        two_sided: false,
                        texture,
                        spectrum,
                    });
                }
                tag => {
                    return Err(at(
                        self.doc,
                        child,
                        format!("<{tag}> inside a shape is not supported"),
                    ))
                }
            }
        }
        p.finish(&[])?;
        // Mitsuba gives a shape without a BSDF its default grey diffuse, but an emitter a
        // black one: raylab's pure emitters are black too (no material).
        let material = match (material, &emitter) {
            (Some(m), _) => Some(m),
            (None, Some(_)) => None,
            (None, None) => Some(match &self.default_material {
                Some(name) => name.clone(),
                None => {
                    let mut name = "default".to_string();
                    while self.materials.iter().any(|(n, _)| *n == name) {
                        name.push('\'');
                    }
                    self.materials.push((
                        name.clone(),
                        MaterialDesc::OneSided(Box::new(bsdf::default_bsdf())),
                    ));
                    self.report.push(format!(
                        "{name}: Mitsuba's default BSDF (diffuse 0.5, one-sided), for shapes \
                         without one"
                    ));
                    self.default_material = Some(name.clone());
                    name
                }
            }),
        };
        // The mesh attribute its material reads, which the shape carries to it.
        let read = material
            .as_ref()
            .and_then(|m| self.materials.iter().find(|(n, _)| n == m))
            .map_or(Vec::new(), |(_, desc)| desc.attributes());
        let shape = match (shape, read.as_slice()) {
            (shape, []) => shape,
            (ShapeDesc::Ply { path, normals, .. }, [one]) => ShapeDesc::Ply {
                path,
                normals,
                attribute: Some(one.clone()),
            },
            (ShapeDesc::Ply { .. }, _) => {
                return Err(at(
                    self.doc,
                    node,
                    format!(
                        "the shape's BSDF reads the mesh attributes {}: raylab carries one per shape",
                        read.join(", ")
                    ),
                ))
            }
            (_, _) => {
                return Err(at(
                    self.doc,
                    node,
                    format!(
                        "the shape's BSDF reads the mesh attribute `{}`: only a `ply` shape carries attributes",
                        read[0]
                    ),
                ))
            }
        };
        Ok(ShapeParts {
            name,
            shape,
            to_world,
            material,
            emitter,
            medium,
            flip,
        })
    }

    pub(super) fn emitter(&mut self, node: Node<'a, 'input>, index: usize) -> Result<(), Located> {
        let kind = self.kind(node)?;
        let name =
            attr(&self.params, self.doc, node, "id")?.unwrap_or_else(|| format!("{kind} #{index}"));
        let mut p = self.props(node)?;
        let to_world = p.transform("to_world")?;
        let transform = to_world.as_ref().map(placed).unwrap_or_default();
        let (emitter, transform) = match kind.as_str() {
            "constant" => {
                let r = p.emission("radiance")?.unwrap_or([1.0; 3]);
                if self.environment.replace(r).is_some() {
                    return Err(at(self.doc, node, "a second environment emitter: raylab's scene has one"));
                }
                p.finish(&[])?;
                return Ok(());
            }
            "envmap" => {
                let path = self.file_name(p.string("filename")?.ok_or_else(|| at(self.doc, node, "<emitter type=\"envmap\"> needs `filename`"))?);
                let scale = p.float("scale")?.unwrap_or(1.0);
                (EmitterDesc::Environment { path, scale, mapping: None }, transform)
            }
            "point" => {
                let (intensity, spectrum) = p.emission_or_spectrum("intensity")?;
                let m = match p.vector("position")? {
                    Some(pos) => Affine3A::from_translation(pos.into()),
                    None => to_world.unwrap_or(Affine3A::IDENTITY),
                };
                (EmitterDesc::Point { intensity, spectrum }, placed(&m))
            }
            "spot" => {
                let (intensity, spectrum) = p.emission_or_spectrum("intensity")?;
                let cutoff_angle = p.float("cutoff_angle")?.unwrap_or(20.0);
                let beam = p.float("beam_width")?.unwrap_or(cutoff_angle * 0.75);
                let texture = self.colour(&mut p, "texture", None)?;
                if matches!(texture, Some(ColorDesc::Texture(_))) && cutoff_angle >= 90.0 {
                    return Err(at(self.doc, node, format!("a textured spot's cutoff_angle must be below 90 degrees (its image lies on a plane ahead), got {cutoff_angle}")));
                }
                let spot = EmitterDesc::Spot {
                    intensity,
                    look_at: None,
                    cutoff_angle,
                    beam_width: Some(beam),
                    falloff: None,
                    texture,
                    spectrum,
                };
                (spot, transform)
            }
            "projector" => {
                let irradiance = self
                    .colour(&mut p, "irradiance", Some([1.0; 3]))?
                    .unwrap_or(ColorDesc::Constant([1.0; 3]));
                let scale = p.float("scale")?.unwrap_or(1.0);
                let (fov, axis) = self.field_of_view(&mut p, node)?;
                if !(fov > 0.0 && fov < 180.0) {
                    return Err(at(self.doc, node, format!("a projector's field of view must lie in (0, 180) degrees, got {fov}")));
                }
                let projector = EmitterDesc::Projector {
                    irradiance,
                    fov,
                    fov_axis: (axis != "x").then_some(axis),
                    scale,
                };
                (projector, transform)
            }
            "directional" => {
                let (irradiance, spectrum) = p.emission_or_spectrum("irradiance")?;
                let direction = p.vector("direction")?.unwrap_or([0.0, 0.0, 1.0]);
                (EmitterDesc::Directional { direction, irradiance, spectrum }, transform)
            }
            other => return Err(at(self.doc, node, format!("emitter `{other}` is not supported (area, point, spot, projector, directional, constant, envmap are)"))),
        };
        p.finish(&[])?;
        self.entities
            .push(EntityDesc::light(name, transform, emitter));
        Ok(())
    }
}

/// Mitsuba 3's `cube`: the 24 vertices of its six faces (`[-1, 1]^3`), each face with its own
/// normal and one pattern of texture coordinates, in Mitsuba's order (`src/shapes/cube.cpp`),
/// so that a texture lies on each face as Mitsuba lays it.
fn mitsuba_cube() -> ShapeDesc {
    const NORMALS: [[f32; 3]; 6] = [
        [0.0, -1.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [-1.0, 0.0, 0.0],
        [0.0, 0.0, -1.0],
    ];
    const UVS: [[f32; 2]; 4] = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    // The corner of each vertex: bit k of a corner gives the sign of axis k.
    const CORNERS: [u32; 24] = [
        1, 5, 4, 0, 3, 2, 6, 7, 1, 3, 7, 5, 5, 7, 6, 4, 4, 6, 2, 0, 3, 1, 0, 2,
    ];
    let corner = |c: u32| {
        let s = |bit: u32| if c & bit != 0 { 1.0 } else { -1.0 };
        [s(1), s(2), s(4)]
    };
    ShapeDesc::Mesh {
        positions: CORNERS.iter().map(|&c| corner(c)).collect(),
        indices: (0..6u32)
            .flat_map(|f| {
                let v = 4 * f;
                [[v, v + 1, v + 2], [v + 3, v, v + 2]]
            })
            .collect(),
        normals: Some((0..24).map(|v| NORMALS[v / 4]).collect()),
        uvs: Some((0..24).map(|v| UVS[v % 4]).collect()),
    }
}
