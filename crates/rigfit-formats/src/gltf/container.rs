//! The GLB binary container (glTF 2.0 section 4.4): a 12-byte header, a JSON chunk and an
//! optional BIN chunk.

use crate::error::ParseError;

const MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// True when the bytes start like a GLB file.
pub fn is_glb(bytes: &[u8]) -> bool {
    bytes.len() >= 4 && &bytes[..4] == MAGIC
}

fn u32_at(bytes: &[u8], at: usize) -> Result<u32, ParseError> {
    bytes
        .get(at..at + 4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .ok_or_else(|| {
            ParseError::new(
                format!("byte {at}"),
                "file is truncated (GLB header or chunk header cut off)",
            )
        })
}

/// Splits a GLB file into its JSON text and its BIN chunk.
pub fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), ParseError> {
    if !is_glb(bytes) {
        return Err(ParseError::new(
            "byte 0",
            "not a GLB file (missing 'glTF' magic)",
        ));
    }
    let version = u32_at(bytes, 4)?;
    if version != 2 {
        return Err(ParseError::new(
            "header",
            format!("GLB version {version} is not supported (only 2)"),
        ));
    }
    let length = u32_at(bytes, 8)? as usize;
    if length > bytes.len() {
        return Err(ParseError::new(
            "header",
            format!(
                "file is truncated: header says {length} bytes, file has {}",
                bytes.len()
            ),
        ));
    }
    let mut at = 12;
    let mut json = None;
    let mut bin = None;
    while at < length {
        let chunk_len = u32_at(bytes, at)? as usize;
        let chunk_type = u32_at(bytes, at + 4)?;
        let start = at + 8;
        let end = start
            .checked_add(chunk_len)
            .filter(|&e| e <= length)
            .ok_or_else(|| {
                ParseError::new(
                    format!("byte {at}"),
                    format!("chunk of {chunk_len} bytes runs past the end of the file"),
                )
            })?;
        match chunk_type {
            CHUNK_JSON if json.is_none() => json = Some(&bytes[start..end]),
            CHUNK_BIN if bin.is_none() && json.is_some() => bin = Some(&bytes[start..end]),
            _ => {} // Unknown chunks are skipped, as the specification asks.
        }
        at = end;
    }
    let json = json.ok_or_else(|| ParseError::new("byte 12", "GLB file has no JSON chunk"))?;
    Ok((json, bin))
}

fn pad_to_4(v: &mut Vec<u8>, fill: u8) {
    while v.len() % 4 != 0 {
        v.push(fill);
    }
}

/// Builds a GLB file from JSON text and an optional BIN chunk.
pub fn join_glb(json: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
    let mut json = json.to_vec();
    pad_to_4(&mut json, b' ');
    let mut bin = bin.map(<[u8]>::to_vec);
    if let Some(b) = bin.as_mut() {
        pad_to_4(b, 0);
    }
    let total = 12 + 8 + json.len() + bin.as_ref().map_or(0, |b| 8 + b.len());
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_JSON.to_le_bytes());
    out.extend_from_slice(&json);
    if let Some(b) = bin {
        out.extend_from_slice(&(b.len() as u32).to_le_bytes());
        out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
        out.extend_from_slice(&b);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_truncation() {
        let glb = join_glb(br#"{"asset":{"version":"2.0"}}"#, Some(&[1, 2, 3]));
        let (json, bin) = split_glb(&glb).expect("valid");
        assert!(json.starts_with(b"{\"asset\""));
        assert_eq!(&bin.expect("bin")[..3], &[1, 2, 3]);
        for cut in 0..glb.len() {
            let _ = split_glb(&glb[..cut]);
        }
        assert!(split_glb(&glb[..glb.len() - 1]).is_err());
    }
}
