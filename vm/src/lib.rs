//! The bytecode of latticesim and the evaluator for one agent.
//!
//! - [`column`]: the width of counters and messages (16 bits, or the 32-bit extension)
//!   and a column of their values;
//! - [`model`]: the data both the compiler and the runtime use (dimension, directions,
//!   patterns, the checked initial configuration);
//! - [`op`]: the instruction set, defined once in a table that generates the opcode enum,
//!   its byte encoding, the decoder and the disassembler (see `docs/bytecode.md`);
//! - [`Program`]: a compiled rules file: per rule a precondition and a postcondition code
//!   sequence, and the constant tables they index; [`Program::verify`] checks it once;
//! - [`eval`]: the evaluator of a precondition in three-valued logic and of the
//!   calculations of a postcondition, over an [`eval::Env`] the runtime provides.
//!
//! The VM never sees source text and depends on no front-end crate.
#![warn(missing_docs)]

pub mod column;
pub mod eval;
pub mod model;
pub mod op;
mod program;

pub use eval::{Env, Tri};
pub use op::Op;
pub use program::{Program, RuleInfo, Uses, Verified, VerifyError};
