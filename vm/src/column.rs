//! How wide counters and numeric messages are, and a column of their values.
//!
//! The paper's counters hold -32767..32767 ([`Width::W16`], the default). The 32-bit
//! extension ([`Width::W32`]) holds -2,147,483,647..2,147,483,647, so that algorithms with
//! unique ids run on more than 32,767 agents; a rules file chooses it with the directive
//! `// latticesim: counters 32` and a command with `--counters 32`. The width is a property
//! of a compiled [`crate::Program`]: its literals are in its range, its calculations saturate
//! to it, and a runtime stores every counter and message column in it ([`Column`]), so a
//! run of the paper's width keeps 16-bit columns.

/// The width of counters and numeric messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Width {
    /// 16 bits, -32767..32767 (the paper's).
    #[default]
    W16,
    /// 32 bits, -2,147,483,647..2,147,483,647 (the extension).
    W32,
}

impl Width {
    /// The largest value (the smallest is its negation).
    pub const fn max(self) -> i32 {
        match self {
            Width::W16 => 32767,
            Width::W32 => 2_147_483_647,
        }
    }

    /// 16 or 32.
    pub const fn bits(self) -> u8 {
        match self {
            Width::W16 => 16,
            Width::W32 => 32,
        }
    }

    /// From 16 or 32.
    pub fn from_bits(bits: u32) -> Option<Width> {
        match bits {
            16 => Some(Width::W16),
            32 => Some(Width::W32),
            _ => None,
        }
    }

    /// Whether `v` is a value of this width.
    pub fn holds(self, v: i64) -> bool {
        (-(self.max() as i64)..=self.max() as i64).contains(&v)
    }

    /// `v` saturated to this width.
    #[inline]
    pub fn saturate(self, v: i64) -> i32 {
        v.clamp(-(self.max() as i64), self.max() as i64) as i32
    }

    /// The range as messages say it: "-32767..32767".
    pub fn range_text(self) -> &'static str {
        match self {
            Width::W16 => "-32767..32767",
            Width::W32 => "-2147483647..2147483647",
        }
    }
}

/// A type a column stores values in: `i16` or `i32`, so that a loop over columns can be
/// written once and compiled for each width. The accessors give the values of a column of
/// this type's width, and none (an empty slice) of the other.
pub trait Value: Copy + Default + Ord + Send + Sync + Into<i32> + 'static {
    /// The width.
    const WIDTH: Width;
    /// The value `v`, which the caller knows to be of the column's width.
    fn of(v: i32) -> Self;
    /// The values of a column.
    fn of_column(c: &Column) -> &[Self];
    /// The values of a part of a column.
    fn of_cut(c: Cut<'_>) -> &[Self];
    /// The values of a part of a column, to write.
    fn of_cut_mut<'b>(c: &'b mut CutMut<'_>) -> &'b mut [Self];
}

impl Value for i16 {
    const WIDTH: Width = Width::W16;
    #[inline]
    fn of(v: i32) -> i16 {
        v as i16
    }
    #[inline]
    fn of_column(c: &Column) -> &[i16] {
        c.narrow()
    }
    #[inline]
    fn of_cut(c: Cut<'_>) -> &[i16] {
        c.narrow()
    }
    #[inline]
    fn of_cut_mut<'b>(c: &'b mut CutMut<'_>) -> &'b mut [i16] {
        c.narrow_mut()
    }
}

impl Value for i32 {
    const WIDTH: Width = Width::W32;
    #[inline]
    fn of(v: i32) -> i32 {
        v
    }
    #[inline]
    fn of_column(c: &Column) -> &[i32] {
        match c {
            Column::W32(v) => v,
            Column::W16(_) => &[],
        }
    }
    #[inline]
    fn of_cut(c: Cut<'_>) -> &[i32] {
        match c {
            Cut::W32(v) => v,
            Cut::W16(_) => &[],
        }
    }
    #[inline]
    fn of_cut_mut<'b>(c: &'b mut CutMut<'_>) -> &'b mut [i32] {
        match c {
            CutMut::W32(v) => v,
            CutMut::W16(_) => &mut [],
        }
    }
}

/// One value per agent, in the program's width.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Column {
    /// 16-bit values.
    W16(Vec<i16>),
    /// 32-bit values.
    W32(Vec<i32>),
}

/// Runs `$body` with `$v` bound to the vector (or slice) inside a [`Column`], [`Cut`] or
/// [`CutMut`], once per width, so that a loop over a column is compiled for each.
#[macro_export]
macro_rules! each_width {
    ($c:expr, $v:ident => $body:expr) => {
        match $c {
            $crate::column::Column::W16($v) => $body,
            $crate::column::Column::W32($v) => $body,
        }
    };
    (cut $c:expr, $v:ident => $body:expr) => {
        match $c {
            $crate::column::Cut::W16($v) => $body,
            $crate::column::Cut::W32($v) => $body,
        }
    };
    (mut $c:expr, $v:ident => $body:expr) => {
        match $c {
            $crate::column::CutMut::W16($v) => $body,
            $crate::column::CutMut::W32($v) => $body,
        }
    };
}

/// A part of a [`Column`].
#[derive(Debug, Clone, Copy)]
pub enum Cut<'a> {
    /// 16-bit values.
    W16(&'a [i16]),
    /// 32-bit values.
    W32(&'a [i32]),
}

/// A part of a [`Column`] to write.
#[derive(Debug)]
pub enum CutMut<'a> {
    /// 16-bit values.
    W16(&'a mut [i16]),
    /// 32-bit values.
    W32(&'a mut [i32]),
}

impl Default for Column {
    fn default() -> Column {
        Column::W16(Vec::new())
    }
}

impl Column {
    /// `n` zeros.
    pub fn zeros(w: Width, n: usize) -> Column {
        match w {
            Width::W16 => Column::W16(vec![0; n]),
            Width::W32 => Column::W32(vec![0; n]),
        }
    }

    /// No values, with room for `n`.
    pub fn with_capacity(w: Width, n: usize) -> Column {
        match w {
            Width::W16 => Column::W16(Vec::with_capacity(n)),
            Width::W32 => Column::W32(Vec::with_capacity(n)),
        }
    }

    /// Its width.
    pub fn width(&self) -> Width {
        match self {
            Column::W16(_) => Width::W16,
            Column::W32(_) => Width::W32,
        }
    }

    /// The value of agent `i`.
    #[inline]
    pub fn get(&self, i: usize) -> i32 {
        // (A conversion in the 16-bit arm, none in the 32-bit one.)
        #[allow(clippy::useless_conversion)]
        let v = each_width!(self, v => v[i].into());
        v
    }

    /// Sets the value of agent `i` to `x` (of the column's width).
    #[inline]
    pub fn set(&mut self, i: usize, x: i32) {
        match self {
            Column::W16(v) => v[i] = x as i16,
            Column::W32(v) => v[i] = x,
        }
    }

    /// Appends `x` (of the column's width).
    #[inline]
    pub fn push(&mut self, x: i32) {
        match self {
            Column::W16(v) => v.push(x as i16),
            Column::W32(v) => v.push(x),
        }
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        each_width!(self, v => v.len())
    }

    /// True when it has no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Zeros appended or values cut off to `n`.
    pub fn resize(&mut self, n: usize) {
        each_width!(self, v => v.resize(n, 0))
    }

    /// The values of rows `order` (each in range), in that order: row `i` of the result is
    /// row `order[i]` of this column.
    pub fn gather(&self, order: &[u32]) -> Column {
        match self {
            Column::W16(v) => Column::W16(gather(v, order)),
            Column::W32(v) => Column::W32(gather(v, order)),
        }
    }

    /// Takes out the values of the rows in `gone` (ascending), keeping the others' order.
    pub fn drop_rows(&mut self, gone: &[u32]) {
        each_width!(self, v => drop_rows(v, gone))
    }

    /// Gives back unused room.
    pub fn shrink_to_fit(&mut self) {
        each_width!(self, v => v.shrink_to_fit())
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        match self {
            Column::W16(v) => v.capacity() * 2,
            Column::W32(v) => v.capacity() * 4,
        }
    }

    /// Appends `other`'s values (of the same width).
    pub fn append(&mut self, other: &mut Column) {
        match (self, other) {
            (Column::W16(a), Column::W16(b)) => a.append(b),
            (Column::W32(a), Column::W32(b)) => a.append(b),
            (a, b) => {
                for i in 0..b.len() {
                    a.push(b.get(i));
                }
                b.resize(0);
            }
        }
    }

    /// Values `r`.
    #[inline]
    pub fn cut(&self, r: std::ops::Range<usize>) -> Cut<'_> {
        match self {
            Column::W16(v) => Cut::W16(&v[r]),
            Column::W32(v) => Cut::W32(&v[r]),
        }
    }

    /// The whole column.
    #[inline]
    pub fn all(&self) -> Cut<'_> {
        self.cut(0..self.len())
    }

    /// The whole column, to write.
    #[inline]
    pub fn all_mut(&mut self) -> CutMut<'_> {
        match self {
            Column::W16(v) => CutMut::W16(v),
            Column::W32(v) => CutMut::W32(v),
        }
    }

    /// `chunks` parts of `size` (empty parts when the column is empty or short).
    pub fn parts_mut(&mut self, size: usize, chunks: usize) -> Vec<CutMut<'_>> {
        let w = self.width();
        let mut out: Vec<CutMut<'_>> = match self {
            Column::W16(v) => v.chunks_mut(size.max(1)).map(CutMut::W16).collect(),
            Column::W32(v) => v.chunks_mut(size.max(1)).map(CutMut::W32).collect(),
        };
        out.resize_with(chunks, || CutMut::empty(w));
        out
    }
}

impl Column {
    /// The 16-bit values (empty for a 32-bit column: code that runs only on 16-bit
    /// columns, as the column interpreter's calculations, asks for them).
    #[inline]
    pub fn narrow(&self) -> &[i16] {
        match self {
            Column::W16(v) => v,
            Column::W32(_) => &[],
        }
    }
}

impl<'a> Cut<'a> {
    /// The 16-bit values (empty for 32-bit ones, see [`Column::narrow`]).
    #[inline]
    pub fn narrow(self) -> &'a [i16] {
        match self {
            Cut::W16(v) => v,
            Cut::W32(_) => &[],
        }
    }

    /// The value at `i`.
    #[inline]
    pub fn get(&self, i: usize) -> i32 {
        // (A conversion in the 16-bit arm, none in the 32-bit one.)
        #[allow(clippy::useless_conversion)]
        let v = each_width!(cut self, v => v[i].into());
        v
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        each_width!(cut self, v => v.len())
    }

    /// True when it has no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl<'a> CutMut<'a> {
    /// No values.
    pub fn empty(w: Width) -> CutMut<'a> {
        match w {
            Width::W16 => CutMut::W16(&mut []),
            Width::W32 => CutMut::W32(&mut []),
        }
    }

    /// The 16-bit values (empty for 32-bit ones, see [`Column::narrow`]).
    #[inline]
    pub fn narrow_mut(&mut self) -> &mut [i16] {
        match self {
            CutMut::W16(v) => v,
            CutMut::W32(_) => &mut [],
        }
    }

    /// Its width.
    pub fn width(&self) -> Width {
        match self {
            CutMut::W16(_) => Width::W16,
            CutMut::W32(_) => Width::W32,
        }
    }

    /// The value at `i`.
    #[inline]
    pub fn get(&self, i: usize) -> i32 {
        // (A conversion in the 16-bit arm, none in the 32-bit one.)
        #[allow(clippy::useless_conversion)]
        let v = each_width!(mut self, v => v[i].into());
        v
    }

    /// Sets the value at `i` to `x` (of the width).
    #[inline]
    pub fn set(&mut self, i: usize, x: i32) {
        match self {
            CutMut::W16(v) => v[i] = x as i16,
            CutMut::W32(v) => v[i] = x,
        }
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        each_width!(mut self, v => v.len())
    }

    /// True when it has no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Values `r`, to read.
    #[inline]
    pub fn cut(&self, r: std::ops::Range<usize>) -> Cut<'_> {
        match self {
            CutMut::W16(v) => Cut::W16(&v[r]),
            CutMut::W32(v) => Cut::W32(&v[r]),
        }
    }

    /// Values `r`, to write.
    #[inline]
    pub fn cut_mut(&mut self, r: std::ops::Range<usize>) -> CutMut<'_> {
        match self {
            CutMut::W16(v) => CutMut::W16(&mut v[r]),
            CutMut::W32(v) => CutMut::W32(&mut v[r]),
        }
    }

    /// Copies `src` (of the same length) in.
    pub fn copy_from(&mut self, src: Cut<'_>) {
        match (self, src) {
            (CutMut::W16(d), Cut::W16(s)) => d.copy_from_slice(s),
            (CutMut::W32(d), Cut::W32(s)) => d.copy_from_slice(s),
            (d, s) => (0..s.len()).for_each(|i| d.set(i, s.get(i))),
        }
    }
}

/// The items at the indices `order` (each in range), in that order.
pub fn gather<T: Copy>(v: &[T], order: &[u32]) -> Vec<T> {
    order.iter().map(|&i| v[i as usize]).collect()
}

/// Takes out the items at the indices `gone` (ascending), keeping the others' order.
pub fn drop_rows<T: Copy>(v: &mut Vec<T>, gone: &[u32]) {
    let mut k = 0;
    let mut at = 0;
    v.retain(|_| {
        let keep = gone.get(k) != Some(&(at as u32));
        k += !keep as usize;
        at += 1;
        keep
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widths_saturate_and_columns_keep_their_width() {
        assert_eq!(Width::W16.saturate(40_000), 32767);
        assert_eq!(Width::W16.saturate(-40_000), -32767);
        assert_eq!(Width::W32.saturate(i64::MAX), 2_147_483_647);
        assert_eq!(Width::W32.saturate(i64::MIN), -2_147_483_647);
        assert!(Width::W32.holds(-2_147_483_647) && !Width::W32.holds(-2_147_483_648));
        let mut c = Column::zeros(Width::W32, 3);
        c.set(1, 100_000);
        assert_eq!((c.get(1), c.bytes(), c.width()), (100_000, 12, Width::W32));
        let parts = c.parts_mut(2, 3);
        assert_eq!(parts.iter().map(CutMut::len).collect::<Vec<_>>(), [2, 1, 0]);
        let mut n = Column::zeros(Width::W16, 0);
        assert_eq!(n.parts_mut(4, 2).len(), 2);
    }
}
