//! The calculations of a step: every agent that executes a rule with calculations or sends
//! runs them, in chunks of agents (on the pool when it pays), through the column
//! interpreter where the plan allows and the evaluator for one agent elsewhere.

use super::*;

impl Post {
    /// Paper step 3, first half: every selected rule's calculations and sends.
    ///
    /// Each agent writes only its own counters and outbox, so the agents are split into
    /// chunks (worked on in parallel with --threads) whose issues and trace events are
    /// joined in agent order afterwards. Within a chunk, a run of consecutive agents that
    /// execute the same single rule runs that rule's calculations one instruction at a
    /// time over the whole run ([`run_batch`]), which amortises the dispatch and lets the
    /// compiler vectorise; other agents run the rule alone ([`run_post`]).
    /// `fire_counts`: per rule, how many agents execute it.
    pub(super) fn calculate(
        &mut self,
        (prog, plan, trace): (&Program, &Plan, bool),
        (lat, th): (&mut Lattice, &Threads),
        (sel, fire_counts): (&Selection, &[u64]),
        (stats, cap): (&mut Stats, Option<usize>),
        rep: &mut StepReport,
    ) {
        if !plan.any_computes {
            return;
        }
        lat.refresh_neighbours();
        let n = lat.len();
        let nd = lat.dim.dirs();
        // External counters read the values at the start of this phase.
        let snapshot = if prog.externals.is_empty() {
            Snapshot::None
        } else if sel.listed {
            let cols = (lat.counters.iter())
                .map(|col| {
                    let mut c = Column::with_capacity(col.width(), sel.list.len());
                    sel.list.iter().for_each(|&a| c.push(col.get(a as usize)));
                    c
                })
                .collect();
            Snapshot::Listed(sel.list.clone(), cols)
        } else {
            Snapshot::All(lat.counters.clone())
        };
        let mut counters = std::mem::take(&mut lat.counters);
        let mut out_num = std::mem::take(&mut self.out_num);
        let mut out_has = std::mem::take(&mut self.out_has);
        let mut out_text = std::mem::take(&mut self.out_text);
        let mut out_text_bits = std::mem::take(&mut self.out_text_bits);
        // External counters of agents outside the list are read from the one chunk that
        // then holds all agents.
        let (par, size, chunks) = match snapshot {
            Snapshot::Listed(..) => (None, n.max(1), 1),
            _ => th.chunks(n),
        };
        let cols = (
            &mut out_num[..],
            &mut out_has[..],
            &mut out_text[..],
            &mut out_text_bits[..],
        );
        let items = CalcChunk::split(&mut counters, cols, (n, nd), (size, chunks));
        let post_columns = &plan.post_columns;
        // When every agent executes the same one rule, runs need no search.
        let uniform = sel.many.is_empty() && fire_counts.contains(&(n as u64));
        // The neighbour bits are made at the first delivery; until then it counts.
        let (defer, has_nbr) = (plan.defer, &self.has_nbr);
        let view = &*lat;
        let count = defer && has_nbr.len() == nd;
        let work = |mut ch: CalcChunk<'_>| {
            // With messages left with their senders, the outboxes come back from the
            // lattice holding the step before last's bits.
            if defer {
                ch.out_has.iter_mut().for_each(|c| c.fill(0));
            }
            let mut issues: Vec<(u32, u32, CalcIssue)> = Vec::new();
            let mut events = Vec::new();
            let mut bufs = Kept::<CalcBufs>::take();
            // The runs of agents to visit: from the selection's list when it has one (the
            // others execute nothing), else found in the entries.
            let mine = sel.listed.then(|| {
                let l = &sel.list[..];
                let lo = l.partition_point(|&a| (a as usize) < ch.lo);
                let hi = l.partition_point(|&a| (a as usize) < ch.lo + ch.len);
                &l[lo..hi]
            });
            let mut k = 0;
            let mut i = 0;
            // One in-place add for the whole chunk, without runs (see the plan).
            if let (None, Some(add), false) = (mine, plan.masked_add, trace) {
                let one = &sel.one[ch.lo..ch.lo + ch.len];
                if sel.many.is_empty() && masked_add(view, &mut ch, one, add) {
                    k = ch.len;
                }
            }
            loop {
                // The next agent that executes a rule, as `k` (from the chunk's start).
                match mine {
                    Some(ids) => match ids.get(i) {
                        Some(&a) => k = a as usize - ch.lo,
                        None => break,
                    },
                    None => {
                        if k >= ch.len {
                            break;
                        }
                        let a = ch.lo + k;
                        if sel.one[a] == NO_RULE {
                            // A run of agents executing nothing.
                            k += run_of(&sel.one[a..ch.lo + ch.len], NO_RULE);
                            continue;
                        }
                    }
                }
                let a = ch.lo + k;
                let rs = sel.of(a);
                if let [r] = *rs {
                    if !prog.rules[r as usize].computes {
                        k += 1;
                        i += 1;
                        continue;
                    }
                    if let Some(post) = &post_columns[r as usize] {
                        let end = match mine {
                            // Listed agents with consecutive ids and the same rule.
                            Some(ids) => {
                                let m = ids[i..]
                                    .iter()
                                    .enumerate()
                                    .take_while(|&(j, &b)| {
                                        b as usize == a + j && sel.one[b as usize] == r
                                    })
                                    .count();
                                i += m;
                                k + m
                            }
                            None if uniform => ch.len,
                            None => k + run_of(&sel.one[ch.lo + k..ch.lo + ch.len], r),
                        };
                        // Traced, the run takes the same path; its counters before are kept
                        // to say which changed, agent by agent as the path of one agent does.
                        let before = trace.then(|| counters_of(&ch, view, k..end));
                        let rule = (r, &post[..]);
                        run_batch(prog, rule, view, (&mut ch, &mut bufs), k..end, &mut issues);
                        if let Some(before) = before {
                            counter_events(&before, &ch, view, k..end, &mut events);
                        }
                        k = end;
                        continue;
                    }
                }
                for &r in rs {
                    let found = (&mut issues, &mut events);
                    run_alone(prog, view, (&mut ch, k, &snapshot), r, trace, found);
                }
                k += 1;
                i += 1;
            }
            let counted = if count {
                Tally::of(&ch.out_has, has_nbr, ch.lo / 64, nd, ch.len)
            } else {
                Tally::default()
            };
            (issues, events, counted)
        };
        let results: Vec<_> = map_on(par, items, work);
        lat.counters = counters;
        self.out_num = out_num;
        self.out_has = out_has;
        self.out_text = out_text;
        self.out_text_bits = out_text_bits;
        if count {
            let mut tallies = results.iter().map(|r| &r.2);
            let first = tallies.next().cloned().unwrap_or_default();
            self.counted = Some(tallies.fold(first, |t, u| t.and(u)));
        }
        for (issues, events, _) in results {
            calc_records(prog, (stats, lat, cap), issues, rep);
            rep.trace.extend(events);
        }
    }
}

/// The records of the calculations' issues (agent, rule, issue), in order.
fn calc_records(
    prog: &Program,
    (stats, lat, cap): (&mut Stats, &Lattice, Option<usize>),
    issues: Vec<(u32, u32, CalcIssue)>,
    rep: &mut StepReport,
) {
    for (a, r, issue) in issues {
        let name = &prog.rules[r as usize].name;
        let id = lat.label(a);
        let kind = match issue {
            CalcIssue::Saturated { .. } => RecordKind::Saturation,
            CalcIssue::DivisionByZero => RecordKind::DivisionByZero,
            CalcIssue::NoExternalAgent { .. } => RecordKind::NoExternalAgent,
        };
        // (Counters near their range may saturate for every agent, every step.)
        let msg = |_: &Lattice| match issue {
            CalcIssue::Saturated { exact } => format!(
                "agent {id}, rule `{name}`: the result {exact} is saturated to the {}-bit range",
                prog.width.bits()
            ),
            CalcIssue::DivisionByZero => {
                format!("agent {id}, rule `{name}`: division by zero; the target is unchanged")
            }
            CalcIssue::NoExternalAgent { off } => format!(
                "agent {id}, rule `{name}`: no agent at ({},{}) to read an external counter \
                 from; the calculation is skipped",
                off[0], off[1]
            ),
        };
        record_with((stats, lat, cap), rep, kind, &[a], msg);
    }
}

/// Every counter of agents `range` of a chunk (a column per counter), for a trace.
fn counters_of(ch: &CalcChunk<'_>, lat: &Lattice, range: std::ops::Range<usize>) -> Vec<Vec<i32>> {
    (0..lat.nc() as u8)
        .map(|i| range.clone().map(|j| ch.counter(lat, j, i)).collect())
        .collect()
}

/// The trace events of the counters of agents `range` of a chunk that changed since
/// `before` ([`counters_of`]), agent by agent, counters in number order.
fn counter_events(
    before: &[Vec<i32>],
    ch: &CalcChunk<'_>,
    lat: &Lattice,
    range: std::ops::Range<usize>,
    events: &mut Vec<TraceEvent>,
) {
    for j in range.clone() {
        for (i, col) in before.iter().enumerate() {
            let new = ch.counter(lat, j, i as u8);
            if col[j - range.start] != new {
                events.push(TraceEvent::Counter {
                    agent: (ch.lo + j) as u32,
                    counter: i as u8,
                    value: new,
                });
            }
        }
    }
}

/// The calculations of rule `r` for agent `k` of a chunk, alone (the evaluator of one
/// agent; `snapshot`: the counters read by external terms), with its issues and, traced,
/// its counters' events.
#[inline]
fn run_alone(
    prog: &Program,
    lat: &Lattice,
    (ch, k, snapshot): (&mut CalcChunk<'_>, usize, &Snapshot),
    r: u32,
    trace: bool,
    (issues, events): (&mut Vec<(u32, u32, CalcIssue)>, &mut Vec<TraceEvent>),
) {
    if !prog.rules[r as usize].computes {
        return;
    }
    let a = ch.lo + k;
    let before = if trace {
        counters_of(ch, lat, k..k + 1)
    } else {
        Vec::new()
    };
    let mut env = CalcCtx {
        lat,
        a,
        k,
        ch: &mut *ch,
        snapshot,
        issues: Vec::new(),
    };
    run_post(prog, r as usize, &mut env);
    issues.extend(env.issues.into_iter().map(|(_, i)| (a as u32, r, i)));
    if trace {
        counter_events(&before, ch, lat, k..k + 1, events);
    }
}
