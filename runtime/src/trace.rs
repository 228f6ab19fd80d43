//! Trace events: every action of every step, for `--trace` (JSON Lines).

use serde::Serialize;

/// A state or a text message as trace events write it.
pub(crate) fn text(s: &[u8; 5]) -> String {
    String::from_utf8_lossy(s).into_owned()
}

/// One thing that happened to an agent in a step.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "event", rename_all = "kebab-case")]
pub enum TraceEvent {
    /// An agent executes these rules (names, file order) at this priority.
    Fire {
        /// Agent id.
        agent: u32,
        /// Rule names.
        rules: Vec<String>,
        /// The priority they share.
        priority: u16,
    },
    /// An agent moved.
    Move {
        /// Agent id.
        agent: u32,
        /// Old position.
        from: [i32; 3],
        /// New position.
        to: [i32; 3],
    },
    /// Two agents swapped places.
    Swap {
        /// One agent.
        a: u32,
        /// The other.
        b: u32,
    },
    /// A bond formed or broke.
    Bond {
        /// One agent.
        a: u32,
        /// The other.
        b: u32,
        /// True when it formed.
        formed: bool,
    },
    /// A state changed.
    State {
        /// Agent id.
        agent: u32,
        /// Old state.
        from: String,
        /// New state.
        to: String,
    },
    /// A counter changed.
    Counter {
        /// Agent id.
        agent: u32,
        /// Counter index.
        counter: u8,
        /// New value.
        value: i32,
    },
    /// A message was delivered (numeric: `slot` and `value`; text: `text`).
    Message {
        /// Sender.
        from: u32,
        /// Receiver, if any agent stood there (else the message was dropped).
        to: Option<u32>,
        /// Direction from the sender.
        dir: char,
        /// Slot, 1-based, for numeric messages.
        slot: Option<u8>,
        /// Value of a numeric message.
        value: Option<i32>,
        /// Text of a text message.
        text: Option<String>,
    },
}
