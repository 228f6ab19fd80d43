//! `latticesim fmt`: rules files in their canonical layout (see
//! `latticesim_grammar::format`), rewritten in place, checked with `--check`, or read from
//! standard input and written to standard output with `-`.

use crate::output::{self, say};
use crate::Color;
use clap::Args;
use std::io::Read;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `latticesim fmt`.
#[derive(Args)]
pub struct FmtArgs {
    /// Rules files to format in place (`-`: standard input to standard output).
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Change nothing: list the files that are not in the canonical layout, with the first
    /// line that differs, and exit 1 if there are any.
    #[arg(long)]
    check: bool,
    /// The dimension, for `T` terms whose offset and state could be read either way.
    #[arg(long, value_parser = ["2", "3"])]
    dim: Option<String>,
    /// Colour in diagnostics.
    #[arg(long, value_enum, default_value_t = Color::Auto)]
    color: Color,
}

/// The first line where two texts differ: its number and both versions (a line that
/// differs only in its CRLF end says so).
fn first_difference(a: &str, b: &str) -> (usize, String, String) {
    let mut la = a.split('\n');
    let mut lb = b.split('\n');
    let mut n = 1;
    loop {
        match (la.next(), lb.next()) {
            (Some(x), Some(y)) if x == y => n += 1,
            (x, y) => {
                let show = |l: Option<&str>| match l {
                    None => "(end of file)".to_string(),
                    Some(l) if l.ends_with('\r') => format!("{} (CRLF)", l.trim_end_matches('\r')),
                    Some(l) => l.to_string(),
                };
                return (n, show(x), show(y));
            }
        }
    }
}

/// Runs `latticesim fmt`. Exit status: 0 done (or, with --check, every file formatted), 1
/// a file has syntax errors (or, with --check, is not formatted), 2 a file cannot be read
/// or written.
pub fn fmt(args: FmtArgs) -> ExitCode {
    let hint = args.dim.as_deref().map(|d| if d == "3" { 3 } else { 2 });
    let mut status = 0u8;
    for path in &args.files {
        let stdin = path.as_os_str() == "-";
        let name = if stdin {
            "<stdin>".to_string()
        } else {
            path.display().to_string()
        };
        let bytes = if stdin {
            let mut b = Vec::new();
            if let Err(e) = std::io::stdin().read_to_end(&mut b) {
                say!("error: cannot read standard input: {e}");
                return ExitCode::from(2);
            }
            b
        } else {
            match crate::read(path) {
                Ok(b) => b,
                Err(c) => return c,
            }
        };
        let Ok(text) = String::from_utf8(bytes.clone()) else {
            let c = crate::check_pair((&name, &bytes), None, None, &Default::default());
            output::stderr(&c.render(crate::colour(args.color)));
            status = status.max(1);
            continue;
        };
        let formatted = match latticesim_grammar::format::format_rules(&text, hint) {
            Ok(f) => f,
            Err(_) => {
                // The checker's rendering of the same file shows every syntax error.
                let mut c = crate::check_pair((&name, &bytes), None, None, &Default::default());
                c.diags.retain(|d| d.is_error());
                output::stderr(&c.render(crate::colour(args.color)));
                say!("{name}: not formatted: it has syntax errors");
                status = status.max(1);
                continue;
            }
        };
        if stdin && !args.check {
            output::stdout(formatted.as_bytes());
        }
        if formatted == text {
            continue;
        }
        if args.check {
            let (n, was, will) = first_difference(&text, &formatted);
            say!(
                "{name}:{n}: not in the canonical layout\n  is:        {was}\n  would be:  {will}"
            );
            status = status.max(1);
        } else if !stdin {
            let f = match output::open_output(path) {
                Ok(f) => f,
                Err(c) => return c,
            };
            if let Ok(meta) = std::fs::metadata(path) {
                let _ = f.set_permissions(meta.permissions());
            }
            if let Err(c) = output::write_output(f, formatted.as_bytes()) {
                return c;
            }
        }
    }
    ExitCode::from(status)
}
