//! Plots for the benchmarks' reports: lines on log-log axes, as SVG.

use plotters::prelude::*;
use std::path::PathBuf;

/// A line of a plot: its name, its points, its colour.
pub type Series = (&'static str, Vec<(f64, f64)>, RGBColor);

/// How an axis labels its values.
pub type Label = fn(&f64) -> String;

/// Counts as 1e4, 1e5, ...
pub fn power_of_ten(v: &f64) -> String {
    format!("{v:.0e}")
}

/// Rates as 150 M, 2.5 G.
pub fn rate(v: &f64) -> String {
    if *v >= 1e9 {
        format!("{:.1} G", v / 1e9)
    } else {
        format!("{:.0} M", v / 1e6)
    }
}

/// Times as 12 ns, 0.35 ns.
pub fn nanoseconds(v: &f64) -> String {
    if *v >= 1.0 {
        format!("{v:.0} ns")
    } else {
        format!("{v:.2} ns")
    }
}

/// Numbers as they are.
pub fn plain(v: &f64) -> String {
    format!("{v}")
}

/// Draws `series` on log-log axes into an SVG file.
pub fn plot_lines(
    path: &PathBuf,
    title: &str,
    (xd, yd): (&str, &str),
    (xl, yl): (Label, Label),
    series: &[Series],
) -> Result<(), Box<dyn std::error::Error>> {
    let pts = series.iter().flat_map(|s| s.1.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in pts {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    let root = SVGBackend::new(path, (720, 450)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (x0 * 0.7..x1 * 1.4).log_scale(),
            (y0 * 0.5..y1 * 2.0).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_desc(xd)
        .y_desc(yd)
        .x_label_formatter(&xl)
        .y_label_formatter(&yl)
        .draw()?;
    for (name, pts, color) in series {
        chart
            .draw_series(LineSeries::new(pts.clone(), color))?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))?;
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE)
        .position(SeriesLabelPosition::LowerRight)
        .draw()?;
    root.present()?;
    Ok(())
}
