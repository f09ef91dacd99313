//! One Gauss-Newton step of the M-step (eq. 15): the data term collapsed per vertex and the
//! rigidity energy (eq. 4) assembled from their moments into the engine's block-sparse
//! normal equations (a [`NormalSink`]), damped, solved, and applied to the patches'
//! rotations and centres.

use rayon::prelude::*;

use super::block_moments::{
    OffsetMoments, OwnBlockSums, PairBlockSums, add_jtr, add_slices, cross_sum,
};
use super::patch_system::PatchSystem;
use crate::engine::linear_algebra::{Block6, BlockSparseNormalEquations, NormalSink, SolveError};
use crate::math::{Matrix3, Point3, Vector3, exp_rotation};
use crate::surface::estep::VertexTargets;
use crate::surface::model::{PatchModel, PatchPose};

/// Weights of the two energy terms.
#[derive(Clone, Debug)]
pub struct StepWeights {
    /// Weight of the data term: `1 / sigma^2`.
    pub data: f64,
    /// Weight of the rigidity energy (eq. 4).
    pub rigidity: f64,
    /// The rigidity between patches of one piece is `rigidity` times this (1 but in the
    /// first, coarse iterations of a frame, see `SurfaceOptions::coarse_stiffness`); contact
    /// links keep `rigidity`.
    pub within_pieces: f64,
    /// Levenberg-Marquardt damping, relative to each diagonal entry.
    pub damping: f64,
    /// Weight of the data residual's component along the surface, against 1 across it:
    /// 1 is the paper's point-to-point distance; below 1 lets a vertex slide along the
    /// surface toward the centroid of its points without the mesh being dragged by the way
    /// points happen to fall around vertices.
    pub tangential: f64,
    /// The step taken is this multiple of the Gauss-Newton step (1: the step itself).
    pub relaxation: f64,
    /// Weight of the pull of patches short of data toward the anchor pose, per vertex,
    /// against the data term of a vertex with the average posterior weight (see
    /// [`anchor_weights`]); 0 turns it off.
    pub anchor: f64,
}

/// The anchor term's weight of each patch (rigfit's addition): a patch with less posterior
/// weight than its share of the vertices (an unseen part, a part seen by a few points or
/// only by outliers) is pulled toward where the anchor pose (the last frame's) puts it, in
/// proportion to what it lacks, `anchor * Wbar * (1 - support_k)` per vertex, `Wbar` the
/// mean posterior weight of a vertex and `support_k` from [`patch_support`]; a patch seen
/// as well as the average is free. With contact links and rigidity, a part out of view follows its
/// neighbours instead of the clutter.
pub fn anchor_weights(
    model: &PatchModel,
    targets: &VertexTargets,
    weights: &StepWeights,
) -> Vec<f64> {
    let mean = targets.weight.iter().sum::<f64>() / model.vertex_count().max(1) as f64;
    if weights.anchor <= 0.0 || mean <= 0.0 {
        return vec![0.0; model.patch_count()];
    }
    patch_support(model, targets)
        .into_iter()
        .map(|seen| weights.anchor * weights.data * mean * (1.0 - seen))
        .collect()
}

/// How well each patch is seen: its vertices' posterior weight against its share of the
/// total by surface area, at most 1; 0 for a patch no point explains (and for every patch
/// when none does).
pub fn patch_support(model: &PatchModel, targets: &VertexTargets) -> Vec<f64> {
    let total = targets.weight.iter().sum::<f64>();
    let area = model.area.iter().sum::<f64>();
    model
        .members
        .iter()
        .zip(&model.area)
        .map(|(m, &a)| {
            let share = total * a / area.max(1e-300);
            if share <= 0.0 {
                return 0.0;
            }
            let seen: f64 = m.iter().map(|&v| targets.weight[v as usize]).sum();
            (seen / share).min(1.0)
        })
        .collect()
}

/// Adds the anchor term's normal equations: over each patch's vertices, residual
/// `x_k(v) - a_k(v)` (`a_k` the anchor pose's prediction), weight `w_k`; with the patch's
/// rest moments, `d = c_k - c_k^a`, the gradient is `[m_k x d - X; w d + m_k - m_a]`,
/// `X = sum q_k x q_a` (as for a rigidity pair of the patch with its anchored self).
fn add_anchor(
    system: &PatchSystem,
    pose: &PatchPose,
    anchor: &PatchPose,
    patch_weights: &[f64],
    sink: &mut impl NormalSink,
) {
    for (k, (&w, moments)) in patch_weights.iter().zip(&system.member_moments).enumerate() {
        if w <= 0.0 {
            continue;
        }
        let (rk, ra) = (&pose.rotation[k], &anchor.rotation[k]);
        let mut block: Block6 = [0.0; 36];
        moments.add_to_block(&mut block, w, rk, rk);
        sink.add_jtj_block6(6 * k, 6 * k, &block);
        let (mk, ma, s) = moments.rotated(rk, ra);
        let d = pose.centre[k] - anchor.centre[k];
        let residual_sum = d * moments.weight + mk - ma;
        let top = mk.cross(&d) - cross_sum(&s);
        for i in 0..3 {
            sink.add_jtr(6 * k + i, w * top[i]);
            sink.add_jtr(6 * k + 3 + i, w * residual_sum[i]);
        }
    }
}

/// One vertex's data term: `weight * |x(v) - ybar_v|_P^2` with `P = n n^T + t (I - n n^T)`.
pub(super) struct DataTerm {
    pub(super) vertex: usize,
    weight: f64,
    normal: Vector3,
    /// `weight * P`.
    pub(super) metric: Matrix3,
    pub(super) residual: Vector3,
}

/// The data term of every vertex with posterior weight (eq. 15, collapsed per vertex).
pub(super) fn data_terms(
    positions: &[Point3],
    normals: &[Vector3],
    targets: &VertexTargets,
    weights: &StepWeights,
) -> Vec<DataTerm> {
    (0..positions.len())
        .filter(|&v| targets.weight[v] > 1e-12)
        .map(|v| {
            let w = targets.weight[v];
            let ybar = targets.weighted_sum[v] / w;
            let n = normals[v];
            let across = n * n.transpose();
            let weight = w * weights.data;
            let metric = (across + (Matrix3::identity() - across) * weights.tangential) * weight;
            DataTerm {
                vertex: v,
                weight,
                normal: n,
                metric,
                residual: positions[v].coords - ybar,
            }
        })
        .collect()
}

/// A patch blended at a vertex: its index, `alpha`, the vertex's rest offset from the patch's
/// rest centre, `q = R offset` and `u = [q x n; n]`.
#[derive(Clone, Copy, Debug)]
struct BlendedPatch {
    patch: usize,
    alpha: f64,
    offset: [f64; 3],
    q: Vector3,
    u: [f64; 6],
}

/// The data term's normal equations summed over a run of vertices: each patch's own block,
/// each block's pair part, and the gradient.
struct DataSums {
    own: Vec<OwnBlockSums>,
    pair: Vec<PairBlockSums>,
    gradient: Vec<f64>,
}

impl DataSums {
    fn zeros(patch_count: usize, block_count: usize) -> Self {
        Self {
            own: vec![OwnBlockSums::default(); patch_count],
            pair: vec![PairBlockSums::default(); block_count],
            gradient: vec![0.0; 6 * patch_count],
        }
    }

    /// Adds another run's sums.
    fn add_sums(&mut self, other: &Self) {
        for (t, s) in self.own.iter_mut().zip(&other.own) {
            t.add_sums(s);
        }
        for (t, s) in self.pair.iter_mut().zip(&other.pair) {
            t.add_sums(s);
        }
        add_slices(&mut self.gradient, &other.gradient);
    }

    /// Adds the sums, rotated by the pose, to their blocks, and the gradient.
    fn add_to(
        &self,
        model: &PatchModel,
        system: &PatchSystem,
        pose: &PatchPose,
        sink: &mut impl NormalSink,
    ) {
        for (sum, position) in self.pair.iter().zip(system.pattern.block_pairs()) {
            let (a, b) = (position.row as usize, position.column as usize);
            let mut block = [0.0; 36];
            if a == b {
                self.own[a].add_to_block(&mut block, &pose.rotation[a]);
            } else {
                let delta = model.rest_centre[a] - model.rest_centre[b];
                sum.add_to_block(&mut block, &pose.rotation[a], &pose.rotation[b], &delta);
            }
            sink.add_jtj_block6(6 * a, 6 * b, &block);
        }
        for (i, &g) in self.gradient.iter().enumerate() {
            sink.add_jtr(i, g);
        }
    }
}

/// Eq. 15's normal equations for the data term. With `P = t I + (1 - t) n n^T` and
/// `J_a = alpha_a [-[q_a]x, I]`, each block `sum_v W_v J_a^T P J_b` splits into an
/// isotropic part (summed as rest-frame moments, rotated once per block) and a rank-one
/// part along the normal. Two halves in parallel, each into its own sums, then added.
fn data_sums(
    model: &PatchModel,
    system: &PatchSystem,
    pose: &PatchPose,
    data_terms: &[DataTerm],
    weights: &StepWeights,
) -> DataSums {
    let n = model.patch_count();
    let half = data_terms.len().div_ceil(2).max(1);
    let partial: Vec<DataSums> = data_terms
        .par_chunks(half)
        .map(|terms| {
            let mut sums = DataSums::zeros(n, system.block_count());
            let mut blend: Vec<BlendedPatch> = Vec::with_capacity(16);
            for term in terms {
                let v = term.vertex;
                let pr = term.metric * term.residual;
                let isotropic = weights.tangential * term.weight;
                let along_normal = (1.0 - weights.tangential) * term.weight;
                let normal = term.normal;
                blend.clear();
                blend.extend(model.blend(v).map(|(k, a)| {
                    let rest_offset = model.rest[v] - model.rest_centre[k];
                    let q = pose.rotation[k] * rest_offset;
                    let c = q.cross(&normal);
                    let u = [c.x, c.y, c.z, normal.x, normal.y, normal.z];
                    BlendedPatch {
                        patch: k,
                        alpha: a,
                        offset: rest_offset.into(),
                        q,
                        u,
                    }
                }));
                let first = model.blend_start[v] as usize;
                for (i, b) in blend.iter().enumerate() {
                    let k = b.patch;
                    add_jtr(&mut sums.gradient[6 * k..6 * k + 6], b.alpha, &b.q, &pr);
                    let weight = system.diagonal[first + i].weight;
                    sums.own[k].add_vertex(
                        isotropic * weight,
                        along_normal * weight,
                        &b.offset,
                        &b.u,
                    );
                }
                for p in system.vertex_pairs(v) {
                    let (a, b) = (&blend[p.first as usize], &blend[p.second as usize]);
                    sums.pair[p.block as usize].add_vertex(
                        isotropic * p.weight,
                        along_normal * p.weight,
                        &a.offset,
                        (&a.u, &b.u),
                    );
                }
            }
            sums
        })
        .collect();
    let mut total = DataSums::zeros(n, system.block_count());
    for part in &partial {
        total.add_sums(part);
    }
    total
}

/// Adds the rigidity term's normal equations (eq. 4) to `sink`: residual
/// x_k(v) - x_l(v) over v in P_k and P_l, weight alpha_k(v) + alpha_l(v); the Jacobian is
/// J_k(v) for patch k and -J_l(v) for patch l. From the pair's rest-frame moments: with
/// d = c_k - c_l and r = d + q_k - q_l, sum beta q_k x r = m_k x d - X and
/// sum beta q_l x r = m_l x d - X, X = sum q_k x q_l.
fn add_rigidity(
    system: &PatchSystem,
    pose: &PatchPose,
    weights: &StepWeights,
    sink: &mut impl NormalSink,
) {
    for pair in &system.rigidity_pairs {
        let (k, l, moments) = (pair.k, pair.l, &pair.moments);
        let (rk, rl) = (&pose.rotation[k], &pose.rotation[l]);
        let w = if pair.small_piece {
            weights.rigidity * weights.within_pieces
        } else {
            weights.rigidity
        };
        let block = |scale: f64, moments: &OffsetMoments, ra: &Matrix3, rb: &Matrix3| {
            let mut block: Block6 = [0.0; 36];
            moments.add_to_block(&mut block, scale, ra, rb);
            block
        };
        sink.add_jtj_block6(6 * k, 6 * k, &block(w, &moments[0], rk, rk));
        sink.add_jtj_block6(6 * l, 6 * l, &block(w, &moments[1], rl, rl));
        sink.add_jtj_block6(6 * k, 6 * l, &block(-w, &moments[2], rk, rl));
        let (mk, ml, s) = moments[2].rotated(rk, rl);
        let crossed = cross_sum(&s);
        let d = pose.centre[k] - pose.centre[l];
        let residual_sum = d * moments[2].weight + mk - ml;
        let top_k = mk.cross(&d) - crossed;
        let top_l = ml.cross(&d) - crossed;
        // `g - x` is `g + (-x)` to the bit.
        for i in 0..3 {
            sink.add_jtr(6 * k + i, w * top_k[i]);
            sink.add_jtr(6 * k + 3 + i, w * residual_sum[i]);
            sink.add_jtr(6 * l + i, -(w * top_l[i]));
            sink.add_jtr(6 * l + 3 + i, -(w * residual_sum[i]));
        }
    }
}

/// One Gauss-Newton step on `data * sum_v W_v |x(v) - ybar_v|_P^2 + rigidity * E_r` (plus
/// the anchor term toward `anchor`, see [`anchor_weights`]), applied to `pose` in place,
/// where `P = n n^T + tangential (I - n n^T)` for the vertex normal `n`.
#[allow(clippy::too_many_arguments)]
pub fn gauss_newton_step(
    model: &PatchModel,
    system: &PatchSystem,
    pose: &mut PatchPose,
    positions: &[Point3],
    normals: &[Vector3],
    targets: &VertexTargets,
    weights: &StepWeights,
    anchor: Option<&PatchPose>,
) -> Result<(), SolveError> {
    let mut equations = system.pattern.equations();

    // Data term, vertex by vertex: residual x(v) - ybar_v with weight W_v; the Jacobian of
    // x(v) is sum_k alpha_k(v) J_k(v) (eq. 2).
    let data_terms = data_terms(positions, normals, targets, weights);
    let sums = data_sums(model, system, pose, &data_terms, weights);
    sums.add_to(model, system, pose, &mut equations);

    add_rigidity(system, pose, weights, &mut equations);
    if let Some(anchor) = anchor {
        let patch_weights = anchor_weights(model, targets, weights);
        add_anchor(system, pose, anchor, &patch_weights, &mut equations);
    }

    damp_solve_and_apply(model, pose, &mut equations, targets, weights)
}

/// Adds the damping to the assembled normal equations, solves them and applies the step
/// (rotation increments and centre shifts) to `pose`.
pub(super) fn damp_solve_and_apply(
    model: &PatchModel,
    pose: &mut PatchPose,
    equations: &mut BlockSparseNormalEquations<'_>,
    targets: &VertexTargets,
    weights: &StepWeights,
) -> Result<(), SolveError> {
    let n = model.patch_count();
    // Damping: relative (Levenberg-Marquardt) plus a floor so that patches with no data and
    // no neighbours (a lone object out of view) stay put instead of making H singular.
    // Rotation entries scale with length^2: the floor compares them at the model's size.
    let max_translation = (0..n)
        .flat_map(|k| (3..6).map(move |i| (k, i)))
        .map(|(k, i)| equations.diagonal_block(k)[7 * i])
        .fold(0.0, f64::max)
        .max(1e-300);
    // A weak prior to stay put, worth about `damping` of an average patch's data, so that a
    // patch seen by a handful of points cannot swing far in one step.
    let data_weight: f64 = targets.weight.iter().sum::<f64>() * weights.data;
    let floor_translation = 1e-9 * max_translation + weights.damping * data_weight / n as f64;
    let floor_rotation = floor_translation * model.diagonal * model.diagonal;
    for k in 0..n {
        let block = equations.diagonal_block_mut(k);
        for i in 0..6 {
            let floor = if i < 3 {
                floor_rotation
            } else {
                floor_translation
            };
            block[7 * i] += weights.damping * block[7 * i] + floor;
        }
    }

    let mut rhs = equations.solve()?;
    for x in &mut rhs {
        *x *= weights.relaxation;
    }
    for k in 0..n {
        let w = Vector3::new(rhs[6 * k], rhs[6 * k + 1], rhs[6 * k + 2]);
        let dc = Vector3::new(rhs[6 * k + 3], rhs[6 * k + 4], rhs[6 * k + 5]);
        let turn = exp_rotation(&w).to_rotation_matrix().into_inner();
        pose.rotation[k] = orthonormalise(&(turn * pose.rotation[k]));
        pose.centre[k] += dc;
    }
    Ok(())
}

/// `m` made a rotation again (products of rotations drift by rounding): Gram-Schmidt on its
/// columns, which for a matrix this close to a rotation is the nearest one to rounding.
fn orthonormalise(m: &Matrix3) -> Matrix3 {
    let x = m.column(0).normalize();
    let y = m.column(1) - x * x.dot(&m.column(1));
    let y = y.normalize();
    let z = x.cross(&y);
    Matrix3::from_columns(&[x, y, z])
}
