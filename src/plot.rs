//! The plots of `sweep --plot`: one log-log panel per metric against n, with every run as
//! a faint point, the mean per n with its spread (min to max), the least-squares power
//! law fitted to all runs with the 95 % interval of its exponent, and optional reference
//! slopes (`--reference n,n^0.5,n log n`), anchored at the first mean. Drawn as SVG with
//! plotters; PNG (resvg) and PDF (svg2pdf) are made from the SVG, chosen by the file's name.

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use statrs::distribution::{ContinuousCDF, StudentsT};
use std::path::Path;

/// A fit of log y = a + b log n to k points: the exponent `b`, `a`, and the half-width of
/// the 95 % interval of `b` (None with fewer than three points).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Fit {
    pub a: f64,
    pub b: f64,
    pub ci: Option<f64>,
    pub k: usize,
}

/// The least-squares fit of log y against log n over the points with both above zero
/// (None with fewer than two distinct n).
pub(crate) fn fit(points: &[(f64, f64)]) -> Option<Fit> {
    let pts: Vec<(f64, f64)> = (points.iter())
        .filter(|p| p.0 > 0.0 && p.1 > 0.0)
        .map(|p| (p.0.ln(), p.1.ln()))
        .collect();
    let k = pts.len();
    if k < 2 {
        return None;
    }
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (mx, my) = (sx / k as f64, sy / k as f64);
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx == 0.0 {
        return None;
    }
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let b = sxy / sxx;
    let a = my - b * mx;
    // The standard error of the slope, and Student's t with k - 2 degrees of freedom.
    let ci = (k > 2).then(|| {
        let sse: f64 = pts.iter().map(|p| (p.1 - a - b * p.0).powi(2)).sum();
        let se = (sse / (k - 2) as f64 / sxx).sqrt();
        let t = StudentsT::new(0.0, 1.0, (k - 2) as f64)
            .expect("positive degrees of freedom")
            .inverse_cdf(0.975);
        t * se
    });
    Some(Fit { a, b, ci, k })
}

impl Fit {
    /// `n^1.02 ± 0.03` (the interval when known).
    pub(crate) fn text(&self) -> String {
        match self.ci {
            Some(ci) => format!("n^{:.2} ± {ci:.2}", self.b),
            None => format!("n^{:.2}", self.b),
        }
    }
}

/// A reference slope: its label and its shape as a function of n.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Reference {
    pub label: String,
    power: f64,
    log: bool,
}

impl std::str::FromStr for Reference {
    type Err = String;

    /// `1`, `n`, `n^P`, `log n`, `n log n` or `n^P log n`.
    fn from_str(s: &str) -> Result<Reference, String> {
        let t = s.trim();
        let (head, log) = match t.strip_suffix("log n") {
            Some(h) => (h.trim().trim_end_matches('*').trim(), true),
            None => (t, false),
        };
        let power = match head {
            "" if log => 0.0,
            "1" => 0.0,
            "n" => 1.0,
            h => h
                .strip_prefix("n^")
                .and_then(|p| p.parse::<f64>().ok())
                .filter(|p| p.is_finite())
                .ok_or_else(|| {
                    format!("`{t}` is not a reference slope: write 1, n, n^P, log n, n log n or n^P log n")
                })?,
        };
        Ok(Reference {
            label: t.to_string(),
            power,
            log,
        })
    }
}

impl Reference {
    fn at(&self, n: f64) -> f64 {
        n.powf(self.power) * if self.log { n.ln().max(1e-9) } else { 1.0 }
    }
}

/// One panel: a metric's name and its points (n, value), one per run.
pub(crate) struct Panel<'a> {
    pub name: &'a str,
    pub points: Vec<(f64, f64)>,
}

/// An integer with thin spaces between thousands (`12 345`), for tick labels.
fn integer(v: &f64) -> String {
    let s = format!("{}", v.round() as i64);
    let (sign, digits) = s.strip_prefix('-').map_or(("", s.as_str()), |d| ("-", d));
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push('\u{2009}');
        }
        out.push(c);
    }
    format!("{sign}{out}")
}

/// A value as a tick label: integers with thin spaces between thousands, values below 1
/// with the decimals they need (`0.05`).
fn number(v: f64) -> String {
    if v >= 1.0 {
        return integer(&v);
    }
    let decimals = (-v.log10()).ceil().max(0.0) as usize;
    format!("{v:.decimals$}")
}

/// One grid line of a log axis: its value, whether it is a power of ten (drawn darker:
/// the others are the minor lines), and its label, if it has one.
#[derive(Debug, PartialEq)]
struct GridLine {
    v: f64,
    major: bool,
    label: Option<String>,
}

/// The grid of a log axis from `lo` to `hi`: a line at each 1..9 times a power of ten,
/// labelled at 1, 2 and 5 times one (at powers of ten alone when that would crowd, every
/// other one past eight), and at every line when fewer than two would be labelled, so
/// that every axis has labels. Each value once (plotters' own log axis could draw 100
/// twice).
fn grid(lo: f64, hi: f64) -> Vec<GridLine> {
    let mut lines: Vec<(f64, u32, i32)> = Vec::new();
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Vec::new();
    }
    for k in lo.log10().floor() as i32..=hi.log10().ceil() as i32 {
        for m in 1..=9 {
            // Written out, not multiplied, so that 3 x 10^-1 is exactly 0.3.
            let v: f64 = format!("{m}e{k}").parse().expect("a number");
            if v >= lo && v <= hi {
                lines.push((v, m, k));
            }
        }
    }
    let labelled =
        |keep: &dyn Fn(u32, i32) -> bool| lines.iter().filter(|l| keep(l.1, l.2)).count();
    let decades = labelled(&|m, _| m == 1);
    let keep: Box<dyn Fn(u32, i32) -> bool> = if labelled(&|m, _| matches!(m, 1 | 2 | 5)) < 2 {
        Box::new(|_, _| true)
    } else if labelled(&|m, _| matches!(m, 1 | 2 | 5)) <= 8 {
        Box::new(|m, _| matches!(m, 1 | 2 | 5))
    } else if decades <= 8 {
        Box::new(|m, _| m == 1)
    } else {
        Box::new(|m, k| m == 1 && k % 2 == 0)
    };
    (lines.iter())
        .map(|&(v, m, k)| GridLine {
            v,
            major: m == 1,
            label: keep(m, k).then(|| number(v)),
        })
        .collect()
}

/// The figure's SVG made as it should look where plotters cannot say it: the reference
/// slopes (drawn in [`REF_COLOURS`]) dashed as one smooth path, in the legend too, and
/// exponents (`n^0.39`) set as superscripts.
fn finish(svg: &str) -> String {
    let mut out = svg.to_string();
    for c in REF_COLOURS {
        let stroke = format!("stroke=\"#{:02X}{:02X}{:02X}\"", c.0, c.1, c.2);
        out = out.replace(&stroke, &format!("{stroke} stroke-dasharray=\"7 4\""));
    }
    superscripts(&out)
}

/// Each `^` followed by an exponent (`-0.5`, `1.18`) inside text set as a superscript.
fn superscripts(svg: &str) -> String {
    let mut out = String::with_capacity(svg.len());
    let mut in_text = false;
    let mut rest = svg;
    while let Some(i) = rest.find(['<', '^']) {
        out.push_str(&rest[..i]);
        rest = &rest[i..];
        if rest.starts_with('<') {
            let end = rest.find('>').map_or(rest.len(), |e| e + 1);
            let tag = &rest[..end];
            if tag.starts_with("<text") {
                in_text = true;
            } else if tag.starts_with("</text") {
                in_text = false;
            }
            out.push_str(tag);
            rest = &rest[end..];
            continue;
        }
        // A `^`: its exponent runs over an optional minus, digits and a point.
        let body = &rest[1..];
        let len = body
            .char_indices()
            .take_while(|&(k, c)| c.is_ascii_digit() || c == '.' || (k == 0 && c == '-'))
            .count();
        let exp = body[..len].trim_end_matches('.');
        if in_text && exp.bytes().any(|b| b.is_ascii_digit()) {
            out.push_str(&format!(
                "<tspan baseline-shift=\"super\" font-size=\"75%\">{exp}</tspan>"
            ));
            rest = &body[exp.len()..];
        } else {
            out.push('^');
            rest = body;
        }
    }
    out.push_str(rest);
    out
}

/// The colours of the reference slopes (each dashed by [`finish`]; no other element is
/// drawn in them).
const REF_COLOURS: [RGBColor; 3] = [
    RGBColor(90, 90, 91),
    RGBColor(140, 140, 141),
    RGBColor(60, 140, 61),
];

/// Panel size in pixels.
const PANEL: (u32, u32) = (560, 400);

/// The panels as one SVG figure: panels side by side in rows of two, under the title.
pub(crate) fn svg(title: &str, panels: &[Panel], refs: &[Reference]) -> Result<String, String> {
    let cols = panels.len().clamp(1, 2) as u32;
    let rows = panels.len().div_ceil(2).max(1) as u32;
    let top = if title.is_empty() { 0 } else { 40 };
    let size = (PANEL.0 * cols, PANEL.1 * rows + top);
    let e = |e: DrawingAreaErrorKind<std::io::Error>| e.to_string();
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let body = if title.is_empty() {
            root.clone()
        } else {
            let (head, body) = root.split_vertically(top);
            head.titled(title, ("sans-serif", 24)).map_err(e)?;
            body
        };
        let areas = body.split_evenly((rows as usize, cols as usize));
        for (panel, area) in panels.iter().zip(areas) {
            draw_panel(&area, panel, refs).map_err(e)?;
        }
        root.present().map_err(e)?;
    }
    Ok(finish(&out))
}

/// Per n (ascending) of the points above zero: n, the smallest value, the mean, the
/// largest value.
fn per_n(points: &[(f64, f64)]) -> Vec<(f64, f64, f64, f64)> {
    let mut by_n: std::collections::BTreeMap<u64, Vec<f64>> = Default::default();
    for &(n, y) in points.iter().filter(|q| q.0 > 0.0 && q.1 > 0.0) {
        by_n.entry(n as u64).or_default().push(y);
    }
    (by_n.iter())
        .map(|(&n, v)| {
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            let (lo, hi) = v
                .iter()
                .fold((f64::MAX, 0.0f64), |a, &y| (a.0.min(y), a.1.max(y)));
            (n as f64, lo, mean, hi)
        })
        .collect()
}

type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

fn draw_panel(
    area: &Area<'_>,
    p: &Panel,
    refs: &[Reference],
) -> Result<(), DrawingAreaErrorKind<std::io::Error>> {
    let ns: Vec<f64> = p.points.iter().map(|q| q.0).filter(|n| *n > 0.0).collect();
    let ys: Vec<f64> = p.points.iter().map(|q| q.1).filter(|y| *y > 0.0).collect();
    let (xmin, xmax) = (
        ns.iter().copied().fold(f64::MAX, f64::min),
        ns.iter().copied().fold(0.0, f64::max),
    );
    let (ymin, ymax) = (
        ys.iter().copied().fold(f64::MAX, f64::min),
        ys.iter().copied().fold(0.0, f64::max),
    );
    let (xmin, xmax) = if ns.is_empty() {
        (1.0, 10.0)
    } else {
        (xmin, xmax.max(xmin * 1.5))
    };
    let (ymin, ymax) = if ys.is_empty() {
        (1.0, 10.0)
    } else {
        (ymin, ymax.max(ymin * 1.5))
    };
    let mut chart = ChartBuilder::on(area)
        .caption(p.name, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (xmin / 1.3..xmax * 1.3).log_scale(),
            (ymin / 2.0..ymax * 2.0).log_scale(),
        )?;
    let (xr, yr) = ((xmin / 1.3, xmax * 1.3), (ymin / 2.0, ymax * 2.0));
    // The axes and their names from plotters; the grid and its labels drawn here.
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("agents n")
        .y_desc(p.name)
        .x_labels(0)
        .y_labels(0)
        .x_label_formatter(&|_| String::new())
        .y_label_formatter(&|_| String::new())
        .draw()?;
    let (xs, ys) = (grid(xr.0, xr.1), grid(yr.0, yr.1));
    let shade = |major: bool| {
        if major {
            RGBColor(190, 190, 190)
        } else {
            RGBColor(232, 232, 232)
        }
    };
    let label = ("sans-serif", 13).into_font().color(&BLACK);
    // The minor lines first, the major ones over them.
    for major in [false, true] {
        for l in xs.iter().filter(|l| l.major == major) {
            let line = [(l.v, yr.0), (l.v, yr.1)];
            chart.draw_series(LineSeries::new(line, shade(l.major).stroke_width(1)))?;
        }
        for l in ys.iter().filter(|l| l.major == major) {
            let line = [(xr.0, l.v), (xr.1, l.v)];
            chart.draw_series(LineSeries::new(line, shade(l.major).stroke_width(1)))?;
        }
    }
    // Where the panel is on the figure (the chart's coordinates are the figure's).
    let (bx, by) = area.get_base_pixel();
    let at = |x: f64, y: f64| {
        let (px, py) = chart.backend_coord(&(x, y));
        (px - bx, py - by)
    };
    for l in &xs {
        if let Some(t) = &l.label {
            let (x, y) = at(l.v, yr.0);
            let style = label.pos(Pos::new(HPos::Center, VPos::Top));
            area.draw(&PathElement::new(
                [(x, y), (x, y + 5)],
                BLACK.stroke_width(1),
            ))?;
            area.draw(&Text::new(t.clone(), (x, y + 8), style))?;
        }
    }
    for l in &ys {
        if let Some(t) = &l.label {
            let (x, y) = at(xr.0, l.v);
            let style = label.pos(Pos::new(HPos::Right, VPos::Center));
            area.draw(&PathElement::new(
                [(x - 5, y), (x, y)],
                BLACK.stroke_width(1),
            ))?;
            area.draw(&Text::new(t.clone(), (x - 8, y), style))?;
        }
    }
    let blue = RGBColor(31, 94, 168);
    // Every run, faint.
    chart.draw_series(
        (p.points.iter())
            .filter(|q| q.0 > 0.0 && q.1 > 0.0)
            .map(|&q| Circle::new(q, 2, blue.mix(0.3).filled())),
    )?;
    // The mean per n and the spread (min to max) of its runs.
    let stats = per_n(&p.points);
    chart.draw_series(
        stats
            .iter()
            .map(|&(n, lo, m, hi)| ErrorBar::new_vertical(n, lo, m, hi, blue.stroke_width(1), 8)),
    )?;
    chart
        .draw_series(
            stats
                .iter()
                .map(|&(n, _, m, _)| Circle::new((n, m), 4, blue.filled())),
        )?
        .label("mean of the runs (bars: min to max)")
        .legend(move |(x, y)| Circle::new((x + 10, y), 4, blue.filled()));
    // The fit, a straight line on these axes.
    if let Some(f) = fit(&p.points) {
        let red = RGBColor(200, 40, 40);
        let line = [xmin, xmax].map(|x| (x, (f.a + f.b * x.ln()).exp()));
        chart
            .draw_series(LineSeries::new(line, red.stroke_width(2)))?
            .label(format!("fit: {} (95 %, {} runs)", f.text(), f.k))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], red.stroke_width(2)));
    }
    // Reference slopes through the first mean: one path each (two points for a power
    // law, a straight line here), dashed by `finish`.
    if let Some(&(n0, _, m0, _)) = stats.first() {
        for (r, &grey) in refs.iter().zip(REF_COLOURS.iter().cycle()) {
            let scale = m0 / r.at(n0);
            let mut pts: Vec<(f64, f64)> = (0..=200)
                .map(|i| {
                    let x = xmin * (xmax / xmin).powf(i as f64 / 200.0);
                    (x, scale * r.at(x))
                })
                .filter(|q| q.1 >= yr.0 && q.1 <= yr.1)
                .collect();
            if !r.log && pts.len() > 2 {
                // A power law is straight on these axes: its ends alone.
                pts = vec![pts[0], pts[pts.len() - 1]];
            }
            chart
                .draw_series(std::iter::once(PathElement::new(pts, grey.stroke_width(1))))?
                .label(format!("∝ {}", r.label))
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 20, y)], grey.stroke_width(1))
                });
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    Ok(())
}

/// The format of a plot file, by its name: `svg`, `png` or `pdf`.
pub(crate) fn format_of(path: &Path) -> Option<&'static str> {
    let name = path.file_name()?.to_str()?.to_ascii_lowercase();
    ["svg", "png", "pdf"]
        .into_iter()
        .find(|e| name.ends_with(&format!(".{e}")))
}

/// Options for reading SVG with text: the system's fonts, `sans-serif` set to the first
/// of DejaVu Sans, Liberation Sans, Noto Sans, FreeSans and Arial the system has (else any
/// family it has), `monospace` to DejaVu Sans Mono, Liberation Mono, Noto Sans Mono or
/// FreeMono (else the sans-serif one); an error when it has no fonts.
pub(crate) fn svg_options() -> Result<resvg::usvg::Options<'static>, String> {
    let mut opt = resvg::usvg::Options::default();
    let db = opt.fontdb_mut();
    db.load_system_fonts();
    let families: Vec<String> = (db.faces())
        .flat_map(|f| f.families.iter().map(|(name, _)| name.clone()))
        .collect();
    let first_of = |names: &[&str]| {
        (names.iter())
            .find(|n| families.iter().any(|f| f == *n))
            .map(|n| n.to_string())
    };
    let sans = first_of(&["DejaVu Sans", "Liberation Sans", "Noto Sans", "FreeSans", "Arial"])
        .or_else(|| families.first().cloned())
        .ok_or("no fonts on this system to set the figure's text in; install some (e.g. Debian's fonts-dejavu-core) or write .svg")?;
    let mono = first_of(&[
        "DejaVu Sans Mono",
        "Liberation Mono",
        "Noto Sans Mono",
        "FreeMono",
    ])
    .unwrap_or_else(|| sans.clone());
    db.set_sans_serif_family(sans);
    db.set_monospace_family(mono);
    Ok(opt)
}

/// The figure in the format `format` (`svg`, `png` at twice the SVG's size, or `pdf`),
/// text set in the system's fonts.
pub(crate) fn encode(svg: &str, format: &str) -> Result<Vec<u8>, String> {
    if format == "svg" {
        return Ok(svg.as_bytes().to_vec());
    }
    let opt = svg_options()?;
    let tree = resvg::usvg::Tree::from_str(svg, &opt).map_err(|e| e.to_string())?;
    if format == "pdf" {
        let (c, p) = (
            svg2pdf::ConversionOptions::default(),
            svg2pdf::PageOptions::default(),
        );
        return svg2pdf::to_pdf(&tree, c, p).map_err(|e| e.to_string());
    }
    let size = tree.size().to_int_size();
    let (w, h) = (size.width() * 2, size.height() * 2);
    let mut pixmap = resvg::tiny_skia::Pixmap::new(w, h).ok_or("the figure is empty")?;
    pixmap.fill(resvg::tiny_skia::Color::WHITE);
    let scale = resvg::tiny_skia::Transform::from_scale(2.0, 2.0);
    resvg::render(&tree, scale, &mut pixmap.as_mut());
    pixmap.encode_png().map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exponent, intercept and 95 % interval against a fit computed independently
    /// (scipy.stats.linregress on the natural logarithms, and t = stats.t.ppf(0.975, 1)):
    /// the points (10, 20), (100, 150), (1000, 2500) give slope 1.048455, intercept
    /// 0.448491, SSE 0.106269 with Sxx 10.603796, and with one degree of freedom
    /// (t = 12.706205) the interval 12.706205 * sqrt(0.106269 / 10.603796) = 1.272004.
    #[test]
    fn fits_a_power_law_with_its_interval() {
        let f = fit(&[(10.0, 20.0), (100.0, 150.0), (1000.0, 2500.0)]).unwrap();
        assert!((f.b - 1.048_455).abs() < 1e-6, "{f:?}");
        assert!((f.a - 0.448_491).abs() < 1e-6, "{f:?}");
        assert!((f.ci.unwrap() - 1.272_004).abs() < 1e-5, "{f:?}");
        assert_eq!(f.k, 3);
        // Exact data: the interval is zero; two points: no interval; one: no fit.
        let exact: Vec<(f64, f64)> = [1.0, 10.0, 100.0, 1000.0]
            .iter()
            .map(|&n: &f64| (n, 3.0 * n.powf(0.5)))
            .collect();
        let f = fit(&exact).unwrap();
        assert!(
            (f.b - 0.5).abs() < 1e-12 && f.ci.unwrap() < 1e-9 && (f.a.exp() - 3.0).abs() < 1e-9
        );
        assert!(fit(&[(1.0, 1.0), (2.0, 2.0)]).unwrap().ci.is_none());
        assert!(fit(&[(1.0, 1.0)]).is_none());
        assert!(
            fit(&[(5.0, 1.0), (5.0, 2.0)]).is_none(),
            "one n: nothing to fit"
        );
    }

    #[test]
    fn reference_slopes_and_ticks() {
        let r = |s: &str| s.parse::<Reference>();
        assert_eq!(r("n").unwrap().at(8.0), 8.0);
        assert_eq!(r("n^0.5").unwrap().at(16.0), 4.0);
        assert!(
            (r("n log n").unwrap().at(std::f64::consts::E) - std::f64::consts::E).abs() < 1e-12
        );
        assert!((r("log n").unwrap().at(std::f64::consts::E) - 1.0).abs() < 1e-12);
        assert_eq!(r("1").unwrap().at(50.0), 1.0);
        assert!(r("n^x").unwrap_err().contains("not a reference slope"));
        assert_eq!(integer(&1234567.0), "1\u{2009}234\u{2009}567");
        assert_eq!(integer(&10.0), "10");
        let pts = [
            (20.0, 4.0),
            (10.0, 1.0),
            (20.0, 8.0),
            (10.0, 3.0),
            (10.0, 0.0),
        ];
        assert_eq!(per_n(&pts), [(10.0, 1.0, 2.0, 3.0), (20.0, 4.0, 6.0, 8.0)]);
        let labels =
            |lo, hi| -> Vec<String> { grid(lo, hi).into_iter().filter_map(|l| l.label).collect() };
        // 1, 2 and 5 times powers of ten, each once (100 was labelled twice).
        assert_eq!(labels(7.0, 400.0), ["10", "20", "50", "100", "200"]);
        let g = grid(7.0, 400.0);
        assert_eq!(g.len(), 3 + 9 + 4);
        assert_eq!(g.iter().filter(|l| l.major).count(), 2);
        // A narrow axis is labelled at every line; a wide one at powers of ten, every
        // other one past eight.
        assert_eq!(labels(31.0, 95.0), ["40", "50", "60", "70", "80", "90"]);
        assert_eq!(labels(1.0, 1e6).len(), 7);
        assert_eq!(
            labels(1.0, 1e12),
            [
                "1",
                "100",
                "10\u{2009}000",
                "1\u{2009}000\u{2009}000",
                "100\u{2009}000\u{2009}000",
                "10\u{2009}000\u{2009}000\u{2009}000",
                "1\u{2009}000\u{2009}000\u{2009}000\u{2009}000"
            ]
        );
        assert_eq!(labels(0.004, 0.03), ["0.005", "0.01", "0.02"]);
        assert!(grid(0.0, 10.0).is_empty() && grid(5.0, 5.0).is_empty());
        assert_eq!(integer(&-1000.0), "-1\u{2009}000");
        // Exponents as superscripts in text only; reference slopes dashed.
        let svg = "<text x=\"1\">fit: n^0.39 ± 0.06, n^-1 log n, a^b</text><path d=\"n^2\"/>";
        assert_eq!(
            superscripts(svg),
            "<text x=\"1\">fit: n<tspan baseline-shift=\"super\" font-size=\"75%\">0.39</tspan> ± 0.06, n<tspan baseline-shift=\"super\" font-size=\"75%\">-1</tspan> log n, a^b</text><path d=\"n^2\"/>"
        );
        assert!(finish("<polyline stroke=\"#5A5A5B\"/>").contains("stroke-dasharray"));
        assert_eq!(format_of(Path::new("a/b.PDF")), Some("pdf"));
        assert_eq!(format_of(Path::new("b.png")), Some("png"));
        assert_eq!(format_of(Path::new("b.jpg")), None);
    }
}
