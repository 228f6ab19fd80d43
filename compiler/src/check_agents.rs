//! Checking an agents file: dimensions, the universe, cells, states, attachments and
//! counters (E40x, W60x), producing the checked [`Config`].

use crate::check_rules::{chars, VALUE_MAX};
use crate::checked::{AgentInit, Bounds, Config, Dim, Dir};
use crate::dim::DimSource;
use latticesim_grammar::ast::AgentsFile;
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
    diags: &mut Vec<Diagnostic>,
) -> Config {
    let d = dim.dim;
    let mut universe: Option<Bounds> = None;
    if let Some(u) = &f.universe {
        let mut b: Bounds = [(0, 0); 3];
        let mut ok = true;
        for (i, pair) in u.bounds.chunks(2).enumerate() {
            for v in pair {
                if i32::try_from(v.node).is_err() {
                    diags.push(
                        Diagnostic::new(
                            Code::E406,
                            format!(
                                "the universe bound {} is outside the 32-bit range",
                                crate::written(src, v.span)
                            ),
                            Label::new(file, v.span, size_word(v.node)),
                        )
                        .with_help("leave out the `U` line for an unbounded universe"),
                    );
                    ok = false;
                }
            }
            b[i] = (pair[0].node as i32, pair[1].node as i32);
        }
        if ok {
            universe = Some(b);
        }
    }
    let mut agents = Vec::with_capacity(f.agents.len());
    let mut cells: HashMap<[i32; 3], usize> = HashMap::with_capacity(f.agents.len());
    let mut spans = Vec::with_capacity(f.agents.len());
    let mut attach_spans: Vec<Option<Span>> = Vec::with_capacity(f.agents.len());
    for a in &f.agents {
        let pos_span = a.pos[0].span.to(a.pos[a.pos.len() - 1].span);
        if a.pos.len() != d.coords() {
            let msg = format!(
                "this position has {} coordinates; the file is {} and needs {}",
                a.pos.len(),
                d.name(),
                d.coords()
            );
            diags.push(
                dim.attach(
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
            continue;
        }
        let mut pos = [0i32; 3];
        let mut ok = true;
        for (i, c) in a.pos.iter().enumerate() {
            match i32::try_from(c.node) {
                Ok(v) => pos[i] = v,
                Err(_) => {
                    diags.push(
                        Diagnostic::new(
                            Code::E410,
                            format!(
                                "the coordinate {} is outside the 32-bit range of the lattice",
                                crate::written(src, c.span)
                            ),
                            Label::new(file, c.span, size_word(c.node)),
                        )
                        .with_help("coordinates are 32-bit integers"),
                    );
                    ok = false;
                }
            }
        }
        if ok {
            if let (Some(b), Some(u)) = (universe, &f.universe) {
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
        let mut state = *b"00000";
        if let Some(s) = a.state {
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
                ok = false;
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
                        ok = false;
                    } else {
                        state[i] = c as u8;
                    }
                }
            }
        }
        let mut attach = 0u8;
        if let Some(s) = a.attach {
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
                ok = false;
            } else {
                for (i, b) in s.node.bytes().enumerate() {
                    if b == b'1' {
                        attach |= 1 << i;
                    }
                }
            }
        }
        let mut counters = Vec::with_capacity(a.counters.len());
        for (c, v) in &a.counters {
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
                ok = false;
            } else if !(-VALUE_MAX..=VALUE_MAX).contains(&v.node) {
                diags.push(
                    Diagnostic::new(
                        Code::E404,
                        format!(
                            "the value {} of C{} is outside -32767..32767",
                            crate::written(src, v.span),
                            c.node
                        ),
                        Label::new(file, v.span, size_word(v.node)),
                    )
                    .with_help("counters hold 16-bit values from -32767 to 32767"),
                );
                ok = false;
            } else if v.node != 0 {
                counters.push((idx as u8, v.node as i16));
            }
        }
        if ok {
            if let Some(&prev) = cells.get(&pos) {
                diags.push(
                    Diagnostic::new(
                        Code::E402,
                        format!(
                            "two agents on the cell {}",
                            a.pos
                                .iter()
                                .map(|p| p.node.to_string())
                                .collect::<Vec<_>>()
                                .join(",")
                        ),
                        Label::new(
                            file,
                            pos_span,
                            format!("agent {} would stand here", agents.len()),
                        ),
                    )
                    .with_secondary(Label::new(
                        file,
                        spans[prev],
                        format!("agent {prev} stands here already"),
                    ))
                    .with_help("move one of them, or delete the duplicate line"),
                );
                continue;
            }
            counters.sort_unstable();
            cells.insert(pos, agents.len());
            spans.push(pos_span);
            attach_spans.push(a.attach.map(|s| field(s.span)));
            agents.push(AgentInit {
                pos,
                state,
                attach,
                counters,
            });
        }
    }
    // Attachments: make them symmetric, warn where only one side declared a bond, drop
    // bonds towards empty cells.
    for i in 0..agents.len() {
        for dir in Dir::ALL.iter().take(d.dirs()) {
            let bit = 1u8 << dir.index();
            if agents[i].attach & bit == 0 {
                continue;
            }
            let o = dir.offset();
            let p = agents[i].pos;
            let key = [p[0] + o[0], p[1] + o[1], p[2] + o[2]];
            let here = attach_spans[i].unwrap_or(spans[i]);
            match cells.get(&key) {
                None => {
                    agents[i].attach &= !bit;
                    diags.push(
                        Diagnostic::new(
                            Code::W602,
                            format!("agent {i} is attached towards {}, where no agent stands; the attachment is dropped", dir.letter()),
                            Label::new(file, here, format!("attachment {}", dir.letter())),
                        )
                        .with_help(format!("set the {} character to 0, or add an agent there", dir.letter())),
                    );
                }
                Some(&j) => {
                    let back = 1u8 << dir.opposite().index();
                    if agents[j].attach & back == 0 {
                        agents[j].attach |= back;
                        diags.push(
                            Diagnostic::new(
                                Code::W601,
                                format!(
                                    "agent {i} is attached towards {} to agent {j}, which does not declare the bond; the bond is made",
                                    dir.letter()
                                ),
                                Label::new(file, here, format!("declares the bond towards {}", dir.letter())),
                            )
                            .with_secondary(Label::new(file, spans[j], format!("agent {j} does not declare it")))
                            .with_help(format!(
                                "set the {} character of agent {j}'s attachments to 1 as well",
                                dir.opposite().letter()
                            )),
                        );
                    }
                }
            }
        }
    }
    Config {
        dim: d,
        universe,
        agents,
    }
}
