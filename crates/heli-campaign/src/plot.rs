//! Outcomes against each varied value: one panel per `[[vary]]` key, x the flight's value
//! (text and booleans as categories; dots on a grid value spread a little sideways), y its
//! ranking score on a log scale (worst criterion over its limit; above the red line at 1 it
//! failed), each flight a dot coloured by outcome. Errors, which have no score, are drawn
//! at the top. SVG or PNG.

use std::path::Path;

use crate::log_plot::{ImageFormat, PlotError};
use plotters::coord::Shift;
use plotters::prelude::*;

use super::report::{FlightOutcome, FlightRecord, Report, SCORE_CAP};

/// Width of the image (pixels).
pub const WIDTH_PX: u32 = 1000;

/// Height of one panel (pixels).
pub const PANEL_HEIGHT_PX: u32 = 260;

/// Most panels drawn (the first keys in file order).
pub const MAX_PANELS: usize = 12;

/// The font the images' text uses (heli-log's, so no system font library is needed).
static FONT: &[u8] = include_bytes!("../assets/DejaVuSansMono.ttf");

/// Colours by outcome (colour-blind-safe): pass, fail, crash, error.
const PASS: RGBColor = RGBColor(0, 158, 115);
const FAIL: RGBColor = RGBColor(230, 159, 0);
const CRASH: RGBColor = RGBColor(213, 94, 0);
const ERROR: RGBColor = RGBColor(0, 0, 0);

/// One panel's points: x, y, outcome; and the category names when x is categorical.
struct Panel {
    title: String,
    points: Vec<(f64, f64, FlightOutcome)>,
    categories: Option<Vec<String>>,
}

/// Draws the report's outcome plot to `path` in `format`.
pub fn render(report: &Report, format: ImageFormat, path: &Path) -> Result<(), PlotError> {
    let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    let span = Span::of(report);
    let panels = panels(report, span);
    let height = PANEL_HEIGHT_PX * panels.len().max(1) as u32 + 50;
    let title = format!(
        "{}: {} flights, {} pass, {} fail, {} crash, {} error",
        report.campaign,
        report.totals.flights,
        report.totals.pass,
        report.totals.fail,
        report.totals.crash,
        report.totals.error
    );
    match format {
        ImageFormat::Svg => {
            let mut svg = String::new();
            {
                let root =
                    SVGBackend::with_string(&mut svg, (WIDTH_PX, height)).into_drawing_area();
                draw(&root, &panels, span, &title)?;
            }
            std::fs::write(path, svg).map_err(|source| PlotError::Write {
                path: path.to_path_buf(),
                source,
            })
        }
        ImageFormat::Png => {
            let root = BitMapBackend::new(path, (WIDTH_PX, height)).into_drawing_area();
            draw(&root, &panels, span, &title)
        }
    }
}

/// The y axis: scores on a log scale from `lo` to `hi`; lower scores are drawn at `lo`,
/// errors (no score) at `hi`.
#[derive(Clone, Copy)]
struct Span {
    lo: f64,
    hi: f64,
}

impl Span {
    fn of(report: &Report) -> Self {
        let scores = report.flights.iter().filter_map(|f| f.score);
        let least = scores
            .clone()
            .filter(|s| *s > 0.0)
            .fold(f64::INFINITY, f64::min);
        let most = scores.fold(0.0_f64, f64::max);
        Span {
            lo: (least * 0.8).clamp(0.01, 0.5),
            hi: (most.min(SCORE_CAP) * 1.25).max(1.5),
        }
    }

    fn y(&self, f: &FlightRecord) -> f64 {
        f.score.map_or(self.hi, |s| s.clamp(self.lo, self.hi))
    }
}

/// A dot's sideways offset, a fraction of `spacing`, fixed by the flight's index: dots on
/// one grid value or category stay apart.
fn jitter(index: u64, spacing: f64) -> f64 {
    let u = (index.wrapping_mul(2_654_435_761) % 1000) as f64 / 1000.0;
    (u - 0.5) * 0.15 * spacing
}

/// Keys with at most this many distinct values are drawn with jitter (grids, choices).
const FEW_VALUES: usize = 12;

fn panels(report: &Report, span: Span) -> Vec<Panel> {
    if report.keys.is_empty() {
        return vec![Panel {
            title: "flight index (nothing varied)".into(),
            points: report
                .flights
                .iter()
                .map(|f| (f.index as f64, span.y(f), f.outcome))
                .collect(),
            categories: None,
        }];
    }
    report
        .keys
        .iter()
        .take(MAX_PANELS)
        .map(|key| {
            let values: Vec<Option<&serde_json::Value>> =
                report.flights.iter().map(|f| f.values.get(key)).collect();
            let numeric = values.iter().flatten().all(|v| v.is_number());
            if numeric {
                let mut distinct: Vec<f64> =
                    values.iter().flatten().filter_map(|v| v.as_f64()).collect();
                distinct.sort_by(f64::total_cmp);
                distinct.dedup();
                let spacing = if distinct.len() > FEW_VALUES {
                    0.0
                } else {
                    distinct
                        .windows(2)
                        .map(|w| w[1] - w[0])
                        .fold(f64::INFINITY, f64::min)
                };
                let spacing = if spacing.is_finite() { spacing } else { 0.0 };
                Panel {
                    title: key.clone(),
                    points: report
                        .flights
                        .iter()
                        .zip(&values)
                        .filter_map(|(f, v)| {
                            let x = v.and_then(|v| v.as_f64())?;
                            Some((x + jitter(f.index, spacing), span.y(f), f.outcome))
                        })
                        .collect(),
                    categories: None,
                }
            } else {
                let mut names: Vec<String> = values.iter().flatten().map(|v| label(v)).collect();
                names.sort();
                names.dedup();
                let points = report
                    .flights
                    .iter()
                    .zip(&values)
                    .filter_map(|(f, v)| {
                        let name = label(v.as_ref()?);
                        let i = names.iter().position(|n| *n == name)?;
                        Some((i as f64 + jitter(f.index, 1.0), span.y(f), f.outcome))
                    })
                    .collect();
                Panel {
                    title: key.clone(),
                    points,
                    categories: Some(names),
                }
            }
        })
        .collect()
}

/// A tick's text: at most four decimals, trailing zeros dropped.
fn tick(x: f64) -> String {
    let text = format!("{x:.4}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" {
        "0".into()
    } else {
        text.into()
    }
}

fn label(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    panels: &[Panel],
    span: Span,
    title: &str,
) -> Result<(), PlotError> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| PlotError::Draw(e.to_string());
    root.fill(&WHITE).map_err(e)?;
    let root = root.titled(title, ("sans-serif", 18)).map_err(e)?;
    let areas = root.split_evenly((panels.len().max(1), 1));
    for (area, panel) in areas.iter().zip(panels) {
        let (x0, x1) = match &panel.categories {
            Some(names) => (-0.5, names.len() as f64 - 0.5),
            None => {
                let lo = panel
                    .points
                    .iter()
                    .map(|p| p.0)
                    .fold(f64::INFINITY, f64::min);
                let hi = panel
                    .points
                    .iter()
                    .map(|p| p.0)
                    .fold(f64::NEG_INFINITY, f64::max);
                if !lo.is_finite() || !hi.is_finite() {
                    (0.0, 1.0)
                } else {
                    let pad = ((hi - lo) * 0.04).max(1e-9 + lo.abs() * 1e-3);
                    (lo - pad, hi + pad)
                }
            }
        };
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, ("sans-serif", 14))
            .margin(8)
            .x_label_area_size(36)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, (span.lo..span.hi).log_scale())
            .map_err(|e| PlotError::Draw(e.to_string()))?;
        let categories = panel.categories.clone();
        let x_label = move |x: &f64| match &categories {
            Some(names) => {
                let i = x.round();
                if (x - i).abs() < 1e-6 && i >= 0.0 {
                    names.get(i as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            }
            None => tick(*x),
        };
        chart
            .configure_mesh()
            .y_desc("score (above 1 fails)")
            .y_labels(8)
            .y_label_formatter(&|y: &f64| tick(*y))
            .x_label_formatter(&x_label)
            .light_line_style(WHITE.mix(0.0))
            .bold_line_style(BLACK.mix(0.08))
            .draw()
            .map_err(|e| PlotError::Draw(e.to_string()))?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(x0, 1.0), (x1, 1.0)],
                RED.mix(0.5).stroke_width(1),
            )))
            .map_err(|e| PlotError::Draw(e.to_string()))?;
        for (outcome, colour) in [
            (FlightOutcome::Pass, PASS),
            (FlightOutcome::Fail, FAIL),
            (FlightOutcome::Crash, CRASH),
            (FlightOutcome::Error, ERROR),
        ] {
            let dots: Vec<(f64, f64)> = panel
                .points
                .iter()
                .filter(|p| p.2 == outcome)
                .map(|p| (p.0, p.1))
                .collect();
            if dots.is_empty() {
                continue;
            }
            chart
                .draw_series(
                    dots.into_iter()
                        .map(move |p| Circle::new(p, 3, colour.mix(0.8).filled())),
                )
                .map_err(|e| PlotError::Draw(e.to_string()))?
                .label(outcome.name())
                .legend(move |(x, y)| Circle::new((x + 6, y), 4, colour.filled()));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK.mix(0.3))
            .draw()
            .map_err(|e| PlotError::Draw(e.to_string()))?;
    }
    root.present().map_err(|e| PlotError::Draw(e.to_string()))
}
