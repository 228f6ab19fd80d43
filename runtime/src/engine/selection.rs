//! The selection: the rules each agent executes in a step, one entry per agent, as the
//! rule dispatch, the selection phase, the actions and the calculations read it.

/// The rules each agent executes in a step: one entry per agent, either [`NO_RULE`], a
/// rule, or [`MANY`] with an index into `starts`/`many` (in file order).
#[derive(Default)]
pub(super) struct Selection {
    pub(super) one: Vec<u32>,
    pub(super) starts: Vec<u32>,
    pub(super) many: Vec<u32>,
    /// When `listed`: every agent that executes a rule, in id order (every other entry
    /// is [`NO_RULE`]), so that the phases after the selection visit only these.
    pub(super) list: Vec<u32>,
    pub(super) listed: bool,
    /// Not `listed`, but `list` holds every agent that executes a rule all the same (the
    /// selection over all agents found them while it counted, and they were few): the
    /// step lists them without looking for them ([`Selection::make_list`]). Cleared at
    /// the start of every selection.
    pub(super) found: bool,
    /// Agents whose entry a hop replaced in this step's actions (set to their new state's
    /// rule for the next step: see [`Dispatch::set_state_at_once`]), with the rule they
    /// executed, in agent order; cleared when the actions begin. (Hops of the tight loop
    /// `hop_run` are not kept: it runs only when every rule only sets the state, so no
    /// record of the actions names such an agent, and records of calculations name
    /// agents that calculate, which never hop.)
    pub(super) replaced: Vec<(u32, u32)>,
    /// Every entry is [`NO_RULE`]: the column was reset and no selection made since (the
    /// selection over all agents then writes only the entries of agents that execute a
    /// rule).
    pub(super) fresh: bool,
}

pub(super) const NO_RULE: u32 = u32::MAX;

pub(super) const MANY: u32 = 1 << 31;

impl Selection {
    /// The rules agent `a` executes, in file order.
    #[inline]
    pub(super) fn of(&self, a: usize) -> &[u32] {
        match self.one[a] {
            NO_RULE => &[],
            v if v & MANY == 0 => std::slice::from_ref(&self.one[a]),
            v => {
                let k = (v & !MANY) as usize;
                &self.many[self.starts[k] as usize..self.starts[k + 1] as usize]
            }
        }
    }

    /// The rules agent `a` executed in this step (whose entry a hop may have replaced),
    /// none for an agent the selection does not hold.
    pub(super) fn executed(&self, a: usize) -> &[u32] {
        if let Ok(k) = (self.replaced).binary_search_by_key(&(a as u32), |h| h.0) {
            return std::slice::from_ref(&self.replaced[k].1);
        }
        if a < self.one.len() {
            self.of(a)
        } else {
            &[]
        }
    }

    /// Sets agent `a`'s rules (agents must be set in increasing order for several rules).
    pub(super) fn set(&mut self, a: usize, rules: &[u32]) {
        self.one[a] = match rules {
            [] => NO_RULE,
            [r] => *r,
            _ => {
                if self.starts.is_empty() {
                    self.starts.push(0);
                }
                self.many.extend_from_slice(rules);
                self.starts.push(self.many.len() as u32);
                MANY | (self.starts.len() - 2) as u32
            }
        };
    }

    pub(super) fn reset(&mut self, n: usize) {
        self.one.clear();
        self.one.resize(n, NO_RULE);
        self.starts.clear();
        self.many.clear();
        self.listed = false;
        self.found = false;
        self.fresh = true;
    }

    /// Lists the agents that execute a rule (`listed`), from the entries.
    pub(super) fn make_list(&mut self) {
        self.listed = true;
        if std::mem::take(&mut self.found) {
            return;
        }
        self.list.clear();
        let one = &self.one;
        self.list
            .extend((0..one.len() as u32).filter(|&a| one[a as usize] != NO_RULE));
    }

    /// Adds to `counts` how many agents of `list` (a part of the list) execute each rule;
    /// returns how many execute any.
    pub(super) fn count_listed(&self, list: &[u32], counts: &mut [u64]) -> u64 {
        count_runs_of(list.iter().map(|&a| self.one[a as usize]), counts)
    }
}

/// Adds to `counts` how many agents of the selection `one` execute each single rule,
/// counting runs of equal entries at once, and returns how many execute any rule.
pub(super) fn count_runs(one: &[u32], counts: &mut [u64]) -> u64 {
    count_runs_of(one.iter().copied(), counts)
}

/// [`count_runs`] of the selection's `entries`, in any order: a run of equal entries (the
/// agents of a list executing the same rule, in id order) is counted at once (a count per
/// agent in memory waited for the last one's store: 4 ns an agent for 1,000 walkers).
fn count_runs_of(entries: impl Iterator<Item = u32>, counts: &mut [u64]) -> u64 {
    let mut active = 0;
    let mut run = (NO_RULE, 0u64);
    for v in entries.chain([NO_RULE]) {
        if v != run.0 {
            if run.0 != NO_RULE {
                active += run.1;
            }
            if run.0 & MANY == 0 {
                counts[run.0 as usize] += run.1;
            }
            run = (v, 0);
        }
        run.1 += 1;
    }
    active
}
