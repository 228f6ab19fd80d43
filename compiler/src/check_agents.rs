//! Checking an agents file: dimensions, the universe, cells, states, attachments and
//! counters (E40x, W60x), producing the checked [`Config`].

use crate::check_rules::{chars, range_help};
use crate::checked::{AgentInit, Bounds, Config, Dim, Dir, Width};
use crate::dim::DimSource;
use latticesim_grammar::ast::{AgentLine, AgentsFile, Universe};
use latticesim_grammar::span::Spanned;
use latticesim_grammar::{Code, Diagnostic, FileId, Label, Span};
use std::collections::HashMap;

fn field(tail: Span) -> Span {
    Span {
        start: tail.start - 1,
        end: tail.end,
    }
}

/// The label of a number out of range.
fn size_word(n: i64) -> &'static str {
    if n < 0 {
        "too small"
    } else {
        "too large"
    }
}

/// Checks a parsed agents file (whose text is `src`) in the dimension `dim` (the file's
/// own, or the one in force).
pub fn check_agents(
    f: &AgentsFile<'_>,
    file: FileId,
    src: &str,
    dim: &DimSource,
    width: Width,
    diags: &mut Vec<Diagnostic>,
) -> Config {
    let d = dim.dim;
    let mut ck = Checker {
        file,
        src,
        base: 0,
        dim,
        diags,
        width,
    };
    let universe = f.universe.as_ref().and_then(|u| ck.universe(u));
    let mut agents = Vec::with_capacity(f.agents.len());
    let mut cells: HashMap<[i32; 3], usize> = HashMap::with_capacity(f.agents.len());
    let mut spans = Vec::with_capacity(f.agents.len());
    let mut attach_spans: Vec<Option<Span>> = Vec::with_capacity(f.agents.len());
    for a in &f.agents {
        let Some(agent) = ck.agent(a, universe.zip(f.universe.as_ref())) else {
            continue;
        };
        let pos_span = position_span(a);
        if let Some(&prev) = cells.get(&agent.pos) {
            let here = (pos_span, agents.len());
            ck.diags
                .push(shared_cell(file, (agent.pos, d), here, (spans[prev], prev)));
            continue;
        }
        cells.insert(agent.pos, agents.len());
        spans.push(pos_span);
        attach_spans.push(a.attach.map(|s| field(s.span)));
        agents.push(agent);
    }
    bonds(
        &mut agents,
        &cells,
        (file, d),
        (&spans, &attach_spans),
        ck.diags,
    );
    Config {
        dim: d,
        universe,
        agents,
    }
}

/// What the checks of one agents file share: the file, its text, its dimension (with its
/// source, for the labels) and where the diagnostics go.
pub(crate) struct Checker<'a, 'd> {
    pub(crate) file: FileId,
    /// The text the spans point into, which starts at offset `base` of the file.
    pub(crate) src: &'a str,
    pub(crate) base: usize,
    pub(crate) dim: &'a DimSource,
    pub(crate) diags: &'d mut Vec<Diagnostic>,
    /// The width of counters, which bounds their values.
    pub(crate) width: Width,
}

/// The span of an agent's position.
pub fn position_span(a: &AgentLine<'_>) -> Span {
    a.pos[0].span.to(a.pos[a.pos.len() - 1].span)
}

/// The span of an agent's attachments field, if it has one.
pub fn attach_span(a: &AgentLine<'_>) -> Option<Span> {
    a.attach.map(|s| field(s.span))
}

impl Checker<'_, '_> {
    /// The text of a span.
    fn written(&self, span: Span) -> &str {
        let at = |o: u32| (o as usize).wrapping_sub(self.base);
        self.src.get(at(span.start)..at(span.end)).unwrap_or("?")
    }

    /// An agent line checked on its own (all but the cell it stands on and its bonds):
    /// `None` when it has an error. `universe`: its bounds and line.
    pub(crate) fn agent(
        &mut self,
        a: &AgentLine<'_>,
        universe: Option<(Bounds, &Universe)>,
    ) -> Option<AgentInit> {
        let (pos, mut ok) = self.position(a, position_span(a), universe)?;
        let state = a.state.map(|s| self.state(s, &mut ok));
        let attach = a.attach.map_or(0, |s| self.attach(s, &mut ok));
        let mut counters = self.counters(a, &mut ok);
        if !ok {
            return None;
        }
        counters.sort_unstable();
        Some(AgentInit {
            pos,
            state: state.unwrap_or(*b"00000"),
            attach,
            counters,
        })
    }

    /// The universe's bounds, when every one is in the 32-bit range (E406).
    pub(crate) fn universe(&mut self, u: &Universe) -> Option<Bounds> {
        let file = self.file;
        let mut b: Bounds = [(0, 0); 3];
        let mut ok = true;
        for (i, pair) in u.bounds.chunks(2).enumerate() {
            for v in pair {
                if i32::try_from(v.node).is_err() {
                    let text = self.written(v.span).to_string();
                    self.diags.push(
                        Diagnostic::new(
                            Code::E406,
                            format!("the universe bound {} is outside the 32-bit range", text),
                            Label::new(file, v.span, size_word(v.node)),
                        )
                        .with_help("leave out the `U` line for an unbounded universe"),
                    );
                    ok = false;
                }
            }
            b[i] = (pair[0].node as i32, pair[1].node as i32);
        }
        ok.then_some(b)
    }

    /// An agent's position, and whether it is in the 32-bit range (E410) and inside the
    /// universe (E403, with `universe` its bounds and line); `None` when it has the wrong
    /// number of coordinates (E407).
    fn position(
        &mut self,
        a: &AgentLine<'_>,
        pos_span: Span,
        universe: Option<(Bounds, &Universe)>,
    ) -> Option<([i32; 3], bool)> {
        let (file, d) = (self.file, self.dim.dim);
        if a.pos.len() != d.coords() {
            let msg = format!(
                "this position has {} coordinates; the file is {} and needs {}",
                a.pos.len(),
                d.name(),
                d.coords()
            );
            self.diags.push(
                self.dim.attach(
                    Diagnostic::new(
                        Code::E407,
                        msg,
                        Label::new(
                            file,
                            pos_span,
                            format!("expected {} coordinates", d.coords()),
                        ),
                    )
                    .with_help(format!(
                        "write the position as {}",
                        if d == Dim::Two { "`x,y`" } else { "`x,y,z`" }
                    )),
                ),
            );
            return None;
        }
        let mut pos = [0i32; 3];
        let mut ok = true;
        for (i, c) in a.pos.iter().enumerate() {
            match i32::try_from(c.node) {
                Ok(v) => pos[i] = v,
                Err(_) => {
                    let text = self.written(c.span).to_string();
                    self.diags.push(
                        Diagnostic::new(
                            Code::E410,
                            format!(
                                "the coordinate {} is outside the 32-bit range of the lattice",
                                text
                            ),
                            Label::new(file, c.span, size_word(c.node)),
                        )
                        .with_help("coordinates are 32-bit integers"),
                    );
                    ok = false;
                }
            }
        }
        let diags = &mut *self.diags;
        if ok {
            if let Some((b, u)) = universe {
                let outside = (0..d.coords()).find(|&i| pos[i] < b[i].0 || pos[i] > b[i].1);
                if let Some(i) = outside {
                    let axis = ["x", "y", "z"][i];
                    diags.push(
                        Diagnostic::new(
                            Code::E403,
                            format!(
                                "the agent at {} is outside the universe: {axis} must be in {}..{}",
                                a.pos
                                    .iter()
                                    .map(|p| p.node.to_string())
                                    .collect::<Vec<_>>()
                                    .join(","),
                                b[i].0,
                                b[i].1
                            ),
                            Label::new(file, a.pos[i].span, "outside the universe"),
                        )
                        .with_secondary(Label::new(file, u.span, "the universe is set here"))
                        .with_help("move the agent inside the bounds or widen the `U` line"),
                    );
                    ok = false;
                }
            }
        }
        Some((pos, ok))
    }

    /// An agent's state (E408 when it is not 5 printable characters other than `*`).
    fn state(&mut self, s: Spanned<&str>, ok: &mut bool) -> [u8; 5] {
        let (file, diags) = (self.file, &mut *self.diags);
        let mut state = *b"00000";
        {
            let n = s.node.chars().count();
            if n != 5 {
                diags.push(
                    Diagnostic::new(
                        Code::E408,
                        format!(
                            "the state `{}` has {}; it needs exactly 5",
                            s.node,
                            chars(n)
                        ),
                        Label::new(file, field(s.span), chars(n)),
                    )
                    .with_help("write `S` and 5 characters, e.g. `SLEAD0`"),
                );
                *ok = false;
            } else {
                for (i, (at, c)) in s.node.char_indices().enumerate() {
                    if c == '*' || !c.is_ascii_graphic() {
                        diags.push(
                            Diagnostic::new(
                                Code::E408,
                                format!("`{c}` cannot stand in an agent's state"),
                                Label::new(file, s.span.sub(at, at + c.len_utf8()), "not allowed"),
                            )
                            .with_help(
                                "states use printable ASCII characters other than blank and `*`",
                            ),
                        );
                        *ok = false;
                    } else {
                        state[i] = c as u8;
                    }
                }
            }
        }
        state
    }

    /// An agent's attachments as bits (E409 when they are not one 0 or 1 per direction).
    fn attach(&mut self, s: Spanned<&str>, ok: &mut bool) -> u8 {
        let (file, d, diags) = (self.file, self.dim.dim, &mut *self.diags);
        let mut attach = 0u8;
        {
            let n = s.node.chars().count();
            if n != d.dirs() || !s.node.bytes().all(|b| b == b'0' || b == b'1') {
                diags.push(
                    Diagnostic::new(
                        Code::E409,
                        format!(
                            "the attachments `A{}` must be {} characters of 0 and 1 in {}",
                            s.node,
                            d.dirs(),
                            d.name()
                        ),
                        Label::new(file, field(s.span), format!("expected {} of 0/1", d.dirs())),
                    )
                    .with_help(format!(
                        "one character per direction, in the order {}",
                        if d == Dim::Two {
                            "N, W, E, S"
                        } else {
                            "N, W, E, S, A, B"
                        }
                    )),
                );
                *ok = false;
            } else {
                for (i, b) in s.node.bytes().enumerate() {
                    if b == b'1' {
                        attach |= 1 << i;
                    }
                }
            }
        }
        attach
    }

    /// An agent's non-zero counters (E404 for a counter the dimension has not, or a value
    /// out of range).
    fn counters(&mut self, a: &AgentLine<'_>, ok: &mut bool) -> Vec<(u8, i32)> {
        let (file, d) = (self.file, self.dim.dim);
        let w = self.width;
        let mut counters = Vec::with_capacity(a.counters.len());
        for (c, v) in &a.counters {
            let text = self.written(v.span).to_string();
            let diags = &mut *self.diags;
            let idx: usize = c.node.parse().unwrap_or(usize::MAX);
            if c.node.len() != 2 || idx >= d.counters() {
                diags.push(
                    Diagnostic::new(
                        Code::E404,
                        format!("`C{}` is not a counter of {}", c.node, d.name()),
                        Label::new(
                            file,
                            field(c.span),
                            format!("{} has C00..C{}", d.name(), d.counters() - 1),
                        ),
                    )
                    .with_help(format!(
                        "counters are written with two digits, C00 to C{}",
                        d.counters() - 1
                    )),
                );
                *ok = false;
            } else if !w.holds(v.node) {
                diags.push(
                    Diagnostic::new(
                        Code::E404,
                        format!(
                            "the value {} of C{} is outside {}",
                            text,
                            c.node,
                            w.range_text()
                        ),
                        Label::new(file, v.span, size_word(v.node)),
                    )
                    .with_help(range_help(w, v.node, "counters hold")),
                );
                *ok = false;
            } else if v.node != 0 {
                counters.push((idx as u8, v.node as i32));
            }
        }
        counters
    }
}

/// E402: agent `here.1` (at `here.0`) stands on the cell `pos` of agent `prev.1` (at
/// `prev.0`), in dimension `d`.
pub fn shared_cell(
    file: FileId,
    (pos, d): ([i32; 3], Dim),
    here: (Span, usize),
    prev: (Span, usize),
) -> Diagnostic {
    Diagnostic::new(
        Code::E402,
        format!(
            "two agents on the cell {}",
            pos[..d.coords()]
                .iter()
                .map(|p| p.to_string())
                .collect::<Vec<_>>()
                .join(",")
        ),
        Label::new(file, here.0, format!("agent {} would stand here", here.1)),
    )
    .with_secondary(Label::new(
        file,
        prev.0,
        format!("agent {} stands here already", prev.1),
    ))
    .with_help("move one of them, or delete the duplicate line")
}

/// W602: agent `i` is attached towards `dir` (its attachments field, or its position,
/// at `here`), where no agent stands.
pub fn bond_dropped(file: FileId, i: usize, dir: Dir, here: Span) -> Diagnostic {
    Diagnostic::new(
        Code::W602,
        format!(
            "agent {i} is attached towards {}, where no agent stands; the attachment is dropped",
            dir.letter()
        ),
        Label::new(file, here, format!("attachment {}", dir.letter())),
    )
    .with_help(format!(
        "set the {} character to 0, or add an agent there",
        dir.letter()
    ))
}

/// W601: agent `i` (at `here`) is attached towards `dir` to agent `j` (whose position is
/// at `there`), which does not declare the bond back.
pub fn bond_made(
    file: FileId,
    (i, here): (usize, Span),
    dir: Dir,
    (j, there): (usize, Span),
) -> Diagnostic {
    Diagnostic::new(
        Code::W601,
        format!(
            "agent {i} is attached towards {} to agent {j}, which does not declare the bond; the bond is made",
            dir.letter()
        ),
        Label::new(file, here, format!("declares the bond towards {}", dir.letter())),
    )
    .with_secondary(Label::new(file, there, format!("agent {j} does not declare it")))
    .with_help(format!(
        "set the {} character of agent {j}'s attachments to 1 as well",
        dir.opposite().letter()
    ))
}

/// Attachments made symmetric: a warning where only one side declared a bond (W601, the
/// bond is made), and bonds towards empty cells dropped (W602). `spans`: each agent's
/// position and attachments field.
fn bonds(
    agents: &mut [AgentInit],
    cells: &HashMap<[i32; 3], usize>,
    (file, d): (FileId, Dim),
    (spans, attach_spans): (&[Span], &[Option<Span>]),
    diags: &mut Vec<Diagnostic>,
) {
    for i in 0..agents.len() {
        for dir in Dir::ALL.iter().take(d.dirs()) {
            let bit = 1u8 << dir.index();
            if agents[i].attach & bit == 0 {
                continue;
            }
            let o = dir.offset();
            let p = agents[i].pos;
            // A cell past the lattice's last (at the 32-bit range's end) holds no agent.
            let key = (|| {
                Some([
                    p[0].checked_add(o[0])?,
                    p[1].checked_add(o[1])?,
                    p[2].checked_add(o[2])?,
                ])
            })();
            let here = attach_spans[i].unwrap_or(spans[i]);
            match key.and_then(|k| cells.get(&k)) {
                None => {
                    agents[i].attach &= !bit;
                    diags.push(bond_dropped(file, i, *dir, here));
                }
                Some(&j) => {
                    let back = 1u8 << dir.opposite().index();
                    if agents[j].attach & back == 0 {
                        agents[j].attach |= back;
                        diags.push(bond_made(file, (i, here), *dir, (j, spans[j])));
                    }
                }
            }
        }
    }
}
