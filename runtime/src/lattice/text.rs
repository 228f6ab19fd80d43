//! The configuration as agents.txt text, written from the columns as it is formatted.

use super::*;
use crate::cells::prefetch;

/// Writes the decimal digits of `v` into `buf` at `at`: where they end. (Digit by digit
/// from the end: a copy of a few bytes would be a call to `memcpy`.)
#[inline]
pub(super) fn put_int(buf: &mut [u8], mut at: usize, v: i64) -> usize {
    if v < 0 {
        buf[at] = b'-';
        at += 1;
    }
    let mut u = v.unsigned_abs();
    let end = at + u.checked_ilog10().map_or(1, |l| l as usize + 1);
    let mut i = end;
    loop {
        i -= 1;
        buf[i] = b'0' + (u % 10) as u8;
        u /= 10;
        if u == 0 {
            break;
        }
    }
    end
}

impl Lattice {
    /// The configuration in agents.txt syntax: the universe line if there is one, then the
    /// agents in id order (the agents file's, [`Lattice::label`]) with state (unless it is
    /// the default, `00000`), attachments (when any) and non-zero counters. It loads again
    /// to the same lattice.
    pub fn to_agents_text(&self) -> String {
        let mut out = Vec::with_capacity(self.len() * 24);
        self.write_agents_text(&mut out, 1)
            .expect("writing to memory does not fail");
        String::from_utf8(out).expect("states are ASCII")
    }

    /// Writes [`Lattice::to_agents_text`] into `w` as it is made, a block of agents at a
    /// time. With `threads` above one, a second thread formats the next blocks while this
    /// one writes (formatting itself on several threads was slower on two cores).
    pub fn write_agents_text(
        &self,
        w: &mut impl std::io::Write,
        threads: usize,
    ) -> std::io::Result<()> {
        /// Agents formatted at a time.
        const BLOCK: usize = 1 << 15;
        let c = self.dim.coords();
        if let Some(b) = self.universe {
            let v: Vec<String> = b[..c]
                .iter()
                .flat_map(|(lo, hi)| [lo.to_string(), hi.to_string()])
                .collect();
            writeln!(w, "U{}", v.join(","))?;
        }
        // Counter columns in number order, so that a line lists its counters so.
        let cols: Vec<(u8, &Column)> = (0..self.nc() as u8)
            .filter(|&i| self.counter_col[i as usize] != NO_COL)
            .map(|i| (i, &self.counters[self.counter_col[i as usize] as usize]))
            .collect();
        let n = self.len();
        let room = BLOCK * self.longest_line(&cols);
        if threads < 2 || n <= BLOCK {
            let mut buf = vec![0u8; room.min(n * self.longest_line(&cols))];
            for a in (0..n).step_by(BLOCK) {
                let len = self.format_agents(a..(a + BLOCK).min(n), &cols, &mut buf);
                w.write_all(&buf[..len])?;
            }
            return Ok(());
        }
        use std::sync::mpsc::sync_channel;
        let (full_tx, full_rx) = sync_channel::<(Vec<u8>, usize)>(3);
        let (empty_tx, empty_rx) = sync_channel::<Vec<u8>>(4);
        for _ in 0..4 {
            let _ = empty_tx.send(vec![0u8; room]);
        }
        std::thread::scope(|s| {
            let cols = &cols;
            s.spawn(move || {
                for a in (0..n).step_by(BLOCK) {
                    // The writer gave up (an error): stop.
                    let Ok(mut buf) = empty_rx.recv() else {
                        return;
                    };
                    let len = self.format_agents(a..(a + BLOCK).min(n), cols, &mut buf);
                    if full_tx.send((buf, len)).is_err() {
                        return;
                    }
                }
            });
            let written = (|| {
                for (buf, len) in full_rx.iter() {
                    w.write_all(&buf[..len])?;
                    let _ = empty_tx.send(buf);
                }
                Ok(())
            })();
            // A write that failed (a full disk) ends the formatting thread: its channels
            // close here, before the scope waits for it.
            drop((full_rx, empty_tx));
            written
        })
    }

    /// The longest line [`Lattice::format_agents`] can make with these counter columns.
    pub(super) fn longest_line(&self, cols: &[(u8, &Column)]) -> usize {
        // ` C00 ` and the value: `-32767` or `-2147483647`.
        let counter = 5 + 1 + self.width.max().ilog10() as usize + 1;
        3 * 12 + 7 + 8 + cols.len() * counter + 1
    }

    /// The lines of agents `range` (see [`Lattice::to_agents_text`]), written into `line`
    /// (room for the longest line per agent): their length. Each line is written in place
    /// (a copy of a line would be a call to `memcpy`).
    pub(super) fn format_agents(
        &self,
        range: std::ops::Range<usize>,
        cols: &[(u8, &Column)],
        line: &mut [u8],
    ) -> usize {
        let (three, dirs) = (self.dim == Dim::Three, self.dim.dirs());
        let mut at = 0;
        // In the agents file's order (agents kept in space order are found by their ids,
        // scattered over the columns: each asked for a dozen agents ahead).
        let of_id = self.labels.as_ref().map(|l| l.agents());
        for id in range {
            let a = of_id.map_or(id, |m| m[id] as usize);
            if let Some(&b) = of_id.and_then(|m| m.get(id + AHEAD)) {
                let b = b as usize;
                prefetch(self.pos.as_ptr().wrapping_add(b));
                prefetch(self.state.as_ptr().wrapping_add(b));
                prefetch(self.attach.as_ptr().wrapping_add(b));
                for (_, col) in cols {
                    latticesim_vm::each_width!(col, v => prefetch(v.as_ptr().wrapping_add(b)));
                }
            }
            let p = self.pos[a];
            at = put_int(line, at, p[0] as i64);
            line[at] = b',';
            at = put_int(line, at + 1, p[1] as i64);
            if three {
                line[at] = b',';
                at = put_int(line, at + 1, p[2] as i64);
            }
            // The default state, `00000`, is left out, as an agents file without `S` says it.
            let st = self.state[a];
            if st != *b"00000" {
                line[at] = b' ';
                line[at + 1] = b'S';
                line[at + 2] = st[0];
                line[at + 3] = st[1];
                line[at + 4] = st[2];
                line[at + 5] = st[3];
                line[at + 6] = st[4];
                at += 7;
            }
            let bonds = self.attach[a];
            if bonds != 0 {
                line[at] = b' ';
                line[at + 1] = b'A';
                at += 2;
                for d in 0..dirs {
                    line[at] = b'0' + (bonds >> d & 1);
                    at += 1;
                }
            }
            for &(i, col) in cols {
                let v = col.get(a);
                if v != 0 {
                    line[at] = b' ';
                    line[at + 1] = b'C';
                    line[at + 2] = b'0' + i / 10;
                    line[at + 3] = b'0' + i % 10;
                    line[at + 4] = b' ';
                    at = put_int(line, at + 5, v as i64);
                }
            }
            line[at] = b'\n';
            at += 1;
        }
        at
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A writer that fails after `left` bytes, as a full disk does.
    struct Full {
        left: usize,
    }

    impl std::io::Write for Full {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            if self.left == 0 {
                return Err(std::io::Error::from(std::io::ErrorKind::StorageFull));
            }
            let n = b.len().min(self.left);
            self.left -= n;
            Ok(n)
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// A write error ends the writer with that error, on one thread or two, at the first
    /// block or a later one: never a wait on the formatting thread.
    #[test]
    fn a_full_disk_is_an_error_not_a_hang() {
        let b = LatticeBuilder::block(400, 400);
        let lat = b.finish();
        for threads in [1, 2] {
            for left in [0, 10, 1 << 20] {
                let e = lat.write_agents_text(&mut Full { left }, threads);
                assert_eq!(
                    e.map_err(|e| e.kind()),
                    Err(std::io::ErrorKind::StorageFull),
                    "{threads} threads, {left} bytes"
                );
            }
        }
    }
}
