//! A kd-tree specialised to the E-step's candidate query, the few nearest points within a
//! radius ([`NearTree`]): single-precision points in full leaves stored by coordinate with
//! their bounding boxes, cells bounded by incremental distances, rebuilt whenever the points
//! move. The general-purpose tree of [`super::kd_tree`] answers the other queries
//! (BENCHMARKS.md compares the two on this one).

use super::nearest_few::{NearestFew, Pending};

/// Points per leaf. Leaves are full (but the last), padded with points at infinity, so that
/// a leaf's distances are one fixed-length loop the compiler vectorises. 32 is the width of
/// the leaf's bit mask (larger leaves: fewer nodes to descend and to build, more distances
/// per leaf; BENCHMARKS.md has the choice).
const LEAF: usize = 32;
const _: () = assert!(LEAF <= 32, "a leaf's mask is a u32");

/// A node: a leaf holds leaf block `start`; an inner node splits at `split` along `axis`,
/// its first child follows it, its second is at `second`.
#[derive(Clone, Copy, Debug)]
struct Node {
    start: u32,
    split: f32,
    /// 0-2, or 3 for a leaf.
    axis: u32,
    second: u32,
}

const LEAF_AXIS: u32 = 3;

/// One leaf's points by coordinate, with their ids.
#[derive(Clone, Copy, Debug)]
struct LeafBlock {
    x: [f32; LEAF],
    y: [f32; LEAF],
    z: [f32; LEAF],
    id: [u32; LEAF],
}

/// The bounding box of a leaf's points. A leaf's cell is often much larger than its points:
/// the box turns away about a third of the leaves a search reaches. Boxes are kept apart
/// from the points, several to a cache line, so that a leaf turned away costs no load of it.
#[derive(Clone, Copy, Debug)]
struct LeafBox {
    low: [f32; 3],
    high: [f32; 3],
}

impl LeafBox {
    /// The box of no point (every distance to it is infinite).
    const EMPTY: Self = Self {
        low: [f32::INFINITY; 3],
        high: [f32::NEG_INFINITY; 3],
    };

    #[inline]
    fn extend(&mut self, p: [f32; 3]) {
        for a in 0..3 {
            self.low[a] = self.low[a].min(p[a]);
            self.high[a] = self.high[a].max(p[a]);
        }
    }

    /// Squared distance from `q` to the box of the leaf's points.
    #[inline]
    fn box_distance2(&self, q: [f32; 3]) -> f32 {
        let mut d2 = 0.0;
        for a in 0..3 {
            let outside = (self.low[a] - q[a]).max(q[a] - self.high[a]).max(0.0);
            d2 += outside * outside;
        }
        d2
    }
}

/// A kd-tree over points given with ids; queries return ids.
#[derive(Clone, Debug, Default)]
pub struct NearTree {
    len: usize,
    leaves: Vec<LeafBlock>,
    boxes: Vec<LeafBox>,
    nodes: Vec<Node>,
    /// The points with their ids, reordered by the build (kept for the next one).
    items: Vec<([f32; 3], u32)>,
}

impl NearTree {
    /// The tree of `points`, the `i`-th with id `ids[i]`. Coordinates must be finite.
    pub fn new(points: &[[f32; 3]], ids: &[u32]) -> Self {
        let mut tree = Self::default();
        tree.rebuild(points, ids);
        tree
    }

    /// Makes this the tree of `points` (as [`NearTree::new`]), reusing its buffers: a frame
    /// builds a tree every E-step, and fresh buffers of this size cost page faults.
    pub fn rebuild(&mut self, points: &[[f32; 3]], ids: &[u32]) {
        debug_assert_eq!(points.len(), ids.len());
        self.len = points.len();
        self.items.clear();
        self.items
            .extend(points.iter().copied().zip(ids.iter().copied()));
        let n_leaves = points.len().div_ceil(LEAF);
        // Every inner node has two children: one node fewer than twice the leaves.
        let n_nodes = (2 * n_leaves).saturating_sub(1);
        let empty_node = Node {
            start: 0,
            split: 0.0,
            axis: LEAF_AXIS,
            second: 0,
        };
        // Only resized: the build writes every node, leaf and box.
        self.nodes.resize(n_nodes, empty_node);
        self.leaves.resize(n_leaves, PADDED_LEAF);
        self.boxes.resize(n_leaves, LeafBox::EMPTY);
        if points.is_empty() {
            return;
        }
        let cell = bounding_cell(points);
        build_in_place(
            &mut self.items,
            cell,
            Placement {
                nodes: &mut self.nodes,
                first_node: 0,
                leaves: &mut self.leaves,
                boxes: &mut self.boxes,
                first_leaf: 0,
            },
        );
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Fills `nearest` with the points nearest to `q` within squared distance `r2` (as many
    /// as its capacity), in no particular order.
    pub fn nearest_within(&self, q: [f32; 3], r2: f32, nearest: &mut NearestFew) {
        nearest.clear();
        if self.nodes.is_empty() {
            return;
        }
        // Finite, so that the padding (at infinity) is never within it.
        let r2 = r2.min(f32::MAX);
        let mut pending = std::mem::take(&mut nearest.pending);
        pending.clear();
        pending.push(Pending {
            node: 0,
            floor: 0.0,
            offset: [0.0; 3],
        });
        while let Some(Pending {
            node: mut n,
            floor,
            offset,
        }) = pending.pop()
        {
            if floor > nearest.bound(r2) {
                continue;
            }
            loop {
                let node = self.nodes[n as usize];
                if node.axis == LEAF_AXIS {
                    let leaf = node.start as usize;
                    if self.boxes[leaf].box_distance2(q) <= nearest.bound(r2) {
                        scan_leaf(&self.leaves[leaf], q, r2, nearest);
                    }
                    break;
                }
                let axis = node.axis as usize;
                let diff = q[axis] - node.split;
                let (near, far) = if diff < 0.0 {
                    (n + 1, node.second)
                } else {
                    (node.second, n + 1)
                };
                let far_floor = floor - offset[axis] * offset[axis] + diff * diff;
                if far_floor <= nearest.bound(r2) {
                    let mut far_offset = offset;
                    far_offset[axis] = diff;
                    pending.push(Pending {
                        node: far,
                        floor: far_floor,
                        offset: far_offset,
                    });
                }
                // The near child's cell is on the query's side: same floor.
                n = near;
            }
        }
        nearest.pending = pending;
    }
}

/// Offers a leaf's points within the current bound.
#[inline]
fn scan_leaf(leaf: &LeafBlock, q: [f32; 3], r2: f32, nearest: &mut NearestFew) {
    let mut d2 = [0f32; LEAF];
    let mut below = leaf_distances(leaf, q, nearest.bound(r2), &mut d2);
    while below != 0 {
        let i = below.trailing_zeros() as usize;
        below &= below - 1;
        // Once the list fills, `offer` itself turns away what is no longer near enough.
        nearest.offer(d2[i], leaf.id[i]);
    }
}

/// The squared distances from `q` to a leaf's points, and the bit mask of those within
/// `bound`. Not inlined: on its own it compiles to whole vector operations (four lanes at a
/// time), inlined into the search it was split into odd pieces.
#[inline(never)]
fn leaf_distances(leaf: &LeafBlock, q: [f32; 3], bound: f32, d2: &mut [f32; LEAF]) -> u32 {
    for (i, d) in d2.iter_mut().enumerate() {
        let (dx, dy, dz) = (leaf.x[i] - q[0], leaf.y[i] - q[1], leaf.z[i] - q[2]);
        *d = dx * dx + dy * dy + dz * dz;
    }
    let mut below = 0u32;
    for (i, &d) in d2.iter().enumerate() {
        below |= ((d <= bound) as u32) << i;
    }
    below
}

/// A cell of the tree: its low and high corners.
type Cell = ([f32; 3], [f32; 3]);

/// The smallest cell holding `points`.
fn bounding_cell(points: &[[f32; 3]]) -> Cell {
    let mut cell = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in points {
        for a in 0..3 {
            cell.0[a] = cell.0[a].min(p[a]);
            cell.1[a] = cell.1[a].max(p[a]);
        }
    }
    cell
}

/// Subtrees of at least this many points build their two halves on two threads.
const PARALLEL_BUILD: usize = 4096;

/// A leaf with no point: every slot at infinity.
const PADDED_LEAF: LeafBlock = LeafBlock {
    x: [f32::INFINITY; LEAF],
    y: [f32::INFINITY; LEAF],
    z: [f32::INFINITY; LEAF],
    id: [u32::MAX; LEAF],
};

/// Where a subtree goes: its nodes (the first is its root, at index `first_node` of the
/// tree), its leaves and their boxes (the first at `first_leaf`). A subtree of `m` points
/// has `m.div_ceil(LEAF)` leaves and one node fewer than twice as many, so that the halves
/// of a cell know their places before they are built, and build side by side.
struct Placement<'a> {
    nodes: &'a mut [Node],
    first_node: usize,
    leaves: &'a mut [LeafBlock],
    boxes: &'a mut [LeafBox],
    first_leaf: usize,
}

/// Builds the subtree of `items` (reordered in place) in `cell` into `place`, depth first
/// (an inner node's first child follows it): splits the cell's widest side near the median,
/// at a multiple of [`LEAF`] so that every leaf but the last is full. The halves of a large
/// cell build on two threads.
fn build_in_place(items: &mut [([f32; 3], u32)], cell: Cell, place: Placement) {
    let Placement {
        nodes,
        first_node,
        leaves,
        boxes,
        first_leaf,
    } = place;
    if items.len() <= LEAF {
        let (leaf, bounds) = (&mut leaves[0], &mut boxes[0]);
        *leaf = PADDED_LEAF;
        *bounds = LeafBox::EMPTY;
        for (i, (p, id)) in items.iter().enumerate() {
            (leaf.x[i], leaf.y[i], leaf.z[i], leaf.id[i]) = (p[0], p[1], p[2], *id);
            bounds.extend(*p);
        }
        nodes[0] = Node {
            start: first_leaf as u32,
            split: 0.0,
            axis: LEAF_AXIS,
            second: 0,
        };
        return;
    }
    let (node, mid, (left_cell, right_cell)) = split_cell(items, cell);
    let in_parallel = items.len() >= PARALLEL_BUILD;
    let left_leaves = mid / LEAF;
    let left_nodes = 2 * left_leaves - 1;
    let (root, below) = nodes.split_first_mut().expect("a node per subtree");
    *root = Node {
        second: (first_node + 1 + left_nodes) as u32,
        ..node
    };
    let (left_node_slots, right_node_slots) = below.split_at_mut(left_nodes);
    let (left_leaf_slots, right_leaf_slots) = leaves.split_at_mut(left_leaves);
    let (left_box_slots, right_box_slots) = boxes.split_at_mut(left_leaves);
    let (left_items, right_items) = items.split_at_mut(mid);
    let left = Placement {
        nodes: left_node_slots,
        first_node: first_node + 1,
        leaves: left_leaf_slots,
        boxes: left_box_slots,
        first_leaf,
    };
    let right = Placement {
        nodes: right_node_slots,
        first_node: first_node + 1 + left_nodes,
        leaves: right_leaf_slots,
        boxes: right_box_slots,
        first_leaf: first_leaf + left_leaves,
    };
    if in_parallel {
        rayon::join(
            || build_in_place(left_items, left_cell, left),
            || build_in_place(right_items, right_cell, right),
        );
    } else {
        build_in_place(left_items, left_cell, left);
        build_in_place(right_items, right_cell, right);
    }
}

/// Splits a cell of more than [`LEAF`] items: the widest side near the median, at a multiple
/// of [`LEAF`] so that every leaf but the last is full. Returns the inner node (without its
/// second child), where `items` (reordered) splits, and the two cells.
fn split_cell(items: &mut [([f32; 3], u32)], cell: Cell) -> (Node, usize, (Cell, Cell)) {
    let (low, high) = cell;
    let axis = (0..3)
        .max_by(|&a, &b| (high[a] - low[a]).total_cmp(&(high[b] - low[b])))
        .unwrap_or(0);
    let mid = (items.len().div_ceil(LEAF) / 2) * LEAF;
    items.select_nth_unstable_by(mid, |x, y| x.0[axis].total_cmp(&y.0[axis]));
    let split = items[mid].0[axis];
    let (mut left_high, mut right_low) = (high, low);
    left_high[axis] = split;
    right_low[axis] = split;
    let node = Node {
        start: 0,
        split,
        axis: axis as u32,
        second: 0,
    };
    (node, mid, ((low, left_high), (right_low, high)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A tree rebuilt over the buffers of a larger one, or built on one thread, is the tree
    /// built afresh: the same nodes and leaves, every leaf full but the last.
    #[test]
    fn rebuilt_in_place_is_the_tree_built_afresh() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(8);
        let mut cloud = |n: usize| -> Vec<[f32; 3]> {
            (0..n)
                .map(|_| {
                    [
                        rng.random::<f32>(),
                        rng.random::<f32>(),
                        rng.random::<f32>(),
                    ]
                })
                .collect()
        };
        let (points, other) = (cloud(20_000), cloud(31_000));
        let ids: Vec<u32> = (0..points.len() as u32).collect();
        let other_ids: Vec<u32> = (0..other.len() as u32).collect();
        let fresh = NearTree::new(&points, &ids);
        let mut reused = NearTree::new(&other, &other_ids);
        reused.rebuild(&points, &ids);
        let one_thread = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("pool")
            .install(|| NearTree::new(&points, &ids));
        for tree in [&reused, &one_thread] {
            assert_eq!(tree.len(), fresh.len());
            assert_eq!(tree.nodes.len(), fresh.nodes.len());
            for (a, b) in tree.nodes.iter().zip(&fresh.nodes) {
                assert_eq!(
                    (a.start, a.split, a.axis, a.second),
                    (b.start, b.split, b.axis, b.second)
                );
            }
            assert_eq!(tree.leaves.len(), fresh.leaves.len());
            for (a, b) in tree.leaves.iter().zip(&fresh.leaves) {
                assert_eq!(a.id, b.id);
            }
        }
        let last = fresh.leaves.len() - 1;
        for leaf in &fresh.leaves[..last] {
            assert!(leaf.id.iter().all(|&id| id != u32::MAX));
        }
        assert_eq!(fresh.nodes.len(), 2 * fresh.leaves.len() - 1);
    }

    #[test]
    fn nearest_within_matches_brute_force() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        for n in [0usize, 1, 7, 9, 100, 2000, 9000] {
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
            for (k, r) in [
                (12usize, 0.15f32),
                (1, 1.0),
                (64, 0.3),
                (12, 0.01),
                (5, f32::INFINITY),
            ] {
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
                    let mut got: Vec<f32> = found.distances2().to_vec();
                    got.sort_by(f32::total_cmp);
                    let want: Vec<f32> = brute.iter().map(|x| x.0).collect();
                    assert_eq!(got, want, "n {n} k {k} r {r}");
                    let farthest = want.last().copied().unwrap_or(0.0);
                    assert_eq!(found.farthest_distance2(), farthest);
                    for (&d2, &id) in found.distances2().iter().zip(found.ids()) {
                        let p = points[((id - 1) / 3) as usize];
                        let e = (0..3).map(|a| (p[a] - q[a]).powi(2)).sum::<f32>();
                        assert_eq!(e, d2);
                    }
                }
            }
        }
    }
}
