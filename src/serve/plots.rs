//! The run's series for the viewer's live charts (`GET /api/series`): per step reached,
//! the agents in each state and what the step did (agents executing, moves, swaps,
//! messages sent, records); and exports of the run as pictures (`GET /api/export`: SVG or
//! PNG of a step, GIF of a range of steps), drawn as `latticesim render` draws them.

use super::*;
use crate::render::{Film, Format};

/// One step of the series.
#[derive(Debug, Clone)]
pub(super) struct Point {
    step: u64,
    executing: u64,
    moves: u64,
    swaps: u64,
    sent: u64,
    records: u64,
    /// Agents per state, by the palette's index (states first seen later are absent).
    states: Vec<u64>,
}

/// The series of the steps reached, every `stride`-th step once it grew long.
#[derive(Debug, Default)]
pub(super) struct Series {
    points: Vec<Point>,
    stride: u64,
}

/// The most points kept: past it every other one is dropped and the stride doubles.
const SERIES_MAX: usize = 20_000;

impl Series {
    /// A series starting with step 0 of `e`, its states counted by the palette's index.
    pub(super) fn new(e: &Engine, states: Vec<u64>) -> Series {
        let mut s = Series {
            points: Vec::new(),
            stride: 1,
        };
        s.points.push(Point {
            step: e.stats.steps,
            executing: 0,
            moves: 0,
            swaps: 0,
            sent: 0,
            records: 0,
            states,
        });
        s
    }

    /// A step first reached: what it did, and then the agents in each state.
    pub(super) fn push(&mut self, cost: &latticesim_runtime::StepCost, states: Vec<u64>) {
        if !cost.step.is_multiple_of(self.stride)
            || self.points.last().is_some_and(|p| p.step >= cost.step)
        {
            return;
        }
        self.points.push(Point {
            step: cost.step,
            executing: cost.executing,
            moves: cost.moves,
            swaps: cost.swaps,
            sent: cost.sent,
            records: cost.all_records(),
            states,
        });
        if self.points.len() > SERIES_MAX {
            self.stride *= 2;
            let stride = self.stride;
            self.points.retain(|p| p.step.is_multiple_of(stride));
        }
    }

    /// The points after step `since` as columns, and the states by index.
    fn view(&self, since: Option<u64>, palette: &crate::palette::Palette) -> Value {
        let pts: Vec<&Point> = (self.points.iter())
            .filter(|p| since.is_none_or(|s| p.step > s))
            .collect();
        let col = |f: fn(&Point) -> u64| pts.iter().map(|p| f(p)).collect::<Vec<u64>>();
        let states: Vec<Value> = (palette.order().iter().enumerate())
            .map(|(i, s)| {
                json!({
                    "name": super::views::state_name(s),
                    "colour": crate::palette::hex(palette.get(s)),
                    "counts": pts.iter().map(|p| p.states.get(i).copied().unwrap_or(0)).collect::<Vec<u64>>(),
                })
            })
            .collect();
        json!({
            "stride": self.stride,
            "step": col(|p| p.step),
            "executing": col(|p| p.executing),
            "moves": col(|p| p.moves),
            "swaps": col(|p| p.swaps),
            "sent": col(|p| p.sent),
            "records": col(|p| p.records),
            "states": states,
        })
    }
}

/// The most agent-frames an exported animation may hold.
const EXPORT_AGENT_FRAMES: u64 = 20_000_000;
/// The most frames an exported animation may have.
const EXPORT_FRAMES: u64 = 1000;

impl Session {
    /// `GET /api/series?since=K`: the series of the steps reached after step K (all
    /// without it), of run `run` (a new run starts a new series): columns `step`, `executing`, `moves`, `swaps`, `sent`, `records`, and
    /// per state its `name`, `colour` and `counts`; `stride` (past 20,000 points, every
    /// other step is kept, and so on).
    pub(super) fn api_series(&mut self, req: &Req) -> Result<Reply, Reply> {
        let since = req.number("since")?;
        let runs = self.runs;
        let run = self.run_mut()?;
        let mut v = run.series.view(since, &run.palette);
        v["run"] = json!(runs);
        Ok(reply_json(200, &v))
    }

    /// `GET /api/export?format=svg|png&step=N` (the step shown without `step`) or
    /// `?format=gif&from=A&to=B[&fps=F]`, with `cell=PX` (16) and `counter=Cnn` (colour by
    /// it): the picture, as `latticesim render` draws it (the whole configuration, a
    /// legend, the step), as a download. The run comes back to the step it showed.
    pub(super) fn api_export(&mut self, req: &Req) -> Result<Reply, Reply> {
        let format = req.query.get("format").copied().unwrap_or("svg");
        let format = Format::of(format)
            .ok_or_else(|| error(400, format!("`format` is svg, png or gif, not `{format}`")))?;
        let cell = req.number("cell")?.unwrap_or(16).clamp(1, 256) as u32;
        let fps = req.number("fps")?.unwrap_or(5).clamp(1, 100) as u32;
        let run = self.run_mut()?;
        let counter = counter_asked(req, run)?;
        let shown = run.hist.steps();
        let (first, last) = match format {
            Format::Gif => {
                let from = req.number("from")?.unwrap_or(0);
                let to = req.number("to")?.unwrap_or(shown);
                if from > to {
                    return Err(error(400, format!("`from` ({from}) is after `to` ({to})")));
                }
                (from, to)
            }
            _ => {
                let s = req.number("step")?.unwrap_or(shown);
                (s, s)
            }
        };
        let n = run.hist.engine().lat.len() as u64;
        let frames = last - first + 1;
        if frames > EXPORT_FRAMES || n * frames > EXPORT_AGENT_FRAMES {
            return Err(error(
                400,
                format!(
                    "{frames} frames of {n} agents are more than an export holds (at most {EXPORT_FRAMES} frames and {EXPORT_AGENT_FRAMES} agent-frames): draw fewer steps, or use `latticesim render`"
                ),
            ));
        }
        let lat = &run.hist.engine().lat;
        let mut film = Film::new(lat.dim, lat.universe, counter);
        let started = Instant::now();
        let mut reached = first;
        run.hist.goto(first.min(run.hist.reached()));
        while run.hist.steps() < first && !run.hist.engine().stats.quiescent {
            run.step();
        }
        for s in first..=last {
            if run.hist.steps() < s {
                if run.hist.engine().stats.quiescent || started.elapsed() > STEP_BUDGET {
                    break;
                }
                run.step();
            }
            film.add(&run.hist.engine().lat);
            reached = s;
        }
        run.hist.goto(shown);
        let (bytes, _) = film
            .encode(format, &run.palette, first, (cell, fps))
            .map_err(|e| error(400, e))?;
        let (ctype, ext) = match format {
            Format::Svg => ("image/svg+xml", "svg"),
            Format::Png => ("image/png", "png"),
            Format::Gif => ("image/gif", "gif"),
        };
        let name = if first == reached {
            format!("latticesim-step-{first}.{ext}")
        } else {
            format!("latticesim-steps-{first}-{reached}.{ext}")
        };
        Ok(Reply {
            status: 200,
            ctype,
            headers: vec![(
                "Content-Disposition",
                format!("attachment; filename=\"{name}\""),
            )],
            body: bytes,
        })
    }
}
