//! Splitting a file into its significant lines: comments, blank lines and line endings gone.
//!
//! Both file formats are line based. A line whose first non-blank characters are `//` is a
//! comment, `//` after content starts a trailing comment, blank lines are ignored, and lines
//! end in LF or CRLF. What is left of a line is trimmed of blanks (spaces and tabs).

/// A significant line: its text without comment and surrounding blanks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Line<'a> {
    /// The text, never empty.
    pub text: &'a str,
    /// Byte offset of `text` in the file.
    pub start: usize,
    /// 1-based line number.
    pub number: u32,
    /// True when a blank line (not a comment) stands between this line and the previous
    /// significant one, or this is the first: rules are separated so.
    pub after_blank: bool,
}

/// True for the blanks that separate terms.
pub fn is_blank(c: char) -> bool {
    c == ' ' || c == '\t'
}

/// The significant lines of a file, in order.
pub fn significant_lines(src: &str) -> impl Iterator<Item = Line<'_>> {
    let mut offset = 0usize;
    let mut blank = true;
    src.split_inclusive('\n')
        .enumerate()
        .filter_map(move |(i, raw)| {
            let line_start = offset;
            offset += raw.len();
            let mut body = raw.strip_suffix('\n').unwrap_or(raw);
            body = body.strip_suffix('\r').unwrap_or(body);
            if body.trim_matches(is_blank).is_empty() {
                blank = true;
            }
            if let Some(c) = body.find("//") {
                body = &body[..c];
            }
            let trimmed_start = body.len() - body.trim_start_matches(is_blank).len();
            let text = body.trim_matches(is_blank);
            (!text.is_empty()).then(|| Line {
                text,
                start: line_start + trimmed_start,
                number: i as u32 + 1,
                after_blank: std::mem::take(&mut blank),
            })
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comments_blanks_and_crlf() {
        let src = "// head\r\n\r\n  name one // trailing\r\n\t42\n//x\nlast";
        let lines: Vec<_> = significant_lines(src).collect();
        assert_eq!(lines.len(), 3);
        assert_eq!(lines[0].text, "name one");
        assert_eq!(&src[lines[0].start..lines[0].start + 8], "name one");
        assert_eq!(lines[0].number, 3);
        assert_eq!(lines[1].text, "42");
        assert_eq!(lines[2].text, "last");
        assert_eq!(lines[2].number, 6);
        let after: Vec<bool> = lines.iter().map(|l| l.after_blank).collect();
        assert_eq!(after, [true, false, false]);
    }
}
