//! What reading geometry costs in memory, charged before it is read: bytes per triangle,
//! per attributed triangle and per vertex (measured), and the checks against the room this
//! process has left.

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
