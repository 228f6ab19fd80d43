//! The data shared by the compiler and the runtime: geometry (dimension, directions),
//! patterns, operations, and the checked initial configuration. It sits in the VM crate so
//! that both sides can use it while neither depends on the other.

pub use crate::column::{Column, Width};

/// 2D or 3D.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Dim {
    /// Square lattice: directions N, W, E, S.
    Two,
    /// Cubic lattice: directions N, W, E, S, A, B.
    Three,
}

impl Dim {
    /// From a number of coordinates or of pattern characters' dimension (2 or 3).
    pub fn from_coords(n: usize) -> Option<Dim> {
        match n {
            2 => Some(Dim::Two),
            3 => Some(Dim::Three),
            _ => None,
        }
    }

    /// 2 or 3.
    pub fn coords(self) -> usize {
        match self {
            Dim::Two => 2,
            Dim::Three => 3,
        }
    }

    /// Number of neighbour directions: 4 or 6.
    pub fn dirs(self) -> usize {
        match self {
            Dim::Two => 4,
            Dim::Three => 6,
        }
    }

    /// Number of counters: 25 or 45.
    pub fn counters(self) -> usize {
        match self {
            Dim::Two => 25,
            Dim::Three => 45,
        }
    }

    /// Numeric message slots per direction: 8 or 3.
    pub fn slots(self) -> usize {
        match self {
            Dim::Two => 8,
            Dim::Three => 3,
        }
    }

    /// "2D" or "3D".
    pub fn name(self) -> &'static str {
        match self {
            Dim::Two => "2D",
            Dim::Three => "3D",
        }
    }

    /// The other dimension.
    pub fn other(self) -> Dim {
        match self {
            Dim::Two => Dim::Three,
            Dim::Three => Dim::Two,
        }
    }
}

/// A neighbour direction, in the fixed order N, W, E, S, A, B.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Dir {
    /// North, (0,+1,0).
    N,
    /// West, (-1,0,0).
    W,
    /// East, (+1,0,0).
    E,
    /// South, (0,-1,0).
    S,
    /// Above, (0,0,+1).
    A,
    /// Below, (0,0,-1).
    B,
}

impl Dir {
    /// All six, in order.
    pub const ALL: [Dir; 6] = [Dir::N, Dir::W, Dir::E, Dir::S, Dir::A, Dir::B];

    /// From its letter.
    pub fn from_char(c: char) -> Option<Dir> {
        Some(match c {
            'N' => Dir::N,
            'W' => Dir::W,
            'E' => Dir::E,
            'S' => Dir::S,
            'A' => Dir::A,
            'B' => Dir::B,
            _ => return None,
        })
    }

    /// Its letter.
    pub fn letter(self) -> char {
        ['N', 'W', 'E', 'S', 'A', 'B'][self.index()]
    }

    /// Position in the order N, W, E, S, A, B.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The unit offset.
    pub fn offset(self) -> [i32; 3] {
        [
            [0, 1, 0],
            [-1, 0, 0],
            [1, 0, 0],
            [0, -1, 0],
            [0, 0, 1],
            [0, 0, -1],
        ][self.index()]
    }

    /// The axis its offset moves along (0 = x, 1 = y, 2 = z) and by how much (1 or -1).
    pub fn axis(self) -> (usize, i32) {
        [(1, 1), (0, -1), (0, 1), (1, -1), (2, 1), (2, -1)][self.index()]
    }

    /// The opposite direction (what `N` sends, the receiver reads from `S`).
    pub fn opposite(self) -> Dir {
        [Dir::S, Dir::E, Dir::W, Dir::N, Dir::B, Dir::A][self.index()]
    }

    /// The direction with this unit offset, if any.
    pub fn from_offset(o: [i32; 3]) -> Option<Dir> {
        Dir::ALL.into_iter().find(|d| d.offset() == o)
    }
}

/// A 5-character pattern: a byte per position, `None` for `*` (any / keep).
pub type TextPat = [Option<u8>; 5];

/// A per-direction pattern over 0/1/`*`: bit i of `mask` set when direction i is tested,
/// bit i of `want` the value it must have.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BitPat {
    /// Directions that are tested.
    pub mask: u8,
    /// Required values where tested.
    pub want: u8,
}

/// An offset coordinate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Coord {
    /// A literal.
    Lit(i32),
    /// An own counter's value.
    Counter(u8),
}

/// A relative position; the third coordinate is `Lit(0)` in 2D.
pub type Offset = [Coord; 3];

/// `<`, `>`, `=`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CmpOp {
    /// `<`
    Lt,
    /// `>`
    Gt,
    /// `=`
    Eq,
}

impl CmpOp {
    /// Applies the comparison.
    pub fn holds(self, a: i32, b: i32) -> bool {
        match self {
            CmpOp::Lt => a < b,
            CmpOp::Gt => a > b,
            CmpOp::Eq => a == b,
        }
    }

    /// Its symbol.
    pub fn symbol(self) -> char {
        match self {
            CmpOp::Lt => '<',
            CmpOp::Gt => '>',
            CmpOp::Eq => '=',
        }
    }
}

/// The operation of a calculation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CalcOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/` (truncating)
    Div,
    /// `M` (remainder, sign of the dividend)
    Mod,
    /// `A` (maximum)
    Max,
    /// `I` (minimum)
    Min,
}

impl CalcOp {
    /// Its letter as written in rules.
    pub fn symbol(self) -> char {
        match self {
            CalcOp::Add => '+',
            CalcOp::Sub => '-',
            CalcOp::Mul => '*',
            CalcOp::Div => '/',
            CalcOp::Mod => 'M',
            CalcOp::Max => 'A',
            CalcOp::Min => 'I',
        }
    }
}

/// What an `A` action says for one direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AttachLetter {
    /// `0`: detach, stay detached.
    Detach,
    /// `1`: detach, attach afterwards if possible.
    Attach,
    /// `*`: detach, re-attach afterwards if attached before.
    Keep,
    /// `+`: stay attached through the move (carry).
    Rigid,
}

/// One agent of a checked configuration.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AgentInit {
    /// Position (z = 0 in 2D).
    pub pos: [i32; 3],
    /// State characters.
    pub state: [u8; 5],
    /// Attachment bits, bit i = direction i; always symmetric between neighbours.
    pub attach: u8,
    /// Counters that are not 0: (index, value).
    pub counters: Vec<(u8, i32)>,
}

/// Inclusive bounds per axis.
pub type Bounds = [(i32, i32); 3];

/// A checked agents file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Config {
    /// The dimension.
    pub dim: Dim,
    /// The universe, if bounded.
    pub universe: Option<Bounds>,
    /// Agents in id order.
    pub agents: Vec<AgentInit>,
}

/// Agents as columns, in id order: a configuration read straight from an agents file
/// (without an [`AgentInit`] per agent), which becomes a lattice without a copy.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Columns {
    /// Positions (z = 0 in 2D).
    pub pos: Vec<[i32; 3]>,
    /// States.
    pub state: Vec<[u8; 5]>,
    /// Attachment bits as written (not yet known to be symmetric).
    pub attach: Vec<u8>,
    /// Per counter number (45 of them): its values, one per agent, or empty while no agent
    /// has set it; all of one width.
    pub counters: Vec<Column>,
}

impl Columns {
    /// No agents, with counters of width `w`.
    pub fn new(w: Width) -> Columns {
        Columns {
            counters: (0..45).map(|_| Column::with_capacity(w, 0)).collect(),
            ..Columns::default()
        }
    }

    /// Number of agents.
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// True when there are no agents.
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Sets counter `c` of the last agent pushed (to a value that is not 0).
    #[inline]
    pub fn set_counter(&mut self, c: usize, v: i32) {
        let n = self.pos.len();
        let col = &mut self.counters[c];
        if col.len() + 1 < n {
            col.resize(n - 1);
        }
        col.push(v);
    }

    /// Gives every counter column that has values one per agent.
    pub fn fill(&mut self) {
        let n = self.pos.len();
        for col in self.counters.iter_mut().filter(|c| !c.is_empty()) {
            col.resize(n);
        }
    }

    /// Takes out the agents in `gone` (ascending ids; the columns filled).
    pub fn drop_rows(&mut self, gone: &[u32]) {
        use crate::column::drop_rows;
        drop_rows(&mut self.pos, gone);
        drop_rows(&mut self.state, gone);
        drop_rows(&mut self.attach, gone);
        for c in self.counters.iter_mut().filter(|c| !c.is_empty()) {
            c.drop_rows(gone);
        }
    }

    /// Appends `other`'s agents after these (both filled).
    pub fn append(&mut self, mut other: Columns) {
        let (n, m) = (self.len(), other.len());
        self.pos.append(&mut other.pos);
        self.state.append(&mut other.state);
        self.attach.append(&mut other.attach);
        for (mine, theirs) in self.counters.iter_mut().zip(&mut other.counters) {
            match (mine.is_empty(), theirs.is_empty()) {
                (_, true) if !mine.is_empty() => mine.resize(n + m),
                (_, true) => {}
                (true, false) => {
                    mine.resize(n);
                    mine.append(theirs);
                }
                (false, false) => mine.append(theirs),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Dir;

    /// A direction's axis and sign are those of its offset, and its opposite's are the
    /// same axis, the other way; `from_offset` finds each direction again.
    #[test]
    fn axis_is_the_offsets() {
        for d in Dir::ALL {
            let (axis, by) = d.axis();
            let mut o = [0; 3];
            o[axis] = by;
            assert_eq!(o, d.offset(), "{}", d.letter());
            assert_eq!(d.opposite().axis(), (axis, -by));
            assert_eq!(Dir::from_offset(o), Some(d));
        }
    }
}
