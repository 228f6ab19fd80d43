//! Parsing rules.txt: the rule structure (four significant lines, found by
//! [`crate::structure`]), each condition line with the lalrpop grammar, and every lexical and
//! syntax error turned into a [`Diagnostic`].
//!
//! Recovery: each line is parsed on its own, so one broken line never hides the next. Within
//! a line, a character that starts no token is reported once for its word, which is left out;
//! unbalanced parentheses are reported and left out; and a syntax error takes the broken term
//! out (from the last place a term could start to the next) before the line is read again,
//! errors in what touches a term already taken out being its consequences, not reported. So
//! one slip is one error, and every message quotes the file as written.

use crate::ast::{Comp, Operand, Rule, RulesFile, Term, Terms};
use crate::diag::{Code, Diagnostic, Fix, Label};
use crate::lexer::{BadChar, Lexer, Spanned3, Tok};
use crate::lines::{significant_lines, Line};
use crate::span::{FileId, Span, Spanned};
use crate::structure::Layout;
use bumpalo::Bump;
use lalrpop_util::ParseError;

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
///
/// The rule structure is found first, from the shape of the file ([`crate::structure`]): a
/// rule that lacks a line or has one too many is reported once, on that rule, and its
/// neighbours are read as written. A rule that lacks a line is not read further.
pub fn parse_rules<'a>(
    src: &'a str,
    file: FileId,
    arena: &'a Bump,
    dim_hint: Option<u8>,
) -> (RulesFile<'a>, Vec<Diagnostic>) {
    let mut diags = Vec::new();
    // About 90 bytes make a rule; reserving avoids doubling a large vector at the end.
    let mut rules = Vec::with_capacity(src.len() / 128);
    let mut toks = Vec::with_capacity(32);
    let mut read = |l: Layout<'a>, last: bool, diags: &mut Vec<Diagnostic>| {
        if let Some((a, b)) = l.extra {
            diags.push(extra_lines(&l, a, b, file));
        }
        let (Some(name), Some(prio), Some(pre), Some(post)) = (l.name, l.priority, l.pre, l.post)
        else {
            diags.push(missing_lines(&l, last, file));
            return;
        };
        let priority = parse_priority(prio, file, diags);
        let pre = parse_line(pre, false, file, arena, dim_hint, diags, &mut toks);
        let post = parse_line(post, true, file, arena, dim_hint, diags, &mut toks);
        rules.push(Rule {
            name: Spanned::new(name.text, line_span(name)),
            priority,
            pre,
            post,
        });
    };
    // Each rule is read once the next is known (the last one is told so).
    let mut prev: Option<Layout<'a>> = None;
    crate::structure::for_each(significant_lines(src), |l| {
        if let Some(p) = prev.replace(l) {
            read(p, false, &mut diags);
        }
    });
    if let Some(p) = prev {
        read(p, true, &mut diags);
    }
    (RulesFile { rules }, diags)
}

const RULE_IS_FOUR_LINES: &str =
    "a rule is four lines: name, priority, precondition, postcondition (see docs/language.md)";

/// E105: lines after a rule's postcondition that start no rule.
fn extra_lines(l: &Layout<'_>, a: Line<'_>, b: Line<'_>, file: FileId) -> Diagnostic {
    let n = b.number - a.number + 1;
    let name = l.name.map_or("", |n| n.text);
    let span = line_span(a).to(line_span(b));
    let many = if n == 1 {
        "a line too many".to_string()
    } else {
        format!("{n} lines too many")
    };
    Diagnostic::new(
        Code::E105,
        format!("the rule `{name}` has {many}: it ended with its postcondition"),
        Label::new(file, span, "after the postcondition"),
    )
    .with_help(format!(
        "{RULE_IS_FOUR_LINES}; delete {}, or make {} a rule of its own with a name and a priority",
        if n == 1 { "this line" } else { "these lines" },
        if n == 1 { "it" } else { "them" },
    ))
}

/// E104 (E103 for the last rule of the file when it lacks its end): the lines a rule lacks,
/// reported on the line after which (or before which) the first of them belongs.
fn missing_lines(l: &Layout<'_>, last: bool, file: FileId) -> Diagnostic {
    let parts = [
        ("name", l.name.is_none()),
        ("priority", l.priority.is_none()),
        ("precondition", l.pre.is_none()),
        ("postcondition", l.post.is_none()),
    ];
    let lacks: Vec<&str> = parts.iter().filter(|p| p.1).map(|p| p.0).collect();
    let lacks_text = match lacks.as_slice() {
        [a] => format!("{a} line is"),
        [a, b] => format!("{a} and {b} lines are"),
        [rest @ .., z] => format!("{} and {z} lines are", rest.join(", ")),
        [] => "lines are".into(),
    };
    let first_missing = parts.iter().position(|p| p.1).unwrap_or(3);
    let name = l.name.map(|n| n.text);
    // The line just before the first missing one; or the first line, when it is the name.
    let before = [l.name, l.priority, l.pre, l.post][..first_missing]
        .iter()
        .rev()
        .find_map(|x| *x);
    let (code, message) = match name {
        Some(n) if last && l.post.is_none() => (
            Code::E103,
            format!("the rule `{n}` is cut short by the end of the file: its {lacks_text} missing"),
        ),
        Some(n) => (
            Code::E104,
            format!("the rule `{n}` lacks a line: its {lacks_text} missing"),
        ),
        None => (
            Code::E104,
            format!("a rule lacks a line: its {lacks_text} missing"),
        ),
    };
    let label = match before {
        Some(b) => Label::new(
            file,
            line_span(b),
            format!("expected the {} after this line", lacks[0]),
        ),
        None => Label::new(
            file,
            l.lines().next().map_or(Span::default(), line_span),
            format!("expected the {} before this line", lacks[0]),
        ),
    };
    let mut d = Diagnostic::new(code, message, label).with_help(format!(
        "{RULE_IS_FOUR_LINES}; add the missing line{} or delete the rule",
        if lacks.len() == 1 { "" } else { "s" }
    ));
    if let (Some(n), Some(b)) = (l.name, before) {
        if n != b {
            d = d.with_secondary(Label::new(file, line_span(n), "the rule starts here"));
        }
    }
    // Only the priority missing: the rule reads whole once it has one.
    if let (["priority"], Some(pre)) = (lacks.as_slice(), l.pre) {
        d = d.with_fix(Fix::replace(
            "add the priority line `1` (the lowest: a higher number wins over lower ones)",
            file,
            Span::new(pre.start, pre.start),
            "1\n",
        ));
    }
    d
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
        let mut d = Diagnostic::new(
            Code::E205,
            format!("the priority line `{t}` is not a whole number"),
            Label::new(file, span, "expected the rule's priority here"),
        )
        .with_help("the second line of a rule is its priority, a whole number from 1 to 32767");
        let digits: String = t
            .chars()
            .map(|c| match c {
                'O' | 'o' => '0',
                'l' | 'I' => '1',
                c => c,
            })
            .collect();
        if crate::structure::is_priority(&digits) {
            // As a number is written: `O5` was `5` with a stray letter, not `05`.
            let number = digits.parse::<i64>().map_or(digits, |n| n.to_string());
            d = d.with_fix(Fix::replace(
                format!("write the number `{number}` with digits"),
                file,
                span,
                number,
            ));
        }
        diags.push(d);
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
    (dim_hint, arena): (Option<u8>, &'a Bump),
    diags: &mut Vec<Diagnostic>,
    toks: &mut Vec<Spanned3<'a>>,
    removed: &mut Vec<Span>,
) {
    toks.clear();
    // Terms split by a blank after their letter (`S STOP0`) are read joined, with one
    // E204 each (the fix removes the blank).
    let split = split_terms(line);
    for &(a, b) in &split {
        diags.push(blank_inside(file, Span::new(a, b)));
    }
    let joined = Joined::of(line, &split, arena);
    let mut open = Vec::new();
    let mut drop = Vec::new();
    let mut bad: Vec<(usize, usize)> = Vec::new();
    // How deep the next term is: the levels of the open groups (each `(` and every `!`
    // before it count one), plus the `!`s just read.
    let mut levels: Vec<usize> = Vec::new();
    let mut bangs = 0;
    for r in Lexer::new(joined.text, line.start, dim_hint) {
        let r = joined.map(r);
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
            Err(BadChar { start, end }) => bad.push((start, end)),
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
    // A character that starts no term spoils its word (up to the blanks around it): one
    // error for the word, and its pieces are not read (so they cause no more).
    // Bad characters and tokens are both in line order: one pass over each.
    let (mut j, mut word_end) = (0, None);
    for (start, end) in bad {
        if word_end.is_some_and(|we| start < we) {
            continue;
        }
        let (ws, we) = word_around(line, start, end);
        word_end = Some(we);
        let d = bad_char(line, file, start, end);
        // A number with the letter O or l for a digit (`0O09`): read as the number its
        // fix writes, so that the rest of the line reads as it was meant.
        let number = (d.fixes.first())
            .filter(|f| f.edits.len() == 1 && matches!(&*f.edits[0].replacement, "0" | "1"))
            .and_then(|f| {
                let (e, word) = (&f.edits[0], line_src(line, ws, we));
                let a = (e.span.start as usize).checked_sub(ws)?;
                let b = (e.span.end as usize).checked_sub(ws)?;
                let (x, y) = (word.get(..a)?, word.get(b..)?);
                format!("{x}{}{y}", e.replacement).parse::<i64>().ok()
            });
        diags.push(d);
        while j < toks.len() && toks[j].0 < ws {
            j += 1;
        }
        let first = j;
        while j < toks.len() && toks[j].0 < we {
            if !matches!(toks[j].1, Tok::LParen | Tok::RParen) {
                drop.push(j);
            }
            j += 1;
        }
        if let (Some(n), Some(t)) = (number, toks.get_mut(first).filter(|_| first < j)) {
            // The word's first token stands for it all.
            *t = (ws, Tok::Int(n), we);
            drop.retain(|&k| k != first);
            continue;
        }
        // The range reaches the next token: a term that starts there and fails is the
        // rest of this one (`c01 A C01 C02`).
        let next = toks.get(j).map_or(we, |t| t.0);
        removed.push(Span::new(ws, next));
    }
    drop.sort_unstable();
    drop.dedup();
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

/// Terms whose letter stands alone, a blank before the rest: `S STOP0`, `N ***0`,
/// `A **+*`, `X N`, `# N01`, `#N 01`. Each is the blank's byte range (absolute), in line
/// order. Only shapes that are one term when joined and nothing when apart are taken (a
/// letter alone is never a term; `A` and `M` are also operators, so `A` is joined only to
/// a pattern with `*` or `+`, and `M` never).
fn split_terms(line: Line<'_>) -> Vec<(usize, usize)> {
    let t = line.text;
    let mut words: Vec<(usize, usize)> = Vec::new();
    let mut i = 0;
    while i < t.len() {
        if t[i..].starts_with(crate::lines::is_blank) {
            i += t[i..].chars().next().map_or(1, char::len_utf8);
            continue;
        }
        let end = t[i..]
            .find(crate::lines::is_blank)
            .map_or(t.len(), |k| i + k);
        words.push((i, end));
        i = end;
    }
    let dir = |c: char| "NEWSAB".contains(c);
    let mut out = Vec::new();
    for pair in words.windows(2) {
        let ((a, b), (c, d)) = (pair[0], pair[1]);
        let first = t[a..b].trim_start_matches(['!', '(']);
        let rest = t[c..d].trim_end_matches(')');
        if rest.is_empty() || rest.starts_with(['!', '(', ')']) {
            continue;
        }
        let only = |set: &str| rest.chars().all(|ch| set.contains(ch));
        let n = rest.chars().count();
        // A message slot may follow a comparison sign (`=#N01`).
        let slot = first.trim_start_matches(['<', '>', '=']);
        let join = match first {
            _ if slot != first && slot.starts_with('#') && slot.len() <= 2 => {
                slot_split(slot, rest)
            }
            "S" => n == 5 && !rest.contains(['(', ')']),
            "N" => (n == 4 || n == 6) && only("01*"),
            "A" => (n == 4 || n == 6) && only("01*+") && rest.contains(['*', '+']),
            "X" => n == 1 && rest.chars().all(dir),
            f if f.starts_with('#') && f.len() <= 2 => slot_split(f, rest),
            _ => false,
        };
        if join {
            out.push((line.start + b, line.start + c));
        }
    }
    out
}

/// `#` then `N01`, or `#N` then `01`: a message slot with a blank inside.
fn slot_split(first: &str, rest: &str) -> bool {
    let dir = |ch: char| "NEWSAB*".contains(ch);
    let digits2 = |w: &str| w.len() == 2 && w.bytes().all(|b| b.is_ascii_digit());
    match first {
        "#" => {
            let mut cs = rest.chars();
            cs.next().is_some_and(dir) && digits2(cs.as_str())
        }
        f => f[1..].chars().all(dir) && digits2(rest),
    }
}

/// A line's text with some blanks taken out (see [`split_terms`]), and the way back from
/// its positions to the line's.
struct Joined<'a> {
    text: &'a str,
    /// Per blank taken out: where it was in the joined text (relative), and its length.
    cuts: Vec<(usize, usize)>,
    start: usize,
}

impl<'a> Joined<'a> {
    fn of(line: Line<'a>, split: &[(usize, usize)], arena: &'a Bump) -> Joined<'a> {
        if split.is_empty() {
            return Joined {
                text: line.text,
                cuts: Vec::new(),
                start: line.start,
            };
        }
        let mut text = String::with_capacity(line.text.len());
        let (mut from, mut cuts) = (0, Vec::new());
        for &(a, b) in split {
            let (a, b) = (a - line.start, b - line.start);
            text.push_str(&line.text[from..a]);
            cuts.push((text.len(), b - a));
            from = b;
        }
        text.push_str(&line.text[from..]);
        Joined {
            text: arena.alloc_str(&text),
            cuts,
            start: line.start,
        }
    }

    /// A position of the joined text as the line's: after a cut, later by its length (a
    /// start at the cut is after it, an end at the cut before it).
    fn at(&self, abs: usize, is_end: bool) -> usize {
        let o = abs - self.start;
        let moved: usize = (self.cuts.iter())
            .filter(|&&(p, _)| if is_end { p < o } else { p <= o })
            .map(|&(_, len)| len)
            .sum();
        abs + moved
    }

    fn map(&self, r: Result<Spanned3<'a>, BadChar>) -> Result<Spanned3<'a>, BadChar> {
        if self.cuts.is_empty() {
            return r;
        }
        match r {
            Ok((l, t, e)) => Ok((self.at(l, false), t, self.at(e, true))),
            Err(BadChar { start, end }) => Err(BadChar {
                start: self.at(start, false),
                end: self.at(end, true),
            }),
        }
    }
}

fn line_src(line: Line<'_>, start: usize, end: usize) -> &str {
    &line.text[start - line.start..end - line.start]
}

/// How many syntax errors of one line are recovered from; the checker shows at most ten a
/// line.
const MAX_ROUNDS: usize = 24;

/// The bytes of the blank-separated word around `start..end` of a line.
fn word_around(line: Line<'_>, start: usize, end: usize) -> (usize, usize) {
    let t = line.text;
    let (s, e) = (start - line.start, end - line.start);
    let ws = t[..s].rfind(crate::lines::is_blank).map_or(0, |i| i + 1);
    let we = t[e..]
        .find(crate::lines::is_blank)
        .map_or(t.len(), |i| e + i);
    (line.start + ws, line.start + we)
}

/// True for a token that can begin a term (or close a group).
fn starts_term(t: &Tok<'_>) -> bool {
    !matches!(
        t,
        Tok::Comma
            | Tok::Plus
            | Tok::Minus
            | Tok::Star
            | Tok::Slash
            | Tok::OpMod
            | Tok::OpMax
            | Tok::OpMin
            | Tok::Int(_)
            | Tok::StateText(_)
    )
}

/// True when token `j` may start a term: it can begin one, and a blank, a `(`, a `)` or a
/// `!` (or the start of the line) comes before it.
fn resync_at(toks: &[Spanned3<'_>], j: usize) -> bool {
    starts_term(&toks[j].1)
        && (j == 0
            || toks[j].0 > toks[j - 1].2
            || matches!(toks[j - 1].1, Tok::LParen | Tok::RParen | Tok::Bang))
}

/// Parses one precondition (`in_post` false) or postcondition line.
fn parse_line<'a>(
    line: Line<'a>,
    in_post: bool,
    file: FileId,
    arena: &'a Bump,
    dim_hint: Option<u8>,
    diags: &mut Vec<Diagnostic>,
    toks: &mut Vec<Spanned3<'a>>,
) -> Terms<'a> {
    let span = line_span(line);
    // Byte ranges of the line not read: words spoilt by a bad character, terms broken by
    // a syntax error. An error in a term that touches one is a consequence: not reported.
    let mut removed: Vec<Span> = Vec::new();
    clean_tokens(line, file, (dim_hint, arena), diags, toks, &mut removed);
    let end = span.end as usize;
    // Recovery: on a syntax error, the broken term (from the last place a term could
    // start, up to the next) is taken out and the line read again, so one slip is one
    // error and nothing is quoted that is not in the file.
    let mut round = 0;
    loop {
        round += 1;
        if round > MAX_ROUNDS {
            // So many broken terms that more would not be shown: the rest of the line is
            // not read (each round reads the whole line again).
            toks.clear();
        }
        let mut gaps = Vec::new();
        let result = rules_grammar::LineParser::new().parse(
            arena,
            &mut gaps,
            toks.iter().map(|&t| Ok::<_, BadChar>(t)),
        );
        let e = match result {
            Ok(v) => {
                for g in gaps {
                    diags.push(blank_inside(file, g));
                }
                let mut v = v;
                if !removed.is_empty() {
                    // Later phases know the line was not read whole.
                    v.push(Spanned::new(Term::Error, removed[0]));
                }
                return Spanned::new(arena.alloc_slice_copy(&v), span);
            }
            Err(e) => e,
        };
        let k = match &e {
            ParseError::UnrecognizedToken {
                token: (l, _, _), ..
            }
            | ParseError::ExtraToken { token: (l, _, _) } => {
                toks.iter().position(|t| t.0 == *l).unwrap_or(toks.len())
            }
            _ => toks.len(),
        };
        let s = (0..k.min(toks.len()) + usize::from(k < toks.len() && !resync_at(toks, k)))
            .rev()
            .find(|&j| resync_at(toks, j))
            .unwrap_or(0);
        // The next term starts after the token in error, or at it when it is a term
        // letter (a value or comparison sign there belongs to the broken term).
        let strong = toks.get(k).is_some_and(|t| {
            !matches!(
                t.1,
                Tok::Lt | Tok::Gt | Tok::Eq | Tok::Counter(_) | Tok::MsgRef(_) | Tok::RParen
            )
        });
        let first = if strong && k > s { k } else { k + 1 };
        let r = (first..toks.len())
            .find(|&j| resync_at(toks, j))
            .unwrap_or(toks.len());
        let from = toks.get(s).map_or(end, |t| t.0);
        // A term that starts right where a weakly resynchronised one was cut (`C00 = C01
        // 0000` read on from `C01`) is still that term: the range reaches its start.
        let to = match toks.get(r) {
            Some(t) if r > k || r == 0 => t.0,
            Some(_) => toks[r - 1].2,
            None => end,
        };
        let upto = toks.get(k).map_or(end, |t| t.2);
        let touches = removed
            .iter()
            .any(|x| (x.start as usize) <= upto && from <= x.end as usize);
        if !touches {
            let d = match operator_slip(line, in_post, file, toks, (s, k)) {
                Some(d) => d,
                None => {
                    let fix = syntax_fix(line, in_post, file, toks, s, k);
                    syntax_error(e, line, file, (from, end), fix)
                }
            };
            diags.push(d);
        }
        removed.push(Span::new(from, to));
        let before = toks.len();
        let mut i = 0;
        toks.retain(|t| {
            let keep = i < s || i >= r || matches!(t.1, Tok::LParen | Tok::RParen);
            i += 1;
            keep
        });
        if toks.len() == before {
            // Nothing left to take out (only parentheses): the line gives no terms.
            return Spanned::new(
                arena.alloc_slice_copy(&[Spanned::new(Term::Error, span)]),
                span,
            );
        }
    }
}

fn blank_inside(file: FileId, g: Span) -> Diagnostic {
    Diagnostic::new(
        Code::E204,
        "a blank inside a term",
        Label::new(file, g, "remove this blank"),
    )
    .with_help(
        "the pieces of one term are written together, e.g. `E-1,0`, `T1,0,ABCDE`, \
         `<C00 0010`",
    )
    .with_fix(Fix::replace("remove the blank", file, g, ""))
}

/// The diagnostic of a syntax error; `from` is where the broken term starts, `end` where
/// the line ends (bytes).
fn syntax_error(
    e: ParseError<usize, Tok<'_>, BadChar>,
    line: Line<'_>,
    file: FileId,
    (from, end): (usize, usize),
    fix: Option<Fix>,
) -> Diagnostic {
    let d = match e {
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
            let from = from.min(end);
            Diagnostic::new(
                Code::E202,
                "the line ends in the middle of a term",
                Label::new(
                    file,
                    Span::new(from, end),
                    format!("expected {} after this", describe(&expected)),
                ),
            )
            .with_help(help_for(&expected))
        }
        ParseError::User { error } => bad_char(line, file, error.start, error.end),
        ParseError::InvalidToken { location }
        | ParseError::ExtraToken {
            token: (location, _, _),
        } => Diagnostic::new(
            Code::E201,
            "a token where it cannot stand",
            Label::new(file, Span::new(location, location + 1), "here"),
        ),
    };
    match fix {
        Some(f) => d.with_fix(f),
        None => d,
    }
}

/// The comparison operators of other languages (`>=`, `<=`, `==`, `=>`, `=<`, `<>`), as
/// two signs written together, and what the rules language says for each: "at least" is
/// "not below" (`!<`), "at most" is "not above" (`!>`).
fn foreign_operator(a: &Tok<'_>, b: &Tok<'_>) -> Option<&'static str> {
    Some(match (a, b) {
        (Tok::Gt, Tok::Eq) | (Tok::Eq, Tok::Gt) => "!<",
        (Tok::Lt, Tok::Eq) | (Tok::Eq, Tok::Lt) => "!>",
        (Tok::Eq, Tok::Eq) => "=",
        (Tok::Lt, Tok::Gt) => "!=",
        _ => return None,
    })
}

/// E201 with its own message for a comparison written as other languages write it: an
/// operator of two signs (`>=C00 0003`), or a sign between the values (`C00 >= 0003`,
/// `C00 > 0003`, in a precondition), at token `k` of a term that starts at token `s`. The
/// fix writes the paper's form, which means the same for every value.
fn operator_slip(
    line: Line<'_>,
    in_post: bool,
    file: FileId,
    toks: &[Spanned3<'_>],
    (s, k): (usize, usize),
) -> Option<Diagnostic> {
    let sign = |j: usize| matches!(toks.get(j)?.1, Tok::Lt | Tok::Gt | Tok::Eq).then_some(j);
    let value = |j: usize| {
        let t = toks.get(j)?;
        matches!(t.1, Tok::Int(_) | Tok::Counter(_) | Tok::MsgRef(_)).then_some(j)
    };
    let src = |a: usize, b: usize| line_src(line, toks[a].0, toks[b].2);
    let together = |a: usize| toks[a].2 == toks[a + 1].0;
    // The signs as written, the first and last token of the slip, and the comparison in
    // the paper's form.
    let (written, first, last, right) = if k > s && sign(k - 1).is_some() && sign(k).is_some() {
        // `>=C00 0003`: the term starts with two signs.
        let op = foreign_operator(&toks[k - 1].1, &toks[k].1).filter(|_| together(k - 1))?;
        let (a, b) = (value(k + 1)?, value(k + 2)?);
        (
            src(k - 1, k),
            k - 1,
            b,
            format!("{op}{} {}", src(a, a), src(b, b)),
        )
    } else if !in_post && value(s).is_some() && sign(k).is_some() && k == s + 1 {
        // `C00 >= 0003` or `C00 > 0003`: the sign between the values.
        let (op, last_sign) = match sign(k + 1).filter(|&j| together(j - 1)) {
            Some(j) => (foreign_operator(&toks[k].1, &toks[j].1)?, j),
            None => (line_src(line, toks[k].0, toks[k].2), k),
        };
        let b = value(last_sign + 1)?;
        let op = match op {
            "<" | ">" | "=" | "!<" | "!>" | "!=" => op,
            _ => return None,
        };
        (
            src(k, last_sign),
            s,
            b,
            format!("{op}{} {}", src(s, s), src(b, b)),
        )
    } else {
        return None;
    };
    let span = Span::new(toks[first].0, toks[last].2);
    Some(
        Diagnostic::new(
            Code::E201,
            format!(
                "`{}` is not how the rules language compares: write `{right}`",
                line_src(line, toks[first].0, toks[last].2)
            ),
            Label::new(
                file,
                span,
                format!("`{written}` is another language's comparison"),
            ),
        )
        .with_help(
            "a comparison is its sign, then two values: `<C00 0003` (below), `>C00 0003` \
             (above), `=C00 0003`; `!<` is at least, `!>` at most, `!=` not equal",
        )
        .with_fix(Fix::replace(format!("write `{right}`"), file, span, right)),
    )
}

/// A fix for a syntax error at token `k` of a term that starts at token `s`, when the slip
/// is a common one.
fn syntax_fix(
    line: Line<'_>,
    in_post: bool,
    file: FileId,
    toks: &[Spanned3<'_>],
    s: usize,
    k: usize,
) -> Option<Fix> {
    let at = toks.get(k)?;
    match (toks[s].1, at.1, toks.get(k + 1)) {
        // `C00 = 5`: setting a counter is a calculation (in a postcondition).
        (
            Tok::Counter(_) | Tok::MsgRef(_),
            Tok::Eq,
            Some(&(vs, Tok::Int(_) | Tok::Counter(_) | Tok::MsgRef(_), ve)),
        ) if s + 1 == k => {
            let target = line_src(line, toks[s].0, toks[s].2);
            let value = line_src(line, vs, ve);
            if !in_post {
                // In a precondition it is a comparison, written with its sign first.
                return Some(Fix::replace(
                    format!("a comparison is written sign first: `={target} {value}`"),
                    file,
                    Span::new(toks[s].0, ve),
                    format!("={target} {value}"),
                ));
            }
            Some(Fix::replace(
                format!("set `{target}` with a calculation: `{target} + {value} 0000` adds zero to `{value}`"),
                file,
                Span::new(at.0, ve),
                format!("+ {value} 0000"),
            ))
        }
        // The letter `I` where a number belongs.
        (_, Tok::OpMin, _) if k > s && matches!(toks[k - 1].1, Tok::Comma) => Some(Fix::replace(
            "write the digit `1`, not the letter `I`",
            file,
            Span::new(at.0, at.2),
            "1",
        )),
        _ => None,
    }
}

/// E102 for a character that starts no term, with a fix when it is a slip we know: a
/// lower-case term letter, the letter O or l for a digit, a `.` or `;` for a comma.
fn bad_char(line: Line<'_>, file: FileId, start: usize, end: usize) -> Diagnostic {
    let c = line_src(line, start, end);
    let d = Diagnostic::new(
        Code::E102,
        format!("{} does not start any term", crate::diag::quote_char(c)),
        Label::new(file, Span::new(start, end), "unexpected character"),
    )
    .with_help(
        "terms start with N, E, F, P, L, Q, A, S, T, M, V, W, X, <, >, =, !, ( \
         or, in a postcondition, a counter or message slot (see docs/language.md)",
    );
    let before = line.text[..start - line.start].chars().next_back();
    let after = line.text[end - line.start..].chars().next();
    let word_start = before.is_none_or(|b| crate::lines::is_blank(b) || b == '(' || b == '!');
    let numeric = |ch: Option<char>| ch.is_some_and(|x| x.is_ascii_digit() || x == ',');
    let ch = c.chars().next().unwrap_or(' ');
    let upper = ch.to_ascii_uppercase();
    let fix = match ch {
        'o' | 'O' if numeric(before) || numeric(after) || before == Some('-') => {
            Some(("0", format!("write the digit `0`, not the letter `{ch}`")))
        }
        'l' if !word_start && (numeric(before) || numeric(after) || before == Some('-')) => {
            Some(("1", "write the digit `1`, not the letter `l`".to_string()))
        }
        '.' | ';' | ':' if numeric(before) && (numeric(after) || after == Some('-')) => Some((
            ",",
            format!("coordinates are separated by commas, not `{ch}`"),
        )),
        'a'..='z' if word_start && "NEFLQASTMVWXPC".contains(upper) => Some((
            &"NEFLQASTMVWXPC"[("NEFLQASTMVWXPC".find(upper).unwrap_or(0))..][..1],
            format!("term letters are capitals: write `{upper}`"),
        )),
        _ => None,
    };
    // `C 15`: a counter with a blank inside (the letter alone starts no term).
    let rest = &line.text[end - line.start..];
    let digits_after = rest.trim_start_matches([' ', '\t']);
    if ch == 'C'
        && word_start
        && rest.len() > digits_after.len()
        && digits_after.len() >= 2
        && digits_after.as_bytes()[..2].iter().all(u8::is_ascii_digit)
        && !digits_after
            .as_bytes()
            .get(2)
            .is_some_and(u8::is_ascii_digit)
    {
        let blank = Span::new(end, end + rest.len() - digits_after.len());
        return blank_inside(file, blank);
    }
    match fix {
        Some((with, message)) => {
            d.with_fix(Fix::replace(message, file, Span::new(start, end), with))
        }
        None => d,
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
