//! The joints file (`--joints FILE`): what each named joint of a rig may do, overriding
//! what rigfit learns from the rig's clips.
//!
//! ```json
//! { "joints": {
//!     "LeftLeg":  { "dof": "hinge", "axis": [1, 0, 0], "min": -0.1, "max": 2.6 },
//!     "LeftArm":  { "dof": "ball", "min": [-1.5, -1.0, -1.6], "max": [1.5, 1.2, 1.6] },
//!     "Spine":    { "dof": "ball" },
//!     "Lift":     { "dof": "free", "translation": { "min": [0, 0, 0], "max": [0, 0, 0.39] } },
//!     "Jaw":      { "dof": "fixed" } } }
//! ```
//!
//! Angles are radians, relative to the joint's rest (bind) rotation: a ball's `min` and
//! `max` bound the rotation vector (axis times angle) of `rest^-1 * rotation` per axis of
//! the joint's own frame; a hinge's bound the signed angle about its `axis` (in the joint's
//! frame). Limits are optional (a joint without them turns freely); `dof` is one of
//! `hinge`, `ball`, `free` (translates too) and `fixed`. A free joint's optional
//! `translation` bounds its local translation, in the rig's units, from its rest translation
//! (a robot's slide joint: the box its range sweeps). Joints not listed keep what the clips
//! show. Unknown keys are ignored.

use std::path::Path;

use rigfit_core::joint_model::JointSpec;
use rigfit_core::{JointDof, JointLimits, Skeleton, Vector3};
use serde_json::{Map, Value};

use crate::error::{FormatError, ParseError, read_bytes};
use crate::json::parse_json;

/// Reads a joints file for `skeleton`: one entry per joint (`None` for joints not listed).
pub fn read_joints_file(
    path: &Path,
    skeleton: &Skeleton,
) -> Result<Vec<Option<JointSpec>>, FormatError> {
    let bytes = read_bytes(path)?;
    parse_joints(&bytes, skeleton).map_err(|e| FormatError::parse(path, e))
}

/// Parses a joints file for `skeleton` (every name must be one of its joints).
pub fn parse_joints(
    bytes: &[u8],
    skeleton: &Skeleton,
) -> Result<Vec<Option<JointSpec>>, ParseError> {
    let doc = parse_json(bytes)?;
    let Value::Object(top) = doc else {
        return Err(ParseError::new(
            "top level",
            "expected a JSON object with a \"joints\" object",
        ));
    };
    let Some(joints) = top.get("joints") else {
        return Err(ParseError::new("top level", "missing \"joints\""));
    };
    let Value::Object(joints) = joints else {
        return Err(ParseError::new(
            "joints",
            "expected an object from joint names to what each may do",
        ));
    };
    let mut model = vec![None; skeleton.len()];
    for (name, entry) in joints {
        let here = format!("joints.{name}");
        let Some(j) = skeleton.find(name) else {
            return Err(ParseError::new(here, "the rig has no joint of that name"));
        };
        let Value::Object(entry) = entry else {
            return Err(ParseError::new(here, "expected an object with a \"dof\""));
        };
        model[j] = Some(parse_spec(&here, entry)?);
    }
    Ok(model)
}

fn parse_spec(here: &str, entry: &Map<String, Value>) -> Result<JointSpec, ParseError> {
    let dof = match entry.get("dof").and_then(Value::as_str) {
        Some("hinge") => {
            let axis = vector(&format!("{here}.axis"), entry.get("axis"))?
                .ok_or_else(|| ParseError::new(here, "a hinge needs an \"axis\" [x, y, z]"))?;
            let axis = axis
                .try_normalize(1e-12)
                .ok_or_else(|| ParseError::new(format!("{here}.axis"), "the axis has no length"))?;
            JointDof::Hinge { axis }
        }
        Some("ball") => JointDof::Ball,
        Some("free") => JointDof::Free,
        Some("fixed") => JointDof::Fixed,
        _ => {
            return Err(ParseError::new(
                format!("{here}.dof"),
                "expected \"hinge\", \"ball\", \"free\" or \"fixed\"",
            ));
        }
    };
    let bound = |key: &str| -> Result<Option<Vector3>, ParseError> {
        let place = format!("{here}.{key}");
        match (dof, entry.get(key)) {
            (_, None | Some(Value::Null)) => Ok(None),
            (JointDof::Hinge { .. }, Some(v)) => {
                let angle = v.as_f64().filter(|a| a.is_finite()).ok_or_else(|| {
                    ParseError::new(&place, "expected an angle in radians (a number)")
                })?;
                Ok(Some(Vector3::new(angle, 0.0, 0.0)))
            }
            (JointDof::Ball | JointDof::Free, v) => vector(&place, v),
            (JointDof::Fixed, Some(_)) => {
                Err(ParseError::new(place, "a fixed joint has no limits"))
            }
        }
    };
    let limits = match (bound("min")?, bound("max")?) {
        (None, None) => None,
        (Some(min), Some(max)) => {
            if let Some(a) = (0..3).find(|&a| min[a] > max[a]) {
                return Err(ParseError::new(
                    here,
                    format!("min is above max (axis {a}: {} > {})", min[a], max[a]),
                ));
            }
            Some(JointLimits { min, max })
        }
        _ => {
            return Err(ParseError::new(
                here,
                "give both \"min\" and \"max\", or neither",
            ));
        }
    };
    let translation = match entry.get("translation") {
        None | Some(Value::Null) => None,
        Some(Value::Object(t)) if dof == JointDof::Free => {
            let place = format!("{here}.translation");
            let min = vector(&format!("{place}.min"), t.get("min"))?;
            let max = vector(&format!("{place}.max"), t.get("max"))?;
            let (Some(min), Some(max)) = (min, max) else {
                return Err(ParseError::new(place, "give both \"min\" and \"max\""));
            };
            if let Some(a) = (0..3).find(|&a| min[a] > max[a]) {
                return Err(ParseError::new(
                    place,
                    format!("min is above max (axis {a}: {} > {})", min[a], max[a]),
                ));
            }
            Some(JointLimits { min, max })
        }
        Some(Value::Object(_)) => {
            return Err(ParseError::new(
                format!("{here}.translation"),
                "only a \"free\" joint translates",
            ));
        }
        Some(_) => {
            return Err(ParseError::new(
                format!("{here}.translation"),
                "expected {\"min\": [x, y, z], \"max\": [x, y, z]}",
            ));
        }
    };
    Ok(JointSpec {
        dof,
        limits,
        translation,
    })
}

/// An optional `[x, y, z]` of finite numbers.
fn vector(place: &str, value: Option<&Value>) -> Result<Option<Vector3>, ParseError> {
    let bad = || ParseError::new(place, "expected a list of 3 numbers [x, y, z]");
    match value {
        None | Some(Value::Null) => Ok(None),
        Some(Value::Array(xyz)) if xyz.len() == 3 => {
            let mut v = Vector3::zeros();
            for (a, x) in xyz.iter().enumerate() {
                v[a] = x.as_f64().filter(|x| x.is_finite()).ok_or_else(bad)?;
            }
            Ok(Some(v))
        }
        Some(_) => Err(bad()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rigfit_core::{Joint, Quat, Trs};

    fn skeleton() -> Skeleton {
        let bone = Trs::new(Vector3::new(0.0, 1.0, 0.0), Quat::identity());
        Skeleton::new(vec![
            Joint::new("Hips", None, bone),
            Joint::new("Knee", Some(0), bone),
            Joint::new("Ankle", Some(1), bone),
        ])
        .expect("parents come first")
    }

    #[test]
    fn reads_hinges_balls_and_fixed_joints() {
        let text = br#"{"joints": {
            "Knee": {"dof": "hinge", "axis": [2, 0, 0], "min": -0.1, "max": 2.5},
            "Ankle": {"dof": "ball", "min": [-1, -0.5, -0.2], "max": [1, 0.5, 0.2]},
            "Hips": {"dof": "fixed"}}}"#;
        let model = parse_joints(text, &skeleton()).expect("a good joints file");
        assert_eq!(model[0].expect("hips").dof, JointDof::Fixed);
        let knee = model[1].expect("knee");
        assert_eq!(knee.dof, JointDof::Hinge { axis: Vector3::x() });
        assert_eq!(knee.limits.expect("knee limits").max.x, 2.5);
        assert_eq!(
            model[2].expect("ankle").limits.expect("ankle limits").min.y,
            -0.5
        );
    }

    #[test]
    fn names_the_place_of_each_problem() {
        let s = skeleton();
        let err = |t: &str| {
            parse_joints(t.as_bytes(), &s)
                .expect_err("a bad joints file")
                .to_string()
        };
        assert_eq!(
            err(r#"{"joints": {"Tail": {"dof": "ball"}}}"#),
            "joints.Tail: the rig has no joint of that name"
        );
        assert!(err(r#"{"joints": {"Knee": {"dof": "slide"}}}"#).starts_with("joints.Knee.dof:"));
        assert!(err(r#"{"joints": {"Knee": {"dof": "hinge"}}}"#).contains("needs an \"axis\""));
        assert!(
            err(r#"{"joints": {"Knee": {"dof": "hinge", "axis": [1,0,0], "min": 1, "max": 0}}}"#)
                .contains("min is above max")
        );
        assert!(
            err(r#"{"joints": {"Knee": {"dof": "ball", "min": [0,0,0]}}}"#).contains("neither")
        );
        assert!(err(r#"{"joint": {}}"#).contains("missing \"joints\""));
        assert!(
            err(r#"{"joints": {"Knee": {"dof": "ball", "translation": {"min": [0,0,0], "max": [0,0,1]}}}}"#)
                .starts_with("joints.Knee.translation: only a \"free\" joint")
        );
        assert!(
            err(r#"{"joints": {"Knee": {"dof": "free", "translation": {"min": [0,0,1], "max": [0,0,0]}}}}"#)
                .contains("min is above max")
        );
    }

    #[test]
    fn a_free_joint_keeps_its_translation_box_from_rest() {
        let text = br#"{"joints": {"Knee": {"dof": "free", "translation": {"min": [0, 0, 0], "max": [0, 0.5, 0]}}}}"#;
        let mut s = skeleton();
        let model = parse_joints(text, &s).expect("a good joints file");
        assert_eq!(
            model[1].expect("knee").translation.expect("a box").max,
            Vector3::new(0.0, 0.5, 0.0)
        );
        rigfit_core::joint_model::apply_joint_model(&mut s, &model);
        // The knee's rest translation is one up: the box is from there.
        let limits = s.joint(1).translation_limits.expect("set");
        assert_eq!(limits.min, Vector3::new(0.0, 1.0, 0.0));
        assert_eq!(limits.max, Vector3::new(0.0, 1.5, 0.0));
    }
}
