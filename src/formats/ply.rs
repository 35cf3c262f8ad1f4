//! Stanford PLY meshes (ASCII, binary little- and big-endian) through `ply-rs-bw`: vertex
//! positions, normals (`nx ny nz`) and texture coordinates (`u v`, `s t`, `texture_u
//! texture_v` or `texture_s texture_t`) in any property order and of any numeric type, faces
//! as `vertex_indices` or `vertex_index` lists, polygons split into triangle fans. Other
//! scalar properties of vertices and faces become mesh attributes named as Mitsuba 3 names
//! them (see [`group`]); other elements are read past and ignored, as Mitsuba 3 does.
//!
//! The file is third-party input to a third-party parser: its header's counts are checked
//! against the memory raylab may use before any payload is read, a panic in the parser is an
//! error naming the file, and indices and values are checked once read.

use super::mesh_files::{check_mesh, guarded, FileMesh, MeshAttribute};
use glam::{Vec2, Vec3A};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{Property, PropertyAccess, PropertyAccessResult};
use std::path::Path;

/// A property's value as a number, if it is a scalar.
fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(v) => v as f64,
        Property::UChar(v) => v as f64,
        Property::Short(v) => v as f64,
        Property::UShort(v) => v as f64,
        Property::Int(v) => v as f64,
        Property::UInt(v) => v as f64,
        Property::Float(v) => v as f64,
        Property::Double(v) => v,
        _ => return None,
    })
}

/// A list property's values as indices (negative ones become `i64` below zero).
fn list(p: Property) -> Option<Vec<i64>> {
    fn all<T: Into<i64>>(v: Vec<T>) -> Vec<i64> {
        v.into_iter().map(Into::into).collect()
    }
    Some(match p {
        Property::ListChar(v) => all(v),
        Property::ListUChar(v) => all(v),
        Property::ListShort(v) => all(v),
        Property::ListUShort(v) => all(v),
        Property::ListInt(v) => all(v),
        Property::ListUInt(v) => all(v),
        _ => return None,
    })
}

/// The slot of a vertex's position, normal or texture coordinate property, `None` for the
/// others (an attribute's).
fn vertex_slot(key: &str) -> Option<usize> {
    Some(match key {
        "x" => 0,
        "y" => 1,
        "z" => 2,
        "nx" => 3,
        "ny" => 4,
        "nz" => 5,
        "u" | "s" | "texture_u" | "texture_s" => 6,
        "v" | "t" | "texture_v" | "texture_t" => 7,
        _ => return None,
    })
}

/// Whether a face's property holds its vertex indices.
fn is_face_indices(key: &str) -> bool {
    matches!(key, "vertex_indices" | "vertex_index")
}

/// One vertex: position, normal, texture coordinates (NaN where the file gives none), and
/// its other scalar properties in the header's order.
struct Vertex([f32; 8], Vec<f32>);

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Vertex([f32::NAN; 8], Vec::new())
    }
    fn set_property(&mut self, key: &str, property: Property) -> PropertyAccessResult {
        let Some(v) = scalar(&property) else {
            return PropertyAccessResult::Ignored;
        };
        match vertex_slot(key) {
            Some(slot) => self.0[slot] = v as f32,
            None => self.1.push(v as f32),
        }
        PropertyAccessResult::Set
    }
}

/// One face: its vertex indices (empty if the file gives none; `None` if they are not
/// integers), and its other scalar properties in the header's order.
struct Face(Option<Vec<i64>>, Vec<f32>);

impl PropertyAccess for Face {
    fn new() -> Self {
        Face(Some(Vec::new()), Vec::new())
    }
    fn set_property(&mut self, key: &str, property: Property) -> PropertyAccessResult {
        if is_face_indices(key) {
            self.0 = list(property);
            return PropertyAccessResult::Set;
        }
        match scalar(&property) {
            Some(v) => {
                self.1.push(v as f32);
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::Ignored,
        }
    }
}

/// Mitsuba 3's grouping of an element's other properties (`names`, in the header's order)
/// into attributes: `r g b` (or `red green blue`) as `color`; consecutive
/// `PREFIX_x y z`, `_r g b`, `_0 1 2` or `_1 2 3` as `PREFIX` (`PREFIX_color` for `_r g b`),
/// of one or three fields; names without a one-letter suffix, and groups of other sizes, are
/// left out (Mitsuba warns and leaves them out too). Each attribute: its name and the
/// positions of its fields in `names`.
pub fn group(names: &[&str]) -> Vec<(String, Vec<usize>)> {
    let find = |n: &str| names.iter().position(|m| *m == n);
    let mut out = Vec::new();
    let colour = match (find("r"), find("g"), find("b")) {
        (Some(r), Some(g), Some(b)) => Some([r, g, b]),
        _ => match (find("red"), find("green"), find("blue")) {
            (Some(r), Some(g), Some(b)) => Some([r, g, b]),
            _ => None,
        },
    };
    let reserved: &[&str] = if colour.is_some() && find("r").is_none() {
        &["red", "green", "blue", "alpha", "r", "g", "b", "a"]
    } else {
        &["r", "g", "b", "a"]
    };
    if let Some(c) = colour {
        out.push(("color".to_string(), c.to_vec()));
    }
    const POSTFIXES: [&[u8; 4]; 4] = [b"xr01", b"yg12", b"zb23", b"wa34"];
    let mut seen: Vec<&str> = Vec::new();
    // The attribute being read: its prefix, its postfix family, its fields.
    let mut current: Option<(&str, usize, Vec<usize>)> = None;
    fn flush<'a>(
        current: &mut Option<(&'a str, usize, Vec<usize>)>,
        seen: &mut Vec<&'a str>,
        out: &mut Vec<(String, Vec<usize>)>,
    ) {
        if let Some((prefix, family, fields)) = current.take() {
            if fields.len() == 1 || fields.len() == 3 {
                let suffix = if family == 1 { "_color" } else { "" };
                out.push((format!("{prefix}{suffix}"), fields));
                seen.push(prefix);
            }
        }
    }
    for (i, name) in names.iter().enumerate() {
        if reserved.contains(name) {
            continue;
        }
        let Some((prefix, postfix)) = name.rsplit_once('_') else {
            flush(&mut current, &mut seen, &mut out);
            continue;
        };
        let [postfix] = postfix.as_bytes() else {
            flush(&mut current, &mut seen, &mut out);
            continue;
        };
        if current.as_ref().is_some_and(|(p, ..)| *p != prefix) {
            flush(&mut current, &mut seen, &mut out);
        }
        match &mut current {
            None => {
                if seen.contains(&prefix) {
                    continue;
                }
                if let Some(family) = POSTFIXES[0].iter().position(|c| c == postfix) {
                    current = Some((prefix, family, vec![i]));
                }
            }
            Some((_, family, fields)) => {
                let level = fields.len();
                if level < 4 && POSTFIXES[level][*family] == *postfix {
                    fields.push(i);
                } else {
                    // A broken sequence: the attribute is left out.
                    seen.push(prefix);
                    current = None;
                }
            }
        }
    }
    flush(&mut current, &mut seen, &mut out);
    out
}

/// The attributes of one element (`kind` `vertex` or `face`) from its records' other values
/// (`records[i]`, in the order of `names`).
fn attributes_of(kind: &str, names: &[&str], records: &[&[f32]]) -> Vec<MeshAttribute> {
    group(names)
        .into_iter()
        .map(|(name, fields)| MeshAttribute {
            name: format!("{kind}_{name}"),
            values: records
                .iter()
                .map(|r| {
                    let at = |k: usize| fields.get(k).and_then(|&f| r.get(f)).copied();
                    match (at(0), at(1), at(2)) {
                        (Some(a), Some(b), Some(c)) => Vec3A::new(a, b, c),
                        (Some(a), _, _) => Vec3A::splat(a),
                        _ => Vec3A::ZERO,
                    }
                })
                .collect(),
            per_face: kind == "face",
        })
        .collect()
}

/// The names of element `kind`'s scalar properties that are not its geometry, in order.
fn other_names<'h>(header: &'h ply_rs_bw::ply::Header, kind: &str) -> Vec<&'h str> {
    header.elements.get(kind).map_or(Vec::new(), |e| {
        e.properties
            .values()
            .filter(|p| matches!(p.data_type, ply_rs_bw::ply::PropertyType::Scalar(_)))
            .map(|p| p.name.as_str())
            .filter(|n| match kind {
                "vertex" => vertex_slot(n).is_none(),
                _ => !is_face_indices(n),
            })
            .collect()
    })
}

/// An element raylab does not use, read past.
struct Skipped;

impl PropertyAccess for Skipped {
    fn new() -> Self {
        Skipped
    }
}

/// The parser's message: its first line (the rest repeats the file's bytes, which may hold
/// anything), with control characters escaped.
fn first_line(e: &dyn std::fmt::Display) -> String {
    let text = e.to_string();
    let line = text.lines().next().unwrap_or("").trim_end();
    line.chars()
        .map(|c| if c.is_control() { '?' } else { c })
        .collect()
}

/// Loads a PLY file as one mesh in the file's space.
pub fn load_ply(file: &Path) -> Result<FileMesh, String> {
    let bytes = crate::files::read_uncompressed(file, crate::files::MAX_BINARY)
        .map_err(|e| format!("cannot load PLY file `{}`: {e}", file.display()))?;
    parse_ply(file, &bytes)
}

/// Reads a PLY file's `bytes` (`file` names it in messages).
pub fn parse_ply(file: &Path, bytes: &[u8]) -> Result<FileMesh, String> {
    let cannot =
        |e: &dyn std::fmt::Display| format!("cannot load PLY file `{}`: {e}", file.display());
    let mut reader = Reader::new(std::io::Cursor::new(bytes));
    let vertex_parser = Parser::<Vertex>::new();
    let header = guarded(
        "PLY",
        file,
        std::panic::AssertUnwindSafe(|| vertex_parser.read_header(&mut reader)),
    )?
    .map_err(|e| cannot(&first_line(&e)))?;
    let count = |name: &str| header.elements.get(name).map_or(0, |e| e.count as u64);
    let has = |names: &[&str]| {
        header
            .elements
            .get("vertex")
            .is_some_and(|e| names.iter().any(|n| e.properties.contains_key(*n)))
    };
    for axis in ["x", "y", "z"] {
        if !has(&[axis]) {
            return Err(cannot(&format!("its vertices have no `{axis}` property")));
        }
    }
    if !header.elements.get("face").is_some_and(|e| {
        e.properties.contains_key("vertex_indices") || e.properties.contains_key("vertex_index")
    }) {
        return Err(cannot(
            &"it has no faces (a `face` element with `vertex_indices`)",
        ));
    }
    // Every element of a property takes at least a byte of the file: a header claiming more
    // is damaged or hostile (an element without properties would be read from no bytes,
    // forever).
    let left = bytes.len() as u64;
    for e in header.elements.values() {
        if e.count > 0 && e.properties.is_empty() {
            return Err(cannot(&format!(
                "element `{}` has {} entries but no properties",
                e.name, e.count
            )));
        }
        if e.count as u64 > left {
            return Err(cannot(&format!(
                "element `{}` claims {} entries, more than the file's {left} bytes could hold",
                e.name, e.count
            )));
        }
    }
    let has_normals = has(&["nx"]) && has(&["ny"]) && has(&["nz"]);
    let has_uvs =
        has(&["u", "s", "texture_u", "texture_s"]) && has(&["v", "t", "texture_v", "texture_t"]);
    // Every face is at least one triangle: refuse what cannot fit before reading (a header
    // may claim billions).
    super::memory::check_mesh_memory(count("face"), count("vertex"), has_normals || has_uvs)
        .map_err(|e| cannot(&e))?;
    // Other properties are kept per record while reading (a vector of their values), then
    // as attributes of three channels: charged before any is read.
    let (vertex_extra, face_extra) = (
        other_names(&header, "vertex").len() as u64,
        other_names(&header, "face").len() as u64,
    );
    let extra = |records: u64, fields: u64| {
        if fields == 0 {
            0
        } else {
            records.saturating_mul(24 + 4 * fields + 16 * fields)
        }
    };
    let extra_bytes = extra(count("vertex"), vertex_extra)
        .saturating_add(extra(count("face").saturating_mul(2), face_extra));
    if extra_bytes > 0 {
        super::memory::check_bytes(extra_bytes, "the mesh's other properties")
            .map_err(|e| cannot(&e))?;
    }

    let (face_parser, skip_parser) = (Parser::<Face>::new(), Parser::<Skipped>::new());
    let (mut vertices, mut faces) = (Vec::new(), Vec::new());
    for element in header.elements.values() {
        guarded(
            "PLY",
            file,
            std::panic::AssertUnwindSafe(|| {
                match element.name.as_str() {
                    "vertex" => {
                        vertices =
                            vertex_parser.read_payload_for_element(&mut reader, element, &header)?
                    }
                    "face" => {
                        faces =
                            face_parser.read_payload_for_element(&mut reader, element, &header)?
                    }
                    _ => {
                        skip_parser.read_payload_for_element(&mut reader, element, &header)?;
                    }
                }
                Ok::<(), ply_rs_bw::parser::ParseError>(())
            }),
        )?
        .map_err(|e| cannot(&format!("element `{}`: {}", element.name, first_line(&e))))?;
    }

    let mut mesh = FileMesh {
        positions: vertices
            .iter()
            .map(|v| Vec3A::new(v.0[0], v.0[1], v.0[2]))
            .collect(),
        ..FileMesh::default()
    };
    if has_normals {
        mesh.normals = Some(
            vertices
                .iter()
                .map(|v| Vec3A::new(v.0[3], v.0[4], v.0[5]))
                .collect(),
        );
    }
    if has_uvs {
        mesh.uvs = Some(vertices.iter().map(|v| Vec2::new(v.0[6], v.0[7])).collect());
    }
    let n = vertices.len() as i64;
    let vertex_values: Vec<&[f32]> = vertices.iter().map(|v| v.1.as_slice()).collect();
    mesh.attributes = attributes_of("vertex", &other_names(&header, "vertex"), &vertex_values);
    // A face's values go to each triangle it is split into.
    let mut triangle_values: Vec<&[f32]> = Vec::new();
    for (f, Face(indices, values)) in faces.iter().enumerate() {
        let Some(indices) = indices else {
            return Err(cannot(&format!(
                "face {f}'s vertex indices are not integers"
            )));
        };
        if let Some(&bad) = indices.iter().find(|&&i| !(0..n).contains(&i)) {
            return Err(cannot(&format!(
                "face {f} refers to vertex {bad}, but the file has {n} vertices"
            )));
        }
        // A fan: polygons of n corners become n - 2 triangles (none for fewer than three).
        for k in 1..indices.len().saturating_sub(1) {
            mesh.indices
                .push([indices[0], indices[k], indices[k + 1]].map(|i| i as u32));
            triangle_values.push(values);
        }
    }
    let face_names = other_names(&header, "face");
    mesh.attributes
        .extend(attributes_of("face", &face_names, &triangle_values));
    check_mesh("PLY", file, &mut mesh)?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit square as two triangles (or one quad), with normals and uvs, in `format`;
    /// properties in an unusual order, of mixed types, and an extra element and property.
    fn square(format: &str, quad: bool) -> Vec<u8> {
        let verts = [
            [-1.0f32, -1.0, 0.0, 0.0, 0.0],
            [1.0, -1.0, 0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0, 1.0, 1.0],
            [-1.0, 1.0, 0.0, 0.0, 1.0],
        ];
        let faces: Vec<Vec<i32>> = if quad {
            vec![vec![0, 1, 2, 3]]
        } else {
            vec![vec![0, 1, 2], vec![0, 2, 3]]
        };
        let mut out = format!(
            "ply\nformat {format} 1.0\ncomment made by raylab's tests\nelement material 1\nproperty uchar red\n\
             element vertex 4\nproperty float u\nproperty double x\nproperty float y\nproperty float z\n\
             property float v\nproperty float nz\nproperty float nx\nproperty float ny\nproperty uchar quality\n\
             element face {}\nproperty list uchar int vertex_indices\nproperty ushort flags\nend_header\n",
            faces.len()
        )
        .into_bytes();
        let big = format == "binary_big_endian";
        let f32b = |v: f32| {
            if big {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        };
        let i32b = |v: i32| {
            if big {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        };
        if format == "ascii" {
            out.extend_from_slice(b"7\n");
            for v in verts {
                out.extend_from_slice(
                    format!("{} {} {} {} {} 1 0 0 9\n", v[3], v[0], v[1], v[2], v[4]).as_bytes(),
                );
            }
            for f in &faces {
                let list: Vec<String> = f.iter().map(|i| i.to_string()).collect();
                out.extend_from_slice(format!("{} {} 3\n", f.len(), list.join(" ")).as_bytes());
            }
        } else {
            out.push(7);
            for v in verts {
                out.extend_from_slice(&f32b(v[3]));
                let x = v[0] as f64;
                out.extend_from_slice(&if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                });
                for c in [v[1], v[2], v[4], 1.0, 0.0, 0.0] {
                    out.extend_from_slice(&f32b(c));
                }
                out.push(9);
            }
            for f in &faces {
                out.push(f.len() as u8);
                for &i in f {
                    out.extend_from_slice(&i32b(i));
                }
                out.extend_from_slice(&if big {
                    3u16.to_be_bytes()
                } else {
                    3u16.to_le_bytes()
                });
            }
        }
        out
    }

    fn load(bytes: &[u8]) -> Result<FileMesh, String> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.ply");
        std::fs::write(&path, bytes).unwrap();
        load_ply(&path)
    }

    #[test]
    fn ascii_and_both_binary_orders_read_the_same_mesh() {
        for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
            for quad in [false, true] {
                let m = load(&square(format, quad)).unwrap_or_else(|e| panic!("{format}: {e}"));
                assert_eq!(m.positions[2], Vec3A::new(1.0, 1.0, 0.0), "{format}");
                assert_eq!(
                    m.indices,
                    vec![[0, 1, 2], [0, 2, 3]],
                    "{format} quad {quad}"
                );
                assert_eq!(m.normals.as_ref().unwrap()[1], Vec3A::Z, "{format}");
                // Texture coordinates as the file has them (Mitsuba 3 does not flip PLY's v).
                assert_eq!(m.uvs.as_ref().unwrap()[1], Vec2::new(1.0, 0.0), "{format}");
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config::with_cases(400))]
        /// Valid files cut short or with bytes replaced: an error or a mesh, never a panic.
        #[test]
        fn damaged_files_never_panic(
            format in 0usize..3,
            cut in proptest::prelude::any::<proptest::sample::Index>(),
            at in proptest::prelude::any::<proptest::sample::Index>(),
            bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..6),
        ) {
            let format = ["ascii", "binary_little_endian", "binary_big_endian"][format];
            let mut file = square(format, format == "ascii");
            let at = at.index(file.len());
            let end = (at + bytes.len()).min(file.len());
            file.splice(at..end, bytes);
            let _ = parse_ply(Path::new("damaged.ply"), &file);
            file.truncate(cut.index(file.len() + 1));
            let _ = parse_ply(Path::new("cut.ply"), &file);
        }
    }

    #[test]
    fn other_properties_group_into_attributes_as_mitsuba_names_them() {
        let names = |g: Vec<(String, Vec<usize>)>| g.into_iter().collect::<Vec<_>>();
        // r g b (or red green blue) anywhere: `color`; PREFIX_0 1 2 and PREFIX_x y z: PREFIX;
        // PREFIX_r g b: PREFIX_color; one field alone: itself.
        assert_eq!(
            names(group(&[
                "weight_0", "red", "green", "blue", "n_x", "n_y", "n_z", "tint_r", "tint_g",
                "tint_b"
            ])),
            vec![
                ("color".to_string(), vec![1, 2, 3]),
                ("weight".to_string(), vec![0]),
                ("n".to_string(), vec![4, 5, 6]),
                ("tint_color".to_string(), vec![7, 8, 9]),
            ]
        );
        // Two fields, a broken sequence, no one-letter suffix: left out, as Mitsuba does.
        assert_eq!(
            names(group(&[
                "a_0",
                "a_1",
                "b_0",
                "b_2",
                "b_1",
                "confidence",
                "c_12"
            ])),
            vec![]
        );
    }

    #[test]
    fn a_ply_gives_its_vertex_and_face_attributes() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                    property float color_0\nproperty float color_1\nproperty float color_2\nelement face 1\n\
                    property list uchar int vertex_indices\nproperty float weight_0\nend_header\n\
                    0 0 0 0.1 0.2 0.3\n1 0 0 0.4 0.5 0.6\n0 1 0 0.7 0.8 0.9\n3 0 1 2 0.25\n";
        let mesh = load(text.as_bytes()).unwrap();
        let names: Vec<&str> = mesh.attributes.iter().map(|a| a.name.as_str()).collect();
        assert_eq!(names, ["vertex_color", "face_weight"]);
        assert_eq!(mesh.attributes[0].values[2], Vec3A::new(0.7, 0.8, 0.9));
        assert!(!mesh.attributes[0].per_face && mesh.attributes[1].per_face);
        assert_eq!(mesh.attributes[1].values, vec![Vec3A::splat(0.25)]);
    }

    #[test]
    fn bad_files_are_refused_with_a_reason() {
        let good = square("binary_little_endian", false);
        let text = String::from_utf8_lossy(&square("ascii", false)).to_string();
        let cases: Vec<(Vec<u8>, &str)> = vec![
            (b"not a ply file at all".to_vec(), "cannot load PLY file"),
            (good[..good.len() - 5].to_vec(), "element `face`"),
            (
                text.replace("3 0 2 3 3\n", "3 0 2 4 3\n").into_bytes(),
                "face 1 refers to vertex 4, but the file has 4 vertices",
            ),
            (
                text.replace("3 0 2 3 3\n", "3 0 -1 3 3\n").into_bytes(),
                "refers to vertex -1",
            ),
            (
                text.replace("element face 2", "element face 4000000000000")
                    .into_bytes(),
                "cannot load PLY file",
            ),
            (
                text.replace("property double x\n", "").into_bytes(),
                "no `x` property",
            ),
            (
                text.replace("1 1 1 0 1 1 0 0 9", "1 1 1e39 0 1 1 0 0 9")
                    .into_bytes(),
                "not finite",
            ),
        ];
        for (bytes, expected) in cases {
            let e = load(&bytes).map(|_| ()).expect_err(expected);
            assert!(e.contains(expected), "{e:?} lacks {expected:?}");
        }
    }
}
