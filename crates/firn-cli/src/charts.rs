//! Line charts for `firn bench --sweep`, as PNG files: plotters draws into an
//! RGB buffer (its bitmap backend) and the text is set in DejaVu Sans, bundled
//! in the binary and rasterised by ab_glyph, so no system font, fontconfig or
//! freetype is needed. The x-axis is logarithmic (base 2); the y-axis is
//! logarithmic (base 10) when the values span more than a factor of ten.

use std::collections::BTreeMap;
use std::error::Error;
use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::prelude::*;

/// DejaVu Sans 2.37 (licence: assets/fonts/LICENSE-DejaVu.txt).
const FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// Width and height of every chart, in pixels.
pub const CHART_SIZE: (u32, u32) = (1000, 640);

/// Line colours, one per series in order (blue, red, green, orange).
const PALETTE: [RGBColor; 4] = [
    RGBColor(31, 100, 180),
    RGBColor(205, 45, 40),
    RGBColor(40, 150, 60),
    RGBColor(230, 130, 20),
];

/// The y values must span more than this factor for a logarithmic y-axis.
const LOG_Y_ABOVE: f64 = 10.0;

/// One measured value as a chart sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// Name of the series (the transfer scheme) it belongs to.
    pub series: String,
    /// Position on the x-axis in its own units (a particle or cell count).
    pub x: f64,
    /// The value, or `None` for a size that was not measured.
    pub y: Option<f64>,
}

/// One line of a chart: a name and its points by increasing x.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// (x, y) in the axes' own units.
    pub points: Vec<(f64, f64)>,
}

/// Groups `samples` into series, in order of each series' first sample, and
/// keeps exactly the points a logarithmic chart can show: measured, finite
/// and positive. Each series' points are sorted by x.
pub fn build_series(samples: &[Sample]) -> Vec<Series> {
    let mut series: Vec<Series> = Vec::new();
    for sample in samples {
        let index = match series.iter().position(|s| s.name == sample.series) {
            Some(index) => index,
            None => {
                series.push(Series {
                    name: sample.series.clone(),
                    points: Vec::new(),
                });
                series.len() - 1
            }
        };
        if let Some(y) = sample.y
            && y.is_finite()
            && y > 0.0
            && sample.x.is_finite()
            && sample.x > 0.0
        {
            series[index].points.push((sample.x, y));
        }
    }
    for line in &mut series {
        line.points.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    series
}

/// How the x-axis is labelled.
#[derive(Clone, Debug, PartialEq)]
pub enum XTicks {
    /// A tick at every power of two in range, labelled 2ᵏ.
    PowersOfTwo,
    /// A tick at each given x (axis units) with its label.
    Labelled(Vec<(f64, String)>),
}

/// The words on a chart.
#[derive(Clone, Debug)]
pub struct ChartText {
    /// Title, at the top.
    pub title: String,
    /// A smaller line under the title: the setting of the measurement.
    pub subtitle: String,
    /// Description of the x-axis, with its unit.
    pub x_label: String,
    /// Description of the y-axis, with its unit.
    pub y_label: String,
}

/// Draws `series` as lines with points and writes the chart as a PNG of
/// [`CHART_SIZE`] at `path` (atomically).
pub fn draw_chart(
    path: &Path,
    text: &ChartText,
    x_ticks: &XTicks,
    series: &[Series],
) -> Result<(), String> {
    register_font()?;
    let (width, height) = CHART_SIZE;
    let mut buffer = vec![0u8; width as usize * height as usize * 3];
    render(&mut buffer, text, x_ticks, series)
        .map_err(|error| format!("cannot draw {}: {error}", path.display()))?;
    let image = image::RgbImage::from_raw(width, height, buffer)
        .ok_or_else(|| format!("cannot draw {}: wrong buffer size", path.display()))?;
    firn_render::output::write_png(path, &image).map_err(|error| error.to_string())
}

/// Registers the bundled font as plotters' "sans-serif" (once per process).
fn register_font() -> Result<(), String> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let registered = *REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_ok()
    });
    if registered {
        Ok(())
    } else {
        Err("the bundled chart font cannot be read".into())
    }
}

/// One axis: a linear coordinate over transformed values (log2 or log10 of
/// the data, or the data itself), its ticks, and their labels.
struct Axis {
    range: (f64, f64),
    ticks: BTreeMap<u64, String>,
    transform: fn(f64) -> f64,
}

impl Axis {
    fn coord(&self) -> TickedRange {
        TickedRange {
            range: self.range,
            ticks: self
                .ticks
                .keys()
                .map(|&bits| f64::from_bits(bits))
                .collect(),
        }
    }

    fn label(&self, value: f64) -> String {
        self.ticks
            .iter()
            .find(|(bits, _)| (f64::from_bits(**bits) - value).abs() < 1e-9)
            .map(|(_, label)| label.clone())
            .unwrap_or_default()
    }

    fn add_tick(&mut self, at: f64, label: String) {
        if at >= self.range.0 - 1e-9 && at <= self.range.1 + 1e-9 {
            self.ticks.insert(at.to_bits(), label);
        }
    }
}

/// A linear f64 coordinate whose mesh lines and labels sit exactly at the
/// given ticks (plotters' `with_key_points` on an f64 range does not accept
/// the label formatters).
struct TickedRange {
    range: (f64, f64),
    ticks: Vec<f64>,
}

impl Ranged for TickedRange {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let share = (value - self.range.0) / (self.range.1 - self.range.0);
        limit.0 + (f64::from(limit.1 - limit.0) * share + 1e-3).floor() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.range.0..self.range.1
    }
}

fn identity(value: f64) -> f64 {
    value
}

/// The x-axis: log2 of the data, half a power of two of room on each side.
fn x_axis(points: &[(f64, f64)], ticks: &XTicks) -> Axis {
    let logs = points.iter().map(|p| p.0.log2());
    let (low, high) = min_max(logs).unwrap_or((0.0, 1.0));
    let mut axis = Axis {
        range: (low - 0.5, high + 0.5),
        ticks: BTreeMap::new(),
        transform: f64::log2,
    };
    match ticks {
        XTicks::PowersOfTwo => {
            let (first, last) = (axis.range.0.ceil() as i32, axis.range.1.floor() as i32);
            for k in first..=last {
                axis.add_tick(k as f64, format!("2{}", superscript(k)));
            }
        }
        XTicks::Labelled(labels) => {
            for (x, label) in labels {
                axis.add_tick(x.log2(), label.clone());
            }
        }
    }
    axis
}

/// The y-axis: logarithmic when the values span more than [`LOG_Y_ABOVE`],
/// else linear from zero; ticks at 1, 2 and 5 times powers of ten.
fn y_axis(points: &[(f64, f64)]) -> Axis {
    let (low, high) = min_max(points.iter().map(|p| p.1)).unwrap_or((1.0, 10.0));
    if high / low > LOG_Y_ABOVE {
        let (low, high) = (low.log10(), high.log10());
        let room = ((high - low) * 0.08).max(0.1);
        let mut axis = Axis {
            range: (low - room, high + room),
            ticks: BTreeMap::new(),
            transform: f64::log10,
        };
        let span = axis.range.1 - axis.range.0;
        let multiples: &[f64] = if span > 4.0 { &[1.0] } else { &[1.0, 2.0, 5.0] };
        for decade in axis.range.0.floor() as i32..=axis.range.1.ceil() as i32 {
            for &multiple in multiples {
                let value = multiple * 10f64.powi(decade);
                axis.add_tick(value.log10(), format_value(value));
            }
        }
        axis
    } else {
        let top = high * 1.12;
        let step = nice_step(top / 6.0);
        let mut axis = Axis {
            range: (0.0, top),
            ticks: BTreeMap::new(),
            transform: identity,
        };
        let mut value = 0.0;
        while value <= top {
            axis.add_tick(value, format_value(value));
            value += step;
        }
        axis
    }
}

/// The smallest of 1, 2 and 5 times a power of ten that is at least `rough`.
fn nice_step(rough: f64) -> f64 {
    let power = 10f64.powf(rough.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|multiple| multiple * power)
        .find(|&step| step >= rough)
        .unwrap_or(10.0 * power)
}

fn min_max(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values.fold(None, |range, value| match range {
        None => Some((value, value)),
        Some((low, high)) => Some((low.min(value), high.max(value))),
    })
}

/// A tick value: whole numbers with thousands separators, small ones with up
/// to three significant digits.
fn format_value(value: f64) -> String {
    if value >= 1.0 && (value - value.round()).abs() < 1e-6 {
        let digits = format!("{:.0}", value);
        let mut grouped = String::new();
        for (i, digit) in digits.chars().enumerate() {
            if i > 0 && (digits.len() - i).is_multiple_of(3) {
                grouped.push(',');
            }
            grouped.push(digit);
        }
        grouped
    } else if value == 0.0 {
        "0".into()
    } else {
        let decimals = (2 - value.abs().log10().floor() as i32).max(0) as usize;
        let text = format!("{value:.decimals$}");
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// `k` in superscript digits (DejaVu Sans has them all).
pub fn superscript(k: i32) -> String {
    k.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            _ => '⁹',
        })
        .collect()
}

/// The legend corner with the fewest points near it (in the unit square of
/// the plotting area).
fn legend_corner(points: &[(f64, f64)]) -> SeriesLabelPosition {
    let corners = [
        (SeriesLabelPosition::UpperRight, (1.0, 1.0)),
        (SeriesLabelPosition::UpperLeft, (0.0, 1.0)),
        (SeriesLabelPosition::LowerRight, (1.0, 0.0)),
        (SeriesLabelPosition::LowerLeft, (0.0, 0.0)),
    ];
    let crowding = |corner: (f64, f64)| {
        points
            .iter()
            .filter(|p| (p.0 - corner.0).abs() < 0.4 && (p.1 - corner.1).abs() < 0.35)
            .count()
    };
    corners
        .into_iter()
        .min_by_key(|(_, corner)| crowding(*corner))
        .map(|(position, _)| position)
        .unwrap_or(SeriesLabelPosition::UpperRight)
}

fn render(
    buffer: &mut [u8],
    text: &ChartText,
    x_ticks: &XTicks,
    series: &[Series],
) -> Result<(), Box<dyn Error>> {
    let all: Vec<(f64, f64)> = series.iter().flat_map(|s| s.points.clone()).collect();
    let x = x_axis(&all, x_ticks);
    let y = y_axis(&all);
    let to_chart = |point: &(f64, f64)| ((x.transform)(point.0), (y.transform)(point.1));
    let unit = |point: &(f64, f64)| {
        let (cx, cy) = to_chart(point);
        (
            (cx - x.range.0) / (x.range.1 - x.range.0),
            (cy - y.range.0) / (y.range.1 - y.range.0),
        )
    };
    let legend = legend_corner(&all.iter().map(unit).collect::<Vec<_>>());

    let root = BitMapBackend::with_buffer(buffer, CHART_SIZE).into_drawing_area();
    root.fill(&WHITE)?;
    let (header, body) = root.split_vertically(78);
    header.draw(&Text::new(
        text.title.clone(),
        (24, 14),
        ("sans-serif", 26).into_font().color(&BLACK),
    ))?;
    header.draw(&Text::new(
        text.subtitle.clone(),
        (24, 50),
        ("sans-serif", 16).into_font().color(&RGBColor(80, 80, 80)),
    ))?;
    let mut chart = ChartBuilder::on(&body)
        .margin_left(16)
        .margin_right(32)
        .margin_top(8)
        .margin_bottom(16)
        .x_label_area_size(64)
        .y_label_area_size(96)
        .build_cartesian_2d(x.coord(), y.coord())?;
    let x_format = |value: &f64| x.label(*value);
    let y_format = |value: &f64| y.label(*value);
    chart
        .configure_mesh()
        .x_desc(text.x_label.as_str())
        .y_desc(text.y_label.as_str())
        .axis_desc_style(("sans-serif", 19))
        .label_style(("sans-serif", 16))
        .x_label_formatter(&x_format)
        .y_label_formatter(&y_format)
        .bold_line_style(RGBColor(225, 225, 225))
        .axis_style(RGBColor(90, 90, 90))
        .draw()?;
    for (index, line) in series.iter().enumerate() {
        let colour = PALETTE[index % PALETTE.len()];
        let points: Vec<(f64, f64)> = line.points.iter().map(to_chart).collect();
        chart
            .draw_series(LineSeries::new(points.clone(), colour.stroke_width(3)))?
            .label(line.name.as_str())
            .legend(move |(px, py)| {
                PathElement::new(vec![(px, py), (px + 28, py)], colour.stroke_width(3))
            });
        chart.draw_series(
            points
                .iter()
                .map(|&point| Circle::new(point, 6, colour.filled())),
        )?;
    }
    if !series.is_empty() {
        chart
            .configure_series_labels()
            .position(legend)
            .margin(14)
            .legend_area_size(40)
            .label_font(("sans-serif", 17))
            .background_style(WHITE.mix(0.9))
            .border_style(RGBColor(170, 170, 170))
            .draw()?;
    }
    root.present()?;
    Ok(())
}
