//! What reading geometry costs in memory, charged before it is read: bytes per triangle,
//! per attributed triangle, per vertex and per curve segment and piece (measured), and the
//! checks against the room this process has left.

/// Memory a triangle takes at the peak, from loading to the built BVH (world triangles, the
/// flattened arrays and the build), in bytes: measured 214 for a mesh of 1M triangles.
pub const BYTES_PER_TRIANGLE: u64 = 200;

/// What a triangle with vertex normals or texture coordinates takes besides: the vertex data
/// read, baked and laid out per triangle. Measured: 444 bytes a triangle in all for a grid of
/// 1M triangles with both, 546 for 1M triangles of their own vertices each.
pub const BYTES_PER_ATTRIBUTED_TRIANGLE: u64 = 240;

/// What a mesh file's vertex takes while it is read (positions, normals and texture
/// coordinates, as read and as converted).
pub const BYTES_PER_VERTEX: u64 = 40;

/// Memory a curve's Bézier segment takes at the peak, from its description to the built BVH
/// (the description, the entity's and the world's copies, the accelerator's), besides its
/// pieces: see [`BYTES_PER_CURVE_PIECE`].
pub const BYTES_PER_CURVE_SEGMENT: u64 = 500;

/// Memory a piece of a curve takes at the peak: a primitive of the BVH (its box in the build,
/// its lane of a packet, its share of the nodes). Measured (`/usr/bin/time`, a RON scene of
/// 5000 curves of 61 segments loaded and built), beyond the process's own: 518 bytes a
/// segment at split depth 0 (one piece), 714 at depth 1, 1693 at depth 3 (pbrt's default, 8
/// pieces) and 4475 at depth 5; charged 660, 820, 1780 and 5620.
pub const BYTES_PER_CURVE_PIECE: u64 = 160;

/// What `segments` curve segments split into `2^split_depth` pieces each take, counted as the
/// triangles that take as much (the geometry checks count triangles).
pub fn curve_triangle_equivalent(segments: u64, split_depth: u32) -> u64 {
    let pieces = segments.saturating_mul(1u64 << split_depth.min(32));
    segments
        .saturating_mul(BYTES_PER_CURVE_SEGMENT)
        .saturating_add(pieces.saturating_mul(BYTES_PER_CURVE_PIECE))
        .div_ceil(BYTES_PER_TRIANGLE)
}

/// Refuses the curves an importer has made so far, `segments` segments taking as much as
/// `triangles` triangles ([`curve_triangle_equivalent`]), if they would not fit in `room`:
/// checked curve after curve, as they are read (their entity is made of many).
pub fn check_curves_made(
    segments: u64,
    triangles: u64,
    room: &crate::system::Room,
) -> Result<(), String> {
    room.check(
        triangles.saturating_mul(BYTES_PER_TRIANGLE),
        &format!("{segments} curve segments"),
    )
}

/// Refuses a mesh of `triangles` triangles over `vertices` vertices, with or without vertex
/// normals or texture coordinates (`attributes`), that would not fit (see
/// [`check_triangle_memory`]).
pub fn check_mesh_memory(triangles: u64, vertices: u64, attributes: bool) -> Result<(), String> {
    check_bytes(
        mesh_bytes(triangles, vertices, attributes),
        &format!("{triangles} triangles"),
    )
}

/// What [`check_mesh_memory`] charges a mesh file's mesh.
pub fn mesh_bytes(triangles: u64, vertices: u64, attributes: bool) -> u64 {
    let per_triangle = BYTES_PER_TRIANGLE
        + if attributes {
            BYTES_PER_ATTRIBUTED_TRIANGLE
        } else {
            0
        };
    triangles
        .saturating_mul(per_triangle)
        .saturating_add(vertices.saturating_mul(BYTES_PER_VERTEX))
}

/// Refuses a scene of `triangles` triangles whose memory would exceed what this process may
/// still allocate (the machine's available memory, the cgroup's limit, `ulimit -v`): an
/// error before the allocation, not an abort in it.
pub fn check_triangle_memory(triangles: u64) -> Result<(), String> {
    check_bytes(
        triangles.saturating_mul(BYTES_PER_TRIANGLE),
        &format!("{triangles} triangles"),
    )
}

/// Refuses `needed` bytes for `what` beyond what this process may still allocate.
pub fn check_bytes(needed: u64, what: &str) -> Result<(), String> {
    crate::system::Room::now().check(needed, what)
}
