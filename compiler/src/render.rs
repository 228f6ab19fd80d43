//! Rendering diagnostics, in one place: terminal text through `codespan-reporting` (plain or
//! coloured) and JSON for editors and the viewer.

use codespan_reporting::diagnostic::{Diagnostic as CsDiagnostic, Label as CsLabel, LabelStyle};
use codespan_reporting::files::{Files, SimpleFiles};
use codespan_reporting::term::{self, Config};
use latticesim_grammar::{Diagnostic, FileId, Label, Severity};
use serde::Serialize;

/// The files a run read, by [`FileId`], with the names shown in messages.
#[derive(Default)]
pub struct Sources {
    files: SimpleFiles<String, String>,
}

impl Sources {
    /// An empty set.
    pub fn new() -> Sources {
        Sources::default()
    }

    /// Adds a file; its id is the number of files added before it.
    pub fn add(&mut self, name: impl Into<String>, text: impl Into<String>) -> FileId {
        FileId(self.files.add(name.into(), text.into()) as u32)
    }

    /// The text of a file.
    pub fn text(&self, id: FileId) -> &str {
        self.files
            .get(id.0 as usize)
            .map(|f| f.source().as_str())
            .unwrap_or("")
    }

    /// The name of a file.
    pub fn name(&self, id: FileId) -> &str {
        self.files
            .get(id.0 as usize)
            .map(|f| f.name().as_str())
            .unwrap_or("")
    }

    /// 1-based line and column (in characters) of a byte offset.
    pub fn line_col(&self, id: FileId, byte: u32) -> (usize, usize) {
        let text = self.text(id);
        let byte = (byte as usize).min(text.len());
        match self.files.location(id.0 as usize, byte) {
            Ok(loc) => (loc.line_number, loc.column_number),
            Err(_) => (1, 1),
        }
    }
}

/// Sorts diagnostics into file order (by file, then position, then code) and drops exact
/// duplicates.
pub fn sort(diags: &mut Vec<Diagnostic>) {
    diags.sort_by(|a, b| {
        (
            a.primary.file,
            a.primary.span.start,
            a.primary.span.end,
            a.code,
        )
            .cmp(&(
                b.primary.file,
                b.primary.span.start,
                b.primary.span.end,
                b.code,
            ))
    });
    diags.dedup();
}

fn clamp(l: &Label, sources: &Sources) -> std::ops::Range<usize> {
    let len = sources.text(l.file).len();
    let s = (l.span.start as usize).min(len);
    let e = (l.span.end as usize).clamp(s, len);
    s..e
}

fn to_codespan(d: &Diagnostic, sources: &Sources) -> CsDiagnostic<usize> {
    let base = match d.severity() {
        Severity::Error => CsDiagnostic::error(),
        Severity::Warning => CsDiagnostic::warning(),
    };
    let mut labels = vec![CsLabel::new(
        LabelStyle::Primary,
        d.primary.file.0 as usize,
        clamp(&d.primary, sources),
    )
    .with_message(d.primary.message.clone())];
    for l in &d.secondary {
        labels.push(
            CsLabel::new(LabelStyle::Secondary, l.file.0 as usize, clamp(l, sources))
                .with_message(l.message.clone()),
        );
    }
    let mut notes = Vec::new();
    if let Some(h) = &d.help {
        notes.push(format!("help: {h}"));
    }
    base.with_code(d.code.as_str())
        .with_message(d.message.clone())
        .with_labels(labels)
        .with_notes(notes)
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

/// Writes diagnostics to standard error, in colour when `color` is true.
pub fn render_stderr(diags: &[Diagnostic], sources: &Sources, color: bool) -> std::io::Result<()> {
    use term::termcolor::{ColorChoice, StandardStream};
    use term::{Styles, StylesWriter};
    let choice = if color {
        ColorChoice::Always
    } else {
        ColorChoice::Never
    };
    let stream = StandardStream::stderr(choice);
    let mut lock = stream.lock();
    let styles = Styles::default();
    let mut writer = StylesWriter::new(&mut lock, &styles);
    let config = Config::default();
    for d in diags {
        let cs = to_codespan(d, sources);
        term::emit_to_write_style(&mut writer, &config, &sources.files, &cs)
            .map_err(|e| std::io::Error::other(e.to_string()))?;
    }
    Ok(())
}

/// A label in JSON output.
#[derive(Serialize, Debug, Clone, PartialEq, Eq)]
pub struct JsonLabel {
    /// Primary (the exact place) or secondary.
    pub primary: bool,
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
    /// Byte offsets.
    pub start_byte: u32,
    /// Byte offset just after the end.
    pub end_byte: u32,
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
}

fn json_label(l: &Label, primary: bool, sources: &Sources) -> JsonLabel {
    let r = clamp(l, sources);
    let (line, column) = sources.line_col(l.file, r.start as u32);
    let (end_line, end_column) = sources.line_col(l.file, r.end as u32);
    JsonLabel {
        primary,
        file: sources.name(l.file).to_string(),
        line,
        column,
        end_line,
        end_column,
        start_byte: r.start as u32,
        end_byte: r.end as u32,
        message: l.message.clone(),
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
                message: d.message.clone(),
                file: p.file,
                line: p.line,
                column: p.column,
                end_line: p.end_line,
                end_column: p.end_column,
                labels,
                help: d.help.clone(),
            }
        })
        .collect()
}
