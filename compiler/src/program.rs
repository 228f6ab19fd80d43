//! The checked program: rules with every name resolved, every pattern turned into masks and
//! every number into range. This is what lowering to bytecode (and the reference evaluator)
//! starts from; it holds no source text, only spans for mapping results back.

use latticesim_grammar::Span;

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
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coord {
    /// A literal.
    Lit(i32),
    /// An own counter's value.
    Counter(u8),
}

/// A relative position; the third coordinate is `Lit(0)` in 2D.
pub type Offset = [Coord; 3];

/// A readable value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Val {
    /// A literal in -32767..32767.
    Lit(i16),
    /// An own counter.
    Counter(u8),
    /// An incoming numeric message slot (0-based) from a direction, or from any (`#*`).
    Msg {
        /// `None` for `#*`.
        dir: Option<Dir>,
        /// 0-based slot.
        slot: u8,
    },
}

/// `<`, `>`, `=`.
pub use latticesim_grammar::ast::{CalcOp, CmpOp};

/// A precondition, as a tree.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Cond {
    /// All must hold.
    And(Vec<Cond>),
    /// Negation.
    Not(Box<Cond>),
    /// `N`: filled (1) / empty (0) neighbour cells.
    Neighbors(BitPat),
    /// `A`: own attachments.
    Attached(BitPat),
    /// `P`: per direction, `<` (strict) or `=` (smaller or equal).
    Priorities {
        /// Directions that must have strictly smaller priority.
        strict: u8,
        /// Directions that must have smaller or equal priority.
        leq: u8,
    },
    /// `S`: own state.
    State(TextPat),
    /// `M`: an incoming text message, from one direction or any.
    Message {
        /// `None` for `M*`.
        dir: Option<Dir>,
        /// The pattern.
        pat: TextPat,
    },
    /// `E`: the cell is empty (and inside the universe).
    Empty(Offset),
    /// `F`: the cell holds an agent.
    Filled(Offset),
    /// `L`: an agent with strictly smaller priority is there.
    Less(Offset),
    /// `Q`: an agent with smaller or equal priority is there.
    LessEq(Offset),
    /// `T`: an agent in a matching state is there.
    RemoteState(Offset, TextPat),
    /// `<a b`, `>a b`, `=a b`.
    Compare(CmpOp, Val, Val),
    /// `V`/`W`: an agent is there and its counter is `<` (strict) or `<=` the value.
    RemoteCompare {
        /// True for `V`.
        strict: bool,
        /// Where.
        offset: Offset,
        /// Its counter.
        counter: u8,
        /// The value compared with.
        rhs: Val,
    },
}

/// What an `A` action says for one direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
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

/// Where a calculation writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// An own counter.
    Counter(u8),
    /// An outgoing numeric message slot towards one direction, or all (`#*`).
    Msg {
        /// `None` for all directions.
        dir: Option<Dir>,
        /// 0-based slot.
        slot: u8,
    },
}

/// An operand of a calculation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Operand {
    /// A literal, counter or incoming message.
    Val(Val),
    /// A counter of the agent at a relative position (2D only).
    External {
        /// x offset.
        x: Coord,
        /// y offset.
        y: Coord,
        /// The counter.
        counter: u8,
    },
}

/// One action of a postcondition.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Action {
    /// `P`: move.
    Move(Offset),
    /// `A`: attachment letters per direction.
    Attach(Vec<AttachLetter>),
    /// `S`: new state; `None` keeps a character.
    State(TextPat),
    /// `M`: send a text to one direction or all.
    Send {
        /// `None` for all.
        dir: Option<Dir>,
        /// The text.
        text: [u8; 5],
    },
    /// `X`: swap with the neighbour.
    Swap(Dir),
    /// A calculation.
    Calc {
        /// Where the result goes.
        target: Target,
        /// The operation.
        op: CalcOp,
        /// First operand.
        lhs: Operand,
        /// Second operand.
        rhs: Operand,
    },
}

/// A checked rule.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rule {
    /// Its name.
    pub name: String,
    /// 1..=32767.
    pub priority: u16,
    /// The precondition (an `And` at the top).
    pub pre: Cond,
    /// The actions, in written order.
    pub post: Vec<Action>,
    /// Span of the name line, for messages.
    pub name_span: Span,
}

/// A checked rules file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Program {
    /// The dimension.
    pub dim: Dim,
    /// The rules, in file order.
    pub rules: Vec<Rule>,
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
    pub counters: Vec<(u8, i16)>,
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
