//! The lattice as structure-of-arrays, the synchronous step, records and statistics.
//!
//! [`Engine`] runs a compiled [`latticesim_vm::Program`] on a [`Lattice`] one [`Engine::step`]
//! at a time; each step returns its [`Record`]s (errors and warnings) and, when tracing, its
//! [`TraceEvent`]s, and updates the [`Stats`]. [`History`] keeps keyframes so that a run
//! can go back to any earlier step exactly, in bounded memory. [`StepCost`] is what one
//! step cost, for per-step series. The runtime does no I/O.
#![warn(missing_docs)]

mod bits;
mod cells;
pub mod checkpoint;
mod engine;
mod history;
mod lattice;
mod record;
mod series;
pub mod shapes;
mod trace;

pub use engine::{Engine, Options, Order, Skip, SpaceOrder, Stats, StepReport, AGENTS_PER_THREAD};
pub use history::{History, Jump, Kept, DELTA_BUDGET, KEYFRAME_BUDGET};
pub use lattice::{Lattice, LatticeBuilder, Mends, Undo, Writes};
pub use record::{Record, RecordKind};
pub use series::StepCost;
pub use trace::TraceEvent;
