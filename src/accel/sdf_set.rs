//! The scene's SDF grids ([`super::sdf_grid`]) for both accelerators: their occupied voxels
//! in a BVH of their own, searched after the other geometry with the distance found so far
//! (a scene without grids pays one emptiness test per ray).

use super::bvh::{isa::Isa, Bvh, Leaves};
use super::sdf_grid::SdfGrid;
use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::ray::Ray;
use raylab_integrators::Hit;
use std::sync::Arc;

/// One SDF grid of the scene, with its material.
#[derive(Clone, Debug)]
pub struct SdfInput {
    pub grid: Arc<SdfGrid>,
    pub material: u32,
}

/// Leaves of a few voxels: each costs a cubic's solution, far more than a node's box test.
struct Voxels;

impl Leaves for Voxels {
    const BLOCK: usize = 1;
    const MAX: usize = 2;
}

/// Every grid's occupied voxels under one BVH.
#[derive(Default)]
pub struct SdfSet {
    bvh: Bvh,
    /// In BVH order: the grid (an index into `grids`) and the voxel.
    voxels: Vec<(u32, u32)>,
    grids: Vec<SdfInput>,
}

impl SdfSet {
    /// The set over `grids`.
    pub fn build(grids: &[SdfInput]) -> SdfSet {
        let mut voxels = Vec::new();
        let mut boxes = Vec::new();
        for (g, input) in grids.iter().enumerate() {
            for (voxel, (lo, hi)) in input.grid.occupied_voxels() {
                voxels.push((g as u32, voxel));
                boxes.push(Aabb::new(lo, hi));
            }
        }
        if voxels.is_empty() {
            return SdfSet::default();
        }
        let (bvh, order) = Bvh::build::<Voxels>(boxes.len(), |i| boxes[i]);
        SdfSet {
            bvh,
            voxels: order.iter().map(|&i| voxels[i as usize]).collect(),
            grids: grids.to_vec(),
        }
    }

    /// The bounds of every voxel, or `None` without any.
    pub fn bounds(&self) -> Option<Aabb> {
        self.bvh.bounds()
    }

    pub fn is_empty(&self) -> bool {
        self.voxels.is_empty()
    }

    pub fn memory_bytes(&self) -> usize {
        self.bvh.memory_bytes() + self.voxels.capacity() * std::mem::size_of::<(u32, u32)>()
    }

    /// The nearest voxel surface on `ray` before `ray.tmax`: its place and distance.
    #[inline(always)]
    pub fn closest<I: Isa>(&self, isa: I, ray: &Ray) -> Option<(u32, f32)> {
        self.bvh.closest(isa, ray, |r, first, count| {
            let mut best: Option<(u32, f32)> = None;
            for k in first..first + count {
                let tmax = best.map_or(r.tmax, |(_, t)| t);
                if let Some(t) = self.distance(k, r, tmax) {
                    best = Some((k, t));
                }
            }
            best
        })
    }

    /// Whether some voxel surface lies on `ray` before `ray.tmax`.
    #[inline(always)]
    pub fn any<I: Isa>(&self, isa: I, ray: &Ray) -> bool {
        self.bvh.any(isa, ray, |r, first, count| {
            (first..first + count).any(|k| self.distance(k, r, r.tmax).is_some())
        })
    }

    /// The distance to voxel `k`'s surface along `ray`, strictly before `tmax`.
    #[inline]
    fn distance(&self, k: u32, ray: &Ray, tmax: f32) -> Option<f32> {
        let (g, voxel) = self.voxels[k as usize];
        let grid = &self.grids[g as usize].grid;
        grid.intersect(voxel, ray.origin, ray.direction, tmax)
            .filter(|&t| t < tmax && t >= ray.tmin)
    }

    /// The surface record of voxel `k` hit at `t` by the world ray `origin + t dir`.
    pub fn hit_record(&self, origin: Vec3A, dir: Vec3A, k: u32, t: f32) -> Hit {
        let (g, _) = self.voxels[k as usize];
        let input = &self.grids[g as usize];
        input.grid.hit(origin, dir, t, input.material, None)
    }
}
