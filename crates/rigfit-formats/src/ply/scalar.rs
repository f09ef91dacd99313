//! PLY scalar types: their names, sizes, and values decoded from binary or ascii.

/// A PLY scalar type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    pub(super) fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    pub(super) fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    pub(super) fn is_integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }

    /// Decodes one value; `b` must hold at least `self.size()` bytes.
    pub(super) fn decode(self, b: &[u8], big_endian: bool) -> Value {
        fn arr<const N: usize>(b: &[u8], big_endian: bool) -> [u8; N] {
            let mut a = [0u8; N];
            a.copy_from_slice(&b[..N]);
            if big_endian {
                a.reverse();
            }
            a
        }
        match self {
            Self::I8 => Value::Int(i64::from(b[0] as i8)),
            Self::U8 => Value::Int(i64::from(b[0])),
            Self::I16 => Value::Int(i64::from(i16::from_le_bytes(arr(b, big_endian)))),
            Self::U16 => Value::Int(i64::from(u16::from_le_bytes(arr(b, big_endian)))),
            Self::I32 => Value::Int(i64::from(i32::from_le_bytes(arr(b, big_endian)))),
            Self::U32 => Value::Int(i64::from(u32::from_le_bytes(arr(b, big_endian)))),
            Self::F32 => Value::Float(f64::from(f32::from_le_bytes(arr(b, big_endian)))),
            Self::F64 => Value::Float(f64::from_le_bytes(arr(b, big_endian))),
        }
    }

    /// Parses one ascii value.
    pub(super) fn parse_text(self, token: &[u8]) -> Option<Value> {
        let s = std::str::from_utf8(token).ok()?;
        if self.is_integer() {
            s.parse::<i64>().ok().map(Value::Int)
        } else {
            s.parse::<f64>().ok().map(Value::Float)
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Value {
    Int(i64),
    Float(f64),
}

impl Value {
    pub(super) fn as_f64(self) -> f64 {
        match self {
            Value::Int(i) => i as f64,
            Value::Float(f) => f,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalar_decoding_both_endians() {
        assert_eq!(Scalar::I16.decode(&[0xff, 0xfe], false), Value::Int(-257));
        assert_eq!(Scalar::I16.decode(&[0xfe, 0xff], true), Value::Int(-257));
        assert_eq!(Scalar::U16.decode(&[0x01, 0x02], true), Value::Int(0x0102));
        assert_eq!(Scalar::I8.decode(&[0x80], false), Value::Int(-128));
        assert_eq!(
            Scalar::U32.decode(&[0xff, 0xff, 0xff, 0xff], false),
            Value::Int(u32::MAX as i64)
        );
        assert_eq!(
            Scalar::F32.decode(&1.5f32.to_be_bytes(), true),
            Value::Float(1.5)
        );
        assert_eq!(
            Scalar::F64.decode(&(-2.25f64).to_le_bytes(), false),
            Value::Float(-2.25)
        );
    }
}
