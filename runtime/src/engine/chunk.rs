//! Chunks of agents as the calculations and the post office split them: each column cut
//! into parts, and one chunk's counters and outboxes (`CalcChunk`), which the column
//! interpreter and the evaluator of one agent write.

use crate::lattice::{Lattice, NO_COL};
use latticesim_vm::column::{Column, CutMut};
use latticesim_vm::op::ANY_DIR;

/// Splits each column into `chunks` parts of `size` (the last may be shorter) and returns,
/// per part, that part of every column.
pub(super) fn split_columns<T>(
    cols: &mut [Vec<T>],
    size: usize,
    chunks: usize,
) -> Vec<Vec<&mut [T]>> {
    let mut out: Vec<Vec<&mut [T]>> = (0..chunks)
        .map(|_| Vec::with_capacity(cols.len()))
        .collect();
    for col in cols {
        for (k, part) in parts(col, size, chunks).into_iter().enumerate() {
            out[k].push(part);
        }
    }
    out
}

/// [`split_columns`] for counter and message columns.
pub(super) fn split_values(
    cols: &mut [Column],
    size: usize,
    chunks: usize,
) -> Vec<Vec<CutMut<'_>>> {
    let mut out: Vec<Vec<CutMut<'_>>> = (0..chunks)
        .map(|_| Vec::with_capacity(cols.len()))
        .collect();
    for col in cols {
        for (k, part) in col.parts_mut(size, chunks).into_iter().enumerate() {
            out[k].push(part);
        }
    }
    out
}

/// `chunks` parts of `size` of a column (empty parts when the column is empty or short).
pub(super) fn parts<T>(col: &mut [T], size: usize, chunks: usize) -> Vec<&mut [T]> {
    let mut out: Vec<&mut [T]> = col.chunks_mut(size.max(1)).collect();
    out.resize_with(chunks, Default::default);
    out
}

/// One chunk of agents as the calculation phase splits them: `len` agents from `lo` (a
/// multiple of 64), their counter columns, numeric outbox columns and bits, text outbox.
pub(super) struct CalcChunk<'a> {
    pub(super) lo: usize,
    pub(super) len: usize,
    pub(super) counters: Vec<CutMut<'a>>,
    pub(super) out_num: Vec<CutMut<'a>>,
    pub(super) out_has: Vec<&'a mut [u64]>,
    pub(super) out_text: &'a mut [[u8; 5]],
    pub(super) out_text_bits: &'a mut [u8],
}

impl<'a> CalcChunk<'a> {
    /// `n` agents (of `nd` directions) split into `chunks` chunks of `size`: their counter
    /// columns and outboxes (numeric columns, their bits, texts and their bits).
    #[allow(clippy::type_complexity)]
    pub(super) fn split(
        counters: &'a mut [Column],
        (num, has, text, text_bits): (
            &'a mut [Column],
            &'a mut [Vec<u64>],
            &'a mut [[u8; 5]],
            &'a mut [u8],
        ),
        (n, nd): (usize, usize),
        (size, chunks): (usize, usize),
    ) -> Vec<CalcChunk<'a>> {
        let mut ctr = split_values(counters, size, chunks).into_iter();
        let mut onum = split_values(num, size, chunks).into_iter();
        let mut ohas = split_columns(has, size.div_ceil(64), chunks).into_iter();
        let mut otext = parts(text, size * nd, chunks).into_iter();
        let mut otbits = parts(text_bits, size, chunks).into_iter();
        (0..chunks)
            .map(|c| CalcChunk {
                lo: c * size,
                len: size.min(n - c * size),
                counters: ctr.next().unwrap_or_default(),
                out_num: onum.next().unwrap_or_default(),
                out_has: ohas.next().unwrap_or_default(),
                out_text: otext.next().unwrap_or_default(),
                out_text_bits: otbits.next().unwrap_or_default(),
            })
            .collect()
    }

    /// Counter `i` of the chunk's `k`-th agent.
    pub(super) fn counter(&self, lat: &Lattice, k: usize, i: u8) -> i32 {
        match lat.counter_col[i as usize] {
            NO_COL => 0,
            c => self.counters[c as usize].get(k),
        }
    }

    /// The outbox columns a send towards `dir` (or all directions) in `slot` writes, and
    /// those whose bits it clears: where the outboxes have a column for sends to all
    /// directions (see `Plan::defer`), such a send writes that one and clears the
    /// direction columns (a value there would be taken before it).
    pub(super) fn send_cols(&self, lat: &Lattice, dir: u8, slot: u8) -> SendCols {
        let (nd, ns, sc) = (
            lat.dim.dirs(),
            lat.slots as usize,
            lat.slot_col[slot as usize] as usize,
        );
        let mut c = SendCols {
            write: [0; 6],
            nw: 0,
            clear: [0; 6],
            nc: 0,
        };
        if dir != ANY_DIR {
            c.write[0] = dir as usize * ns + sc;
            c.nw = 1;
        } else if self.out_num.len() > nd * ns {
            c.write[0] = nd * ns + sc;
            c.nw = 1;
            for d in 0..nd {
                c.clear[d] = d * ns + sc;
            }
            c.nc = nd;
        } else {
            for d in 0..nd {
                c.write[d] = d * ns + sc;
            }
            c.nw = nd;
        }
        c
    }

    /// The text outbox directions of a send towards `dir` (or all directions).
    pub(super) fn text_dirs(lat: &Lattice, dir: u8) -> std::ops::Range<usize> {
        if dir == ANY_DIR {
            0..lat.dim.dirs()
        } else {
            dir as usize..dir as usize + 1
        }
    }
}

/// The outbox columns of a send: see [`CalcChunk::send_cols`].
pub(super) struct SendCols {
    pub(super) write: [usize; 6],
    pub(super) nw: usize,
    pub(super) clear: [usize; 6],
    pub(super) nc: usize,
}

impl SendCols {
    pub(super) fn write(&self) -> &[usize] {
        &self.write[..self.nw]
    }
    pub(super) fn clear(&self) -> &[usize] {
        &self.clear[..self.nc]
    }
}
