//! Mesh files: Wavefront OBJ through `tobj` and glTF 2.0 / GLB through `gltf`, each read into
//! one local-space [`FileMesh`]: triangles, optional vertex normals, and which of the file's
//! materials each triangle uses (OBJ `Kd`/`Ke` from the MTL file; glTF `baseColorFactor`,
//! `emissiveFactor` times `KHR_materials_emissive_strength`).
//!
//! Both parsers are third-party code fed user files: a panic in either is caught (quietly) and
//! becomes an error naming the file, and everything they return is checked here (indices in
//! range, finite positions, at least one triangle, no cycle in a glTF node graph).

use super::access::{relative_uri, SceneFiles};
use super::schema::MeshNormals;
use glam::{Mat3, Mat4, Vec2, Vec3, Vec3A};
use std::panic::UnwindSafe;
use std::path::Path;
use std::sync::Mutex;

/// A material as a mesh file describes it, reduced to what raylab uses.
#[derive(Clone, Debug, PartialEq)]
pub struct FileMaterial {
    /// The file's name for it (or `#N` / `default` when it has none).
    pub name: String,
    /// Diffuse reflectance (linear RGB), used as a Lambert albedo.
    pub albedo: [f32; 3],
    /// Emitted radiance, when non-zero.
    pub emission: Option<[f32; 3]>,
    /// glTF `doubleSided` (emits from both sides); OBJ materials are one-sided.
    pub two_sided: bool,
}

/// A mesh read from a file, in the file's space.
#[derive(Debug, Default)]
pub struct FileMesh {
    pub positions: Vec<Vec3A>,
    pub indices: Vec<[u32; 3]>,
    pub normals: Option<Vec<Vec3A>>,
    /// Texture coordinates per vertex, with `v` running down the image from its top row
    /// (Mitsuba 3's convention).
    pub uvs: Option<Vec<Vec2>>,
    /// Per triangle, its index in `materials`.
    pub triangle_material: Vec<u32>,
    pub materials: Vec<FileMaterial>,
    /// Vertex normals the file gave as NaN or infinite (or zero), replaced by the angle-weighted
    /// normal of the triangles around the vertex.
    pub repaired_normals: usize,
    /// The file's other per-vertex and per-face values (PLY), named as Mitsuba 3 names them.
    pub attributes: Vec<MeshAttribute>,
}

/// Values a mesh file gives per vertex or per face beside its geometry (Mitsuba 3's mesh
/// attributes): one or three numbers each (one is kept in all three channels).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshAttribute {
    /// `vertex_NAME` or `face_NAME` (`vertex_color` for `red green blue` or `r g b`).
    pub name: String,
    /// Per vertex, or per triangle (a face's value for each triangle it was split into).
    pub values: Vec<Vec3A>,
    pub per_face: bool,
}

impl MeshAttribute {
    /// The values at the corners of triangle `i` of `indices`.
    #[inline]
    pub fn corners(&self, indices: &[[u32; 3]], i: usize) -> [Vec3A; 3] {
        if self.per_face {
            [self.values[i]; 3]
        } else {
            indices[i].map(|k| self.values[k as usize])
        }
    }
}

impl FileMesh {
    /// The mesh with its normals as `mode` asks (see [`MeshNormals`]).
    pub fn shaded(mut self, mode: MeshNormals) -> Self {
        match mode {
            MeshNormals::File => {}
            MeshNormals::Flat => self.normals = None,
            MeshNormals::Smooth if self.normals.is_none() => {
                self.normals = Some(angle_weighted_normals(&self.positions, &self.indices))
            }
            MeshNormals::Smooth => {}
        }
        self
    }

    /// One mesh per material that some triangle uses (in material order), each with only the
    /// vertices it uses (and no materials of its own).
    pub fn split_by_material(self) -> Vec<(FileMaterial, FileMesh)> {
        let mut out = Vec::new();
        for (m, material) in self.materials.iter().enumerate() {
            let mut remap = vec![u32::MAX; self.positions.len()];
            let (mut positions, mut normals, mut uvs, mut indices) =
                (Vec::new(), Vec::new(), Vec::new(), Vec::new());
            for (t, _) in self
                .indices
                .iter()
                .zip(&self.triangle_material)
                .filter(|(_, k)| **k as usize == m)
            {
                indices.push(t.map(|v| {
                    let v = v as usize;
                    if remap[v] == u32::MAX {
                        remap[v] = positions.len() as u32;
                        positions.push(self.positions[v]);
                        if let Some(n) = &self.normals {
                            normals.push(n[v]);
                        }
                        if let Some(uv) = &self.uvs {
                            uvs.push(uv[v]);
                        }
                    }
                    remap[v]
                }));
            }
            if !indices.is_empty() {
                let normals = self.normals.is_some().then_some(normals);
                let uvs = self.uvs.is_some().then_some(uvs);
                out.push((
                    material.clone(),
                    FileMesh {
                        positions,
                        indices,
                        normals,
                        uvs,
                        ..FileMesh::default()
                    },
                ));
            }
        }
        out
    }
}

/// Vertex normals from the faces around each vertex, each face's unit normal weighted by its
/// angle at the vertex (Thürmer and Wüthrich 1998, as Mitsuba 3 computes them for meshes
/// without normals). Degenerate faces add nothing; a vertex they alone touch gets the normal of
/// the first face that names it, or `+z`.
pub fn angle_weighted_normals(positions: &[Vec3A], indices: &[[u32; 3]]) -> Vec<Vec3A> {
    let mut sum = vec![Vec3A::ZERO; positions.len()];
    for tri in indices {
        let p = tri.map(|i| positions[i as usize]);
        let Some(n) = (p[1] - p[0]).cross(p[2] - p[0]).try_normalize() else {
            continue;
        };
        for k in 0..3 {
            let d0 = (p[(k + 1) % 3] - p[k]).normalize_or_zero();
            let d1 = (p[(k + 2) % 3] - p[k]).normalize_or_zero();
            let angle = d0.dot(d1).clamp(-1.0, 1.0).acos();
            sum[tri[k] as usize] += n * angle;
        }
    }
    sum.into_iter()
        .map(|n| n.try_normalize().unwrap_or(Vec3A::Z))
        .collect()
}

/// Runs a third-party parser on a user file. A panic in it becomes an error; the default
/// hook, which would print "panicked" as if raylab had crashed, is silenced meanwhile (the
/// lock keeps two loads from swapping hooks at once).
pub(super) fn guarded<T>(
    kind: &str,
    file: &Path,
    parse: impl FnOnce() -> T + UnwindSafe,
) -> Result<T, String> {
    static HOOK: Mutex<()> = Mutex::new(());
    let _lock = HOOK.lock().unwrap_or_else(|e| e.into_inner());
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let result = std::panic::catch_unwind(parse);
    std::panic::set_hook(previous);
    result.map_err(|payload| {
        let reason = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown reason".into());
        format!(
            "cannot load {kind} file `{}`: the file is malformed (the parser failed: {reason})",
            file.display()
        )
    })
}

/// The folder `file` lies in ("." for a bare name): where the files it names are.
fn parent_of(file: &Path) -> &Path {
    match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Every position, normal and texture coordinate finite, at least one triangle.
pub(super) fn check_mesh(kind: &str, file: &Path, mesh: &mut FileMesh) -> Result<(), String> {
    if let Some((i, p)) = mesh
        .positions
        .iter()
        .enumerate()
        .find(|(_, p)| !p.is_finite())
    {
        return Err(format!(
            "{kind} file `{}`: vertex {i} has a position that is not finite: {:?}",
            file.display(),
            p.to_array()
        ));
    }
    if let Some(uv) = &mesh.uvs {
        if let Some((i, v)) = uv.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(format!(
                "{kind} file `{}`: vertex {i} has texture coordinates that are not finite: {:?}",
                file.display(),
                v.to_array()
            ));
        }
    }
    // A vertex normal that is not finite (or zero) has no direction to interpolate: it is
    // replaced by the one the triangles around the vertex give (pbrt-v4 falls back to the
    // triangle's own normal for such a hit; a per-vertex repair keeps the others smooth).
    if let Some(n) = &mut mesh.normals {
        let bad = |v: &Vec3A| !v.is_finite() || *v == Vec3A::ZERO;
        if n.iter().any(bad) {
            // Index ranges are checked later, with the shape: only those in range count here.
            let count = mesh.positions.len();
            let valid: Vec<[u32; 3]> = (mesh.indices.iter())
                .filter(|t| t.iter().all(|&i| (i as usize) < count))
                .copied()
                .collect();
            let around = angle_weighted_normals(&mesh.positions, &valid);
            for (v, a) in n.iter_mut().zip(around) {
                if bad(v) {
                    *v = a;
                    mesh.repaired_normals += 1;
                }
            }
        }
    }
    if mesh.indices.is_empty() {
        return Err(format!("{kind} file `{}` has no triangles", file.display()));
    }
    Ok(())
}

/// A colour channel triple from a file: finite, non-negative.
fn colour(file: &Path, material: &str, what: &str, c: [f32; 3]) -> Result<[f32; 3], String> {
    if c.iter().all(|v| v.is_finite() && *v >= 0.0) {
        Ok(c)
    } else {
        Err(format!(
            "material `{material}` of `{}`: {what} must be finite and non-negative, got {c:?}",
            file.display()
        ))
    }
}

/// The grey that OBJ faces without a material get (glTF has its own default: white).
pub const OBJ_DEFAULT_ALBEDO: [f32; 3] = [0.8, 0.8, 0.8];

/// Loads an OBJ file as one mesh (all its objects), with normals when every object has them,
/// and the diffuse (`Kd`) and emitted (`Ke`) colours of its MTL materials. A missing or bad
/// MTL file is an error only if `need_materials`.
pub fn load_obj(file: &Path, need_materials: bool, files: &SceneFiles) -> Result<FileMesh, String> {
    // Streamed, lines capped (a binary file is one endless line), a byte-order mark skipped.
    let (handle, _) = crate::files::open_capped(file, crate::files::MAX_BINARY)
        .map_err(|e| format!("cannot load OBJ file `{}`: {e}", file.display()))?;
    let mut reader = std::io::BufReader::new(handle);
    if std::io::BufRead::fill_buf(&mut reader).is_ok_and(|b| b.starts_with(b"\xef\xbb\xbf")) {
        std::io::BufRead::consume(&mut reader, 3);
    }
    let mut text = crate::files::LineCapped::new(reader);
    let line_error = std::cell::RefCell::new(None::<String>);
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    // MTL files: relative to the OBJ, under the folders the scene may read, read by us (tobj
    // would open any path). Why one could not be read is kept for the message.
    let mtl_error = std::cell::RefCell::new(None::<String>);
    let load_mtl = |name: &Path| {
        let path = parent_of(file).join(name);
        let read = files.check(&path, &name.to_string_lossy()).and_then(|()| {
            crate::files::read_capped(&path, crate::files::MAX_TEXT)
                .map_err(|e| format!("`{}`: {e}", path.display()))
        });
        match read {
            Ok(bytes) => tobj::load_mtl_buf(&mut &bytes[..]),
            Err(e) => {
                *mtl_error.borrow_mut() = Some(e);
                Err(tobj::LoadError::OpenFileFailed)
            }
        }
    };
    let (models, materials) = guarded(
        "OBJ",
        file,
        std::panic::AssertUnwindSafe(|| {
            let result = tobj::load_obj_buf(&mut text, &options, load_mtl);
            if let Err(e) = std::io::BufRead::fill_buf(&mut text) {
                *line_error.borrow_mut() = Some(e.to_string());
            }
            result
        }),
    )?
    .map_err(|e| {
        if let Some(why) = line_error.take() {
            return format!("cannot load OBJ file `{}`: {why}", file.display());
        }
        let hint = match e {
            tobj::LoadError::ReadError => " (is it a text OBJ file?)",
            _ => "",
        };
        format!("cannot load OBJ file `{}`: {e}{hint}", file.display())
    })?;
    let file_materials = match materials {
        Ok(m) => m,
        Err(e) if need_materials => {
            let why = mtl_error.take().unwrap_or_else(|| e.to_string());
            return Err(format!(
                "OBJ file `{}`: cannot load its MTL materials (its `mtllib` file, relative to it): {why}",
                file.display()
            ));
        }
        Err(_) => Vec::new(),
    };
    let mut materials: Vec<FileMaterial> = Vec::with_capacity(file_materials.len() + 1);
    for m in &file_materials {
        let albedo = colour(file, &m.name, "Kd", m.diffuse.unwrap_or(OBJ_DEFAULT_ALBEDO))?;
        let emission = colour(file, &m.name, "Ke", m.emissive.unwrap_or([0.0; 3]))?;
        materials.push(FileMaterial {
            name: m.name.clone(),
            albedo,
            emission: emission.iter().any(|c| *c > 0.0).then_some(emission),
            two_sided: false,
        });
    }
    let default_material = materials.len() as u32;
    let mut uses_default = false;

    let mut mesh = FileMesh::default();
    let mut streams = VertexStreams {
        all_normals: models.iter().all(|m| !m.mesh.normals.is_empty()),
        all_uvs: models.iter().all(|m| !m.mesh.texcoords.is_empty()),
        ..VertexStreams::default()
    };
    for m in &models {
        let base = mesh.positions.len() as u32;
        let count = m.mesh.positions.len() / 3;
        let material = match m.mesh.material_id {
            Some(k) if k < file_materials.len() => k as u32,
            _ => {
                uses_default = true;
                default_material
            }
        };
        mesh.positions.extend(
            m.mesh
                .positions
                .chunks_exact(3)
                .map(|p| Vec3A::new(p[0], p[1], p[2])),
        );
        if streams.all_normals {
            streams.normals.extend(
                m.mesh
                    .normals
                    .chunks_exact(3)
                    .map(|n| Vec3A::new(n[0], n[1], n[2])),
            );
        }
        if streams.all_uvs {
            // OBJ's `v` runs up the image: turned to run down it, as Mitsuba 3 reads OBJ.
            streams.uvs.extend(
                m.mesh
                    .texcoords
                    .chunks_exact(2)
                    .map(|t| Vec2::new(t[0], 1.0 - t[1])),
            );
        }
        for t in m.mesh.indices.chunks_exact(3) {
            if t.iter().any(|&i| i as usize >= count) {
                return Err(format!(
                    "OBJ file `{}`: object `{}`: a face index is out of range (the object has {count} vertices)",
                    file.display(),
                    m.name
                ));
            }
            mesh.indices.push([base + t[0], base + t[1], base + t[2]]);
            mesh.triangle_material.push(material);
        }
    }
    let default = uses_default.then_some(OBJ_DEFAULT_ALBEDO);
    finish_mesh("OBJ", file, mesh, materials, default, streams)
}

/// Loads the triangles of a glTF file's default scene (or its first) as one mesh, each mesh
/// placed by its node's world transform; normals when every primitive has them; the base
/// colour and emission of each primitive's material.
pub fn load_gltf(file: &Path, files: &SceneFiles) -> Result<FileMesh, String> {
    let cannot =
        |e: &dyn std::fmt::Display| format!("cannot load glTF file `{}`: {e}", file.display());
    let bytes =
        crate::files::read_capped(file, crate::files::MAX_BINARY).map_err(|e| cannot(&e))?;
    // A GLB's header states its length: one beyond the file is damage (or a lie).
    if let Some(&[a, b, c, d]) = bytes.strip_prefix(b"glTF").and_then(|rest| rest.get(4..8)) {
        let claimed = u32::from_le_bytes([a, b, c, d]) as usize;
        if claimed > bytes.len() {
            return Err(cannot(&format!(
                "its GLB header claims {claimed} bytes, the file has {}",
                bytes.len()
            )));
        }
    }
    let gltf = guarded("glTF", file, || gltf::Gltf::from_slice(&bytes))?.map_err(|e| cannot(&e))?;
    let document = &gltf.document;
    // Buffers: embedded, data: URIs, or relative paths under the folders the scene may read.
    for buffer in document.buffers() {
        if let gltf::buffer::Source::Uri(uri) = buffer.source() {
            if let Some(relative) = relative_uri(uri).map_err(|e| cannot(&e))? {
                let path = parent_of(file).join(relative);
                files.check(&path, uri).map_err(|e| cannot(&e))?;
                crate::files::open_capped(&path, crate::files::MAX_BINARY)
                    .map_err(|e| cannot(&format!("buffer `{uri}`: {e}")))?;
            }
        }
    }
    let buffers = guarded("glTF", file, || {
        gltf::import_buffers(document, Some(parent_of(file)), gltf.blob.clone())
    })?;
    let buffers = buffers.map_err(|e| {
        let uris: Vec<String> = document
            .buffers()
            .filter_map(|b| match b.source() {
                gltf::buffer::Source::Uri(u) if !u.starts_with("data:") => Some(format!("`{u}`")),
                _ => None,
            })
            .collect();
        format!(
            "cannot load the buffers of glTF file `{}` ({}): {e}",
            file.display(),
            if uris.is_empty() {
                "embedded".to_string()
            } else {
                uris.join(", ")
            }
        )
    })?;
    check_gltf_accessors(file, document)?;
    // The reader is third-party code on user data too.
    guarded(
        "glTF",
        file,
        std::panic::AssertUnwindSafe(|| read_gltf_scene(file, document, &buffers)),
    )?
}

/// Every primitive's accessors of the types raylab reads: positions and normals as three
/// floats, indices as unsigned integers (the glTF crate's reader panics on others).
fn check_gltf_accessors(file: &Path, document: &gltf::Document) -> Result<(), String> {
    use gltf::accessor::{DataType, Dimensions};
    for mesh in document.meshes() {
        for primitive in mesh.primitives() {
            let at = format!(
                "glTF file `{}`: mesh {} primitive {}",
                file.display(),
                mesh.index(),
                primitive.index()
            );
            for (semantic, accessor) in primitive.attributes() {
                let name = match semantic {
                    gltf::Semantic::Positions => "POSITION",
                    gltf::Semantic::Normals => "NORMAL",
                    _ => continue,
                };
                if (accessor.data_type(), accessor.dimensions())
                    != (DataType::F32, Dimensions::Vec3)
                {
                    return Err(format!(
                        "{at}: its {name} accessor holds {:?} {:?}, not three floats (VEC3 FLOAT)",
                        accessor.dimensions(),
                        accessor.data_type()
                    ));
                }
            }
            if let Some(indices) = primitive.indices() {
                let unsigned = matches!(
                    indices.data_type(),
                    DataType::U8 | DataType::U16 | DataType::U32
                );
                if !unsigned || indices.dimensions() != Dimensions::Scalar {
                    return Err(format!(
                        "{at}: its indices accessor holds {:?} {:?}, not unsigned integers (SCALAR UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT)",
                        indices.dimensions(),
                        indices.data_type()
                    ));
                }
            }
        }
    }
    Ok(())
}

/// The triangles of a glTF document's default scene (or its first), as [`load_gltf`] says.
fn read_gltf_scene(
    file: &Path,
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
) -> Result<FileMesh, String> {
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| format!("glTF file `{}` has no scene", file.display()))?;

    let mut materials: Vec<FileMaterial> = Vec::new();
    for (i, m) in document.materials().enumerate() {
        materials.push(gltf_material(file, &m, i)?);
    }
    // Primitives without a material use the specification's default (white, no emission).
    let default_material = materials.len() as u32;
    let mut uses_default = false;

    let mut mesh = FileMesh::default();
    let mut streams = VertexStreams {
        all_normals: true,
        all_uvs: true,
        ..VertexStreams::default()
    };
    // What flattening every node's mesh will make (a node graph can place one mesh
    // thousands of times), checked against memory before anything is read.
    let mut triangles = 0u64;
    let mut pending: Vec<gltf::Node> = scene.nodes().collect();
    let mut visits_left = document.nodes().len();
    while let Some(node) = pending.pop() {
        if visits_left == 0 {
            break; // a cycle: the walk below reports it
        }
        visits_left -= 1;
        for primitive in node.mesh().iter().flat_map(|m| m.primitives()) {
            let vertices = primitive
                .get(&gltf::Semantic::Positions)
                .map_or(0, |a| a.count());
            let corners = primitive.indices().map_or(vertices, |a| a.count());
            triangles += corners as u64 / 3;
        }
        pending.extend(node.children());
    }
    super::memory::check_triangle_memory(triangles)
        .map_err(|e| format!("glTF file `{}`: its scene's {e}", file.display()))?;
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    // A valid file is a forest: each node is reached once. More visits mean a cycle.
    let mut visits_left = document.nodes().len();
    while let Some((node, parent)) = stack.pop() {
        if visits_left == 0 {
            return Err(format!(
                "glTF file `{}`: its node hierarchy has a cycle",
                file.display()
            ));
        }
        visits_left -= 1;
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if !world.is_finite() {
            return Err(format!(
                "glTF file `{}`: node {} has a transform that is not finite",
                file.display(),
                node.index()
            ));
        }
        if let Some(gmesh) = node.mesh() {
            let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
            for primitive in gmesh.primitives() {
                let at = || {
                    format!(
                        "glTF file `{}`: mesh {} primitive {}",
                        file.display(),
                        gmesh.index(),
                        primitive.index()
                    )
                };
                if primitive.mode() != gltf::mesh::Mode::Triangles {
                    return Err(format!("{}: only triangle primitives are supported", at()));
                }
                let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
                let base = mesh.positions.len() as u32;
                let p = reader.read_positions().ok_or_else(|| {
                    format!(
                        "{}: its POSITION data cannot be read (missing, or outside its buffer)",
                        at()
                    )
                })?;
                mesh.positions
                    .extend(p.map(|v| Vec3A::from(world.transform_point3(Vec3::from(v)))));
                let count = mesh.positions.len() as u32 - base;
                // Each stream is kept only when every primitive gives one entry per vertex.
                let before = (streams.normals.len(), streams.uvs.len());
                match reader.read_normals() {
                    Some(n) if streams.all_normals => {
                        streams.normals.extend(n.map(|v| {
                            Vec3A::from(normal_matrix * Vec3::from(v)).normalize_or_zero()
                        }))
                    }
                    _ => streams.all_normals = false,
                }
                // glTF's `v` runs down the image already.
                match reader.read_tex_coords(0) {
                    Some(t) if streams.all_uvs => {
                        streams.uvs.extend(t.into_f32().map(Vec2::from_array))
                    }
                    _ => streams.all_uvs = false,
                }
                streams.all_normals &= streams.normals.len() - before.0 == count as usize;
                streams.all_uvs &= streams.uvs.len() - before.1 == count as usize;
                let tri: Vec<u32> = match (primitive.indices(), reader.read_indices()) {
                    (None, _) => (0..count).collect(),
                    (Some(_), Some(i)) => i.into_u32().collect(),
                    (Some(_), None) => {
                        return Err(format!(
                            "{}: its indices cannot be read (outside their buffer?)",
                            at()
                        ))
                    }
                };
                let material = match primitive.material().index() {
                    Some(k) => k as u32,
                    None => {
                        uses_default = true;
                        default_material
                    }
                };
                for t in tri.chunks_exact(3) {
                    if let Some(i) = t.iter().find(|&&i| i >= count) {
                        return Err(format!(
                            "{}: index {i} is out of range (the primitive has {count} vertices)",
                            at()
                        ));
                    }
                    mesh.indices.push([base + t[0], base + t[1], base + t[2]]);
                    mesh.triangle_material.push(material);
                }
            }
        }
        stack.extend(node.children().map(|c| (c, world)));
    }
    let default = uses_default.then_some([1.0; 3]);
    finish_mesh("glTF", file, mesh, materials, default, streams)
}

/// Vertex normals and texture coordinates as a file's objects give them, and whether every
/// object had them.
#[derive(Default)]
struct VertexStreams {
    normals: Vec<Vec3A>,
    all_normals: bool,
    uvs: Vec<Vec2>,
    all_uvs: bool,
}

/// Completes a mesh read from `file`: its materials, with a default one of albedo `default`
/// appended when some triangle has none; the vertex normals and texture coordinates, each
/// kept when every vertex has one; then the checks every mesh file passes.
fn finish_mesh(
    format: &str,
    file: &Path,
    mut mesh: FileMesh,
    mut materials: Vec<FileMaterial>,
    default: Option<[f32; 3]>,
    streams: VertexStreams,
) -> Result<FileMesh, String> {
    if let Some(albedo) = default {
        materials.push(FileMaterial {
            name: "default".into(),
            albedo,
            emission: None,
            two_sided: false,
        });
    }
    mesh.materials = materials;
    let count = mesh.positions.len();
    let VertexStreams {
        normals,
        all_normals,
        uvs,
        all_uvs,
    } = streams;
    mesh.normals = (all_normals && normals.len() == count).then_some(normals);
    mesh.uvs = (all_uvs && uvs.len() == count).then_some(uvs);
    check_mesh(format, file, &mut mesh)?;
    Ok(mesh)
}

/// A glTF material's base colour (as albedo) and emission (`emissiveFactor` times
/// `KHR_materials_emissive_strength`); textures are not used.
fn gltf_material(file: &Path, m: &gltf::Material, index: usize) -> Result<FileMaterial, String> {
    let name = m.name().map_or_else(|| format!("#{index}"), str::to_string);
    let [r, g, b, _alpha] = m.pbr_metallic_roughness().base_color_factor();
    let albedo = colour(file, &name, "baseColorFactor", [r, g, b])?;
    let strength = m.emissive_strength().unwrap_or(1.0);
    let emission = colour(
        file,
        &name,
        "emissiveFactor x emissive_strength",
        m.emissive_factor().map(|c| c * strength),
    )?;
    Ok(FileMaterial {
        name,
        albedo,
        emission: emission.iter().any(|c| *c > 0.0).then_some(emission),
        two_sided: m.double_sided(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Normals that are NaN, infinite or zero are replaced, one by one, by the normal of the
    /// triangles around their vertex, and counted; the good ones stay as the file has them.
    #[test]
    fn vertex_normals_that_are_not_finite_are_repaired_and_counted() {
        let mut mesh = FileMesh {
            positions: vec![Vec3A::ZERO, Vec3A::X, Vec3A::Y, Vec3A::new(1.0, 1.0, 0.0)],
            indices: vec![[0, 1, 2], [1, 3, 2]],
            normals: Some(vec![
                Vec3A::splat(f32::NAN),
                Vec3A::new(0.0, 0.6, 0.8),
                Vec3A::new(f32::INFINITY, 0.0, 1.0),
                Vec3A::ZERO,
            ]),
            ..FileMesh::default()
        };
        check_mesh("PLY", Path::new("m.ply"), &mut mesh).unwrap();
        assert_eq!(mesh.repaired_normals, 3);
        let n = mesh.normals.unwrap();
        for i in [0, 2, 3] {
            assert!((n[i] - Vec3A::Z).length() < 1e-6, "{i}: {}", n[i]);
        }
        assert_eq!(n[1], Vec3A::new(0.0, 0.6, 0.8));
    }

    #[test]
    fn angle_weighted_normals_do_not_depend_on_the_triangulation() {
        // A unit cube whose faces are split along different diagonals: at a corner a face
        // meets the vertex in one triangle (90 degrees) or two (45 + 45), so weighting by angle
        // gives every corner the diagonal direction, whatever the split (weighting by area or
        // count would not).
        let p: Vec<Vec3A> = (0..8)
            .map(|i| Vec3A::new((i & 1) as f32, ((i >> 1) & 1) as f32, (i >> 2) as f32))
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let mut tris = Vec::new();
        for (k, q) in quads.iter().enumerate() {
            if k % 2 == 0 {
                tris.extend([[q[0], q[1], q[2]], [q[0], q[2], q[3]]]);
            } else {
                tris.extend([[q[1], q[2], q[3]], [q[1], q[3], q[0]]]);
            }
        }
        let normals = angle_weighted_normals(&p, &tris);
        for (v, n) in p.iter().zip(&normals) {
            let diagonal = (*v - Vec3A::splat(0.5)).normalize();
            assert!((*n - diagonal).length() < 1e-6, "{v}: {n}");
        }
    }

    #[test]
    fn mesh_normals_modes() {
        let mesh = || FileMesh {
            positions: vec![Vec3A::ZERO, Vec3A::X, Vec3A::Y],
            indices: vec![[0, 1, 2]],
            normals: Some(vec![Vec3A::X; 3]),
            ..FileMesh::default()
        };
        assert_eq!(mesh().shaded(MeshNormals::File).normals, mesh().normals);
        assert_eq!(mesh().shaded(MeshNormals::Smooth).normals, mesh().normals);
        assert_eq!(mesh().shaded(MeshNormals::Flat).normals, None);
        let bare = FileMesh {
            normals: None,
            ..mesh()
        };
        assert_eq!(
            bare.shaded(MeshNormals::Smooth).normals,
            Some(vec![Vec3A::Z; 3])
        );
    }
}
