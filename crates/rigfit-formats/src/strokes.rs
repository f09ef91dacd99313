//! The strokes file (see `interfaces.md`, "Strokes file"):
//!
//! ```json
//! { "strokes": [ { "points": [[0.1, 1.2, 0.0], [0.12, 1.1, 0.01]] },
//!                { "points": [[0, 1, 0], [0, 2, 0]], "bones": ["LeftArm", "LeftForeArm"] } ] }
//! ```
//!
//! `bones` is optional (`null` counts as absent); unknown keys are ignored. Errors name the
//! place as a JSON path, e.g. `strokes[2].points[5]`, or the line and column of a syntax error.

use std::path::Path;

use rigfit_core::{Point3, Stroke};
use serde_json::Value;

use crate::error::{FormatError, ParseError, read_bytes, write_atomic};
use crate::json::parse_json;

/// Parses a strokes file. There must be at least one stroke, each with at least 2 points of
/// 3 finite numbers, and a `bones` list, when given, must name at least one bone.
pub fn parse_strokes(bytes: &[u8]) -> Result<Vec<Stroke>, ParseError> {
    strokes_from_json(&parse_json(bytes)?)
}

/// The strokes of a parsed strokes document (or of any JSON object with a `"strokes"` list,
/// such as a `rigfit serve` solve request), with the checks of [`parse_strokes`].
pub fn strokes_from_json(doc: &Value) -> Result<Vec<Stroke>, ParseError> {
    let Value::Object(top) = doc else {
        return Err(ParseError::new(
            "top level",
            "expected a JSON object with a \"strokes\" list",
        ));
    };
    let Some(list) = top.get("strokes") else {
        return Err(ParseError::new("top level", "missing \"strokes\""));
    };
    let Value::Array(list) = list else {
        return Err(ParseError::new("strokes", "expected a list of strokes"));
    };
    if list.is_empty() {
        return Err(ParseError::new("strokes", "no strokes"));
    }
    list.iter()
        .enumerate()
        .map(|(i, s)| parse_stroke(i, s))
        .collect()
}

fn parse_stroke(i: usize, value: &Value) -> Result<Stroke, ParseError> {
    let here = format!("strokes[{i}]");
    let Value::Object(obj) = value else {
        return Err(ParseError::new(
            here,
            "expected an object with a \"points\" list",
        ));
    };
    let Some(points) = obj.get("points") else {
        return Err(ParseError::new(here, "missing \"points\""));
    };
    let Value::Array(points) = points else {
        return Err(ParseError::new(
            format!("{here}.points"),
            "expected a list of [x, y, z] points",
        ));
    };
    let points = points
        .iter()
        .enumerate()
        .map(|(j, p)| parse_point(&format!("{here}.points[{j}]"), p))
        .collect::<Result<Vec<_>, _>>()?;
    if points.len() < 2 {
        return Err(ParseError::new(
            here,
            format!(
                "a stroke needs at least 2 points (this one has {})",
                points.len()
            ),
        ));
    }
    let bones = match obj.get("bones") {
        None | Some(Value::Null) => None,
        Some(Value::Array(names)) => {
            if names.is_empty() {
                return Err(ParseError::new(
                    format!("{here}.bones"),
                    "empty bones list (leave \"bones\" out to let the solver choose)",
                ));
            }
            let names = names
                .iter()
                .enumerate()
                .map(|(k, n)| match n {
                    Value::String(s) if !s.is_empty() => Ok(s.clone()),
                    Value::String(_) => Err(ParseError::new(
                        format!("{here}.bones[{k}]"),
                        "empty bone name",
                    )),
                    _ => Err(ParseError::new(
                        format!("{here}.bones[{k}]"),
                        "expected a bone name (a string)",
                    )),
                })
                .collect::<Result<Vec<_>, _>>()?;
            Some(names)
        }
        Some(_) => {
            return Err(ParseError::new(
                format!("{here}.bones"),
                "expected a list of bone names",
            ));
        }
    };
    Ok(Stroke { points, bones })
}

fn parse_point(place: &str, value: &Value) -> Result<Point3, ParseError> {
    let bad = || ParseError::new(place, "expected a point: a list of 3 numbers [x, y, z]");
    let Value::Array(xyz) = value else {
        return Err(bad());
    };
    let [x, y, z] = &xyz[..] else {
        return Err(bad());
    };
    let mut p = [0.0; 3];
    for (out, v) in p.iter_mut().zip([x, y, z]) {
        *out = v.as_f64().ok_or_else(bad)?;
        if let Some(problem) = crate::error::coordinate_problem(*out) {
            return Err(ParseError::new(place, problem));
        }
    }
    Ok(Point3::from(p))
}

/// Reads a strokes file, naming it in any error.
pub fn read_strokes(path: &Path) -> Result<Vec<Stroke>, FormatError> {
    let bytes = read_bytes(path)?;
    let _span = tracing::warn_span!("reading", file = %path.display()).entered();
    parse_strokes(&bytes).map_err(|e| FormatError::parse(path, e))
}

/// Writes a strokes file atomically.
pub fn write_strokes(path: &Path, strokes: &[Stroke]) -> Result<(), FormatError> {
    write_atomic(path, strokes_json(strokes).as_bytes())
}

/// The JSON text of a strokes file, one stroke per line. Numbers are written so they read
/// back exactly (a non-finite one becomes `null`, which the reader rejects).
pub fn strokes_json(strokes: &[Stroke]) -> String {
    let num = |x: f64| serde_json::to_string(&x).unwrap_or_else(|_| "null".into());
    let mut s = String::from("{\"strokes\": [");
    for (i, stroke) in strokes.iter().enumerate() {
        s.push_str(if i == 0 { "\n  " } else { ",\n  " });
        s.push_str("{\"points\": [");
        for (j, p) in stroke.points.iter().enumerate() {
            if j > 0 {
                s.push_str(", ");
            }
            s.push_str(&format!("[{}, {}, {}]", num(p.x), num(p.y), num(p.z)));
        }
        s.push(']');
        if let Some(bones) = &stroke.bones {
            s.push_str(", \"bones\": ");
            s.push_str(&serde_json::to_string(bones).unwrap_or_else(|_| "[]".into()));
        }
        s.push('}');
    }
    s.push_str(if strokes.is_empty() { "]}\n" } else { "\n]}\n" });
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn places_are_json_paths() {
        let e = parse_strokes(
            br#"{"strokes": [{"points": [[0,0,0],[1,1,1]]}, {"points": [[0,0,0],[1,"x",1]]}]}"#,
        )
        .expect_err("string coordinate");
        assert_eq!(e.place, "strokes[1].points[1]");
        let e = parse_strokes(br#"{"strokes": [{"points": [[0,0,0]]}]}"#).expect_err("one");
        assert_eq!(
            e.to_string(),
            "strokes[0]: a stroke needs at least 2 points (this one has 1)"
        );
    }

    #[test]
    fn syntax_errors_have_line_and_column() {
        let e = parse_strokes(b"{\n  \"strokes\": [,]\n}").expect_err("syntax");
        assert!(e.place.starts_with("line 2, column"), "{e}");
        assert!(!e.to_string().contains('\n'));
        let e = parse_strokes(b"{\"strokes\": [{\"points\": [[NaN, 0, 0]]}]}").expect_err("nan");
        assert!(e.problem.contains("NaN"), "{e}");
        let e =
            parse_strokes(b"{\"strokes\": [{\"points\": [[0, -Infinity, 0]]}]}").expect_err("inf");
        assert!(e.problem.contains("finite"), "{e}");
    }

    #[test]
    fn bones_null_is_absent() {
        let s = parse_strokes(
            br#"{"strokes": [{"points": [[0,0,0],[1,1,1]], "bones": null, "x": 1}], "v": 2}"#,
        )
        .expect("parses");
        assert_eq!(s[0].bones, None);
    }
}
