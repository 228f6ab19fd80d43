//! The checked rules: every name resolved, every pattern turned into masks and
//! every number into range. This is what lowering to bytecode (and the reference evaluator)
//! starts from; it holds no source text, only spans for mapping results back.

use latticesim_grammar::Span;
pub use latticesim_vm::model::{
    AgentInit, AttachLetter, BitPat, Bounds, CalcOp, CmpOp, Column, Columns, Config, Coord, Dim,
    Dir, Offset, TextPat, Width,
};

/// A readable value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Val {
    /// A literal of the rules' width (-32767..32767, or the 32-bit range).
    Lit(i32),
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
pub struct CheckedRules {
    /// The dimension.
    pub dim: Dim,
    /// The width of counters and numeric messages.
    pub width: Width,
    /// The rules, in file order.
    pub rules: Vec<Rule>,
}
