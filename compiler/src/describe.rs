//! Words for a term or action as written: what the language server shows on hover. Each
//! kind of term has one sentence (docs/language.md has the long form), and patterns are
//! spelt out direction by direction.

use latticesim_grammar::ast::{CalcOp, CmpOp, Comp, Operand, Term, Value};

const DIRS: [&str; 6] = ["north", "west", "east", "south", "above", "below"];

fn offset(cs: &[latticesim_grammar::Spanned<Comp<'_>>]) -> String {
    let parts: Vec<String> = cs
        .iter()
        .map(|c| match c.node {
            Comp::Int(n) => n.to_string(),
            Comp::Counter(d) => format!("C{d}"),
        })
        .collect();
    format!("({})", parts.join(", "))
}

fn per_direction(p: &str, meaning: impl Fn(char) -> Option<&'static str>) -> String {
    let parts: Vec<String> = p
        .chars()
        .zip(DIRS)
        .filter_map(|(c, d)| meaning(c).map(|m| format!("{d} {m}")))
        .collect();
    if parts.is_empty() {
        "no direction constrained".into()
    } else {
        parts.join(", ")
    }
}

fn value(v: &Value<'_>) -> String {
    match v {
        Value::Int(n) => n.to_string(),
        Value::Counter(d) => format!("counter C{d}"),
        Value::Msg(m) => match m.chars().next() {
            Some('*') => format!("numeric message slot {} from any direction", &m[1..]),
            Some(c) => format!(
                "numeric message slot {} from {}",
                &m[c.len_utf8()..],
                dir_word(c)
            ),
            None => "a message slot".into(),
        },
    }
}

fn dir_word(c: char) -> &'static str {
    match c {
        'N' => "the north",
        'W' => "the west",
        'E' => "the east",
        'S' => "the south",
        'A' => "above",
        'B' => "below",
        '*' => "every direction",
        _ => "an unknown direction",
    }
}

fn operand(o: &Operand<'_>) -> String {
    match o {
        Operand::Value(v) => value(&v.node),
        Operand::External(cs) => {
            let n = cs.node.len();
            let counter = match cs.node.last().map(|c| c.node) {
                Some(Comp::Counter(d)) => format!("C{d}"),
                _ => "a counter".into(),
            };
            format!(
                "counter {counter} of the agent at {}",
                offset(&cs.node[..n.saturating_sub(1)])
            )
        }
    }
}

/// Markdown for a term or action: what it tests or does. `in_post` tells a postcondition's
/// action (`S`, `A`, `M` are actions there) from a precondition's test.
pub fn term(t: &Term<'_>, in_post: bool) -> String {
    match t {
        Term::Neighbors(p) => format!(
            "**Neighbour cells** `N{}`: {}. (`0` empty, `1` filled, `*` either; one character per direction N, W, E, S[, A, B].)",
            p.node,
            per_direction(p.node, |c| match c {
                '0' => Some("empty"),
                '1' => Some("filled"),
                _ => None,
            })
        ),
        Term::Attach(p) if in_post => format!(
            "**Set attachments** `A{}`: {}. (`0` detach, `1` attach afterwards, `*` re-attach if attached before, `+` stay attached and carry along when moving.)",
            p.node,
            per_direction(p.node, |c| match c {
                '0' => Some("detach"),
                '1' => Some("attach"),
                '+' => Some("carry along"),
                _ => None,
            })
        ),
        Term::Attach(p) => format!(
            "**Attachments test** `A{}`: {}. (`0` not attached, `1` attached, `*` either.)",
            p.node,
            per_direction(p.node, |c| match c {
                '0' => Some("not attached"),
                '1' => Some("attached"),
                _ => None,
            })
        ),
        Term::Priorities(p) => format!(
            "**Neighbour priorities** `P{}`: {}. (`<` strictly smaller than this agent's, `=` smaller or equal, `*` indifferent.)",
            p.node,
            per_direction(p.node, |c| match c {
                '<' => Some("smaller"),
                '=' => Some("smaller or equal"),
                _ => None,
            })
        ),
        Term::State(s) if in_post => format!(
            "**Set the state** to `{}` (`*` keeps that character).",
            s.node
        ),
        Term::State(s) => format!(
            "**State test**: the agent's state matches `{}` (`*` matches any character).",
            s.node
        ),
        Term::Message { dir, text } if in_post => format!(
            "**Send the text message** `{}` to {}.",
            text.node,
            dir_word(dir.node)
        ),
        Term::Message { dir, text } => format!(
            "**Text message test**: a message matching `{}` came from {} this step.",
            text.node,
            dir_word(dir.node)
        ),
        Term::Empty(o) => format!("**Empty cell**: no agent at the offset {}.", offset(o.node)),
        Term::Filled(o) => format!("**Filled cell**: an agent at the offset {}.", offset(o.node)),
        Term::Less(o) => format!(
            "**Smaller priority**: the agent at {} applies a rule of strictly smaller priority.",
            offset(o.node)
        ),
        Term::LessEq(o) => format!(
            "**Smaller or equal priority**: the agent at {} applies a rule of smaller or equal priority.",
            offset(o.node)
        ),
        Term::RemoteState { offset: o, state } => format!(
            "**Remote state**: an agent at {} whose state matches `{}`.",
            offset(o.node),
            state.node
        ),
        Term::Compare(c) => format!(
            "**Comparison**: {} {} {}.",
            value(&c.lhs.node),
            match c.op.node {
                CmpOp::Lt => "<",
                CmpOp::Gt => ">",
                CmpOp::Eq => "=",
            },
            value(&c.rhs.node)
        ),
        Term::RemoteCompare(r) => {
            let n = r.comps.node.len();
            format!(
                "**Remote counter** (2D): the counter {} of the agent at {} is {} {}.",
                match r.comps.node.last().map(|c| c.node) {
                    Some(Comp::Counter(d)) => format!("C{d}"),
                    _ => "?".into(),
                },
                offset(&r.comps.node[..n.saturating_sub(1)]),
                if r.strict {
                    "smaller than"
                } else {
                    "smaller than or equal to"
                },
                value(&r.rhs.node)
            )
        }
        Term::Move(o) => format!(
            "**Move** by {} (with the agents attached with `+`).",
            offset(o.node)
        ),
        Term::Swap(d) => format!(
            "**Swap** places with the neighbour to {}.",
            d.node.chars().next().map_or("?", dir_word)
        ),
        Term::Calc(c) => {
            let op = match c.op.node {
                CalcOp::Add => "the sum of",
                CalcOp::Sub => "the difference of",
                CalcOp::Mul => "the product of",
                CalcOp::Div => "the quotient (rounded towards zero) of",
                CalcOp::Mod => "the remainder of",
                CalcOp::Max => "the larger of",
                CalcOp::Min => "the smaller of",
            };
            let target = match c.target.node {
                Value::Msg(m) => format!(
                    "numeric message slot {} sent to {}",
                    m.get(1..).unwrap_or(""),
                    m.chars().next().map_or("?", dir_word)
                ),
                v => value(&v),
            };
            format!(
                "**Calculation**: {target} becomes {op} {} and {} (16-bit, saturating).",
                operand(&c.lhs),
                operand(&c.rhs)
            )
        }
        Term::Not(_) => "**Not**: the term after `!` must not hold.".into(),
        Term::Group(_) => "**Group**: every term in the parentheses holds (used with `!`).".into(),
        Term::Error => "A term that could not be read.".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bumpalo::Bump;
    use latticesim_grammar::{parse_rules, FileId};

    #[test]
    fn every_term_is_described() {
        let src = "r\n1\nN1*0* A1*** P<=** SAB*** MNhi*** E1,0 F-1,0 L0,1 Q1,1 T1,0,AB*** <C00 0005 V1,0,C03 #N01 !(E0,1)\nA1+*0 SX**** M*hello P1,0 C00 + C01 1,0,C02\n";
        let arena = Bump::new();
        let (f, d) = parse_rules(src, FileId(0), &arena, Some(2));
        assert!(d.is_empty(), "{d:?}");
        let r = &f.rules[0];
        let pre: Vec<String> = r.pre.node.iter().map(|t| term(&t.node, false)).collect();
        let post: Vec<String> = r.post.node.iter().map(|t| term(&t.node, true)).collect();
        assert!(pre[0].contains("north filled") && pre[0].contains("east empty"));
        assert!(pre[2].contains("north smaller") && pre[2].contains("west smaller or equal"));
        assert!(pre[3].starts_with("**State test**"));
        assert!(pre[9].contains("(1, 0)") && pre[9].contains("AB***"));
        assert!(pre[11].contains("C03 of the agent at (1, 0)"));
        assert!(post[0].contains("north attach") && post[0].contains("west carry along"));
        assert!(post[1].starts_with("**Set the state**"));
        assert!(post[2].contains("every direction"));
        assert!(post[4].contains(
            "counter C00 becomes the sum of counter C01 and counter C02 of the agent at (1, 0)"
        ));
        for s in pre.iter().chain(&post) {
            assert!(s.len() > 20, "{s}");
        }
    }
}
