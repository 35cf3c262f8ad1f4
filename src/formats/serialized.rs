//! Mitsuba's `.serialized` meshes (format versions 3 and 4), as Mitsuba 3's `serialized` shape
//! reads them: a little-endian file of one or more meshes, each a 4-byte header (`0x041C`, the
//! version) followed by a zlib stream of flags, (v4) a name, the vertex and triangle counts,
//! positions, optional normals, texture coordinates and colours (single or double precision),
//! and `u32` triangle indices; after the last mesh, a table of each mesh's file offset (`u64`
//! in v4, `u32` in v3) and their count (`u32`).
//!
//! The counts come from the file: they are checked against the file's size (zlib cannot
//! expand data more than 1032 times) and against the memory raylab may use before anything is
//! allocated, and the stream is read no further than they say.

use super::mesh_files::{check_mesh, FileMesh};
use flate2::read::ZlibDecoder;
use glam::{Vec2, Vec3A};
use std::io::Read;
use std::path::Path;

const HEADER: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const DOUBLE_PRECISION: u32 = 0x2000;
/// The most zlib's deflate can expand its input.
const MAX_INFLATION: u64 = 1032;

/// Loads mesh `shape_index` of a `.serialized` file, in the file's space.
pub fn load_serialized(file: &Path, shape_index: u32) -> Result<FileMesh, String> {
    let bytes = crate::files::read_capped(file, crate::files::MAX_BINARY)
        .map_err(|e| format!("cannot load serialized mesh `{}`: {e}", file.display()))?;
    parse_serialized(file, &bytes, shape_index)
}

/// Reads mesh `shape_index` of a `.serialized` file's `bytes` (`file` names it in messages).
pub fn parse_serialized(file: &Path, bytes: &[u8], shape_index: u32) -> Result<FileMesh, String> {
    let cannot = |e: &str| format!("cannot load serialized mesh `{}`: {e}", file.display());
    let version = header(bytes, 0).map_err(|e| cannot(&e))?;
    let start = if shape_index == 0 {
        0
    } else {
        mesh_offset(bytes, version, shape_index).map_err(|e| cannot(&e))?
    };
    if start != 0 && header(bytes, start).map_err(|e| cannot(&e))? != version {
        return Err(cannot(&format!(
            "mesh {shape_index} has another format version than the file's first"
        )));
    }
    let compressed = &bytes[start + 4..];
    let mut stream = Stream {
        inner: ZlibDecoder::new(compressed),
        budget: (compressed.len() as u64).saturating_mul(MAX_INFLATION),
    };
    read_mesh(&mut stream, version)
        .map_err(|e| cannot(&format!("mesh {shape_index}: {e}")))
        .and_then(|mut mesh| {
            check_mesh("serialized", file, &mut mesh)?;
            Ok(mesh)
        })
}

/// The format version of the header at `at`, which must be Mitsuba's.
fn header(bytes: &[u8], at: usize) -> Result<u16, String> {
    let word = |i: usize| {
        bytes
            .get(at + i..at + i + 2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
    };
    match (word(0), word(2)) {
        (Some(HEADER), Some(v @ (3 | 4))) => Ok(v),
        (Some(HEADER), Some(v)) => Err(format!(
            "format version {v} is not supported (Mitsuba's are 3 and 4)"
        )),
        _ => Err("it is not a Mitsuba serialized mesh (no 0x041C header)".to_string()),
    }
}

/// Where mesh `index` starts, from the table at the end of the file.
fn mesh_offset(bytes: &[u8], version: u16, index: u32) -> Result<usize, String> {
    let len = bytes.len();
    let tail = |from: usize, n: usize| bytes.get(from..from + n);
    let count = len
        .checked_sub(4)
        .and_then(|at| tail(at, 4))
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .ok_or("the file is too short for its table of meshes")?;
    if index >= count {
        return Err(format!(
            "shape_index {index} is out of range: the file holds {count} mesh(es)"
        ));
    }
    let width = if version == 4 { 8 } else { 4 };
    let from_end = (count - index) as usize * width + 4;
    let entry = len
        .checked_sub(from_end)
        .and_then(|at| tail(at, width))
        .ok_or("the file is too short for its table of meshes")?;
    let offset = if version == 4 {
        u64::from_le_bytes(entry.try_into().map_err(|_| "a damaged table of meshes")?)
    } else {
        u32::from_le_bytes(entry.try_into().map_err(|_| "a damaged table of meshes")?) as u64
    };
    usize::try_from(offset)
        .ok()
        .filter(|&o| o.saturating_add(4) < len)
        .ok_or_else(|| {
            format!("mesh {index} starts at {offset}, past the file's end ({len} bytes)")
        })
}

/// The decompressed stream, with what it may still yield.
struct Stream<'a> {
    inner: ZlibDecoder<&'a [u8]>,
    budget: u64,
}

impl Stream<'_> {
    fn bytes(&mut self, n: u64) -> Result<Vec<u8>, String> {
        if n > self.budget {
            return Err(format!(
                "it claims {n} more bytes than its compressed data can hold"
            ));
        }
        self.budget -= n;
        let mut buf = vec![0u8; n as usize];
        self.inner
            .read_exact(&mut buf)
            .map_err(|e| match e.kind() {
                std::io::ErrorKind::UnexpectedEof => "the data ends early".to_string(),
                _ => format!("the compressed data is damaged ({e})"),
            })?;
        Ok(buf)
    }

    fn u32(&mut self) -> Result<u32, String> {
        let b = self.bytes(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn u64(&mut self) -> Result<u64, String> {
        let b = self.bytes(8)?;
        Ok(u64::from_le_bytes(b[..8].try_into().unwrap_or([0; 8])))
    }

    /// `n` floats of the file's precision.
    fn floats(&mut self, n: u64, double: bool) -> Result<Vec<f32>, String> {
        let width = if double { 8 } else { 4 };
        let raw = self.bytes(n.saturating_mul(width))?;
        Ok(if double {
            raw.chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])) as f32)
                .collect()
        } else {
            raw.chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect()
        })
    }
}

fn read_mesh(s: &mut Stream, version: u16) -> Result<FileMesh, String> {
    let flags = s.u32()?;
    if version == 4 {
        // The mesh's name, zero-terminated (not used).
        while s.bytes(1)?[0] != 0 {}
    }
    let (vertices, triangles) = (s.u64()?, s.u64()?);
    if vertices > u32::MAX as u64 {
        return Err(format!(
            "{vertices} vertices: raylab indexes meshes with 32 bits"
        ));
    }
    super::memory::check_mesh_memory(
        triangles,
        vertices,
        flags & (HAS_NORMALS | HAS_TEXCOORDS) != 0,
    )?;
    let double = flags & DOUBLE_PRECISION != 0;
    let vec3s = |v: Vec<f32>| -> Vec<Vec3A> {
        v.chunks_exact(3)
            .map(|c| Vec3A::new(c[0], c[1], c[2]))
            .collect()
    };
    let mut mesh = FileMesh {
        positions: vec3s(s.floats(vertices * 3, double)?),
        ..FileMesh::default()
    };
    if flags & HAS_NORMALS != 0 {
        mesh.normals = Some(vec3s(s.floats(vertices * 3, double)?));
    }
    if flags & HAS_TEXCOORDS != 0 {
        let uv = s.floats(vertices * 2, double)?;
        mesh.uvs = Some(uv.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect());
    }
    if flags & HAS_COLORS != 0 {
        // Vertex colours: read past, as Mitsuba 3 does.
        s.floats(vertices * 3, double)?;
    }
    let raw = s.bytes(triangles.saturating_mul(12))?;
    mesh.indices = raw
        .chunks_exact(12)
        .map(|c| {
            let i = |k: usize| u32::from_le_bytes([c[k], c[k + 1], c[k + 2], c[k + 3]]);
            [i(0), i(4), i(8)]
        })
        .collect();
    if let Some((t, bad)) = mesh
        .indices
        .iter()
        .enumerate()
        .find_map(|(t, tri)| tri.iter().find(|&&i| i as u64 >= vertices).map(|&i| (t, i)))
    {
        return Err(format!(
            "triangle {t} refers to vertex {bad}, but the mesh has {vertices} vertices"
        ));
    }
    Ok(mesh)
}

/// A mesh to write: positions, triangles and optional normals.
#[cfg(test)]
pub(crate) type MeshData<'a> = (&'a [[f32; 3]], &'a [[u32; 3]], Option<&'a [[f32; 3]]>);

/// Writes meshes in the format (`version` 3 or 4), for tests.
#[cfg(test)]
pub(crate) fn write_serialized(version: u16, meshes: &[MeshData]) -> Vec<u8> {
    use flate2::write::ZlibEncoder;
    use std::io::Write;
    let mut out = Vec::new();
    let mut offsets = Vec::new();
    for (positions, triangles, normals) in meshes {
        offsets.push(out.len() as u64);
        out.extend_from_slice(&HEADER.to_le_bytes());
        out.extend_from_slice(&version.to_le_bytes());
        let mut body = Vec::new();
        let flags = 0x1000 | if normals.is_some() { HAS_NORMALS } else { 0 };
        body.extend_from_slice(&flags.to_le_bytes());
        if version == 4 {
            body.extend_from_slice(b"mesh\0");
        }
        body.extend_from_slice(&(positions.len() as u64).to_le_bytes());
        body.extend_from_slice(&(triangles.len() as u64).to_le_bytes());
        for v in positions
            .iter()
            .chain(normals.iter().flat_map(|n| n.iter()))
        {
            for x in v {
                body.extend_from_slice(&x.to_le_bytes());
            }
        }
        for t in triangles.iter() {
            for i in t {
                body.extend_from_slice(&i.to_le_bytes());
            }
        }
        let mut z = ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        let _ = z.write_all(&body);
        out.extend(z.finish().unwrap_or_default());
    }
    for &o in &offsets {
        if version == 4 {
            out.extend_from_slice(&o.to_le_bytes());
        } else {
            out.extend_from_slice(&(o as u32).to_le_bytes());
        }
    }
    out.extend_from_slice(&(offsets.len() as u32).to_le_bytes());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const SQUARE: [[f32; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    const TRIS: [[u32; 3]; 2] = [[0, 1, 2], [0, 2, 3]];
    const UP: [[f32; 3]; 4] = [[0.0, 0.0, 1.0]; 4];

    fn two_meshes(version: u16) -> Vec<u8> {
        write_serialized(
            version,
            &[
                (&SQUARE, &TRIS, None),
                (&SQUARE[..3], &TRIS[..1], Some(&UP[..3])),
            ],
        )
    }

    #[test]
    fn reads_each_mesh_of_a_file_of_either_version() {
        for version in [3, 4] {
            reads_each_mesh(version);
        }
    }

    fn reads_each_mesh(version: u16) {
        let bytes = two_meshes(version);
        let path = Path::new("m.serialized");
        let first = parse_serialized(path, &bytes, 0).unwrap();
        assert_eq!(first.positions.len(), 4);
        assert_eq!(first.indices, TRIS.to_vec());
        assert!(first.normals.is_none() && first.uvs.is_none());
        let second = parse_serialized(path, &bytes, 1).unwrap();
        assert_eq!(second.indices, vec![[0, 1, 2]]);
        assert_eq!(second.positions[2], Vec3A::new(1.0, 1.0, 0.0));
        assert_eq!(second.normals.unwrap()[1], Vec3A::Z);
        let err = parse_serialized(path, &bytes, 2).unwrap_err();
        assert!(
            err.contains("shape_index 2 is out of range: the file holds 2"),
            "{err}"
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config::with_cases(300))]
        /// Files with bytes replaced, before or after compression, or cut short: an error or
        /// a mesh, never a panic or a huge allocation.
        #[test]
        fn damaged_files_never_panic(
            version in 3u16..5,
            compressed in proptest::prelude::any::<bool>(),
            cut in proptest::prelude::any::<proptest::sample::Index>(),
            at in proptest::prelude::any::<proptest::sample::Index>(),
            bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..9),
        ) {
            let mut file = two_meshes(version);
            if compressed {
                let at = at.index(file.len());
                let end = (at + bytes.len()).min(file.len());
                file.splice(at..end, bytes);
            } else {
                // The first mesh's stream, damaged, then compressed again.
                let mut body = Vec::new();
                let _ = ZlibDecoder::new(&file[4..]).read_to_end(&mut body);
                let at = at.index(body.len());
                let end = (at + bytes.len()).min(body.len());
                body.splice(at..end, bytes);
                let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
                let _ = std::io::Write::write_all(&mut z, &body);
                file.truncate(4);
                file.extend(z.finish().unwrap_or_default());
            }
            for index in [0, 1] {
                let _ = parse_serialized(Path::new("damaged.serialized"), &file, index);
            }
            file.truncate(cut.index(file.len() + 1));
            let _ = parse_serialized(Path::new("cut.serialized"), &file, 0);
        }
    }

    #[test]
    fn damaged_files_are_errors() {
        let path = Path::new("m.serialized");
        let bytes = two_meshes(4);
        let cases: Vec<(Vec<u8>, &str)> = vec![
            (b"PLY\n".to_vec(), "not a Mitsuba serialized mesh"),
            (vec![0x1C, 0x04, 9, 0], "format version 9"),
            (bytes[..bytes.len() / 3].to_vec(), "ends early"),
            (
                {
                    let mut b = bytes.clone();
                    b[10] ^= 0xFF;
                    b
                },
                "",
            ),
        ];
        for (data, want) in cases {
            let err = parse_serialized(path, &data, 0).unwrap_err();
            assert!(err.contains(want) && err.contains("m.serialized"), "{err}");
        }
        // A count that the compressed data cannot hold is refused before allocating.
        let huge = write_serialized(4, &[(&SQUARE, &TRIS, None)]);
        let mut body = Vec::new();
        ZlibDecoder::new(&huge[4..]).read_to_end(&mut body).unwrap();
        body[9..17].copy_from_slice(&(1u64 << 40).to_le_bytes());
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        std::io::Write::write_all(&mut z, &body).unwrap();
        let mut file = huge[..4].to_vec();
        file.extend(z.finish().unwrap());
        let err = parse_serialized(path, &file, 0).unwrap_err();
        assert!(
            err.contains("vertices") || err.contains("memory") || err.contains("hold"),
            "{err}"
        );
        // An index past the vertices.
        let bad = write_serialized(4, &[(&SQUARE, &[[0, 1, 7]], None)]);
        let err = parse_serialized(path, &bad, 0).unwrap_err();
        assert!(err.contains("refers to vertex 7"), "{err}");
    }
}
