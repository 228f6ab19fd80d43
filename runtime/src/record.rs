//! Records: every error and warning a run produces, with the step, the agents and a sentence.

use serde::Serialize;

macro_rules! kinds {
    ($($kind:ident $name:literal $sev:ident;)*) => {
        /// What a record is about.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
        pub enum RecordKind { $(#[doc = $name] $kind,)* }

        impl RecordKind {
            /// Every kind, in a fixed order.
            pub const ALL: &'static [RecordKind] = &[$(RecordKind::$kind,)*];

            /// The kebab-case name used in statistics and messages.
            pub fn name(self) -> &'static str {
                match self { $(RecordKind::$kind => $name,)* }
            }

            /// Error or warning.
            pub fn is_error(self) -> bool {
                match self { $(RecordKind::$kind => kinds!(@err $sev),)* }
            }
        }
    };
    (@err error) => { true };
    (@err warning) => { false };
}

kinds! {
    MoveConflict "move-conflict" error;
    MoveBlocked "move-blocked" error;
    MoveCollision "move-collision" error;
    GroupConflict "group-conflict" error;
    SwapConflict "swap-conflict" error;
    SwapTarget "swap-target" error;
    SwapShared "swap-shared" error;
    AttachConflict "attach-conflict" error;
    AttachRefused "attach-refused" warning;
    StateConflict "state-conflict" error;
    CircularPriority "circular-priority" warning;
    Saturation "saturation" warning;
    DivisionByZero "division-by-zero" error;
    NoExternalAgent "no-external-agent" error;
}

/// One record.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Record {
    /// The step (from 1).
    pub step: u64,
    /// The kind.
    pub kind: RecordKind,
    /// The agents involved: id and position at the time.
    pub agents: Vec<(u32, [i32; 3])>,
    /// What happened, in one sentence.
    pub message: String,
    /// The rules its agents executed in that step (file order, each once): what the
    /// viewer's log filters by. Not written to records files (the message names them
    /// where it matters).
    #[serde(skip_serializing)]
    pub rules: Vec<u32>,
}

impl Record {
    /// Error or warning.
    pub fn is_error(&self) -> bool {
        self.kind.is_error()
    }
}

impl std::fmt::Display for Record {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let sev = if self.is_error() { "error" } else { "warning" };
        write!(
            f,
            "{sev}[{}] step {}: {}",
            self.kind.name(),
            self.step,
            self.message
        )
    }
}
