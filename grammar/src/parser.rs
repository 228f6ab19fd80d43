//! Parsing rules.txt: the rule structure (four significant lines) by hand, each condition
//! line with the lalrpop grammar, and every lexical and syntax error turned into a
//! [`Diagnostic`].
//!
//! Recovery: each line is parsed on its own, so one broken line never hides the next. Within
//! a line, characters that start no token and unbalanced parentheses are reported and removed
//! before parsing, and the grammar's error productions skip to the next term.

use crate::ast::{Comp, Operand, Rule, RulesFile, Term, Terms};
use crate::diag::{Code, Diagnostic, Label};
use crate::lexer::{BadChar, Lexer, Spanned3, Tok};
use crate::lines::{significant_lines, Line};
use crate::span::{FileId, Span, Spanned};
use bumpalo::Bump;
use lalrpop_util::{ErrorRecovery, ParseError};

lalrpop_util::lalrpop_mod!(
    #[allow(clippy::all, clippy::pedantic, missing_docs, unused)]
    rules_grammar,
    "/rules.rs"
);

/// Records a blank between two pieces of one term (`a` is where the first ended, `b` where
/// the next starts).
pub(crate) fn touch(gaps: &mut Vec<Span>, a: usize, b: usize) {
    if a < b {
        gaps.push(Span::new(a, b));
    }
}

/// Builds an external-counter operand from its first coordinate and the `,c` pieces after it.
pub(crate) fn external<'a>(
    arena: &'a Bump,
    first: Spanned<Comp<'a>>,
    rest: Vec<(usize, Spanned<Comp<'a>>)>,
    gaps: &mut Vec<Span>,
) -> Operand<'a> {
    let mut all = vec![first];
    let mut end = first.span.end as usize;
    for (comma, c) in rest {
        touch(gaps, end, comma);
        touch(gaps, comma + 1, c.span.start as usize);
        end = c.span.end as usize;
        all.push(c);
    }
    let span = first.span.to(all[all.len() - 1].span);
    Operand::External(Spanned::new(arena.alloc_slice_copy(&all), span))
}

/// Parses a rules file. `dim_hint` (2 or 3), when known, decides how an ambiguous `T` term
/// splits into offset and state. Returns every complete rule (lines with syntax errors keep
/// what could be read) and the diagnostics in file order.
pub fn parse_rules<'a>(
    src: &'a str,
    file: FileId,
    arena: &'a Bump,
    dim_hint: Option<u8>,
) -> (RulesFile<'a>, Vec<Diagnostic>) {
    let mut diags = Vec::new();
    // About 90 bytes make a rule; reserving avoids doubling a large vector at the end.
    let mut rules = Vec::with_capacity(src.len() / 128);
    // Lines are taken four at a time as they come; nothing holds the whole file's lines.
    let mut chunk: Vec<Line<'a>> = Vec::with_capacity(4);
    let mut toks = Vec::with_capacity(32);
    for line in significant_lines(src) {
        chunk.push(line);
        if chunk.len() < 4 {
            continue;
        }
        let [name, prio, pre, post] = [chunk[0], chunk[1], chunk[2], chunk[3]];
        chunk.clear();
        let priority = parse_priority(prio, file, &mut diags);
        let pre = parse_line(pre, file, arena, dim_hint, &mut diags, &mut toks);
        let post = parse_line(post, file, arena, dim_hint, &mut diags, &mut toks);
        rules.push(Rule {
            name: Spanned::new(name.text, line_span(name)),
            priority,
            pre,
            post,
        });
    }
    let rest = &chunk[..];
    if let Some(first) = rest.first() {
        let missing = ["priority", "precondition", "postcondition"];
        let last = rest[rest.len() - 1];
        let span = line_span(*first).to(line_span(last));
        let lacks = match &missing[rest.len() - 1..] {
            [a, b, c] => format!("{a}, {b} and {c}"),
            [a, b] => format!("{a} and {b}"),
            [a] => a.to_string(),
            _ => unreachable!("a remainder has 1 to 3 lines"),
        };
        diags.push(
            Diagnostic::new(
                Code::E103,
                format!(
                    "the rule `{}` is cut short by the end of the file: its {} line{} missing",
                    first.text,
                    lacks,
                    if rest.len() == 3 { " is" } else { "s are" }
                ),
                Label::new(file, span, "this rule has only these lines"),
            )
            .with_help(
                "a rule is four lines: name, priority, precondition, postcondition; \
                 complete it or delete it",
            ),
        );
    }
    (RulesFile { rules }, diags)
}

fn line_span(line: Line<'_>) -> Span {
    Span::new(line.start, line.start + line.text.len())
}

fn parse_priority(
    line: Line<'_>,
    file: FileId,
    diags: &mut Vec<Diagnostic>,
) -> Spanned<Option<i64>> {
    let span = line_span(line);
    let t = line.text;
    let digits = t.strip_prefix('-').unwrap_or(t);
    let value = if !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()) {
        Some(t.parse::<i64>().unwrap_or(if t.starts_with('-') {
            i64::MIN
        } else {
            i64::MAX
        }))
    } else {
        diags.push(
            Diagnostic::new(
                Code::E205,
                format!("the priority line `{t}` is not a whole number"),
                Label::new(file, span, "expected the rule's priority here"),
            )
            .with_help(
                "the second line of a rule is its priority, a whole number from 1 to 32767 \
                 (did a line go missing above?)",
            ),
        );
        None
    };
    Spanned::new(value, span)
}

/// How deep `!` and `(` may nest in one line. Every later phase walks terms recursively, so
/// this bounds their stack (a few hundred bytes a level) far below any thread's.
pub const MAX_NESTING: usize = 100;

/// Lexes one line, reporting bad characters and unbalanced parentheses and leaving them out,
/// and refusing lines nested deeper than [`MAX_NESTING`].
fn clean_tokens<'a>(
    line: Line<'a>,
    file: FileId,
    dim_hint: Option<u8>,
    diags: &mut Vec<Diagnostic>,
    toks: &mut Vec<Spanned3<'a>>,
) {
    toks.clear();
    let mut open = Vec::new();
    let mut drop = Vec::new();
    // How deep the next term is: the levels of the open groups (each `(` and every `!`
    // before it count one), plus the `!`s just read.
    let mut levels: Vec<usize> = Vec::new();
    let mut bangs = 0;
    for r in Lexer::new(line.text, line.start, dim_hint) {
        match r {
            Ok(t) => {
                let depth = levels.last().copied().unwrap_or(0) + bangs;
                match t.1 {
                    Tok::Bang | Tok::LParen if depth >= MAX_NESTING => {
                        diags.push(
                            Diagnostic::new(
                                Code::E206,
                                format!("`!` and `(` are nested more than {MAX_NESTING} deep"),
                                Label::new(
                                    file,
                                    Span::new(t.0, t.2),
                                    format!("level {} starts here", depth + 1),
                                ),
                            )
                            .with_help(
                                "a double `!` cancels out and a group of one term needs no \
                                 parentheses; write the condition flatter",
                            ),
                        );
                        // The line is not parsed further: nothing deeper is built.
                        toks.clear();
                        return;
                    }
                    Tok::Bang => bangs += 1,
                    Tok::LParen => {
                        levels.push(depth + 1);
                        bangs = 0;
                    }
                    Tok::RParen => {
                        levels.pop();
                        bangs = 0;
                    }
                    _ => bangs = 0,
                }
                match t.1 {
                    Tok::LParen => open.push(toks.len()),
                    // The guard pops the matching `(` when there is one.
                    Tok::RParen if open.pop().is_none() => {
                        diags.push(
                            Diagnostic::new(
                                Code::E201,
                                "a `)` with no `(` before it",
                                Label::new(file, Span::new(t.0, t.2), "unmatched `)`"),
                            )
                            .with_help("delete this `)` or add the `(` it closes"),
                        );
                        drop.push(toks.len());
                    }
                    _ => {}
                }
                toks.push(t);
            }
            Err(BadChar { start, end }) => {
                let c = &line_src(line, start, end);
                diags.push(
                    Diagnostic::new(
                        Code::E102,
                        format!("{} does not start any term", crate::diag::quote_char(c)),
                        Label::new(file, Span::new(start, end), "unexpected character"),
                    )
                    .with_help(
                        "terms start with N, E, F, P, L, Q, A, S, T, M, V, W, X, <, >, =, !, ( \
                         or, in a postcondition, a counter or message slot (see docs/language.md)",
                    ),
                );
            }
        }
    }
    for &i in &open {
        let t = toks[i];
        diags.push(
            Diagnostic::new(
                Code::E203,
                "this `(` is never closed",
                Label::new(file, Span::new(t.0, t.2), "opened here"),
            )
            .with_help("add `)` after the last term of the group"),
        );
    }
    drop.extend(open);
    drop.sort_unstable();
    let mut k = 0;
    let mut i = 0;
    toks.retain(|_| {
        let keep = drop.get(k) != Some(&i);
        if !keep {
            k += 1;
        }
        i += 1;
        keep
    });
}

fn line_src(line: Line<'_>, start: usize, end: usize) -> &str {
    &line.text[start - line.start..end - line.start]
}

fn parse_line<'a>(
    line: Line<'a>,
    file: FileId,
    arena: &'a Bump,
    dim_hint: Option<u8>,
    diags: &mut Vec<Diagnostic>,
    toks: &mut Vec<Spanned3<'a>>,
) -> Terms<'a> {
    let span = line_span(line);
    clean_tokens(line, file, dim_hint, diags, toks);
    let mut recovered: Vec<ErrorRecovery<usize, Tok<'a>, BadChar>> = Vec::new();
    let mut gaps = Vec::new();
    let end = span.end as usize;
    let result = rules_grammar::LineParser::new().parse(
        arena,
        &mut recovered,
        &mut gaps,
        toks.iter().map(|&t| Ok::<_, BadChar>(t)),
    );
    for e in recovered {
        diags.push(syntax_error(e.error, line, file, end));
    }
    for g in gaps {
        diags.push(
            Diagnostic::new(
                Code::E204,
                "a blank inside a term",
                Label::new(file, g, "remove this blank"),
            )
            .with_help(
                "the pieces of one term are written together, e.g. `E-1,0`, `T1,0,ABCDE`, \
                 `<C00 0010`",
            ),
        );
    }
    let terms: &'a [Spanned<Term<'a>>] = match result {
        Ok(v) => arena.alloc_slice_copy(&v),
        Err(e) => {
            diags.push(syntax_error(e, line, file, end));
            &[]
        }
    };
    Spanned::new(terms, span)
}

fn syntax_error(
    e: ParseError<usize, Tok<'_>, BadChar>,
    line: Line<'_>,
    file: FileId,
    end: usize,
) -> Diagnostic {
    match e {
        ParseError::UnrecognizedToken {
            token: (l, _, r),
            expected,
        } => {
            let text = line_src(line, l, r);
            Diagnostic::new(
                Code::E201,
                format!("`{text}` cannot stand here"),
                Label::new(
                    file,
                    Span::new(l, r),
                    format!("expected {}", describe(&expected)),
                ),
            )
            .with_help(help_for(&expected))
        }
        ParseError::UnrecognizedEof { expected, .. } => {
            let last_word_start = line.text.rfind(crate::lines::is_blank).map_or(0, |i| i + 1);
            let span = Span::new(line.start + last_word_start, end);
            Diagnostic::new(
                Code::E202,
                "the line ends in the middle of a term",
                Label::new(
                    file,
                    span,
                    format!("expected {} after this", describe(&expected)),
                ),
            )
            .with_help(help_for(&expected))
        }
        ParseError::User { error } => Diagnostic::new(
            Code::E102,
            "a character that starts no term",
            Label::new(
                file,
                Span::new(error.start, error.end),
                "unexpected character",
            ),
        ),
        ParseError::InvalidToken { location }
        | ParseError::ExtraToken {
            token: (location, _, _),
        } => Diagnostic::new(
            Code::E201,
            "a token where it cannot stand",
            Label::new(file, Span::new(location, location + 1), "here"),
        ),
    }
}

/// Words for what the grammar expected.
fn describe(expected: &[String]) -> String {
    let mut words: Vec<&str> = Vec::new();
    let has = |t: &str| expected.iter().any(|e| e == t);
    if has("\"npat\"") {
        return "a term or the end of the line".into();
    }
    for e in expected {
        let w = match e.as_str() {
            "\"int\"" => "a number",
            "\"counter\"" => "a counter (C00)",
            "\"msgref\"" => "a message slot (#N01)",
            "\",\"" => "`,`",
            "\"state\"" => "a state of 5 characters",
            "\")\"" => "`)`",
            "\"+\"" | "\"-\"" | "\"*\"" | "\"/\"" | "\"M\"" | "\"A\"" | "\"I\"" => {
                "an operation (+ - * / M A I)"
            }
            _ => continue,
        };
        if !words.contains(&w) {
            words.push(w);
        }
    }
    match words.len() {
        0 => "something else".into(),
        1 => words[0].into(),
        n => format!("{} or {}", words[..n - 1].join(", "), words[n - 1]),
    }
}

fn help_for(expected: &[String]) -> &'static str {
    let has = |t: &str| expected.iter().any(|e| e == t);
    if has("\"+\"") {
        "a calculation is `target op a b`, e.g. `C00 + C01 0001`"
    } else if has("\"state\"") {
        "a remote state term is `Tdx,dy,STATE`, e.g. `T1,0,ABCDE`"
    } else if has("\"int\"") && has("\"counter\"") && !has("\"msgref\"") {
        "an offset is numbers or counters separated by commas, e.g. `E-1,0` or `PC03,0`"
    } else if has("\"int\"") {
        "a value is a number (0010), a counter (C03) or a message slot (#N01)"
    } else {
        "see docs/language.md for the terms of a precondition and the actions of a postcondition"
    }
}
