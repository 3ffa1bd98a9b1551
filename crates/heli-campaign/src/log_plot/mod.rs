//! Plots of a flight log: one channel's fields against time, as SVG or PNG.
//!
//! The thesis's ground software "plots the data after the flight"; this is that step done on
//! the log file itself. A plot is built in two stages so that each can be tested on its own:
//! [`panels`] picks the fields out of the decoded messages (pure data, no drawing), and
//! [`render`] draws them, one panel per field group, with the flight's events as vertical
//! marks so that a phase change or a lost GPS can be lined up with the traces.
//!
//! Long channels are thinned for drawing by keeping, in each of [`MAX_POINTS_PER_SERIES`]/2
//! buckets, the lowest and the highest sample: a spike of a single sample still shows.
//! Text uses an embedded DejaVu Sans Mono, so no system font library is needed.

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

use plotters::prelude::*;
use serde_json::Value;

use heli_log::{LogContents, LoggedMessage};

/// Most points drawn per trace; longer traces are thinned by min/max buckets.
pub const MAX_POINTS_PER_SERIES: usize = 4000;

/// Width of a rendered plot (pixels).
pub const WIDTH_PX: u32 = 1200;

/// Height of one panel (pixels).
pub const PANEL_HEIGHT_PX: u32 = 220;

/// Most panels in one plot: a default plot of a wide channel stops here and says so.
pub const MAX_PANELS: usize = 12;

static FONT: &[u8] = include_bytes!("../../assets/DejaVuSansMono.ttf");

/// One trace: a field's samples against log time.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Flattened field name, e.g. `pos_ned_m[2]`.
    pub name: String,
    /// Sample times (s of vehicle clock).
    pub t_s: Vec<f64>,
    /// Sample values in the field's own unit (booleans as 0 and 1).
    pub values: Vec<f64>,
}

/// One panel: the traces of one field (all components of a vector field share a panel).
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// Field (group) name, used as the panel's title.
    pub title: String,
    /// Its traces.
    pub series: Vec<Series>,
}

/// Image formats [`render`] writes, chosen by the output file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageFormat {
    /// Scalable vector graphics (`.svg`).
    Svg,
    /// Portable network graphics (`.png`).
    Png,
}

impl ImageFormat {
    /// The format named by a path's extension, if it is one of ours.
    pub fn from_path(path: &Path) -> Option<Self> {
        match path.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "svg" => Some(ImageFormat::Svg),
            "png" => Some(ImageFormat::Png),
            _ => None,
        }
    }
}

/// What can go wrong making a plot.
#[derive(Debug)]
pub enum PlotError {
    /// The channel has no messages in the time window.
    NoMessages {
        /// The channel asked for.
        channel: String,
    },
    /// A requested field is not in the channel.
    UnknownField {
        /// The field asked for.
        field: String,
        /// The numeric fields the channel has.
        available: Vec<String>,
    },
    /// The channel has no numeric field to plot.
    NothingNumeric {
        /// The channel asked for.
        channel: String,
    },
    /// The output's extension is neither `.svg` nor `.png`.
    UnknownFormat(String),
    /// Drawing the image failed (the drawing library's error, whose type depends on the
    /// image format).
    Draw(String),
    /// The image could not be written.
    Write {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

impl fmt::Display for PlotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlotError::NoMessages { channel } => {
                write!(f, "no messages on channel '{channel}' in the time window")
            }
            PlotError::UnknownField { field, available } => write!(
                f,
                "no numeric field '{field}' on this channel; it has: {}",
                available.join(", ")
            ),
            PlotError::NothingNumeric { channel } => {
                write!(f, "channel '{channel}' has no numeric field to plot")
            }
            PlotError::UnknownFormat(path) => {
                write!(
                    f,
                    "cannot tell the image format of '{path}': use .svg or .png"
                )
            }
            PlotError::Draw(why) => write!(f, "drawing the plot: {why}"),
            PlotError::Write { path, source } => write!(f, "writing {}: {source}", path.display()),
        }
    }
}

impl std::error::Error for PlotError {}

/// A time window in seconds of vehicle clock; `None` ends are open.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Window {
    /// Earliest time plotted (s).
    pub from_s: Option<f64>,
    /// Latest time plotted (s).
    pub to_s: Option<f64>,
}

impl Window {
    fn contains(&self, t_s: f64) -> bool {
        self.from_s.is_none_or(|from| t_s >= from) && self.to_s.is_none_or(|to| t_s <= to)
    }
}

/// Panels of `channel`'s fields in `window`.
///
/// Each entry of `fields` selects the field of that name and, for a vector or a record, all
/// its components (`pos_ned_m` selects `pos_ned_m[0]` to `pos_ned_m[2]`); each entry is one
/// panel. With no fields, every numeric field is plotted, one panel per top-level field.
/// Either way at most [`MAX_PANELS`] are drawn; the second value returned says how many
/// panels were left out.
pub fn panels(
    contents: &LogContents,
    channel: &str,
    fields: &[String],
    window: Window,
) -> Result<(Vec<Panel>, usize), PlotError> {
    let messages: Vec<&LoggedMessage> = contents
        .messages
        .iter()
        .filter(|m| m.topic == channel && window.contains(seconds(m.t_us)))
        .collect();
    if messages.is_empty() {
        return Err(PlotError::NoMessages {
            channel: channel.to_string(),
        });
    }
    let columns = numeric_columns(&messages);
    if columns.is_empty() {
        return Err(PlotError::NothingNumeric {
            channel: channel.to_string(),
        });
    }
    let groups: Vec<(String, Vec<&Series>)> = if fields.is_empty() {
        let mut groups: Vec<(String, Vec<&Series>)> = Vec::new();
        for series in &columns {
            let top = top_level(&series.name);
            match groups.iter_mut().find(|(title, _)| title == top) {
                Some((_, members)) => members.push(series),
                None => groups.push((top.to_string(), vec![series])),
            }
        }
        groups
    } else {
        let mut groups = Vec::new();
        for field in fields {
            let members: Vec<&Series> =
                columns.iter().filter(|s| selects(field, &s.name)).collect();
            if members.is_empty() {
                return Err(PlotError::UnknownField {
                    field: field.clone(),
                    available: columns.iter().map(|s| s.name.clone()).collect(),
                });
            }
            groups.push((field.clone(), members));
        }
        groups
    };
    let left_out = groups.len().saturating_sub(MAX_PANELS);
    let panels = groups
        .into_iter()
        .take(MAX_PANELS)
        .map(|(title, members)| Panel {
            title,
            series: members.into_iter().map(thin).collect(),
        })
        .collect();
    Ok((panels, left_out))
}

/// The `events` channel's messages in `window`, as (time s, text) for marking on a plot.
pub fn events(contents: &LogContents, window: Window) -> Vec<(f64, String)> {
    contents
        .messages
        .iter()
        .filter(|m| m.topic == "events" && window.contains(seconds(m.t_us)))
        .map(|m| {
            let text = match m.value.get("text") {
                Some(Value::String(s)) => s.clone(),
                _ => m.value.to_string(),
            };
            (seconds(m.t_us), text)
        })
        .collect()
}

/// Draws `panels` stacked one above the other, a shared time axis, events as red vertical
/// lines numbered 1, 2, … in the top panel in the order of `events`, and writes the image
/// to `path` in `format`.
pub fn render(
    panels: &[Panel],
    events: &[(f64, String)],
    title: &str,
    format: ImageFormat,
    path: &Path,
) -> Result<(), PlotError> {
    register_font();
    let height = PANEL_HEIGHT_PX * panels.len().max(1) as u32 + 40;
    match format {
        ImageFormat::Svg => {
            let mut svg = String::new();
            {
                let root =
                    SVGBackend::with_string(&mut svg, (WIDTH_PX, height)).into_drawing_area();
                draw(&root, panels, events, title)?;
            }
            std::fs::write(path, svg).map_err(|source| PlotError::Write {
                path: path.to_path_buf(),
                source,
            })
        }
        ImageFormat::Png => {
            let root = BitMapBackend::new(path, (WIDTH_PX, height)).into_drawing_area();
            draw(&root, panels, events, title)
        }
    }
}

/// Colours of the traces within a panel, in order (a colour-blind-safe palette).
const COLOURS: [RGBColor; 6] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
];

/// Colour of the vertical marks at the flight's events.
const EVENT_MARK: RGBColor = RGBColor(200, 30, 30);

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    panels: &[Panel],
    events: &[(f64, String)],
    title: &str,
) -> Result<(), PlotError> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| PlotError::Draw(e.to_string());
    root.fill(&WHITE).map_err(err)?;
    let root = root
        .titled(title, ("sans-serif", 20))
        .map_err(|e| PlotError::Draw(e.to_string()))?;
    let (t0, t1) = time_span(panels);
    let areas = root.split_evenly((panels.len().max(1), 1));
    for (k, (area, panel)) in areas.iter().zip(panels).enumerate() {
        let (y0, y1) = value_span(panel);
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, ("sans-serif", 15))
            .margin(6)
            .x_label_area_size(38)
            .y_label_area_size(80)
            .build_cartesian_2d(t0..t1, y0..y1)
            .map_err(|e| PlotError::Draw(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc("t (s)")
            .light_line_style(WHITE.mix(0.0))
            .bold_line_style(BLACK.mix(0.08))
            .draw()
            .map_err(|e| PlotError::Draw(e.to_string()))?;
        let marks = events
            .iter()
            .filter(|(t, _)| (t0..=t1).contains(t))
            .map(|&(t, _)| PathElement::new(vec![(t, y0), (t, y1)], EVENT_MARK.mix(0.5)));
        chart
            .draw_series(marks)
            .map_err(|e| PlotError::Draw(e.to_string()))?;
        if k == 0 {
            // The marks are numbered in the top panel, in the order of `events`; events at
            // the same instant share one label ("3,4").
            let mut labels: Vec<(f64, String)> = Vec::new();
            for (i, &(t, _)) in events.iter().enumerate() {
                if !(t0..=t1).contains(&t) {
                    continue;
                }
                match labels.last_mut() {
                    Some((last, label)) if *last == t => label.push_str(&format!(",{}", i + 1)),
                    _ => labels.push((t, format!("{}", i + 1))),
                }
            }
            let numbers = labels.into_iter().map(|(t, label)| {
                Text::new(
                    label,
                    (t, y1),
                    ("sans-serif", 11).into_font().color(&EVENT_MARK),
                )
            });
            chart
                .draw_series(numbers)
                .map_err(|e| PlotError::Draw(e.to_string()))?;
        }
        for (i, series) in panel.series.iter().enumerate() {
            let colour = COLOURS.get(i % COLOURS.len()).copied().unwrap_or(BLACK);
            let points = series
                .t_s
                .iter()
                .copied()
                .zip(series.values.iter().copied());
            chart
                .draw_series(LineSeries::new(points, colour.stroke_width(1)))
                .map_err(|e| PlotError::Draw(e.to_string()))?
                .label(series.name.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], colour));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK.mix(0.3))
            .draw()
            .map_err(|e| PlotError::Draw(e.to_string()))?;
    }
    root.present().map_err(|e| PlotError::Draw(e.to_string()))
}

fn register_font() {
    // Registering twice replaces the font with itself; an error means the embedded file is
    // damaged, and then plotters reports the missing font when it draws text.
    let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
}

fn seconds(t_us: u64) -> f64 {
    t_us as f64 * 1e-6
}

/// Every numeric (or boolean) flattened field of `messages`, in order of first appearance.
fn numeric_columns(messages: &[&LoggedMessage]) -> Vec<Series> {
    let mut index: BTreeMap<String, usize> = BTreeMap::new();
    let mut columns: Vec<Series> = Vec::new();
    let mut leaves = Vec::new();
    for m in messages {
        leaves.clear();
        numeric_leaves(&m.value, &mut leaves);
        for (name, value) in leaves.drain(..) {
            let i = *index.entry(name.clone()).or_insert_with(|| {
                columns.push(Series {
                    name,
                    t_s: Vec::new(),
                    values: Vec::new(),
                });
                columns.len() - 1
            });
            if let Some(series) = columns.get_mut(i) {
                series.t_s.push(seconds(m.t_us));
                series.values.push(value);
            }
        }
    }
    columns
}

fn numeric_leaves(value: &Value, out: &mut Vec<(String, f64)>) {
    heli_log::for_each_leaf("", value, &mut |name, v| match v {
        Value::Number(n) => {
            if let Some(x) = n.as_f64().filter(|x| x.is_finite()) {
                out.push((name, x));
            }
        }
        Value::Bool(b) => out.push((name, if *b { 1.0 } else { 0.0 })),
        _ => {}
    });
}

/// The top-level field a flattened name belongs to: `pos_ned_m[2]` → `pos_ned_m`.
fn top_level(name: &str) -> &str {
    name.split(['[', '.']).next().unwrap_or(name)
}

/// Whether the requested `field` selects the flattened column `name`.
fn selects(field: &str, name: &str) -> bool {
    name == field
        || name
            .strip_prefix(field)
            .is_some_and(|rest| rest.starts_with('[') || rest.starts_with('.'))
}

/// `series` thinned to at most [`MAX_POINTS_PER_SERIES`] points: in each bucket, its lowest
/// and highest samples in time order.
fn thin(series: &Series) -> Series {
    let n = series.values.len();
    if n <= MAX_POINTS_PER_SERIES {
        return series.clone();
    }
    let buckets = MAX_POINTS_PER_SERIES / 2;
    let mut out = Series {
        name: series.name.clone(),
        t_s: Vec::with_capacity(MAX_POINTS_PER_SERIES),
        values: Vec::with_capacity(MAX_POINTS_PER_SERIES),
    };
    for b in 0..buckets {
        let start = b * n / buckets;
        let end = ((b + 1) * n / buckets).min(n);
        let Some(bucket) = series.values.get(start..end) else {
            continue;
        };
        let mut lo = 0;
        let mut hi = 0;
        for (i, v) in bucket.iter().enumerate() {
            if bucket.get(lo).is_some_and(|l| v < l) {
                lo = i;
            }
            if bucket.get(hi).is_some_and(|h| v > h) {
                hi = i;
            }
        }
        let (first, second) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        for i in if first == second {
            vec![first]
        } else {
            vec![first, second]
        } {
            if let (Some(&t), Some(&v)) = (series.t_s.get(start + i), bucket.get(i)) {
                out.t_s.push(t);
                out.values.push(v);
            }
        }
    }
    out
}

fn time_span(panels: &[Panel]) -> (f64, f64) {
    let times = panels
        .iter()
        .flat_map(|p| &p.series)
        .flat_map(|s| s.t_s.iter().copied());
    padded(times)
}

fn value_span(panel: &Panel) -> (f64, f64) {
    let (lo, hi) = padded(panel.series.iter().flat_map(|s| s.values.iter().copied()));
    let margin = 0.05 * (hi - lo);
    (lo - margin, hi + margin)
}

/// Largest magnitude an axis reaches: a diverged value (up to ±1.8e308) is drawn at the edge,
/// and the axis arithmetic (width, margin) stays finite. An infinite axis would never finish
/// laying out its ticks.
const AXIS_LIMIT: f64 = 1e300;

/// The range of `values` within ±[`AXIS_LIMIT`], widened when it is (nearly) a single value so
/// that an axis can be drawn.
fn padded(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .map(|v| v.clamp(-AXIS_LIMIT, AXIS_LIMIT))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return (0.0, 1.0);
    }
    let scale = lo.abs().max(hi.abs());
    if hi - lo <= 1e-9 * scale || scale == 0.0 {
        let half = (scale * 0.1).max(0.5);
        return (lo - half, hi + half);
    }
    (lo, hi)
}

#[cfg(test)]
mod tests;
