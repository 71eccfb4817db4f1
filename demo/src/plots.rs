//! SVG plots of the demo (plotters): Fig. 5 style torque validation and Fig. 6 style residuals.

use std::path::Path;

use plotters::prelude::*;

/// One line of a panel.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// (time s, value) points.
    pub points: Vec<(f64, f64)>,
    /// Palette index.
    pub color: usize,
    /// Dashed (drawn thinner) instead of solid.
    pub dashed: bool,
}

/// One panel: a title, lines and optional horizontal threshold lines.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Panel title.
    pub title: String,
    /// Y-axis label.
    pub y_label: String,
    /// Lines.
    pub series: Vec<Series>,
    /// Horizontal lines (e.g. ±6 Nm thresholds).
    pub hlines: Vec<f64>,
}

/// Draws panels stacked vertically into an SVG file.
pub fn draw(path: &Path, panels: &[Panel]) -> anyhow::Result<()> {
    let height = 260 * panels.len().max(1) as u32;
    let root = SVGBackend::new(path, (1000, height)).into_drawing_area();
    root.fill(&WHITE)?;
    let areas = root.split_evenly((panels.len().max(1), 1));
    for (panel, area) in panels.iter().zip(areas.iter()) {
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for s in &panel.series {
            for &(x, y) in &s.points {
                if x.is_finite() && y.is_finite() {
                    x0 = x0.min(x);
                    x1 = x1.max(x);
                    y0 = y0.min(y);
                    y1 = y1.max(y);
                }
            }
        }
        for &h in &panel.hlines {
            y0 = y0.min(h);
            y1 = y1.max(h);
        }
        if x0 >= x1 {
            (x0, x1) = (0.0, 1.0);
        }
        if y0 >= y1 {
            (y0, y1) = (-1.0, 1.0);
        }
        let pad = 0.05 * (y1 - y0);
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d(x0..x1, (y0 - pad)..(y1 + pad))?;
        chart
            .configure_mesh()
            .x_desc("t [s]")
            .y_desc(panel.y_label.as_str())
            .light_line_style(WHITE.mix(0.0))
            .draw()?;
        for &h in &panel.hlines {
            chart.draw_series(LineSeries::new(
                vec![(x0, h), (x1, h)],
                BLACK.mix(0.6).stroke_width(1),
            ))?;
        }
        for s in &panel.series {
            let color = Palette99::pick(s.color).to_rgba();
            let style = color.stroke_width(if s.dashed { 1 } else { 2 });
            chart
                .draw_series(LineSeries::new(s.points.iter().copied(), style))?
                .label(s.label.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK.mix(0.3))
            .label_font(("sans-serif", 11))
            .draw()?;
    }
    root.present()?;
    Ok(())
}
