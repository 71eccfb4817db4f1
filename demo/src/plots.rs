//! The demo's figures (plotters): Fig. 5 style torque validation and Fig. 6 style residuals,
//! each written as SVG and, beside it, as PNG.
//!
//! Made for print: quantity symbols with units on the axes, thresholds as labelled dashed
//! lines, contact onsets as labelled vertical markers, one legend for the figure in a strip
//! right of the panels (never over the data), and the Okabe–Ito colour-blind-safe palette without its yellow (too light
//! on white paper). Text in the PNG is rendered with the DejaVu Sans font shipped in
//! `demo/assets` (plotters' `ab_glyph`), so the figures do not depend on the fonts installed.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use anyhow::Context as _;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// DejaVu Sans (Bitstream Vera licence, `demo/assets/DejaVuSans-LICENSE.txt`).
const FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
/// The font family every text of the figures uses.
const FAMILY: &str = "sans-serif";

/// Okabe & Ito (2008) colours, yellow left out, in the order joints 1..7 use them.
const PALETTE: [RGBColor; 7] = [
    RGBColor(0x00, 0x72, 0xB2), // blue
    RGBColor(0xD5, 0x5E, 0x00), // vermillion
    RGBColor(0x00, 0x9E, 0x73), // bluish green
    RGBColor(0xCC, 0x79, 0xA7), // reddish purple
    RGBColor(0xE6, 0x9F, 0x00), // orange
    RGBColor(0x56, 0xB4, 0xE9), // sky blue
    RGBColor(0x00, 0x00, 0x00), // black
];
/// Thresholds shared by several joints and contact markers.
const NEUTRAL: RGBColor = RGBColor(0x55, 0x55, 0x55);

/// Dash and gap of threshold lines, SVG pixels.
const DASH: (f64, f64) = (9.0, 5.0);
/// Dash and gap of the (dotted) contact markers, SVG pixels.
const DOT: (f64, f64) = (2.0, 3.0);

/// Width of one figure in SVG pixels; the PNG is [`PNG_SCALE`] times larger.
const WIDTH: u32 = 1000;
/// Height of one panel in SVG pixels.
const PANEL_HEIGHT: u32 = 300;
/// Width of the figure's legend strip right of the panels, SVG pixels.
const LEGEND_WIDTH: u32 = 190;
/// Resolution factor of the PNG over the SVG (2000 px wide: about 200 dpi at 10 in).
const PNG_SCALE: f64 = 2.0;

/// One line of a panel.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// (time s, value) points.
    pub points: Vec<(f64, f64)>,
    /// Index into the palette (joint index for per-joint lines).
    pub color: usize,
    /// Line width, SVG pixels.
    pub width: u32,
}

/// A detection threshold ±`value`, drawn as two dashed lines and labelled at the right end.
#[derive(Debug, Clone)]
pub struct Threshold {
    /// Threshold, in the panel's unit (drawn at +value and −value); with `curve`, the value the
    /// label is written at (the curve's last).
    pub value: f64,
    /// A threshold that follows the motion (calibrated, scheduled): ±θ(t) as (time s, value)
    /// points, drawn dashed instead of the constant `value`.
    pub curve: Option<Vec<(f64, f64)>>,
    /// Label, e.g. `θ = ±6 Nm`.
    pub label: String,
    /// Palette index (the joint's colour), or `None` for a neutral grey.
    pub color: Option<usize>,
}

/// A vertical marker at time `t`, e.g. a contact onset.
#[derive(Debug, Clone)]
pub struct Marker {
    /// Time, s.
    pub t: f64,
    /// Label written beside the marker's top, e.g. `C1`.
    pub label: String,
}

/// One panel: a title, lines, thresholds and markers.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Panel title: what is drawn.
    pub title: String,
    /// Y-axis label: quantity symbol and unit, e.g. `r [Nm]`.
    pub y_label: String,
    /// Lines.
    pub series: Vec<Series>,
    /// Thresholds (±value each).
    pub thresholds: Vec<Threshold>,
    /// Vertical markers.
    pub markers: Vec<Marker>,
    /// Legend entry of the markers (e.g. `contact onsets C1–C3`), if any.
    pub marker_legend: Option<String>,
    /// Times the monitor detected a contact, s: drawn as triangles on the top edge.
    pub detections: Vec<f64>,
}

/// Legend entry of the detection triangles.
const DETECTION_LEGEND: &str = "monitor detection";

/// A tick label: integers without decimals, else the shortest of up to three decimals.
fn tick(v: f64) -> String {
    if (v - v.round()).abs() < 1e-9 {
        return format!("{:.0}", v.round() + 0.0);
    }
    let text = format!("{v:.3}");
    text.trim_end_matches('0').trim_end_matches('.').to_owned()
}

/// `points` cut where the time step exceeds ten times its median (samples the log does not
/// have, or left out): each piece is drawn as its own line, never bridged across the gap.
fn pieces(points: &[(f64, f64)]) -> Vec<&[(f64, f64)]> {
    let mut steps: Vec<f64> = points.windows(2).map(|w| w[1].0 - w[0].0).collect();
    if steps.is_empty() {
        return vec![points];
    }
    steps.sort_by(f64::total_cmp);
    let limit = 10.0 * steps[steps.len() / 2];
    let mut out = Vec::new();
    let mut start = 0;
    for k in 1..points.len() {
        if points[k].0 - points[k - 1].0 > limit {
            out.push(&points[start..k]);
            start = k;
        }
    }
    out.push(&points[start..]);
    out
}

/// Draws `panels` stacked vertically into `svg` and into the PNG beside it (same name,
/// extension `png`); returns the PNG's path.
pub fn draw(svg: &Path, panels: &[Panel]) -> anyhow::Result<PathBuf> {
    register_font()?;
    let height = PANEL_HEIGHT * panels.len().max(1) as u32;
    {
        let root = SVGBackend::new(svg, (WIDTH, height)).into_drawing_area();
        draw_on(&root, panels, 1.0)?;
        root.present()
            .with_context(|| format!("writing {}", svg.display()))?;
    }
    let png = svg.with_extension("png");
    {
        let size = (
            (f64::from(WIDTH) * PNG_SCALE) as u32,
            (f64::from(height) * PNG_SCALE) as u32,
        );
        let root = BitMapBackend::new(&png, size).into_drawing_area();
        draw_on(&root, panels, PNG_SCALE)?;
        root.present()
            .with_context(|| format!("writing {}", png.display()))?;
    }
    Ok(png)
}

/// Registers the shipped font once per process (plotters' `ab_glyph` has no system fonts).
fn register_font() -> anyhow::Result<()> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED
        .get_or_init(|| plotters::style::register_font(FAMILY, FontStyle::Normal, FONT).is_ok());
    anyhow::ensure!(
        ok,
        "the shipped font demo/assets/DejaVuSans.ttf does not parse"
    );
    Ok(())
}

/// Sizes of one rendering (SVG at 1, PNG at [`PNG_SCALE`]).
#[derive(Debug, Clone, Copy)]
struct Scale(f64);

impl Scale {
    fn px(self, svg_px: f64) -> u32 {
        (svg_px * self.0).round().max(1.0) as u32
    }
    fn font(self, svg_px: f64) -> TextStyle<'static> {
        (FAMILY, svg_px * self.0).into_font().color(&BLACK)
    }
}

fn draw_on<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    panels: &[Panel],
    scale: f64,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let s = Scale(scale);
    root.fill(&WHITE).map_err(|e| anyhow::anyhow!("{e}"))?;
    let (width, _) = root.dim_in_pixel();
    let (plots_area, legend_area) =
        root.split_horizontally(width.saturating_sub(s.px(LEGEND_WIDTH as f64)));
    let areas = plots_area.split_evenly((panels.len().max(1), 1));
    for (panel, area) in panels.iter().zip(areas.iter()) {
        draw_panel(area, panel, s).map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    draw_legend(&legend_area, &legend_of(panels), s).map_err(|e| anyhow::anyhow!("{e}"))
}

/// One legend for the whole figure: every distinct line, labelled threshold and marker of its
/// panels, each once (the panels share their joints' colours).
fn legend_of(panels: &[Panel]) -> Panel {
    let mut legend = Panel {
        title: String::new(),
        y_label: String::new(),
        series: Vec::new(),
        thresholds: Vec::new(),
        markers: Vec::new(),
        marker_legend: None,
        detections: Vec::new(),
    };
    for p in panels {
        for series in &p.series {
            if !legend
                .series
                .iter()
                .any(|l| l.label == series.label && l.color == series.color)
            {
                legend.series.push(Series {
                    points: Vec::new(),
                    ..series.clone()
                });
            }
        }
        for t in p.thresholds.iter().filter(|t| !t.label.is_empty()) {
            if !legend.thresholds.iter().any(|l| l.label == t.label) {
                legend.thresholds.push(Threshold {
                    curve: None,
                    ..t.clone()
                });
            }
        }
        if legend.marker_legend.is_none() {
            legend.marker_legend.clone_from(&p.marker_legend);
        }
        legend.detections.extend(p.detections.first());
    }
    legend
}

/// The data's x and y extent, thresholds included, y padded by 5 %.
fn extent(panel: &Panel) -> ((f64, f64), (f64, f64)) {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in panel.series.iter().flat_map(|s| &s.points) {
        if x.is_finite() && y.is_finite() {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
    }
    for t in &panel.thresholds {
        let top = t.curve.as_ref().map_or(t.value, |c| {
            c.iter()
                .map(|p| p.1)
                .filter(|y| y.is_finite())
                .fold(t.value, f64::max)
        });
        y0 = y0.min(-top);
        y1 = y1.max(top);
    }
    if x0 >= x1 {
        (x0, x1) = (0.0, 1.0);
    }
    if y0 >= y1 {
        (y0, y1) = (-1.0, 1.0);
    }
    // Room above the data for the marker labels.
    let pad = 0.05 * (y1 - y0);
    ((x0, x1), (y0 - pad, y1 + 2.5 * pad))
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
    s: Scale,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let ((x0, x1), (y0, y1)) = extent(panel);
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, s.font(17.0))
        .margin(s.px(8.0))
        .margin_right(s.px(4.0))
        .x_label_area_size(s.px(42.0))
        .y_label_area_size(s.px(62.0))
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc(panel.y_label.as_str())
        .axis_desc_style(s.font(15.0))
        .label_style(s.font(13.0))
        .bold_line_style(RGBColor(0xE4, 0xE4, 0xE4).stroke_width(s.px(1.0)))
        .light_line_style(TRANSPARENT)
        .axis_style(BLACK.stroke_width(s.px(1.0)))
        .x_labels(11)
        .y_labels(7)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .draw()?;
    // Zero line: the residual's rest value.
    chart.draw_series(LineSeries::new(
        [(x0, 0.0), (x1, 0.0)],
        RGBColor(0xAA, 0xAA, 0xAA).stroke_width(s.px(1.0)),
    ))?;
    for s_ in &panel.series {
        let color = PALETTE[s_.color % PALETTE.len()];
        for piece in pieces(&s_.points) {
            chart.draw_series(LineSeries::new(
                piece.iter().copied(),
                color.stroke_width(s.px(f64::from(s_.width))),
            ))?;
        }
    }
    // Thresholds after the data, so they stay visible where the data cross them.
    let dash = (s.px(DASH.0), s.px(DASH.1));
    for t in &panel.thresholds {
        let color = t.color.map_or(NEUTRAL, |c| PALETTE[c % PALETTE.len()]);
        // A curve per joint is thin (seven of them share the band around zero).
        let width = if t.curve.is_some() { 1.0 } else { 2.0 };
        let style = color.stroke_width(s.px(width));
        for sign in [1.0, -1.0] {
            match &t.curve {
                Some(points) => {
                    chart.draw_series(DashedLineSeries::new(
                        points.iter().map(|&(x, y)| (x, sign * y)),
                        dash.0,
                        dash.1,
                        style,
                    ))?;
                }
                None => {
                    chart.draw_series(DashedLineSeries::new(
                        [(x0, sign * t.value), (x1, sign * t.value)],
                        dash.0,
                        dash.1,
                        style,
                    ))?;
                }
            }
        }
    }
    // Threshold labels at the right end, just above +θ.
    let label_style = s.font(12.0);
    for t in panel
        .thresholds
        .iter()
        .filter(|t| !t.label.is_empty() && t.curve.is_none())
    {
        let color = t.color.map_or(NEUTRAL, |c| PALETTE[c % PALETTE.len()]);
        let style = label_style
            .clone()
            .color(&color)
            .pos(Pos::new(HPos::Right, VPos::Bottom));
        let offset = (-(s.px(4.0) as i32), -(s.px(3.0) as i32));
        chart.draw_series(std::iter::once(
            EmptyElement::at((x1, t.value)) + Text::new(t.label.clone(), offset, style),
        ))?;
    }
    // Contact markers: dotted verticals labelled at the top.
    for m in &panel.markers {
        if !(x0..=x1).contains(&m.t) {
            continue;
        }
        chart.draw_series(DashedLineSeries::new(
            [(m.t, y0), (m.t, y1)],
            s.px(DOT.0),
            s.px(DOT.1),
            NEUTRAL.stroke_width(s.px(1.5)),
        ))?;
        let style = label_style
            .clone()
            .color(&NEUTRAL)
            .pos(Pos::new(HPos::Left, VPos::Top));
        let offset = (s.px(3.0) as i32, s.px(2.0) as i32);
        chart.draw_series(std::iter::once(
            EmptyElement::at((m.t, y1)) + Text::new(m.label.clone(), offset, style),
        ))?;
    }
    // Detections: a triangle on the top edge at each.
    let size = s.px(5.0) as i32;
    chart.draw_series(
        panel
            .detections
            .iter()
            .filter(|t| (x0..=x1).contains(*t))
            .map(|&t| TriangleMarker::new((t, y1), size, BLACK.filled())),
    )?;
    Ok(())
}

/// The legend in its own strip right of the panels: one entry per line, per threshold and for
/// the markers.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
    s: Scale,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let font = s.font(13.0);
    let line = s.px(18.0) as i32;
    let sample = s.px(26.0) as i32;
    let x = s.px(6.0) as i32;
    let mut y = s.px(44.0) as i32;
    // `dash`: (dash, gap) in SVG pixels, or `None` for a solid line.
    let mut entry = |label: &str, style: ShapeStyle, dash: Option<(f64, f64)>| {
        let mid = y;
        let points = [(x, mid), (x + sample, mid)];
        let drawn = if let Some((on, off)) = dash {
            area.draw(&plotters::element::DashedPathElement::new(
                points,
                s.px(on),
                s.px(off),
                style,
            ))
        } else {
            area.draw(&PathElement::new(points, style))
        };
        let text = area.draw_text(
            label,
            &font.clone().pos(Pos::new(HPos::Left, VPos::Center)),
            (x + sample + s.px(6.0) as i32, mid),
        );
        y += line;
        drawn.and(text)
    };
    for series in &panel.series {
        let color = PALETTE[series.color % PALETTE.len()];
        entry(
            &series.label,
            color.stroke_width(s.px(f64::from(series.width.max(2)))),
            None,
        )?;
    }
    // Thresholds without a label share the legend entry of a labelled one.
    for t in panel.thresholds.iter().filter(|t| !t.label.is_empty()) {
        let color = t.color.map_or(NEUTRAL, |c| PALETTE[c % PALETTE.len()]);
        entry(&t.label, color.stroke_width(s.px(2.0)), Some(DASH))?;
    }
    if let Some(label) = &panel.marker_legend {
        entry(label, NEUTRAL.stroke_width(s.px(1.5)), Some(DOT))?;
    }
    if !panel.detections.is_empty() {
        let centre = (x + sample / 2, y);
        area.draw(&TriangleMarker::new(
            centre,
            s.px(5.0) as i32,
            BLACK.filled(),
        ))?;
        area.draw_text(
            DETECTION_LEGEND,
            &font.clone().pos(Pos::new(HPos::Left, VPos::Center)),
            (x + sample + s.px(6.0) as i32, y),
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_integers_without_decimals_and_fractions_without_trailing_zeros() {
        assert_eq!(tick(30.0), "30");
        assert_eq!(tick(-0.0), "0");
        assert_eq!(tick(-10.0), "-10");
        assert_eq!(tick(-1.5), "-1.5");
        assert_eq!(tick(0.25), "0.25");
    }

    #[test]
    fn a_line_is_cut_at_a_gap_and_kept_whole_without_one() {
        let mut points: Vec<(f64, f64)> = (0..100).map(|k| (k as f64 * 0.005, 1.0)).collect();
        assert_eq!(pieces(&points).len(), 1);
        // 60 ms missing after t = 0.25 s (a host stall in a real-time log).
        for p in points.iter_mut().skip(50) {
            p.0 += 0.06;
        }
        let cut = pieces(&points);
        assert_eq!(cut.iter().map(|p| p.len()).collect::<Vec<_>>(), [50, 50]);
    }
}
