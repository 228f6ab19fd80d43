//! Lint levels, as rustc and clippy have them: a warning may be allowed (not said), warned
//! of (the default) or denied (said as an error, so the check fails), by its code (`W603`)
//! or its name (`idle-start-state`), or all warnings at once (`warnings`).
//!
//! Levels come from the rules file, on comment lines (the paper's files stay valid):
//!
//! ```text
//! // latticesim: allow W603, deny W501 W502
//! // latticesim: deny warnings
//! ```
//!
//! and from the command line (`--allow`, `--warn`, `--deny`), which comes after the file.
//! A level for a code wins over one for `warnings`; for one code, the last said wins (the
//! command line's `--allow`, then `--warn`, then `--deny`). Errors have no level.
//!
//! The same lines choose the width of counters and numeric messages (the 32-bit extension,
//! see [`latticesim_vm::column`]): `// latticesim: counters 32`; the command line's
//! `--counters 16|32` wins over the file's. [`Lints`] carries both: what the rules file and
//! the command line say about how a file is checked and run.

use latticesim_grammar::{Code, Diagnostic, FileId, Label, Severity, Span};
use latticesim_vm::column::Width;

/// What a lint level does to a warning.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// Not said.
    Allow,
    /// Said as a warning.
    Warn,
    /// Said as an error.
    Deny,
}

impl Level {
    fn word(self) -> &'static str {
        match self {
            Level::Allow => "allow",
            Level::Warn => "warn",
            Level::Deny => "deny",
        }
    }

    fn parse(s: &str) -> Option<Level> {
        match s {
            "allow" => Some(Level::Allow),
            "warn" => Some(Level::Warn),
            "deny" => Some(Level::Deny),
            _ => None,
        }
    }
}

/// What a level is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// One warning.
    Code(Code),
    /// Every warning.
    Warnings,
}

impl Target {
    /// `warnings`, a warning's code (`W603`) or its name (`idle-start-state`); an error's
    /// code or an unknown word is refused, with why.
    pub fn parse(s: &str) -> Result<Target, String> {
        if s.eq_ignore_ascii_case("warnings") {
            return Ok(Target::Warnings);
        }
        let code = Code::parse(&s.to_ascii_uppercase())
            .or_else(|| Code::ALL.iter().copied().find(|c| c.slug() == s));
        match code {
            Some(c) if c.severity() == Severity::Warning => Ok(Target::Code(c)),
            Some(c) => Err(format!(
                "{} is an error, and errors have no level (only warnings, W501 to W603, or `warnings`)",
                c.as_str()
            )),
            None => Err(format!(
                "`{s}` is neither a warning's code (W501 to W603), its name (as `idle-start-state`) nor `warnings`"
            )),
        }
    }
}

/// Lint levels in the order said (see the module's text).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Lints {
    /// (what, level, where it was said).
    said: Vec<(Target, Level, String)>,
    /// The width of counters, when said, and where.
    counters: Option<(Width, String)>,
    /// How many diagnostics of a file are shown in full, when said (`--max-diagnostics`).
    shown: Option<usize>,
}

impl Lints {
    /// No levels: every warning warned of.
    pub fn new() -> Lints {
        Lints::default()
    }

    /// Adds a level, said at `origin` (shown when it denies: "`--deny W603`").
    pub fn push(&mut self, target: Target, level: Level, origin: impl Into<String>) {
        self.said.push((target, level, origin.into()));
    }

    /// The command line's levels: every `--allow`, then `--warn`, then `--deny`.
    pub fn from_flags(allow: &[String], warn: &[String], deny: &[String]) -> Result<Lints, String> {
        let mut l = Lints::new();
        for (level, args) in [
            (Level::Allow, allow),
            (Level::Warn, warn),
            (Level::Deny, deny),
        ] {
            for a in args {
                let t = Target::parse(a).map_err(|e| format!("--{} {a}: {e}", level.word()))?;
                l.push(t, level, format!("`--{} {a}`", level.word()));
            }
        }
        Ok(l)
    }

    /// `self`'s levels, then `later`'s (which win, as does its width of counters).
    pub fn then(&self, later: &Lints) -> Lints {
        let mut l = self.clone();
        l.said.extend(later.said.iter().cloned());
        if later.counters.is_some() {
            l.counters = later.counters.clone();
        }
        l.shown = later.shown.or(l.shown);
        l
    }

    /// Shows at most `n` diagnostics of a file in full (the rest are counted per code).
    pub fn set_shown(&mut self, n: usize) {
        self.shown = Some(n);
    }

    /// How many diagnostics of a file are shown in full: as said, else
    /// [`crate::SHOWN_PER_FILE`].
    pub fn shown(&self) -> usize {
        self.shown.unwrap_or(crate::SHOWN_PER_FILE)
    }

    /// Whether no level is said.
    pub fn is_empty(&self) -> bool {
        self.said.is_empty()
    }

    /// Sets the width of counters, said at `origin`.
    pub fn set_counters(&mut self, w: Width, origin: impl Into<String>) {
        self.counters = Some((w, origin.into()));
    }

    /// The width of counters in force: as said, else the paper's 16 bits.
    pub fn width(&self) -> Width {
        self.counters.as_ref().map_or(Width::W16, |c| c.0)
    }

    /// Where the width of counters was said, if it was.
    pub fn width_origin(&self) -> Option<&str> {
        self.counters.as_ref().map(|c| c.1.as_str())
    }

    /// The level of a warning, and where it was said (none: warned of by default).
    fn level(&self, code: Code) -> Option<(Level, &str)> {
        let last = |t: Target| {
            (self.said.iter().rev())
                .find(|s| s.0 == t)
                .map(|s| (s.1, s.2.as_str()))
        };
        last(Target::Code(code)).or_else(|| last(Target::Warnings))
    }

    /// True when diagnostics of `code` are errors (of their own, or denied warnings).
    pub fn is_error(&self, code: Code) -> bool {
        code.severity() == Severity::Error || matches!(self.level(code), Some((Level::Deny, _)))
    }

    /// True when diagnostics of `code` are allowed (taken out).
    pub fn allows(&self, code: Code) -> bool {
        code.severity() == Severity::Warning && matches!(self.level(code), Some((Level::Allow, _)))
    }

    /// Applies the levels: allowed warnings are taken out, denied ones marked errors.
    pub fn apply(&self, diags: &mut Vec<Diagnostic>) {
        if self.said.is_empty() {
            return;
        }
        diags.retain_mut(|d| self.mark(d));
    }

    /// Applies the levels to one diagnostic: `None` when it is allowed.
    pub fn admit(&self, mut d: Diagnostic) -> Option<Diagnostic> {
        self.mark(&mut d).then_some(d)
    }

    /// Marks a denied warning; false for an allowed one.
    fn mark(&self, d: &mut Diagnostic) -> bool {
        if self.said.is_empty() || d.code.severity() != Severity::Warning {
            return true;
        }
        match self.level(d.code) {
            Some((Level::Allow, _)) => false,
            Some((Level::Deny, origin)) => {
                d.denied = Some(origin.to_string());
                true
            }
            Some((Level::Warn, _)) | None => {
                d.denied = None;
                true
            }
        }
    }

    /// The levels a rules file says on its directive lines (`// latticesim: ...`), and an
    /// E106 for each part of one that cannot be read.
    pub fn from_rules(text: &str, file: FileId) -> (Lints, Vec<Diagnostic>) {
        let mut l = Lints::new();
        let mut bad = Vec::new();
        let mut at = 0usize;
        for (n, line) in text.split_inclusive('\n').enumerate() {
            let start = at;
            at += line.len();
            let line = line.trim_end_matches(['\r', '\n']);
            let t = line.trim_start();
            let Some(rest) = t.strip_prefix("//") else {
                continue;
            };
            let Some(body) = rest.trim_start().strip_prefix("latticesim:") else {
                continue;
            };
            let body_at = start + (line.len() - body.len());
            let mut off = 0;
            for item in body.split(',') {
                let item_at = body_at + off;
                off += item.len() + 1;
                let words: Vec<&str> = item.split_whitespace().collect();
                let lead = item.len() - item.trim_start().len();
                let span = Span {
                    start: (item_at + lead) as u32,
                    end: (item_at + item.trim_end().len().max(lead)) as u32,
                };
                let say = |msg: String| {
                    Diagnostic::new(
                        Code::E106,
                        msg,
                        Label::new(file, span, "this directive"),
                    )
                    .with_help("a directive is `// latticesim: allow CODE`, `warn CODE` or `deny CODE` (a warning's code or name, or `warnings`), or `counters 32`, several separated by commas")
                };
                let Some((&word, targets)) = words.split_first() else {
                    bad.push(say("an empty directive".into()));
                    continue;
                };
                if word == "counters" {
                    match targets {
                        [b] if b.parse().ok().and_then(Width::from_bits).is_some() => {
                            let w = b.parse().ok().and_then(Width::from_bits);
                            l.set_counters(
                                w.unwrap_or_default(),
                                format!("`counters {b}` on line {} of the rules file", n + 1),
                            );
                        }
                        _ => bad.push(say(format!(
                            "`counters` takes 16 or 32 (the bits of counters and messages), not `{}`",
                            targets.join(" ")
                        ))),
                    }
                    continue;
                }
                let Some(level) = Level::parse(word) else {
                    bad.push(say(format!(
                        "`{word}` is not a lint level (`allow`, `warn` or `deny`)"
                    )));
                    continue;
                };
                if targets.is_empty() {
                    bad.push(say(format!("`{word}` says no warning")));
                }
                for &t in targets {
                    match Target::parse(t) {
                        Ok(target) => l.push(
                            target,
                            level,
                            format!("`{word} {t}` on line {} of the rules file", n + 1),
                        ),
                        Err(e) => bad.push(say(e)),
                    }
                }
            }
        }
        (l, bad)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn w(code: Code) -> Diagnostic {
        Diagnostic::new(
            code,
            "w",
            Label::new(FileId(0), Span { start: 0, end: 1 }, ""),
        )
    }

    /// Codes, names and `warnings`; a code's level over `warnings`'; the last said wins;
    /// errors keep theirs.
    #[test]
    fn levels_apply_by_code_name_and_all() {
        let (f, bad) = Lints::from_rules(
            "// latticesim: deny warnings, allow idle-start-state\nr\n1\n// latticesim: warn W501\n",
            FileId(0),
        );
        assert!(bad.is_empty(), "{bad:?}");
        let mut d = vec![w(Code::W501), w(Code::W502), w(Code::W603), w(Code::E302)];
        f.apply(&mut d);
        let got: Vec<_> = d.iter().map(|d| (d.code, d.is_error())).collect();
        assert_eq!(
            got,
            [(Code::W501, false), (Code::W502, true), (Code::E302, true)]
        );
        assert_eq!(
            d[1].denied.as_deref(),
            Some("`deny warnings` on line 1 of the rules file")
        );
        let cli = Lints::from_flags(&["W502".into()], &[], &["W603".into()]).unwrap();
        let mut d = vec![w(Code::W502), w(Code::W603)];
        f.then(&cli).apply(&mut d);
        assert_eq!(d.len(), 1);
        assert_eq!(d[0].denied.as_deref(), Some("`--deny W603`"));
        assert!(Lints::from_flags(&[], &[], &["E302".into()]).is_err());
        assert!(Lints::from_flags(&["W999".into()], &[], &[]).is_err());
    }

    /// The width of counters: from a directive, the command line's after it.
    #[test]
    fn counters_are_said_by_the_file_and_the_command_line() {
        let (f, bad) = Lints::from_rules("// latticesim: counters 32, deny warnings\n", FileId(0));
        assert!(bad.is_empty(), "{bad:?}");
        assert_eq!(f.width(), Width::W32);
        assert_eq!(Lints::new().width(), Width::W16);
        let mut cli = Lints::new();
        cli.set_counters(Width::W16, "`--counters 16`");
        assert_eq!(f.then(&cli).width(), Width::W16);
        assert_eq!(f.then(&Lints::new()).width(), Width::W32);
        for wrong in ["counters 64", "counters", "counters 32 16"] {
            let (_, bad) = Lints::from_rules(&format!("// latticesim: {wrong}\n"), FileId(0));
            assert_eq!(bad.len(), 1, "{wrong}");
        }
    }

    /// Directives that cannot be read: E106 on the part, the rest honoured.
    #[test]
    fn bad_directives_are_said_where_they_are() {
        let text = "// latticesim: forbid W603, deny W501 E302,\n";
        let (l, bad) = Lints::from_rules(text, FileId(0));
        let at: Vec<&str> = bad
            .iter()
            .map(|d| &text[d.primary.span.start as usize..d.primary.span.end as usize])
            .collect();
        assert_eq!(at, ["forbid W603", "deny W501 E302", ""]);
        let mut d = vec![w(Code::W501)];
        l.apply(&mut d);
        assert!(d[0].is_error());
    }
}
