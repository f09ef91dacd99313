//! The PLY binary body: rows of little or big endian values, read from a byte slice.

use crate::error::ParseError;

use super::body::{Row, RowSource, ends_early};
use super::header::{Element, PropKind};
use super::scalar::Value;

pub(super) struct BinarySource<'a> {
    pub(super) data: &'a [u8],
    pub(super) pos: usize,
    /// The offset of `data` in the file, for error places.
    pub(super) base: usize,
    pub(super) big_endian: bool,
}

impl BinarySource<'_> {
    fn take(&mut self, n: usize) -> Option<&[u8]> {
        let end = self.pos.checked_add(n)?;
        let b = self.data.get(self.pos..end)?;
        self.pos = end;
        Some(b)
    }
}

impl RowSource for BinarySource<'_> {
    fn read_row(
        &mut self,
        el: &Element,
        row: usize,
        capture: Option<usize>,
        out: &mut Row,
    ) -> Result<(), ParseError> {
        let big_endian = self.big_endian;
        let eof = |s: &Self| {
            ends_early(
                el,
                row,
                format!("inside it, at byte {}", s.base + s.data.len()),
            )
        };
        out.scalars.clear();
        out.list.clear();
        for (pi, prop) in el.props.iter().enumerate() {
            match prop.kind {
                PropKind::Scalar(ty) => {
                    let Some(b) = self.take(ty.size()) else {
                        return Err(eof(self));
                    };
                    out.scalars.push(ty.decode(b, big_endian).as_f64());
                }
                PropKind::List { count, item } => {
                    out.scalars.push(0.0);
                    let at = self.base + self.pos;
                    let Some(b) = self.take(count.size()) else {
                        return Err(eof(self));
                    };
                    let n = match count.decode(b, big_endian) {
                        Value::Int(n) => usize::try_from(n).ok(),
                        Value::Float(_) => None,
                    };
                    let Some(n) = n else {
                        return Err(ParseError::new(
                            format!("{} {row} (byte {at})", el.name),
                            format!("list {:?} has a negative length", prop.name),
                        ));
                    };
                    let Some(items) = n.checked_mul(item.size()).and_then(|len| self.take(len))
                    else {
                        return Err(ParseError::new(
                            format!("{} {row}", el.name),
                            format!(
                                "the data ends early: list {:?} at byte {at} declares {n} items \
                                 but only {} bytes are left",
                                prop.name,
                                self.remaining()
                            ),
                        ));
                    };
                    if capture == Some(pi) {
                        out.list
                            .extend(items.chunks_exact(item.size()).filter_map(|c| {
                                match item.decode(c, big_endian) {
                                    Value::Int(i) => Some(i),
                                    Value::Float(_) => None,
                                }
                            }));
                    }
                }
            }
        }
        Ok(())
    }

    fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }
}
