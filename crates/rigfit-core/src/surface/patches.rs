//! Cutting the reference mesh into patches of bounded geodesic radius (Cagniart et al. 2010,
//! section 3.1): geodesic farthest-point sampling over the mesh's edge graph, each vertex
//! joining its geodesically nearest seed. Patches never cross connected components, so several
//! objects in one scene each get their own patches.

use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};

use crate::math::Point3;

/// The vertex graph of a mesh: edges of its triangles, weighted by length, plus zero-length
/// links between coincident vertices (UV seams split vertices that are one point).
#[derive(Clone, Debug)]
pub struct VertexGraph {
    /// CSR offsets into `adjacent` / `length`, one row per vertex.
    pub start: Vec<u32>,
    pub adjacent: Vec<u32>,
    pub length: Vec<f64>,
}

impl VertexGraph {
    /// Builds the graph; vertices closer than `weld_tolerance` are linked when each is on an
    /// open edge or in no triangle.
    pub fn new(vertices: &[Point3], triangles: &[[u32; 3]], weld_tolerance: f64) -> Self {
        let mut edges: Vec<(u32, u32)> = Vec::with_capacity(triangles.len() * 6);
        for t in triangles {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                if a != b {
                    edges.push((a, b));
                    edges.push((b, a));
                }
            }
        }
        // Coincident vertices: same cell of a grid of `weld_tolerance`. Only vertices on an
        // open edge (a seam splits a surface into pieces with open borders) or in no
        // triangle are welded: two closed pieces that touch at a vertex (a robot's two
        // capsules side by side) stay two pieces.
        if weld_tolerance > 0.0 {
            let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
            for &(a, b) in &edges {
                if a < b {
                    *uses.entry((a, b)).or_insert(0) += 1;
                }
            }
            let mut weldable = vec![true; vertices.len()];
            for t in triangles {
                for &v in t {
                    weldable[v as usize] = false;
                }
            }
            for (&(a, b), &n) in &uses {
                if n == 1 {
                    weldable[a as usize] = true;
                    weldable[b as usize] = true;
                }
            }
            let mut cells: HashMap<[i64; 3], u32> = HashMap::new();
            for (i, p) in vertices.iter().enumerate() {
                if !weldable[i] {
                    continue;
                }
                let key = [0, 1, 2].map(|a| (p[a] / weld_tolerance).round() as i64);
                match cells.get(&key) {
                    Some(&first) => {
                        edges.push((first, i as u32));
                        edges.push((i as u32, first));
                    }
                    None => {
                        cells.insert(key, i as u32);
                    }
                }
            }
        }
        edges.sort_unstable();
        edges.dedup();
        let mut start = vec![0u32; vertices.len() + 1];
        for &(a, _) in &edges {
            start[a as usize + 1] += 1;
        }
        for i in 0..vertices.len() {
            start[i + 1] += start[i];
        }
        let adjacent: Vec<u32> = edges.iter().map(|&(_, b)| b).collect();
        let length = edges
            .iter()
            .map(|&(a, b)| (vertices[a as usize] - vertices[b as usize]).norm())
            .collect();
        Self {
            start,
            adjacent,
            length,
        }
    }

    /// The neighbours of `v` and the lengths of the links to them.
    pub fn neighbours(&self, v: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let (a, b) = (self.start[v] as usize, self.start[v + 1] as usize);
        self.adjacent[a..b]
            .iter()
            .zip(&self.length[a..b])
            .map(|(&n, &l)| (n as usize, l))
    }

    pub fn vertex_count(&self) -> usize {
        self.start.len() - 1
    }

    /// True when `v` has at least one link.
    pub fn is_linked(&self, v: usize) -> bool {
        self.start[v + 1] > self.start[v]
    }
}

/// A min-heap entry for Dijkstra.
#[derive(Clone, Copy, PartialEq)]
struct Frontier {
    distance: f64,
    vertex: usize,
}

impl Eq for Frontier {}

impl Ord for Frontier {
    fn cmp(&self, other: &Self) -> Ordering {
        other.distance.total_cmp(&self.distance)
    }
}

impl PartialOrd for Frontier {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// The result of the partition.
#[derive(Clone, Debug)]
pub struct Partition {
    /// The patch of each vertex.
    pub vertex_patch: Vec<u32>,
    /// The seed vertex of each patch.
    pub seeds: Vec<u32>,
    /// Geodesic distance of each vertex to its patch's seed.
    pub distance: Vec<f64>,
}

/// Geodesic farthest-point sampling: seeds are added at the vertex farthest (along the graph)
/// from every seed so far until every linked vertex is within `radius` of one; each vertex
/// joins its nearest seed. Every connected component gets at least one seed. Vertices with
/// no link (in no triangle) are left to the caller (`u32::MAX`).
pub fn farthest_point_partition(graph: &VertexGraph, radius: f64) -> Partition {
    let n = graph.vertex_count();
    let mut distance = vec![f64::INFINITY; n];
    let mut vertex_patch = vec![u32::MAX; n];
    let mut seeds = Vec::new();
    let mut heap = BinaryHeap::new();
    loop {
        // The farthest linked vertex; an unreached one (a new component) first.
        let mut far = None;
        let mut far_distance = radius;
        for v in 0..n {
            if graph.is_linked(v) && distance[v] > far_distance {
                far_distance = distance[v];
                far = Some(v);
                if far_distance == f64::INFINITY {
                    break;
                }
            }
        }
        let Some(seed) = far else { break };
        let patch = seeds.len() as u32;
        seeds.push(seed as u32);
        distance[seed] = 0.0;
        vertex_patch[seed] = patch;
        heap.push(Frontier {
            distance: 0.0,
            vertex: seed,
        });
        // Dijkstra from the new seed, only where it is closer than the seeds before it.
        while let Some(Frontier {
            distance: d,
            vertex,
        }) = heap.pop()
        {
            if d > distance[vertex] {
                continue;
            }
            for (next, length) in graph.neighbours(vertex) {
                let nd = d + length;
                if nd < distance[next] {
                    distance[next] = nd;
                    vertex_patch[next] = patch;
                    heap.push(Frontier {
                        distance: nd,
                        vertex: next,
                    });
                }
            }
        }
    }
    Partition {
        vertex_patch,
        seeds,
        distance,
    }
}

/// Connected components of the graph (a label per vertex).
pub fn connected_components(graph: &VertexGraph) -> Vec<u32> {
    let n = graph.vertex_count();
    let mut label = vec![u32::MAX; n];
    let mut stack = Vec::new();
    let mut next = 0;
    for s in 0..n {
        if label[s] != u32::MAX {
            continue;
        }
        label[s] = next;
        stack.push(s);
        while let Some(v) = stack.pop() {
            for (w, _) in graph.neighbours(v) {
                if label[w] == u32::MAX {
                    label[w] = next;
                    stack.push(w);
                }
            }
        }
        next += 1;
    }
    label
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat grid of `n` x `n` vertices with spacing 1.
    pub(crate) fn grid(n: usize) -> (Vec<Point3>, Vec<[u32; 3]>) {
        let mut v = Vec::new();
        for j in 0..n {
            for i in 0..n {
                v.push(Point3::new(i as f64, j as f64, 0.0));
            }
        }
        let mut t = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let a = (j * n + i) as u32;
                t.push([a, a + 1, a + n as u32 + 1]);
                t.push([a, a + n as u32 + 1, a + n as u32]);
            }
        }
        (v, t)
    }

    #[test]
    fn every_vertex_is_within_the_radius_of_its_seed() {
        let (v, t) = grid(20);
        let graph = VertexGraph::new(&v, &t, 1e-9);
        let p = farthest_point_partition(&graph, 4.0);
        assert!(p.seeds.len() > 4 && p.seeds.len() < 60, "{}", p.seeds.len());
        assert!(p.distance.iter().all(|&d| d <= 4.0));
        assert!(p.vertex_patch.iter().all(|&k| (k as usize) < p.seeds.len()));
    }

    #[test]
    fn components_each_get_a_seed_and_welds_join() {
        let (mut v, mut t) = grid(4);
        let (v2, t2) = grid(4);
        let offset = v.len() as u32;
        v.extend(
            v2.iter()
                .map(|p| p + crate::math::Vector3::new(10.0, 0.0, 0.0)),
        );
        t.extend(t2.iter().map(|f| f.map(|i| i + offset)));
        let graph = VertexGraph::new(&v, &t, 1e-9);
        let comp = connected_components(&graph);
        assert_eq!(comp.iter().max(), Some(&1));
        let p = farthest_point_partition(&graph, 100.0);
        assert_eq!(p.seeds.len(), 2);
        // Two triangles sharing an edge only through duplicated vertices are one component.
        let v = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(1.0, 1.0, 0.0),
        ];
        let graph = VertexGraph::new(&v, &[[0, 1, 2], [3, 5, 4]], 1e-9);
        assert!(connected_components(&graph).iter().all(|&c| c == 0));
        // Two closed tetrahedra touching at one point (two capsules of a robot side by
        // side) stay two pieces: only open borders are welded.
        let tetra = |o: [f64; 3], s: f64| {
            [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ]
            .map(|c| Point3::new(o[0] + s * c[0], o[1] + s * c[1], o[2] + s * c[2]))
        };
        let mut v = tetra([0.0; 3], 1.0).to_vec();
        v.extend(tetra([1.0, 0.0, 0.0], 1.0));
        let faces = |o: u32| [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]].map(|f| f.map(|i| i + o));
        let mut t = faces(0).to_vec();
        t.extend(faces(4));
        let graph = VertexGraph::new(&v, &t, 1e-9);
        let comp = connected_components(&graph);
        assert_eq!(comp[0], comp[1]);
        assert_ne!(
            comp[1], comp[4],
            "vertex 1 and vertex 4 coincide but are not welded"
        );
    }
}
