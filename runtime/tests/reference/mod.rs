//! The reference evaluator: a deliberately simple, obviously correct implementation of the
//! step of SEMANTICS.md section 5, for the tests only. It walks the checked program's
//! condition trees (no bytecode), keeps agents as a plain list and finds them by scanning
//! it, and resolves priorities by recomputing everything until nothing changes. It shares
//! no code with the engine beyond the checked-program types.

use latticesim_compiler::checked::{
    Action, AttachLetter, CalcOp, CheckedRules, CmpOp, Cond, Config, Coord, Dim, Dir, Offset,
    Operand, Rule, Target, TextPat, Val, Width,
};
use std::collections::BTreeMap;

#[derive(Clone, Debug, PartialEq)]
pub struct Agent {
    pub pos: [i32; 3],
    pub state: [u8; 5],
    pub attach: u8,
    pub counters: Vec<i32>,
    pub inbox_num: Vec<Vec<i32>>,
    pub inbox_text: Vec<Option<[u8; 5]>>,
}

#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Rec {
    pub step: u64,
    pub kind: &'static str,
    pub agents: Vec<u32>,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct RefStats {
    pub steps: u64,
    pub firings: Vec<u64>,
    pub moves: u64,
    pub carried: u64,
    pub swaps: u64,
    pub sent: u64,
    pub delivered: u64,
    pub dropped: u64,
    pub records: BTreeMap<&'static str, u64>,
}

/// What an agent's rules of one step ask for in conflict (SEMANTICS 5.2).
#[derive(Clone, Copy, Default)]
struct Judged {
    move_bad: bool,
    swap_bad: bool,
    /// Directions with different letters.
    dirs: u8,
    /// State positions set differently.
    chars: u8,
}

pub struct World {
    pub dim: Dim,
    pub universe: Option<[(i32, i32); 3]>,
    pub agents: Vec<Agent>,
    pub prog: CheckedRules,
    pub stats: RefStats,
    pub messages_first: bool,
    pub static_first: bool,
    #[allow(clippy::type_complexity)]
    pending: Option<(Vec<Vec<Vec<Option<i32>>>>, Vec<Vec<Option<[u8; 5]>>>)>,
    /// Who stands where: made again after the moves, updated by each swap (the only
    /// places positions change).
    cells: std::collections::HashMap<[i32; 3], usize>,
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum T3 {
    F,
    T,
    U,
}

fn and3(a: T3, b: T3) -> T3 {
    if a == T3::F || b == T3::F {
        T3::F
    } else if a == T3::U || b == T3::U {
        T3::U
    } else {
        T3::T
    }
}

fn not3(a: T3) -> T3 {
    match a {
        T3::F => T3::T,
        T3::T => T3::F,
        T3::U => T3::U,
    }
}

fn b3(b: bool) -> T3 {
    if b {
        T3::T
    } else {
        T3::F
    }
}

fn matches(p: &TextPat, t: &[u8; 5]) -> bool {
    (0..5).all(|i| p[i].is_none() || p[i] == Some(t[i]))
}

/// Priority status of every agent during selection.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Status {
    Open(u16),
    Fixed(u16),
}

impl World {
    pub fn new(
        prog: CheckedRules,
        cfg: &Config,
        messages_first: bool,
        static_first: bool,
    ) -> World {
        let d = cfg.dim;
        let agents = cfg
            .agents
            .iter()
            .map(|a| {
                let mut counters = vec![0i32; d.counters()];
                for &(c, v) in &a.counters {
                    counters[c as usize] = v;
                }
                Agent {
                    pos: a.pos,
                    state: a.state,
                    attach: a.attach,
                    counters,
                    inbox_num: vec![vec![0; d.slots()]; d.dirs()],
                    inbox_text: vec![None; d.dirs()],
                }
            })
            .collect();
        let k = prog.rules.len();
        let mut w = World {
            dim: d,
            universe: cfg.universe,
            agents,
            prog,
            stats: RefStats {
                firings: vec![0; k],
                ..Default::default()
            },
            messages_first,
            static_first,
            pending: None,
            cells: Default::default(),
        };
        w.reindex();
        w
    }

    fn reindex(&mut self) {
        self.cells = self
            .agents
            .iter()
            .enumerate()
            .map(|(i, a)| (a.pos, i))
            .collect();
    }

    fn inside(&self, p: [i64; 3]) -> bool {
        if p.iter()
            .any(|&c| c < i32::MIN as i64 || c > i32::MAX as i64)
        {
            return false;
        }
        match self.universe {
            None => true,
            Some(b) => {
                (0..self.dim.coords()).all(|i| p[i] >= b[i].0 as i64 && p[i] <= b[i].1 as i64)
            }
        }
    }

    /// None: blocked; Some(None): empty; Some(Some(id)): an agent.
    fn look(&self, from: [i32; 3], off: [i32; 3]) -> Option<Option<usize>> {
        let p = [
            from[0] as i64 + off[0] as i64,
            from[1] as i64 + off[1] as i64,
            from[2] as i64 + off[2] as i64,
        ];
        if !self.inside(p) {
            return None;
        }
        let p = [p[0] as i32, p[1] as i32, p[2] as i32];
        Some(self.cells.get(&p).copied())
    }

    fn offset(&self, a: usize, o: &Offset) -> [i32; 3] {
        let c = |c: &Coord| match c {
            Coord::Lit(v) => *v,
            Coord::Counter(i) => self.agents[a].counters[*i as usize],
        };
        [c(&o[0]), c(&o[1]), c(&o[2])]
    }

    fn value(&self, a: usize, v: &Val, any_dir: usize) -> i32 {
        match v {
            Val::Lit(x) => *x,
            Val::Counter(c) => self.agents[a].counters[*c as usize],
            Val::Msg { dir: Some(d), slot } => self.agents[a].inbox_num[d.index()][*slot as usize],
            Val::Msg { dir: None, slot } => self.agents[a].inbox_num[any_dir][*slot as usize],
        }
    }

    /// Is agent `b`'s priority smaller (strict) or smaller or equal than `p`?
    fn prio_cmp(&self, status: Option<&[Status]>, b: Option<usize>, p: u16, strict: bool) -> T3 {
        let Some(status) = status else { return T3::U };
        let Some(b) = b else { return T3::T };
        match status[b] {
            Status::Fixed(f) => b3(if strict { f < p } else { f <= p }),
            Status::Open(c) => {
                if !strict || c < p {
                    T3::T
                } else {
                    T3::U
                }
            }
        }
    }

    fn eval(&self, a: usize, c: &Cond, p: u16, status: Option<&[Status]>) -> T3 {
        let me = &self.agents[a];
        let nd = self.dim.dirs();
        match c {
            Cond::And(cs) => cs
                .iter()
                .fold(T3::T, |acc, c| and3(acc, self.eval(a, c, p, status))),
            Cond::Not(c) => not3(self.eval(a, c, p, status)),
            Cond::Neighbors(bp) => b3((0..nd).filter(|d| bp.mask & (1 << d) != 0).all(|d| {
                let want = bp.want & (1 << d) != 0;
                match self.look(me.pos, Dir::ALL[d].offset()) {
                    None => false,
                    Some(x) => x.is_some() == want,
                }
            })),
            Cond::Attached(bp) => b3(me.attach & bp.mask == bp.want & bp.mask),
            Cond::Priorities { strict, leq } => {
                if status.is_none() {
                    return T3::U;
                }
                let mut acc = T3::T;
                for d in 0..nd {
                    if (strict | leq) & (1 << d) == 0 {
                        continue;
                    }
                    let b = self.look(me.pos, Dir::ALL[d].offset()).flatten();
                    acc = and3(acc, self.prio_cmp(status, b, p, strict & (1 << d) != 0));
                }
                acc
            }
            Cond::State(pat) => b3(matches(pat, &me.state)),
            Cond::Message { dir: Some(d), pat } => {
                b3(me.inbox_text[d.index()].is_some_and(|t| matches(pat, &t)))
            }
            Cond::Message { dir: None, pat } => b3(me
                .inbox_text
                .iter()
                .any(|t| t.is_some_and(|t| matches(pat, &t)))),
            Cond::Empty(o) => b3(self.look(me.pos, self.offset(a, o)) == Some(None)),
            Cond::Filled(o) => b3(matches!(
                self.look(me.pos, self.offset(a, o)),
                Some(Some(_))
            )),
            Cond::Less(o) | Cond::LessEq(o) => {
                if status.is_none() {
                    return T3::U;
                }
                match self.look(me.pos, self.offset(a, o)) {
                    Some(Some(b)) => self.prio_cmp(status, Some(b), p, matches!(c, Cond::Less(_))),
                    _ => T3::F,
                }
            }
            Cond::RemoteState(o, pat) => b3(match self.look(me.pos, self.offset(a, o)) {
                Some(Some(b)) => matches(pat, &self.agents[b].state),
                _ => false,
            }),
            Cond::Compare(op, x, y) => {
                let any = matches!(x, Val::Msg { dir: None, .. })
                    || matches!(y, Val::Msg { dir: None, .. });
                let dirs = if any { 0..nd } else { 0..1 };
                b3(dirs
                    .into_iter()
                    .any(|d| cmp(*op, self.value(a, x, d), self.value(a, y, d))))
            }
            Cond::RemoteCompare {
                strict,
                offset,
                counter,
                rhs,
            } => b3(match self.look(me.pos, self.offset(a, offset)) {
                Some(Some(b)) => {
                    let v = self.agents[b].counters[*counter as usize];
                    let dirs = if matches!(rhs, Val::Msg { dir: None, .. }) {
                        0..nd
                    } else {
                        0..1
                    };
                    dirs.into_iter().any(|d| {
                        let r = self.value(a, rhs, d);
                        if *strict {
                            v < r
                        } else {
                            v <= r
                        }
                    })
                }
                _ => false,
            }),
        }
    }

    /// Selection: the rules each agent executes, in file order.
    fn select(&self, recs: &mut Vec<Rec>, step: u64) -> Vec<Vec<usize>> {
        let n = self.agents.len();
        let rules = &self.prog.rules;
        // valid[a]: (rule, value) with value T or U, in file order.
        let mut valid: Vec<Vec<(usize, T3)>> = vec![Vec::new(); n];
        for a in 0..n {
            for (r, rule) in rules.iter().enumerate() {
                let v = self.eval(a, &rule.pre, rule.priority, None);
                if v != T3::F {
                    valid[a].push((r, v));
                }
            }
        }
        let top = |vs: &Vec<(usize, T3)>, below: u16| top_below(rules, vs, below);
        let mut status: Vec<Status> = (0..n)
            .map(|a| match top(&valid[a], u16::MAX) {
                None => Status::Fixed(0),
                Some(p) => Status::Open(p),
            })
            .collect();
        loop {
            // The highest level with undecided work.
            let level = (0..n)
                .filter_map(|a| match status[a] {
                    Status::Open(p) if p > 0 => Some(p),
                    Status::Fixed(p)
                        if valid[a]
                            .iter()
                            .any(|(r, v)| rules[*r].priority == p && *v == T3::U) =>
                    {
                        Some(p)
                    }
                    _ => None,
                })
                .max();
            let Some(p) = level else { break };
            let at_level = |a: usize, status: &[Status]| {
                status[a] == Status::Open(p) || status[a] == Status::Fixed(p)
            };
            self.resolve_level(p, &mut valid, &mut status);
            // Circles.
            let mut circle = Vec::new();
            for a in 0..n {
                if !at_level(a, &status) {
                    continue;
                }
                let before = valid[a].len();
                valid[a].retain(|(r, v)| !(rules[*r].priority == p && *v == T3::U));
                if valid[a].len() != before {
                    circle.push(a as u32);
                    if status[a] == Status::Open(p) {
                        status[a] = match top(&valid[a], p) {
                            Some(q) => Status::Open(q),
                            None => Status::Fixed(0),
                        };
                    }
                }
            }
            if !circle.is_empty() {
                recs.push(Rec {
                    step,
                    kind: "circular-priority",
                    agents: circle,
                });
            }
        }
        (0..n)
            .map(|a| match status[a] {
                Status::Fixed(f) if f > 0 => valid[a]
                    .iter()
                    .filter(|(r, v)| rules[*r].priority == f && *v == T3::T)
                    .map(|(r, _)| *r)
                    .collect(),
                _ => Vec::new(),
            })
            .collect()
    }

    /// Level `p` resolved to its fixpoint (SEMANTICS section 5): the rules of its agents
    /// evaluated again, all at once, against the priorities fixed so far, and each open
    /// agent fixed at `p` or dropped to its next valid priority, until nothing changes.
    fn resolve_level(&self, p: u16, valid: &mut Vec<Vec<(usize, T3)>>, status: &mut [Status]) {
        let (n, rules) = (self.agents.len(), &self.prog.rules);
        let top = |vs: &Vec<(usize, T3)>, below: u16| top_below(rules, vs, below);
        let at_level = |a: usize, status: &[Status]| {
            status[a] == Status::Open(p) || status[a] == Status::Fixed(p)
        };
        loop {
            // Step 1, for all at once against the same status.
            let snapshot = status.to_vec();
            let mut changed = false;
            let mut new_valid = valid.clone();
            for a in 0..n {
                if !at_level(a, &snapshot) {
                    continue;
                }
                for (r, v) in new_valid[a].iter_mut() {
                    if rules[*r].priority == p && *v == T3::U {
                        let nv = self.eval(a, &rules[*r].pre, p, Some(&snapshot));
                        if nv != T3::U {
                            *v = nv;
                            changed = true;
                        }
                    }
                }
                new_valid[a].retain(|(_, v)| *v != T3::F);
            }
            *valid = new_valid;
            // Step 2.
            for a in 0..n {
                if !at_level(a, &snapshot) {
                    continue;
                }
                let has_true = valid[a]
                    .iter()
                    .any(|(r, v)| rules[*r].priority == p && *v == T3::T);
                let has_any = valid[a].iter().any(|(r, _)| rules[*r].priority == p);
                if status[a] == Status::Open(p) {
                    if has_true {
                        status[a] = Status::Fixed(p);
                        changed = true;
                    } else if !has_any {
                        status[a] = match top(&valid[a], p) {
                            Some(q) => Status::Open(q),
                            None => Status::Fixed(0),
                        };
                        changed = true;
                    }
                }
            }
            if !changed {
                break;
            }
        }
    }

    pub fn step(&mut self) -> (bool, Vec<Rec>) {
        let step = self.stats.steps + 1;
        let mut recs = Vec::new();
        let sel = self.select(&mut recs, step);
        for rs in &sel {
            for &r in rs {
                self.stats.firings[r] += 1;
            }
        }
        let quiet = sel.iter().all(|s| s.is_empty());
        if self.messages_first {
            self.calcs(&sel, &mut recs, step);
            self.deliver();
            self.all_actions(&sel, &mut recs, step);
        } else {
            self.all_actions(&sel, &mut recs, step);
            self.calcs(&sel, &mut recs, step);
            self.deliver();
        }
        for r in &recs {
            *self.stats.records.entry(r.kind).or_insert(0) += 1;
        }
        self.stats.steps += 1;
        (quiet, recs)
    }

    fn all_actions(&mut self, sel: &[Vec<usize>], recs: &mut Vec<Rec>, step: u64) {
        // Conflicts are judged over every rule an agent executes in the step, whatever
        // the pass its effects belong to.
        let judged = self.judge(sel, recs, step);
        if self.static_first {
            let moves = |r: &usize| {
                self.prog.rules[*r]
                    .post
                    .iter()
                    .any(|a| matches!(a, Action::Move(_) | Action::Swap(_)))
            };
            let still: Vec<Vec<usize>> = sel
                .iter()
                .map(|rs| rs.iter().copied().filter(|r| !moves(r)).collect())
                .collect();
            let mov: Vec<Vec<usize>> = sel
                .iter()
                .map(|rs| rs.iter().copied().filter(|r| moves(r)).collect())
                .collect();
            self.actions(&still, &judged, recs, step);
            self.actions(&mov, &judged, recs, step);
        } else {
            self.actions(sel, &judged, recs, step);
        }
    }

    /// What each agent's rules `sel` ask for: every distinct non-zero move, swap
    /// direction, letter per direction and character per position.
    #[allow(clippy::type_complexity)]
    fn asks(
        &self,
        a: usize,
        rules: &[usize],
    ) -> (
        Vec<[i32; 3]>,
        Vec<Dir>,
        Vec<Vec<AttachLetter>>,
        Vec<Vec<u8>>,
    ) {
        let nd = self.dim.dirs();
        let mut moves: Vec<[i32; 3]> = Vec::new();
        let mut swaps: Vec<Dir> = Vec::new();
        let mut lets: Vec<Vec<AttachLetter>> = vec![Vec::new(); nd];
        let mut chars: Vec<Vec<u8>> = vec![Vec::new(); 5];
        for &r in rules {
            for act in &self.prog.rules[r].post {
                match act {
                    Action::Move(o) => {
                        let o = self.offset(a, o);
                        if o != [0, 0, 0] && !moves.contains(&o) {
                            moves.push(o);
                        }
                    }
                    Action::Swap(d) if !swaps.contains(d) => swaps.push(*d),
                    Action::Attach(ls) => {
                        for d in 0..nd {
                            if !lets[d].contains(&ls[d]) {
                                lets[d].push(ls[d]);
                            }
                        }
                    }
                    Action::State(p) => {
                        for i in 0..5 {
                            if let Some(c) = p[i] {
                                if !chars[i].contains(&c) {
                                    chars[i].push(c);
                                }
                            }
                        }
                    }
                    _ => {}
                }
            }
        }
        (moves, swaps, lets, chars)
    }

    /// SEMANTICS 5.2's conflicts of each agent over all the rules it executes, with their
    /// records.
    fn judge(&self, sel: &[Vec<usize>], recs: &mut Vec<Rec>, step: u64) -> Vec<Judged> {
        let nd = self.dim.dirs();
        let mut out = vec![Judged::default(); sel.len()];
        for (a, rules) in sel.iter().enumerate() {
            let (moves, swaps, lets, chars) = self.asks(a, rules);
            let rec = |kind| Rec {
                step,
                kind,
                agents: vec![a as u32],
            };
            let j = &mut out[a];
            if moves.len() > 1 {
                j.move_bad = true;
                recs.push(rec("move-conflict"));
            }
            if swaps.len() > 1 {
                j.swap_bad = true;
                recs.push(rec("swap-conflict"));
            }
            for (d, l) in lets.iter().enumerate().take(nd) {
                if l.len() > 1 {
                    j.dirs |= 1 << d;
                    recs.push(rec("attach-conflict"));
                }
            }
            for (i, c) in chars.iter().enumerate() {
                if c.len() > 1 {
                    j.chars |= 1 << i;
                    recs.push(rec("state-conflict"));
                }
            }
        }
        out
    }

    fn actions(&mut self, sel: &[Vec<usize>], judged: &[Judged], recs: &mut Vec<Rec>, step: u64) {
        if sel.iter().all(|s| s.is_empty()) {
            return;
        }
        let asked = self.asked(sel, judged);
        // Partners before anything changes.
        let partner = self.partners();
        // 1. Detach.
        let rigid = self.rigid(&partner, &asked.letters);
        // 3. Move. Groups: flood fill over rigid bonds.
        self.move_groups(&asked, (&partner, &rigid), recs, step);
        // 4. Attach.
        self.attach_after(&asked.letters, &partner, rigid, recs, step);
        // 5. State.
        for a in 0..self.agents.len() {
            for i in 0..5 {
                if let Some(c) = asked.newstate[a][i] {
                    self.agents[a].state[i] = c;
                }
            }
        }
        // 6. Swaps. A request towards an agent that takes part in no swap is cancelled
        // (a swap-target record) but still counts when pairs are judged.
        self.swaps(&asked, recs, step);
    }

    /// What each agent's selected rules ask for, with the conflicts `judged` left out.
    fn asked(&self, sel: &[Vec<usize>], judged: &[Judged]) -> Asked {
        let n = self.agents.len();
        let nd = self.dim.dirs();
        let mut mv: Vec<Option<[i32; 3]>> = vec![None; n];
        let mut mv_bad = vec![false; n];
        let mut swap: Vec<Option<Dir>> = vec![None; n];
        // Agents that take part in no swap: their rules ask for different ones.
        let mut no_swap = vec![false; n];
        let mut letters: Vec<Vec<AttachLetter>> = vec![vec![AttachLetter::Keep; nd]; n];
        let mut newstate: Vec<[Option<u8>; 5]> = vec![[None; 5]; n];
        for a in 0..n {
            let (moves, swaps, lets, chars) = self.asks(a, &sel[a]);
            let j = judged[a];
            if j.move_bad {
                mv_bad[a] = !moves.is_empty();
            } else {
                mv[a] = moves.first().copied();
            }
            if j.swap_bad {
                no_swap[a] = true;
            } else {
                swap[a] = swaps.first().copied();
            }
            for d in 0..nd {
                if j.dirs & (1 << d) == 0 {
                    if let Some(&l) = lets[d].first() {
                        letters[a][d] = l;
                    }
                }
            }
            for i in 0..5 {
                if j.chars & (1 << i) == 0 {
                    newstate[a][i] = chars[i].first().copied();
                }
            }
        }
        Asked {
            mv,
            mv_bad,
            swap,
            no_swap,
            letters,
            newstate,
        }
    }

    /// Per agent and direction, its bonded partner.
    fn partners(&self) -> Vec<Vec<Option<usize>>> {
        let n = self.agents.len();
        let nd = self.dim.dirs();
        (0..n)
            .map(|a| {
                (0..nd)
                    .map(|d| {
                        if self.agents[a].attach & (1 << d) != 0 {
                            self.look(self.agents[a].pos, Dir::ALL[d].offset())
                                .flatten()
                        } else {
                            None
                        }
                    })
                    .collect()
            })
            .collect()
    }

    /// The bonds kept rigid through the moves.
    fn rigid(&self, partner: &[Vec<Option<usize>>], letters: &[Vec<AttachLetter>]) -> Vec<u8> {
        let n = self.agents.len();
        let nd = self.dim.dirs();
        let mut rigid = vec![0u8; n];
        for a in 0..n {
            for d in 0..nd {
                if let Some(b) = partner[a][d] {
                    let la = letters[a][d];
                    let lb = letters[b][Dir::ALL[d].opposite().index()];
                    let zero = la == AttachLetter::Detach || lb == AttachLetter::Detach;
                    let plus = la == AttachLetter::Rigid || lb == AttachLetter::Rigid;
                    if !zero && plus {
                        rigid[a] |= 1 << d;
                    }
                }
            }
        }
        rigid
    }

    /// The groups of rigid bonds moved whole, or not at all (with their records).
    fn move_groups(
        &mut self,
        asked: &Asked,
        (partner, rigid): (&[Vec<Option<usize>>], &[u8]),
        recs: &mut Vec<Rec>,
        step: u64,
    ) {
        let n = self.agents.len();
        let nd = self.dim.dirs();
        let (mv, mv_bad) = (&asked.mv, &asked.mv_bad);
        let mut group = vec![usize::MAX; n];
        for s in 0..n {
            if group[s] != usize::MAX {
                continue;
            }
            let mut stack = vec![s];
            group[s] = s;
            while let Some(x) = stack.pop() {
                for d in 0..nd {
                    if rigid[x] & (1 << d) != 0 {
                        if let Some(y) = partner[x][d] {
                            if group[y] == usize::MAX {
                                group[y] = s;
                                stack.push(y);
                            }
                        }
                    }
                }
            }
        }
        let mut goff: BTreeMap<usize, [i32; 3]> = BTreeMap::new();
        let groups: Vec<usize> = {
            let mut g: Vec<usize> = (0..n)
                .filter(|&a| mv[a].is_some() || mv_bad[a])
                .map(|a| group[a])
                .collect();
            g.sort();
            g.dedup();
            g
        };
        for &g in &groups {
            let ms: Vec<usize> = (0..n).filter(|&a| group[a] == g).collect();
            if ms.iter().any(|&m| mv_bad[m]) {
                continue;
            }
            let mut offs: Vec<[i32; 3]> = ms.iter().filter_map(|&m| mv[m]).collect();
            offs.sort();
            offs.dedup();
            if offs.len() > 1 {
                recs.push(Rec {
                    step,
                    kind: "group-conflict",
                    agents: ms.iter().map(|&m| m as u32).collect(),
                });
                continue;
            }
            let o = offs[0];
            let blocked = ms.iter().any(|&m| {
                let p = self.agents[m].pos;
                !self.inside([
                    p[0] as i64 + o[0] as i64,
                    p[1] as i64 + o[1] as i64,
                    p[2] as i64 + o[2] as i64,
                ])
            });
            if blocked {
                recs.push(Rec {
                    step,
                    kind: "move-blocked",
                    agents: ms.iter().map(|&m| m as u32).collect(),
                });
                continue;
            }
            goff.insert(g, o);
        }
        self.cancel_collisions(&mut goff, &group, recs, step);
        for a in 0..n {
            if let Some(o) = goff.get(&group[a]) {
                let p = self.agents[a].pos;
                self.agents[a].pos = [p[0] + o[0], p[1] + o[1], p[2] + o[2]];
                self.stats.moves += 1;
                if mv[a].is_none() {
                    self.stats.carried += 1;
                }
            }
        }
        self.reindex();
    }

    /// Groups whose targets meet another agent's (moving or not) are cancelled with a
    /// record, again until no two agents would share a cell.
    fn cancel_collisions(
        &self,
        goff: &mut BTreeMap<usize, [i32; 3]>,
        group: &[usize],
        recs: &mut Vec<Rec>,
        step: u64,
    ) {
        let n = self.agents.len();
        loop {
            let target = |a: usize, goff: &BTreeMap<usize, [i32; 3]>| {
                let p = self.agents[a].pos;
                match goff.get(&group[a]) {
                    Some(o) => [p[0] + o[0], p[1] + o[1], p[2] + o[2]],
                    None => p,
                }
            };
            // Every cell two agents would share, one of them moving: one record naming
            // all the agents that would be there, and every group moving there stays.
            let mut at: BTreeMap<[i32; 3], Vec<usize>> = BTreeMap::new();
            for a in 0..n {
                at.entry(target(a, goff)).or_default().push(a);
            }
            let events: Vec<Vec<usize>> = at
                .into_values()
                .filter(|v| v.len() > 1 && v.iter().any(|&a| goff.contains_key(&group[a])))
                .collect();
            if events.is_empty() {
                break;
            }
            for agents in events {
                for &a in &agents {
                    goff.remove(&group[a]);
                }
                recs.push(Rec {
                    step,
                    kind: "move-collision",
                    agents: agents.iter().map(|&a| a as u32).collect(),
                });
            }
        }
    }

    /// Bonds made after the moves.
    fn attach_after(
        &mut self,
        letters: &[Vec<AttachLetter>],
        partner: &[Vec<Option<usize>>],
        rigid: Vec<u8>,
        recs: &mut Vec<Rec>,
        step: u64,
    ) {
        let n = self.agents.len();
        let nd = self.dim.dirs();
        let mut att = rigid;
        for a in 0..n {
            for d in 0..nd {
                if att[a] & (1 << d) != 0 {
                    continue;
                }
                let Some(Some(b)) = self.look(self.agents[a].pos, Dir::ALL[d].offset()) else {
                    continue;
                };
                let la = letters[a][d];
                let decided = match la {
                    AttachLetter::Attach => true,
                    AttachLetter::Keep | AttachLetter::Rigid => partner[a][d] == Some(b),
                    AttachLetter::Detach => false,
                };
                let od = Dir::ALL[d].opposite().index();
                if decided && letters[b][od] == AttachLetter::Detach {
                    if la == AttachLetter::Attach {
                        recs.push(Rec {
                            step,
                            kind: "attach-refused",
                            agents: vec![a as u32, b as u32],
                        });
                    }
                } else if decided {
                    att[a] |= 1 << d;
                    att[b] |= 1 << od;
                }
            }
        }
        for a in 0..n {
            self.agents[a].attach = att[a];
        }
    }

    /// The swaps asked for, those sharing an agent or towards an agent that takes none
    /// cancelled.
    fn swaps(&mut self, asked: &Asked, recs: &mut Vec<Rec>, step: u64) {
        let n = self.agents.len();
        let nd = self.dim.dirs();
        let (swap, no_swap) = (&asked.swap, &asked.no_swap);
        let mut reqs: Vec<(usize, usize)> = Vec::new();
        let mut dead: Vec<(usize, usize)> = Vec::new();
        for a in 0..n {
            let Some(d) = swap[a] else { continue };
            match self.look(self.agents[a].pos, d.offset()) {
                Some(Some(b)) => {
                    let pair = (a.min(b), a.max(b));
                    if !reqs.contains(&pair) {
                        reqs.push(pair);
                    }
                    if no_swap[b] {
                        dead.push(pair);
                        recs.push(Rec {
                            step,
                            kind: "swap-target",
                            agents: vec![a as u32, b as u32],
                        });
                    }
                }
                _ => recs.push(Rec {
                    step,
                    kind: "swap-target",
                    agents: vec![a as u32],
                }),
            }
        }
        let shared = |p: &(usize, usize)| {
            reqs.iter()
                .any(|q| q != p && (q.0 == p.0 || q.0 == p.1 || q.1 == p.0 || q.1 == p.1))
        };
        let ok: Vec<(usize, usize)> = reqs
            .iter()
            .copied()
            .filter(|p| !shared(p) && !dead.contains(p))
            .collect();
        for p in reqs.iter().filter(|p| shared(p) && !dead.contains(p)) {
            recs.push(Rec {
                step,
                kind: "swap-shared",
                agents: vec![p.0 as u32, p.1 as u32],
            });
        }
        for (x, y) in ok {
            let bonded = (0..nd).any(|d| {
                self.agents[x].attach & (1 << d) != 0
                    && self.look(self.agents[x].pos, Dir::ALL[d].offset()) == Some(Some(y))
            });
            for s in [x, y] {
                for d in 0..nd {
                    if self.agents[s].attach & (1 << d) != 0 {
                        if let Some(Some(o)) = self.look(self.agents[s].pos, Dir::ALL[d].offset()) {
                            self.agents[o].attach &= !(1 << Dir::ALL[d].opposite().index());
                        }
                    }
                }
                self.agents[s].attach = 0;
            }
            let (px, py) = (self.agents[x].pos, self.agents[y].pos);
            self.agents[x].pos = py;
            self.agents[y].pos = px;
            self.cells.insert(py, x);
            self.cells.insert(px, y);
            if bonded {
                let d = Dir::from_offset([px[0] - py[0], px[1] - py[1], px[2] - py[2]])
                    .expect("neighbours");
                self.agents[x].attach |= 1 << d.index();
                self.agents[y].attach |= 1 << d.opposite().index();
            }
            self.stats.swaps += 1;
        }
    }

    fn calcs(&mut self, sel: &[Vec<usize>], recs: &mut Vec<Rec>, step: u64) {
        let n = self.agents.len();
        let nd = self.dim.dirs();
        let ns = self.dim.slots();
        let start = self.agents.clone();
        let mut out_num: Vec<Vec<Vec<Option<i32>>>> = vec![vec![vec![None; ns]; nd]; n];
        // The width of counters and messages: the paper's 16 bits or the 32-bit extension.
        let max: i64 = match self.prog.width {
            Width::W16 => 32767,
            Width::W32 => 2147483647,
        };
        let mut out_text: Vec<Vec<Option<[u8; 5]>>> = vec![vec![None; nd]; n];
        for a in 0..n {
            for &r in &sel[a] {
                for act in &self.prog.rules[r].post {
                    match act {
                        Action::Send { dir, text } => match dir {
                            Some(d) => out_text[a][d.index()] = Some(*text),
                            None => (0..nd).for_each(|d| out_text[a][d] = Some(*text)),
                        },
                        Action::Calc {
                            target,
                            op,
                            lhs,
                            rhs,
                        } => {
                            let read = |o: &Operand| -> Option<i32> {
                                match o {
                                    Operand::Val(Val::Lit(x)) => Some(*x),
                                    Operand::Val(Val::Counter(c)) => {
                                        Some(self.agents[a].counters[*c as usize])
                                    }
                                    Operand::Val(Val::Msg { dir, slot }) => Some(
                                        self.agents[a].inbox_num[dir.expect("checked").index()]
                                            [*slot as usize],
                                    ),
                                    Operand::External { x, y, counter } => {
                                        let c = |k: &Coord| match k {
                                            Coord::Lit(v) => *v,
                                            Coord::Counter(i) => {
                                                self.agents[a].counters[*i as usize]
                                            }
                                        };
                                        // In i64: with 32-bit counters an offset can
                                        // leave the i32 plane (no agent there).
                                        let p = start[a].pos;
                                        let far = |v: i32, d: i32| {
                                            i32::try_from(v as i64 + d as i64).ok()
                                        };
                                        let q = far(p[0], c(x)).zip(far(p[1], c(y)));
                                        q.and_then(|(qx, qy)| {
                                            start
                                                .iter()
                                                .find(|s| s.pos == [qx, qy, p[2]])
                                                .map(|s| s.counters[*counter as usize])
                                        })
                                    }
                                }
                            };
                            let (Some(x), Some(y)) = (read(lhs), read(rhs)) else {
                                recs.push(Rec {
                                    step,
                                    kind: "no-external-agent",
                                    agents: vec![a as u32],
                                });
                                continue;
                            };
                            let exact: i64 = match op {
                                CalcOp::Add => x as i64 + y as i64,
                                CalcOp::Sub => x as i64 - y as i64,
                                CalcOp::Mul => x as i64 * y as i64,
                                CalcOp::Div | CalcOp::Mod if y == 0 => {
                                    recs.push(Rec {
                                        step,
                                        kind: "division-by-zero",
                                        agents: vec![a as u32],
                                    });
                                    continue;
                                }
                                CalcOp::Div => x as i64 / y as i64,
                                CalcOp::Mod => x as i64 % y as i64,
                                CalcOp::Max => x.max(y) as i64,
                                CalcOp::Min => x.min(y) as i64,
                            };
                            let v = exact.clamp(-max, max);
                            if v != exact {
                                recs.push(Rec {
                                    step,
                                    kind: "saturation",
                                    agents: vec![a as u32],
                                });
                            }
                            let v = v as i32;
                            match target {
                                Target::Counter(c) => self.agents[a].counters[*c as usize] = v,
                                Target::Msg { dir: Some(d), slot } => {
                                    out_num[a][d.index()][*slot as usize] = Some(v)
                                }
                                Target::Msg { dir: None, slot } => {
                                    (0..nd).for_each(|d| out_num[a][d][*slot as usize] = Some(v))
                                }
                            }
                        }
                        _ => {}
                    }
                }
            }
        }
        self.pending = Some((out_num, out_text));
    }

    fn deliver(&mut self) {
        let Some((out_num, out_text)) = self.pending.take() else {
            return;
        };
        let n = self.agents.len();
        let nd = self.dim.dirs();
        let ns = self.dim.slots();
        for a in &mut self.agents {
            a.inbox_num = vec![vec![0; ns]; nd];
            a.inbox_text = vec![None; nd];
        }
        for a in 0..n {
            for d in 0..nd {
                let to = self
                    .look(self.agents[a].pos, Dir::ALL[d].offset())
                    .flatten();
                let od = Dir::ALL[d].opposite().index();
                for s in 0..ns {
                    if let Some(v) = out_num[a][d][s] {
                        self.stats.sent += 1;
                        match to {
                            Some(b) => {
                                self.agents[b].inbox_num[od][s] = v;
                                self.stats.delivered += 1;
                            }
                            None => self.stats.dropped += 1,
                        }
                    }
                }
                if let Some(t) = out_text[a][d] {
                    self.stats.sent += 1;
                    match to {
                        Some(b) => {
                            self.agents[b].inbox_text[od] = Some(t);
                            self.stats.delivered += 1;
                        }
                        None => self.stats.dropped += 1,
                    }
                }
            }
        }
    }
}

fn cmp(op: CmpOp, a: i32, b: i32) -> bool {
    match op {
        CmpOp::Lt => a < b,
        CmpOp::Gt => a > b,
        CmpOp::Eq => a == b,
    }
}

/// What each agent's rules ask of the actions, conflicts left out.
struct Asked {
    mv: Vec<Option<[i32; 3]>>,
    mv_bad: Vec<bool>,
    swap: Vec<Option<Dir>>,
    /// Agents that take part in no swap: their rules ask for different ones.
    no_swap: Vec<bool>,
    letters: Vec<Vec<AttachLetter>>,
    newstate: Vec<[Option<u8>; 5]>,
}

/// The highest priority below `below` among an agent's valid rules `vs`.
fn top_below(rules: &[Rule], vs: &[(usize, T3)], below: u16) -> Option<u16> {
    vs.iter()
        .map(|(r, _)| rules[*r].priority)
        .filter(|&p| p < below)
        .max()
}
