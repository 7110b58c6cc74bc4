//! Log-log SVG plots for the studies, drawn with `plotters`.

use std::path::Path;

use plotters::prelude::*;

/// One curve: a name, its points, and how to draw them.
#[derive(Debug)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub style: Style,
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// Markers only (measurements).
    Points,
    /// Joined, with markers on short curves.
    Line,
    /// A wide pale band under the other curves (a front or envelope), so
    /// the points it passes through stay visible.
    Band,
}

const COLOURS: [RGBColor; 8] = [
    RGBColor(59, 125, 216),
    RGBColor(240, 140, 46),
    RGBColor(22, 121, 76),
    RGBColor(163, 21, 27),
    RGBColor(117, 79, 182),
    RGBColor(0, 150, 170),
    RGBColor(140, 86, 75),
    RGBColor(90, 90, 90),
];

/// Curves with more points than this are drawn without markers.
const MARKED_POINTS: usize = 20;

/// Draws `series` on log-log axes into `path`.
pub fn loglog(
    path: &Path,
    title: &str,
    axes: (&str, &str),
    series: &[Series],
) -> anyhow::Result<()> {
    let all: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .collect();
    anyhow::ensure!(!all.is_empty(), "nothing to plot");
    // Whole decades, so every axis has labelled ticks even when the data
    // span less than one.
    let span = |v: Vec<f64>| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        10f64.powf((lo / 1.2).log10().floor())..10f64.powf((hi * 1.2).log10().ceil())
    };
    let xs = span(all.iter().map(|p| p.0).collect());
    let ys = span(all.iter().map(|p| p.1).collect());
    let root = SVGBackend::new(path, (820, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(72)
        .build_cartesian_2d(xs.log_scale(), ys.log_scale())?;
    chart
        .configure_mesh()
        .x_desc(axes.0)
        .y_desc(axes.1)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .draw()?;
    // Bands first, underneath.
    let mut order: Vec<usize> = (0..series.len()).collect();
    order.sort_by_key(|&k| series[k].style != Style::Band);
    for k in order {
        let s = &series[k];
        let colour = COLOURS[k % COLOURS.len()];
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| *x > 0.0 && *y > 0.0)
            .collect();
        match s.style {
            Style::Band => {
                let pale = colour.mix(0.35);
                chart
                    .draw_series(LineSeries::new(pts, pale.stroke_width(10)))?
                    .label(s.name.as_str())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], pale.stroke_width(8))
                    });
            }
            Style::Line => {
                chart
                    .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))?
                    .label(s.name.as_str())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour));
                if pts.len() <= MARKED_POINTS {
                    chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, colour.filled())))?;
                }
            }
            Style::Points => {
                chart
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 4, colour.filled())))?
                    .label(s.name.as_str())
                    .legend(move |(x, y)| Circle::new((x + 9, y), 4, colour.filled()));
            }
        }
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.85))
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    root.present()?;
    Ok(())
}

/// A tick label: plain decimals from 0.01 to 10⁴, powers of ten outside.
fn tick(v: f64) -> String {
    if (0.01..1e4).contains(&v.abs()) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        format!("{v:.0e}")
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn ticks_are_short() {
        assert_eq!(super::tick(0.02), "0.02");
        assert_eq!(super::tick(30.0), "30");
        assert_eq!(super::tick(2.5), "2.5");
        assert_eq!(super::tick(3e-5), "3e-5");
        assert_eq!(super::tick(1e5), "1e5");
    }
}
