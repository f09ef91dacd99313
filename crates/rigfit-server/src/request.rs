//! Reading the JSON of solve and export requests: every problem is one
//! `PLACE: PROBLEM` line (a JSON path such as `pose.joints[2].rotation`), like the
//! command line's readers.

use rigfit_core::animation::quat_from_xyzw;
use rigfit_core::{Pose, Skeleton, Vector3};
use rigfit_formats::ParseError;
use serde_json::{Map, Value};

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

/// A list of names (strings).
pub fn names(place: &str, value: &Value) -> Result<Vec<String>, ParseError> {
    let list = value
        .as_array()
        .ok_or_else(|| ParseError::new(place, "expected a list of joint names"))?;
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
/// `place` is the pose's JSON path.
pub fn pose(
    place: &str,
    value: &Value,
    skeleton: &Skeleton,
    stored: &Pose,
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
            local.translation = Vector3::from(numbers::<3>(&format!("{here}.translation"), t)?);
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
            local.scale = Vector3::from(numbers::<3>(&format!("{here}.scale"), s)?);
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
