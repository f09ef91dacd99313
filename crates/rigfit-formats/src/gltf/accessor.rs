//! Reading and writing glTF accessors: typed views into buffers (glTF 2.0 section 3.6),
//! with every offset and length checked against the buffer it points into.

use serde_json::{Value, json};

use crate::error::ParseError;

/// The largest accessor rigfit reads, in scalar components. Accessors with a buffer view
/// are also bounded by the bytes really there (checked before allocating).
const MAX_COMPONENTS: usize = 1 << 28;
/// The largest accessor without a buffer view (all zeros, possibly with sparse values): a
/// guard against a few bytes of JSON asking for gigabytes.
const MAX_VIEWLESS_COMPONENTS: usize = 1 << 22;

/// A JSON field as an index or count.
pub(crate) fn index_field(obj: &Value, key: &str, path: &str) -> Result<Option<usize>, ParseError> {
    match obj.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(v) => v
            .as_u64()
            .and_then(|n| usize::try_from(n).ok())
            .map(Some)
            .ok_or_else(|| {
                ParseError::new(format!("{path}.{key}"), "expected a non-negative integer")
            }),
    }
}

/// A required index field.
pub(crate) fn required_index(obj: &Value, key: &str, path: &str) -> Result<usize, ParseError> {
    index_field(obj, key, path)?.ok_or_else(|| ParseError::new(path, format!("missing '{key}'")))
}

/// The `i`th element of a top-level array such as `accessors`.
pub(crate) fn element<'a>(
    json: &'a Value,
    array: &str,
    i: usize,
    from: &str,
) -> Result<&'a Value, ParseError> {
    json.get(array).and_then(|a| a.get(i)).ok_or_else(|| {
        ParseError::new(
            from,
            format!("refers to {array}[{i}], which does not exist"),
        )
    })
}

fn components_of(ty: &str) -> Option<usize> {
    Some(match ty {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" => 4,
        "MAT2" => 4,
        "MAT3" => 9,
        "MAT4" => 16,
        _ => return None,
    })
}

fn component_size(component_type: u64) -> Option<usize> {
    Some(match component_type {
        5120 | 5121 => 1,
        5122 | 5123 => 2,
        5125 | 5126 => 4,
        _ => return None,
    })
}

fn read_component(bytes: &[u8], component_type: u64, normalized: bool) -> f64 {
    match component_type {
        5120 => {
            let v = bytes[0] as i8 as f64;
            if normalized { (v / 127.0).max(-1.0) } else { v }
        }
        5121 => {
            let v = bytes[0] as f64;
            if normalized { v / 255.0 } else { v }
        }
        5122 => {
            let v = i16::from_le_bytes([bytes[0], bytes[1]]) as f64;
            if normalized {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }
        5123 => {
            let v = u16::from_le_bytes([bytes[0], bytes[1]]) as f64;
            if normalized { v / 65535.0 } else { v }
        }
        5125 => u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
        _ => f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
    }
}

/// How an accessor's elements are stored: values per element, their component type,
/// whether integers are normalised, and the columns of a matrix type.
#[derive(Debug, Clone, Copy)]
struct ElementLayout {
    components: usize,
    component_type: u64,
    normalized: bool,
    matrix_columns: Option<usize>,
}

/// Reads `count` elements laid out as `layout` from a buffer view.
fn read_view(
    json: &Value,
    buffers: &[Vec<u8>],
    view_index: usize,
    byte_offset: usize,
    count: usize,
    layout: ElementLayout,
    path: &str,
) -> Result<Vec<f64>, ParseError> {
    let ElementLayout {
        components,
        component_type,
        normalized,
        matrix_columns,
    } = layout;
    let view_path = format!("bufferViews[{view_index}]");
    let view = element(json, "bufferViews", view_index, path)?;
    let buffer_index = required_index(view, "buffer", &view_path)?;
    let buffer = buffers.get(buffer_index).ok_or_else(|| {
        ParseError::new(
            &view_path,
            format!("refers to buffers[{buffer_index}], which does not exist"),
        )
    })?;
    let view_offset = index_field(view, "byteOffset", &view_path)?.unwrap_or(0);
    let view_length = required_index(view, "byteLength", &view_path)?;
    let view_end = view_offset
        .checked_add(view_length)
        .filter(|&e| e <= buffer.len())
        .ok_or_else(|| {
            ParseError::new(
                &view_path,
                format!(
                    "byteOffset {view_offset} + byteLength {view_length} is past the end of buffers[{buffer_index}] ({} bytes)",
                    buffer.len()
                ),
            )
        })?;
    let size = component_size(component_type).unwrap_or(4);
    // Matrices of 1- and 2-byte components have padded columns (glTF 2.0 section 3.6.2.4).
    let (rows, cols) = match matrix_columns {
        Some(n) if size < 4 => (n, n),
        _ => (components, 1),
    };
    let column_stride = (rows * size).div_ceil(4) * 4;
    let element_size = if cols > 1 {
        column_stride * cols
    } else {
        components * size
    };
    let stride = index_field(view, "byteStride", &view_path)?
        .unwrap_or(element_size)
        .max(element_size);
    if count == 0 {
        return Ok(Vec::new());
    }
    let start = view_offset.saturating_add(byte_offset);
    let last = (count - 1)
        .checked_mul(stride)
        .and_then(|s| s.checked_add(start))
        .and_then(|s| s.checked_add(element_size));
    match last {
        Some(end) if end <= view_end => {}
        _ => {
            return Err(ParseError::new(
                path,
                format!(
                    "{count} elements of {element_size} bytes (stride {stride}) from byte {byte_offset} run past the end of bufferViews[{view_index}] ({view_length} bytes)"
                ),
            ));
        }
    }
    let mut out = Vec::with_capacity(count * components);
    for e in 0..count {
        let base = start + e * stride;
        for c in 0..cols {
            for r in 0..rows {
                let at = base + c * if cols > 1 { column_stride } else { 0 } + r * size;
                out.push(read_component(
                    &buffer[at..at + size],
                    component_type,
                    normalized,
                ));
            }
        }
    }
    Ok(out)
}

/// Reads accessor `index` as flat `f64` values; returns them and the components per element.
pub(crate) fn read_accessor(
    json: &Value,
    buffers: &[Vec<u8>],
    index: usize,
    from: &str,
) -> Result<(Vec<f64>, usize), ParseError> {
    let path = format!("accessors[{index}]");
    let acc = element(json, "accessors", index, from)?;
    let count = required_index(acc, "count", &path)?;
    let ty = acc.get("type").and_then(Value::as_str).unwrap_or("");
    let components =
        components_of(ty).ok_or_else(|| ParseError::new(&path, format!("unknown type '{ty}'")))?;
    let component_type = acc
        .get("componentType")
        .and_then(Value::as_u64)
        .unwrap_or(0);
    if component_size(component_type).is_none() {
        return Err(ParseError::new(
            &path,
            format!("unknown componentType {component_type}"),
        ));
    }
    if count.saturating_mul(components) > MAX_COMPONENTS {
        return Err(ParseError::new(
            &path,
            format!("count {count} is too large"),
        ));
    }
    let normalized = acc
        .get("normalized")
        .and_then(Value::as_bool)
        .unwrap_or(false);
    let byte_offset = index_field(acc, "byteOffset", &path)?.unwrap_or(0);
    let matrix_columns = match ty {
        "MAT2" => Some(2),
        "MAT3" => Some(3),
        "MAT4" => Some(4),
        _ => None,
    };
    let layout = ElementLayout {
        components,
        component_type,
        normalized,
        matrix_columns,
    };
    let mut values = match index_field(acc, "bufferView", &path)? {
        Some(view) => read_view(json, buffers, view, byte_offset, count, layout, &path)?,
        None => {
            if count * components > MAX_VIEWLESS_COMPONENTS {
                return Err(ParseError::new(
                    &path,
                    format!("count {count} is too large for an accessor without a bufferView"),
                ));
            }
            vec![0.0; count * components]
        }
    };
    if let Some(sparse) = acc.get("sparse") {
        let sp = format!("{path}.sparse");
        let n = required_index(sparse, "count", &sp)?;
        let idx = sparse
            .get("indices")
            .ok_or_else(|| ParseError::new(&sp, "missing 'indices'"))?;
        let val = sparse
            .get("values")
            .ok_or_else(|| ParseError::new(&sp, "missing 'values'"))?;
        let idx_type = idx
            .get("componentType")
            .and_then(Value::as_u64)
            .unwrap_or(0);
        if !matches!(idx_type, 5121 | 5123 | 5125) {
            return Err(ParseError::new(
                format!("{sp}.indices"),
                "componentType must be an unsigned integer",
            ));
        }
        let indices = read_view(
            json,
            buffers,
            required_index(idx, "bufferView", &sp)?,
            index_field(idx, "byteOffset", &sp)?.unwrap_or(0),
            n,
            ElementLayout {
                components: 1,
                component_type: idx_type,
                normalized: false,
                matrix_columns: None,
            },
            &format!("{sp}.indices"),
        )?;
        let replacement = read_view(
            json,
            buffers,
            required_index(val, "bufferView", &sp)?,
            index_field(val, "byteOffset", &sp)?.unwrap_or(0),
            n,
            layout,
            &format!("{sp}.values"),
        )?;
        for (k, &i) in indices.iter().enumerate() {
            let i = i as usize;
            if i >= count {
                return Err(ParseError::new(
                    format!("{sp}.indices"),
                    format!("index {i} is out of range (count {count})"),
                ));
            }
            values[i * components..(i + 1) * components]
                .copy_from_slice(&replacement[k * components..(k + 1) * components]);
        }
    }
    Ok((values, components))
}

/// Reads an accessor that must have `components` values per element.
pub(crate) fn read_accessor_as(
    json: &Value,
    buffers: &[Vec<u8>],
    index: usize,
    components: usize,
    from: &str,
) -> Result<Vec<f64>, ParseError> {
    let (values, c) = read_accessor(json, buffers, index, from)?;
    if c != components {
        return Err(ParseError::new(
            format!("accessors[{index}]"),
            format!("has {c} components per element where {from} needs {components}"),
        ));
    }
    Ok(values)
}

/// Appends typed data to a binary buffer and describes it with buffer views and accessors.
#[derive(Debug)]
pub(crate) struct AccessorWriter<'a> {
    pub json: &'a mut Value,
    pub buffer_index: usize,
    pub bytes: &'a mut Vec<u8>,
}

impl AccessorWriter<'_> {
    fn push_view(&mut self, data: &[u8], target: Option<u32>) -> usize {
        while self.bytes.len() % 4 != 0 {
            self.bytes.push(0);
        }
        let offset = self.bytes.len();
        self.bytes.extend_from_slice(data);
        let mut view =
            json!({ "buffer": self.buffer_index, "byteOffset": offset, "byteLength": data.len() });
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        push(self.json, "bufferViews", view)
    }

    /// Adds a float accessor of the given type (`VEC3`, `MAT4`, ...), with min/max when asked.
    pub fn floats(
        &mut self,
        values: &[f64],
        ty: &str,
        with_bounds: bool,
        target: Option<u32>,
    ) -> usize {
        let components = components_of(ty).unwrap_or(1);
        let data: Vec<u8> = values
            .iter()
            .flat_map(|&v| (v as f32).to_le_bytes())
            .collect();
        let view = self.push_view(&data, target);
        let mut acc = json!({
            "bufferView": view, "componentType": 5126, "count": values.len() / components, "type": ty,
        });
        if with_bounds && !values.is_empty() {
            let mut min = vec![f64::INFINITY; components];
            let mut max = vec![f64::NEG_INFINITY; components];
            for chunk in values.chunks(components) {
                for (c, &v) in chunk.iter().enumerate() {
                    let v = v as f32 as f64;
                    min[c] = min[c].min(v);
                    max[c] = max[c].max(v);
                }
            }
            acc["min"] = json!(min);
            acc["max"] = json!(max);
        }
        push(self.json, "accessors", acc)
    }

    /// Adds an unsigned-short accessor (`JOINTS_0`).
    pub fn u16s(&mut self, values: &[u16], ty: &str) -> usize {
        let components = components_of(ty).unwrap_or(1);
        let data: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.push_view(&data, Some(34962));
        push(
            self.json,
            "accessors",
            json!({ "bufferView": view, "componentType": 5123, "count": values.len() / components, "type": ty }),
        )
    }

    /// Adds an unsigned-int index accessor.
    pub fn indices(&mut self, values: &[u32]) -> usize {
        let data: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.push_view(&data, Some(34963));
        push(
            self.json,
            "accessors",
            json!({ "bufferView": view, "componentType": 5125, "count": values.len(), "type": "SCALAR" }),
        )
    }
}

/// Appends `value` to the top-level array `array` (created if missing); returns its index.
pub(crate) fn push(json: &mut Value, array: &str, value: Value) -> usize {
    if !json.get(array).is_some_and(Value::is_array) {
        json[array] = json!([]);
    }
    let arr = json[array].as_array_mut().expect("just made an array");
    arr.push(value);
    arr.len() - 1
}
