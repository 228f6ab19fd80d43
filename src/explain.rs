//! `latticesim explain`: the long explanation of a diagnostic code, with an example that
//! gives it (and what it gives) and the example put right; without a code, the list of
//! codes. The text is `latticesim_compiler::explain`'s, the same as docs/language.md's.

use crate::output::{self, say};
use crate::Color;
use latticesim_compiler::explain;
use latticesim_grammar::Code;
use std::io::IsTerminal;
use std::process::ExitCode;

/// Runs `latticesim explain [CODE]`. Exit status: 0 shown, 2 no such code.
pub fn explain(code: Option<String>, color: Color) -> ExitCode {
    let Some(typed) = code else {
        let mut text = String::from("Diagnostic codes (latticesim explain CODE for one):\n");
        for c in Code::ALL {
            text += &format!("  {}  {:<38} {}\n", c.as_str(), c.slug(), c.title());
        }
        output::stdout(text.as_bytes());
        return ExitCode::SUCCESS;
    };
    let found = Code::parse(typed.trim()).or_else(|| explain::nearest(&typed));
    let Some(e) = found.and_then(explain::explanation) else {
        say!("error: `{typed}` is not a latticesim diagnostic code (`latticesim explain` lists them)");
        return ExitCode::from(2);
    };
    let color = crate::colour_on(color, std::io::stdout().is_terminal());
    output::stdout(explain::render(&e, color).as_bytes());
    ExitCode::SUCCESS
}
