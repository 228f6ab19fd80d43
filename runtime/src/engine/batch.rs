//! The column interpreter: preconditions and calculations run over a run of agents at
//! once, a column per value (`batch_pre`, `run_batch`), with the most frequent calculations
//! in place (`fast_calc`, chains of `max`/`min`). The engine takes this path only for the
//! rules its plan marks as batchable. Both widths of counters run here: the loops over
//! columns are written once over [`Lane`] and compiled for each.

use super::*;

/// Stack depth of [`batch_pre`].
pub(super) const PRE_STACK: usize = 6;

/// The working space of [`batch_pre`], taken once for a chunk of agents rather than at
/// each call (a call may evaluate a run of a few agents), and kept by its thread between
/// steps ([`Kept`]): its stack of truth values and its two operands.
pub(super) struct PreBufs {
    pub(super) stack: [[bool; BATCH]; PRE_STACK],
    pub(super) x: [i32; BATCH],
    pub(super) y: [i32; BATCH],
}

impl Scratch for PreBufs {
    fn made() -> Box<PreBufs> {
        Box::new(PreBufs {
            stack: [[false; BATCH]; PRE_STACK],
            x: [0; BATCH],
            y: [0; BATCH],
        })
    }

    fn kept() -> &'static std::thread::LocalKey<std::cell::Cell<Option<Box<PreBufs>>>> {
        thread_local! {
            static KEPT: std::cell::Cell<Option<Box<PreBufs>>> = const { std::cell::Cell::new(None) };
        }
        &KEPT
    }
}

/// Working space of the column interpreter that a chunk of agents takes for a step
/// ([`Kept::take`]): made (and zeroed) once per thread, not for every chunk of every step.
/// (B2F made 16 of each kind a step, 29 KB zeroed per chunk; 1,000 walkers beside 10^5
/// agents at rest, listed, spent a tenth of their stepping on making theirs.)
pub(super) trait Scratch: Sized + 'static {
    /// New working space.
    fn made() -> Box<Self>;
    /// Where this thread keeps the last given back.
    fn kept() -> &'static std::thread::LocalKey<std::cell::Cell<Option<Box<Self>>>>;
}

/// Working space taken from the thread's (or made), given back when dropped. What it holds
/// between uses is what it holds between two runs of one chunk, which the interpreter
/// expects of it already; after a panic it is not given back.
pub(super) struct Kept<T: Scratch>(Option<Box<T>>);

impl<T: Scratch> Kept<T> {
    /// The thread's working space, or new.
    pub(super) fn take() -> Kept<T> {
        let kept = T::kept().try_with(|k| k.take()).ok().flatten();
        Kept(Some(kept.unwrap_or_else(T::made)))
    }
}

impl<T: Scratch> std::ops::Deref for Kept<T> {
    type Target = T;
    fn deref(&self) -> &T {
        self.0.as_deref().expect("held until dropped")
    }
}

impl<T: Scratch> std::ops::DerefMut for Kept<T> {
    fn deref_mut(&mut self) -> &mut T {
        self.0.as_deref_mut().expect("held until dropped")
    }
}

impl<T: Scratch> Drop for Kept<T> {
    fn drop(&mut self) {
        if let Some(b) = self.0.take().filter(|_| !std::thread::panicking()) {
            // (A thread being torn down keeps nothing.)
            let _ = T::kept().try_with(|k| k.set(Some(b)));
        }
    }
}

/// A value a column precondition reads: never an external counter nor a message from any
/// direction (those are evaluated one agent at a time).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum ColVal {
    /// A literal.
    Lit(i32),
    /// An own counter.
    Counter(u8),
    /// An incoming numeric message from one direction.
    Msg { dir: u8, slot: u8 },
}

impl ColVal {
    /// The value as the column interpreter reads it, when it can.
    pub(super) fn of(v: Val, prog: &Program) -> Option<ColVal> {
        match v {
            Val::Lit(c) => Some(ColVal::Lit(c as i32)),
            Val::Wide(i) => Some(ColVal::Lit(prog.wide[i as usize])),
            Val::Counter(c) => Some(ColVal::Counter(c)),
            Val::Msg { dir, slot } if dir != ANY_DIR => Some(ColVal::Msg { dir, slot }),
            _ => None,
        }
    }
}

/// One instruction of a precondition the column interpreter runs ([`batch_pre`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum PreStep {
    True,
    Nbr {
        mask: u8,
        want: u8,
    },
    /// `F` (`filled`) or `E` at a literal offset other than one step.
    Cell {
        off: [i32; 3],
        filled: bool,
    },
    Att {
        mask: u8,
        want: u8,
    },
    State {
        pat: u16,
    },
    Cmp {
        op: CmpOp,
        a: ColVal,
        b: ColVal,
    },
    Not,
    And,
}

/// A rule's precondition as the column interpreter runs it: made by [`column_pre`], only
/// for preconditions it can run, so that running one never meets an instruction it does
/// not know.
pub(super) type ColumnPre = Vec<PreStep>;

/// A precondition for [`batch_pre`], when it can run it: only terms about the agent itself
/// and its neighbours (no priorities, offsets, texts, external counters or messages from
/// any direction), within its stack depth. Short-circuit jumps are left out: the terms
/// have no side effects and a false left operand makes the conjunction false either way.
///
/// `filter`: the rule's state filter. Only agents whose state passes it evaluate the rule
/// (rule dispatch), so a test of the agent's state against that pattern is true for all of
/// them; it is left out with the conjunction that takes it (for nearly every rule, whose
/// precondition begins with its state, this saves a test of five letters per agent).
pub(super) fn column_pre(prog: &Program, code: &[Op], filter: Option<u16>) -> Option<ColumnPre> {
    let mut depth = 0usize;
    let mut steps = Vec::with_capacity(code.len());
    // Per value on the stack: the index in `steps` of the `True` that pushed it, when it
    // is that constant.
    let mut truth: Vec<Option<usize>> = Vec::new();
    // `E` or `F` at a literal offset of one step (`E0,-1`: the cell below is empty) asks
    // what a neighbour pattern asks (`N***0`), and is run as one.
    let neighbour = |off: u16| {
        let o = literal(&prog.offsets[off as usize])?;
        (0..prog.dim.dirs()).find(|&d| Dir::ALL[d].offset() == o)
    };
    for op in code {
        let step = match *op {
            Op::True {} => PreStep::True,
            Op::Nbr { mask, want } => PreStep::Nbr { mask, want },
            Op::Empty { off } | Op::Filled { off } => {
                let filled = matches!(op, Op::Filled { .. });
                match neighbour(off) {
                    Some(d) => PreStep::Nbr {
                        mask: 1 << d,
                        want: (filled as u8) << d,
                    },
                    None => PreStep::Cell {
                        off: literal(&prog.offsets[off as usize])?,
                        filled,
                    },
                }
            }
            Op::Att { mask, want } => PreStep::Att { mask, want },
            Op::State { pat } if Some(pat) == filter => PreStep::True,
            Op::State { pat } => PreStep::State { pat },
            Op::Cmp { op, a, b } => PreStep::Cmp {
                op,
                a: ColVal::of(a, prog)?,
                b: ColVal::of(b, prog)?,
            },
            Op::Not {} => PreStep::Not,
            Op::And {} => PreStep::And,
            Op::Jf { .. } => continue,
            _ => return None,
        };
        match step {
            PreStep::Not => {
                // (A negated constant is no longer the constant `True`.)
                if let Some(t) = truth.last_mut() {
                    *t = None;
                }
            }
            PreStep::And => {
                let (Some(b), Some(a)) = (truth.pop(), truth.pop()) else {
                    return None;
                };
                // `x and True` is `x`: the `True` and this `And` are left out (the `True`
                // of the lower operand comes before the steps of the upper one, which
                // push exactly one value of their own).
                match (a, b) {
                    (_, Some(i)) | (Some(i), None) => {
                        steps.remove(i);
                        depth -= 1;
                        truth.push(if b.is_some() { a } else { None });
                        continue;
                    }
                    (None, None) => {
                        depth -= 1;
                        truth.push(None);
                    }
                }
            }
            PreStep::True => {
                depth += 1;
                truth.push(Some(steps.len()));
            }
            _ => {
                depth += 1;
                truth.push(None);
            }
        }
        if depth > PRE_STACK {
            return None;
        }
        steps.push(step);
    }
    Some(steps)
}

/// An offset's value when it has no counter in it.
pub(super) fn literal(o: &latticesim_vm::model::Offset) -> Option<[i32; 3]> {
    let lit = |c: &Coord| match *c {
        Coord::Lit(v) => Some(v),
        Coord::Counter(_) => None,
    };
    Some([lit(&o[0])?, lit(&o[1])?, lit(&o[2])?])
}

/// The agents a column program runs over: a run of consecutive agents from the first,
/// or agents listed by id (in any order).
#[derive(Clone, Copy)]
pub(super) enum Rows<'a> {
    Run(usize),
    Ids(&'a [u32]),
}

impl Rows<'_> {
    /// The values of a column for the rows, into `out` (as many as it holds).
    #[inline]
    fn gather<T: Copy, U>(self, col: &[T], out: &mut [U], f: impl Fn(T) -> U) {
        match self {
            Rows::Run(first) => {
                let m = out.len();
                for (t, &s) in out.iter_mut().zip(&col[first..first + m]) {
                    *t = f(s);
                }
            }
            Rows::Ids(ids) => {
                for (t, &a) in out.iter_mut().zip(ids) {
                    *t = f(col[a as usize]);
                }
            }
        }
    }

    /// The `j`-th agent.
    #[inline]
    fn agent(self, j: usize) -> usize {
        match self {
            Rows::Run(first) => first + j,
            Rows::Ids(ids) => ids[j] as usize,
        }
    }
}

/// Evaluates a precondition made by [`column_pre`] (in a program without priority terms)
/// for the agents `rows` (as many as `out` holds) at once, one instruction over all of
/// them.
pub(super) fn batch_pre(
    prog: &Program,
    (pre, rows): (&[PreStep], Rows<'_>),
    lat: &Lattice,
    bufs: &mut PreBufs,
    out: &mut [bool],
) {
    let m = out.len();
    let PreBufs { stack, x, y } = bufs;
    let mut sp = 0;
    let nd = lat.dim.dirs();
    let load = |v: ColVal, into: &mut [i32]| match v {
        ColVal::Lit(c) => into.fill(c),
        ColVal::Counter(c) => match lat.counter_col[c as usize] {
            NO_COL => into.fill(0),
            col => each_width!(&lat.counters[col as usize], v => rows.gather(v, into, Into::into)),
        },
        ColVal::Msg { dir, slot } => {
            for (j, t) in into.iter_mut().enumerate() {
                *t = lat.inbox(rows.agent(j) as u32, dir, slot);
            }
        }
    };
    for &step in pre {
        match step {
            PreStep::True => {
                stack[sp][..m].fill(true);
                sp += 1;
            }
            PreStep::Nbr { mask, want } => {
                // Only the directions the term asks about are looked at.
                let top = &mut stack[sp][..m];
                top.fill(true);
                for d in (0..nd).filter(|d| mask & (1 << d) != 0) {
                    let filled = want & (1 << d) != 0;
                    match rows {
                        Rows::Run(first) => lat.keep_if_filled(first, d, filled, top),
                        Rows::Ids(ids) => lat.keep_if_filled_ids(&ids[..m], d, filled, top),
                    }
                }
                sp += 1;
            }
            PreStep::Cell { off, filled } => {
                let agents = (0..m).map(|j| rows.agent(j));
                lat.cells_filled(agents, off, filled, &mut stack[sp][..m]);
                sp += 1;
            }
            PreStep::Att { mask, want } => {
                rows.gather(&lat.attach, &mut stack[sp][..m], |at| {
                    at & mask == want & mask
                });
                sp += 1;
            }
            PreStep::State { pat } => {
                let p = &prog.pats[pat as usize];
                let top = &mut stack[sp][..m];
                match rows {
                    Rows::Run(first) => {
                        for (t, st) in top.iter_mut().zip(&lat.state[first..first + m]) {
                            *t = latticesim_vm::eval::matches(p, st);
                        }
                    }
                    Rows::Ids(ids) => {
                        for (t, &a) in top.iter_mut().zip(ids) {
                            *t = latticesim_vm::eval::matches(p, &lat.state[a as usize]);
                        }
                    }
                }
                sp += 1;
            }
            // A counter against a literal: compared straight from its column.
            PreStep::Cmp {
                op,
                a: ColVal::Counter(c),
                b: ColVal::Lit(v),
            } if lat.counter_col[c as usize] != NO_COL => {
                let top = &mut stack[sp][..m];
                each_width!(&lat.counters[lat.counter_col[c as usize] as usize], col => {
                    let w = |p| -> i32 { Into::into(p) };
                    match op {
                        CmpOp::Lt => rows.gather(col, top, |p| w(p) < v),
                        CmpOp::Gt => rows.gather(col, top, |p| w(p) > v),
                        CmpOp::Eq => rows.gather(col, top, |p| w(p) == v),
                    }
                });
                sp += 1;
            }
            PreStep::Cmp { op, a, b } => {
                load(a, &mut x[..m]);
                load(b, &mut y[..m]);
                let top = stack[sp][..m].iter_mut().zip(&x[..m]).zip(&y[..m]);
                // One loop per operator, so that each is a vector compare.
                match op {
                    CmpOp::Lt => top.for_each(|((t, &p), &q)| *t = p < q),
                    CmpOp::Gt => top.for_each(|((t, &p), &q)| *t = p > q),
                    CmpOp::Eq => top.for_each(|((t, &p), &q)| *t = p == q),
                }
                sp += 1;
            }
            PreStep::Not => stack[sp - 1][..m].iter_mut().for_each(|t| *t = !*t),
            PreStep::And => {
                sp -= 1;
                let (low, high) = stack.split_at_mut(sp);
                for (t, &u) in low[sp - 1][..m].iter_mut().zip(&high[0][..m]) {
                    *t &= u;
                }
            }
        }
    }
    out.copy_from_slice(&stack[0][..m]);
}

/// The most frequent calculations over a run of agents, in the columns' own width (without
/// a detour through wider temporaries): `Cxx = Cxx max/min (message or literal)` in place
/// (cannot saturate), `Cxx = Cxx +/- literal` in place when no result saturates, and
/// sending a counter as it is (`x + 0`, `x - 0`). Returns false for anything else.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(super) fn fast_calc<V: Lane>(
    lat: &Lattice,
    ch: &mut CalcChunk<'_>,
    ks: std::ops::Range<usize>,
    first: usize,
    (target, op, a, b): (Target, CalcOp, ColVal, ColVal),
    buf: &mut MsgBufs,
) -> bool {
    let len = ks.len();
    match (target, op, a, b) {
        (Target::Counter(c), CalcOp::Max | CalcOp::Min, ColVal::Counter(ca), b) if ca == c => {
            let col =
                &mut V::of_cut_mut(&mut ch.counters[lat.counter_col[c as usize] as usize])[ks];
            let max = op == CalcOp::Max;
            match b {
                ColVal::Lit(v) if max => col.iter_mut().for_each(|t| *t = (*t).max(V::of(v))),
                ColVal::Lit(v) => col.iter_mut().for_each(|t| *t = (*t).min(V::of(v))),
                ColVal::Msg { dir, slot } => {
                    let (out, hint) = V::bufs(buf);
                    let src = lat.inbox_run(first, (dir, slot), &mut out[..len], hint);
                    if max {
                        col.iter_mut().zip(src).for_each(|(t, &v)| *t = (*t).max(v));
                    } else {
                        col.iter_mut().zip(src).for_each(|(t, &v)| *t = (*t).min(v));
                    }
                }
                _ => return false,
            }
            true
        }
        // `Cxx = Cxx + v` or `Cxx = Cxx - v` in place, when no result saturates.
        (Target::Counter(c), CalcOp::Add | CalcOp::Sub, ColVal::Counter(ca), ColVal::Lit(v))
            if ca == c =>
        {
            let col =
                &mut V::of_cut_mut(&mut ch.counters[lat.counter_col[c as usize] as usize])[ks];
            let v = if op == CalcOp::Add {
                v as i64
            } else {
                -(v as i64)
            };
            let m = V::WIDTH.max() as i64;
            let fits = |t: V| (-m..=m).contains(&(Into::<i32>::into(t) as i64 + v));
            if !col.iter().fold(true, |ok, &t| ok & fits(t)) {
                return false;
            }
            col.iter_mut()
                .for_each(|t| *t = V::of((Into::<i32>::into(*t) as i64 + v) as i32));
            true
        }
        (
            Target::Msg { dir, slot },
            CalcOp::Add | CalcOp::Sub,
            ColVal::Counter(c),
            ColVal::Lit(0),
        ) => {
            let src = lat.counter_col[c as usize] as usize;
            let cols = ch.send_cols(lat, dir, slot);
            for &col in cols.write() {
                let counters = ch.counters[src].cut(ks.clone());
                ch.out_num[col].cut_mut(ks.clone()).copy_from(counters);
                set_bits(ch.out_has[col], ks.clone());
            }
            for &col in cols.clear() {
                clear_bits(ch.out_has[col], ks.clone());
            }
            true
        }
        _ => false,
    }
}

/// How many instructions at the start of `code` (none, or two to six) are a chain of
/// `Cxx = Cxx max #Dss` on one counter (or of `min`, not mixed), each with a message
/// from one direction, which [`chain_in_place`] runs in one pass.
#[inline]
pub(super) fn max_chain(code: &[Op]) -> usize {
    let link = |op: &Op| match *op {
        Op::Calc {
            target: Target::Counter(c),
            op: op @ (CalcOp::Max | CalcOp::Min),
            a: Val::Counter(ca),
            b: Val::Msg { dir, .. },
        } if ca == c && dir != ANY_DIR => Some((c, op)),
        _ => None,
    };
    let Some(first) = code.first().and_then(link) else {
        return 0;
    };
    let n = code
        .iter()
        .take(6)
        .take_while(|op| link(op) == Some(first))
        .count();
    if n >= 2 {
        n
    } else {
        0
    }
}

/// One step of a postcondition the column interpreter runs ([`run_batch`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum PostStep {
    /// A text sent towards a direction (or all).
    Send { dir: u8, text: u16 },
    /// A chain of in-place max/min with messages ([`max_chain`]), run in one pass.
    Chain(Chain),
    /// A calculation on values of the agent itself.
    Calc {
        target: Target,
        op: CalcOp,
        a: ColVal,
        b: ColVal,
    },
}

/// A chain of two to six in-place `max` (or `min`) of a counter with messages from one
/// direction each ([`max_chain`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Chain {
    /// The counter.
    pub(super) counter: u8,
    /// `max` (else `min`).
    pub(super) max: bool,
    /// Per link, the message's direction and slot (the first `len`).
    pub(super) msgs: [(u8, u8); 6],
    pub(super) len: u8,
}

/// A rule's postcondition as the column interpreter runs it: made by [`column_post`], only
/// for postconditions whose every calculation it can run.
pub(super) type ColumnPost = Vec<PostStep>;

/// A postcondition for [`run_batch`], when it can run its calculations: none reads an
/// external counter or a message from any direction. The actions (moves, bonds, states,
/// swaps) are the actions phase's and are left out; an instruction of any other kind
/// makes no column program (the rule then runs one agent at a time), so that none is
/// passed over unseen.
pub(super) fn column_post(prog: &Program, code: &[Op]) -> Option<ColumnPost> {
    let mut steps = Vec::new();
    let mut i = 0;
    while i < code.len() {
        let chain = max_chain(&code[i..]);
        if chain >= 2 {
            let mut c = Chain {
                counter: 0,
                max: true,
                msgs: [(0, 0); 6],
                len: chain as u8,
            };
            for (k, op) in code[i..i + chain].iter().enumerate() {
                // max_chain found only such links.
                if let Op::Calc {
                    target: Target::Counter(t),
                    op,
                    b: Val::Msg { dir, slot },
                    ..
                } = *op
                {
                    (c.counter, c.max, c.msgs[k]) = (t, op == CalcOp::Max, (dir, slot));
                }
            }
            steps.push(PostStep::Chain(c));
            i += chain;
            continue;
        }
        match code[i] {
            Op::Send { dir, text } => steps.push(PostStep::Send { dir, text }),
            Op::Calc { target, op, a, b } => steps.push(PostStep::Calc {
                target,
                op,
                a: ColVal::of(a, prog)?,
                b: ColVal::of(b, prog)?,
            }),
            Op::Move { .. } | Op::Attach { .. } | Op::SetState { .. } | Op::Swap { .. } => {}
            _ => return None,
        }
        i += 1;
    }
    Some(steps)
}

/// Runs a chain of in-place max/min with messages ([`max_chain`]) over agents `ks` of the
/// chunk: the messages of each link are read first (the first into the first buffer, the
/// others into more), then the counter is read and written once. Max and min of values of
/// the width cannot saturate, so nothing is recorded.
pub(super) fn chain_in_place<V: Lane>(
    lat: &Lattice,
    ch: &mut CalcChunk<'_>,
    (chain, ks): (&Chain, std::ops::Range<usize>),
    bufs: &mut MsgBufs,
) {
    let (len, first) = (ks.len(), ch.lo + ks.start);
    let links = &chain.msgs[..chain.len as usize];
    let (first_buf, more, hint) = V::all_bufs(bufs);
    if more.len() < links.len() - 1 {
        more.resize(links.len() - 1, [V::default(); BATCH]);
    }
    let mut outs = std::iter::once(first_buf).chain(more.iter_mut());
    let mut srcs: [&[V]; 6] = [&[]; 6];
    for (k, &(dir, slot)) in links.iter().enumerate() {
        let out = &mut outs.next().expect("a buffer for each link")[..len];
        srcs[k] = lat.inbox_run(first, (dir, slot), out, hint);
    }
    let col =
        &mut V::of_cut_mut(&mut ch.counters[lat.counter_col[chain.counter as usize] as usize])[ks];
    if chain.max {
        fold_in_place(col, &srcs[..links.len()], V::max);
    } else {
        fold_in_place(col, &srcs[..links.len()], V::min);
    }
}

/// `col[j] = f(...f(f(col[j], srcs[0][j]), srcs[1][j])...)` in passes of up to four
/// sources each (vectorised).
#[inline(always)]
pub(super) fn fold_in_place<V: Copy>(col: &mut [V], srcs: &[&[V]], f: impl Fn(V, V) -> V + Copy) {
    let n = col.len();
    match *srcs {
        [] => {}
        [a] => col
            .iter_mut()
            .zip(&a[..n])
            .for_each(|(t, &x)| *t = f(*t, x)),
        [a, b] => {
            let ab = a[..n].iter().zip(&b[..n]);
            col.iter_mut()
                .zip(ab)
                .for_each(|(t, (&x, &y))| *t = f(f(*t, x), y));
        }
        [a, b, c] => {
            let abc = a[..n].iter().zip(&b[..n]).zip(&c[..n]);
            col.iter_mut()
                .zip(abc)
                .for_each(|(t, ((&x, &y), &z))| *t = f(f(f(*t, x), y), z));
        }
        [a, b, c, d, ref rest @ ..] => {
            let abcd = a[..n].iter().zip(&b[..n]).zip(&c[..n]).zip(&d[..n]);
            col.iter_mut()
                .zip(abcd)
                .for_each(|(t, (((&x, &y), &z), &w))| *t = f(f(f(f(*t, x), y), z), w));
            fold_in_place(col, rest, f);
        }
    }
}

/// Agents per inner batch of [`run_batch`], [`batch_pre`] and the post office.
pub(super) const BATCH: usize = 1024;

/// Messages read a batch at a time ([`Lattice::inbox_run`]) in either width: the first
/// buffer, those of the links of a chain of in-place max/min past the first (see
/// [`max_chain`], made at the first chain), and the post office's hints.
pub(super) struct MsgBufs {
    w16: ([i16; BATCH], Vec<[i16; BATCH]>),
    w32: ([i32; BATCH], Vec<[i32; BATCH]>),
    hint: [usize; 6],
}

/// A width the column interpreter calculates in: its message buffers.
pub(super) trait Lane: Value {
    /// The first buffer, the others, the hints.
    #[allow(clippy::type_complexity)]
    fn all_bufs(b: &mut MsgBufs) -> (&mut [Self; BATCH], &mut Vec<[Self; BATCH]>, &mut [usize; 6]);
    /// The first buffer and the hints.
    fn bufs(b: &mut MsgBufs) -> (&mut [Self; BATCH], &mut [usize; 6]) {
        let (first, _, hint) = Self::all_bufs(b);
        (first, hint)
    }
}

impl Lane for i16 {
    fn all_bufs(b: &mut MsgBufs) -> (&mut [i16; BATCH], &mut Vec<[i16; BATCH]>, &mut [usize; 6]) {
        (&mut b.w16.0, &mut b.w16.1, &mut b.hint)
    }
}

impl Lane for i32 {
    fn all_bufs(b: &mut MsgBufs) -> (&mut [i32; BATCH], &mut Vec<[i32; BATCH]>, &mut [usize; 6]) {
        (&mut b.w32.0, &mut b.w32.1, &mut b.hint)
    }
}

/// The working space of [`run_batch`], taken once for a chunk of agents rather than at
/// each call (a call may run a few agents), and kept by its thread between steps
/// ([`Kept`]): the two operands, whether each agent's result stands (all true between
/// instructions), and the messages read with the post office's hints (see
/// [`Lattice::inbox_run`]; a hint is checked before it is used, so one kept from another
/// step only costs a search).
pub(super) struct CalcBufs {
    pub(super) x: [i32; BATCH],
    pub(super) y: [i32; BATCH],
    pub(super) ok: [bool; BATCH],
    pub(super) msgs: MsgBufs,
}

impl Scratch for CalcBufs {
    fn kept() -> &'static std::thread::LocalKey<std::cell::Cell<Option<Box<CalcBufs>>>> {
        thread_local! {
            static KEPT: std::cell::Cell<Option<Box<CalcBufs>>> = const { std::cell::Cell::new(None) };
        }
        &KEPT
    }

    fn made() -> Box<CalcBufs> {
        Box::new(CalcBufs {
            x: [0; BATCH],
            y: [0; BATCH],
            ok: [true; BATCH],
            msgs: MsgBufs {
                w16: ([0; BATCH], Vec::new()),
                w32: ([0; BATCH], Vec::new()),
                hint: [0; 6],
            },
        })
    }
}

/// `Cxx = Cxx + v` ([`Plan::masked_add`]) for the agents of the chunk whose entry of the
/// selection (`one`, the chunk's part) is one of the rules `r`, in one pass over the
/// column without a branch per agent (agents that execute them scattered among others
/// would make runs of one or two for [`run_batch`]). Returns false, having changed nothing,
/// when a result would saturate (the runs then make the records).
pub(super) fn masked_add(
    lat: &Lattice,
    ch: &mut CalcChunk<'_>,
    one: &[u32],
    (r, c, v): ([u32; 4], u8, i32),
) -> bool {
    // (One rule, the common case, tested alone: a test against four took a tenth of
    // B2's stepping time more.)
    let one_rule = move |e: u32| e == r[0];
    let any = move |e: u32| (e == r[0]) | (e == r[1]) | (e == r[2]) | (e == r[3]);
    match (lat.width(), r.iter().all(|&q| q == r[0])) {
        (Width::W16, true) => masked_add_in::<i16>(lat, ch, one, (one_rule, c, v)),
        (Width::W16, false) => masked_add_in::<i16>(lat, ch, one, (any, c, v)),
        (Width::W32, true) => masked_add_in::<i32>(lat, ch, one, (one_rule, c, v)),
        (Width::W32, false) => masked_add_in::<i32>(lat, ch, one, (any, c, v)),
    }
}

/// [`masked_add`] in the lattice's width, for the entries `adds` takes.
fn masked_add_in<V: Lane>(
    lat: &Lattice,
    ch: &mut CalcChunk<'_>,
    one: &[u32],
    (adds, c, v): (impl Fn(u32) -> bool + Copy, u8, i32),
) -> bool {
    let col = V::of_cut_mut(&mut ch.counters[lat.counter_col[c as usize] as usize]);
    // `t + v` stays in range exactly when `t` is within `lo..=hi` (counters are always in
    // range, and so is `v`): compared in the column's own width, with `&` and `|` (not
    // `&&` and `||`: no branch per agent), so that the loop vectorises.
    let m = V::WIDTH.max() as i64;
    let bound = |b: i64| V::of(b.clamp(-m, m) as i32);
    let (lo, hi) = (bound(-m - v as i64), bound(m - v as i64));
    // Every agent's result checked and added (wrapping) in one pass; when one would
    // saturate, every add is taken back (wrapping back), and nothing has changed. (Checked
    // in a pass of its own before the adds, the column and the selection's entries were
    // read twice: B2 on one thread 1.02-1.03x the time.)
    let add = |t: &mut V, e: u32, by: i32| {
        let x: i32 = (*t).into();
        *t = V::of(x.wrapping_add(adds(e) as i32 * by));
    };
    let mut all = true;
    for (t, &e) in col.iter_mut().zip(one) {
        all &= !adds(e) | ((*t >= lo) & (*t <= hi));
        add(t, e, v);
    }
    if !all {
        for (t, &e) in col.iter_mut().zip(one) {
            add(t, e, v.wrapping_neg());
        }
    }
    all
}

/// Runs rule `r`'s calculations and sends for the chunk's agents `range` (all of which
/// execute `r` alone), one instruction at a time over up to [`BATCH`] agents, in the
/// lattice's width. The results, and the issues (in agent order, then instruction order),
/// are those of [`run_post`] run for each agent in turn: an agent's instructions touch only
/// its own counters and outbox.
pub(super) fn run_batch(
    prog: &Program,
    rule: (u32, &[PostStep]),
    lat: &Lattice,
    chb: (&mut CalcChunk<'_>, &mut CalcBufs),
    range: std::ops::Range<usize>,
    issues: &mut Vec<(u32, u32, CalcIssue)>,
) {
    match lat.width() {
        Width::W16 => run_batch_in::<i16>(prog, rule, lat, chb, range, issues),
        Width::W32 => run_batch_in::<i32>(prog, rule, lat, chb, range, issues),
    }
}

fn run_batch_in<V: Lane>(
    prog: &Program,
    (r, post): (u32, &[PostStep]),
    lat: &Lattice,
    (ch, bufs): (&mut CalcChunk<'_>, &mut CalcBufs),
    range: std::ops::Range<usize>,
    issues: &mut Vec<(u32, u32, CalcIssue)>,
) {
    let mut found: Vec<(u32, CalcIssue)> = Vec::new();
    let CalcBufs { x, y, ok, msgs } = bufs;
    let max = V::WIDTH.max();
    let mut start = range.start;
    while start < range.end {
        let len = (range.end - start).min(BATCH);
        let ks = start..start + len;
        let first = ch.lo + start;
        for &step in post {
            match step {
                // A chain of in-place max (or min) with messages: one pass over the counter.
                PostStep::Chain(chain) => {
                    chain_in_place::<V>(lat, ch, (&chain, ks.clone()), msgs);
                }
                PostStep::Send { dir, text } => {
                    send_text(ch, lat, (dir, prog.texts[text as usize]), ks.clone())
                }
                PostStep::Calc { target, op, a, b }
                    if fast_calc::<V>(lat, ch, ks.clone(), first, (target, op, a, b), msgs) => {}
                PostStep::Calc { target, op, a, b } => {
                    let mut load = |v: ColVal, into: &mut [i32], ch: &CalcChunk<'_>| match v {
                        ColVal::Lit(c) => into.fill(c),
                        ColVal::Counter(c) => {
                            let col =
                                ch.counters[lat.counter_col[c as usize] as usize].cut(ks.clone());
                            for (t, &s) in into.iter_mut().zip(V::of_cut(col)) {
                                *t = s.into();
                            }
                        }
                        ColVal::Msg { dir, slot } => {
                            let (out, hint) = V::bufs(msgs);
                            let src = lat.inbox_run(first, (dir, slot), &mut out[..len], hint);
                            for (t, &s) in into.iter_mut().zip(src) {
                                *t = s.into();
                            }
                        }
                    };
                    load(a, &mut x[..len], ch);
                    load(b, &mut y[..len], ch);
                    let (xs, ys) = (&mut x[..len], &y[..len]);
                    let mut all_ok = true;
                    // 16-bit operands: i32 holds every sum, difference and product. 32-bit
                    // ones: those are made exactly in i64 and saturated here.
                    let exact = V::WIDTH == Width::W32
                        && matches!(op, CalcOp::Add | CalcOp::Sub | CalcOp::Mul);
                    match op {
                        _ if exact => {
                            for (j, (p, &q)) in xs.iter_mut().zip(ys).enumerate() {
                                let (p64, q64) = (*p as i64, q as i64);
                                let e = match op {
                                    CalcOp::Add => p64 + q64,
                                    CalcOp::Sub => p64 - q64,
                                    _ => p64 * q64,
                                };
                                *p = V::WIDTH.saturate(e);
                                if *p as i64 != e {
                                    found.push((
                                        (first + j) as u32,
                                        CalcIssue::Saturated { exact: e },
                                    ));
                                }
                            }
                        }
                        CalcOp::Max => xs.iter_mut().zip(ys).for_each(|(p, &q)| *p = (*p).max(q)),
                        CalcOp::Min => xs.iter_mut().zip(ys).for_each(|(p, &q)| *p = (*p).min(q)),
                        CalcOp::Add => xs.iter_mut().zip(ys).for_each(|(p, &q)| *p += q),
                        CalcOp::Sub => xs.iter_mut().zip(ys).for_each(|(p, &q)| *p -= q),
                        CalcOp::Mul => xs.iter_mut().zip(ys).for_each(|(p, &q)| *p *= q),
                        CalcOp::Div | CalcOp::Mod => {
                            for (j, (p, &q)) in xs.iter_mut().zip(ys).enumerate() {
                                ok[j] = q != 0;
                                all_ok &= q != 0;
                                if q == 0 {
                                    found.push(((first + j) as u32, CalcIssue::DivisionByZero));
                                } else if op == CalcOp::Div {
                                    // (-max / -1 is max: no overflow within the width.)
                                    *p /= q;
                                } else {
                                    *p %= q;
                                }
                            }
                        }
                    }
                    // Saturation of 16-bit results (32-bit ones are within the width).
                    if !exact && xs.iter().any(|&v| !(-max..=max).contains(&v)) {
                        for (j, v) in xs.iter_mut().enumerate() {
                            if ok[j] && !(-max..=max).contains(v) {
                                found.push((
                                    (first + j) as u32,
                                    CalcIssue::Saturated { exact: *v as i64 },
                                ));
                                *v = (*v).clamp(-max, max);
                            }
                        }
                    }
                    store_batch::<V>(
                        ch,
                        lat,
                        target,
                        ks.clone(),
                        (&x[..len], &mut ok[..], all_ok),
                    );
                }
            }
        }
        // Issues in agent order, then instruction order (the sort is stable).
        found.sort_by_key(|f| f.0);
        issues.extend(found.drain(..).map(|(a, i)| (a, r, i)));
        start += len;
    }
}

/// Sends text `t` towards `dir` (or all directions) from agents `ks` of a chunk.
#[inline]
fn send_text(
    ch: &mut CalcChunk<'_>,
    lat: &Lattice,
    (dir, t): (u8, [u8; 5]),
    ks: std::ops::Range<usize>,
) {
    let nd = lat.dim.dirs();
    for d in CalcChunk::text_dirs(lat, dir) {
        for k in ks.clone() {
            ch.out_text[k * nd + d] = t;
            ch.out_text_bits[k] |= 1 << d;
        }
    }
}

/// Stores the results `xs` (of the width) of one calculation over agents `ks` of a chunk
/// into its target (a counter, or an outbox column with its bits); where `all_ok` is
/// false, only for the agents whose `ok` is set (the others divided by zero), and `ok` is
/// set again.
#[inline]
fn store_batch<V: Lane>(
    ch: &mut CalcChunk<'_>,
    lat: &Lattice,
    target: Target,
    ks: std::ops::Range<usize>,
    (xs, ok, all_ok): (&[i32], &mut [bool], bool),
) {
    let (start, len) = (ks.start, ks.len());
    let keep = |j: usize| all_ok || ok[j];
    match target {
        Target::Counter(c) => {
            let col = &mut V::of_cut_mut(&mut ch.counters[lat.counter_col[c as usize] as usize])
                [ks.clone()];
            if all_ok {
                col.iter_mut().zip(xs).for_each(|(t, &v)| *t = V::of(v));
            } else {
                for (j, (t, &v)) in col.iter_mut().zip(xs).enumerate() {
                    if keep(j) {
                        *t = V::of(v);
                    }
                }
            }
        }
        Target::Msg { dir, slot } => {
            let cols = ch.send_cols(lat, dir, slot);
            for &c in cols.clear() {
                let bits = &mut *ch.out_has[c];
                if all_ok {
                    clear_bits(bits, ks.clone());
                } else {
                    for k in ks.clone().filter(|&k| keep(k - start)) {
                        bits[k >> 6] &= !(1 << (k & 63));
                    }
                }
            }
            for &c in cols.write() {
                let col = &mut V::of_cut_mut(&mut ch.out_num[c])[ks.clone()];
                let bits = &mut *ch.out_has[c];
                if all_ok {
                    col.iter_mut().zip(xs).for_each(|(t, &v)| *t = V::of(v));
                    set_bits(bits, ks.clone());
                } else {
                    for (j, (t, &v)) in col.iter_mut().zip(xs).enumerate() {
                        if keep(j) {
                            *t = V::of(v);
                            let k = start + j;
                            bits[k >> 6] |= 1 << (k & 63);
                        }
                    }
                }
            }
        }
    }
    if !all_ok {
        ok[..len].fill(true);
    }
}

/// The counters as they were at the start of the calculations, for external counters:
/// every column copied, or, when only the agents of a list calculate (the others' counters
/// do not change in the phase), the columns of those agents alone (in list order).
pub(super) enum Snapshot {
    None,
    All(Vec<Column>),
    Listed(Vec<u32>, Vec<Column>),
}

impl Snapshot {
    /// Counter column `c` of agent `b` at the start of the phase (`now`: its value as it
    /// is, for an agent the snapshot does not hold, which has not changed).
    #[inline]
    pub(super) fn counter(&self, c: usize, b: u32, now: impl Fn() -> i32) -> i32 {
        match self {
            Snapshot::All(cols) => cols[c].get(b as usize),
            Snapshot::Listed(list, cols) => match list.binary_search(&b) {
                Ok(k) => cols[c].get(k),
                Err(_) => now(),
            },
            Snapshot::None => now(),
        }
    }
}

/// What the calculations of agent `a` (the `k`-th of its chunk) read and write: the
/// lattice for positions and inboxes, and the chunk's own counters and outbox.
pub(super) struct CalcCtx<'a, 'c, 'd> {
    pub(super) lat: &'a Lattice,
    pub(super) a: usize,
    pub(super) k: usize,
    pub(super) ch: &'c mut CalcChunk<'d>,
    pub(super) snapshot: &'a Snapshot,
    pub(super) issues: Vec<(usize, CalcIssue)>,
}

impl CalcEnv for CalcCtx<'_, '_, '_> {
    fn counter(&self, i: u8) -> i32 {
        self.ch.counter(self.lat, self.k, i)
    }
    fn set_counter(&mut self, i: u8, v: i32) {
        let c = self.lat.counter_col[i as usize] as usize;
        self.ch.counters[c].set(self.k, v);
    }
    fn inbox_num(&self, dir: u8, slot: u8) -> i32 {
        self.lat.inbox(self.a as u32, dir, slot)
    }
    fn external(&self, off: [i32; 2], counter: u8) -> Option<i32> {
        match self.lat.cell_at(self.lat.pos[self.a], [off[0], off[1], 0]) {
            Cell::Agent(b) => Some(match self.lat.counter_col[counter as usize] {
                NO_COL => 0,
                // (With a list, the phase is one chunk of all agents: `ch` holds them.)
                c => (self.snapshot).counter(c as usize, b, || {
                    self.ch.counters[c as usize].get(b as usize - self.ch.lo)
                }),
            }),
            _ => None,
        }
    }
    fn send_num(&mut self, dir: u8, slot: u8, v: i32) {
        let k = self.k;
        let cols = self.ch.send_cols(self.lat, dir, slot);
        for &c in cols.clear() {
            self.ch.out_has[c][k >> 6] &= !(1 << (k & 63));
        }
        for &c in cols.write() {
            self.ch.out_num[c].set(k, v);
            self.ch.out_has[c][k >> 6] |= 1 << (k & 63);
        }
    }
    fn send_text(&mut self, dir: u8, text: [u8; 5]) {
        let nd = self.lat.dim.dirs();
        for d in CalcChunk::text_dirs(self.lat, dir) {
            self.ch.out_text[self.k * nd + d] = text;
            self.ch.out_text_bits[self.k] |= 1 << d;
        }
    }
    fn issue(&mut self, pc: usize, issue: CalcIssue) {
        self.issues.push((pc, issue));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use latticesim_compiler::{check, compile, Input};
    use latticesim_vm::model::Dim;

    /// Working space given back is taken again by the same thread (what it holds stays),
    /// another thread makes its own, and space dropped by a panic is not given back.
    #[test]
    fn working_space_is_kept_per_thread() {
        let first = {
            let mut b = Kept::<PreBufs>::take();
            b.x[0] = 7;
            &b.x[0] as *const i32
        };
        let again = Kept::<PreBufs>::take();
        assert_eq!((&again.x[0] as *const i32, again.x[0]), (first, 7));
        std::thread::spawn(|| assert_eq!(Kept::<PreBufs>::take().x[0], 0))
            .join()
            .unwrap();
        drop(again);
        let _ = std::panic::catch_unwind(|| {
            let mut b = Kept::<CalcBufs>::take();
            b.ok[0] = false;
            panic!("in a run");
        });
        assert!(Kept::<CalcBufs>::take().ok[0], "made anew after a panic");
    }

    /// The column programs of `rules`' rules (2D), by rule.
    fn columns(rules: &str) -> Vec<Option<ColumnPre>> {
        let input = Input {
            name: "rules.txt",
            bytes: rules.as_bytes(),
        };
        let c = check(input, None, Some(Dim::Two));
        assert_eq!(c.errors(), 0, "{:#?}", c.diags);
        let prog = compile(c.rules.as_ref().expect("rules")).expect("a program");
        let pre =
            |r: &latticesim_vm::RuleInfo| &prog.code[r.pre.start as usize..r.pre.end as usize];
        (prog.rules.iter())
            .map(|r| column_pre(&prog, pre(r), r.state_filter))
            .collect()
    }

    /// A precondition's test of the agent's state against its rule's state filter is true
    /// for every agent that evaluates the rule: it is left out, with the conjunction that
    /// takes it, wherever it stands.
    #[test]
    fn the_state_filter_is_not_tested_again() {
        let pres = columns(
            "rest\n1\nSREST0 >C00 0000\nC00 - C00 0001\n\n\
             walk\n1\nSWALK0 N**0* >C01 0000\nP1,0\n\n\
             late\n1\nN**0* SLATE0\nP1,0\n\n\
             only\n1\nSONLY0\nP1,0\n",
        );
        let gt = |c: u8| PreStep::Cmp {
            op: CmpOp::Gt,
            a: ColVal::Counter(c),
            b: ColVal::Lit(0),
        };
        let east = PreStep::Nbr {
            mask: 1 << 2,
            want: 0,
        };
        assert_eq!(pres[0].as_deref(), Some(&[gt(0)][..]));
        assert_eq!(pres[1].as_deref(), Some(&[east, gt(1), PreStep::And][..]));
        assert_eq!(pres[2].as_deref(), Some(&[east][..]));
        // A precondition of the filter alone is true.
        assert_eq!(pres[3].as_deref(), Some(&[PreStep::True][..]));
    }
}
