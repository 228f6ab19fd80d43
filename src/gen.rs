//! `latticesim gen`: agents files for lines, blocks, random connected shapes and clouds.

use crate::agents_file;
use crate::output::{self, open_output, say};
use clap::ValueEnum;
use latticesim_runtime::shapes::{write_agents, GenOptions, Shape};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Clone, Copy, ValueEnum)]
enum ShapeArg {
    /// `--n` agents in a row along x.
    Line,
    /// A full rectangle (2D) or box (3D): `--width`, `--height` (and `--depth`).
    #[value(alias = "rect", alias = "box")]
    Block,
    /// A random connected polyomino (2D) or polycube (3D) of `--n` cells, grown from the
    /// origin (agent 0 stands there).
    #[value(alias = "polyomino", alias = "polycube")]
    Connected,
    /// `--n` cells drawn at random from a `--width` x `--height` (x `--depth`) box.
    Cloud,
}

/// What every generated agent gets besides its position; shared by `gen` and `sweep`.
#[derive(clap::Args)]
pub struct AgentOptions {
    /// 2 or 3.
    #[arg(long, default_value = "2", value_parser = ["2", "3"])]
    dim: String,
    /// State of every agent.
    #[arg(long)]
    state: Option<String>,
    /// State of agent 0 (the origin of a connected shape), e.g. a root.
    #[arg(long)]
    first_state: Option<String>,
    /// Give --first-state to the easternmost agent instead of agent 0 (a root whose row is
    /// free to the east).
    #[arg(long)]
    first_east: bool,
    /// Put unique ids 1..n, in random order, into this counter (e.g. C00); past 32767
    /// agents, run with 32-bit counters (`// latticesim: counters 32`, or `--counters 32`).
    #[arg(long)]
    ids: Option<String>,
    /// Add a universe line: the bounding box of the agents.
    #[arg(long)]
    universe: bool,
    /// Fill the holes of a 2D shape, so that it is simply connected.
    #[arg(long)]
    fill_holes: bool,
}

impl AgentOptions {
    /// True for 3D.
    pub fn three_d(&self) -> bool {
        self.dim == "3"
    }

    /// The generator's options for one seed, or a message for a bad `--ids`.
    pub fn gen_options(&self, seed: u64) -> Result<GenOptions, String> {
        Ok(GenOptions {
            three_d: self.three_d(),
            state: self.state.clone(),
            first_state: self.first_state.clone(),
            first_east: self.first_east,
            fill_holes: self.fill_holes,
            ids: self.ids.as_deref().map(parse_counter).transpose()?,
            universe: self.universe,
            seed,
        })
    }
}

/// The arguments of `latticesim gen`.
#[derive(clap::Args)]
pub struct GenArgs {
    /// The shape.
    #[arg(value_enum)]
    shape: ShapeArg,
    /// Number of agents (line, connected, cloud).
    #[arg(long, short)]
    n: Option<u32>,
    /// Width (block, cloud).
    #[arg(long)]
    width: Option<u32>,
    /// Height (block, cloud).
    #[arg(long)]
    height: Option<u32>,
    /// Depth (3D block, 3D cloud).
    #[arg(long, default_value_t = 1)]
    depth: u32,
    /// Seed of the random choices.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    agents: AgentOptions,
    /// Write here instead of standard output.
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn gen(a: GenArgs) -> ExitCode {
    let out_file = match a.out.as_deref().map(open_output).transpose() {
        Ok(f) => f,
        Err(c) => return c,
    };
    let need = |v: Option<u32>, name: &str| v.ok_or_else(|| format!("this shape needs --{name}"));
    let shape = match a.shape {
        ShapeArg::Line => need(a.n, "n").map(|n| Shape::Line { n }),
        ShapeArg::Block => need(a.width, "width")
            .and_then(|w| need(a.height, "height").map(|h| Shape::Block { w, h, d: a.depth })),
        ShapeArg::Connected => need(a.n, "n").map(|n| Shape::Connected { n }),
        ShapeArg::Cloud => need(a.n, "n").and_then(|n| {
            need(a.width, "width").and_then(|w| {
                need(a.height, "height").map(|h| Shape::Cloud {
                    n,
                    w,
                    h,
                    d: a.depth,
                })
            })
        }),
    };
    let opts = match a.agents.gen_options(a.seed) {
        Ok(o) => o,
        Err(e) => {
            say!("error: {e}");
            return ExitCode::from(2);
        }
    };
    if a.depth != 1 && !opts.three_d {
        // It was ignored: a 2D file where a 3D box was meant.
        say!("error: --depth {} is for 3D shapes: add --dim 3", a.depth);
        return ExitCode::from(2);
    }
    let shape = match shape {
        Ok(s) => s,
        Err(e) => {
            say!("error: {e}");
            return ExitCode::from(2);
        }
    };
    if let Some(k) = opts.ids {
        let n = match shape {
            Shape::Line { n } | Shape::Connected { n } | Shape::Cloud { n, .. } => n as u64,
            Shape::Block { w, h, d } => {
                w as u64 * h as u64 * if opts.three_d { d as u64 } else { 1 }
            }
        };
        let w = latticesim_vm::model::Width::W32;
        if n > w.max() as u64 {
            say!(
                "error: --ids C{k:02}: {n} agents need ids past {}, the most a counter holds",
                w.max()
            );
            return ExitCode::from(2);
        }
        if n > 32767 {
            say!("note: ids past 32767 need 32-bit counters: the rules file says `// latticesim: counters 32` (as examples/leader-election does), or run with `--counters 32`");
        }
    }
    let written = match out_file {
        Some(f) => {
            let path = f.path().to_path_buf();
            let packing = agents_file::Packing::of(&path);
            let mut w = match agents_file::Packed::new(f, packing) {
                Ok(w) => w,
                Err(e) => {
                    say!("error: cannot write `{}`: {e}", path.display());
                    return ExitCode::from(2);
                }
            };
            write_agents(&shape, &opts, &mut w).map(|r| {
                r.and_then(|()| w.finish())
                    .and_then(|f| f.commit())
                    .map_err(|e| format!("cannot write `{}`: {e}", path.display()))
            })
        }
        None => {
            let mut w = output::Stdout::new();
            write_agents(&shape, &opts, &mut w).map(|_| Ok(()))
        }
    };
    match written {
        Ok(Ok(())) => ExitCode::SUCCESS,
        Err(e) | Ok(Err(e)) => {
            say!("error: {e}");
            ExitCode::from(2)
        }
    }
}

/// The counter a name such as `C07` gives (C00 to C44, the most a dimension has); the one
/// parser of counter names in the command line.
pub fn parse_counter(s: &str) -> Result<u8, String> {
    let d = s
        .strip_prefix('C')
        .ok_or(format!("`{s}` is not a counter such as C00"))?;
    match d.parse::<u8>() {
        Ok(v) if d.len() == 2 && v < 45 => Ok(v),
        _ => Err(format!("`{s}` is not a counter such as C00")),
    }
}
