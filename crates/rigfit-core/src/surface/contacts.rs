//! Objects made of parts (rigfit's addition to Cagniart et al. 2010): a reference whose mesh
//! is several disconnected pieces (robot links, props, a character split into meshes).
//! Patches never cross or blend across pieces, so a piece has no rigidity term (eq. 4)
//! with the rest and drifts on whatever points it gets. Pieces that touch or nearly touch
//! are linked instead: each piece hangs from the nearest piece larger than itself (no link
//! longer than the largest gap), so that a link joins a part to the one it is mounted on
//! rather than to whatever happens to pass near it, and the links form a forest; groups
//! that rule leaves apart though they touch (a piece whose neighbours are all smaller) are
//! joined along their nearest gaps. A link is a
//! rigidity term over the vertices at the contact, each predicted by the patch it belongs
//! to and by the patch of its nearest vertex across the gap: the two pieces may turn about
//! the contact (a joint) but not come apart.

use std::collections::HashMap;

use crate::engine::spatial::PointTree;
use crate::geometry::Aabb;
use crate::math::Point3;

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

/// The representative of `a`'s group in a union-find forest (halving the path).
fn root(group: &mut [usize], mut a: usize) -> usize {
    while group[a] != a {
        group[a] = group[group[a]];
        a = group[a];
    }
    a
}

/// The contact links of a reference cut into patches. `component` is each vertex's piece,
/// `vertex_patch` each vertex's patch. Pieces whose gap is at most `largest_gap` may be
/// linked (each to the nearest larger piece, then, with `join_groups`, the groups left
/// apart along their shortest gaps); a vertex is at the contact when
/// it lies within the gap plus `contact_width` of the other piece, and weighs `weight` in
/// the rigidity term.
pub fn contact_links(
    rest: &[Point3],
    component: &[u32],
    vertex_patch: &[u32],
    largest_gap: f64,
    contact_width: f64,
    weight: f64,
    join_groups: bool,
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
    // Each piece hangs from the nearest piece larger than itself (more vertices; ties by
    // index): small parts are mounted on bigger ones, so they are carried by them rather
    // than chained to their peers, and the links form a forest.
    let larger = |a: usize, b: usize| (members[a].len(), a) > (members[b].len(), b);
    let mut mount: Vec<Option<Gap>> = vec![None; pieces];
    for gap in &gaps {
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
    // A piece whose neighbours are all smaller hangs from none (a foot welded into one
    // piece with its twin, touching only two shins), and the groups the mounts leave apart
    // are joined along their nearest gaps, shortest first (Kruskal's rule), the smaller
    // piece hanging from the larger.
    let mut chosen: Vec<Gap> = mount.into_iter().flatten().collect();
    if join_groups {
        let mut group: Vec<usize> = (0..pieces).collect();
        for gap in &chosen {
            let (ra, rb) = (root(&mut group, gap.a), root(&mut group, gap.b));
            group[ra] = rb;
        }
        gaps.sort_by(|x, y| x.distance.total_cmp(&y.distance));
        for gap in gaps {
            let (ra, rb) = (root(&mut group, gap.a), root(&mut group, gap.b));
            if ra != rb {
                group[ra] = rb;
                let (child, parent) = if larger(gap.b, gap.a) {
                    (gap.a, gap.b)
                } else {
                    (gap.b, gap.a)
                };
                chosen.push(Gap {
                    distance: gap.distance,
                    a: child,
                    b: parent,
                });
            }
        }
    }
    let mut by_patches: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    let mut weight_of: HashMap<(u32, u32), f64> = HashMap::new();
    for gap in chosen {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A cube of `n` x `n` x `n` vertices (no faces needed here) with its lower corner at
    /// `at` and side 1.
    fn block(n: usize, at: [f64; 3]) -> Vec<Point3> {
        let mut v = Vec::new();
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    let s = 1.0 / (n - 1) as f64;
                    v.push(Point3::new(
                        at[0] + i as f64 * s,
                        at[1] + j as f64 * s,
                        at[2] + k as f64 * s,
                    ));
                }
            }
        }
        v
    }

    #[test]
    fn a_piece_whose_neighbours_are_all_smaller_is_joined_to_them() {
        // Two large blocks with a small one between them, touching both (the walker's
        // feet, one piece, touch only its two shins): the small block hangs from one large
        // block, and the other hangs from nothing unless the groups are joined.
        let mut rest = block(5, [0.0; 3]);
        rest.extend(block(3, [1.1, 0.0, 0.0]));
        rest.extend(block(5, [2.2, 0.0, 0.0]));
        let component: Vec<u32> = (0..rest.len())
            .map(|v| match v {
                v if v < 125 => 0,
                v if v < 152 => 1,
                _ => 2,
            })
            .collect();
        let pairs = |join| {
            contact_links(&rest, &component, &component, 0.5, 0.05, 1.0, join)
                .iter()
                .map(|l| (l.k, l.l))
                .collect::<Vec<_>>()
        };
        assert_eq!(pairs(false).len(), 1);
        assert_eq!(pairs(true), vec![(0, 1), (1, 2)]);
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
        let links = contact_links(&rest, &component, &component, 0.5, 0.05, 1.0, true);
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
        let links = contact_links(&rest, &component, &component, 0.2, 0.05, 1.0, true);
        assert_eq!(links.len(), 1);
        // One piece: nothing to link.
        assert!(
            contact_links(
                &rest[..count],
                &component[..count],
                &component[..count],
                1.0,
                0.1,
                1.0,
                true
            )
            .is_empty()
        );
    }
}
