//! The instruction set and the evaluator for one agent.
//!
//! Not yet written: the bytecode and the VM are the subject of issue 3. The crate exists so
//! that the workspace has its final shape and its dependency direction
//! (`compiler -> {grammar, vm}`, `runtime -> vm`) is fixed from the start.
#![warn(missing_docs)]
