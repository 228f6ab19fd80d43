//! Documents as the editor has them: their text, LSP positions (lines and UTF-16 columns)
//! to byte offsets and back, incremental edits.

use lsp_types::{Position, Range, TextDocumentContentChangeEvent};

/// Where each line of a text starts, for turning positions into offsets and back.
pub struct LineIndex<'t> {
    text: &'t str,
    starts: std::borrow::Cow<'t, [usize]>,
}

/// Where each line of `text` starts (byte offsets, the first 0).
pub fn line_starts(text: &str) -> Vec<usize> {
    let mut starts = vec![0];
    starts.extend(memchr::memchr_iter(b'\n', text.as_bytes()).map(|i| i + 1));
    starts
}

impl<'t> LineIndex<'t> {
    /// The index of a text.
    pub fn new(text: &'t str) -> LineIndex<'t> {
        LineIndex {
            text,
            starts: line_starts(text).into(),
        }
    }

    /// The index of a text whose [`line_starts`] are known (kept by the caller, to index a
    /// large text once for many positions).
    pub fn with_starts(text: &'t str, starts: &'t [usize]) -> LineIndex<'t> {
        LineIndex {
            text,
            starts: starts.into(),
        }
    }

    /// The byte offset of a position; positions past a line's end or the text's end are
    /// taken to that end (an editor's stale position never fails).
    pub fn offset(&self, p: Position) -> usize {
        let Some(&start) = self.starts.get(p.line as usize) else {
            return self.text.len();
        };
        let end = self
            .starts
            .get(p.line as usize + 1)
            .map_or(self.text.len(), |&e| e - 1);
        let mut units = 0u32;
        for (i, c) in self.text[start..end].char_indices() {
            if units >= p.character {
                return start + i;
            }
            units += c.len_utf16() as u32;
        }
        end
    }

    /// The position of a byte offset (taken to the text's end and to a character
    /// boundary).
    pub fn position(&self, offset: usize) -> Position {
        let mut offset = offset.min(self.text.len());
        while !self.text.is_char_boundary(offset) {
            offset -= 1;
        }
        let line = self.starts.partition_point(|&s| s <= offset) - 1;
        Position::new(line as u32, self.column(line, offset))
    }

    /// The UTF-16 column of `offset` (a character boundary) on line `line`.
    fn column(&self, line: usize, offset: usize) -> u32 {
        let before = &self.text[self.starts[line]..offset];
        // (Bytes are UTF-16 units in ASCII, which most files are.)
        match before.is_ascii() {
            true => before.len() as u32,
            false => before.encode_utf16().count() as u32,
        }
    }

    /// The positions of byte offsets given in increasing order (as [`LineIndex::position`]),
    /// found walking forward: no search per offset.
    pub fn positions_in_order(&self) -> impl FnMut(usize) -> Position + '_ {
        let mut line = 0;
        move |offset| {
            let mut offset = offset.min(self.text.len());
            while !self.text.is_char_boundary(offset) {
                offset -= 1;
            }
            if self.starts[line] > offset {
                line = 0;
            }
            while self.starts.get(line + 1).is_some_and(|&s| s <= offset) {
                line += 1;
            }
            Position::new(line as u32, self.column(line, offset))
        }
    }

    /// The range of a byte span.
    pub fn range(&self, start: usize, end: usize) -> Range {
        Range::new(self.position(start), self.position(end))
    }
}

/// Applies an editor's changes, in order, to a text.
pub fn apply_changes(text: &mut String, changes: Vec<TextDocumentContentChangeEvent>) {
    for c in changes {
        match c.range {
            None => *text = c.text,
            Some(r) => {
                let (s, e) = {
                    let ix = LineIndex::new(text);
                    let s = ix.offset(r.start);
                    let e = ix.offset(r.end);
                    (s.min(e), s.max(e))
                };
                text.replace_range(s..e, &c.text);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_count_utf16_units() {
        let text = "ab\né😀x\r\nlast";
        let ix = LineIndex::new(text);
        assert_eq!(ix.offset(Position::new(1, 0)), 3);
        assert_eq!(ix.offset(Position::new(1, 1)), 5); // after é (2 bytes)
        assert_eq!(ix.offset(Position::new(1, 3)), 9); // after 😀 (2 units, 4 bytes)
        assert_eq!(ix.offset(Position::new(1, 99)), 11); // the line's end (before \n)
        assert_eq!(ix.offset(Position::new(9, 0)), text.len());
        for o in 0..=text.len() {
            if text.is_char_boundary(o) {
                assert_eq!(ix.offset(ix.position(o)), o.min(text.len()), "{o}");
            }
        }
        assert_eq!(ix.position(6), ix.position(5)); // inside 😀: its start
        let mut walk = ix.positions_in_order();
        for o in 0..=text.len() + 2 {
            assert_eq!(walk(o), ix.position(o), "{o}");
        }
    }

    #[test]
    fn changes_apply_in_order() {
        let mut t = "abc\ndef\n".to_string();
        apply_changes(
            &mut t,
            vec![
                TextDocumentContentChangeEvent {
                    range: Some(Range::new(Position::new(1, 0), Position::new(1, 1))),
                    range_length: None,
                    text: "X".into(),
                },
                TextDocumentContentChangeEvent {
                    range: Some(Range::new(Position::new(0, 3), Position::new(0, 0))),
                    range_length: None,
                    text: "!".into(),
                },
            ],
        );
        assert_eq!(t, "!\nXef\n");
    }
}
