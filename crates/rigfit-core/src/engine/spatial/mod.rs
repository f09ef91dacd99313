//! Spatial indices over point sets, one family: [`grid`] (a uniform grid for fixed-radius
//! neighbours and voxel subsampling: the articulated tracker's correspondences), [`kd_tree`]
//! (a general kd-tree: nearest, nearest few, within a radius; normal estimation and mesh
//! neighbours), [`near_tree`] with [`nearest_few`] (a kd-tree specialised to the few nearest
//! within a radius: the surface tracker's candidate lists), and [`morton`] (a spatial visiting
//! order). The kd-trees hold single-precision coordinates relative to an origin
//! ([`to_local`]).

pub mod grid;
pub mod kd_tree;
pub mod morton;
pub mod near_tree;
pub mod nearest_few;

pub use grid::{PointGrid, voxel_subsample};
pub use kd_tree::PointTree;
pub use morton::morton_order;
pub use near_tree::NearTree;
pub use nearest_few::{MAX_NEAREST, NearestFew};

use crate::math::Point3;

/// `p - origin` in single precision.
#[inline]
pub fn to_local(p: &Point3, origin: &Point3) -> [f32; 3] {
    [
        (p.x - origin.x) as f32,
        (p.y - origin.y) as f32,
        (p.z - origin.z) as f32,
    ]
}

/// Squared distance in single precision.
#[inline]
pub fn distance2(a: &[f32; 3], b: &[f32; 3]) -> f32 {
    let (dx, dy, dz) = (a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    dx * dx + dy * dy + dz * dz
}
