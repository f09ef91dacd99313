//! The patch-based deformation model (Cagniart et al. 2010, section 3.1): each patch `k` has a
//! rotation `R_k` and a centre `c_k`; it predicts a position for every vertex (eq. 1); the
//! deformed mesh blends the predictions of a vertex's patch and its neighbours with normalised
//! Gaussian weights (eq. 2); the rigidity energy keeps neighbouring predictions consistent
//! (eq. 4).

use rayon::prelude::*;

use super::SurfaceError;
use super::contacts::{ContactLink, LinkRule, contact_links};
use super::patches::{VertexGraph, connected_components, farthest_point_partition};
use crate::geometry::{Aabb, TriMesh};
use crate::math::{Matrix3, Point3, Vector3};

/// How the reference is cut into patches and how predictions are blended.
#[derive(Clone, Debug)]
pub struct PatchOptions {
    /// Largest geodesic radius of a patch, as a fraction of the reference's bounding-box
    /// diagonal.
    pub radius: f64,
    /// Width of the blending Gaussians, as a fraction of the patch radius.
    pub blend_width: f64,
    /// Pieces of the mesh (connected components) that touch or nearly touch are held
    /// together by contact links (rigfit's addition, [`contact_links`]; the paper leaves
    /// every component on its own).
    pub link_parts: bool,
    /// The widest gap between two pieces that a link may span, as a fraction of the patch
    /// radius.
    pub part_gap: f64,
    /// A vertex is at a contact when it lies within the gap plus this fraction of the patch
    /// radius of the other piece.
    pub contact_width: f64,
    /// Rigidity weight of a contact vertex, against `alpha_k(v) + alpha_l(v)` (at most 1) of
    /// a vertex in a piece's rigidity term.
    pub contact_stiffness: f64,
    /// Which touching pieces are linked ([`contact_links`]): `None` chooses by the
    /// reference (the ends meeting for an object made of parts, the nearest larger piece
    /// for a skinned body with pieces on it).
    pub link_rule: Option<LinkRule>,
}

impl Default for PatchOptions {
    fn default() -> Self {
        Self {
            radius: 0.06,
            blend_width: 0.8,
            link_parts: true,
            part_gap: 1.0,
            contact_width: 0.25,
            contact_stiffness: 1.0,
            link_rule: None,
        }
    }
}

/// The parameters `Theta`: a rotation and a centre per patch.
#[derive(Clone, Debug, PartialEq)]
pub struct PatchPose {
    pub rotation: Vec<Matrix3>,
    pub centre: Vec<Point3>,
}

/// Every blend entry `e = (l, v)` of a pose: `at[e] = x_l(v)` (eq. 1) and `normal[e]`, the
/// reference normal of `v` turned by `R_l`.
#[derive(Clone, Debug, Default)]
pub struct Predictions {
    pub at: Vec<Point3>,
    pub normal: Vec<Vector3>,
}

/// The reference mesh cut into patches, with the blending weights of every vertex.
#[derive(Clone, Debug)]
pub struct PatchModel {
    /// Reference positions `x^0(v)`.
    pub rest: Vec<Point3>,
    /// Reference normals (area-weighted, from the faces).
    pub rest_normals: Vec<Vector3>,
    pub triangles: Vec<[u32; 3]>,
    /// The patch `P_k` each vertex belongs to.
    pub vertex_patch: Vec<u32>,
    /// Vertices of each patch.
    pub members: Vec<Vec<u32>>,
    /// Neighbouring patches `N_k` (sorted, without `k`): joined by an edge, so always of one
    /// piece.
    pub neighbours: Vec<Vec<u32>>,
    /// Rigidity links between patches of pieces that touch (see [`PatchOptions::link_parts`]).
    pub contacts: Vec<ContactLink>,
    /// Reference centre of mass `c_k^0` of each patch.
    pub rest_centre: Vec<Point3>,
    /// Surface area of each patch (its vertices' thirds of their triangles).
    pub area: Vec<f64>,
    /// Connected component (object) of each patch.
    pub component: Vec<u32>,
    /// CSR offsets into `blend_patch` / `blend_weight`, one row per vertex: the patches with a
    /// non-zero weight `alpha_k(v)` (the vertex's own first, then its neighbours).
    pub blend_start: Vec<u32>,
    pub blend_patch: Vec<u32>,
    pub blend_weight: Vec<f64>,
    /// The vertex of each blend entry (the row of the CSR above).
    pub blend_vertex: Vec<u32>,
    /// The reference's edges, coincident vertices welded (the E-step walks it).
    pub graph: VertexGraph,
    /// The reference's bounding-box diagonal.
    pub diagonal: f64,
    /// Mean edge length of the reference.
    pub mean_edge: f64,
}

impl PatchModel {
    /// Cuts `reference` into patches. Needs triangles (for normals, areas and geodesics).
    /// Vertices in no triangle follow the patch of their nearest vertex that is in one.
    /// Non-manifold edges are accepted: the partition only needs the edge graph.
    pub fn new(reference: &TriMesh, options: &PatchOptions) -> Result<Self, SurfaceError> {
        let rest = reference.vertices.clone();
        if rest.is_empty() {
            return Err(SurfaceError::EmptyReference);
        }
        if let Some(i) = rest.iter().position(|p| p.iter().any(|x| !x.is_finite())) {
            return Err(SurfaceError::NonFinite {
                what: "reference vertex",
                index: i,
            });
        }
        if let Some(index) = crate::math::first_out_of_range(&rest) {
            return Err(SurfaceError::OutOfRange {
                what: "reference vertex",
                index,
            });
        }
        if reference.triangles.is_empty() {
            return Err(SurfaceError::NoFaces);
        }
        if let Some(t) = reference
            .triangles
            .iter()
            .position(|t| t.iter().any(|&i| i as usize >= rest.len()))
        {
            return Err(SurfaceError::BadFace { index: t });
        }
        let bounds = Aabb::from_points(&rest).ok_or(SurfaceError::EmptyReference)?;
        let diagonal = bounds.diagonal();
        if diagonal <= 0.0 {
            return Err(SurfaceError::Degenerate);
        }
        let triangles: Vec<[u32; 3]> = reference
            .triangles
            .iter()
            .copied()
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect();
        if triangles.is_empty() {
            return Err(SurfaceError::NoFaces);
        }
        let graph = VertexGraph::new(&rest, &triangles, 1e-7 * diagonal);
        let radius = options.radius * diagonal;
        let partition = farthest_point_partition(&graph, radius);
        let mut vertex_patch = partition.vertex_patch;
        let patch_count = partition.seeds.len();
        if patch_count == 0 {
            return Err(SurfaceError::NoFaces);
        }
        // Vertices in no triangle: the patch of the nearest vertex that has one.
        let linked: Vec<usize> = (0..rest.len()).filter(|&v| graph.is_linked(v)).collect();
        if linked.len() < rest.len() {
            let points: Vec<[f64; 3]> = linked
                .iter()
                .map(|&v| [rest[v].x, rest[v].y, rest[v].z])
                .collect();
            let tree = crate::engine::spatial::PointTree::new(&points);
            for v in 0..rest.len() {
                if vertex_patch[v] == u32::MAX {
                    let nearest = tree.nearest(&rest[v]);
                    vertex_patch[v] = vertex_patch[linked[nearest]];
                }
            }
        }
        let mut members = vec![Vec::new(); patch_count];
        for (v, &k) in vertex_patch.iter().enumerate() {
            members[k as usize].push(v as u32);
        }
        // Neighbours: patches joined by an edge.
        let mut neighbours = vec![Vec::new(); patch_count];
        for v in 0..rest.len() {
            let k = vertex_patch[v];
            for (w, _) in graph.neighbours(v) {
                let l = vertex_patch[w];
                if l != k {
                    neighbours[k as usize].push(l);
                }
            }
        }
        let components = connected_components(&graph);
        let component: Vec<u32> = partition
            .seeds
            .iter()
            .map(|&s| components[s as usize])
            .collect();
        let rest_normals = TriMesh {
            vertices: rest.clone(),
            normals: None,
            triangles: triangles.clone(),
        }
        .vertex_normals_from_faces();
        let contacts = if options.link_parts {
            // A piece per patch: loose vertices go with the patch they follow.
            let vertex_component: Vec<u32> = vertex_patch
                .iter()
                .map(|&k| component[k as usize])
                .collect();
            contact_links(
                &rest,
                &rest_normals,
                &vertex_component,
                &vertex_patch,
                options.part_gap * radius,
                options.contact_width * radius,
                options.contact_stiffness,
                options.link_rule,
            )
        } else {
            Vec::new()
        };
        for n in &mut neighbours {
            n.sort_unstable();
            n.dedup();
        }
        // Vertex areas (a third of each triangle) and normals.
        let mut vertex_area = vec![0.0; rest.len()];
        for t in &triangles {
            let [a, b, c] = t.map(|i| rest[i as usize]);
            let area = 0.5 * (b - a).cross(&(c - a)).norm();
            for &i in t {
                vertex_area[i as usize] += area / 3.0;
            }
        }
        let mut area = vec![0.0; patch_count];
        let mut rest_centre = Vec::with_capacity(patch_count);
        for (k, m) in members.iter().enumerate() {
            let a: f64 = m.iter().map(|&v| vertex_area[v as usize]).sum();
            area[k] = a;
            let centre = if a > 0.0 {
                m.iter()
                    .map(|&v| rest[v as usize].coords * vertex_area[v as usize])
                    .sum::<Vector3>()
                    / a
            } else {
                m.iter().map(|&v| rest[v as usize].coords).sum::<Vector3>() / m.len() as f64
            };
            rest_centre.push(Point3::from(centre));
        }
        // Blending weights alpha_k(v): Gaussians of the distance to c_k^0 over the vertex's
        // patch and its neighbours, normalised (eq. 2).
        let width = options.blend_width * radius;
        let mut blend_start = Vec::with_capacity(rest.len() + 1);
        let mut blend_patch = Vec::new();
        let mut blend_weight = Vec::new();
        let mut blend_vertex = Vec::new();
        blend_start.push(0u32);
        for v in 0..rest.len() {
            let own = vertex_patch[v];
            let first = blend_weight.len();
            for k in std::iter::once(own).chain(neighbours[own as usize].iter().copied()) {
                let d2 = (rest[v] - rest_centre[k as usize]).norm_squared();
                blend_patch.push(k);
                blend_vertex.push(v as u32);
                blend_weight.push((-d2 / (2.0 * width * width)).exp().max(1e-300));
            }
            let total: f64 = blend_weight[first..].iter().sum();
            for w in &mut blend_weight[first..] {
                *w /= total;
            }
            blend_start.push(blend_weight.len() as u32);
        }
        let edge_total: f64 = graph.length.iter().sum();
        let mean_edge = if graph.length.is_empty() {
            radius * 0.1
        } else {
            edge_total / graph.length.len() as f64
        };
        Ok(Self {
            rest,
            rest_normals,
            triangles,
            vertex_patch,
            members,
            neighbours,
            contacts,
            rest_centre,
            area,
            component,
            blend_start,
            blend_patch,
            blend_weight,
            blend_vertex,
            graph,
            diagonal,
            mean_edge: mean_edge.max(1e-12 * diagonal),
        })
    }

    pub fn patch_count(&self) -> usize {
        self.members.len()
    }

    /// How many pieces (connected components) the reference has: one past the largest
    /// `component` (0 with no patch).
    pub fn piece_count(&self) -> usize {
        self.component
            .iter()
            .map(|&c| c as usize + 1)
            .max()
            .unwrap_or(0)
    }

    pub fn vertex_count(&self) -> usize {
        self.rest.len()
    }

    /// The blend entries of vertex `v`: indices into `blend_patch`, `blend_weight` and
    /// `blend_vertex`.
    #[inline]
    pub fn blend_entries(&self, v: usize) -> std::ops::Range<usize> {
        self.blend_start[v] as usize..self.blend_start[v + 1] as usize
    }

    /// The patches blended at `v` and their weights `alpha_k(v)`.
    pub fn blend(&self, v: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let entries = self.blend_entries(v);
        self.blend_patch[entries.clone()]
            .iter()
            .zip(&self.blend_weight[entries])
            .map(|(&k, &w)| (k as usize, w))
    }

    /// The reference itself: every patch at rest.
    pub fn rest_pose(&self) -> PatchPose {
        PatchPose {
            rotation: vec![Matrix3::identity(); self.patch_count()],
            centre: self.rest_centre.clone(),
        }
    }

    /// `R_k (x^0(v) - c_k^0)`: the rotated offset of `v` from patch `k`'s centre.
    #[inline]
    pub fn offset(&self, pose: &PatchPose, k: usize, v: usize) -> Vector3 {
        pose.rotation[k] * (self.rest[v] - self.rest_centre[k])
    }

    /// The position of `v` predicted by patch `k`: `x_k(v) = R_k (x^0(v) - c_k^0) + c_k`
    /// (eq. 1).
    #[inline]
    pub fn prediction(&self, pose: &PatchPose, k: usize, v: usize) -> Point3 {
        pose.centre[k] + self.offset(pose, k, v)
    }

    /// Every blend entry's prediction and turned normal for `pose` (computed once per
    /// iteration: the E-step's hypotheses, the blended positions and normals all use them).
    pub fn predictions(&self, pose: &PatchPose) -> Predictions {
        let mut predictions = Predictions::default();
        self.predictions_into(pose, &mut predictions);
        predictions
    }

    /// [`PatchModel::predictions`] written over `out`, whose buffers are reused (a frame
    /// computes them every iteration: fresh buffers of this size cost page faults).
    pub fn predictions_into(&self, pose: &PatchPose, out: &mut Predictions) {
        let n = self.blend_patch.len();
        out.at.resize(n, Point3::origin());
        out.normal.resize(n, Vector3::zeros());
        const CHUNK: usize = 2048;
        out.at
            .par_chunks_mut(CHUNK)
            .zip(out.normal.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(chunk, (at, normal))| {
                let first = chunk * CHUNK;
                for (i, (x, m)) in at.iter_mut().zip(normal.iter_mut()).enumerate() {
                    let e = first + i;
                    let (l, v) = (self.blend_patch[e] as usize, self.blend_vertex[e] as usize);
                    *x = self.prediction(pose, l, v);
                    *m = pose.rotation[l] * self.rest_normals[v];
                }
            });
    }

    /// The deformed mesh from its predictions: `x(v) = sum_k alpha_k(v) x_k(v)` (eq. 2).
    pub fn blended_positions(&self, predictions: &Predictions) -> Vec<Point3> {
        let mut positions = Vec::new();
        self.blended_positions_into(predictions, &mut positions);
        positions
    }

    /// [`PatchModel::blended_positions`] written over `out` (its buffer reused).
    pub fn blended_positions_into(&self, predictions: &Predictions, out: &mut Vec<Point3>) {
        out.resize(self.vertex_count(), Point3::origin());
        out.par_iter_mut().enumerate().for_each(|(v, x)| {
            *x = Point3::from(
                self.blend_entries(v)
                    .map(|e| predictions.at[e].coords * self.blend_weight[e])
                    .sum::<Vector3>(),
            );
        });
    }

    /// The deformed mesh's normals from its predictions: the reference normals turned by the
    /// blended rotations.
    pub fn blended_normals(&self, predictions: &Predictions) -> Vec<Vector3> {
        let mut normals = Vec::new();
        self.blended_normals_into(predictions, &mut normals);
        normals
    }

    /// [`PatchModel::blended_normals`] written over `out` (its buffer reused).
    pub fn blended_normals_into(&self, predictions: &Predictions, out: &mut Vec<Vector3>) {
        out.resize(self.vertex_count(), Vector3::zeros());
        out.par_iter_mut().enumerate().for_each(|(v, normal)| {
            let n = self
                .blend_entries(v)
                .map(|e| predictions.normal[e] * self.blend_weight[e])
                .sum::<Vector3>();
            *normal = n.try_normalize(1e-12).unwrap_or(self.rest_normals[v]);
        });
    }

    /// The deformed mesh of `pose` (eq. 2).
    pub fn positions(&self, pose: &PatchPose) -> Vec<Point3> {
        self.blended_positions(&self.predictions(pose))
    }

    /// Normals of the deformed mesh of `pose`.
    pub fn normals(&self, pose: &PatchPose) -> Vec<Vector3> {
        self.blended_normals(&self.predictions(pose))
    }

    /// Pairs of neighbouring patches `(k, l)`, `k < l`.
    pub fn neighbour_pairs(&self) -> Vec<(usize, usize)> {
        let mut pairs = Vec::new();
        for (k, n) in self.neighbours.iter().enumerate() {
            for &l in n {
                if (l as usize) > k {
                    pairs.push((k, l as usize));
                }
            }
        }
        pairs
    }

    /// The pairs the M-step couples, `k < l`, sorted: neighbouring patches and the patches
    /// of contact links.
    pub fn linked_pairs(&self) -> Vec<(usize, usize)> {
        let mut pairs = self.neighbour_pairs();
        pairs.extend(self.contacts.iter().map(|c| (c.k as usize, c.l as usize)));
        pairs.sort_unstable();
        pairs.dedup();
        pairs
    }

    /// The weight `alpha_k(v)` (zero when `k` is not blended at `v`).
    pub fn alpha(&self, k: usize, v: usize) -> f64 {
        self.blend(v)
            .find(|&(p, _)| p == k)
            .map(|(_, a)| a)
            .unwrap_or(0.0)
    }

    /// The rigidity energy `E_r` (eq. 4): over neighbouring patches `k`, `l` and the vertices
    /// of both, `(alpha_k(v) + alpha_l(v)) |x_k(v) - x_l(v)|^2` (each unordered pair twice,
    /// halved); plus, over contact links, `weight |x_k(v) - x_l(v)|^2` at their vertices.
    pub fn rigidity_energy(&self, pose: &PatchPose) -> f64 {
        self.neighbour_pairs()
            .into_iter()
            .map(|(k, l)| {
                self.members[k]
                    .iter()
                    .chain(&self.members[l])
                    .map(|&v| {
                        let v = v as usize;
                        let beta = self.alpha(k, v) + self.alpha(l, v);
                        beta * (self.prediction(pose, k, v) - self.prediction(pose, l, v))
                            .norm_squared()
                    })
                    .sum::<f64>()
            })
            .sum::<f64>()
            + self
                .contacts
                .iter()
                .map(|c| {
                    let (k, l) = (c.k as usize, c.l as usize);
                    c.vertices
                        .iter()
                        .map(|&v| {
                            let v = v as usize;
                            (self.prediction(pose, k, v) - self.prediction(pose, l, v))
                                .norm_squared()
                        })
                        .sum::<f64>()
                        * c.weight
                })
                .sum::<f64>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Quat;

    fn sheet() -> TriMesh {
        let n = 21;
        let mut vertices = Vec::new();
        for j in 0..n {
            for i in 0..n {
                vertices.push(Point3::new(i as f64 / 20.0, j as f64 / 20.0, 0.0));
            }
        }
        let mut triangles = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let a = (j * n + i) as u32;
                triangles.push([a, a + 1, a + n as u32 + 1]);
                triangles.push([a, a + n as u32 + 1, a + n as u32]);
            }
        }
        TriMesh {
            vertices,
            normals: None,
            triangles,
        }
    }

    #[test]
    fn rest_pose_reproduces_the_reference_with_zero_rigidity_energy() {
        let mesh = sheet();
        let model = PatchModel::new(&mesh, &PatchOptions::default()).expect("a sheet");
        assert!(model.patch_count() > 10);
        let pose = model.rest_pose();
        for (a, b) in model.positions(&pose).iter().zip(&mesh.vertices) {
            assert!((a - b).norm() < 1e-12);
        }
        assert!(model.rigidity_energy(&pose) < 1e-20);
        for v in 0..model.vertex_count() {
            let s: f64 = model.blend(v).map(|(_, a)| a).sum();
            assert!((s - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn a_rigid_motion_keeps_zero_rigidity_energy() {
        let model = PatchModel::new(&sheet(), &PatchOptions::default()).expect("a sheet");
        let q = Quat::from_euler_angles(0.3, -0.2, 0.5);
        let t = Vector3::new(0.1, 2.0, -1.0);
        let mut pose = model.rest_pose();
        for k in 0..model.patch_count() {
            pose.rotation[k] = q.to_rotation_matrix().into_inner();
            pose.centre[k] = q * pose.centre[k] + t;
        }
        assert!(model.rigidity_energy(&pose) < 1e-18);
        let moved = model.positions(&pose);
        for (a, b) in moved.iter().zip(&model.rest) {
            assert!((a - (q * b + t)).norm() < 1e-12);
        }
        // Turning one patch alone is penalised.
        pose.rotation[0] = Matrix3::identity();
        assert!(model.rigidity_energy(&pose) > 1e-6);
        // Each prediction of a rigid motion is the moved vertex, its normal the turned one.
        pose.rotation[0] = q.to_rotation_matrix().into_inner();
        let predictions = model.predictions(&pose);
        assert_eq!(predictions.at.len(), model.blend_patch.len());
        for (e, &v) in model.blend_vertex.iter().enumerate() {
            let v = v as usize;
            assert!((predictions.at[e] - (q * model.rest[v] + t)).norm() < 1e-12);
            assert!((predictions.normal[e] - q * model.rest_normals[v]).norm() < 1e-12);
        }
        for (n, n0) in model.normals(&pose).iter().zip(&model.rest_normals) {
            assert!((n - q * n0).norm() < 1e-12);
        }
    }

    #[test]
    fn no_faces_is_an_error_and_loose_vertices_follow_a_patch() {
        let mut mesh = sheet();
        let triangles = std::mem::take(&mut mesh.triangles);
        assert!(matches!(
            PatchModel::new(&mesh, &PatchOptions::default()),
            Err(SurfaceError::NoFaces)
        ));
        mesh.triangles = triangles;
        mesh.vertices.push(Point3::new(0.5, 0.5, 0.3));
        let model = PatchModel::new(&mesh, &PatchOptions::default()).expect("a sheet");
        assert!((model.vertex_patch[mesh.vertices.len() - 1] as usize) < model.patch_count());
    }
}
