//! Diagnostics: the one table of codes, and the `Diagnostic` value every phase builds.
//!
//! Every problem latticesim reports in an input file has a stable code. Codes are grouped by
//! the phase that finds them and are never reused:
//!
//! | range | phase |
//! |---|---|
//! | E1xx | reading and splitting a file (encoding, characters, rule structure) |
//! | E2xx | syntax of a precondition or postcondition line |
//! | E3xx | checks of rules: dimension, ranges, placement of terms and actions |
//! | E4xx | agents files |
//! | W5xx | warnings about rules |
//! | W6xx | warnings about agents files |
//!
//! Rendering (terminal text, JSON) lives in the compiler crate; this module only describes.

use crate::span::{FileId, Span};

/// A piece of text for a message: in backquotes, or named when it is a single control
/// character (which would be invisible, or act on the terminal, if shown).
pub fn quote_char(text: &str) -> String {
    let mut chars = text.chars();
    match (chars.next(), chars.next()) {
        (Some('\r'), None) => "a lone carriage return (CR, `\\r`)".into(),
        (Some('\0'), None) => "a NUL character (U+0000)".into(),
        (Some('\x1b'), None) => "an escape character (ESC, U+001B)".into(),
        (Some(c), None) if c.is_control() => {
            format!("the control character U+{:04X}", c as u32)
        }
        _ => format!("`{text}`"),
    }
}

/// How serious a diagnostic is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    /// The input cannot be run; `check` exits 1.
    Error,
    /// Suspicious but runnable.
    Warning,
}

macro_rules! codes {
    ($($code:ident $sev:ident $slug:literal $title:literal;)*) => {
        /// A diagnostic code. See the module documentation for the ranges.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub enum Code { $(#[doc = $title] $code,)* }

        impl Code {
            /// Every code, in table order.
            pub const ALL: &'static [Code] = &[$(Code::$code,)*];

            /// The code as written in messages, e.g. `E302`.
            pub fn as_str(self) -> &'static str {
                match self { $(Code::$code => stringify!($code),)* }
            }

            /// A short kebab-case name, e.g. `pattern-length`.
            pub fn slug(self) -> &'static str {
                match self { $(Code::$code => $slug,)* }
            }

            /// One line saying what the code is about.
            pub fn title(self) -> &'static str {
                match self { $(Code::$code => $title,)* }
            }

            /// Error or warning.
            pub fn severity(self) -> Severity {
                match self { $(Code::$code => Severity::$sev,)* }
            }

            /// Looks a code up by its written form (`E302`).
            pub fn parse(s: &str) -> Option<Code> {
                match s { $(stringify!($code) => Some(Code::$code),)* _ => None }
            }
        }
    };
}

codes! {
    E101 Error "invalid-utf8" "the file is not valid UTF-8";
    E102 Error "invalid-character" "a character that starts no term";
    E103 Error "rule-cut-short" "a rule cut short at the end of the file";
    E104 Error "rule-missing-line" "a rule that lacks its name, priority, precondition or postcondition line";
    E105 Error "rule-extra-line" "a line after a rule's postcondition that starts no rule";
    E106 Error "bad-directive" "a `// latticesim:` directive that cannot be read";
    E201 Error "unexpected-token" "a token where it cannot stand";
    E202 Error "unexpected-end-of-line" "a line that ends inside a term";
    E203 Error "unclosed-parenthesis" "a `(` without its `)`";
    E204 Error "blank-inside-term" "a blank inside a term";
    E205 Error "bad-priority" "a priority line that is not a whole number";
    E206 Error "nested-too-deeply" "`!` and `(` nested deeper than latticesim allows";
    E301 Error "dimension-conflict" "two sources disagree about the dimension";
    E302 Error "pattern-length" "an N, A or P pattern of the wrong length";
    E303 Error "text-length" "a state or message text that is not 5 characters";
    E304 Error "bad-pattern-character" "a character a pattern or state does not allow";
    E305 Error "counter-range" "a counter that does not exist in this dimension";
    E306 Error "message-slot-range" "a numeric message slot that does not exist in this dimension";
    E307 Error "direction-3d-only" "a direction that exists only in 3D (A, B) used in 2D";
    E308 Error "term-2d-only" "a term that exists only in 2D (V, W, external counters) used in 3D";
    E309 Error "priority-range" "a priority outside 1..32767";
    E310 Error "literal-range" "a number outside -32767..32767";
    E311 Error "message-wildcards" "a message pattern with more than four `*`";
    E312 Error "precondition-term-in-postcondition" "a precondition term in a postcondition";
    E313 Error "postcondition-action-in-precondition" "a postcondition action in a precondition";
    E314 Error "duplicate-action" "a second P, X, A or S action in one postcondition";
    E315 Error "move-with-swap" "a move (P) and a swap (X) in one postcondition";
    E316 Error "offset-arity" "an offset with the wrong number of coordinates";
    E317 Error "bad-direction" "a direction letter that is not N, W, E, S, A, B (or `*`)";
    E318 Error "wildcard-not-allowed" "a `*` where a definite value is needed";
    E319 Error "remote-counter-form" "a remote or external counter written wrongly";
    E320 Error "logic-in-postcondition" "`!`, `(` or `)` in a postcondition";
    E321 Error "rule-too-large" "a rule too large for the bytecode";
    E322 Error "lines-swapped" "a rule whose precondition and postcondition lines are swapped";
    E401 Error "agents-syntax" "an agents line that cannot be read";
    E402 Error "agents-same-cell" "two agents on one cell";
    E403 Error "agents-outside-universe" "an agent outside the universe";
    E404 Error "agents-counter" "a counter index or value out of range";
    E405 Error "agents-duplicate-field" "a field given twice on one agent line";
    E406 Error "universe-line" "a universe line that is malformed or misplaced";
    E407 Error "agents-dimension" "a position with the wrong number of coordinates";
    E408 Error "agents-state" "an agent state that is not 5 allowed characters";
    E409 Error "agents-attachments" "an attachment field of the wrong length or characters";
    E410 Error "coordinate-range" "a coordinate outside the 32-bit range of the lattice";
    W501 Warning "duplicate-rule-name" "two rules with the same name";
    W502 Warning "contradictory-precondition" "a precondition that can never hold";
    W503 Warning "pattern-never-matches" "an `S` or `T` pattern that no state an agent starts in or a rule sets matches";
    W504 Warning "move-onto-agent" "a move onto a cell the precondition requires to hold an agent";
    W505 Warning "certain-conflict" "two rules of one priority and precondition whose actions conflict";
    W506 Warning "rule-always-outranked" "a rule that a rule of higher priority always outranks";
    W507 Warning "state-one-letter-off" "a state set one letter away from a state the rules test, which no rule tests";
    W601 Warning "one-sided-attachment" "an attachment declared by only one of two agents";
    W602 Warning "attachment-to-empty-cell" "an attachment towards an empty cell";
    W603 Warning "idle-start-state" "agents that start in a state no rule tests or sets";
}

/// A place in a file with a short message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Label {
    /// The file.
    pub file: FileId,
    /// The bytes it marks.
    pub span: Span,
    /// What it says about that place (may be empty).
    pub message: Text,
}

/// The text of a message: a literal kept as it is, or one made for the case (most labels
/// and help lines are literals: a file with tens of thousands of warnings holds no copy).
pub type Text = std::borrow::Cow<'static, str>;

impl Label {
    /// A label with a message.
    pub fn new(file: FileId, span: Span, message: impl Into<Text>) -> Label {
        Label {
            file,
            span,
            message: message.into(),
        }
    }
}

/// A replacement of some text of one file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Edit {
    /// The file.
    pub file: FileId,
    /// The bytes replaced (empty to insert).
    pub span: Span,
    /// What they are replaced with (empty to delete).
    pub replacement: String,
}

/// A suggested fix: what it does in words and the edits that do it. Applying every edit of a
/// fix (they never overlap) turns the text into what the suggestion says; editors offer it
/// as a quick fix, and `check --format json` lists it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Fix {
    /// One short sentence, e.g. "write `0` (zero), not the letter `O`".
    pub message: String,
    /// The edits, in file order.
    pub edits: Vec<Edit>,
}

impl Fix {
    /// A fix that replaces one span.
    pub fn replace(
        message: impl Into<String>,
        file: FileId,
        span: Span,
        replacement: impl Into<String>,
    ) -> Fix {
        Fix {
            message: message.into(),
            edits: vec![Edit {
                file,
                span,
                replacement: replacement.into(),
            }],
        }
    }

    /// The text with every edit of this fix applied (edits outside `text` are ignored).
    pub fn apply(&self, text: &str, file: FileId) -> String {
        let mut edits: Vec<&Edit> = self.edits.iter().filter(|e| e.file == file).collect();
        edits.sort_by_key(|e| e.span.start);
        let mut out = String::with_capacity(text.len());
        let mut at = 0;
        for e in edits {
            let (s, t) = (e.span.start as usize, e.span.end as usize);
            if s < at || t > text.len() {
                continue;
            }
            out.push_str(&text[at..s]);
            out.push_str(&e.replacement);
            at = t;
        }
        out.push_str(&text[at..]);
        out
    }
}

/// One problem found in an input file.
///
/// It always has a primary label: the constructor takes it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Diagnostic {
    /// The stable code.
    pub code: Code,
    /// One sentence.
    pub message: Text,
    /// The exact place.
    pub primary: Label,
    /// Other places involved.
    pub secondary: Vec<Label>,
    /// How to fix it, if we can say.
    pub help: Option<Text>,
    /// Machine-applicable fixes, most likely first.
    pub fixes: Vec<Fix>,
    /// For a warning made an error by a lint level: where it was denied (`--deny W603`).
    pub denied: Option<String>,
}

impl Diagnostic {
    /// A diagnostic with its code, message and primary label.
    pub fn new(code: Code, message: impl Into<Text>, primary: Label) -> Diagnostic {
        Diagnostic {
            code,
            message: message.into(),
            primary,
            secondary: Vec::new(),
            help: None,
            fixes: Vec::new(),
            denied: None,
        }
    }

    /// Adds a suggested fix.
    pub fn with_fix(mut self, fix: Fix) -> Diagnostic {
        self.fixes.push(fix);
        self
    }

    /// Adds a secondary label.
    pub fn with_secondary(mut self, label: Label) -> Diagnostic {
        self.secondary.push(label);
        self
    }

    /// Sets the help line.
    pub fn with_help(mut self, help: impl Into<Text>) -> Diagnostic {
        self.help = Some(help.into());
        self
    }

    /// Error or warning, from the code.
    pub fn severity(&self) -> Severity {
        match self.denied {
            Some(_) => Severity::Error,
            None => self.code.severity(),
        }
    }

    /// True for errors.
    pub fn is_error(&self) -> bool {
        self.severity() == Severity::Error
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_unique_and_grouped() {
        let mut seen = std::collections::HashSet::new();
        for &c in Code::ALL {
            assert!(seen.insert(c.as_str()), "{c:?} twice");
            assert!(seen.insert(c.slug()), "slug of {c:?} twice");
            assert_eq!(Code::parse(c.as_str()), Some(c));
            let warning = c.as_str().starts_with('W');
            assert_eq!(warning, c.severity() == Severity::Warning, "{c:?}");
        }
    }
}
