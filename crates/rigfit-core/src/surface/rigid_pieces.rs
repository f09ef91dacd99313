//! The fitted mesh of an object of rigid pieces handed out with each piece laid rigidly
//! where the fit put it (rigfit's addition to Cagniart et al. 2010). The patches of a piece
//! bend against each other a little (their rigidity is a soft prior, eq. 4), and a patch
//! whose data is another piece's (a link's end inside its neighbour, a fingertip beside
//! the next) drags a few vertices far. Each piece's motion is the least-squares rigid
//! motion of its reference vertices onto their fitted places, made robust by reweighting:
//! vertices farther than [`HUBER_WIDTH`] from it count less (Huber), so the dragged few
//! follow the rest.

use rayon::prelude::*;

use super::model::PatchModel;
use super::piece_tree::RigidMotion;
use crate::math::{Matrix3, Point3, Vector3, nearest_rotation};

/// Residuals (fraction of the diagonal) beyond which a vertex's weight falls as one over its
/// residual (Huber).
const HUBER_WIDTH: f64 = 0.005;

/// Reweighted fits per piece (the first with every vertex weighted alike).
const REWEIGHTED_FITS: usize = 4;

/// Lays each piece of `model` (connected component of the reference) rigidly onto
/// `positions`, the fitted places of the reference's vertices: each vertex is moved to its
/// piece's robust rigid motion of its reference place. The same bits on one thread or
/// several (each piece is fitted on its own). Returns each piece's motion from the
/// reference (`None` for a piece left as it was).
pub(super) fn lay_pieces_rigidly(
    model: &PatchModel,
    positions: &mut [Point3],
) -> Vec<Option<RigidMotion>> {
    let pieces = model.piece_count();
    if pieces == 0 || positions.len() != model.rest.len() {
        return Vec::new();
    }
    // Each piece's vertices (a counting sort by piece).
    let piece_of = |v: usize| model.component[model.vertex_patch[v] as usize] as usize;
    let mut start = vec![0usize; pieces + 1];
    for v in 0..positions.len() {
        start[piece_of(v) + 1] += 1;
    }
    for p in 0..pieces {
        start[p + 1] += start[p];
    }
    let mut next = start.clone();
    let mut members = vec![0u32; positions.len()];
    for v in 0..positions.len() {
        let p = piece_of(v);
        members[next[p]] = v as u32;
        next[p] += 1;
    }
    let width = HUBER_WIDTH * model.diagonal;
    let fitted: &[Point3] = positions;
    let motions: Vec<Option<RigidMotion>> = (0..pieces)
        .into_par_iter()
        .map(|p| {
            let vertices = &members[start[p]..start[p + 1]];
            robust_rigid_motion(vertices, &model.rest, fitted, width)
        })
        .collect();
    for (p, motion) in motions.iter().enumerate() {
        let Some(motion) = motion else {
            continue;
        };
        for &v in &members[start[p]..start[p + 1]] {
            let v = v as usize;
            positions[v] =
                Point3::from(motion.rotation * model.rest[v].coords + motion.translation);
        }
    }
    motions
}

/// The rigid motion `x -> rotation * x + translation` taking the reference places `rest` of
/// `vertices` onto their `fitted` places, in the least squares (Kabsch) with weights
/// reweighted [`REWEIGHTED_FITS`] times by the residuals beyond `width` (Huber). `None` for
/// a piece with no vertex or a non-finite fit.
fn robust_rigid_motion(
    vertices: &[u32],
    rest: &[Point3],
    fitted: &[Point3],
    width: f64,
) -> Option<RigidMotion> {
    if vertices.is_empty() {
        return None;
    }
    let mut weight = vec![1.0f64; vertices.len()];
    let mut motion = None;
    for _ in 0..REWEIGHTED_FITS {
        let (mut total, mut from, mut to) = (0.0, Vector3::zeros(), Vector3::zeros());
        for (&v, &w) in vertices.iter().zip(&weight) {
            total += w;
            from += rest[v as usize].coords * w;
            to += fitted[v as usize].coords * w;
        }
        if total <= 0.0 {
            return None;
        }
        from /= total;
        to /= total;
        let mut covariance = Matrix3::zeros();
        for (&v, &w) in vertices.iter().zip(&weight) {
            covariance +=
                (fitted[v as usize].coords - to) * (rest[v as usize].coords - from).transpose() * w;
        }
        let rotation = nearest_rotation(&covariance);
        let translation = to - rotation * from;
        for (&v, w) in vertices.iter().zip(weight.iter_mut()) {
            let v = v as usize;
            let residual = (rotation * rest[v].coords + translation - fitted[v].coords).norm();
            *w = if residual <= width {
                1.0
            } else {
                width / residual
            };
        }
        motion = Some(RigidMotion {
            rotation,
            translation,
        });
    }
    motion.filter(|m| {
        m.rotation
            .iter()
            .chain(m.translation.iter())
            .all(|x| x.is_finite())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::model::PatchOptions;
    use crate::surface::piece_tree::tests::body_and_arm;

    /// A piece moved rigidly with a few of its vertices dragged far comes back rigid: the
    /// dragged vertices follow the rest of their piece, and the other piece stays put.
    #[test]
    fn a_piece_with_a_few_dragged_vertices_is_laid_rigidly() {
        let (mesh, _) = body_and_arm();
        let model = PatchModel::new(&mesh, &PatchOptions::default()).expect("model");
        let arm = model.component[model.vertex_patch[mesh.vertices.len() - 1] as usize];
        let turn = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), 0.4).into_inner();
        let shift = Vector3::new(0.1, -0.05, 0.02);
        let truth: Vec<Point3> = (0..mesh.vertices.len())
            .map(|v| {
                let piece = model.component[model.vertex_patch[v] as usize];
                if piece == arm {
                    Point3::from(turn * mesh.vertices[v].coords + shift)
                } else {
                    mesh.vertices[v]
                }
            })
            .collect();
        let mut fitted = truth.clone();
        let arm_vertices: Vec<usize> = (0..fitted.len())
            .filter(|&v| model.component[model.vertex_patch[v] as usize] == arm)
            .collect();
        for &v in arm_vertices.iter().step_by(17) {
            fitted[v] += Vector3::new(0.0, 0.3, 0.0) * model.diagonal;
        }
        lay_pieces_rigidly(&model, &mut fitted);
        let worst = fitted
            .iter()
            .zip(&truth)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        assert!(worst < 1e-3 * model.diagonal, "{worst}");
    }
}
