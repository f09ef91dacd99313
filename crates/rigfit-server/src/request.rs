//! Reading the JSON of solve and export requests: every problem is one
//! `PLACE: PROBLEM` line (a JSON path such as `pose.joints[2].rotation`), like the
//! command line's readers. Requests are bounded ([`Limits`]) so that none makes the server
//! allocate or compute without bound: strokes, points, names, joints of a pose, and how far
//! a pose may move or scale a joint.

use rigfit_core::animation::quat_from_xyzw;
use rigfit_core::{Pose, Rig, Skeleton, Vector3};
use rigfit_formats::ParseError;
use serde_json::{Map, Value};

/// The most strokes one solve request may hold.
pub const MAX_STROKES: usize = 200;
/// The most points one stroke may hold.
pub const MAX_STROKE_POINTS: usize = 10_000;
/// The most points all the strokes of one solve request may hold together.
pub const MAX_POINTS: usize = 50_000;
/// How far a pose may put a joint from its parent (or a root from the origin), in character
/// heights (or in the largest distance the character's own file uses, if larger).
pub const MAX_TRANSLATION_HEIGHTS: f64 = 1_000.0;
/// The largest scale a pose may give a joint (in absolute value, per axis).
pub const MAX_SCALE: f64 = 1_000.0;

/// The bounds of one request on one character.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// The character's joint count: the most joints a pose or a list of names may hold.
    pub joints: usize,
    /// The longest translation a pose may give a joint.
    pub max_translation: f64,
}

impl Limits {
    pub fn for_rig(rig: &Rig) -> Self {
        let file_scale = rig
            .skeleton
            .joints()
            .iter()
            .map(|j| j.rest.translation.norm())
            .chain(rig.pose.local.iter().map(|t| t.translation.norm()))
            .filter(|d| d.is_finite())
            .fold(rig.height(), f64::max);
        Self {
            joints: rig.skeleton.len(),
            max_translation: MAX_TRANSLATION_HEIGHTS * file_scale.max(1e-3),
        }
    }
}

/// Checks the sizes of a solve request's `strokes` before they are read: at most
/// [`MAX_STROKES`] strokes, [`MAX_STROKE_POINTS`] points each, [`MAX_POINTS`] in all, and no
/// more bone names per stroke than the character has joints. Shapes are left to the reader.
pub fn check_strokes(doc: &Value, limits: &Limits) -> Result<(), ParseError> {
    let Some(Value::Array(strokes)) = doc.get("strokes") else {
        return Ok(());
    };
    if strokes.len() > MAX_STROKES {
        return Err(ParseError::new(
            "strokes",
            format!(
                "{} strokes: a request may hold at most {MAX_STROKES}",
                strokes.len()
            ),
        ));
    }
    let mut total = 0usize;
    for (i, stroke) in strokes.iter().enumerate() {
        if let Some(Value::Array(points)) = stroke.get("points") {
            if points.len() > MAX_STROKE_POINTS {
                return Err(ParseError::new(
                    format!("strokes[{i}].points"),
                    format!(
                        "{} points: a stroke may hold at most {MAX_STROKE_POINTS}",
                        points.len()
                    ),
                ));
            }
            total += points.len();
            if total > MAX_POINTS {
                return Err(ParseError::new(
                    format!("strokes[{i}].points"),
                    format!("more than {MAX_POINTS} points in all the strokes of one request"),
                ));
            }
        }
        if let Some(Value::Array(bones)) = stroke.get("bones") {
            check_count(
                &format!("strokes[{i}].bones"),
                bones.len(),
                limits.joints,
                "names",
            )?;
        }
    }
    Ok(())
}

/// `count` items of `what` against the character's joint count.
fn check_count(place: &str, count: usize, joints: usize, what: &str) -> Result<(), ParseError> {
    if count > joints {
        return Err(ParseError::new(
            place,
            format!("{count} {what}: more than the character has joints ({joints})"),
        ));
    }
    Ok(())
}

/// The request's top-level object.
pub fn object(doc: &Value) -> Result<&Map<String, Value>, ParseError> {
    doc.as_object()
        .ok_or_else(|| ParseError::new("top level", "expected a JSON object"))
}

/// An optional field: `None` when absent or `null`.
pub fn optional<'a>(obj: &'a Map<String, Value>, key: &str) -> Option<&'a Value> {
    obj.get(key).filter(|v| !v.is_null())
}

/// `N` finite numbers.
fn numbers<const N: usize>(place: &str, value: &Value) -> Result<[f64; N], ParseError> {
    let bad = || ParseError::new(place, format!("expected a list of {N} numbers"));
    let list = value.as_array().ok_or_else(bad)?;
    if list.len() != N {
        return Err(bad());
    }
    let mut out = [0.0; N];
    for (o, v) in out.iter_mut().zip(list) {
        *o = v.as_f64().ok_or_else(bad)?;
        if !o.is_finite() {
            return Err(ParseError::new(
                place,
                "coordinate is not a finite number (NaN or infinity)",
            ));
        }
    }
    Ok(out)
}

/// A list of names (strings), at most one per joint of the character.
pub fn names(place: &str, value: &Value, limits: &Limits) -> Result<Vec<String>, ParseError> {
    let list = value
        .as_array()
        .ok_or_else(|| ParseError::new(place, "expected a list of joint names"))?;
    check_count(place, list.len(), limits.joints, "names")?;
    list.iter()
        .enumerate()
        .map(|(k, v)| {
            v.as_str()
                .map(str::to_string)
                .ok_or_else(|| ParseError::new(format!("{place}[{k}]"), "expected a name"))
        })
        .collect()
}

/// A pose `{"joints": [{"name", "translation"?, "rotation"?, "scale"?}, ...]}` over
/// `stored`: joints not listed (and parts not given) keep their stored local transform.
/// `place` is the pose's JSON path. At most one entry per joint; translations and scales
/// within `limits`.
pub fn pose(
    place: &str,
    value: &Value,
    skeleton: &Skeleton,
    stored: &Pose,
    limits: &Limits,
) -> Result<Pose, ParseError> {
    let obj = value
        .as_object()
        .ok_or_else(|| ParseError::new(place, "expected an object with a \"joints\" list"))?;
    let joints = match optional(obj, "joints") {
        None => return Ok(stored.clone()),
        Some(j) => j.as_array().ok_or_else(|| {
            ParseError::new(format!("{place}.joints"), "expected a list of joints")
        })?,
    };
    check_count(
        &format!("{place}.joints"),
        joints.len(),
        limits.joints,
        "joints",
    )?;
    let mut pose = stored.clone();
    for (i, joint) in joints.iter().enumerate() {
        let here = format!("{place}.joints[{i}]");
        let fields = joint
            .as_object()
            .ok_or_else(|| ParseError::new(&here, "expected an object with a \"name\""))?;
        let name = fields
            .get("name")
            .and_then(Value::as_str)
            .ok_or_else(|| ParseError::new(format!("{here}.name"), "expected a joint name"))?;
        let index = skeleton.find(name).ok_or_else(|| {
            ParseError::new(format!("{here}.name"), format!("unknown joint '{name}'"))
        })?;
        let local = &mut pose.local[index];
        if let Some(t) = optional(fields, "translation") {
            let place = format!("{here}.translation");
            let t = Vector3::from(numbers::<3>(&place, t)?);
            if t.norm() > limits.max_translation {
                return Err(ParseError::new(
                    place,
                    format!(
                        "{:.3e} from the parent: more than {MAX_TRANSLATION_HEIGHTS} times the character's size ({:.3e})",
                        t.norm(),
                        limits.max_translation
                    ),
                ));
            }
            local.translation = t;
        }
        if let Some(r) = optional(fields, "rotation") {
            let place = format!("{here}.rotation");
            let q = numbers::<4>(&place, r)?;
            let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            if !(norm > 1e-9 && norm.is_finite()) {
                return Err(ParseError::new(
                    place,
                    "not a rotation: the quaternion [x, y, z, w] has no length",
                ));
            }
            local.rotation = quat_from_xyzw(q);
        }
        if let Some(s) = optional(fields, "scale") {
            let place = format!("{here}.scale");
            let s = numbers::<3>(&place, s)?;
            if s.iter().any(|x| x.abs() > MAX_SCALE) {
                return Err(ParseError::new(
                    place,
                    format!("a scale over {MAX_SCALE} (in absolute value)"),
                ));
            }
            local.scale = Vector3::from(s);
        }
    }
    Ok(pose)
}

/// A non-negative whole number.
pub fn whole_number(place: &str, value: &Value) -> Result<u64, ParseError> {
    value
        .as_u64()
        .ok_or_else(|| ParseError::new(place, "expected a whole number (0 or more)"))
}

/// A positive finite number.
pub fn positive_number(place: &str, value: &Value) -> Result<f64, ParseError> {
    value
        .as_f64()
        .filter(|x| x.is_finite() && *x > 0.0)
        .ok_or_else(|| ParseError::new(place, "expected a positive number"))
}

/// One of the given words.
pub fn word<'a>(place: &str, value: &'a Value, choices: &[&str]) -> Result<&'a str, ParseError> {
    value
        .as_str()
        .filter(|s| choices.contains(s))
        .ok_or_else(|| {
            ParseError::new(
                place,
                format!(
                    "expected one of {}",
                    choices
                        .iter()
                        .map(|c| format!("\"{c}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
        })
}
