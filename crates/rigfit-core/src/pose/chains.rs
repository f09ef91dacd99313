//! Strokes along chains: a stroke is an ordered polyline, so it covers one connected chain
//! of bones in order, and each point along the chain corresponds to the stroke point at the
//! same fraction of arclength (a correspondence with no local minima of the kind
//! nearest-point matching falls into).

use super::candidates::distance_cost;
use super::setup::Setup;
use crate::kinematics::ForwardKinematics;
use crate::math::{Point3, Vector3};
use crate::skeleton::Pose;

/// Samples compared per stroke and chain.
pub(super) const SAMPLES: usize = 24;

/// A stroke's chain: bones from the chain's root end to its tip, and whether the stroke was
/// drawn tip first. `None`: the stroke is set aside as a stray.
pub(super) type Assignment = Option<(Vec<usize>, bool)>;

/// The point at normalised arclength `u` of a polyline with cumulative lengths `cum`.
pub(super) fn at(line: &[Point3], cum: &[f64], u: f64) -> Point3 {
    let total = *cum.last().unwrap_or(&0.0);
    if total <= 0.0 || line.len() < 2 {
        return line[0];
    }
    let target = u.clamp(0.0, 1.0) * total;
    let seg = cum
        .partition_point(|&c| c < target)
        .clamp(1, line.len() - 1)
        - 1;
    let (a, b) = (cum[seg], cum[seg + 1]);
    let t = if b > a { (target - a) / (b - a) } else { 0.0 };
    line[seg] + (line[seg + 1] - line[seg]) * t
}

/// Cumulative lengths along a polyline (starting at 0).
pub(super) fn cumulative(line: &[Point3]) -> Vec<f64> {
    let mut c = Vec::with_capacity(line.len());
    let mut acc = 0.0;
    c.push(0.0);
    for w in line.windows(2) {
        acc += (w[1] - w[0]).norm();
        c.push(acc);
    }
    c
}

/// [`SAMPLES`] points evenly spaced in arclength along a polyline, and its length.
pub(super) fn arclength_samples(line: &[Point3]) -> ([Point3; SAMPLES], f64) {
    arclength_samples_along(|| line.iter().copied())
}

/// [`arclength_samples`] along the polyline `points()` walks (twice: its length, then the
/// samples), without collecting it. The cumulative lengths are summed in the same order as
/// [`cumulative`]'s, so the samples are those [`at`] finds.
pub(super) fn arclength_samples_along<I: Iterator<Item = Point3>>(
    points: impl Fn() -> I,
) -> ([Point3; SAMPLES], f64) {
    let mut walk = points();
    let Some(first) = walk.next() else {
        panic!("a polyline has at least one point");
    };
    let (mut total, mut previous, mut segments) = (0.0, first, 0usize);
    for p in walk {
        total += (p - previous).norm();
        previous = p;
        segments += 1;
    }
    let mut samples = [first; SAMPLES];
    if total <= 0.0 || segments == 0 {
        return (samples, total);
    }
    // One sweep: segment `[a, b]` runs from cumulative length `cum_a` to `cum_b`; a target
    // lies on the first segment whose end is not below it (the last one past the end).
    let mut walk = points();
    let mut a = walk.next().unwrap_or(first);
    let mut b = walk.next().unwrap_or(a);
    let (mut cum_a, mut cum_b, mut seg) = (0.0, (b - a).norm(), 0usize);
    for (i, sample) in samples.iter_mut().enumerate() {
        let target = (i as f64 / (SAMPLES - 1) as f64).clamp(0.0, 1.0) * total;
        while cum_b < target && seg + 1 < segments {
            let Some(next) = walk.next() else { break };
            (a, b) = (b, next);
            cum_a = cum_b;
            cum_b += (b - a).norm();
            seg += 1;
        }
        let t = if cum_b > cum_a {
            (target - cum_a) / (cum_b - cum_a)
        } else {
            0.0
        };
        *sample = a + (b - a) * t;
    }
    (samples, total)
}

/// Whether two strokes of `assignment` cover one bone (of `bones`).
pub(super) fn covers_a_bone_twice(assignment: &[Assignment], bones: usize) -> bool {
    let mut taken = vec![false; bones];
    (assignment.iter().flatten().flat_map(|(c, _)| c))
        .any(|&b| std::mem::replace(&mut taken[b], true))
}

/// The arclength of stroke `s` (after resampling).
pub(super) fn stroke_length(setup: &Setup, s: usize) -> f64 {
    setup.strokes.by_arclength[s].1
}

/// Mean squared distance between a stroke's and a chain's arclength samples, the stroke
/// reversed or not.
fn sample_distance(stroke: &[Point3], chain: &[Point3], reversed: bool) -> f64 {
    (0..SAMPLES)
        .map(|i| {
            let k = if reversed { SAMPLES - 1 - i } else { i };
            (stroke[i] - chain[k]).norm_squared()
        })
        .sum::<f64>()
        / SAMPLES as f64
}

/// Whether stroke `s` runs along `chain` tip first: the direction whose arclength-matched
/// points lie closer at `pose`; on a near tie (a chain at right angles to a stroke from its
/// attachment fits both ways alike), the one closer at the chain's attached end, which moves
/// least with the limb's pose.
pub(super) fn better_direction(setup: &Setup, pose: &Pose, s: usize, chain: &[usize]) -> bool {
    let fk = ForwardKinematics::new(setup.skeleton, pose);
    let (line, _) = setup.model.chain_samples(chain, &fk);
    let stroke = &setup.strokes.by_arclength[s].0;
    let (ahead, back) = (
        sample_distance(stroke, &line, false),
        sample_distance(stroke, &line, true),
    );
    if (ahead - back).abs() > DIRECTION_TIE * ahead.max(back) {
        back < ahead
    } else {
        let h = setup.height;
        distance_cost(stroke, &line, true, h) < distance_cost(stroke, &line, false, h)
    }
}

/// Two directions whose mean distances differ by less than this share are a tie.
const DIRECTION_TIE: f64 = 0.1;

/// RMS distance (in heights) of each assigned stroke's points to its chain at the same
/// fraction of arclength, at `pose` (0 for strokes set aside).
pub(super) fn stroke_residuals(setup: &Setup, pose: &Pose, assignment: &[Assignment]) -> Vec<f64> {
    let fk = ForwardKinematics::new(setup.skeleton, pose);
    assignment
        .iter()
        .enumerate()
        .map(|(s, a)| {
            let Some((chain, reversed)) = a else {
                return 0.0;
            };
            let (line, _) = setup.model.chain_samples(chain, &fk);
            let stroke = &setup.strokes.by_arclength[s].0;
            sample_distance(stroke, &line, *reversed).sqrt() / setup.height
        })
        .collect()
}

/// Stroke samples a translating bone's stretch of stroke is fitted with.
const LINE_FIT_SAMPLES: usize = 16;

/// The ends of the least-squares line through the stroke between arclength fractions
/// `span` (samples evenly spaced in arclength, fitted against their fraction).
fn fitted_line(stroke: &[Point3], cum: &[f64], span: (f64, f64)) -> (Point3, Point3) {
    let n = LINE_FIT_SAMPLES;
    let t_mean = 0.5;
    let (mut p_mean, mut covariance, mut variance) = (Vector3::zeros(), Vector3::zeros(), 0.0);
    let samples: [(f64, Point3); LINE_FIT_SAMPLES] = std::array::from_fn(|i| {
        let t = i as f64 / (n - 1) as f64;
        (t, at(stroke, cum, span.0 + t * (span.1 - span.0)))
    });
    for (_, p) in &samples {
        p_mean += p.coords / n as f64;
    }
    for (t, p) in &samples {
        covariance += (p.coords - p_mean) * (t - t_mean);
        variance += (t - t_mean).powi(2);
    }
    let slope = covariance / variance;
    let at_t = |t: f64| Point3::from(p_mean + slope * (t - t_mean));
    (at_t(0.0), at_t(1.0))
}

/// Translating bones together shorter than this share of a stroke have no length to go by.
const ZERO_LENGTH_SHARE: f64 = 1e-3;

/// How much of a stroke `drawn` long each bone of `chain` covers: its rest length; but when
/// the chain's translating bones have next to none (a hip a clip drops from the body it
/// rests in), they share alike what the stroke has beyond the other bones.
fn drawn_lengths(setup: &Setup, chain: &[usize], drawn: f64) -> Vec<f64> {
    let bones = &setup.model.bones;
    let (mut turning, mut translating, mut translating_count) = (0.0, 0.0, 0usize);
    for &b in chain {
        if bones[b].tip_translates {
            translating += bones[b].length;
            translating_count += 1;
        } else {
            turning += bones[b].length;
        }
    }
    // A noisy stroke is longer than the path it follows: the rest lengths give the shares
    // whenever they can.
    if translating_count == 0 || translating > ZERO_LENGTH_SHARE * drawn.max(turning) {
        return chain.iter().map(|&b| bones[b].length).collect();
    }
    let slack = (drawn - turning).max(0.0);
    chain
        .iter()
        .map(|&b| match bones[b].tip_translates {
            false => bones[b].length,
            true => slack / translating_count as f64,
        })
        .collect()
}

/// For each model point on an assigned chain, the stroke point at the same fraction of
/// arclength (bone lengths give the model's fractions, [`drawn_lengths`]), with weight 1.
pub(super) fn arclength_targets(
    setup: &Setup,
    assignment: &[Assignment],
) -> Vec<Option<(Point3, f64)>> {
    let model = &setup.model;
    let mut targets = vec![None; model.points.len()];
    for (s, chain) in assignment.iter().enumerate() {
        let Some((chain, reversed)) = chain else {
            continue;
        };
        let mut stroke = setup.strokes.stroke(s).to_vec();
        if *reversed {
            stroke.reverse();
        }
        let cum = cumulative(&stroke);
        // The stroke now runs from the chain's root end to its tip.
        let lengths = drawn_lengths(setup, chain, *cum.last().unwrap_or(&0.0));
        let total: f64 = lengths.iter().sum();
        let mut before = 0.0;
        for (&b, &length) in chain.iter().zip(&lengths) {
            let bone = &model.bones[b];
            let span = (
                before / total.max(1e-12),
                (before + length) / total.max(1e-12),
            );
            // A translating bone's weight sits at its ends: each end goes where the straight
            // line fitted to its stretch of stroke puts it, not to one noisy stroke point.
            let fitted = bone
                .tip_translates
                .then(|| fitted_line(&stroke, &cum, span));
            for k in model.bone_points[b].clone() {
                let along = model.points[k].along;
                let target = match fitted {
                    Some((start, end)) => start + (end - start) * along,
                    None => at(&stroke, &cum, span.0 + along * (span.1 - span.0)),
                };
                targets[k] = Some((target, 1.0));
            }
            before += length;
        }
    }
    targets
}
