//! Objects made of parts (rigfit's addition to Cagniart et al. 2010): a reference whose mesh
//! is several disconnected pieces (robot links, props, a character split into meshes).
//! Patches never cross or blend across pieces, so a piece has no rigidity term (eq. 4)
//! with the rest and drifts on whatever points it gets. Pieces that touch or nearly touch
//! are linked instead, the links a spanning forest chosen by [`LinkRule`]:
//! - an object made of parts links the pieces whose ends meet first: a joint is where the
//!   end of one piece meets another (a shin's top at its thigh), while pieces side by side
//!   (two legs, two fingers) touch along their length and are linked only when nothing
//!   else joins them;
//! - a skinned body with pieces on it (eyes, a jacket) hangs each piece from the nearest
//!   piece larger than itself, so that small parts are carried by the body rather than
//!   chained to their peers.
//!
//! A link is a rigidity term over the vertices at the contact, each predicted by the patch
//! it belongs to and by the patch of its nearest vertex across the gap: the two pieces may
//! turn about the contact (a joint) but not come apart.

use std::collections::HashMap;

use crate::engine::spatial::PointTree;
use crate::geometry::Aabb;
use crate::math::{Matrix3, Point3, Vector3};

/// A rigidity link between patches `k < l` of two pieces that touch: the vertices at the
/// contact, whose predictions by `k` and by `l` the rigidity term keeps together.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactLink {
    pub k: u32,
    pub l: u32,
    pub vertices: Vec<u32>,
    /// The rigidity weight of each vertex.
    pub weight: f64,
}

/// Where two pieces come closest: the gap and the pieces.
#[derive(Clone, Copy, Debug)]
struct Gap {
    distance: f64,
    a: usize,
    b: usize,
}

/// A piece more than this share of the reference's diagonal across is a skin, not a part
/// (the skinned characters' bodies span 0.99 of it, the many-part corpus's robot and
/// creature parts at most 0.66).
pub const SKIN_SPAN: f64 = 0.75;

/// Which pieces are linked ([`contact_links`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkRule {
    /// Kruskal's rule over every gap, the pieces whose ends meet first: a piece's end (the
    /// mean of its vertices at either end of its longest axis) on the other piece's surface
    /// or inside it, then nearest (centroids apart, in their extents). Pieces side by side
    /// are linked only when no chain of joints holds them together.
    EndsMeeting,
    /// Each piece hangs from the nearest piece larger than itself (more vertices, ties by
    /// index); the groups that leaves apart are joined along their nearest gaps.
    NearestLarger,
}

impl LinkRule {
    /// The rule for pieces within `bounds`: the nearest larger piece when one of them spans
    /// most of the whole ([`SKIN_SPAN`]: a skinned body carrying its pieces), else the ends
    /// meeting (an object made of parts).
    fn for_pieces(bounds: &[Option<Aabb>]) -> Self {
        let corners = bounds.iter().flatten().flat_map(|b| [&b.min, &b.max]);
        let diagonal = Aabb::from_points(corners).map_or(0.0, |b| b.diagonal());
        if bounds
            .iter()
            .flatten()
            .any(|b| b.diagonal() > SKIN_SPAN * diagonal)
        {
            LinkRule::NearestLarger
        } else {
            LinkRule::EndsMeeting
        }
    }
}

/// The representative of `a`'s group in a union-find forest (halving the path).
fn root(group: &mut [usize], mut a: usize) -> usize {
    while group[a] != a {
        group[a] = group[group[a]];
        a = group[a];
    }
    a
}

/// The contact links of a reference cut into patches. `component` is each vertex's piece,
/// `vertex_patch` each vertex's patch, `normals` each vertex's outward normal. Pieces whose
/// gap is at most `largest_gap` may be linked, as `rule` chooses (`None`: as the pieces
/// are, [`SKIN_SPAN`]); a vertex is at the contact when it lies within the gap plus
/// `contact_width` of the other piece, and weighs `weight` in the rigidity term.
#[allow(clippy::too_many_arguments)]
pub fn contact_links(
    rest: &[Point3],
    normals: &[Vector3],
    component: &[u32],
    vertex_patch: &[u32],
    largest_gap: f64,
    contact_width: f64,
    weight: f64,
    rule: Option<LinkRule>,
) -> Vec<ContactLink> {
    let pieces = component.iter().map(|&c| c as usize + 1).max().unwrap_or(0);
    if pieces < 2 {
        return Vec::new();
    }
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); pieces];
    for (v, &c) in component.iter().enumerate() {
        members[c as usize].push(v as u32);
    }
    let bounds: Vec<Option<Aabb>> = members
        .iter()
        .map(|m| Aabb::from_points(&m.iter().map(|&v| rest[v as usize]).collect::<Vec<_>>()))
        .collect();
    let trees: Vec<PointTree> = members
        .iter()
        .map(|m| {
            let coords: Vec<[f64; 3]> = m.iter().map(|&v| rest[v as usize].coords.into()).collect();
            PointTree::new(&coords)
        })
        .collect();
    // The nearest vertex of piece `b` to `p`, and its squared distance.
    let nearest_in = |b: usize, p: &Point3| -> (u32, f64) {
        let i = trees[b].nearest(p);
        let w = members[b][i];
        (w, (rest[w as usize] - p).norm_squared())
    };
    // Candidate pairs: pieces whose boxes, widened by the largest gap, overlap.
    let mut gaps = Vec::new();
    for a in 0..pieces {
        let Some(box_a) = &bounds[a] else { continue };
        for b in a + 1..pieces {
            let Some(box_b) = &bounds[b] else { continue };
            let apart = (0..3).any(|i| {
                box_a.min[i] > box_b.max[i] + largest_gap
                    || box_b.min[i] > box_a.max[i] + largest_gap
            });
            if apart {
                continue;
            }
            // The smaller piece's vertices against the larger's tree.
            let (small, large) = if members[a].len() <= members[b].len() {
                (a, b)
            } else {
                (b, a)
            };
            let distance = members[small]
                .iter()
                .map(|&v| nearest_in(large, &rest[v as usize]).1)
                .fold(f64::INFINITY, f64::min)
                .sqrt();
            if distance <= largest_gap {
                gaps.push(Gap { distance, a, b });
            }
        }
    }
    let larger = |a: usize, b: usize| (members[a].len(), a) > (members[b].len(), b);
    let linked = match rule.unwrap_or_else(|| LinkRule::for_pieces(&bounds)) {
        LinkRule::NearestLarger => nearest_larger(&gaps, pieces, &larger),
        LinkRule::EndsMeeting => {
            let shapes: Vec<PieceShape> = members
                .iter()
                .zip(&bounds)
                .map(|(m, b)| PieceShape::new(rest, m, b.map_or(0.0, |b| b.diagonal())))
                .collect();
            let end_distance = |from: usize, to: usize| -> f64 {
                shapes[from].ends_to(to, &nearest_in, rest, normals)
            };
            // By how far the nearer end lies from the other piece, then by how far apart
            // the two are.
            let mut scored: Vec<(f64, f64, Gap)> = gaps
                .iter()
                .map(|g| {
                    let (a, b) = (&shapes[g.a], &shapes[g.b]);
                    let apart = (a.centroid - b.centroid).norm()
                        / (a.extent + b.extent).max(f64::MIN_POSITIVE);
                    let ends = end_distance(g.a, g.b).min(end_distance(g.b, g.a));
                    (ends, apart, *g)
                })
                .collect();
            scored.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.total_cmp(&y.1)));
            spanning_forest(scored.into_iter().map(|(_, _, g)| g), pieces, &larger)
        }
    };
    let mut by_patches: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    let mut weight_of: HashMap<(u32, u32), f64> = HashMap::new();
    for gap in linked {
        let reach = gap.distance + contact_width;
        // A piece with many patches carries itself on its data; a small one is carried.
        let patches = {
            let mut p: Vec<u32> = members[gap.a]
                .iter()
                .map(|&v| vertex_patch[v as usize])
                .collect();
            p.sort_unstable();
            p.dedup();
            p.len().max(1)
        };
        for (from, to) in [(gap.a, gap.b), (gap.b, gap.a)] {
            for &v in &members[from] {
                let (w, d2) = nearest_in(to, &rest[v as usize]);
                if d2 <= reach * reach {
                    let (k, l) = (vertex_patch[v as usize], vertex_patch[w as usize]);
                    let key = (k.min(l), k.max(l));
                    by_patches.entry(key).or_default().push(v);
                    weight_of.insert(key, weight / patches as f64);
                }
            }
        }
    }
    let mut links: Vec<ContactLink> = by_patches
        .into_iter()
        .map(|((k, l), mut vertices)| {
            vertices.sort_unstable();
            vertices.dedup();
            ContactLink {
                k,
                l,
                vertices,
                weight: weight_of[&(k, l)],
            }
        })
        .collect();
    links.sort_by_key(|link| (link.k, link.l));
    links
}

/// Each piece hangs from the nearest piece `larger` than itself; the groups that leaves
/// apart (a piece whose neighbours are all smaller: a foot welded into one piece with its
/// twin, touching only two shins) are joined along their nearest gaps, shortest first.
/// Each link is returned as a gap from the child (`a`) to the piece it hangs from (`b`).
fn nearest_larger(gaps: &[Gap], pieces: usize, larger: &impl Fn(usize, usize) -> bool) -> Vec<Gap> {
    let mut mount: Vec<Option<Gap>> = vec![None; pieces];
    for gap in gaps {
        for (child, parent) in [(gap.a, gap.b), (gap.b, gap.a)] {
            if larger(parent, child) && mount[child].is_none_or(|m| gap.distance < m.distance) {
                mount[child] = Some(Gap {
                    distance: gap.distance,
                    a: child,
                    b: parent,
                });
            }
        }
    }
    // The mounts form a forest (each piece hangs from a larger one); the gaps after them
    // only join the groups they leave apart.
    let mut by_distance = gaps.to_vec();
    by_distance.sort_by(|x, y| x.distance.total_cmp(&y.distance));
    spanning_forest(
        mount.into_iter().flatten().chain(by_distance),
        pieces,
        larger,
    )
}

/// Kruskal's rule: the gaps in the order given, each kept when it joins two groups, as a
/// link from the smaller piece (`a`) to the `larger` one (`b`).
fn spanning_forest(
    gaps: impl IntoIterator<Item = Gap>,
    pieces: usize,
    larger: &impl Fn(usize, usize) -> bool,
) -> Vec<Gap> {
    let mut group: Vec<usize> = (0..pieces).collect();
    let mut kept = Vec::new();
    for gap in gaps {
        let (ra, rb) = (root(&mut group, gap.a), root(&mut group, gap.b));
        if ra == rb {
            continue;
        }
        group[ra] = rb;
        let (child, parent) = if larger(gap.b, gap.a) {
            (gap.a, gap.b)
        } else {
            (gap.b, gap.a)
        };
        kept.push(Gap {
            distance: gap.distance,
            a: child,
            b: parent,
        });
    }
    kept
}

/// A piece's centroid, extent (its bounding box's diagonal) and two ends: the mean of its
/// vertices within a fiftieth of the extent of the farthest along its longest axis, either
/// way (for a capsule, the tips of its caps).
struct PieceShape {
    centroid: Vector3,
    extent: f64,
    ends: [Point3; 2],
}

impl PieceShape {
    /// The shape of the piece of vertices `members`, `extent` across.
    fn new(rest: &[Point3], members: &[u32], extent: f64) -> Self {
        let at = |v: u32| rest[v as usize].coords;
        let count = members.len().max(1) as f64;
        let centroid = members.iter().fold(Vector3::zeros(), |s, &v| s + at(v)) / count;
        let mut covariance = Matrix3::zeros();
        for &v in members {
            let d = at(v) - centroid;
            covariance += d * d.transpose();
        }
        let eigen = covariance.symmetric_eigen();
        let axis: Vector3 = eigen
            .eigenvectors
            .column(eigen.eigenvalues.imax())
            .into_owned();
        let along: Vec<f64> = members
            .iter()
            .map(|&v| (at(v) - centroid).dot(&axis))
            .collect();
        let (first, last) = along
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &t| {
                (lo.min(t), hi.max(t))
            });
        let band = 0.02 * extent;
        let end = |near: &dyn Fn(f64) -> bool| {
            let (sum, n) = members
                .iter()
                .zip(&along)
                .filter(|&(_, &t)| near(t))
                .fold((Vector3::zeros(), 0usize), |(s, n), (&v, _)| {
                    (s + at(v), n + 1)
                });
            Point3::from(if n == 0 { centroid } else { sum / n as f64 })
        };
        Self {
            centroid,
            extent,
            ends: [end(&|t| t >= last - band), end(&|t| t <= first + band)],
        }
    }

    /// How far this piece's nearer end lies from piece `other`'s surface, in this piece's
    /// extents: zero when the end is inside it (behind its nearest vertex's normal, as the
    /// links of a tail's overlapping vertebrae are). `nearest_in(other, p)` is `other`'s
    /// nearest vertex to `p` and its squared distance.
    fn ends_to(
        &self,
        other: usize,
        nearest_in: &impl Fn(usize, &Point3) -> (u32, f64),
        rest: &[Point3],
        normals: &[Vector3],
    ) -> f64 {
        self.ends
            .iter()
            .map(|end| {
                let (w, squared) = nearest_in(other, end);
                let inside = normals
                    .get(w as usize)
                    .is_some_and(|n| (end - rest[w as usize]).dot(n) < 0.0);
                if inside { 0.0 } else { squared.sqrt() }
            })
            .fold(f64::INFINITY, f64::min)
            / self.extent.max(f64::MIN_POSITIVE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cube of `n` x `n` x `n` vertices (no faces needed here) with its lower corner at
    /// `at` and side 1.
    fn block(n: usize, at: [f64; 3]) -> Vec<Point3> {
        cuboid([n; 3], at, [1.0; 3])
    }

    /// A grid of `n[0]` x `n[1]` x `n[2]` vertices filling the box from `at` of sides `size`.
    fn cuboid(n: [usize; 3], at: [f64; 3], size: [f64; 3]) -> Vec<Point3> {
        let mut v = Vec::new();
        let step = |a: usize| size[a] / (n[a] - 1) as f64;
        for i in 0..n[0] {
            for j in 0..n[1] {
                for k in 0..n[2] {
                    v.push(Point3::new(
                        at[0] + i as f64 * step(0),
                        at[1] + j as f64 * step(1),
                        at[2] + k as f64 * step(2),
                    ));
                }
            }
        }
        v
    }

    /// Each vertex's piece, for pieces of `counts` vertices in order.
    fn pieces_of(counts: &[usize]) -> Vec<u32> {
        counts
            .iter()
            .enumerate()
            .flat_map(|(p, &n)| std::iter::repeat_n(p as u32, n))
            .collect()
    }

    /// The linked pairs of pieces (one patch per piece), in order.
    fn linked(
        rest: &[Point3],
        component: &[u32],
        gap: f64,
        rule: Option<LinkRule>,
    ) -> Vec<(u32, u32)> {
        contact_links(rest, &[], component, component, gap, 0.05, 1.0, rule)
            .iter()
            .map(|l| (l.k, l.l))
            .collect()
    }

    #[test]
    fn a_piece_whose_neighbours_are_all_smaller_is_joined_to_them() {
        // Two large blocks with a small one between them, touching both (the walker's
        // feet, one piece, touch only its two shins): the small block hangs from one large
        // block, and the other large block is joined to it along the nearest gap.
        let mut rest = block(5, [0.0; 3]);
        rest.extend(block(3, [1.1, 0.0, 0.0]));
        rest.extend(block(5, [2.2, 0.0, 0.0]));
        let component = pieces_of(&[125, 27, 125]);
        let nearest_larger = Some(LinkRule::NearestLarger);
        assert_eq!(
            linked(&rest, &component, 0.5, nearest_larger),
            vec![(0, 1), (1, 2)]
        );
    }

    #[test]
    fn legs_side_by_side_are_linked_where_their_ends_meet() {
        // A body on two legs, each a thigh over a shin; the legs stand side by side, closer
        // to each other (0.05) than every joint's gap but one (0.08 at the knees, 0.05 at
        // the hips). Every piece has the same number of vertices, as the walker's capsules.
        let leg = [3, 3, 9];
        let size = [0.4, 0.4, 1.5];
        let mut rest = cuboid([5, 3, 3], [0.0, 0.0, 1.55], [0.85, 0.4, 0.5]);
        rest.extend(cuboid(leg, [0.0, 0.0, 0.0], size)); // 1: left thigh
        rest.extend(cuboid(leg, [0.45, 0.0, 0.0], size)); // 2: right thigh
        rest.extend(cuboid(leg, [0.0, 0.0, -1.58], size)); // 3: left shin
        rest.extend(cuboid(leg, [0.45, 0.0, -1.58], size)); // 4: right shin
        let component = pieces_of(&[45, 81, 81, 81, 81]);
        // The ends meeting: the body holds both thighs, each thigh its own shin.
        assert_eq!(
            linked(&rest, &component, 0.2, None),
            vec![(0, 1), (0, 2), (1, 3), (2, 4)]
        );
        // Hung from the nearest larger piece (by vertex count, then index), the thighs
        // hang from each other and so do the shins: the walker's defect.
        assert_eq!(
            linked(&rest, &component, 0.2, Some(LinkRule::NearestLarger)),
            vec![(0, 1), (1, 2), (2, 4), (3, 4)]
        );
    }

    #[test]
    fn a_body_across_the_reference_carries_its_pieces() {
        // A long body and two small blocks on it, touching each other: with a skin among
        // the pieces, each small piece hangs from the body (nearest larger), not from its
        // peer.
        let mut rest = cuboid([9, 3, 3], [0.0, 0.0, 0.0], [8.0, 1.0, 1.0]);
        rest.extend(cuboid([3, 3, 3], [3.0, 0.0, 1.05], [0.5, 0.5, 0.5]));
        rest.extend(cuboid([3, 3, 3], [3.56, 0.0, 1.05], [0.5, 0.5, 0.5]));
        let component = pieces_of(&[81, 27, 27]);
        assert_eq!(linked(&rest, &component, 0.2, None), vec![(0, 1), (0, 2)]);
    }

    #[test]
    fn each_piece_hangs_from_its_nearest_larger_neighbour() {
        // Three blocks in a row, gaps 0.1 and 0.3, and a fourth far away.
        let mut rest = block(5, [0.0; 3]);
        rest.extend(block(5, [1.1, 0.0, 0.0]));
        rest.extend(block(5, [2.4, 0.0, 0.0]));
        rest.extend(block(5, [10.0, 0.0, 0.0]));
        let count = rest.len() / 4;
        let component: Vec<u32> = (0..rest.len()).map(|v| (v / count) as u32).collect();
        // One patch per piece.
        let nearest_larger = Some(LinkRule::NearestLarger);
        let links = contact_links(
            &rest,
            &[],
            &component,
            &component,
            0.5,
            0.05,
            1.0,
            nearest_larger,
        );
        let pairs: Vec<(u32, u32)> = links.iter().map(|l| (l.k, l.l)).collect();
        assert_eq!(pairs, vec![(0, 1), (1, 2)]);
        // The contact is the facing sides: one face of 25 vertices each.
        assert_eq!(links[0].vertices.len(), 50);
        assert!(
            links[0]
                .vertices
                .iter()
                .all(|&v| (0.95..=1.15).contains(&rest[v as usize].x))
        );
        // The far piece and a gap wider than the largest stay unlinked.
        let links = contact_links(
            &rest,
            &[],
            &component,
            &component,
            0.2,
            0.05,
            1.0,
            nearest_larger,
        );
        assert_eq!(links.len(), 1);
        // One piece: nothing to link.
        assert!(
            contact_links(
                &rest[..count],
                &[],
                &component[..count],
                &component[..count],
                1.0,
                0.1,
                1.0,
                None
            )
            .is_empty()
        );
    }
}
