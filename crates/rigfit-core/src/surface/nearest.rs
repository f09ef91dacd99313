//! The few nearest points within a radius, for the E-step's candidate lists: a small kd-tree
//! over single-precision points, rebuilt whenever the points move (a build costs about as
//! much as a few hundred queries), and a sorted, fixed-capacity list of the nearest found.
//!
//! A general-purpose tree (kiddo) spent about 8,000 instructions on one 12-nearest query
//! here; this one, specialised to that query, about a fifth of that (BENCHMARKS.md).

/// Most neighbours a query keeps.
pub const MAX_NEAREST: usize = 64;

/// Points per leaf at most.
const LEAF: usize = 16;

/// The nearest few of a stream of candidates, `(squared distance, id)`, nearest first. Kept
/// sorted by insertion: most candidates are farther than the last kept one and cost one
/// comparison.
#[derive(Clone, Debug)]
pub struct NearestFew {
    capacity: usize,
    len: usize,
    items: [(f32, u32); MAX_NEAREST],
}

impl NearestFew {
    /// At most `capacity` (clamped to `1..=MAX_NEAREST`).
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity: capacity.clamp(1, MAX_NEAREST),
            len: 0,
            items: [(0.0, 0); MAX_NEAREST],
        }
    }

    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// The squared distance a candidate must be below to be kept, given the radius `r2`.
    #[inline]
    fn bound(&self, r2: f32) -> f32 {
        if self.len == self.capacity {
            self.items[self.len - 1].0
        } else {
            r2
        }
    }

    /// Keeps `id` if it is among the nearest so far.
    #[inline]
    pub fn offer(&mut self, d2: f32, id: u32) {
        if self.len == self.capacity {
            if d2 >= self.items[self.len - 1].0 {
                return;
            }
            self.len -= 1;
        }
        let mut i = self.len;
        while i > 0 && self.items[i - 1].0 > d2 {
            self.items[i] = self.items[i - 1];
            i -= 1;
        }
        self.items[i] = (d2, id);
        self.len += 1;
    }

    pub fn as_slice(&self) -> &[(f32, u32)] {
        &self.items[..self.len]
    }
}

/// A node: a leaf holds `points[start..end]`; an inner node splits at `split` along `axis`,
/// its first child follows it, its second is at `second`.
#[derive(Clone, Copy, Debug)]
struct Node {
    start: u32,
    end: u32,
    split: f32,
    /// 0-2, or 3 for a leaf.
    axis: u32,
    second: u32,
}

/// A kd-tree over points given with ids; queries return ids.
#[derive(Clone, Debug, Default)]
pub struct NearTree {
    points: Vec<[f32; 3]>,
    ids: Vec<u32>,
    nodes: Vec<Node>,
}

impl NearTree {
    /// The tree of `points`, the `i`-th with id `ids[i]`. Coordinates must be finite.
    pub fn new(points: &[[f32; 3]], ids: &[u32]) -> Self {
        debug_assert_eq!(points.len(), ids.len());
        let mut items: Vec<([f32; 3], u32)> =
            points.iter().copied().zip(ids.iter().copied()).collect();
        let mut nodes = Vec::with_capacity(2 * points.len() / LEAF + 1);
        if !items.is_empty() {
            build(&mut items, 0, &mut nodes);
        }
        Self {
            points: items.iter().map(|x| x.0).collect(),
            ids: items.iter().map(|x| x.1).collect(),
            nodes,
        }
    }

    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Fills `nearest` with the points nearest to `q` within squared distance `r2` (as many
    /// as its capacity), nearest first.
    pub fn nearest_within(&self, q: [f32; 3], r2: f32, nearest: &mut NearestFew) {
        nearest.clear();
        if self.nodes.is_empty() {
            return;
        }
        // Pending far children with a lower bound on their squared distance.
        let mut stack = [(0u32, 0f32); 64];
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let (mut n, floor) = stack[depth];
            if floor > nearest.bound(r2) {
                continue;
            }
            loop {
                let node = self.nodes[n as usize];
                if node.axis == 3 {
                    for i in node.start as usize..node.end as usize {
                        let p = self.points[i];
                        let (dx, dy, dz) = (p[0] - q[0], p[1] - q[1], p[2] - q[2]);
                        let d2 = dx * dx + dy * dy + dz * dz;
                        if d2 <= nearest.bound(r2) {
                            nearest.offer(d2, self.ids[i]);
                        }
                    }
                    break;
                }
                let diff = q[node.axis as usize] - node.split;
                let (near, far) = if diff < 0.0 {
                    (n + 1, node.second)
                } else {
                    (node.second, n + 1)
                };
                let gap = diff * diff;
                if gap <= nearest.bound(r2) && depth < stack.len() {
                    stack[depth] = (far, gap);
                    depth += 1;
                }
                n = near;
            }
        }
    }
}

/// Builds the subtree of `items` (reordered in place), which start at `offset` in the final
/// order, pushing its nodes depth first.
fn build(items: &mut [([f32; 3], u32)], offset: usize, nodes: &mut Vec<Node>) {
    let here = nodes.len();
    let end = offset + items.len();
    if items.len() <= LEAF {
        nodes.push(Node {
            start: offset as u32,
            end: end as u32,
            split: 0.0,
            axis: 3,
            second: 0,
        });
        return;
    }
    // Split the widest extent at the median.
    let mut low = [f32::INFINITY; 3];
    let mut high = [f32::NEG_INFINITY; 3];
    for (p, _) in items.iter() {
        for a in 0..3 {
            low[a] = low[a].min(p[a]);
            high[a] = high[a].max(p[a]);
        }
    }
    let axis = (0..3)
        .max_by(|&a, &b| (high[a] - low[a]).total_cmp(&(high[b] - low[b])))
        .unwrap_or(0);
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |x, y| x.0[axis].total_cmp(&y.0[axis]));
    let split = items[mid].0[axis];
    nodes.push(Node {
        start: offset as u32,
        end: end as u32,
        split,
        axis: axis as u32,
        second: 0,
    });
    let (left, right) = items.split_at_mut(mid);
    build(left, offset, nodes);
    nodes[here].second = nodes.len() as u32;
    build(right, offset + mid, nodes);
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn nearest_within_matches_brute_force() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        for n in [0usize, 1, 7, 9, 100, 2000] {
            let points: Vec<[f32; 3]> = (0..n)
                .map(|_| {
                    [
                        rng.random::<f32>(),
                        rng.random::<f32>(),
                        0.2 * rng.random::<f32>(),
                    ]
                })
                .collect();
            // Duplicates too.
            let mut points = points;
            if n > 10 {
                points[5] = points[4];
            }
            let ids: Vec<u32> = (0..points.len() as u32).map(|i| 3 * i + 1).collect();
            let tree = NearTree::new(&points, &ids);
            assert_eq!(tree.len(), points.len());
            for (k, r) in [(12usize, 0.15f32), (1, 1.0), (64, 0.3), (12, 0.01)] {
                let mut found = NearestFew::new(k);
                for _ in 0..50 {
                    let q = [
                        rng.random::<f32>(),
                        rng.random::<f32>(),
                        rng.random::<f32>(),
                    ];
                    tree.nearest_within(q, r * r, &mut found);
                    let mut brute: Vec<(f32, u32)> = points
                        .iter()
                        .zip(&ids)
                        .map(|(p, &id)| {
                            let d2 = (0..3).map(|a| (p[a] - q[a]).powi(2)).sum::<f32>();
                            (d2, id)
                        })
                        .filter(|&(d2, _)| d2 <= r * r)
                        .collect();
                    brute.sort_by(|a, b| a.0.total_cmp(&b.0));
                    brute.truncate(k);
                    let got: Vec<f32> = found.as_slice().iter().map(|x| x.0).collect();
                    let want: Vec<f32> = brute.iter().map(|x| x.0).collect();
                    assert_eq!(got, want, "n {n} k {k} r {r}");
                    for &(d2, id) in found.as_slice() {
                        let p = points[((id - 1) / 3) as usize];
                        let e = (0..3).map(|a| (p[a] - q[a]).powi(2)).sum::<f32>();
                        assert_eq!(e, d2);
                    }
                }
            }
        }
    }
}
