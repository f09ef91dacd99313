//! Rotations about coordinate axes, and a rotation split into Euler angles for any order of
//! one, two or three distinct axes.

use rigfit_core::{Quat, Vector3};

/// A rotation of `radians` about coordinate axis `axis`.
pub(super) fn axis_rotation(axis: usize, radians: f64) -> Quat {
    Quat::from_axis_angle(&Vector3::ith_axis(axis.min(2)), radians)
}

/// An angle in (-pi, pi].
pub(super) fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    if !a.is_finite() {
        return 0.0;
    }
    let mut r = a % TAU;
    if r > PI {
        r -= TAU;
    } else if r <= -PI {
        r += TAU;
    }
    r
}

/// The angle (radians) of the rotation about `axis` closest to `q`'s twist about it; exact
/// when `q` is such a rotation.
pub(super) fn single_axis_angle(q: &Quat, axis: usize) -> f64 {
    2.0 * q.imag()[axis.min(2)].atan2(q.w)
}

/// Angles (radians) `[a, b]` with `R_p(a) * R_q(b)` equal to `q` when it can be, for two
/// different axes `p`, `q`.
pub(super) fn euler2(rot: &Quat, p: usize, q: usize) -> [f64; 2] {
    let m = rot.to_rotation_matrix().into_inner();
    let ep = Vector3::ith(p, 1.0);
    let eq = Vector3::ith(q, 1.0);
    let n = ep.cross(&eq);
    // R e_q = R_p(a) e_q and R^T e_p = R_q(-b) e_p.
    let v = m * eq;
    let w = m.transpose() * ep;
    [n.dot(&v).atan2(eq.dot(&v)), n.dot(&w).atan2(ep.dot(&w))]
}

/// Angles (radians) `[a, b, c]` with `R_i(a) * R_j(b) * R_k(c) == q` for distinct axes.
pub(super) fn euler3(rot: &Quat, [i, j, k]: [usize; 3]) -> [f64; 3] {
    let m = rot.to_rotation_matrix().into_inner();
    let s = if j == (i + 1) % 3 { 1.0 } else { -1.0 };
    let cb = m[(i, i)].hypot(m[(i, j)]);
    let b = (s * m[(i, k)]).atan2(cb);
    let a = if cb > 1e-9 {
        (-s * m[(j, k)]).atan2(m[(k, k)])
    } else {
        // Gimbal lock: only a + c or a - c is defined; take c from what is left.
        (s * m[(k, j)]).atan2(m[(j, j)])
    };
    let rest = (axis_rotation(i, a) * axis_rotation(j, b)).inverse() * rot;
    let c = single_axis_angle(&rest, k);
    [a, b, c]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic pseudo-random numbers in [-1, 1).
    fn lcg(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    #[test]
    fn euler3_recomposes_every_order() {
        let orders = [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ];
        let mut s = 7u64;
        for order in orders {
            for n in 0..200 {
                let mut q = Quat::from_scaled_axis(
                    Vector3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 3.0,
                );
                if n < 4 {
                    // Gimbal lock: the middle angle at +-90 degrees.
                    let b = if n % 2 == 0 { 1.0 } else { -1.0 } * std::f64::consts::FRAC_PI_2;
                    q = axis_rotation(order[0], lcg(&mut s) * 3.0)
                        * axis_rotation(order[1], b)
                        * axis_rotation(order[2], lcg(&mut s) * 3.0);
                }
                let [a, b, c] = euler3(&q, order);
                let back = axis_rotation(order[0], a)
                    * axis_rotation(order[1], b)
                    * axis_rotation(order[2], c);
                assert!(
                    back.angle_to(&q) < 1e-12,
                    "order {order:?}: {}",
                    back.angle_to(&q)
                );
            }
        }
    }

    #[test]
    fn euler2_and_single_axis_are_exact_when_representable() {
        let mut s = 3u64;
        for (p, q) in [(0, 1), (1, 0), (2, 0), (0, 2), (1, 2), (2, 1)] {
            for _ in 0..100 {
                let (x, y) = (lcg(&mut s) * 3.1, lcg(&mut s) * 3.1);
                let r = axis_rotation(p, x) * axis_rotation(q, y);
                let [a, b] = euler2(&r, p, q);
                let back = axis_rotation(p, a) * axis_rotation(q, b);
                assert!(back.angle_to(&r) < 1e-12);
                let single = single_axis_angle(&axis_rotation(p, x), p);
                assert!((wrap_angle(single) - x).abs() < 1e-12);
            }
        }
    }
}
