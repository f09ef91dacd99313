//! The Morton (Z-order) curve over a point set: visiting points in its order keeps
//! neighbouring points in neighbouring memory (the surface E-step's candidate lists).

use crate::geometry::Aabb;
use crate::math::Point3;

/// The points' indices sorted along a Morton (Z-order) curve over their bounding box.
pub fn morton_order(points: &[Point3]) -> Vec<u32> {
    let Some(bounds) = Aabb::from_points(points) else {
        return Vec::new();
    };
    let extent = bounds.extent();
    let scale = 1023.0 / extent.x.max(extent.y).max(extent.z).max(1e-300);
    // Spreads the low 10 bits of `x` to every third bit.
    let spread = |x: u64| {
        let mut x = x & 0x3ff;
        x = (x | (x << 16)) & 0x0300_00ff;
        x = (x | (x << 8)) & 0x0300_f00f;
        x = (x | (x << 4)) & 0x030c_30c3;
        (x | (x << 2)) & 0x0924_9249
    };
    let mut keyed: Vec<(u64, u32)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let q = (p - bounds.min) * scale;
            let code = spread(q.x as u64) | (spread(q.y as u64) << 1) | (spread(q.z as u64) << 2);
            (code, i as u32)
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_order_is_a_permutation_that_keeps_neighbours_close() {
        let points: Vec<Point3> = (0..1000)
            .map(|i| Point3::new((i % 10) as f64, ((i / 10) % 10) as f64, (i / 100) as f64))
            .collect();
        let mut order = morton_order(&points);
        let steps: f64 = order
            .windows(2)
            .map(|w| (points[w[0] as usize] - points[w[1] as usize]).norm())
            .sum();
        // A random order would step about 5 units on average.
        assert!(steps / 999.0 < 2.0, "{}", steps / 999.0);
        order.sort_unstable();
        assert!(order.iter().enumerate().all(|(i, &o)| o as usize == i));
    }
}
