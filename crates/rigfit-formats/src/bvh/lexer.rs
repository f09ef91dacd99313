//! The BVH tokenizer (whitespace-separated tokens with line numbers) and the quoting of input
//! in error messages.

/// A piece of the input for an error message: quoted, escaped, at most 40 characters.
pub(super) fn quote(s: &str) -> String {
    let mut short: String = s.chars().take(40).collect();
    if short.len() < s.len() {
        short.push_str("...");
    }
    format!("{short:?}")
}

/// Whitespace-separated tokens with line numbers; `{` and `}` are tokens by themselves.
#[derive(Clone, Copy)]
pub(super) struct Lexer<'a> {
    pub(super) text: &'a str,
    pub(super) pos: usize,
    pub(super) line: usize,
}

fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\x0b' | b'\x0c')
}

impl<'a> Lexer<'a> {
    pub(super) fn next_token(&mut self) -> Option<(&'a str, usize)> {
        let b = self.text.as_bytes();
        while self.pos < b.len() && is_space(b[self.pos]) {
            if b[self.pos] == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
        if self.pos >= b.len() {
            return None;
        }
        let start = self.pos;
        if b[start] == b'{' || b[start] == b'}' {
            self.pos += 1;
        } else {
            while self.pos < b.len()
                && !is_space(b[self.pos])
                && b[self.pos] != b'{'
                && b[self.pos] != b'}'
            {
                self.pos += 1;
            }
        }
        // Token boundaries are ASCII bytes, so they are character boundaries.
        self.text.get(start..self.pos).map(|t| (t, self.line))
    }

    pub(super) fn peek_token(&self) -> Option<(&'a str, usize)> {
        let mut copy = *self;
        copy.next_token()
    }

    /// The number of the last line of the text, for errors at its end.
    pub(super) fn eof_line(&self) -> usize {
        let newlines = self.text.bytes().filter(|&b| b == b'\n').count();
        if self.text.ends_with('\n') {
            newlines.max(1)
        } else {
            newlines + 1
        }
    }

    /// The rest of the current line (without the newline, which stays unread).
    pub(super) fn rest_of_line(&mut self) -> &'a str {
        let b = self.text.as_bytes();
        let start = self.pos;
        while self.pos < b.len() && b[self.pos] != b'\n' {
            self.pos += 1;
        }
        self.text.get(start..self.pos).unwrap_or("")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lexer_splits_braces_and_counts_lines() {
        let mut lx = Lexer {
            text: "ROOT a{\n  OFFSET 1\n}x",
            pos: 0,
            line: 1,
        };
        assert_eq!(lx.next_token(), Some(("ROOT", 1)));
        assert_eq!(lx.rest_of_line(), " a{");
        assert_eq!(lx.next_token(), Some(("OFFSET", 2)));
        assert_eq!(lx.next_token(), Some(("1", 2)));
        assert_eq!(lx.next_token(), Some(("}", 3)));
        assert_eq!(lx.next_token(), Some(("x", 3)));
        assert_eq!(lx.next_token(), None);
    }
}
