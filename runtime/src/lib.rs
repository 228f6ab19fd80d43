//! The lattice as structure-of-arrays, the synchronous step, records and statistics.
//!
//! Not yet written: the step is the subject of issue 3. The crate exists so that the
//! workspace has its final shape (`runtime -> vm`, never back up the chain).
#![warn(missing_docs)]
