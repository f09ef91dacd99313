//! glTF animations: the channels that move skeleton joints, with their key times and
//! values.

use rigfit_core::{Animation, AnimationChannel, ChannelTarget, Interpolation};
use serde_json::Value;

use super::accessor::{index_field, read_accessor_as, required_index};
use crate::error::{ParseError, coordinate_problem};

pub(super) fn read_animations(
    json: &Value,
    buffers: &[Vec<u8>],
    local_of_node: &[usize],
    new_index: &[usize],
) -> Result<Vec<Animation>, ParseError> {
    let anims = json
        .get("animations")
        .and_then(Value::as_array)
        .map(Vec::as_slice)
        .unwrap_or(&[]);
    let mut out = Vec::with_capacity(anims.len());
    for (a, anim) in anims.iter().enumerate() {
        let path = format!("animations[{a}]");
        let samplers = anim
            .get("samplers")
            .and_then(Value::as_array)
            .map(Vec::as_slice)
            .unwrap_or(&[]);
        let mut animation = Animation {
            name: anim
                .get("name")
                .and_then(Value::as_str)
                .map_or_else(|| format!("animation{a}"), str::to_owned),
            ..Default::default()
        };
        let channels = anim
            .get("channels")
            .and_then(Value::as_array)
            .map(Vec::as_slice)
            .unwrap_or(&[]);
        for (c, ch) in channels.iter().enumerate() {
            let cpath = format!("{path}.channels[{c}]");
            let target = ch
                .get("target")
                .ok_or_else(|| ParseError::new(&cpath, "missing 'target'"))?;
            let Some(node) = index_field(target, "node", &format!("{cpath}.target"))? else {
                continue;
            };
            let Some(&local) = local_of_node.get(node).filter(|&&l| l != usize::MAX) else {
                continue;
            };
            let target_kind = match target.get("path").and_then(Value::as_str) {
                Some("translation") => ChannelTarget::Translation,
                Some("rotation") => ChannelTarget::Rotation,
                Some("scale") => ChannelTarget::Scale,
                _ => continue, // morph weights and extensions do not move joints
            };
            let s = required_index(ch, "sampler", &cpath)?;
            let spath = format!("{path}.samplers[{s}]");
            let sampler = samplers
                .get(s)
                .ok_or_else(|| ParseError::new(&cpath, format!("sampler {s} does not exist")))?;
            let interpolation = match sampler
                .get("interpolation")
                .and_then(Value::as_str)
                .unwrap_or("LINEAR")
            {
                "STEP" => Interpolation::Step,
                "CUBICSPLINE" => Interpolation::CubicSpline,
                _ => Interpolation::Linear,
            };
            let times = read_accessor_as(
                json,
                buffers,
                required_index(sampler, "input", &spath)?,
                1,
                &format!("{spath}.input"),
            )?;
            if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[1] < w[0]) {
                return Err(ParseError::new(
                    format!("{spath}.input"),
                    "key times must be finite and increasing",
                ));
            }
            let width = if target_kind == ChannelTarget::Rotation {
                4
            } else {
                3
            };
            let raw = read_accessor_as(
                json,
                buffers,
                required_index(sampler, "output", &spath)?,
                width,
                &format!("{spath}.output"),
            )?;
            let per_key = if interpolation == Interpolation::CubicSpline {
                3
            } else {
                1
            };
            if raw.len() != times.len() * per_key * width {
                return Err(ParseError::new(
                    format!("{spath}.output"),
                    format!("has {} values for {} keys", raw.len() / width, times.len()),
                ));
            }
            let problem = if width == 3 {
                raw.iter().find_map(|&v| coordinate_problem(v))
            } else {
                raw.iter()
                    .any(|v| !v.is_finite())
                    .then(|| "values are not finite".to_string())
            };
            if let Some(problem) = problem {
                return Err(ParseError::new(format!("{spath}.output"), problem));
            }
            let values = raw
                .chunks(width)
                .map(|v| {
                    if width == 4 {
                        // Scaled by the largest component, so that normalising it later
                        // cannot overflow (cubic-spline tangents are kept as they are).
                        let largest = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                        let k = if per_key == 1 && largest > 1.0 {
                            largest
                        } else {
                            1.0
                        };
                        [v[0] / k, v[1] / k, v[2] / k, v[3] / k]
                    } else {
                        [v[0], v[1], v[2], 0.0]
                    }
                })
                .collect::<Vec<[f64; 4]>>();
            animation.channels.push(AnimationChannel {
                joint: new_index[local],
                target: target_kind,
                interpolation,
                times,
                values,
            });
        }
        out.push(animation);
    }
    Ok(out)
}
