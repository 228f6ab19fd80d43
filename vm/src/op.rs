//! The instruction set, defined once in the `ops!` table below: the table generates the
//! [`Op`] enum, its byte encoding ([`Op::encode`]), the decoder ([`Op::decode`]) and the
//! disassembly ([`std::fmt::Display`]), so they cannot drift apart. `docs/bytecode.md`
//! describes every opcode.
//!
//! Encoding: one byte opcode, then the operands in the order listed, each in its own
//! encoding: `u8` one byte, `u16` two bytes little-endian, [`Val`] and [`Target`] a tag byte
//! and two payload bytes, [`CmpOp`]/[`CalcOp`] one byte.

use crate::model::{CalcOp, CmpOp};
use std::fmt;

/// Direction operand value meaning "any direction" (in tests) or "all directions" (in sends).
pub const ANY_DIR: u8 = 6;

/// A value read by a comparison or a calculation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Val {
    /// A literal.
    Lit(i16),
    /// An own counter.
    Counter(u8),
    /// An incoming numeric message: direction (0..6, or [`ANY_DIR`]) and 0-based slot.
    Msg {
        /// Direction index, or [`ANY_DIR`].
        dir: u8,
        /// 0-based slot.
        slot: u8,
    },
    /// An external counter: an index into [`crate::Program::externals`].
    Ext(u16),
    /// A literal outside the 16-bit range (the 32-bit extension): an index into
    /// [`crate::Program::wide`].
    Wide(u16),
}

/// Where a calculation writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// An own counter.
    Counter(u8),
    /// An outgoing numeric message slot: direction (or [`ANY_DIR`] for all) and slot.
    Msg {
        /// Direction index, or [`ANY_DIR`].
        dir: u8,
        /// 0-based slot.
        slot: u8,
    },
}

/// A bytecode that does not decode.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DecodeError {
    /// Byte offset of the problem.
    pub at: usize,
    /// What is wrong.
    pub what: &'static str,
}

/// How an operand type is written to and read from bytes, and shown.
trait Operand: Sized {
    fn put(&self, out: &mut Vec<u8>);
    fn get(b: &mut &[u8]) -> Option<Self>;
    fn show(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result;
}

fn take<const N: usize>(b: &mut &[u8]) -> Option<[u8; N]> {
    let (head, rest) = b.split_first_chunk::<N>()?;
    *b = rest;
    Some(*head)
}

impl Operand for u8 {
    fn put(&self, out: &mut Vec<u8>) {
        out.push(*self);
    }
    fn get(b: &mut &[u8]) -> Option<Self> {
        take::<1>(b).map(|[x]| x)
    }
    fn show(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{self}")
    }
}

impl Operand for u16 {
    fn put(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
    fn get(b: &mut &[u8]) -> Option<Self> {
        take::<2>(b).map(u16::from_le_bytes)
    }
    fn show(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{self}")
    }
}

fn dir_name(d: u8) -> char {
    *b"NWESAB*".get(d as usize).unwrap_or(&b'?') as char
}

impl Operand for Val {
    fn put(&self, out: &mut Vec<u8>) {
        let (tag, p) = match *self {
            Val::Lit(v) => (0u8, v.to_le_bytes()),
            Val::Counter(c) => (1, [c, 0]),
            Val::Msg { dir, slot } => (2, [dir, slot]),
            Val::Ext(i) => (3, i.to_le_bytes()),
            Val::Wide(i) => (4, i.to_le_bytes()),
        };
        out.push(tag);
        out.extend_from_slice(&p);
    }
    fn get(b: &mut &[u8]) -> Option<Self> {
        let [tag, x, y] = take::<3>(b)?;
        Some(match tag {
            0 => Val::Lit(i16::from_le_bytes([x, y])),
            1 => Val::Counter(x),
            2 => Val::Msg { dir: x, slot: y },
            3 => Val::Ext(u16::from_le_bytes([x, y])),
            4 => Val::Wide(u16::from_le_bytes([x, y])),
            _ => return None,
        })
    }
    fn show(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Val::Lit(v) => write!(f, "{v}"),
            Val::Counter(c) => write!(f, "C{c:02}"),
            Val::Msg { dir, slot } => write!(f, "#{}{:02}", dir_name(dir), slot + 1),
            Val::Ext(i) => write!(f, "ext[{i}]"),
            Val::Wide(i) => write!(f, "wide[{i}]"),
        }
    }
}

impl Operand for Target {
    fn put(&self, out: &mut Vec<u8>) {
        match *self {
            Target::Counter(c) => out.extend_from_slice(&[0, c, 0]),
            Target::Msg { dir, slot } => out.extend_from_slice(&[1, dir, slot]),
        }
    }
    fn get(b: &mut &[u8]) -> Option<Self> {
        let [tag, x, y] = take::<3>(b)?;
        Some(match tag {
            0 => Target::Counter(x),
            1 => Target::Msg { dir: x, slot: y },
            _ => return None,
        })
    }
    fn show(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Target::Counter(c) => write!(f, "C{c:02}"),
            Target::Msg { dir, slot } => write!(f, "out#{}{:02}", dir_name(dir), slot + 1),
        }
    }
}

impl Operand for CmpOp {
    fn put(&self, out: &mut Vec<u8>) {
        out.push(*self as u8);
    }
    fn get(b: &mut &[u8]) -> Option<Self> {
        Some(match u8::get(b)? {
            0 => CmpOp::Lt,
            1 => CmpOp::Gt,
            2 => CmpOp::Eq,
            _ => return None,
        })
    }
    fn show(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.symbol())
    }
}

impl Operand for CalcOp {
    fn put(&self, out: &mut Vec<u8>) {
        out.push(*self as u8);
    }
    fn get(b: &mut &[u8]) -> Option<Self> {
        use CalcOp::*;
        [Add, Sub, Mul, Div, Mod, Max, Min]
            .get(u8::get(b)? as usize)
            .copied()
    }
    fn show(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.symbol())
    }
}

macro_rules! ops {
    ($( $(#[doc = $doc:literal])* $name:ident = $code:literal $mnemonic:literal { $($field:ident : $ty:ty),* } )*) => {
        /// One instruction. See the module documentation and `docs/bytecode.md`.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum Op {
            $( $(#[doc = $doc])* $name { $( #[allow(missing_docs)] $field: $ty ),* }, )*
        }

        impl Op {
            /// The opcode byte.
            pub fn opcode(&self) -> u8 {
                match self { $( Op::$name { .. } => $code, )* }
            }

            /// The name in disassembly.
            pub fn mnemonic(&self) -> &'static str {
                match self { $( Op::$name { .. } => $mnemonic, )* }
            }

            /// Every opcode with its mnemonic, in table order.
            pub const TABLE: &'static [(u8, &'static str)] = &[ $( ($code, $mnemonic), )* ];

            /// Appends the encoding of this instruction.
            pub fn encode(&self, out: &mut Vec<u8>) {
                match self {
                    $( Op::$name { $($field),* } => {
                        out.push($code);
                        $( Operand::put($field, out); )*
                    } )*
                }
            }

            /// Decodes one instruction from the front of `bytes`, advancing it.
            pub fn decode(bytes: &mut &[u8], at: usize) -> Result<Op, DecodeError> {
                let code = u8::get(bytes).ok_or(DecodeError { at, what: "missing opcode" })?;
                let bad = DecodeError { at, what: "truncated or invalid operand" };
                match code {
                    $( $code => Ok(Op::$name { $( $field: <$ty as Operand>::get(bytes).ok_or(bad.clone())? ),* }), )*
                    _ => Err(DecodeError { at, what: "unknown opcode" }),
                }
            }
        }

        impl fmt::Display for Op {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                match self {
                    $( Op::$name { $($field),* } => {
                        f.write_str($mnemonic)?;
                        $( f.write_str(concat!(" ", stringify!($field), "="))?; Operand::show($field, f)?; )*
                        Ok(())
                    } )*
                }
            }
        }
    };
}

ops! {
    /// Precondition: push true.
    True = 0x01 "true" {}
    /// Push whether the tested neighbour cells (bits of `mask`) are filled as in `want`.
    Nbr = 0x02 "nbr" { mask: u8, want: u8 }
    /// Push whether the tested attachments (bits of `mask`) are as in `want`.
    Att = 0x03 "att" { mask: u8, want: u8 }
    /// Push whether the neighbours' priorities are smaller (`strict` bits) or smaller or
    /// equal (`leq` bits) than the rule's; unknown while priorities are being resolved.
    Prio = 0x04 "prio" { strict: u8, leq: u8 }
    /// Push whether the own state matches pattern `pat`.
    State = 0x05 "state" { pat: u16 }
    /// Push whether the text received from `dir` (or any) matches pattern `pat`.
    Msg = 0x06 "msg" { dir: u8, pat: u16 }
    /// Push whether the cell at offset `off` is empty.
    Empty = 0x07 "empty" { off: u16 }
    /// Push whether the cell at offset `off` holds an agent.
    Filled = 0x08 "filled" { off: u16 }
    /// Push whether an agent with strictly smaller priority stands at `off`.
    Less = 0x09 "less" { off: u16 }
    /// Push whether an agent with smaller or equal priority stands at `off`.
    LessEq = 0x0a "lesseq" { off: u16 }
    /// Push whether an agent in a state matching `pat` stands at `off`.
    RState = 0x0b "rstate" { off: u16, pat: u16 }
    /// Push whether `a op b` holds (a `#*` value: for some direction).
    Cmp = 0x0c "cmp" { op: CmpOp, a: Val, b: Val }
    /// Push whether an agent stands at `off` and its counter is < (`strict`) or <= `b`.
    RCmp = 0x0d "rcmp" { strict: u8, off: u16, counter: u8, b: Val }
    /// Replace the top with its negation (Kleene).
    Not = 0x0e "not" {}
    /// Replace the two topmost with their conjunction (Kleene).
    And = 0x0f "and" {}
    /// If the top is false, jump to instruction `to` (relative to the rule's start), keeping it.
    Jf = 0x10 "jf" { to: u16 }
    /// Postcondition: move by offset `off`.
    Move = 0x20 "move" { off: u16 }
    /// Attachment letters `letters` (an index into the letters table).
    Attach = 0x21 "attach" { letters: u16 }
    /// New state from pattern `pat` (`*` keeps a character).
    SetState = 0x22 "setstate" { pat: u16 }
    /// Swap with the neighbour in direction `dir`.
    Swap = 0x23 "swap" { dir: u8 }
    /// Send text `text` towards `dir` (or all).
    Send = 0x24 "send" { dir: u8, text: u16 }
    /// `target = a op b`, saturated to -32767..32767.
    Calc = 0x25 "calc" { target: Target, op: CalcOp, a: Val, b: Val }
}

impl Op {
    /// True for the instructions of a precondition.
    pub fn is_pre(&self) -> bool {
        self.opcode() < 0x20
    }
}

/// Encodes a sequence.
pub fn encode(code: &[Op]) -> Vec<u8> {
    let mut out = Vec::with_capacity(code.len() * 4);
    for op in code {
        op.encode(&mut out);
    }
    out
}

/// Decodes a whole sequence.
pub fn decode(mut bytes: &[u8]) -> Result<Vec<Op>, DecodeError> {
    let total = bytes.len();
    let mut out = Vec::new();
    while !bytes.is_empty() {
        let at = total - bytes.len();
        out.push(Op::decode(&mut bytes, at)?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opcodes_are_unique() {
        let mut seen = std::collections::HashSet::new();
        for (code, name) in Op::TABLE {
            assert!(seen.insert(*code), "{name}");
        }
    }

    #[test]
    fn ops_stay_small() {
        assert!(
            std::mem::size_of::<Op>() <= 16,
            "{}",
            std::mem::size_of::<Op>()
        );
    }

    #[test]
    fn encode_decode_roundtrip() {
        let code = vec![
            Op::True {},
            Op::Nbr { mask: 5, want: 1 },
            Op::Cmp {
                op: CmpOp::Gt,
                a: Val::Msg {
                    dir: ANY_DIR,
                    slot: 1,
                },
                b: Val::Lit(-5),
            },
            Op::Jf { to: 300 },
            Op::Calc {
                target: Target::Msg { dir: 2, slot: 7 },
                op: CalcOp::Mod,
                a: Val::Ext(3),
                b: Val::Counter(24),
            },
            Op::Cmp {
                op: CmpOp::Lt,
                a: Val::Wide(2),
                b: Val::Counter(0),
            },
            Op::Not {},
        ];
        let bytes = encode(&code);
        assert_eq!(decode(&bytes).unwrap(), code);
        assert!(decode(&bytes[..bytes.len() - 2]).is_err());
        assert!(decode(&[0xff]).is_err());
        assert_eq!(code[2].to_string(), "cmp op=> a=#*02 b=-5");
    }
}

#[cfg(test)]
mod doc_tests {
    use super::Op;

    #[test]
    fn bytecode_page_lists_every_opcode() {
        let doc =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/bytecode.md"))
                .expect("docs/bytecode.md exists");
        for (code, name) in Op::TABLE {
            let row = format!("| `{code:#04x}` | `{name}` |");
            assert!(doc.contains(&row), "docs/bytecode.md has no row {row}");
        }
    }
}
