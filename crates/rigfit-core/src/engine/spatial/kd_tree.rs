//! A kd-tree over 3D points for neighbour queries on clouds and meshes (normal estimation,
//! loose vertices, nearby parts). Points at the very same position are stored once: a
//! cloud of a million copies of one point would otherwise make every query visit them all.

use std::collections::HashMap;
use std::num::NonZero;

use kiddo::{ImmutableKdTree, SquaredEuclidean};

use super::to_local;
use crate::math::Point3;

/// A kd-tree over 3D points (indices into the slice it was built from). Coordinates are
/// stored in single precision relative to the first point: ample for choosing neighbours,
/// and twice as fast to search.
#[derive(Debug)]
pub struct PointTree {
    tree: ImmutableKdTree<f32, 3>,
    origin: Point3,
    len: usize,
    /// When some points share a position: the input indices at each stored position.
    copies: Option<Copies>,
}

/// The input indices of each stored position, ascending (compressed rows).
#[derive(Debug)]
struct Copies {
    offsets: Vec<u32>,
    indices: Vec<u32>,
}

impl Copies {
    fn of(&self, stored: usize) -> &[u32] {
        &self.indices[self.offsets[stored] as usize..self.offsets[stored + 1] as usize]
    }
}

impl PointTree {
    pub fn new(points: &[[f64; 3]]) -> Self {
        let origin = Point3::from(points.first().copied().unwrap_or([0.0; 3]));
        // Single precision relative to the origin, kept finite (a point beyond f32's range
        // is as far as any other such point: a neighbour of nothing).
        let local: Vec<[f32; 3]> = points
            .iter()
            .map(|p| to_local(&Point3::from(*p), &origin).map(finite))
            .collect();
        let (stored, copies) = stored_positions(&local);
        let tree = ImmutableKdTree::new_from_slice(stored.as_deref().unwrap_or(&local))
            .expect("finite points build a kd-tree");
        Self {
            tree,
            origin,
            len: points.len(),
            copies,
        }
    }

    fn local(&self, p: &Point3) -> [f32; 3] {
        to_local(p, &self.origin).map(finite)
    }

    /// How many positions the tree stores.
    fn stored_len(&self) -> usize {
        self.copies
            .as_ref()
            .map_or(self.len, |c| c.offsets.len() - 1)
    }

    /// The input indices at a stored position, ascending.
    fn expand(&self, stored: usize) -> impl Iterator<Item = usize> + '_ {
        let copies = self.copies.as_ref().map(|c| c.of(stored));
        let single = copies.is_none().then_some(stored);
        copies
            .into_iter()
            .flatten()
            .map(|&i| i as usize)
            .chain(single)
    }

    /// The index of the nearest point (`0` for an empty tree).
    pub fn nearest(&self, p: &Point3) -> usize {
        if self.len == 0 {
            return 0;
        }
        let stored = self
            .tree
            .query(&self.local(p))
            .nearest_one::<SquaredEuclidean<f32>>()
            .execute()
            .item as usize;
        self.expand(stored).next().unwrap_or(stored)
    }

    /// Up to `n` nearest points within `radius`, nearest first, with squared distances.
    pub fn nearest_within(&self, p: &Point3, n: usize, radius: f64) -> Vec<(usize, f64)> {
        let Some(k) = NonZero::new(n.min(self.stored_len())) else {
            return Vec::new();
        };
        self.tree
            .query(&self.local(p))
            .nearest_n::<SquaredEuclidean<f32>>(k)
            .within((radius * radius) as f32)
            .execute()
            .into_iter()
            .flat_map(|r| {
                self.expand(r.item as usize)
                    .map(move |i| (i, r.distance as f64))
            })
            .take(n)
            .collect()
    }

    /// The `n` nearest points, nearest first.
    pub fn nearest_n(&self, p: &Point3, n: usize) -> Vec<usize> {
        let Some(k) = NonZero::new(n.min(self.stored_len())) else {
            return Vec::new();
        };
        self.tree
            .query(&self.local(p))
            .nearest_n::<SquaredEuclidean<f32>>(k)
            .execute()
            .into_iter()
            .flat_map(|r| self.expand(r.item as usize))
            .take(n)
            .collect()
    }
}

fn finite(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(-f32::MAX, f32::MAX)
    }
}

/// When some points share a position: each position once (in order of first appearance)
/// and the input indices at each. `(None, None)` when every point is at its own position.
fn stored_positions(local: &[[f32; 3]]) -> (Option<Vec<[f32; 3]>>, Option<Copies>) {
    // `+ 0.0` makes -0.0 and 0.0 one key.
    let key = |p: &[f32; 3]| p.map(|v| (v + 0.0).to_bits());
    let mut first_at: HashMap<[u32; 3], u32> = HashMap::with_capacity(local.len());
    let mut slot = Vec::with_capacity(local.len());
    for p in local {
        let next = first_at.len() as u32;
        slot.push(*first_at.entry(key(p)).or_insert(next));
    }
    let stored_count = first_at.len();
    if stored_count == local.len() {
        return (None, None);
    }
    let mut offsets = vec![0u32; stored_count + 1];
    for &s in &slot {
        offsets[s as usize + 1] += 1;
    }
    for s in 0..stored_count {
        offsets[s + 1] += offsets[s];
    }
    let mut fill = offsets.clone();
    let mut indices = vec![0u32; local.len()];
    let mut stored = vec![[0.0f32; 3]; stored_count];
    for (i, &s) in slot.iter().enumerate() {
        let s = s as usize;
        stored[s] = local[i];
        indices[fill[s] as usize] = i as u32;
        fill[s] += 1;
    }
    (Some(stored), Some(Copies { offsets, indices }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn copies_of_one_position_are_stored_once_and_all_found() {
        let mut points = vec![[0.0, 0.0, 0.0]; 10];
        points.push([1.0, 0.0, 0.0]);
        points.push([-0.0, 0.0, 0.0]);
        let tree = PointTree::new(&points);
        assert_eq!(tree.stored_len(), 2);
        assert_eq!(tree.nearest(&Point3::new(0.1, 0.0, 0.0)), 0);
        assert_eq!(tree.nearest(&Point3::new(0.9, 0.0, 0.0)), 10);
        let near = tree.nearest_n(&Point3::new(0.9, 0.0, 0.0), 3);
        assert_eq!(near, vec![10, 0, 1]);
        let within = tree.nearest_within(&Point3::origin(), 20, 0.5);
        let mut found: Vec<usize> = within.iter().map(|w| w.0).collect();
        found.sort_unstable();
        assert_eq!(found, (0..10).chain([11]).collect::<Vec<_>>());
    }

    #[test]
    fn distinct_points_answer_as_before() {
        let points: Vec<[f64; 3]> = (0..50).map(|i| [i as f64, 0.0, 0.0]).collect();
        let tree = PointTree::new(&points);
        assert_eq!(tree.nearest(&Point3::new(7.2, 0.0, 0.0)), 7);
        assert_eq!(tree.nearest_n(&Point3::new(7.2, 0.0, 0.0), 2), vec![7, 8]);
    }

    #[test]
    fn points_beyond_single_precision_do_not_break_the_tree() {
        let points = vec![[0.0, 0.0, 0.0], [1e300, -1e300, 0.0], [1.0, 0.0, 0.0]];
        let tree = PointTree::new(&points);
        assert_eq!(tree.nearest(&Point3::new(0.9, 0.0, 0.0)), 2);
    }
}
