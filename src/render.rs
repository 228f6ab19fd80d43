//! `latticesim render`: a frame (PNG or SVG) or an animation (GIF) of a run, for papers
//! and talks. Agents are squares (2D) or isometric cubes (3D) in their state's colour
//! ([`state_colour`]), bonds are bars between attached agents, a bounded universe is
//! outlined. Every format carries the step and a legend of the states on the right.

use crate::output::{open_output, say, write_output};
use crate::palette::{hex, Palette};
use crate::run::load;
use crate::{colour, Color};
use latticesim_runtime::{Engine, Lattice, Options};
use latticesim_vm::model::{Dim, Dir};
use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `latticesim render`.
#[derive(clap::Args)]
pub struct RenderArgs {
    /// The rules file.
    rules: PathBuf,
    #[command(flatten)]
    lints: crate::LintArgs,
    /// The agents file.
    agents: PathBuf,
    /// Draw the configuration after this many steps (0: the agents file as it is).
    #[arg(long, conflicts_with = "steps")]
    step: Option<u64>,
    /// Draw every step from A to B (inclusive) as an animation, e.g. `0..40` (GIF only).
    #[arg(long, value_name = "A..B")]
    steps: Option<String>,
    /// The image to write: .png or .svg for one frame, .gif for one or more.
    #[arg(long)]
    out: PathBuf,
    /// Pixels per lattice cell (made smaller if the image would be wider than 8192 pixels).
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..=256))]
    cell: u32,
    /// Colour the agents by this counter (e.g. C00) on a continuous scale, from its
    /// smallest to its largest value in the frames drawn, instead of by state.
    #[arg(long, value_name = "Cnn")]
    color_by: Option<String>,
    /// The colours of the states: a file of `#rrggbb` lines (the colours handed out in
    /// order of first appearance) and `STATE #rrggbb` lines (a state's own colour).
    #[arg(long, value_name = "FILE")]
    palette: Option<PathBuf>,
    /// Which comes first in a step (as `run --order`).
    #[arg(long, value_enum, default_value_t = crate::run::OrderArg::ActionsFirst)]
    order: crate::run::OrderArg,
    /// Rules without a move or swap act before the rules with one (as `run --static-first`).
    #[arg(long)]
    static_first: bool,
    /// Frames per second of an animation.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=100))]
    fps: u32,
    /// Colour in diagnostics.
    #[arg(long, value_enum, default_value_t = Color::Auto)]
    color: Color,
}

/// The most frames an animation may have.
const MAX_FRAMES: u64 = 2000;
/// The most agents times frames an animation may hold.
const MAX_AGENT_FRAMES: u64 = 50_000_000;
/// The widest or highest image, in pixels.
const MAX_SIDE: u64 = 8192;

fn shade(c: [u8; 3], f: f64) -> [u8; 3] {
    c.map(|v| (v as f64 * f).round() as u8)
}

const BACKGROUND: [u8; 3] = [255, 255, 255];
const BOND: [u8; 3] = [40, 40, 40];
const WALL: [u8; 3] = [150, 150, 150];

/// What one frame shows.
struct Frame {
    pos: Vec<[i32; 3]>,
    state: Vec<[u8; 5]>,
    /// With `--color-by`: each agent's value of that counter.
    value: Vec<i32>,
    /// Bonds as pairs of agent indices, each once.
    bonds: Vec<(usize, usize)>,
}

impl Frame {
    fn of(lat: &Lattice, counter: Option<u8>) -> Frame {
        let mut bonds = Vec::new();
        for a in 0..lat.len() {
            for d in Dir::ALL.iter().take(lat.dim.dirs()) {
                if lat.attach[a] & (1 << d.index()) != 0 {
                    if let Some(b) = lat.neighbour(a as u32, *d).filter(|&b| b as usize > a) {
                        bonds.push((a, b as usize));
                    }
                }
            }
        }
        Frame {
            pos: lat.pos.clone(),
            state: lat.state.clone(),
            value: counter.map_or(Vec::new(), |c| {
                (0..lat.len()).map(|a| lat.counter(a as u32, c)).collect()
            }),
            bonds,
        }
    }
}

/// A filled convex polygon, a bar or an outline, in image coordinates.
enum Shape {
    Poly(Vec<(f64, f64)>, [u8; 3]),
    Line((f64, f64), (f64, f64), f64, [u8; 3]),
}

/// How cells map to the picture.
struct View {
    three_d: bool,
    cell: f64,
    /// Lattice bounds drawn: low and high corner.
    lo: [i64; 3],
    hi: [i64; 3],
    /// Offset added to projected coordinates, and the image size.
    origin: (f64, f64),
    size: (u32, u32),
    universe: Option<[(i64, i64); 3]>,
}

impl View {
    /// Projects a lattice point (cell corner coordinates) to the image.
    fn at(&self, x: f64, y: f64, z: f64) -> (f64, f64) {
        let (u, v) = if self.three_d {
            ((x - y) * self.cell, ((x + y) * 0.5 - z) * self.cell)
        } else {
            (x * self.cell, -y * self.cell)
        };
        (u + self.origin.0, v + self.origin.1)
    }

    fn new(frames: &[Frame], dim: Dim, universe: Option<[(i64, i64); 3]>, cell: u32) -> View {
        let mut lo = [i64::MAX; 3];
        let mut hi = [i64::MIN; 3];
        for p in frames.iter().flat_map(|f| &f.pos) {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k] as i64);
                hi[k] = hi[k].max(p[k] as i64);
            }
        }
        if lo[0] == i64::MAX {
            (lo, hi) = ([0; 3], [0; 3]);
        }
        // A bounded universe not much larger than the agents is drawn whole.
        let universe = universe
            .filter(|u| (0..dim.coords()).all(|k| u[k].1 - u[k].0 <= 4 * (hi[k] - lo[k] + 1) + 16));
        if let Some(u) = universe {
            for k in 0..dim.coords() {
                lo[k] = lo[k].min(u[k].0);
                hi[k] = hi[k].max(u[k].1);
            }
        }
        let three_d = dim == Dim::Three;
        let mut view = View {
            three_d,
            cell: cell as f64,
            lo,
            hi,
            origin: (0.0, 0.0),
            size: (1, 1),
            universe,
        };
        // Fit the cell size to the largest image, then place the drawing with a margin.
        let extent = |v: &View| {
            let corners = (0..8).map(|i| {
                let c = |k: usize| if i & (1 << k) != 0 { v.hi[k] + 1 } else { v.lo[k] } as f64;
                v.at(c(0), c(1), c(2))
            });
            corners.fold((f64::MAX, f64::MAX, f64::MIN, f64::MIN), |b, (x, y)| {
                (b.0.min(x), b.1.min(y), b.2.max(x), b.3.max(y))
            })
        };
        let (x0, y0, x1, y1) = extent(&view);
        let widest = (x1 - x0).max(y1 - y0) / view.cell + 2.0;
        view.cell = view.cell.min(MAX_SIDE as f64 / widest).max(1.0).floor();
        let (x0, y0, x1, y1) = extent(&view);
        let margin = view.cell;
        view.origin = (margin - x0, margin - y0);
        view.size = (
            (x1 - x0 + 2.0 * margin).ceil() as u32,
            (y1 - y0 + 2.0 * margin).ceil() as u32,
        );
        view
    }

    /// The shapes of a frame, back to front.
    fn shapes(&self, f: &Frame, key: &Key) -> Vec<Shape> {
        let mut out = Vec::new();
        if let Some(u) = self.universe {
            let (x0, y0, x1, y1) = (
                u[0].0 as f64,
                u[1].0 as f64,
                u[0].1 as f64 + 1.0,
                u[1].1 as f64 + 1.0,
            );
            let z = if self.three_d { u[2].0 as f64 } else { 0.0 };
            let ring = [(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)];
            for w in ring.windows(2) {
                let (a, b) = (self.at(w[0].0, w[0].1, z), self.at(w[1].0, w[1].1, z));
                out.push(Shape::Line(a, b, 1.0, WALL));
            }
        }
        let centre = |p: [i32; 3]| {
            let (x, y, z) = (p[0] as f64 + 0.5, p[1] as f64 + 0.5, p[2] as f64);
            self.at(x, y, if self.three_d { z + 1.0 } else { 0.0 })
        };
        let bar = (self.cell / 5.0).max(1.0);
        if self.three_d {
            // Painter's order: far (small x + y, low z) first.
            let mut order: Vec<usize> = (0..f.pos.len()).collect();
            order.sort_by_key(|&a| {
                let p = f.pos[a];
                (p[0] as i64 + p[1] as i64, p[2], p[0])
            });
            for a in order {
                let [x, y, z] = f.pos[a].map(|c| c as f64);
                let c = key.colour(f, a);
                let q = |pts: [(f64, f64, f64); 4]| pts.map(|(x, y, z)| self.at(x, y, z)).to_vec();
                out.push(Shape::Poly(
                    q([
                        (x + 1.0, y, z),
                        (x + 1.0, y + 1.0, z),
                        (x + 1.0, y + 1.0, z + 1.0),
                        (x + 1.0, y, z + 1.0),
                    ]),
                    shade(c, 0.8),
                ));
                out.push(Shape::Poly(
                    q([
                        (x, y + 1.0, z),
                        (x + 1.0, y + 1.0, z),
                        (x + 1.0, y + 1.0, z + 1.0),
                        (x, y + 1.0, z + 1.0),
                    ]),
                    shade(c, 0.65),
                ));
                out.push(Shape::Poly(
                    q([
                        (x, y, z + 1.0),
                        (x + 1.0, y, z + 1.0),
                        (x + 1.0, y + 1.0, z + 1.0),
                        (x, y + 1.0, z + 1.0),
                    ]),
                    c,
                ));
            }
        } else {
            let inset = if self.cell >= 4.0 {
                1.0 / self.cell
            } else {
                0.0
            };
            for (a, p) in f.pos.iter().enumerate() {
                let (x, y) = (p[0] as f64, p[1] as f64);
                let c = key.colour(f, a);
                let sq = |d: f64| {
                    vec![
                        self.at(x + d, y + d, 0.0),
                        self.at(x + 1.0 - d, y + d, 0.0),
                        self.at(x + 1.0 - d, y + 1.0 - d, 0.0),
                        self.at(x + d, y + 1.0 - d, 0.0),
                    ]
                };
                out.push(Shape::Poly(sq(0.0), shade(c, 0.7)));
                out.push(Shape::Poly(sq(inset), c));
            }
        }
        for &(a, b) in &f.bonds {
            out.push(Shape::Line(centre(f.pos[a]), centre(f.pos[b]), bar, BOND));
        }
        out
    }
}

/// Rasterises shapes into an RGB image.
fn raster(view: &View, shapes: &[Shape]) -> Vec<u8> {
    let (w, h) = (view.size.0 as usize, view.size.1 as usize);
    let mut img = BACKGROUND.repeat(w * h);
    let mut fill = |pts: &[(f64, f64)], c: [u8; 3]| {
        // Scanline fill of a convex polygon, sampling pixel centres.
        let ys = pts.iter().map(|p| p.1);
        let (top, bottom) = ys.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
        let (r0, r1) = (
            (top - 0.5).ceil().max(0.0) as usize,
            ((bottom - 0.5).floor() as i64).min(h as i64 - 1),
        );
        for row in r0 as i64..=r1 {
            let yc = row as f64 + 0.5;
            let (mut l, mut r) = (f64::MAX, f64::MIN);
            for i in 0..pts.len() {
                let (a, b) = (pts[i], pts[(i + 1) % pts.len()]);
                if (a.1 <= yc && b.1 > yc) || (b.1 <= yc && a.1 > yc) {
                    let x = a.0 + (yc - a.1) / (b.1 - a.1) * (b.0 - a.0);
                    (l, r) = (l.min(x), r.max(x));
                }
            }
            if l > r {
                continue;
            }
            let (c0, c1) = (
                (l - 0.5).ceil().max(0.0) as usize,
                ((r - 0.5).floor() as i64).min(w as i64 - 1),
            );
            for col in c0 as i64..=c1 {
                let i = (row as usize * w + col as usize) * 3;
                img[i..i + 3].copy_from_slice(&c);
            }
        }
    };
    for s in shapes {
        match s {
            Shape::Poly(pts, c) => fill(pts, *c),
            Shape::Line(a, b, width, c) => {
                // A bar: the segment widened by `width` across its direction.
                let (dx, dy) = (b.0 - a.0, b.1 - a.1);
                let len = (dx * dx + dy * dy).sqrt().max(1e-9);
                let (nx, ny) = (-dy / len * width / 2.0, dx / len * width / 2.0);
                let pts = [
                    (a.0 + nx, a.1 + ny),
                    (b.0 + nx, b.1 + ny),
                    (b.0 - nx, b.1 - ny),
                    (a.0 - nx, a.1 - ny),
                ];
                fill(&pts, *c);
            }
        }
    }
    img
}

/// The width of the legend beside a picture, in pixels.
const LEGEND_W: u32 = 140;

/// How agents are coloured, and the legend that says so: by state (each state its
/// colour, [`state_colour`]), or by a counter on a continuous scale from its smallest to
/// its largest value in the frames drawn.
enum Key {
    /// The states drawn, in order of first appearance, and their colours.
    States(Vec<[u8; 5]>, Palette),
    Counter {
        name: String,
        lo: i32,
        hi: i32,
    },
}

/// The scale of `--color-by`: viridis, from dark purple (smallest) to yellow (largest),
/// as five stops interpolated in RGB.
const SCALE: [[u8; 3]; 5] = [
    [68, 1, 84],
    [59, 82, 139],
    [33, 145, 140],
    [94, 201, 98],
    [253, 231, 37],
];

/// The scale's colour at `t` in 0..=1.
fn scale(t: f64) -> [u8; 3] {
    let t = t.clamp(0.0, 1.0) * (SCALE.len() - 1) as f64;
    let (i, f) = (
        (t.floor() as usize).min(SCALE.len() - 2),
        t - t.floor().min((SCALE.len() - 2) as f64),
    );
    let (a, b) = (SCALE[i], SCALE[i + 1]);
    [0, 1, 2].map(|k| (a[k] as f64 + (b[k] as f64 - a[k] as f64) * f).round() as u8)
}

/// Height of the colour bar of a counter's legend.
const BAR_H: u32 = 120;

impl Key {
    fn colour(&self, f: &Frame, a: usize) -> [u8; 3] {
        match self {
            Key::States(_, p) => p.get(&f.state[a]),
            Key::Counter { lo, hi, .. } => {
                let span = (*hi as f64 - *lo as f64).max(1.0);
                scale((f.value[a] as f64 - *lo as f64) / span)
            }
        }
    }

    /// The height the legend needs.
    fn height(&self) -> u32 {
        match self {
            Key::States(states, _) => 24 + 18 * states.len() as u32,
            Key::Counter { .. } => 40 + BAR_H + 20,
        }
    }

    /// The legend's SVG elements, from `x`: the step, then a swatch and the name per
    /// state, or the counter's name and its colour bar from the largest value (top) to
    /// the smallest.
    fn legend(&self, s: &mut String, x: u32, step: u64) {
        let _ = writeln!(
            s,
            "<text x=\"{x}\" y=\"16\" font-family=\"sans-serif\" font-size=\"12\">step {step}</text>"
        );
        let (states, palette) = match self {
            Key::States(states, p) => (states, p),
            Key::Counter { name, lo, hi } => {
                let _ = writeln!(
                    s,
                    "<text x=\"{x}\" y=\"36\" font-family=\"monospace\" font-size=\"12\">{name}</text>"
                );
                for i in 0..BAR_H {
                    let c = scale(1.0 - i as f64 / (BAR_H - 1) as f64);
                    let _ = writeln!(
                        s,
                        "<rect x=\"{x}\" y=\"{}\" width=\"14\" height=\"1\" fill=\"{}\"/>",
                        44 + i,
                        hex(c)
                    );
                }
                for (v, y) in [(hi, 44 + 10), (lo, 44 + BAR_H)] {
                    let _ = writeln!(
                        s,
                        "<text x=\"{}\" y=\"{y}\" font-family=\"sans-serif\" font-size=\"12\">{v}</text>",
                        x + 20
                    );
                }
                return;
            }
        };
        for (i, st) in states.iter().enumerate() {
            let y = 24 + 18 * i as u32;
            let name: String = String::from_utf8_lossy(st)
                .chars()
                .map(|c| match c {
                    '<' => '‹',
                    '>' => '›',
                    '&' => '+',
                    c => c,
                })
                .collect();
            let _ = writeln!(
                s,
                "<rect x=\"{x}\" y=\"{y}\" width=\"14\" height=\"14\" fill=\"{}\"/><text x=\"{}\" y=\"{}\" font-family=\"monospace\" font-size=\"12\">{name}</text>",
                hex(palette.get(st)),
                x + 20,
                y + 12
            );
        }
    }
}

fn svg_head(w: u32, h: u32) -> String {
    format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\">\n<rect width=\"{w}\" height=\"{h}\" fill=\"white\"/>\n"
    )
}

/// The frame as SVG, with the legend on the right.
fn svg(view: &View, shapes: &[Shape], key: &Key, step: u64) -> String {
    let (w, h) = (view.size.0 + LEGEND_W, view.size.1.max(key.height()));
    let mut s = svg_head(w, h);
    for sh in shapes {
        match sh {
            Shape::Poly(pts, c) => {
                let p: Vec<String> = pts.iter().map(|(x, y)| format!("{x:.2},{y:.2}")).collect();
                let _ = writeln!(
                    s,
                    "<polygon points=\"{}\" fill=\"{}\"/>",
                    p.join(" "),
                    hex(*c)
                );
            }
            Shape::Line(a, b, width, c) => {
                let _ = writeln!(
                    s,
                    "<line x1=\"{:.2}\" y1=\"{:.2}\" x2=\"{:.2}\" y2=\"{:.2}\" stroke=\"{}\" stroke-width=\"{width:.2}\"/>",
                    a.0, a.1, b.0, b.1, hex(*c)
                );
            }
        }
    }
    key.legend(&mut s, view.size.0 + 10, step);
    s.push_str("</svg>\n");
    s
}

/// Pictures with the legend beside them, as PNG and GIF write them: the legend is the
/// SVG's, drawn with resvg in the system's fonts.
struct Legended<'a> {
    key: &'a Key,
    opt: resvg::usvg::Options<'static>,
    /// The size of the whole image.
    size: (u32, u32),
}

impl<'a> Legended<'a> {
    fn new(view: &View, key: &'a Key) -> Result<Legended<'a>, String> {
        Ok(Legended {
            key,
            opt: crate::plot::svg_options()?,
            size: (view.size.0 + LEGEND_W, view.size.1.max(key.height())),
        })
    }

    /// The picture `rgb` (of `view`'s size) with the legend of step `step` on its right,
    /// padded with white below when the legend is taller: RGB rows of `self.size`.
    fn image(&self, view: &View, rgb: &[u8], step: u64) -> Result<Vec<u8>, String> {
        let (w, h) = self.size;
        let mut s = svg_head(LEGEND_W, h);
        self.key.legend(&mut s, 10, step);
        s.push_str("</svg>\n");
        let tree = resvg::usvg::Tree::from_str(&s, &self.opt).map_err(|e| e.to_string())?;
        let mut pix = resvg::tiny_skia::Pixmap::new(LEGEND_W, h).ok_or("an empty legend")?;
        pix.fill(resvg::tiny_skia::Color::WHITE);
        resvg::render(
            &tree,
            resvg::tiny_skia::Transform::identity(),
            &mut pix.as_mut(),
        );
        let (vw, vh) = (view.size.0 as usize, view.size.1 as usize);
        let mut out = Vec::with_capacity(w as usize * h as usize * 3);
        for y in 0..h as usize {
            match rgb.get(y * vw * 3..(y + 1) * vw * 3).filter(|_| y < vh) {
                Some(row) => out.extend_from_slice(row),
                None => out.resize(out.len() + vw * 3, 255),
            }
            // The legend is opaque (on white): its premultiplied RGBA is its RGB.
            let l = &pix.data()[y * LEGEND_W as usize * 4..(y + 1) * LEGEND_W as usize * 4];
            out.extend(l.chunks(4).flat_map(|p| [p[0], p[1], p[2]]));
        }
        Ok(out)
    }
}

fn png(size: (u32, u32), rgb: &[u8]) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let mut enc = png::Encoder::new(&mut out, size.0, size.1);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header().map_err(|e| e.to_string())?;
    w.write_image_data(rgb).map_err(|e| e.to_string())?;
    w.finish().map_err(|e| e.to_string())?;
    Ok(out)
}

/// The frames (of steps `first`, `first + 1`, ...) as an animated GIF, each with the
/// legend and its step, rasterised only when it is encoded (one frame in memory at a time).
fn gif(
    view: &View,
    frames: &[Frame],
    lg: &Legended,
    (first, fps): (u64, u32),
) -> Result<Vec<u8>, String> {
    let (w, h) = lg.size;
    if w > u16::MAX as u32 || h > u16::MAX as u32 {
        return Err(format!(
            "a GIF is at most 65535 pixels a side; this one is {w} x {h}"
        ));
    }
    let mut out = Vec::new();
    {
        let mut enc =
            gif::Encoder::new(&mut out, w as u16, h as u16, &[]).map_err(|e| e.to_string())?;
        enc.set_repeat(gif::Repeat::Infinite)
            .map_err(|e| e.to_string())?;
        for (i, frame) in frames.iter().enumerate() {
            let rgb = lg.image(
                view,
                &raster(view, &view.shapes(frame, lg.key)),
                first + i as u64,
            )?;
            let mut f = gif::Frame::from_rgb_speed(w as u16, h as u16, &rgb, 10);
            f.delay = (100 / fps).max(1) as u16;
            enc.write_frame(&f).map_err(|e| e.to_string())?;
        }
    }
    Ok(out)
}

/// The counter `Cnn` names, when the lattice (of `nc` counters) has it.
fn counter_of(s: &str, nc: usize) -> Result<u8, String> {
    crate::gen::parse_counter(s)
        .ok()
        .filter(|&c| (c as usize) < nc)
        .ok_or_else(|| format!("`{s}`: name a counter of the run, C00 to C{:02}", nc - 1))
}

/// Parses `A..B` (inclusive).
fn range(s: &str) -> Option<(u64, u64)> {
    let (a, b) = s.split_once("..")?;
    let (a, b) = (a.trim().parse().ok()?, b.trim().parse().ok()?);
    (a <= b).then_some((a, b))
}

/// The steps asked for (`--step N` or `--steps A..B`), when the output's extension
/// `ext` can hold them.
fn asked(args: &RenderArgs, ext: Option<&str>) -> Result<(u64, u64), ExitCode> {
    let (first, last) = match (&args.steps, args.step) {
        (Some(s), _) => match range(s) {
            Some(r) if r.1 - r.0 < MAX_FRAMES => r,
            Some(_) => {
                say!("error: --steps {s}: at most {MAX_FRAMES} frames");
                return Err(ExitCode::from(2));
            }
            None => {
                say!("error: --steps {s}: expected A..B with A <= B, e.g. 0..40");
                return Err(ExitCode::from(2));
            }
        },
        (None, n) => (n.unwrap_or(0), n.unwrap_or(0)),
    };
    match (ext, first == last) {
        (Some("png" | "svg"), true) | (Some("gif"), _) => {}
        (Some("png" | "svg"), false) => {
            say!(
                "error: an animation (--steps) is written as .gif, not `{}`",
                args.out.display()
            );
            return Err(ExitCode::from(2));
        }
        _ => {
            say!(
                "error: `{}`: the image must end in .png, .svg or .gif",
                args.out.display()
            );
            return Err(ExitCode::from(2));
        }
    }
    Ok((first, last))
}

/// Pictures of a run, frame by frame (configurations of consecutive steps), to encode as
/// one picture (SVG, PNG: the first frame) or an animation (GIF): for `latticesim render`
/// and the viewer's exports.
pub(crate) struct Film {
    frames: Vec<Frame>,
    states: BTreeSet<[u8; 5]>,
    dim: Dim,
    universe: Option<[(i64, i64); 3]>,
    counter: Option<u8>,
}

/// The formats a [`Film`] is encoded in.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Format {
    Svg,
    Png,
    Gif,
}

impl Format {
    /// From a file's extension or a name (`svg`, `png`, `gif`).
    pub(crate) fn of(name: &str) -> Option<Format> {
        match name.to_ascii_lowercase().as_str() {
            "svg" => Some(Format::Svg),
            "png" => Some(Format::Png),
            "gif" => Some(Format::Gif),
            _ => None,
        }
    }
}

impl Film {
    /// No frames yet, of lattices of `dim` in `universe`, coloured by `counter` or state.
    pub(crate) fn new(
        dim: Dim,
        universe: Option<latticesim_vm::model::Bounds>,
        counter: Option<u8>,
    ) -> Film {
        Film {
            frames: Vec::new(),
            states: BTreeSet::new(),
            dim,
            universe: universe.map(|b| [0, 1, 2].map(|k| (b[k].0 as i64, b[k].1 as i64))),
            counter,
        }
    }

    /// The next frame.
    pub(crate) fn add(&mut self, lat: &Lattice) {
        let f = Frame::of(lat, self.counter);
        self.states.extend(f.state.iter().copied());
        self.frames.push(f);
    }

    pub(crate) fn len(&self) -> usize {
        self.frames.len()
    }

    /// The frames encoded, the first labelled step `first`, with `cell` pixels a cell
    /// (fewer when the picture would be too large) and `fps` frames a second: the bytes
    /// and the picture's size; or why they cannot be.
    pub(crate) fn encode(
        &self,
        format: Format,
        palette: &Palette,
        first: u64,
        (cell, fps): (u32, u32),
    ) -> Result<(Vec<u8>, (u32, u32)), String> {
        let key = match self.counter {
            None => {
                let order = (palette.order().iter())
                    .filter(|s| self.states.contains(*s))
                    .copied()
                    .collect();
                Key::States(order, palette.clone())
            }
            Some(c) => {
                let values = self.frames.iter().flat_map(|f| f.value.iter().copied());
                let (lo, hi) = values.fold((i32::MAX, i32::MIN), |a, v| (a.0.min(v), a.1.max(v)));
                let (lo, hi) = if lo > hi { (0, 0) } else { (lo, hi) };
                Key::Counter {
                    name: format!("C{c:02}"),
                    lo,
                    hi,
                }
            }
        };
        let view = View::new(&self.frames, self.dim, self.universe, cell);
        if view.size.0 as u64 > MAX_SIDE + 64 || view.size.1 as u64 > MAX_SIDE + 64 {
            return Err(format!(
                "the agents spread over {} x {} cells, more than a picture of at most {MAX_SIDE} pixels a side can show at one pixel a cell",
                view.hi[0] - view.lo[0] + 1,
                view.hi[1] - view.lo[1] + 1
            ));
        }
        let size = (view.size.0 + LEGEND_W, view.size.1.max(key.height()));
        let bytes = match format {
            Format::Svg => {
                Ok(svg(&view, &view.shapes(&self.frames[0], &key), &key, first).into_bytes())
            }
            Format::Png => Legended::new(&view, &key).and_then(|lg| {
                let rgb = lg.image(
                    &view,
                    &raster(&view, &view.shapes(&self.frames[0], &key)),
                    first,
                )?;
                png(lg.size, &rgb)
            }),
            Format::Gif => Legended::new(&view, &key)
                .and_then(|lg| gif(&view, &self.frames, &lg, (first, fps))),
        }?;
        Ok((bytes, size))
    }
}

/// The frames of steps `first..=last` of the engine's run, or up to where it became
/// quiescent (nothing changes after that), whichever comes first, with a note when the
/// run stopped early; the step reached.
fn frames(
    engine: &mut Engine,
    (first, last): (u64, u64),
    film: &mut Film,
    palette: &mut Palette,
) -> u64 {
    // The run is drawn up to `last`, or up to where it became quiescent (nothing changes
    // after that), whichever comes first.
    while engine.stats.steps <= last {
        // Every step's states take their colours in order of first appearance, drawn or
        // not, as in the viewer.
        palette.observe(&engine.lat.state);
        if engine.stats.steps >= first {
            film.add(&engine.lat);
        }
        if engine.stats.steps == last || engine.stats.quiescent {
            break;
        }
        engine.step();
    }
    let reached = engine.stats.steps;
    if film.len() == 0 {
        // Quiescent before `first`: the configuration it stopped in is the one asked for.
        film.add(&engine.lat);
    }
    if reached < last {
        let shown = if first == last {
            format!("step {last} is the configuration it stopped in")
        } else {
            format!(
                "the animation ends there, at frame {} (steps {}..{reached})",
                film.len(),
                first.min(reached)
            )
        };
        say!("note: the run is quiescent after step {reached} (no agent has a rule left to execute); {shown}");
    }
    reached
}

pub fn render(args: RenderArgs) -> ExitCode {
    let ext = args
        .out
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let (first, last) = match asked(&args, ext.as_deref()) {
        Ok(r) => r,
        Err(c) => return c,
    };
    let out_file = match open_output(&args.out) {
        Ok(f) => f,
        Err(c) => return c,
    };
    let mut palette = match args.palette.as_deref().map(Palette::read).transpose() {
        Ok(p) => p.unwrap_or_default(),
        Err(e) => {
            say!("error: --palette {e}");
            return ExitCode::from(2);
        }
    };
    let threads = crate::run::io_threads(None);
    let levels = match args.lints.lints() {
        Ok(l) => l,
        Err(c) => return c,
    };
    let shown = (true, colour(args.color));
    let ready = match load(&args.rules, &args.agents, shown, threads, &levels) {
        Ok(l) => l,
        Err(c) => return c,
    };
    let (dim, universe) = (ready.lat.dim, ready.lat.universe);
    let opts = Options {
        threads: crate::engine_threads(None, ready.lat.len()),
        order: args.order.into(),
        static_first: args.static_first,
        trace: false,
        skip: Default::default(),
        space_order: Default::default(),
        // (Frames show no records.)
        records_per_step: Some(0),
    };
    let mut engine = Engine::new(ready.prog, ready.lat, opts);
    let agent_frames = engine.lat.len() as u64 * (last - first + 1);
    if agent_frames > MAX_AGENT_FRAMES {
        say!(
            "error: {} agents in {} frames are more than {MAX_AGENT_FRAMES} agent-frames; draw fewer steps",
            engine.lat.len(),
            last - first + 1
        );
        return ExitCode::from(2);
    }
    let counter = match args
        .color_by
        .as_deref()
        .map(|c| counter_of(c, engine.lat.nc()))
    {
        Some(Err(e)) => {
            say!("error: --color-by {e}");
            return ExitCode::from(2);
        }
        Some(Ok(c)) => Some(c),
        None => None,
    };
    let mut film = Film::new(dim, universe, counter);
    let reached = frames(&mut engine, (first, last), &mut film, &mut palette);
    // A single picture is labelled with the step asked for; an animation covers the steps
    // that were run.
    let (first, last) = if first == last {
        (first, last)
    } else {
        (first.min(reached), last.min(reached))
    };
    let format = match ext.as_deref().and_then(Format::of) {
        Some(f) => f,
        None => Format::Gif,
    };
    let (bytes, size) = match film.encode(format, &palette, first, (args.cell, args.fps)) {
        Ok(b) => b,
        Err(e) if e.starts_with("the agents spread") => {
            say!("error: `{}`: {e}", args.agents.display());
            return ExitCode::from(2);
        }
        Err(e) => {
            say!("error: cannot encode `{}`: {e}", args.out.display());
            return ExitCode::from(2);
        }
    };
    if let Err(c) = write_output(out_file, &bytes) {
        return c;
    }
    let steps = if first == last {
        format!("step {first}")
    } else {
        format!("steps {first}..{last}")
    };
    say!(
        "{}: {} frame{} ({} x {} pixels, {steps}), {} agents",
        args.out.display(),
        film.len(),
        if film.len() == 1 { "" } else { "s" },
        size.0,
        size.1,
        engine.lat.len()
    );
    ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scale meets its stops at 0, 1/4, 1/2, 3/4 and 1, halfway between them in
    /// between, and holds its ends outside 0..=1.
    #[test]
    fn the_counter_scale_interpolates_its_stops() {
        for (k, stop) in SCALE.iter().enumerate() {
            assert_eq!(scale(k as f64 / 4.0), *stop);
        }
        assert_eq!(
            scale(0.125),
            [64, 42, 112],
            "halfway between the first two stops"
        );
        assert_eq!((scale(-1.0), scale(2.0)), (SCALE[0], SCALE[4]));
    }
}
