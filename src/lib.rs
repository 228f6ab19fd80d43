//! The `latticesim` command-line program as a library: reads files, calls the library
//! crates, prints. All I/O of the project lives here. `src/main.rs` calls [`main`]; the
//! Python package (`python/`) calls the same loading, writing, statistics and sweep code.

use clap::{Parser, Subcommand, ValueEnum};
use latticesim_compiler::lints::Lints;
use latticesim_compiler::{check_with, Checked, Dim, Input};
use output::say;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

pub mod agents_file;
pub mod alloc;
mod explain;
mod fmt;
pub mod fuzzing;
pub mod gen;
pub mod lsp;
pub mod merge;
pub mod output;
pub mod palette;
mod plot;
pub mod processor;
mod render;
pub mod run;
pub mod series;
mod serve;
pub mod set;
pub mod sweep;
pub mod table;

#[derive(Parser)]
#[command(
    name = "latticesim",
    version,
    about = "Simulator for synchronized distributed algorithms on 2D and 3D lattice agents"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, ValueEnum)]
enum Format {
    /// Rendered with source excerpts (stderr).
    Human,
    /// One JSON document (stdout).
    Json,
}

#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum Color {
    /// Colour when stderr is a terminal.
    Auto,
    /// Always colour.
    Always,
    /// Never colour.
    Never,
}

#[derive(Subcommand)]
enum Command {
    /// Run rules on agents, step by step, until quiescence or --max-steps.
    ///
    /// Exit status: 0 done, 1 errors in the input files, 2 usage or I/O failure, 3 stopped by
    /// --strict at an error record, 130 interrupted (Ctrl-C). --out and --stats are written
    /// in every case but 1 and 2 (and also when only another output failed, with 2); an
    /// output path that cannot be written is found before anything runs.
    Run(run::RunArgs),
    /// Generate an agents file: a line, a block, a random connected shape or a cloud.
    Gen(gen::GenArgs),
    /// Run rules over generated shapes of growing n and write CSV (and a plot) of the cost.
    Sweep(sweep::SweepArgs),
    /// Join the parts of a sharded sweep (`sweep --shard I/N`) into one table, in run order.
    ///
    /// Exit status: 0 written, 2 when a part cannot be read, parts disagree (other
    /// columns, a run twice) or the output cannot be written.
    Merge(merge::MergeArgs),
    /// Draw a step of a run as PNG or SVG, or a range of steps as an animated GIF.
    ///
    /// Exit status: 0 written, 1 errors in the input files, 2 usage or I/O failure.
    Render(render::RenderArgs),
    /// Serve the viewer and editor in the browser, on 127.0.0.1 (prints the URL).
    ///
    /// Exit status: 2 when the files cannot be read or the port cannot be opened; errors in
    /// the files are shown in the editor.
    Serve(serve::ServeArgs),
    /// Check a rules file (and an agents file) and report every problem.
    ///
    /// Exit status: 0 no errors (warnings allowed), 1 errors, 2 usage or I/O failure.
    Check {
        /// The rules file.
        rules: PathBuf,
        /// The agents file; it also decides the dimension.
        #[arg(long, short)]
        agents: Option<PathBuf>,
        /// The dimension, when no agents file decides it.
        #[arg(long, value_parser = ["2", "3"])]
        dim: Option<String>,
        /// Output format.
        #[arg(long, value_enum, default_value_t = Format::Human)]
        format: Format,
        /// Colour in human output.
        #[arg(long, value_enum, default_value_t = Color::Auto)]
        color: Color,
        /// When there are no errors, print the compiled bytecode to stdout.
        #[arg(long)]
        dump_bytecode: bool,
        #[command(flatten)]
        lints: LintArgs,
    },
    /// Explain a diagnostic code (`latticesim explain E302`), with an example that gives it
    /// and the example put right; without a code, list the codes.
    ///
    /// Exit status: 0 shown, 2 no such code.
    Explain {
        /// The code, e.g. E302 (also `e302`, `302` or `pattern-length`).
        code: Option<String>,
        /// Colour in the example's diagnostic.
        #[arg(long, value_enum, default_value_t = Color::Auto)]
        color: Color,
    },
    /// Write rules files in their canonical layout (comments kept), or check that they are.
    ///
    /// Exit status: 0 done (with --check: all formatted), 1 syntax errors (with --check: a
    /// file not formatted), 2 a file cannot be read or written.
    Fmt(fmt::FmtArgs),
    /// Run the language server for rules and agents files over standard input and output
    /// (for editors; see docs/editors.md).
    Lsp,
}

pub(crate) fn read(path: &PathBuf) -> Result<Vec<u8>, ExitCode> {
    std::fs::read(path).map_err(|e| {
        say!("error: cannot read `{}`: {e}", path.display());
        ExitCode::from(2)
    })
}

/// Lint levels on the command line (see docs/language.md, "Lint levels"): after the
/// rules file's `// latticesim:` directives.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct LintArgs {
    /// Do not say this warning: a code (W603), its name (idle-start-state) or `warnings`;
    /// may be given again.
    #[arg(long, value_name = "CODE")]
    pub allow: Vec<String>,
    /// Say this warning as a warning, whatever the rules file says; may be given again.
    #[arg(long, value_name = "CODE")]
    pub warn: Vec<String>,
    /// Make this warning an error (`--deny warnings`: every warning); may be given again.
    #[arg(long, value_name = "CODE")]
    pub deny: Vec<String>,
    /// Counters and numeric messages of 16 bits (the paper's, -32767..32767) or 32 (the
    /// extension, to ±2147483647, for unique ids past 32767 agents); wins over the rules
    /// file's `// latticesim: counters 32`.
    #[arg(long, value_name = "BITS", value_parser = ["16", "32"])]
    pub counters: Option<String>,
    /// Show at most N diagnostics of a file in full (default 200); the rest are counted
    /// per code on one line.
    #[arg(long, value_name = "N")]
    pub max_diagnostics: Option<usize>,
}

impl LintArgs {
    /// The levels (and width of counters), or a usage error said (exit 2).
    pub fn lints(&self) -> Result<Lints, ExitCode> {
        let counters = (self.counters.as_deref())
            .map(|b| (b.parse().unwrap_or(0), format!("`--counters {b}`")));
        let mut l = levels(&self.allow, &self.warn, &self.deny, counters).map_err(|e| {
            say!("error: {e}");
            ExitCode::from(2)
        })?;
        if let Some(n) = self.max_diagnostics {
            l.set_shown(n);
        }
        Ok(l)
    }
}

/// Lint levels (every `allow`, then `warn`, then `deny`) and the width of counters
/// (`counters`: the bits and where they were said, e.g. "`--counters 32`"), for the
/// command line and for Python's keywords; a message when one is not understood.
pub fn levels(
    allow: &[String],
    warn: &[String],
    deny: &[String],
    counters: Option<(u32, String)>,
) -> Result<Lints, String> {
    let mut l = Lints::from_flags(allow, warn, deny)?;
    if let Some((bits, origin)) = counters {
        let w = latticesim_vm::model::Width::from_bits(bits)
            .ok_or_else(|| format!("{origin}: use 16 (the paper's) or 32"))?;
        l.set_counters(w, origin);
    }
    Ok(l)
}

/// Checks a rules file and, when given, an agents file, each as (name, bytes), with lint
/// levels (after the rules file's own).
pub fn check_pair(
    rules: (&str, &[u8]),
    agents: Option<(&str, &[u8])>,
    dim: Option<Dim>,
    levels: &Lints,
) -> Checked {
    check_with(
        Input {
            name: rules.0,
            bytes: rules.1,
        },
        agents.map(|(name, bytes)| Input { name, bytes }),
        dim,
        levels,
    )
}

/// The diagnostics found but not listed, per file, for JSON documents.
pub(crate) fn not_shown_json(c: &Checked) -> serde_json::Value {
    c.not_shown
        .iter()
        .map(|n| {
            serde_json::json!({
                "file": c.sources.name(n.file),
                "errors": n.errors,
                "warnings": n.warnings,
                "codes": n.codes.iter().map(|(c, k)| (c.as_str().to_string(), serde_json::Value::from(*k))).collect::<serde_json::Map<_, _>>(),
            })
        })
        .collect()
}

fn summary(c: &Checked, agents: bool) -> String {
    let rules = c.sources.name(latticesim_grammar::FileId(0));
    let mut s = format!(
        "{rules}: {} rule{}, {} ({})",
        c.rule_count,
        if c.rule_count == 1 { "" } else { "s" },
        c.dim.dim.name(),
        c.dim.why
    );
    if agents {
        let name = c.sources.name(latticesim_grammar::FileId(1));
        s += &format!(
            "; {name}: {} agent{}",
            c.agent_count,
            if c.agent_count == 1 { "" } else { "s" }
        );
    }
    let (e, w) = (c.errors(), c.warnings());
    s += &format!(
        "; {e} error{}, {w} warning{}",
        if e == 1 { "" } else { "s" },
        if w == 1 { "" } else { "s" }
    );
    s
}

fn run_check(
    rules: PathBuf,
    agents: Option<PathBuf>,
    dim: Option<String>,
    (format, color): (Format, Color),
    dump_bytecode: bool,
    levels: &Lints,
) -> ExitCode {
    let rules_bytes = match read(&rules) {
        Ok(b) => b,
        Err(c) => return c,
    };
    let dim = dim.map(|d| if d == "3" { Dim::Three } else { Dim::Two });
    let rules_name = rules.display().to_string();
    // What the checker could not do, for a file too large for it.
    let mut note = None;
    let checked = match (&agents, dim) {
        // The fast path of agents files, unless --dim is to be reconciled with the file's.
        (Some(path), None) => {
            let name = path.display().to_string();
            let threads = run::io_threads(None);
            match agents_file::load(
                (&rules_name, &rules_bytes),
                &name,
                agents_file::Source::File(path),
                threads,
                levels,
            ) {
                Ok(l) => {
                    note = l.note;
                    l.checked
                }
                Err(e) => {
                    say!("error: cannot read `{name}`: {e}");
                    return ExitCode::from(2);
                }
            }
        }
        _ => {
            let agents_bytes = match agents.as_deref().map(agents_file::read_all).transpose() {
                Ok(b) => b,
                Err(c) => return c,
            };
            let agents_name = agents.as_ref().map(|p| p.display().to_string());
            check_pair(
                (&rules_name, &rules_bytes),
                agents_name.as_deref().zip(agents_bytes.as_deref()),
                dim,
                levels,
            )
        }
    };
    match format {
        Format::Human => {
            let mut text = checked.render(colour(color));
            if let Some(n) = &note {
                text += n;
                text.push('\n');
            }
            text += &summary(&checked, agents.is_some());
            text.push('\n');
            output::stderr(&text);
        }
        Format::Json => {
            let doc = serde_json::json!({
                "dimension": checked.dim.dim.name(),
                "dimension_reason": checked.dim.why,
                "rules": checked.rule_count,
                "agents": agents.as_ref().map(|_| checked.agent_count),
                "errors": checked.errors(),
                "warnings": checked.warnings(),
                "diagnostics": latticesim_compiler::diagnostics::to_json(&checked.diags, &checked.sources),
                "not_shown": not_shown_json(&checked),
                "not_checked": note,
            });
            let mut text = serde_json::to_string_pretty(&doc).expect("JSON of plain data");
            text.push('\n');
            output::stdout(text.as_bytes());
        }
    }
    if checked.errors() > 0 || note.is_some() {
        return ExitCode::from(1);
    }
    if dump_bytecode {
        if let Some(p) = &checked.rules {
            output::stdout(latticesim_compiler::lower(p).disassemble().as_bytes());
        }
    }
    ExitCode::SUCCESS
}

/// Whether to colour what goes to standard error.
pub(crate) fn colour(color: Color) -> bool {
    colour_on(color, std::io::stderr().is_terminal())
}

/// Whether to colour output to a stream that is (or not) a terminal: `--color`, else a
/// terminal without `NO_COLOR`.
pub(crate) fn colour_on(color: Color, terminal: bool) -> bool {
    match color {
        Color::Always => true,
        Color::Never => false,
        Color::Auto => terminal && std::env::var_os("NO_COLOR").is_none(),
    }
}

/// The threads to use when `requested` (default: every core) are asked for work that can
/// keep at most `most` busy (`why_most` says why, for the note): never more than the
/// machine's cores nor than `most`; a note says so when fewer than asked are used.
pub fn threads(requested: Option<usize>, most: usize, why_most: &str) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let used = requested.unwrap_or(cores).clamp(1, cores.min(most.max(1)));
    if let Some(r) = requested.filter(|&r| r > used) {
        let why = if used == cores && cores <= most {
            format!(
                "this machine has {cores} core{}",
                if cores == 1 { "" } else { "s" }
            )
        } else {
            why_most.to_string()
        };
        say!("note: --threads {r}: using {used}, because {why}");
    }
    used
}

/// The threads of an engine on `agents` agents (see [`threads`]).
pub fn engine_threads(requested: Option<usize>, agents: usize) -> usize {
    let per = latticesim_runtime::AGENTS_PER_THREAD;
    let most = agents.div_ceil(per);
    let why = format!(
        "{agents} agent{} keep at most {} busy (one per {per} agents)",
        if agents == 1 { "" } else { "s" },
        most.max(1)
    );
    threads(requested, most, &why)
}

/// `n` and a noun, plural when `n` is not 1 ("1 rule", "2 rules").
pub fn plural(n: usize, noun: &str) -> String {
    format!("{n} {noun}{}", if n == 1 { "" } else { "s" })
}

/// How many records of one kind are printed before the rest are only counted.
pub(crate) const RECORDS_SHOWN_PER_KIND: u64 = 5;

/// The command line: parses the arguments, runs the command, gives its exit status.
pub fn main() -> ExitCode {
    if let Some(text) = processor::check() {
        eprintln!("latticesim: {text}");
        return ExitCode::from(2);
    }
    output::on_interrupt();
    let cli = Cli::parse();
    let code = match cli.command {
        Command::Check {
            rules,
            agents,
            dim,
            format,
            color,
            dump_bytecode,
            lints,
        } => match lints.lints() {
            Ok(l) => run_check(rules, agents, dim, (format, color), dump_bytecode, &l),
            Err(c) => c,
        },
        Command::Run(args) => run::run(args),
        Command::Gen(args) => gen::gen(args),
        Command::Sweep(args) => sweep::sweep(args),
        Command::Merge(args) => merge::merge(args),
        Command::Render(args) => render::render(args),
        Command::Serve(args) => serve::serve(args),
        Command::Explain { code, color } => explain::explain(code, color),
        Command::Fmt(args) => fmt::fmt(args),
        Command::Lsp => lsp::run(),
    };
    output::finish(code)
}
