//! Checking rules: every constraint of the paper and SEMANTICS.md on a parsed rules file,
//! producing the [`CheckedRules`] and diagnostics (E3xx, W5xx).

use crate::checked::{
    Action, AttachLetter, BitPat, CheckedRules, Cond, Coord, Dim, Dir, Offset, Operand, Rule,
    Target, TextPat, Val, Width,
};
use crate::contradict;
use crate::dim::DimSource;
use latticesim_grammar::ast::{self, Comp, Term, Value};
use latticesim_grammar::{Code, Diagnostic, Edit, FileId, Fix, Label, Span, Spanned};
use std::collections::HashMap;

fn cmp_op(op: ast::CmpOp) -> crate::checked::CmpOp {
    use crate::checked::CmpOp as C;
    match op {
        ast::CmpOp::Lt => C::Lt,
        ast::CmpOp::Gt => C::Gt,
        ast::CmpOp::Eq => C::Eq,
    }
}

fn calc_op(op: ast::CalcOp) -> crate::checked::CalcOp {
    use crate::checked::CalcOp as C;
    match op {
        ast::CalcOp::Add => C::Add,
        ast::CalcOp::Sub => C::Sub,
        ast::CalcOp::Mul => C::Mul,
        ast::CalcOp::Div => C::Div,
        ast::CalcOp::Mod => C::Mod,
        ast::CalcOp::Max => C::Max,
        ast::CalcOp::Min => C::Min,
    }
}

/// "1 character", "3 characters".
pub(crate) fn chars(n: usize) -> String {
    if n == 1 {
        "1 character".into()
    } else {
        format!("{n} characters")
    }
}

/// True when `b` is `a` with one character added or taken away.
fn one_edit(a: &str, b: &str) -> bool {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let (short, long) = if a.len() < b.len() { (a, b) } else { (b, a) };
    if long.len() != short.len() + 1 {
        return false;
    }
    let i = short.iter().zip(&long).take_while(|(x, y)| x == y).count();
    short[i..] == long[i + 1..]
}

/// The states a rules file names in full: its `S` and `T` texts of five characters
/// without `*`, once each.
fn named_states<'a>(f: &latticesim_grammar::ast::RulesFile<'a>) -> Vec<&'a str> {
    fn walk<'a>(
        ts: &[Spanned<Term<'a>>],
        seen: &mut std::collections::HashSet<&'a str>,
        out: &mut Vec<&'a str>,
    ) {
        for t in ts {
            match t.node {
                Term::State(s) | Term::RemoteState { state: s, .. }
                    if s.node.chars().count() == 5
                        && !s.node.contains('*')
                        && seen.insert(s.node) =>
                {
                    out.push(s.node)
                }
                Term::Not(i) => walk(std::slice::from_ref(i), seen, out),
                Term::Group(g) => walk(g, seen, out),
                _ => {}
            }
        }
    }
    let (mut seen, mut out) = (std::collections::HashSet::new(), Vec::new());
    for r in &f.rules {
        walk(r.pre.node, &mut seen, &mut out);
        walk(r.post.node, &mut seen, &mut out);
    }
    out
}

/// The digit a letter is often typed for (`O` for `0`, `l` or `I` for `1`).
pub(crate) fn digit_for(c: char) -> Option<char> {
    match c {
        'O' | 'o' => Some('0'),
        'l' | 'I' | 'i' | '|' => Some('1'),
        _ => None,
    }
}

/// The range of priorities (and of the paper's counter values, literals and offsets).
pub const VALUE_MAX: i64 = 32767;

/// The help for a value outside the width `w` that `what` holds ("counters hold ..."):
/// the range, and how to choose 32-bit counters when they would hold it.
pub(crate) fn range_help(w: Width, n: i64, what: &str) -> String {
    let range = format!(
        "{what} {}-bit values from -{m} to {m}",
        w.bits(),
        m = w.max()
    );
    if w == Width::W16 && Width::W32.holds(n) {
        format!("{range}; for 32-bit counters and messages, write `// latticesim: counters 32` in the rules file or run with `--counters 32`")
    } else {
        range
    }
}

pub(crate) struct Checker<'d> {
    pub file: FileId,
    /// The file's text, to quote numbers as written.
    pub src: &'d str,
    pub dim: &'d DimSource,
    pub diags: &'d mut Vec<Diagnostic>,
    /// The states the rules file names in full (`S` and `T` without `*`), for suggestions.
    pub states: Vec<&'d str>,
    /// The width of counters and messages, which bounds literals.
    pub width: Width,
}

type OffsetAst<'a> = ast::Offset<'a>;

impl Checker<'_> {
    fn d(&self) -> Dim {
        self.dim.dim
    }

    /// `Mpath!`: a message term whose direction was left out (its first text character
    /// read as the direction, and four characters left): one E317 for the term, not one
    /// for the direction and one for the text.
    fn has_direction(&mut self, dir: &Spanned<char>, text: &Spanned<&str>) -> Option<()> {
        let known = matches!(dir.node, 'N' | 'W' | 'E' | 'S' | 'A' | 'B' | '*');
        if known || text.node.chars().count() != 4 {
            return Some(());
        }
        let term = format!("M{}{}", dir.node, text.node);
        self.push(
            Diagnostic::new(
                Code::E317,
                format!("`{term}` has no direction"),
                self.label(
                    Span::new(dir.span.start as usize, text.span.end as usize),
                    "no direction before the text",
                ),
            )
            .with_help(
                "a message term is `M`, a direction (N, W, E, S; A, B in 3D; `*` for any), \
                 then five characters, e.g. `MNpath!`",
            ),
        );
        None
    }

    fn label(&self, span: Span, msg: impl Into<latticesim_grammar::Text>) -> Label {
        Label::new(self.file, span, msg)
    }

    pub fn push(&mut self, d: Diagnostic) {
        self.diags.push(d);
    }

    /// A diagnostic that also points at why the dimension is what it is.
    fn push_dim(&mut self, d: Diagnostic) {
        let d = self.dim.attach(d);
        let why = &self.dim.why;
        let d = if self.dim.label.is_none() {
            let help = d.help.clone().unwrap_or_default();
            d.with_help(format!("{help} ({why})"))
        } else {
            d
        };
        self.diags.push(d);
    }

    fn literal(&mut self, n: i64, span: Span) -> Option<i32> {
        let w = self.width;
        if w.holds(n) {
            return Some(n as i32);
        }
        let written = crate::written(self.src, span);
        let mut help = format!(
            "use a number from -{m} to {m}, e.g. {}",
            w.saturate(n),
            m = w.max()
        );
        if w == Width::W16 && Width::W32.holds(n) {
            help.push_str(", or 32-bit counters: write `// latticesim: counters 32` in the rules file or run with `--counters 32`");
        }
        self.push(
            Diagnostic::new(
                Code::E310,
                format!(
                    "{written} is outside the {}-bit range {}",
                    w.bits(),
                    w.range_text()
                ),
                self.label(span, if n < 0 { "too small" } else { "too large" }),
            )
            .with_help(help),
        );
        None
    }

    pub fn counter(&mut self, digits: &str, span: Span) -> Option<u8> {
        let n: usize = digits.parse().unwrap_or(usize::MAX);
        let max = self.d().counters() - 1;
        if digits.len() != 2 {
            let help = if n <= max {
                format!("write `C{n:02}`")
            } else {
                format!("counters are C00..C{max}")
            };
            let mut d = Diagnostic::new(
                Code::E305,
                format!("the counter `C{digits}` must be written with two digits"),
                self.label(span, "not two digits"),
            )
            .with_help(help);
            if n <= max {
                d = d.with_fix(Fix::replace(
                    format!("write `C{n:02}`"),
                    self.file,
                    span,
                    format!("C{n:02}"),
                ));
            }
            self.push(d);
            return None;
        }
        if n > max {
            let d = Diagnostic::new(
                Code::E305,
                format!(
                    "the counter `C{digits}` does not exist in {}",
                    self.d().name()
                ),
                self.label(span, format!("{} has C00..C{max}", self.d().name())),
            )
            .with_help(format!("use a counter from C00 to C{max}"));
            if n < self.d().other().counters() {
                self.push_dim(d);
            } else {
                self.push(d);
            }
            return None;
        }
        Some(n as u8)
    }

    /// A direction letter: `Some(None)` for `*` where allowed.
    fn dir(&mut self, c: char, span: Span, any: bool, what: &str) -> Option<Option<Dir>> {
        if c == '*' {
            if any {
                return Some(None);
            }
            self.push(
                Diagnostic::new(
                    Code::E318,
                    format!("{what} needs one definite direction, not `*`"),
                    self.label(span, "`*` is not allowed here"),
                )
                .with_help(self.dir_help()),
            );
            return None;
        }
        match Dir::from_char(c) {
            Some(d) if d.index() < self.d().dirs() => Some(Some(d)),
            Some(d) => {
                self.push_dim(
                    Diagnostic::new(
                        Code::E307,
                        format!(
                            "the direction `{c}` ({}) exists only in 3D",
                            if d == Dir::A { "above" } else { "below" }
                        ),
                        self.label(span, "3D direction in a 2D rules file"),
                    )
                    .with_help(self.dir_help()),
                );
                None
            }
            None => {
                let mut d = Diagnostic::new(
                    Code::E317,
                    format!("`{c}` is not a direction"),
                    self.label(span, "expected a direction letter"),
                )
                .with_help(self.dir_help());
                let upper = c.to_ascii_uppercase();
                if Dir::from_char(upper).is_some_and(|d| d.index() < self.d().dirs()) {
                    d = d.with_fix(Fix::replace(
                        format!("directions are capitals: write `{upper}`"),
                        self.file,
                        span,
                        upper.to_string(),
                    ));
                }
                self.push(d);
                None
            }
        }
    }

    fn dir_help(&self) -> String {
        match self.d() {
            Dim::Two => "directions are N, W, E, S (2D)".into(),
            Dim::Three => "directions are N, W, E, S, A (above), B (below)".into(),
        }
    }

    /// `#Dkk`: direction (or `*`) and 0-based slot.
    fn msg_ref(&mut self, text: &str, span: Span, any: bool) -> Option<(Option<Dir>, u8)> {
        let mut chars = text.chars();
        let Some(c) = chars.next() else {
            self.push(
                Diagnostic::new(
                    Code::E306,
                    "`#` must be followed by a direction and a two-digit slot",
                    self.label(span, "incomplete message slot"),
                )
                .with_help("write e.g. `#N01`"),
            );
            return None;
        };
        let digits = chars.as_str();
        let dir = self.dir(c, span.sub(1, 1 + c.len_utf8()), any, "this message slot");
        let slots = self.d().slots();
        let n: usize = digits.parse().unwrap_or(0);
        if digits.len() != 2 || !digits.bytes().all(|b| b.is_ascii_digit()) || n == 0 || n > slots {
            let d = Diagnostic::new(
                Code::E306,
                format!(
                    "`#{text}` is not a numeric message slot of {}",
                    self.d().name()
                ),
                self.label(
                    span,
                    format!("{} has slots 01..{slots:02} per direction", self.d().name()),
                ),
            )
            .with_help(format!(
                "write `#` + direction + two digits from 01 to {slots:02}, e.g. `#{}01`",
                if c.is_ascii_uppercase() || c == '*' {
                    c
                } else {
                    'N'
                }
            ));
            // The letters O and l (or I) typed for the digits 0 and 1.
            let as_digits: String = (digits.chars())
                .map(|d| match d {
                    'O' | 'o' => '0',
                    'l' | 'I' => '1',
                    d => d,
                })
                .collect();
            let m: usize = as_digits.parse().unwrap_or(0);
            let digits_only = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
            let fix = if digits.len() != 2
                && !digits.is_empty()
                && digits_only(digits)
                && (1..=slots).contains(&n)
            {
                Some(("write the slot with two digits", format!("#{c}{n:02}")))
            } else if as_digits != digits
                && as_digits.len() == 2
                && digits_only(&as_digits)
                && (1..=slots).contains(&m)
            {
                Some(("write the slot with digits", format!("#{c}{as_digits}")))
            } else {
                None
            };
            let d = match fix {
                Some((how, slot)) => d.with_fix(Fix::replace(
                    format!("{how}: `{slot}`"),
                    self.file,
                    span,
                    slot,
                )),
                None => d,
            };
            if n > slots && n <= self.d().other().slots() && digits.len() == 2 {
                self.push_dim(d);
            } else {
                self.push(d);
            }
            return None;
        }
        Some((dir?, (n - 1) as u8))
    }

    fn value(&mut self, v: &Spanned<Value<'_>>, any: bool) -> Option<Val> {
        match v.node {
            Value::Int(n) => self.literal(n, v.span).map(Val::Lit),
            Value::Counter(d) => self.counter(d, v.span).map(Val::Counter),
            Value::Msg(m) => {
                if !any && m.starts_with('*') {
                    self.push(
                        Diagnostic::new(
                            Code::E318,
                            format!("`#{m}` cannot be read in a calculation"),
                            self.label(v.span, "`#*` means 'some direction' only in a comparison"),
                        )
                        .with_help("read one direction's slot, e.g. `#N01`; `#*kk` is allowed as a target (send to all)"),
                    );
                    return None;
                }
                self.msg_ref(m, v.span, any)
                    .map(|(dir, slot)| Val::Msg { dir, slot })
            }
        }
    }

    fn coord(&mut self, c: &Spanned<Comp<'_>>) -> Option<Coord> {
        match c.node {
            Comp::Int(n) => self.literal(n, c.span).map(Coord::Lit),
            Comp::Counter(d) => self.counter(d, c.span).map(Coord::Counter),
        }
    }

    fn coords(&mut self, cs: &[Spanned<Comp<'_>>]) -> Option<Vec<Coord>> {
        let out: Vec<Option<Coord>> = cs.iter().map(|c| self.coord(c)).collect();
        out.into_iter().collect()
    }

    fn offset(&mut self, letter: char, o: &OffsetAst<'_>) -> Option<Offset> {
        let need = self.d().coords();
        let coords = self.coords(o.node);
        if o.node.len() != need {
            let example = if need == 2 {
                format!("{letter}1,0")
            } else {
                format!("{letter}1,0,0")
            };
            self.push_dim(
                Diagnostic::new(
                    Code::E316,
                    format!(
                        "this offset has {} coordinates; {} needs {need}",
                        o.node.len(),
                        self.d().name()
                    ),
                    self.label(o.span, format!("expected {need} coordinates")),
                )
                .with_help(format!(
                    "write {need} coordinates separated by commas, e.g. `{example}`"
                )),
            );
            return None;
        }
        let c = coords?;
        Some([c[0], c[1], c.get(2).copied().unwrap_or(Coord::Lit(0))])
    }

    fn text(&mut self, s: &Spanned<&str>, what: &str, star: bool) -> Option<TextPat> {
        let n = s.node.chars().count();
        if n != 5 {
            let mut d = Diagnostic::new(
                Code::E303,
                format!("{what} `{}` has {}; it needs exactly 5", s.node, chars(n)),
                self.label(s.span, chars(n)),
            )
            .with_help(if star {
                "write 5 characters; `*` stands for any character".to_string()
            } else {
                "write exactly 5 characters".to_string()
            });
            // A state of the file one character away (`SINT0` for `SINIT0`).
            let mut near = self.states.iter().filter(|t| one_edit(s.node, t));
            if what.contains("state") {
                if let (Some(t), None) = (near.next(), near.next()) {
                    d = d.with_fix(Fix::replace(
                        format!("did you mean `{t}`? the rules name it"),
                        self.file,
                        s.span,
                        t.to_string(),
                    ));
                }
            }
            self.push(d);
            return None;
        }
        let mut pat: TextPat = [None; 5];
        let mut ok = true;
        for (i, (at, c)) in s.node.char_indices().enumerate() {
            let cspan = s.span.sub(at, at + c.len_utf8());
            if c == '*' {
                if !star {
                    self.push(
                        Diagnostic::new(
                            Code::E318,
                            format!("{what} cannot contain `*`"),
                            self.label(cspan, "a sent text is definite"),
                        )
                        .with_help("replace `*` with the character to send"),
                    );
                    ok = false;
                }
                continue;
            }
            if !c.is_ascii_graphic() {
                self.push(
                    Diagnostic::new(
                        Code::E304,
                        format!("`{c}` cannot stand in {what}"),
                        self.label(cspan, "not a printable ASCII character"),
                    )
                    .with_help("states and messages use printable ASCII characters other than blank and `*`"),
                );
                ok = false;
                continue;
            }
            pat[i] = Some(c as u8);
        }
        ok.then_some(pat)
    }

    /// A per-direction pattern over `allowed` characters, `dirs` long.
    fn dir_pattern(
        &mut self,
        letter: char,
        p: &Spanned<&str>,
        allowed: &str,
        meaning: &str,
    ) -> Option<Vec<char>> {
        let need = self.d().dirs();
        let chars: Vec<char> = p.node.chars().collect();
        let mut ok = true;
        for (at, c) in p.node.char_indices() {
            if !allowed.contains(c) {
                let extra = if letter == 'A' && c == '+' {
                    " (`+`, carry along, is a postcondition letter)"
                } else {
                    ""
                };
                let cspan = p.span.sub(at, at + c.len_utf8());
                let mut d = Diagnostic::new(
                    Code::E304,
                    format!("`{c}` cannot stand in an `{letter}` pattern{extra}"),
                    self.label(cspan, format!("expected one of {allowed}")),
                )
                .with_help(format!(
                    "each character of `{letter}` is one of {allowed}: {meaning}"
                ));
                if let Some(digit) = digit_for(c).filter(|d| allowed.contains(*d)) {
                    d = d.with_fix(Fix::replace(
                        format!("write the digit `{digit}`, not `{c}`"),
                        self.file,
                        cspan,
                        digit.to_string(),
                    ));
                }
                self.push(d);
                ok = false;
            }
        }
        // A pattern with a wrong character is one slip: its length is judged once it is
        // right.
        if ok && chars.len() != need {
            let order = if need == 4 {
                "N, W, E, S"
            } else {
                "N, W, E, S, A, B"
            };
            let d = Diagnostic::new(
                Code::E302,
                format!(
                    "`{letter}{}` has {}; {} needs {need}",
                    p.node,
                    self::chars(chars.len()),
                    self.d().name()
                ),
                self.label(
                    p.span.sub(0, 0).to(p.span),
                    format!("expected {need} characters"),
                ),
            )
            .with_help(format!(
                "write one character per direction, in the order {order}"
            ));
            let d = match (need, chars.len()) {
                (4, 6) => d.with_fix(Fix::replace(
                    "drop the last two characters (A and B, above and below, exist only in 3D)",
                    self.file,
                    p.span,
                    chars[..4].iter().collect::<String>(),
                )),
                (6, 4) => d.with_fix(Fix::replace(
                    "add `**` for above and below (either)",
                    self.file,
                    p.span.sub(p.span.len(), p.span.len()),
                    "**",
                )),
                _ => d,
            };
            if chars.len() == self.d().other().dirs() {
                self.push_dim(d);
            } else {
                self.push(d);
            }
            return None;
        }
        ok.then_some(chars)
    }

    fn bit_pat(&mut self, letter: char, p: &Spanned<&str>, meaning: &str) -> Option<BitPat> {
        let cs = self.dir_pattern(letter, p, "01*", meaning)?;
        let mut b = BitPat::default();
        for (i, c) in cs.iter().enumerate() {
            match c {
                '0' => b.mask |= 1 << i,
                '1' => {
                    b.mask |= 1 << i;
                    b.want |= 1 << i;
                }
                _ => {}
            }
        }
        Some(b)
    }

    fn misplaced(&mut self, t: &Spanned<Term<'_>>, in_pre: bool) {
        let (code, msg, help) = if in_pre {
            let help = match t.node {
                Term::Move(_) => "to compare priorities write `P` with `<`, `=`, `*` (e.g. `P<***`); \
                                  to test a cell use `E` or `F`; a move belongs in the postcondition",
                _ => "move it to the postcondition (the fourth line of the rule)",
            };
            (
                Code::E313,
                format!(
                    "`{}` is an action; it cannot stand in a precondition",
                    crate::written(self.src, t.span)
                ),
                help,
            )
        } else {
            let help = match t.node {
                Term::Priorities(_) => "in a postcondition `P` moves (e.g. `P1,0`); priority tests belong in the precondition",
                _ => "move it to the precondition (the third line of the rule)",
            };
            (
                Code::E312,
                format!(
                    "`{}` is a test; it cannot stand in a postcondition",
                    crate::written(self.src, t.span)
                ),
                help,
            )
        };
        let label = if in_pre {
            "action in a precondition"
        } else {
            "test in a postcondition"
        };
        self.push(Diagnostic::new(code, msg, self.label(t.span, label)).with_help(help));
    }

    pub fn cond(&mut self, t: &Spanned<Term<'_>>) -> Option<Cond> {
        Some(match &t.node {
            Term::Neighbors(p) => {
                Cond::Neighbors(self.bit_pat('N', p, "0 empty, 1 filled, * either")?)
            }
            Term::Attach(p) => {
                Cond::Attached(self.bit_pat('A', p, "0 not attached, 1 attached, * either")?)
            }
            Term::Priorities(p) => {
                let cs = self.dir_pattern(
                    'P',
                    p,
                    "<=*",
                    "< strictly smaller, = smaller or equal, * either",
                )?;
                let (mut strict, mut leq) = (0u8, 0u8);
                for (i, c) in cs.iter().enumerate() {
                    match c {
                        '<' => strict |= 1 << i,
                        '=' => leq |= 1 << i,
                        _ => {}
                    }
                }
                Cond::Priorities { strict, leq }
            }
            Term::State(p) => Cond::State(self.text(p, "the state pattern", true)?),
            Term::Message { dir, text } => {
                self.has_direction(dir, text)?;
                let d = self.dir(dir.node, dir.span, true, "a message test");
                let pat = self.text(text, "the message pattern", true);
                let stars = text.node.chars().filter(|&c| c == '*').count();
                if stars > 4 {
                    self.push(
                        Diagnostic::new(
                            Code::E311,
                            format!("the message pattern `{}` has {stars} `*`; at most four are allowed", text.node),
                            self.label(text.span, "too many wildcards"),
                        )
                        .with_help("fix at least one character; to test only that a message came, use a pattern such as `M*A****` against a known first character"),
                    );
                    return None;
                }
                Cond::Message { dir: d?, pat: pat? }
            }
            Term::Empty(o) => Cond::Empty(self.offset('E', o)?),
            Term::Filled(o) => Cond::Filled(self.offset('F', o)?),
            Term::Less(o) => Cond::Less(self.offset('L', o)?),
            Term::LessEq(o) => Cond::LessEq(self.offset('Q', o)?),
            Term::RemoteState { offset, state } => {
                let o = self.offset('T', offset);
                let s = self.text(state, "the remote state pattern", true);
                Cond::RemoteState(o?, s?)
            }
            Term::Compare(c) => {
                let (op, lhs, rhs) = (&c.op, &c.lhs, &c.rhs);
                let any = [lhs, rhs]
                    .iter()
                    .filter(|v| matches!(v.node, Value::Msg(m) if m.starts_with('*')))
                    .count();
                let a = self.value(lhs, true);
                let b = self.value(rhs, true);
                if any > 1 {
                    self.push(
                        Diagnostic::new(
                            Code::E318,
                            "a comparison may use `#*` only once",
                            self.label(t.span, "two `#*` values"),
                        )
                        .with_help(
                            "compare `#*kk` with a counter, a literal or one direction's slot",
                        ),
                    );
                    return None;
                }
                Cond::Compare(cmp_op(op.node), a?, b?)
            }
            Term::RemoteCompare(rc) => {
                let (strict, comps, rhs) = (&rc.strict, &rc.comps, &rc.rhs);
                let letter = if *strict { 'V' } else { 'W' };
                if self.d() == Dim::Three {
                    self.push_dim(
                        Diagnostic::new(
                            Code::E308,
                            format!("`{letter}` exists only in 2D"),
                            self.label(t.span, "2D-only term in a 3D rules file"),
                        )
                        .with_help(
                            "in 3D, compare a neighbour's value through a numeric message instead",
                        ),
                    );
                    return None;
                }
                let rhs = self.value(rhs, true);
                let (counter, offset) = self.remote_counter(letter, comps)?;
                Cond::RemoteCompare {
                    strict: *strict,
                    offset,
                    counter,
                    rhs: rhs?,
                }
            }
            Term::Move(_) | Term::Swap(_) | Term::Calc(_) => {
                self.misplaced(t, true);
                return None;
            }
            Term::Not(inner) => Cond::Not(Box::new(self.cond(inner)?)),
            Term::Group(ts) => Cond::And(self.conds(ts)?),
            Term::Error => return None,
        })
    }

    /// `dx,dy,Cnn`: the coordinates and the counter after them.
    fn remote_counter(&mut self, letter: char, comps: &OffsetAst<'_>) -> Option<(u8, Offset)> {
        let n = comps.node.len();
        let last = comps.node.last()?;
        let Comp::Counter(digits) = last.node else {
            self.push(
                Diagnostic::new(
                    Code::E319,
                    format!("`{letter}` must end with the remote agent's counter"),
                    self.label(last.span, "expected a counter such as C03"),
                )
                .with_help(format!(
                    "write `{letter}dx,dy,Cnn value`, e.g. `{letter}1,0,C03 0010`"
                )),
            );
            return None;
        };
        let counter = self.counter(digits, last.span);
        let pos = Spanned::new(
            &comps.node[..n - 1],
            comps.node[0].span.to(comps.node[n.saturating_sub(2)].span),
        );
        let offset = if n == 3 {
            self.offset(letter, &pos)
        } else {
            self.push(
                Diagnostic::new(
                    Code::E319,
                    format!(
                        "`{letter}` takes two coordinates and a counter; here are {} parts",
                        n
                    ),
                    self.label(comps.span, "expected dx,dy,Cnn"),
                )
                .with_help(format!(
                    "write `{letter}dx,dy,Cnn value`, e.g. `{letter}1,0,C03 0010`"
                )),
            );
            None
        };
        Some((counter?, offset?))
    }

    fn conds(&mut self, ts: &[Spanned<Term<'_>>]) -> Option<Vec<Cond>> {
        let out: Vec<Option<Cond>> = ts.iter().map(|t| self.cond(t)).collect();
        out.into_iter().collect()
    }

    fn operand(&mut self, o: &ast::Operand<'_>) -> Option<Operand> {
        match o {
            ast::Operand::Value(v) => self.value(v, false).map(Operand::Val),
            ast::Operand::External(cs) => {
                if self.d() == Dim::Three {
                    self.push_dim(
                        Diagnostic::new(
                            Code::E308,
                            "external counters exist only in 2D",
                            self.label(cs.span, "2D-only operand in a 3D rules file"),
                        )
                        .with_help(
                            "in 3D, receive the neighbour's value as a numeric message instead",
                        ),
                    );
                    return None;
                }
                let n = cs.node.len();
                let last = cs.node[n - 1];
                let Comp::Counter(digits) = last.node else {
                    self.push(
                        Diagnostic::new(
                            Code::E319,
                            "an external counter must end with the counter to read",
                            self.label(last.span, "expected a counter such as C03"),
                        )
                        .with_help("write `dx,dy,Cnn` or `Cxx,Cyy,Cnn`, e.g. `1,0,C03`"),
                    );
                    return None;
                };
                if n != 3 {
                    self.push(
                        Diagnostic::new(
                            Code::E319,
                            format!("an external counter has two coordinates and a counter; here are {n} parts"),
                            self.label(cs.span, "expected dx,dy,Cnn"),
                        )
                        .with_help("write `dx,dy,Cnn` or `Cxx,Cyy,Cnn`, e.g. `1,0,C03`"),
                    );
                    return None;
                }
                let x = self.coord(&cs.node[0]);
                let y = self.coord(&cs.node[1]);
                let counter = self.counter(digits, last.span);
                Some(Operand::External {
                    x: x?,
                    y: y?,
                    counter: counter?,
                })
            }
        }
    }

    fn action(&mut self, t: &Spanned<Term<'_>>) -> Option<Action> {
        Some(match &t.node {
            Term::Attach(p) => {
                let cs = self.dir_pattern(
                    'A',
                    p,
                    "01*+",
                    "0 detach, 1 attach afterwards, * re-attach if attached before, + stay attached and carry",
                )?;
                Action::Attach(
                    cs.iter()
                        .map(|c| match c {
                            '0' => AttachLetter::Detach,
                            '1' => AttachLetter::Attach,
                            '+' => AttachLetter::Rigid,
                            _ => AttachLetter::Keep,
                        })
                        .collect(),
                )
            }
            Term::State(p) => Action::State(self.text(p, "the new state", true)?),
            Term::Message { dir, text } => {
                self.has_direction(dir, text)?;
                let d = self.dir(dir.node, dir.span, true, "a sent message");
                let pat = self.text(text, "the sent text", false)?;
                let mut out = [0u8; 5];
                for (o, c) in out.iter_mut().zip(pat) {
                    *o = c?;
                }
                Action::Send { dir: d?, text: out }
            }
            Term::Move(o) => Action::Move(self.offset('P', o)?),
            Term::Swap(s) => {
                let mut cs = s.node.chars();
                match (cs.next(), cs.next()) {
                    (Some(c), None) => Action::Swap(self.dir(c, s.span, false, "a swap")??),
                    _ => {
                        self.push(
                            Diagnostic::new(
                                Code::E317,
                                format!(
                                    "`X{}` is not a swap: `X` takes one direction letter",
                                    s.node
                                ),
                                self.label(s.span, "expected one direction letter"),
                            )
                            .with_help(format!("write e.g. `XN`; {}", self.dir_help())),
                        );
                        return None;
                    }
                }
            }
            Term::Calc(c) => {
                let (target, op, lhs, rhs) = (&c.target, &c.op, &c.lhs, &c.rhs);
                let tgt = match target.node {
                    Value::Counter(d) => self.counter(d, target.span).map(Target::Counter),
                    Value::Msg(m) => self
                        .msg_ref(m, target.span, true)
                        .map(|(dir, slot)| Target::Msg { dir, slot }),
                    Value::Int(_) => None,
                };
                let externals = [lhs, rhs]
                    .iter()
                    .filter(|o| matches!(o, ast::Operand::External(_)))
                    .count();
                let a = self.operand(lhs);
                let b = self.operand(rhs);
                if externals > 1 {
                    self.push(
                        Diagnostic::new(
                            Code::E319,
                            "a calculation may read at most one external counter",
                            self.label(t.span, "two external counters"),
                        )
                        .with_help(
                            "copy one of them into an own counter in an earlier calculation",
                        ),
                    );
                    return None;
                }
                Action::Calc {
                    target: tgt?,
                    op: calc_op(op.node),
                    lhs: a?,
                    rhs: b?,
                }
            }
            Term::Not(_) | Term::Group(_) => {
                self.push(
                    Diagnostic::new(
                        Code::E320,
                        "a postcondition is a plain list of actions: no `!` and no parentheses",
                        self.label(t.span, "logic in a postcondition"),
                    )
                    .with_help("write the actions one after the other; choose between them with separate rules"),
                );
                return None;
            }
            Term::Error => return None,
            _ => {
                self.misplaced(t, false);
                return None;
            }
        })
    }

    fn post(&mut self, ts: &[Spanned<Term<'_>>]) -> Option<Vec<Action>> {
        const KINDS: [char; 4] = ['P', 'X', 'A', 'S'];
        let mut first: [Option<Span>; 4] = [None; 4];
        let mut ok = true;
        for t in ts {
            let k = match t.node {
                Term::Move(_) => 0,
                Term::Swap(_) => 1,
                Term::Attach(_) => 2,
                Term::State(_) => 3,
                _ => continue,
            };
            let kind = KINDS[k];
            if let Some(prev) = first[k] {
                ok = false;
                self.push(
                    Diagnostic::new(
                        Code::E314,
                        format!("a postcondition may have only one `{kind}` action"),
                        self.label(t.span, "second one"),
                    )
                    .with_secondary(self.label(prev, "first one"))
                    .with_help(format!("merge the two `{kind}` actions into one")),
                );
            } else {
                first[k] = Some(t.span);
            }
        }
        if let (Some(p), Some(x)) = (first[0], first[1]) {
            ok = false;
            let (a, b) = if p < x { (p, x) } else { (x, p) };
            self.push(
                Diagnostic::new(
                    Code::E315,
                    "a rule cannot both move (`P`) and swap (`X`)",
                    self.label(b, "this one"),
                )
                .with_secondary(self.label(a, "conflicts with this one"))
                .with_help("split them into two rules"),
            );
        }
        let out: Vec<Option<Action>> = ts.iter().map(|t| self.action(t)).collect();
        let out: Option<Vec<Action>> = out.into_iter().collect();
        if ok {
            out
        } else {
            None
        }
    }
}

/// Terms that are only actions: a precondition holding one is E313 (`Checker::cond`'s arm).
fn action_only(t: &Term<'_>) -> bool {
    matches!(t, Term::Move(_) | Term::Swap(_) | Term::Calc(_))
}

/// Terms that are tests in a precondition and actions in a postcondition (`S`, `A`, `M`);
/// every other term but [`action_only`] ones (and what the parser could not read) is only a
/// test: a postcondition holding one is E312 (E320 for `!` and `(`).
fn both_sides(t: &Term<'_>) -> bool {
    matches!(
        t,
        Term::State(_) | Term::Attach(_) | Term::Message { .. } | Term::Error
    )
}

/// E322: a rule whose precondition line holds actions and no test, and whose postcondition
/// line holds tests and no action (`S`, `A` and `M` are both): the two lines were
/// written in each other's place. One error, with the swap as its fix, instead of one for
/// every term.
fn swapped(r: &latticesim_grammar::ast::Rule<'_>, file: FileId, src: &str) -> Option<Diagnostic> {
    let action = |t: &Spanned<Term<'_>>| action_only(&t.node);
    let test = |t: &Spanned<Term<'_>>| !action_only(&t.node) && !both_sides(&t.node);
    let broken = |ts: &[Spanned<Term<'_>>]| ts.iter().any(|t| matches!(t.node, Term::Error));
    let (pre, post) = (r.pre.node, r.post.node);
    let swapped = pre.iter().any(action)
        && !pre.iter().any(test)
        && post.iter().any(test)
        && !post.iter().any(action)
        && !broken(pre)
        && !broken(post);
    if !swapped {
        return None;
    }
    let (a, b) = (
        crate::written(src, r.pre.span),
        crate::written(src, r.post.span),
    );
    Some(
        Diagnostic::new(
            Code::E322,
            format!(
                "the precondition and postcondition of the rule `{}` are swapped",
                r.name.node
            ),
            Label::new(file, r.pre.span, "actions: this is a postcondition"),
        )
        .with_secondary(Label::new(
            file,
            r.post.span,
            "tests: this is a precondition",
        ))
        .with_help(
            "a rule is four lines: name, priority, precondition (what must hold), \
             postcondition (what the agent does)",
        )
        .with_fix(Fix {
            message: "swap the two lines".into(),
            edits: vec![
                Edit {
                    file,
                    span: r.pre.span,
                    replacement: b.to_string(),
                },
                Edit {
                    file,
                    span: r.post.span,
                    replacement: a.to_string(),
                },
            ],
        }),
    )
}

/// Checks a parsed rules file in the given dimension. The program holds the rules that
/// passed; it is complete only when no error was reported.
pub fn check_rules(
    f: &latticesim_grammar::ast::RulesFile<'_>,
    file: FileId,
    src: &str,
    dim: &DimSource,
    width: Width,
    diags: &mut Vec<Diagnostic>,
) -> CheckedRules {
    let mut ck = Checker {
        file,
        src,
        dim,
        diags,
        states: named_states(f),
        width,
    };
    let mut rules = Vec::with_capacity(f.rules.len());
    let mut names: HashMap<&str, Span> = HashMap::with_capacity(f.rules.len());
    for r in &f.rules {
        if let Some(&prev) = names.get(r.name.node) {
            ck.push(
                Diagnostic::new(
                    Code::W501,
                    format!("a rule named `{}` is already defined", r.name.node),
                    Label::new(file, r.name.span, "second rule with this name"),
                )
                .with_secondary(Label::new(file, prev, "first defined here"))
                .with_help("rename one of them, so statistics and records can tell them apart"),
            );
        } else {
            names.insert(r.name.node, r.name.span);
        }
        let priority = match r.priority.node {
            Some(p) if (1..=VALUE_MAX).contains(&p) => Some(p as u16),
            Some(p) => {
                ck.push(
                    Diagnostic::new(
                        Code::E309,
                        format!(
                            "the priority {} is outside 1..32767",
                            crate::written(src, r.priority.span)
                        ),
                        Label::new(
                            file,
                            r.priority.span,
                            if p < 1 { "too small" } else { "too large" },
                        ),
                    )
                    .with_help("a priority is a whole number from 1 (lowest) to 32767 (highest)"),
                );
                None
            }
            None => None,
        };
        if let Some(d) = swapped(r, file, src) {
            ck.push(d);
            continue;
        }
        let pre = ck.conds(r.pre.node);
        if let Some(conds) = &pre {
            contradict::check(r.pre.node, conds, (ck.file, ck.d(), ck.src), ck.diags);
        }
        let post = ck.post(r.post.node);
        if let (Some(priority), Some(pre), Some(post)) = (priority, pre, post) {
            rules.push(Rule {
                name: r.name.node.to_string(),
                priority,
                pre: Cond::And(pre),
                post,
                name_span: r.name.span,
            });
        }
    }
    crate::slips::check(f, &rules, (file, dim.dim, src), ck.diags);
    CheckedRules {
        dim: dim.dim,
        width,
        rules,
    }
}
