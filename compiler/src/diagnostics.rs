//! Rendering diagnostics, in one place: terminal text through `codespan-reporting` (plain or
//! coloured) and JSON for editors and the viewer.

use codespan_reporting::diagnostic::{Diagnostic as CsDiagnostic, Label as CsLabel, LabelStyle};
use codespan_reporting::files::{Files, SimpleFiles};
use codespan_reporting::term::{self, Config};
use latticesim_grammar::{Code, Diagnostic, FileId, Fix, Label, Severity};
use serde::Serialize;

/// The files a run read, by [`FileId`], with the names shown in messages.
///
/// Each file is kept as read (for the checker) and as shown (for excerpts): in the shown
/// text every control character but tab and line ends is its Unicode picture (ESC `␛`, a
/// lone CR `␍`), and C1 controls and bidirectional overrides are `�`, so quoting a file can
/// never move the cursor, clear the screen or reorder what the terminal shows.
///
/// A file may be held in part: an excerpt of some of its lines ([`Sources::excerpt`]), for
/// files too large to hold whose diagnostics quote a few lines. Spans stay offsets in the
/// whole file, and excerpts show the lines' own numbers.
#[derive(Default)]
pub struct Sources {
    /// As shown.
    files: Shown,
    /// As read.
    texts: Vec<String>,
    /// Per file: (offset as read just after a replaced character, bytes the shown text has
    /// gained up to there), in order.
    shifts: Vec<Vec<(u32, u32)>>,
}

/// A run of whole lines of a file held in part ([`Sources::excerpt`]).
#[derive(Debug, Clone, Copy)]
struct Piece {
    /// Where it starts in the whole file, and in the excerpt.
    at: usize,
    at_excerpt: usize,
    len: usize,
    /// The 1-based number of its first line in the whole file, and the 0-based index of
    /// that line in the excerpt.
    line: usize,
    line_excerpt: usize,
}

/// The files as shown, for `codespan-reporting`: lines are numbered as in the whole file
/// for the files held in part.
#[derive(Default)]
struct Shown {
    files: SimpleFiles<String, String>,
    /// Per file held in part: its pieces.
    pieces: Vec<Option<Vec<Piece>>>,
}

impl Shown {
    fn add(&mut self, name: String, text: String, pieces: Option<Vec<Piece>>) -> usize {
        self.pieces.push(pieces);
        self.files.add(name, text)
    }
}

impl<'a> Files<'a> for Shown {
    type FileId = usize;
    type Name = &'a str;
    type Source = &'a str;

    fn name(&'a self, id: usize) -> Result<&'a str, codespan_reporting::files::Error> {
        Ok(self.files.get(id)?.name().as_str())
    }

    fn source(&'a self, id: usize) -> Result<&'a str, codespan_reporting::files::Error> {
        Ok(self.files.get(id)?.source().as_str())
    }

    fn line_index(
        &'a self,
        id: usize,
        byte: usize,
    ) -> Result<usize, codespan_reporting::files::Error> {
        self.files.line_index(id, byte)
    }

    fn line_number(
        &'a self,
        id: usize,
        index: usize,
    ) -> Result<usize, codespan_reporting::files::Error> {
        let Some(Some(pieces)) = self.pieces.get(id) else {
            return Ok(index + 1);
        };
        let k = pieces.partition_point(|p| p.line_excerpt <= index);
        Ok(match k.checked_sub(1) {
            Some(k) => pieces[k].line + (index - pieces[k].line_excerpt),
            None => index + 1,
        })
    }

    fn line_range(
        &'a self,
        id: usize,
        index: usize,
    ) -> Result<std::ops::Range<usize>, codespan_reporting::files::Error> {
        self.files.line_range(id, index)
    }
}

/// What a character is shown as in an excerpt, if not itself (`next` follows it).
fn picture(c: char, next: Option<char>) -> Option<char> {
    match c {
        '\t' | '\n' => None,
        '\r' if next == Some('\n') => None,
        '\0'..='\x1f' => char::from_u32(0x2400 + c as u32),
        '\x7f' => Some('\u{2421}'),
        '\u{80}'..='\u{9f}'
        | '\u{200e}'
        | '\u{200f}'
        | '\u{202a}'..='\u{202e}'
        | '\u{2066}'..='\u{2069}'
        | '\u{061c}' => Some('\u{fffd}'),
        _ => None,
    }
}

/// The shown text of `text` and its shifts (see [`Sources`]).
fn shown(text: &str) -> (String, Vec<(u32, u32)>) {
    let mut chars = text.char_indices().peekable();
    if !text
        .chars()
        .any(|c| picture(c, Some('\n')).is_some() || c == '\r')
    {
        return (text.to_string(), Vec::new());
    }
    let mut out = String::with_capacity(text.len());
    let mut shifts = Vec::new();
    let mut gained = 0u32;
    while let Some((i, c)) = chars.next() {
        match picture(c, chars.peek().map(|p| p.1)) {
            Some(p) => {
                out.push(p);
                let grow = (p.len_utf8() - c.len_utf8()) as u32;
                if grow > 0 {
                    gained += grow;
                    shifts.push(((i + c.len_utf8()) as u32, gained));
                }
            }
            None => out.push(c),
        }
    }
    (out, shifts)
}

/// A message with its control characters written as escapes (`\r`, `\u{1b}`).
pub fn visible(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if picture(c, None).is_some() => out.push_str(&format!("\\u{{{:x}}}", c as u32)),
            c => out.push(c),
        }
    }
    out
}

impl Sources {
    /// An empty set.
    pub fn new() -> Sources {
        Sources::default()
    }

    /// Adds a file; its id is the number of files added before it.
    pub fn add(&mut self, name: impl Into<String>, text: impl Into<String>) -> FileId {
        self.add_pieces(name.into(), text.into(), None)
    }

    fn add_pieces(&mut self, name: String, text: String, pieces: Option<Vec<Piece>>) -> FileId {
        let (show, shifts) = shown(&text);
        self.texts.push(text);
        self.shifts.push(shifts);
        FileId(self.files.add(name, show, pieces) as u32)
    }

    /// Adds a file held in part: `parts` are (offset in the whole file, 1-based number of
    /// its first line, whole lines of text), in order and apart; `len` is the whole file's
    /// length. Where lines are left out between parts, a break is shown (one line left
    /// out is shown as a break too, where the whole file would show it: give it as a part). Diagnostics on it are given in offsets of the whole file, and may only point
    /// into the parts.
    pub fn excerpt(
        &mut self,
        name: impl Into<String>,
        len: usize,
        parts: &[(usize, usize, &str)],
    ) -> FileId {
        let mut text = String::new();
        let mut pieces: Vec<Piece> = Vec::new();
        let mut lines = 0;
        for &(at, line, t) in parts {
            // Lines left out between two parts: two lines that stand for them, so that a
            // label on each side is shown with a break between, as in the whole file.
            let after = pieces.last().map(|p| p.line + (lines - p.line_excerpt));
            if after.is_some_and(|n| line > n) {
                text.push_str("\n\n");
                lines += 2;
            }
            pieces.push(Piece {
                at,
                at_excerpt: text.len(),
                len: t.len(),
                line,
                line_excerpt: lines,
            });
            text.push_str(t);
            // A line end after each part but the file's last line when it has none.
            let open_tail = at + t.len() == len && !t.ends_with('\n');
            if !t.ends_with('\n') && !open_tail {
                text.push('\n');
            }
            lines += t.matches('\n').count() + (!t.ends_with('\n') && !open_tail) as usize;
        }
        // The whole file's end, where a label past the parts lands (on the line after the
        // last part: the lines between are not counted); or, when the last part is the
        // file's last line without its line end, at the end of that line, as in the whole
        // file.
        let line = pieces
            .last()
            .map_or(1, |p| p.line + (lines - p.line_excerpt));
        pieces.push(Piece {
            at: len,
            at_excerpt: text.len(),
            len: 0,
            line,
            line_excerpt: lines,
        });
        self.add_pieces(name.into(), text, Some(pieces))
    }

    /// True when a file is held whole (not in part: see [`Sources::excerpt`]).
    pub fn is_whole(&self, id: FileId) -> bool {
        !matches!(self.files.pieces.get(id.0 as usize), Some(Some(_)))
    }

    /// The length of a file (of the whole file, for one held in part).
    pub fn len(&self, id: FileId) -> usize {
        match self.files.pieces.get(id.0 as usize) {
            Some(Some(p)) => p.last().map_or(0, |p| p.at),
            _ => self.text(id).len(),
        }
    }

    /// Where an offset of a file held in part is in its excerpt (others: the offset).
    fn in_excerpt(&self, id: FileId, byte: usize) -> usize {
        let Some(Some(pieces)) = self.files.pieces.get(id.0 as usize) else {
            return byte;
        };
        let k = pieces.partition_point(|p| p.at <= byte);
        match k.checked_sub(1) {
            Some(k) => pieces[k].at_excerpt + (byte - pieces[k].at).min(pieces[k].len),
            None => 0,
        }
    }

    /// The text of a file, as read.
    pub fn text(&self, id: FileId) -> &str {
        self.texts.get(id.0 as usize).map_or("", |t| t.as_str())
    }

    /// The name of a file.
    pub fn name(&self, id: FileId) -> &str {
        self.files
            .files
            .get(id.0 as usize)
            .map(|f| f.name().as_str())
            .unwrap_or("")
    }

    /// Where a byte offset of the text as read is in the text as shown.
    fn shown_offset(&self, id: FileId, byte: usize) -> usize {
        let byte = self.in_excerpt(id, byte).min(self.text(id).len());
        let Some(shifts) = self.shifts.get(id.0 as usize) else {
            return byte;
        };
        let k = shifts.partition_point(|&(at, _)| at as usize <= byte);
        byte + k.checked_sub(1).map_or(0, |k| shifts[k].1 as usize)
    }

    /// The 0-based line of a byte offset (a binary search; no column is counted).
    pub fn line_index(&self, id: FileId, byte: u32) -> usize {
        let byte = self.shown_offset(id, byte as usize);
        (self.files.line_index(id.0 as usize, byte))
            .and_then(|i| self.files.line_number(id.0 as usize, i))
            .map_or(0, |n| n - 1)
    }

    /// 1-based line and column (in characters) of a byte offset.
    pub fn line_col(&self, id: FileId, byte: u32) -> (usize, usize) {
        let byte = self.shown_offset(id, byte as usize);
        match self.files.location(id.0 as usize, byte) {
            Ok(loc) => (loc.line_number, loc.column_number),
            Err(_) => (1, 1),
        }
    }
}

/// True for the codes that cause others: a file that is not UTF-8, a dimension conflict, a
/// file cut short. They come first, whatever their place.
pub fn is_root_cause(code: Code) -> bool {
    matches!(code, Code::E101 | Code::E301 | Code::E103)
}

/// Sorts diagnostics: root causes first ([`is_root_cause`]), then file order (by file, then
/// position, then code); exact duplicates are dropped.
pub fn sort(diags: &mut Vec<Diagnostic>) {
    diags.sort_by_key(key);
    diags.dedup();
}

/// The order of diagnostics ([`sort`]'s).
pub type Key = (bool, FileId, u32, u32, Code);

/// A diagnostic's place in [`sort`]'s order.
pub fn key(d: &Diagnostic) -> Key {
    (
        !is_root_cause(d.code),
        d.primary.file,
        d.primary.span.start,
        d.primary.span.end,
        d.code,
    )
}

fn clamp(l: &Label, sources: &Sources) -> std::ops::Range<usize> {
    let len = sources.len(l.file);
    let s = (l.span.start as usize).min(len);
    let e = (l.span.end as usize).clamp(s, len);
    s..e
}

/// A label's range in the text as shown.
fn shown_range(l: &Label, sources: &Sources) -> std::ops::Range<usize> {
    let r = clamp(l, sources);
    sources.shown_offset(l.file, r.start)..sources.shown_offset(l.file, r.end)
}

fn to_codespan(d: &Diagnostic, sources: &Sources) -> CsDiagnostic<usize> {
    let base = match d.severity() {
        Severity::Error => CsDiagnostic::error(),
        Severity::Warning => CsDiagnostic::warning(),
    };
    let mut labels = vec![CsLabel::new(
        LabelStyle::Primary,
        d.primary.file.0 as usize,
        shown_range(&d.primary, sources),
    )
    .with_message(visible(&d.primary.message))];
    for l in &d.secondary {
        labels.push(
            CsLabel::new(
                LabelStyle::Secondary,
                l.file.0 as usize,
                shown_range(l, sources),
            )
            .with_message(visible(&l.message)),
        );
    }
    let mut notes = Vec::new();
    if let Some(o) = &d.denied {
        notes.push(format!("note: a warning made an error by {}", visible(o)));
    }
    if let Some(h) = &d.help {
        notes.push(format!("help: {}", visible(h)));
    }
    for f in &d.fixes {
        notes.push(fix_note(f, sources));
    }
    base.with_code(d.code.as_str())
        .with_message(visible(&d.message))
        .with_labels(labels)
        .with_notes(notes)
}

/// A fix as a note: what it does, then each line it changes as it reads after the fix.
fn fix_note(f: &Fix, sources: &Sources) -> String {
    let mut note = format!("fix: {}", visible(&f.message));
    let Some(first) = f.edits.first() else {
        return note;
    };
    let file = first.file;
    let text = sources.text(file);
    // In a file held in part, the edits' offsets of the whole file are where they fall in
    // the part held (they may only touch lines held).
    let mut edits: Vec<_> = (f.edits.iter().filter(|e| e.file == file))
        .map(|e| {
            let at = |b: u32| sources.in_excerpt(file, b as usize) as u32;
            latticesim_grammar::Edit {
                span: latticesim_grammar::Span {
                    start: at(e.span.start),
                    end: at(e.span.end),
                },
                ..e.clone()
            }
        })
        .collect();
    edits.sort_by_key(|e| e.span.start);
    let local = Fix {
        message: String::new(),
        edits,
    };
    let fixed = local.apply(text, file);
    // The lines the edits touch, found in the fixed text by how far the edits shifted them,
    // each with the part the edits wrote (from the first's start to the last's end).
    let mut shift: isize = 0;
    let mut shown: Vec<(usize, usize, usize)> = Vec::new();
    for e in &local.edits {
        let at = ((e.span.start as isize + shift).max(0) as usize).min(fixed.len());
        shift += e.replacement.len() as isize - e.span.len() as isize;
        let end = (at + e.replacement.len()).min(fixed.len());
        let start = fixed[..at].rfind('\n').map_or(0, |i| i + 1);
        match shown.iter_mut().find(|s| s.0 == start) {
            Some(s) => s.2 = s.2.max(end),
            None => shown.push((start, at, end)),
        }
    }
    note += ":";
    for (start, from, to) in shown {
        let line = fixed[start..].split('\n').next().unwrap_or("");
        let line = line.trim_end_matches('\r');
        let index = fixed[..start].matches('\n').count();
        let number = (sources.files.line_number(file.0 as usize, index)).unwrap_or(index + 1);
        let part = window(line, from - start, to - start);
        note += &format!("\n{number} | {}", visible(&part));
    }
    note
}

/// A fix's note quotes a line of at most this many characters whole.
const FIX_LINE: usize = 160;

/// Of a longer line, it quotes at most this many characters on each side of what the fix
/// wrote.
const FIX_CONTEXT: usize = 60;

/// The part of a long line around `from..to` (byte offsets in it), with `…` where it is cut;
/// a line of at most [`FIX_LINE`] characters is whole.
fn window(line: &str, from: usize, to: usize) -> std::borrow::Cow<'_, str> {
    if line.len() <= FIX_LINE || line.chars().nth(FIX_LINE).is_none() {
        return line.into();
    }
    let from = from.min(line.len());
    let to = to.clamp(from, line.len());
    let before: usize = (line[..from].chars().rev().take(FIX_CONTEXT))
        .map(char::len_utf8)
        .sum();
    let after: usize = (line[to..].chars().take(FIX_CONTEXT))
        .map(char::len_utf8)
        .sum();
    let (a, b) = (from - before, to + after);
    if a == 0 && b == line.len() {
        return line.into();
    }
    let cut = |yes: bool| if yes { "…" } else { "" };
    format!("{}{}{}", cut(a > 0), &line[a..b], cut(b < line.len())).into()
}

/// Renders diagnostics as plain text, as the golden files hold them.
pub fn render_plain(diags: &[Diagnostic], sources: &Sources) -> String {
    let config = Config::default();
    let mut out = String::new();
    for d in diags {
        let cs = to_codespan(d, sources);
        term::emit_to_string(&mut out, &config, &sources.files, &cs)
            .expect("labels were clamped to their files");
    }
    out
}

/// The line that says how many diagnostics of a file are not shown.
pub fn not_shown_line(n: &crate::NotShown, sources: &Sources) -> String {
    let count = |k: usize, what: &str| format!("{k} {what}{}", if k == 1 { "" } else { "s" });
    let codes: Vec<String> = (n.codes.iter())
        .map(|(c, k)| format!("{k} {}", c.as_str()))
        .collect();
    format!(
        "note: not shown in {}: {} and {}: {} (at most {} a line and {} a file are shown; \
         `--max-diagnostics N` shows N)",
        sources.name(n.file),
        count(n.errors, "more error"),
        count(n.warnings, "more warning"),
        codes.join(", "),
        crate::SHOWN_PER_LINE,
        n.per_file
    )
}

/// Renders diagnostics as terminal text, with ANSI colours when `color` is true (the caller
/// writes it; this crate does no I/O).
pub fn render_text(diags: &[Diagnostic], sources: &Sources, color: bool) -> String {
    if !color {
        return render_plain(diags, sources);
    }
    use term::termcolor::Ansi;
    use term::{Styles, StylesWriter};
    let styles = Styles::default();
    let mut ansi = Ansi::new(Vec::new());
    {
        let mut writer = StylesWriter::new(&mut ansi, &styles);
        let config = Config::default();
        for d in diags {
            let cs = to_codespan(d, sources);
            term::emit_to_write_style(&mut writer, &config, &sources.files, &cs)
                .expect("labels were clamped to their files");
        }
    }
    String::from_utf8(ansi.into_inner()).expect("rendered from UTF-8 text")
}

/// A place in a file, in JSON output: lines and columns (1-based, columns in characters,
/// the end just past the span) and bytes.
#[derive(Serialize, Debug, Clone, PartialEq, Eq)]
pub struct JsonPlace {
    /// File name.
    pub file: String,
    /// 1-based line of the start.
    pub line: usize,
    /// 1-based column of the start, in characters.
    pub column: usize,
    /// 1-based line of the end.
    pub end_line: usize,
    /// 1-based column just after the end.
    pub end_column: usize,
    /// Byte offset of the start.
    pub start_byte: u32,
    /// Byte offset just after the end.
    pub end_byte: u32,
}

/// A label in JSON output.
#[derive(Serialize, Debug, Clone, PartialEq, Eq)]
pub struct JsonLabel {
    /// Primary (the exact place) or secondary.
    pub primary: bool,
    /// Where.
    #[serde(flatten)]
    pub at: JsonPlace,
    /// What the label says.
    pub message: String,
}

/// One diagnostic in JSON output.
#[derive(Serialize, Debug, Clone, PartialEq, Eq)]
pub struct JsonDiagnostic {
    /// The code, e.g. `E302`.
    pub code: &'static str,
    /// `error` or `warning`.
    pub severity: &'static str,
    /// The message.
    pub message: String,
    /// File of the primary label.
    pub file: String,
    /// Start line of the primary label.
    pub line: usize,
    /// Start column of the primary label.
    pub column: usize,
    /// End line of the primary label.
    pub end_line: usize,
    /// End column of the primary label.
    pub end_column: usize,
    /// All labels, primary first.
    pub labels: Vec<JsonLabel>,
    /// How to fix it.
    pub help: Option<String>,
    /// Suggested fixes with their edits, most likely first.
    pub fixes: Vec<JsonFix>,
}

/// A suggested fix in JSON output.
#[derive(Serialize, Debug, Clone, PartialEq, Eq)]
pub struct JsonFix {
    /// What it does.
    pub message: String,
    /// The replacements; each has a label's place fields and `replacement`.
    pub edits: Vec<JsonEdit>,
}

/// One replacement of a fix: where and the new text.
#[derive(Serialize, Debug, Clone, PartialEq, Eq)]
pub struct JsonEdit {
    /// Where.
    #[serde(flatten)]
    pub at: JsonPlace,
    /// The new text.
    pub replacement: String,
}

fn json_place(file: FileId, span: latticesim_grammar::Span, sources: &Sources) -> JsonPlace {
    let r = clamp(&Label::new(file, span, ""), sources);
    let (line, column) = sources.line_col(file, r.start as u32);
    let (end_line, end_column) = sources.line_col(file, r.end as u32);
    JsonPlace {
        file: sources.name(file).to_string(),
        line,
        column,
        end_line,
        end_column,
        start_byte: r.start as u32,
        end_byte: r.end as u32,
    }
}

fn json_label(l: &Label, primary: bool, sources: &Sources) -> JsonLabel {
    JsonLabel {
        primary,
        at: json_place(l.file, l.span, sources),
        message: visible(&l.message),
    }
}

/// Diagnostics as JSON values.
pub fn to_json(diags: &[Diagnostic], sources: &Sources) -> Vec<JsonDiagnostic> {
    diags
        .iter()
        .map(|d| {
            let p = json_label(&d.primary, true, sources);
            let mut labels = vec![p.clone()];
            labels.extend(d.secondary.iter().map(|l| json_label(l, false, sources)));
            JsonDiagnostic {
                code: d.code.as_str(),
                severity: match d.severity() {
                    Severity::Error => "error",
                    Severity::Warning => "warning",
                },
                message: visible(&d.message),
                file: p.at.file,
                line: p.at.line,
                column: p.at.column,
                end_line: p.at.end_line,
                end_column: p.at.end_column,
                labels,
                help: d.help.as_deref().map(visible),
                fixes: d
                    .fixes
                    .iter()
                    .map(|f| JsonFix {
                        message: visible(&f.message),
                        edits: f
                            .edits
                            .iter()
                            .map(|e| JsonEdit {
                                at: json_place(e.file, e.span, sources),
                                replacement: e.replacement.clone(),
                            })
                            .collect(),
                    })
                    .collect(),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_are_shown_as_pictures_at_the_right_places() {
        let mut s = Sources::new();
        let id = s.add("f", "a\x1bb\r\nc\rd\u{85}e\u{202e}f\n");
        let (shown, _) = shown(s.text(id));
        assert_eq!(shown, "a\u{241b}b\r\nc\u{240d}d\u{fffd}e\u{fffd}f\n");
        // Offsets as read map onto the same characters as shown.
        let text = s.text(id);
        for (i, c) in text.char_indices() {
            let j = s.shown_offset(id, i);
            let d = shown[j..].chars().next().unwrap();
            assert_eq!(
                picture(c, text[i + c.len_utf8()..].chars().next()).unwrap_or(c),
                d
            );
        }
        assert_eq!(s.line_col(id, 5), (2, 1));
        assert_eq!(s.line_col(id, 7), (2, 3));
        assert_eq!(visible("x\x1b[2J\ry"), "x\\u{1b}[2J\\ry");
    }

    /// A fix's note quotes a line of up to FIX_LINE characters whole, and of a longer line
    /// the part the fix wrote with FIX_CONTEXT characters each side, cut where `…` shows.
    #[test]
    fn fix_notes_quote_long_lines_around_the_fix() {
        let short = "C00 A C00 #N01 C00 A C00 #W01 C00 A C00 #E01 C00 A C00 #S01";
        assert_eq!(window(short, 10, 14), short);
        let long = format!("{}XY{}", "é".repeat(500), "b".repeat(500));
        let from = "é".len() * 500;
        let w = window(&long, from, from + 2);
        assert_eq!(w, format!("…{}XY{}…", "é".repeat(60), "b".repeat(60)));
        assert_eq!(window(&long, 0, 2), format!("{}…", "é".repeat(61)));
        let end = long.len();
        assert_eq!(window(&long, end, end), format!("…{}", "b".repeat(60)));

        // Through the renderer: a fix on a line of 10^5 characters quotes about 130 of them.
        let mut s = Sources::new();
        let text = format!("r\n1\n{} q\n", "N ".repeat(50_000));
        let id = s.add("rules.txt", text.clone());
        let at = text.find(" q").unwrap() as u32 + 1;
        let span = latticesim_grammar::Span {
            start: at,
            end: at + 1,
        };
        let d = Diagnostic::new(Code::E102, "no term", Label::new(id, span, "here"))
            .with_fix(Fix::replace("write `Q`", id, span, "Q"));
        let out = render_plain(&[d], &s);
        let note = out.lines().find(|l| l.contains("3 | ")).unwrap();
        let fixed = text.replace(" q", " Q");
        let line = fixed.lines().nth(2).unwrap();
        assert!(
            note.ends_with(&format!(" | …{}", &line[line.len() - 61..])),
            "{note}"
        );
        assert!(out.len() < 2 * text.len() + 1_000, "{} bytes", out.len());
    }

    /// A file held in part: labels in offsets of the whole file, shown on their own lines
    /// with their own numbers; JSON places the same.
    #[test]
    fn excerpts_keep_offsets_and_line_numbers() {
        let mut s = Sources::new();
        let _rules = s.add("rules.txt", "r\n");
        let id = s.excerpt(
            "agents.txt",
            10_000,
            &[
                (0, 1, "// head\n0,0 SA0000\n"),
                (9_000, 700, "5,5 \x1bSB0000\n"),
            ],
        );
        assert_eq!(s.len(id), 10_000);
        assert_eq!(s.line_col(id, 8), (2, 1));
        assert_eq!(s.line_col(id, 9_005), (700, 6));
        let d = Diagnostic::new(
            Code::W603,
            "m",
            Label::new(
                id,
                latticesim_grammar::Span {
                    start: 9_005,
                    end: 9_011,
                },
                "here",
            ),
        );
        let text = render_plain(&[d], &s);
        assert!(text.contains("agents.txt:700:6"), "{text}");
        assert!(text.contains("700 │ 5,5 ␛SB0000"), "{text}");
        // The file's last line without a line end: its end is on that line, as in the
        // whole file (it was placed on the line after).
        let tail = s.excerpt(
            "tail.txt",
            9_003,
            &[(0, 1, "// head\n"), (9_000, 700, "1,1")],
        );
        assert_eq!(s.line_col(tail, 9_003), (700, 4));
        let mut whole = Sources::new();
        let w = whole.add("tail.txt", "// head\n1,1");
        assert_eq!(whole.line_col(w, 11), (2, 4));
    }
}
