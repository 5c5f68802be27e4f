//! Allocation-free tokenizing of text formats (ascii PLY, OBJ).
//!
//! Both formats are line oriented and whitespace separated, so the readers
//! walk lines and tokens as byte slices of the file held in memory; numbers
//! are parsed straight from those slices.

/// Lines of `bytes` with their 1-based numbers, starting at `first_line`.
/// A trailing `\r` (Windows line end) is stripped.
pub(crate) struct Lines<'a> {
    rest: &'a [u8],
    next_line: usize,
    done: bool,
}

impl<'a> Lines<'a> {
    pub(crate) fn new(bytes: &'a [u8], first_line: usize) -> Self {
        Lines {
            rest: bytes,
            next_line: first_line,
            done: false,
        }
    }

    /// Number the next line returned will have (one past the last line at
    /// the end of the input).
    pub(crate) fn line_number(&self) -> usize {
        self.next_line
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = (usize, &'a [u8]);

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let (line, rest) = if let Some(i) = self.rest.iter().position(|&b| b == b'\n') {
            (&self.rest[..i], &self.rest[i + 1..])
        } else {
            self.done = true;
            if self.rest.is_empty() {
                return None;
            }
            (self.rest, &self.rest[self.rest.len()..])
        };
        self.rest = rest;
        let n = self.next_line;
        self.next_line += 1;
        Some((n, line.strip_suffix(b"\r").unwrap_or(line)))
    }
}

/// Whitespace-separated tokens of one line.
pub(crate) fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(u8::is_ascii_whitespace)
        .filter(|t| !t.is_empty())
}

/// Whether a line holds nothing but whitespace.
pub(crate) fn is_blank(line: &[u8]) -> bool {
    line.iter().all(u8::is_ascii_whitespace)
}

/// A token as text for error messages, cut short if long or binary.
pub(crate) fn show(token: &[u8]) -> String {
    const MAX: usize = 40;
    let s = String::from_utf8_lossy(&token[..token.len().min(MAX)]);
    if token.len() > MAX {
        format!("{s}...")
    } else {
        s.into_owned()
    }
}

/// Parses a decimal integer with optional sign; `None` on anything else or
/// on overflow.
pub(crate) fn parse_i64(token: &[u8]) -> Option<i64> {
    let (negative, digits) = match token.first()? {
        b'-' => (true, &token[1..]),
        b'+' => (false, &token[1..]),
        _ => (false, token),
    };
    if digits.is_empty() {
        return None;
    }
    let mut value: i64 = 0;
    for &d in digits {
        if !d.is_ascii_digit() {
            return None;
        }
        // Accumulate negatively so that i64::MIN parses too.
        value = value.checked_mul(10)?.checked_sub(i64::from(d - b'0'))?;
    }
    if negative {
        Some(value)
    } else {
        value.checked_neg()
    }
}

/// Parses a floating-point number (also `nan`, `inf`; these are kept so
/// that validation can name the vertex that has them).
pub(crate) fn parse_f64(token: &[u8]) -> Option<f64> {
    std::str::from_utf8(token).ok()?.parse().ok()
}

/// Parses a number as `f32`, the value a PLY `float` property holds.
pub(crate) fn parse_f32(token: &[u8]) -> Option<f32> {
    std::str::from_utf8(token).ok()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_numbered_and_lose_their_carriage_return() {
        let v: Vec<_> = Lines::new(b"a\r\nb\n\nc", 5).collect();
        assert_eq!(
            v,
            vec![
                (5, &b"a"[..]),
                (6, &b"b"[..]),
                (7, &b""[..]),
                (8, &b"c"[..])
            ]
        );
        assert_eq!(Lines::new(b"a\n", 1).count(), 1);
        assert_eq!(Lines::new(b"", 1).count(), 0);
    }

    #[test]
    fn integers_parse_exactly_and_reject_garbage() {
        assert_eq!(parse_i64(b"-12"), Some(-12));
        assert_eq!(parse_i64(b"+7"), Some(7));
        assert_eq!(parse_i64(b"-9223372036854775808"), Some(i64::MIN));
        assert_eq!(parse_i64(b"9223372036854775808"), None);
        assert_eq!(parse_i64(b"1.0"), None);
        assert_eq!(parse_i64(b"-"), None);
        assert_eq!(parse_i64(b""), None);
    }

    #[test]
    fn floats_keep_non_finite_values() {
        assert_eq!(parse_f64(b"1e3"), Some(1000.0));
        assert!(parse_f64(b"nan").unwrap().is_nan());
        assert_eq!(parse_f64(b"-inf"), Some(f64::NEG_INFINITY));
        assert_eq!(parse_f64(b"1,5"), None);
        assert_eq!(parse_f32(b"0.1"), Some(0.1f32));
    }
}
