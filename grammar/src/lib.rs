//! The front end's first half: from the text of rules.txt and agents.txt to syntax trees.
//!
//! - [`lines`] splits a file into significant lines (comments and blanks gone),
//! - [`lexer`] turns a condition line into tokens (`logos`),
//! - the lalrpop grammar in `rules.lalrpop` builds [`ast`] nodes in a `bumpalo` arena,
//! - [`parse_rules`] and [`parse_agents`] drive it and report every problem as a
//!   [`Diagnostic`] with a code from the one table in [`diag`],
//! - [`pretty`] prints a tree back as text that parses to the same tree.
//!
//! Nothing here judges meaning (dimensions, ranges, placement): that is the compiler's.
#![warn(missing_docs)]

pub mod agents;
pub mod ast;
pub mod diag;
pub mod format;
pub mod lexer;
pub mod lines;
mod parser;
pub mod pretty;
pub mod span;
pub mod structure;

pub use agents::parse_agents;
pub use diag::{Code, Diagnostic, Edit, Fix, Label, Severity, Text};
pub use parser::{parse_rules, MAX_NESTING};
pub use span::{FileId, Span, Spanned};

/// Decodes a file's bytes, reporting invalid UTF-8 (E101) at the first bad byte. The text
/// returned keeps every byte position: each invalid byte becomes `?`.
pub fn decode(bytes: &[u8], file: FileId) -> (String, Option<Diagnostic>) {
    match std::str::from_utf8(bytes) {
        Ok(s) => (s.to_owned(), None),
        Err(e) => {
            let at = e.valid_up_to();
            let text: String = bytes
                .iter()
                .map(|&b| if b.is_ascii() { b as char } else { '?' })
                .collect();
            let d = Diagnostic::new(
                Code::E101,
                format!("the file is not valid UTF-8 (first bad byte at offset {at})"),
                Label::new(file, Span::new(at, at + 1), "this byte is not UTF-8"),
            )
            .with_help("save the file as UTF-8; rules and agents files use ASCII characters");
            (text, Some(d))
        }
    }
}
