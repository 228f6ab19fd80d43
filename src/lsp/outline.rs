//! The shape of a document for the editor: its rules as symbols (the outline), semantic
//! tokens (what each word is, for colouring: rule names, priorities, term letters, states,
//! counters, numbers, messages, comments), and folding ranges (each rule, each run of
//! comment lines).

use super::names::{self, What};
use super::text::LineIndex;
use super::{Kind, Server};
use bumpalo::Bump;
use latticesim_grammar::ast::{Comp, Operand, Term, Value};
use latticesim_grammar::{FileId, Span, Spanned};
use lsp_types::{
    DocumentSymbol, DocumentSymbolParams, DocumentSymbolResponse, FoldingRange, FoldingRangeKind,
    FoldingRangeParams, SemanticToken, SemanticTokenType, SemanticTokensLegend,
    SemanticTokensParams, SymbolKind,
};

/// The token types, in the legend's order (a token's type is its index here).
const TYPES: [SemanticTokenType; 8] = [
    SemanticTokenType::COMMENT,
    SemanticTokenType::FUNCTION,
    SemanticTokenType::NUMBER,
    SemanticTokenType::KEYWORD,
    SemanticTokenType::ENUM_MEMBER,
    SemanticTokenType::VARIABLE,
    SemanticTokenType::STRING,
    SemanticTokenType::OPERATOR,
];

/// A token's type: an index into [`TYPES`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum Type {
    /// `//` to the line's end.
    Comment = 0,
    /// A rule's name.
    Rule,
    /// A priority, a literal, a coordinate, an agent's counter value.
    Number,
    /// A term's or field's letter (`N`, `S`, `P`, `U`, ...).
    Letter,
    /// A state or state pattern.
    State,
    /// A counter or a numeric message slot.
    Counter,
    /// A text message.
    Text,
    /// `!`, `(`, `)`, a comparison or a calculation's operator.
    Operator,
}

/// The legend the server announces.
pub fn legend() -> SemanticTokensLegend {
    SemanticTokensLegend {
        token_types: TYPES.to_vec(),
        token_modifiers: Vec::new(),
    }
}

/// The tokens of a document: (start, end, type), sorted, none overlapping.
pub fn tokens(text: &str, kind: Kind) -> Vec<(usize, usize, Type)> {
    let mut v = comments(text);
    match kind {
        Kind::Rules => rules_tokens(text, &mut v),
        Kind::Agents => agents_tokens(text, &mut v),
    }
    v.sort_by_key(|&(s, e, _)| (s, e));
    let mut out: Vec<(usize, usize, Type)> = Vec::with_capacity(v.len());
    for t in v {
        if t.1 > t.0 && out.last().is_none_or(|l| l.1 <= t.0) {
            out.push(t);
        }
    }
    out
}

/// Every `//` comment: from the slashes to the line's end.
fn comments(text: &str) -> Vec<(usize, usize, Type)> {
    let mut v = Vec::new();
    let mut start = 0;
    for raw in text.split_inclusive('\n') {
        let mut slashes = memchr::memchr_iter(b'/', raw.as_bytes());
        if let Some(c) = slashes.find(|&i| raw.as_bytes().get(i + 1) == Some(&b'/')) {
            let body = raw.trim_end_matches(['\n', '\r']);
            v.push((start + c, start + body.len(), Type::Comment));
        }
        start += raw.len();
    }
    v
}

fn rules_tokens(text: &str, v: &mut Vec<(usize, usize, Type)>) {
    let arena = Bump::new();
    let (f, _) = latticesim_grammar::parse_rules(text, FileId(0), &arena, None);
    for o in names::of_rules(&f, text) {
        let (s, e) = (o.span.start as usize, o.span.end as usize);
        match o.what {
            What::Rule => v.push((s, e, Type::Rule)),
            What::State => v.push((s, e, Type::State)),
            What::Counter => v.push((s - 1, e, Type::Counter)),
        }
    }
    for r in &f.rules {
        let p = r.priority.span;
        v.push((p.start as usize, p.end as usize, Type::Number));
        for t in r.pre.node.iter().chain(r.post.node) {
            term(t, v);
        }
    }
}

fn span(s: Span, t: Type) -> (usize, usize, Type) {
    (s.start as usize, s.end as usize, t)
}

fn comps(cs: &[Spanned<Comp<'_>>], v: &mut Vec<(usize, usize, Type)>) {
    for c in cs {
        if let Comp::Int(_) = c.node {
            v.push(span(c.span, Type::Number));
        }
    }
}

fn value(x: &Spanned<Value<'_>>, v: &mut Vec<(usize, usize, Type)>) {
    match x.node {
        Value::Int(_) => v.push(span(x.span, Type::Number)),
        Value::Msg(_) => v.push(span(x.span, Type::Counter)),
        Value::Counter(_) => {}
    }
}

/// A term's letters, operators, numbers and messages (its states and counters come from
/// [`names::of_rules`]).
fn term(t: &Spanned<Term<'_>>, v: &mut Vec<(usize, usize, Type)>) {
    let s = t.span.start as usize;
    let letter = (s, s + 1, Type::Letter);
    match &t.node {
        Term::Not(inner) => {
            v.push((s, s + 1, Type::Operator));
            term(inner, v);
        }
        Term::Group(ts) => {
            let e = t.span.end as usize;
            v.push((s, s + 1, Type::Operator));
            v.push((e.saturating_sub(1), e, Type::Operator));
            for t in ts.iter() {
                term(t, v);
            }
        }
        Term::Neighbors(_)
        | Term::Attach(_)
        | Term::Priorities(_)
        | Term::State(_)
        | Term::Swap(_) => v.push(letter),
        Term::Message { text, .. } => {
            v.push((s, s + 2, Type::Letter));
            v.push(span(text.span, Type::Text));
        }
        Term::Empty(o) | Term::Filled(o) | Term::Less(o) | Term::LessEq(o) | Term::Move(o) => {
            v.push(letter);
            comps(o.node, v);
        }
        Term::RemoteState { offset, .. } => {
            v.push(letter);
            comps(offset.node, v);
        }
        Term::Compare(c) => {
            v.push(span(c.op.span, Type::Operator));
            value(&c.lhs, v);
            value(&c.rhs, v);
        }
        Term::RemoteCompare(c) => {
            v.push(letter);
            comps(c.comps.node, v);
            value(&c.rhs, v);
        }
        Term::Calc(c) => {
            value(&c.target, v);
            v.push(span(c.op.span, Type::Operator));
            for o in [&c.lhs, &c.rhs] {
                match o {
                    Operand::Value(x) => value(x, v),
                    Operand::External(o) => comps(o.node, v),
                }
            }
        }
        Term::Error => {}
    }
}

fn agents_tokens(text: &str, v: &mut Vec<(usize, usize, Type)>) {
    let (f, _) = latticesim_grammar::parse_agents(text, FileId(1));
    if let Some(u) = &f.universe {
        let s = u.span.start as usize;
        v.push((s, s + 1, Type::Letter));
        v.extend(u.bounds.iter().map(|b| span(b.span, Type::Number)));
    }
    for a in &f.agents {
        v.extend(a.pos.iter().map(|p| span(p.span, Type::Number)));
        if let Some(s) = a.state {
            let st = s.span.start as usize;
            v.push((st - 1, st, Type::Letter));
            v.push(span(s.span, Type::State));
        }
        if let Some(at) = a.attach {
            let st = at.span.start as usize;
            v.push((st - 1, st, Type::Letter));
            v.push(span(at.span, Type::Text));
        }
        for (c, n) in &a.counters {
            v.push((
                c.span.start as usize - 1,
                c.span.end as usize,
                Type::Counter,
            ));
            v.push(span(n.span, Type::Number));
        }
    }
}

/// The tokens as the protocol sends them: each relative to the one before, in UTF-16.
fn encode(text: &str, tokens: &[(usize, usize, Type)]) -> Vec<SemanticToken> {
    let ix = LineIndex::new(text);
    // Tokens are sorted and none overlaps: their starts and ends come in order.
    let mut at = ix.positions_in_order();
    let (mut line, mut col) = (0, 0);
    tokens
        .iter()
        .map(|&(s, e, ty)| {
            let a = at(s);
            let b = at(e);
            let delta_line = a.line - line;
            let delta_start = if delta_line == 0 {
                a.character - col
            } else {
                a.character
            };
            (line, col) = (a.line, a.character);
            SemanticToken {
                delta_line,
                delta_start,
                length: b.character.saturating_sub(a.character),
                token_type: ty as u32,
                token_modifiers_bitset: 0,
            }
        })
        .collect()
}

/// The runs of two or more whole comment lines, as (first, last) 0-based lines.
fn comment_blocks(text: &str) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    let mut run: Option<(u32, u32)> = None;
    for (i, line) in text.lines().enumerate() {
        let i = i as u32;
        if line.trim_start_matches([' ', '\t']).starts_with("//") {
            run = Some(run.map_or((i, i), |(a, _)| (a, i)));
        } else if let Some((a, b)) = run.take() {
            out.push((a, b));
        }
    }
    out.extend(run);
    out.retain(|(a, b)| b > a);
    out
}

impl Server {
    pub(super) fn document_symbols(
        &self,
        p: DocumentSymbolParams,
    ) -> Option<DocumentSymbolResponse> {
        let doc = self.docs.get(p.text_document.uri.as_str())?;
        if doc.kind != Kind::Rules {
            return Some(DocumentSymbolResponse::Nested(Vec::new()));
        }
        let arena = Bump::new();
        let (f, _) = latticesim_grammar::parse_rules(&doc.text, FileId(0), &arena, None);
        let ix = LineIndex::new(&doc.text);
        let symbols = f
            .rules
            .iter()
            .map(|r| {
                let (s, e) = (r.name.span.start as usize, r.name.span.end as usize);
                let end = (r.post.span.end as usize).max(e);
                #[allow(deprecated)] // the field must be written; it is left out when None
                DocumentSymbol {
                    name: r.name.node.to_string(),
                    detail: Some(
                        r.priority
                            .node
                            .map_or("priority ?".into(), |p| format!("priority {p}")),
                    ),
                    kind: SymbolKind::FUNCTION,
                    tags: None,
                    deprecated: None,
                    range: ix.range(s, end),
                    selection_range: ix.range(s, e),
                    children: None,
                }
            })
            .collect();
        Some(DocumentSymbolResponse::Nested(symbols))
    }

    /// The document symbols as JSON text (see [`frame::raw`](super::frame::raw)).
    pub(super) fn document_symbols_json(&self, p: DocumentSymbolParams) -> String {
        serde_json::to_string(&self.document_symbols(p)).expect("symbols are plain data")
    }

    /// The semantic tokens as JSON text: `{"data":[...]}`, five numbers a token, written
    /// as they are made (60,000 tokens of 5,005 rules are 300,000 numbers).
    pub(super) fn semantic_tokens_json(&self, p: SemanticTokensParams) -> String {
        let Some(doc) = self.docs.get(p.text_document.uri.as_str()) else {
            return "null".into();
        };
        let data = encode(&doc.text, &tokens(&doc.text, doc.kind));
        let mut out = String::with_capacity(12 + data.len() * 20);
        out.push_str("{\"data\":[");
        let mut digits = itoa::Buffer::new();
        for t in &data {
            for n in [
                t.delta_line,
                t.delta_start,
                t.length,
                t.token_type,
                t.token_modifiers_bitset,
            ] {
                out.push_str(digits.format(n));
                out.push(',');
            }
        }
        if out.ends_with(',') {
            out.pop();
        }
        out.push_str("]}");
        out
    }

    pub(super) fn folding_ranges(&self, p: FoldingRangeParams) -> Option<Vec<FoldingRange>> {
        let doc = self.docs.get(p.text_document.uri.as_str())?;
        let ix = LineIndex::new(&doc.text);
        let fold = |a: u32, b: u32, kind: Option<FoldingRangeKind>| FoldingRange {
            start_line: a,
            start_character: None,
            end_line: b,
            end_character: None,
            kind,
            collapsed_text: None,
        };
        let mut out: Vec<FoldingRange> = comment_blocks(&doc.text)
            .into_iter()
            .map(|(a, b)| fold(a, b, Some(FoldingRangeKind::Comment)))
            .collect();
        if doc.kind == Kind::Rules {
            let arena = Bump::new();
            let (f, _) = latticesim_grammar::parse_rules(&doc.text, FileId(0), &arena, None);
            for r in &f.rules {
                let a = ix.position(r.name.span.start as usize).line;
                let b = ix.position(r.post.span.end as usize).line;
                if b > a {
                    out.push(fold(a, b, Some(FoldingRangeKind::Region)));
                }
            }
        }
        out.sort_by_key(|f| f.start_line);
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shown(text: &str, kind: Kind) -> Vec<(&str, Type)> {
        tokens(text, kind)
            .into_iter()
            .map(|(s, e, t)| (&text[s..e], t))
            .collect()
    }

    #[test]
    fn every_word_of_a_rule_has_its_type() {
        use Type::*;
        let text = "walk // east\n1\nSWALK0 !E1,0 >C01 0000\nP1,0 C01 - C01 0001 MNhello\n";
        assert_eq!(
            shown(text, Kind::Rules),
            vec![
                ("walk", Rule),
                ("// east", Comment),
                ("1", Number),
                ("S", Letter),
                ("WALK0", State),
                ("!", Operator),
                ("E", Letter),
                ("1", Number),
                ("0", Number),
                (">", Operator),
                ("C01", Counter),
                ("0000", Number),
                ("P", Letter),
                ("1", Number),
                ("0", Number),
                ("C01", Counter),
                ("-", Operator),
                ("C01", Counter),
                ("0001", Number),
                ("MN", Letter),
                ("hello", Text),
            ]
        );
    }

    #[test]
    fn agents_have_their_types() {
        use Type::*;
        let text = "U0,9,0,9\n1,-2 SWALK0 C01 7 A1000\n";
        assert_eq!(
            shown(text, Kind::Agents),
            vec![
                ("U", Letter),
                ("0", Number),
                ("9", Number),
                ("0", Number),
                ("9", Number),
                ("1", Number),
                ("-2", Number),
                ("S", Letter),
                ("WALK0", State),
                ("C01", Counter),
                ("7", Number),
                ("A", Letter),
                ("1000", Text),
            ]
        );
    }

    #[test]
    fn tokens_are_relative_and_in_utf16() {
        let text = "// é\nrüle\n1\nS*****\nS*****\n";
        let t = tokens(text, Kind::Rules);
        let e = encode(text, &t);
        assert_eq!((e[0].delta_line, e[0].delta_start, e[0].length), (0, 0, 4));
        assert_eq!((e[1].delta_line, e[1].delta_start, e[1].length), (1, 0, 4));
        assert_eq!(e[1].token_type, Type::Rule as u32);
    }

    #[test]
    fn comment_runs_fold() {
        assert_eq!(
            comment_blocks("// a\n// b\nx\n// c\n  // d\n// e"),
            vec![(0, 1), (3, 5)]
        );
    }
}
