//! The syntax tree of rules.txt and agents.txt.
//!
//! Rule lines are allocated in a `bumpalo` arena and borrow their texts from the source, so a
//! file of 100,000 rules costs a handful of allocations. Nodes keep what was written (pattern
//! texts, counter digits) and leave judging it to the checker, which can then say precisely
//! what is wrong. Every node carries its span; equality ignores spans (see [`Spanned`]).

use crate::span::{Span, Spanned};

/// A coordinate of an offset: a number or an own counter (`C03`, digits kept as written).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Comp<'a> {
    /// A literal.
    Int(i64),
    /// An own counter; the digits after `C`.
    Counter(&'a str),
}

/// The coordinates of an offset, e.g. `-1,0` or `C03,C04,1`.
pub type Offset<'a> = Spanned<&'a [Spanned<Comp<'a>>]>;

/// A readable numeric value, or the target of a calculation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Value<'a> {
    /// A literal such as `0010` or `-0005`.
    Int(i64),
    /// A counter `Cnn`; the digits after `C`.
    Counter(&'a str),
    /// A numeric message `#Dkk`; the text after `#`.
    Msg(&'a str),
}

/// An operand of a calculation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Operand<'a> {
    /// A literal, counter or incoming message.
    Value(Spanned<Value<'a>>),
    /// An external counter `dx,dy,Cnn` or `Cxx,Cyy,Cnn`: coordinates then the counter.
    External(Offset<'a>),
}

/// `<`, `>` or `=`, as written. (The VM has its own `CmpOp` and `CalcOp`: the bytecode
/// crate depends on no front-end crate, and the checker maps one onto the other.)
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CmpOp {
    /// `<`
    Lt,
    /// `>`
    Gt,
    /// `=`
    Eq,
}

/// The operation of a calculation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CalcOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `M` (remainder)
    Mod,
    /// `A` (maximum)
    Max,
    /// `I` (minimum)
    Min,
}

/// A numeric comparison `<a b`, `>a b`, `=a b`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Compare<'a> {
    /// The comparison.
    pub op: Spanned<CmpOp>,
    /// Left value.
    pub lhs: Spanned<Value<'a>>,
    /// Right value.
    pub rhs: Spanned<Value<'a>>,
}

/// `Vdx,dy,Cnn b` (strict) or `Wdx,dy,Cnn b`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RemoteCompare<'a> {
    /// True for `V`.
    pub strict: bool,
    /// Coordinates followed by the remote counter, as written.
    pub comps: Offset<'a>,
    /// The value compared with.
    pub rhs: Spanned<Value<'a>>,
}

/// A calculation `target op a b`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Calc<'a> {
    /// Counter or outgoing message slot.
    pub target: Spanned<Value<'a>>,
    /// The operation.
    pub op: Spanned<CalcOp>,
    /// First operand.
    pub lhs: Operand<'a>,
    /// Second operand.
    pub rhs: Operand<'a>,
}

/// One term of a precondition or one action of a postcondition. Both lines share this
/// type; the checker reports terms that stand on the wrong line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Term<'a> {
    /// `N____`: neighbour cells.
    Neighbors(Spanned<&'a str>),
    /// `A____`: attachments (test in a precondition, action in a postcondition).
    Attach(Spanned<&'a str>),
    /// `P<=*_`: neighbour priorities.
    Priorities(Spanned<&'a str>),
    /// `S_____`: state (test or new state).
    State(Spanned<&'a str>),
    /// `MD_____`: a text message (test or send).
    Message {
        /// Direction character as written.
        dir: Spanned<char>,
        /// The text.
        text: Spanned<&'a str>,
    },
    /// `Edx,dy`: empty cell.
    Empty(Offset<'a>),
    /// `Fdx,dy`: filled cell.
    Filled(Offset<'a>),
    /// `Ldx,dy`: an agent there with strictly smaller priority.
    Less(Offset<'a>),
    /// `Qdx,dy`: an agent there with smaller or equal priority.
    LessEq(Offset<'a>),
    /// `Tdx,dy,_____`: an agent there in a matching state.
    RemoteState {
        /// Where.
        offset: Offset<'a>,
        /// The state pattern.
        state: Spanned<&'a str>,
    },
    /// `<a b`, `>a b`, `=a b` (kept in the arena: terms stay small).
    Compare(&'a Compare<'a>),
    /// `Vdx,dy,Cnn b` (strict) or `Wdx,dy,Cnn b`.
    RemoteCompare(&'a RemoteCompare<'a>),
    /// `Pdx,dy`: move.
    Move(Offset<'a>),
    /// `XD`: swap with a neighbour.
    Swap(Spanned<&'a str>),
    /// `target op a b` (kept in the arena: terms stay small).
    Calc(&'a Calc<'a>),
    /// `!term`.
    Not(&'a Spanned<Term<'a>>),
    /// `( terms )`.
    Group(&'a [Spanned<Term<'a>>]),
    /// What the parser skipped after a syntax error.
    Error,
}

/// A precondition or postcondition line.
pub type Terms<'a> = Spanned<&'a [Spanned<Term<'a>>]>;

/// One rule: four significant lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rule<'a> {
    /// The name line.
    pub name: Spanned<&'a str>,
    /// The priority, if the line is a whole number (saturated to the i64 range).
    pub priority: Spanned<Option<i64>>,
    /// The precondition.
    pub pre: Terms<'a>,
    /// The postcondition.
    pub post: Terms<'a>,
}

/// A parsed rules file.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct RulesFile<'a> {
    /// The complete rules, in file order.
    pub rules: Vec<Rule<'a>>,
}

/// The universe line: inclusive bounds per axis. Equality ignores the line's span.
#[derive(Debug, Clone, Eq)]
pub struct Universe {
    /// `minX, maxX, minY, maxY[, minZ, maxZ]` with their spans.
    pub bounds: Vec<Spanned<i64>>,
    /// The whole line.
    pub span: Span,
}

/// One agent line. Equality ignores the line's span.
#[derive(Debug, Clone, Eq)]
pub struct AgentLine<'a> {
    /// The coordinates as written.
    pub pos: Vec<Spanned<i64>>,
    /// `S` field text.
    pub state: Option<Spanned<&'a str>>,
    /// `A` field text.
    pub attach: Option<Spanned<&'a str>>,
    /// `Cnn value` fields: counter digits and value.
    pub counters: Vec<(Spanned<&'a str>, Spanned<i64>)>,
    /// The whole line.
    pub span: Span,
}

/// A parsed agents file.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct AgentsFile<'a> {
    /// The `U` line, if any.
    pub universe: Option<Universe>,
    /// The agents, in id order.
    pub agents: Vec<AgentLine<'a>>,
}

impl PartialEq for Universe {
    fn eq(&self, other: &Self) -> bool {
        self.bounds == other.bounds
    }
}

impl PartialEq for AgentLine<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.pos == other.pos
            && self.state == other.state
            && self.attach == other.attach
            && self.counters == other.counters
    }
}

#[cfg(test)]
mod size_tests {
    use super::*;

    /// Terms are the bulk of a large rules file's tree: keep them small (big variants live
    /// behind a reference into the arena).
    #[test]
    fn terms_stay_small() {
        assert!(
            std::mem::size_of::<Spanned<Term<'_>>>() <= 64,
            "{}",
            std::mem::size_of::<Spanned<Term<'_>>>()
        );
        assert!(std::mem::size_of::<Rule<'_>>() <= 96);
    }
}
