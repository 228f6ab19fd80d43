//! The post office: the messages of a step delivered into the inboxes the next step reads,
//! or, while no agent can move, left where their senders wrote them (`Pending` in
//! lattice.rs) and only counted; and the trace of the messages.

use super::*;

/// One chunk of recipients: `len` agents from `lo`, their numeric inbox columns, text
/// inboxes and text bits.
pub(super) struct InboxChunk<'a> {
    pub(super) lo: usize,
    pub(super) len: usize,
    pub(super) num: Vec<latticesim_vm::column::CutMut<'a>>,
    pub(super) text: &'a mut [[u8; 5]],
    pub(super) has: &'a mut [u8],
}

/// With messages left with their senders: how many messages the outbox bits `cols` (the
/// words from `w0` of every column, the columns for sends to all directions last) hold,
/// and how many of them have a recipient. A send to all directions is one message per
/// direction (one sent later towards one direction replaces that one). `empty` tells the
/// columns without a bit set, which are not read.
pub(super) fn count_messages<C: AsRef<[u64]>>(
    cols: &[C],
    has_nbr: &[Vec<u64>],
    (w0, nd): (usize, usize),
    empty: &[bool],
) -> (u64, u64) {
    let ns = cols.len() / (nd + 1);
    let (mut sent, mut delivered) = (0u64, 0u64);
    for s in 0..ns {
        let all = cols[nd * ns + s].as_ref();
        let none_to_all = empty[nd * ns + s];
        if !none_to_all {
            sent += nd as u64 * all.iter().map(|&a| ones(a)).sum::<u64>();
        }
        for (d, nbr) in has_nbr.iter().enumerate().take(nd) {
            let col = d * ns + s;
            let (one, nbr) = (cols[col].as_ref(), &nbr[w0..w0 + all.len()]);
            match (empty[col], none_to_all) {
                (true, true) => {}
                (true, false) => {
                    delivered += all.iter().zip(nbr).map(|(a, b)| ones(a & b)).sum::<u64>();
                }
                (false, _) => {
                    for ((h, a), b) in one.iter().zip(all).zip(nbr) {
                        sent += ones(h & !a);
                        delivered += ones((h | a) & b);
                    }
                }
            }
        }
    }
    (sent, delivered)
}

/// With messages left with their senders, what a step's outboxes (or a chunk of agents'
/// part of them) hold: the messages sent and delivered ([`count_messages`]), and per
/// outbox column whether every agent's bit is set (`full`) and whether none is (`empty`),
/// so that the post office need not test ranges of bits in such columns.
#[derive(Clone, Debug, Default)]
pub(super) struct Tally {
    pub(super) sent: u64,
    pub(super) delivered: u64,
    pub(super) full: Vec<bool>,
    pub(super) empty: Vec<bool>,
}

impl Tally {
    /// The tally of the outbox bits `cols` of `len` agents (from word `w0` of the
    /// neighbour bits).
    pub(super) fn of<C: AsRef<[u64]>>(
        cols: &[C],
        has_nbr: &[Vec<u64>],
        w0: usize,
        nd: usize,
        len: usize,
    ) -> Tally {
        let full = cols.iter().map(|c| all_bits(c.as_ref(), 0..len)).collect();
        let empty: Vec<bool> = cols.iter().map(|c| no_bits(c.as_ref(), 0..len)).collect();
        let (sent, delivered) = count_messages(cols, has_nbr, (w0, nd), &empty);
        Tally {
            sent,
            delivered,
            full,
            empty,
        }
    }

    /// The tally of two chunks together.
    pub(super) fn and(self, other: &Tally) -> Tally {
        let both = |a: Vec<bool>, b: &[bool]| a.iter().zip(b).map(|(&x, &y)| x && y).collect();
        Tally {
            sent: self.sent + other.sent,
            delivered: self.delivered + other.delivered,
            full: both(self.full, &other.full),
            empty: both(self.empty, &other.empty),
        }
    }
}

/// The post office: this step's outboxes (numeric, a column per direction and slot in
/// use, with a bit set per column of the agents that wrote it; texts), filled by the
/// calculations and emptied into the inboxes by the delivery.
pub(super) struct Post {
    /// Numeric outboxes: a column per direction and slot in use (as the inboxes).
    pub(super) out_num: Vec<Column>,
    /// Per numeric column, which agents wrote it.
    pub(super) out_has: Vec<Vec<u64>>,
    /// Text outboxes, `dirs` per agent, and which directions were written (empty when no
    /// rule sends texts).
    pub(super) out_text: Vec<[u8; 5]>,
    pub(super) out_text_bits: Vec<u8>,
    /// With `defer`: per direction, a bit per agent that has a neighbour there (to count
    /// the messages delivered); made at the first delivery.
    pub(super) has_nbr: Vec<Vec<u64>>,
    /// With `defer`: this step's outboxes as counted by the calculations (see [`Tally`]).
    pub(super) counted: Option<Tally>,
}

impl Post {
    /// Outboxes for the program's sends on `lat` (whose slot columns are made). With
    /// `defer` (see [`Plan::defer`]), a send to all directions writes one more column per
    /// slot, and only the columns some send writes hold values (the others are read only
    /// where their bits are set, which they never are).
    pub(super) fn new(prog: &Program, lat: &Lattice, defer: bool, texts: bool) -> Post {
        let n = lat.len();
        let cols = lat.inbox_num.len() + if defer { lat.slots as usize } else { 0 };
        let mut written = vec![!defer; cols];
        for op in &prog.code {
            if let Op::Calc {
                target: Target::Msg { dir, slot },
                ..
            } = *op
            {
                let (ns, sc) = (lat.slots as usize, lat.slot_col[slot as usize] as usize);
                let d = if dir == ANY_DIR {
                    lat.dim.dirs()
                } else {
                    dir as usize
                };
                if let Some(w) = written.get_mut(d * ns + sc) {
                    *w = true;
                }
            }
        }
        let width = lat.width();
        Post {
            out_num: written
                .iter()
                .map(|&w| Column::zeros(width, if w { n } else { 0 }))
                .collect(),
            out_has: vec![vec![0; n.div_ceil(64)]; cols],
            out_text: if texts {
                vec![[0; 5]; n * lat.dim.dirs()]
            } else {
                Vec::new()
            },
            out_text_bits: if texts { vec![0; n] } else { Vec::new() },
            has_nbr: Vec::new(),
            counted: None,
        }
    }

    /// Whether the program sends messages (numeric or text) at all.
    pub(super) fn sends(&self) -> bool {
        !self.out_has.is_empty() || !self.out_text_bits.is_empty()
    }

    /// The directions (bit i = direction index i) agent `a` sends a message towards in
    /// this step's outboxes.
    pub(super) fn sent_dirs(&self, lat: &Lattice, a: usize) -> u8 {
        let (nd, ns) = (lat.dim.dirs(), lat.slots as usize);
        let (w, b) = (a / 64, 1u64 << (a % 64));
        let mut dirs = self.out_text_bits.get(a).copied().unwrap_or(0);
        for (c, bits) in self.out_has.iter().enumerate() {
            if bits[w] & b != 0 {
                // Past the direction columns: the columns of sends to all directions.
                dirs |= if c < nd * ns {
                    1 << (c / ns)
                } else {
                    (1 << nd) - 1
                };
            }
        }
        dirs
    }

    /// Bytes the outboxes hold.
    pub(super) fn bytes(&self) -> usize {
        self.out_num.iter().map(Column::bytes).sum::<usize>()
            + self.out_has.iter().map(|c| c.capacity() * 8).sum::<usize>()
            + self.out_text.capacity() * 5
            + self.out_text_bits.capacity()
    }

    /// Paper step 3, second half: every inbox is emptied and filled with what this step's
    /// outboxes hold, each agent pulling from the neighbour in each direction what that
    /// neighbour sent towards it (in chunks of agents, in parallel with --threads).
    pub(super) fn deliver(
        &mut self,
        (lat, th): (&mut Lattice, &Threads),
        (defer, trace): (bool, bool),
        stats: &mut Stats,
        rep: &mut StepReport,
    ) {
        lat.refresh_neighbours();
        let d = lat.dim;
        let (n, nd, ns) = (lat.len(), d.dirs(), lat.slots as usize);
        if trace {
            self.trace_messages(lat, rep);
        }
        let texts = !self.out_text_bits.is_empty();
        if ns == 0 && !texts {
            // No rule sends or reads messages: there is nothing to deliver.
            return;
        }
        if defer {
            self.deliver_deferred(lat, th, stats);
            return;
        }
        let sent: u64 = self.out_has.iter().flatten().map(|&w| ones(w)).sum::<u64>()
            + self
                .out_text_bits
                .iter()
                .map(|t| t.count_ones() as u64)
                .sum::<u64>();
        let mut inbox_num = std::mem::take(&mut lat.inbox_num);
        let mut inbox_text = std::mem::take(&mut lat.inbox_text);
        let mut inbox_has = std::mem::take(&mut lat.inbox_text_has);
        let (par, size, chunks) = th.chunks(n);
        let mut num = split_values(&mut inbox_num, size, chunks).into_iter();
        let mut text = parts(&mut inbox_text, size * nd, chunks).into_iter();
        let mut has = parts(&mut inbox_has, size, chunks).into_iter();
        let items: Vec<InboxChunk<'_>> = (0..chunks)
            .map(|c| InboxChunk {
                lo: c * size,
                len: size.min(n - c * size),
                num: num.next().unwrap_or_default(),
                text: text.next().unwrap_or_default(),
                has: has.next().unwrap_or_default(),
            })
            .collect();
        let out = Outboxes {
            num: &self.out_num,
            has: &self.out_has,
            text: &self.out_text,
            text_bits: &self.out_text_bits,
        };
        let view = &*lat;
        let pull = |ch: InboxChunk<'_>| pull(ch, view, &out, (nd, ns, texts));
        let delivered: u64 = map_on(par, items, pull).into_iter().sum();
        lat.inbox_num = inbox_num;
        lat.inbox_text = inbox_text;
        lat.inbox_text_has = inbox_has;
        self.out_has.iter_mut().for_each(|c| c.fill(0));
        self.out_text_bits.fill(0);
        stats.sent += sent;
        stats.delivered += delivered;
        stats.dropped += sent - delivered;
    }

    /// [`Post::deliver`] when the agents that sent are among `senders` (in id order) and
    /// every inbox that holds anything is among `emptied` (the last delivery's
    /// recipients): those inboxes are emptied, then each sender's messages put into the
    /// inbox of its neighbour in their direction, and the senders' outboxes cleared. The
    /// same inboxes and counts as the delivery over all agents, in time that follows the
    /// senders and recipients.
    pub(super) fn deliver_listed(
        &mut self,
        lat: &mut Lattice,
        (senders, emptied): (&[u32], &[u32]),
        stats: &mut Stats,
    ) {
        let (nd, ns) = (lat.dim.dirs(), lat.slots as usize);
        let texts = !self.out_text_bits.is_empty();
        for &b in emptied {
            let b = b as usize;
            for col in lat.inbox_num.iter_mut() {
                col.set(b, 0);
            }
            if texts {
                lat.inbox_text_has[b] = 0;
            }
        }
        let (mut sent, mut delivered) = (0u64, 0u64);
        for &a in senders {
            let a = a as usize;
            let (w, bit) = (a / 64, 1u64 << (a % 64));
            let texts_of = if texts {
                std::mem::take(&mut self.out_text_bits[a])
            } else {
                0
            };
            for d in 0..nd {
                let from_text = texts_of & (1 << d) != 0;
                let any_num = (0..ns).any(|s| self.out_has[d * ns + s][w] & bit != 0);
                if !from_text && !any_num {
                    continue;
                }
                let to = match lat.neighbour_cell(a as u32, d) {
                    Cell::Agent(b) => Some(b as usize),
                    _ => None,
                };
                let od = OPPOSITE[d];
                for s in 0..ns {
                    let col = d * ns + s;
                    if self.out_has[col][w] & bit == 0 {
                        continue;
                    }
                    self.out_has[col][w] &= !bit;
                    sent += 1;
                    if let Some(b) = to {
                        lat.inbox_num[od * ns + s].set(b, self.out_num[col].get(a));
                        delivered += 1;
                    }
                }
                if from_text {
                    sent += 1;
                    if let Some(b) = to {
                        lat.inbox_text[b * nd + od] = self.out_text[a * nd + d];
                        lat.inbox_text_has[b] |= 1 << od;
                        delivered += 1;
                    }
                }
            }
        }
        stats.sent += sent;
        stats.delivered += delivered;
        stats.dropped += sent - delivered;
    }

    /// Delivery without copying: this step's outboxes become the lattice's pending
    /// messages (and the last step's pending columns the next outboxes). A message is
    /// delivered when its sender has a neighbour in the direction it was sent.
    pub(super) fn deliver_deferred(&mut self, lat: &mut Lattice, th: &Threads, stats: &mut Stats) {
        // Counted by the calculations (see [`Tally`]), but for the first time.
        let tally = match self.counted.take() {
            Some(c) => c,
            None => {
                self.prepare_deferred(lat, th);
                let (n, nd) = (lat.len(), lat.dim.dirs());
                Tally::of(&self.out_has, &self.has_nbr, 0, nd, n)
            }
        };
        let (sent, delivered) = (tally.sent, tally.delivered);
        let p = lat.pending.as_mut().expect("made at the first delivery");
        std::mem::swap(&mut p.num, &mut self.out_num);
        std::mem::swap(&mut p.has, &mut self.out_has);
        (p.full, p.empty) = (tally.full, tally.empty);
        // The inbox columns are not read while messages are pending. The outboxes' bits
        // are cleared by the next calculations.
        lat.inbox_num
            .iter_mut()
            .for_each(|c| *c = Column::zeros(c.width(), 0));
        stats.sent += sent;
        stats.delivered += delivered;
        stats.dropped += sent - delivered;
    }

    /// With `defer`: the pending columns (and plan) and the neighbour bits, made once.
    pub(super) fn prepare_deferred(&mut self, lat: &mut Lattice, th: &Threads) {
        if lat.pending.is_none() {
            let view = &*lat;
            let parts = th.par_chunks(view.len(), &|lo, hi| Pending::plan_part(view, lo, hi));
            lat.pending = Some(Pending::new(lat, &self.out_num, parts));
        }
        let nd = lat.dim.dirs();
        if self.has_nbr.len() != nd {
            let p = lat.pending.as_ref().expect("just made");
            self.has_nbr = (0..nd).map(|d| p.has_sender(lat, d)).collect();
        }
    }

    /// One trace event per message of this step's outboxes, senders in id order.
    pub(super) fn trace_messages(&self, lat: &Lattice, rep: &mut StepReport) {
        let d = lat.dim;
        let (nd, ns) = (d.dirs(), d.slots());
        let bit = |col: usize, a: usize| self.out_has[col][a >> 6] & (1 << (a & 63)) != 0;
        // With a column for sends to all directions (see `defer`), its bit counts too.
        let cols = nd * lat.slots as usize;
        let all = |col: usize| (self.out_has.len() > cols).then(|| cols + col % lat.slots as usize);
        let has = |col: usize, a: usize| bit(col, a) || all(col).is_some_and(|c| bit(c, a));
        for a in 0..lat.len() {
            for dir in 0..nd {
                let slots: Vec<usize> = (0..ns)
                    .filter(|&s| {
                        let c = lat.slot_col[s];
                        c != NO_COL && has(dir * lat.slots as usize + c as usize, a)
                    })
                    .collect();
                let has_text = self
                    .out_text_bits
                    .get(a)
                    .is_some_and(|t| t & (1 << dir) != 0);
                if slots.is_empty() && !has_text {
                    continue;
                }
                let to = lat.neighbour(a as u32, Dir::ALL[dir]);
                let letter = Dir::ALL[dir].letter();
                for s in slots {
                    let col = dir * lat.slots as usize + lat.slot_col[s] as usize;
                    rep.trace.push(TraceEvent::Message {
                        from: a as u32,
                        to,
                        dir: letter,
                        slot: Some(s as u8 + 1),
                        value: Some(match all(col) {
                            Some(c) if !bit(col, a) => self.out_num[c].get(a),
                            _ => self.out_num[col].get(a),
                        }),
                        text: None,
                    });
                }
                if has_text {
                    rep.trace.push(TraceEvent::Message {
                        from: a as u32,
                        to,
                        dir: letter,
                        slot: None,
                        value: None,
                        text: Some(text(&self.out_text[a * nd + dir])),
                    });
                }
            }
        }
    }
}

/// Fills the inboxes `inb` of one direction and slot from the outbox column `out` (and its
/// bits) of their senders `from` (consecutive agents when `dense`): how many arrived.
#[inline(always)]
fn pull_one<V: Value>(inb: &mut [V], out: &[V], bits: &[u64], from: &[u32], dense: bool) -> u64 {
    let m = inb.len();
    let f0 = from[0] as usize;
    if dense && all_bits(bits, f0..f0 + m) {
        inb.copy_from_slice(&out[f0..f0 + m]);
        return m as u64;
    }
    let mut got = 0;
    for (v, &f) in inb.iter_mut().zip(from) {
        let f = f as usize;
        *v = if f != NO_AGENT as usize && bits[f >> 6] & (1 << (f & 63)) != 0 {
            got += 1;
            out[f]
        } else {
            V::default()
        };
    }
    got
}

/// This step's outboxes, for [`pull`].
pub(super) struct Outboxes<'a> {
    num: &'a [Column],
    has: &'a [Vec<u64>],
    text: &'a [[u8; 5]],
    text_bits: &'a [u8],
}

/// Fills one chunk of recipients' inboxes from the outboxes of their neighbours: how many
/// messages arrived. `texts`: text messages are in use.
#[inline]
pub(super) fn pull(
    ch: InboxChunk<'_>,
    lat: &Lattice,
    out: &Outboxes<'_>,
    (nd, ns, texts): (usize, usize, bool),
) -> u64 {
    let (out_num, out_has, out_text, out_text_bits) = (out.num, out.has, out.text, out.text_bits);
    let mut got = 0u64;
    let InboxChunk {
        lo,
        len,
        mut num,
        text,
        has,
    } = ch;
    if texts {
        has.fill(0);
    }
    // In batches: first every recipient's neighbours, then one tight loop per
    // direction and slot.
    // Agents on consecutive cells of a grid read their neighbours straight from it.
    let mut nb = [[NO_AGENT; BATCH]; 6];
    let mut one = [NO_AGENT; 6];
    let mut base = 0;
    while base < len {
        let mut m = BATCH.min(len - base);
        let run = lat.neighbour_run(lo + base, m);
        if let Some((r, _)) = run {
            m = r;
        } else {
            for j in 0..m {
                lat.neighbours((lo + base + j) as u32, &mut one);
                for (col, &v) in nb.iter_mut().zip(&one).take(nd) {
                    col[j] = v;
                }
            }
        }
        for dir in 0..nd {
            let from = match &run {
                Some((_, r)) => r[dir],
                None => &nb[dir][..m],
            };
            let od = OPPOSITE[dir];
            // The senders are themselves consecutive agents.
            let dense = from[0] != NO_AGENT && is_sequence(from, from[0]);
            for sc in 0..ns {
                let cout = od * ns + sc;
                let bits = &out_has[cout][..];
                let inb = num[dir * ns + sc].cut_mut(base..base + m);
                got += match (inb, &out_num[cout]) {
                    (CutMut::W16(inb), Column::W16(out)) => pull_one(inb, out, bits, from, dense),
                    (CutMut::W32(inb), Column::W32(out)) => pull_one(inb, out, bits, from, dense),
                    // One width for every column of a lattice: not met.
                    _ => 0,
                };
            }
            if texts {
                for (j, &f) in from.iter().enumerate() {
                    let f = f as usize;
                    if f != NO_AGENT as usize && out_text_bits[f] & (1 << od) != 0 {
                        let k = base + j;
                        text[k * nd + dir] = out_text[f * nd + od];
                        has[k] |= 1 << dir;
                        got += 1;
                    }
                }
            }
        }
        base += m;
    }
    got
}
