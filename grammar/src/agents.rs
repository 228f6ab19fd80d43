//! Parsing agents.txt: an optional universe line, then one agent a line.
//!
//! The format is simple enough for a hand-written scanner, which is also the fastest way to
//! read files of millions of agents. Only the form is judged here (numbers, field letters,
//! duplicates, the place of the `U` line); ranges and the lattice are the compiler's.

use crate::ast::{AgentLine, AgentsFile, Universe};
use crate::diag::{Code, Diagnostic, Label};
use crate::lines::{is_blank, significant_lines, Line};
use crate::span::{FileId, Span, Spanned};

const FIELDS_HELP: &str =
    "an agent line is `x,y[,z]` followed by any of `S` + 5 characters, `A` + 4 [6] of 0/1, \
     and `Cnn value`, separated by blanks";

/// The blank-separated words of a line, with their absolute spans.
fn words(line: Line<'_>) -> impl Iterator<Item = Spanned<&str>> {
    let base = line.start;
    let text = line.text;
    let mut at = 0;
    std::iter::from_fn(move || {
        let rest = &text[at..];
        let skip = rest.len() - rest.trim_start_matches(is_blank).len();
        at += skip;
        if at >= text.len() {
            return None;
        }
        let len = text[at..].find(is_blank).unwrap_or(text.len() - at);
        let w = Spanned::new(&text[at..at + len], Span::new(base + at, base + at + len));
        at += len;
        Some(w)
    })
}

/// The span of a whole field from the span of its text after the one-letter prefix.
fn whole(tail: Span) -> Span {
    Span {
        start: tail.start - 1,
        end: tail.end,
    }
}

fn parse_int(s: &str) -> Option<i64> {
    let digits = s.strip_prefix('-').unwrap_or(s);
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some(s.parse::<i64>().unwrap_or(if s.starts_with('-') {
        i64::MIN
    } else {
        i64::MAX
    }))
}

/// Comma-separated integers with their spans, or `None` if any part is not a number.
fn int_list(w: Spanned<&str>) -> Option<Vec<Spanned<i64>>> {
    let mut out = Vec::new();
    let mut at = 0;
    for part in w.node.split(',') {
        let v = parse_int(part)?;
        out.push(Spanned::new(v, w.span.sub(at, at + part.len())));
        at += part.len() + 1;
    }
    Some(out)
}

/// Parses an agents file. Returns the agents read (a line with an error is left out) and
/// the diagnostics in file order.
pub fn parse_agents(src: &str, file: FileId) -> (AgentsFile<'_>, Vec<Diagnostic>) {
    let mut diags = Vec::new();
    let mut out = AgentsFile::default();
    for (i, line) in significant_lines(src).enumerate() {
        parse_line(line, i == 0, file, &mut diags, &mut out);
    }
    (out, diags)
}

/// One significant line of an agents file, read as [`parse_agents`] reads it (`first`: no
/// significant line stands before it): a universe line sets `out.universe` when it is the
/// first, an agent line without an error joins `out.agents`. The streaming reader of large
/// files reads the lines its fast path leaves with this, one at a time.
pub fn parse_line<'a>(
    line: Line<'a>,
    first: bool,
    file: FileId,
    diags: &mut Vec<Diagnostic>,
    out: &mut AgentsFile<'a>,
) {
    if let Some(rest) = line.text.strip_prefix('U') {
        let u = parse_universe(line, rest, file, diags);
        if !first {
            diags.push(
                Diagnostic::new(
                    Code::E406,
                    "the universe line must be the first line of the file",
                    Label::new(
                        file,
                        Span::new(line.start, line.start + 1),
                        "universe line here",
                    ),
                )
                .with_help("move the `U` line above the first agent"),
            );
        } else {
            out.universe = u;
        }
        return;
    }
    if let Some(a) = parse_agent(line, file, diags) {
        out.agents.push(a);
    }
}

fn parse_universe(
    line: Line<'_>,
    rest: &str,
    file: FileId,
    diags: &mut Vec<Diagnostic>,
) -> Option<Universe> {
    let span = Span::new(line.start, line.start + line.text.len());
    let body = rest.trim_start_matches(is_blank);
    let off = line.text.len() - body.len();
    let w = Spanned::new(body, Span::new(line.start + off, span.end as usize));
    let bad = |msg: &str| {
        Diagnostic::new(
            Code::E406,
            msg.to_string(),
            Label::new(file, span, "universe line"),
        )
        .with_help("write `U minX,maxX,minY,maxY` (2D) or `U minX,maxX,minY,maxY,minZ,maxZ` (3D)")
    };
    let Some(bounds) = (!body.contains(is_blank)).then(|| int_list(w)).flatten() else {
        diags.push(bad(
            "the universe line is not a list of whole numbers separated by commas",
        ));
        return None;
    };
    if bounds.len() != 4 && bounds.len() != 6 {
        diags.push(bad(&format!(
            "the universe line has {} numbers; it needs 4 (2D) or 6 (3D)",
            bounds.len()
        )));
        return None;
    }
    for pair in bounds.chunks(2) {
        if pair[0].node > pair[1].node {
            diags.push(
                Diagnostic::new(
                    Code::E406,
                    format!(
                        "the universe bound {} is greater than {}",
                        pair[0].node, pair[1].node
                    ),
                    Label::new(file, pair[0].span.to(pair[1].span), "minimum above maximum"),
                )
                .with_help("each axis is written minimum first, then maximum"),
            );
            return None;
        }
    }
    Some(Universe { bounds, span })
}

fn parse_agent<'a>(
    line: Line<'a>,
    file: FileId,
    diags: &mut Vec<Diagnostic>,
) -> Option<AgentLine<'a>> {
    let span = Span::new(line.start, line.start + line.text.len());
    let mut ws = words(line);
    let first = ws.next()?;
    let Some(pos) = int_list(first) else {
        let help = if first.node.ends_with(',') {
            "write the position without blanks: `x,y` or `x,y,z`"
        } else {
            "every agent line starts with its position `x,y` or `x,y,z`"
        };
        diags.push(
            Diagnostic::new(
                Code::E401,
                format!("`{}` is not a position", first.node),
                Label::new(
                    file,
                    first.span,
                    "expected whole numbers separated by commas",
                ),
            )
            .with_help(help),
        );
        return None;
    };
    let mut agent = AgentLine {
        pos,
        state: None,
        attach: None,
        counters: Vec::new(),
        span,
    };
    let mut ok = true;
    while let Some(w) = ws.next() {
        let first_len = w.node.chars().next().map_or(1, char::len_utf8);
        let tail = Spanned::new(&w.node[first_len..], w.span.sub(first_len, w.node.len()));
        let dup = |prev: Span, what: &str| {
            Diagnostic::new(
                Code::E405,
                format!("the {what} of this agent is given twice"),
                Label::new(file, w.span, "second time"),
            )
            .with_secondary(Label::new(file, prev, "first time"))
            .with_help(format!("keep one {what} field"))
        };
        match w.node.as_bytes()[0] {
            b'S' => match agent.state {
                Some(prev) => {
                    diags.push(dup(whole(prev.span), "state"));
                    ok = false;
                }
                None => agent.state = Some(tail),
            },
            b'A' => match agent.attach {
                Some(prev) => {
                    diags.push(dup(whole(prev.span), "attachment field"));
                    ok = false;
                }
                None => agent.attach = Some(tail),
            },
            b'C' if w.node.len() > 1 && w.node[1..].bytes().all(|b| b.is_ascii_digit()) => {
                let Some(v) = ws.next() else {
                    diags.push(
                        Diagnostic::new(
                            Code::E401,
                            format!("the counter `{}` has no value", w.node),
                            Label::new(file, w.span, "expected a value after this"),
                        )
                        .with_help(format!(
                            "write `{} 0010`: the counter, a blank, its value",
                            w.node
                        )),
                    );
                    ok = false;
                    break;
                };
                let Some(value) = parse_int(v.node) else {
                    diags.push(
                        Diagnostic::new(
                            Code::E401,
                            format!("`{}` is not a whole number", v.node),
                            Label::new(file, v.span, format!("value of {}", w.node)),
                        )
                        .with_help("a counter value is a whole number from -32767 to 32767"),
                    );
                    ok = false;
                    continue;
                };
                if let Some((prev, _)) = agent.counters.iter().find(|(c, _)| c.node == tail.node) {
                    diags.push(dup(whole(prev.span), &format!("counter C{}", tail.node)));
                    ok = false;
                    continue;
                }
                agent.counters.push((tail, Spanned::new(value, v.span)));
            }
            _ => {
                diags.push(
                    Diagnostic::new(
                        Code::E401,
                        format!("`{}` is not an agent field", w.node),
                        Label::new(file, w.span, "unknown field"),
                    )
                    .with_help(FIELDS_HELP),
                );
                ok = false;
            }
        }
    }
    ok.then_some(agent)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_fields_in_any_order() {
        let src = "U0,9,0,9\n1,2 C03 -7 SAB(DE A1000\n// c\n3,4\n";
        let (f, d) = parse_agents(src, FileId(0));
        assert!(d.is_empty(), "{d:?}");
        assert_eq!(f.universe.unwrap().bounds.len(), 4);
        assert_eq!(f.agents.len(), 2);
        let a = &f.agents[0];
        assert_eq!(a.pos.iter().map(|p| p.node).collect::<Vec<_>>(), vec![1, 2]);
        assert_eq!(a.state.unwrap().node, "AB(DE");
        assert_eq!(a.attach.unwrap().node, "1000");
        assert_eq!(a.counters[0].0.node, "03");
        assert_eq!(a.counters[0].1.node, -7);
        assert_eq!(&src[a.counters[0].1.span.range()], "-7");
    }

    #[test]
    fn reports_and_recovers() {
        let src = "1, 2\n1,2 S00000 S11111\n5,5 C01\n6,6 Zz\n7,7\nU 0,1,0,1\n";
        let (f, d) = parse_agents(src, FileId(0));
        let codes: Vec<_> = d.iter().map(|d| d.code).collect();
        assert_eq!(
            codes,
            vec![Code::E401, Code::E405, Code::E401, Code::E401, Code::E406]
        );
        assert_eq!(f.agents.len(), 1);
    }
}
