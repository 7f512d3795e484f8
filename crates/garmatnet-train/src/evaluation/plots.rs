//! PNG charts of per-pose errors (the paper's Figs. 7–8), drawn with plotters' bitmap
//! backend and an embedded DejaVu Sans font (through `ab_glyph`), so no system font library
//! (fontconfig, freetype) is needed.

use std::path::Path;
use std::sync::OnceLock;

use image::RgbImage;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

use crate::error::{Error, Result};

/// DejaVu Sans (Bitstream Vera licence, see `assets/DejaVuSans-LICENSE.txt`).
static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

/// Registers the embedded font once per process.
fn ensure_font() -> std::result::Result<(), String> {
    static REGISTERED: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            register_font("sans-serif", FontStyle::Normal, FONT)
                .map_err(|_| "the embedded font is not a valid TrueType font".to_owned())
        })
        .clone()
}

/// Draws with `draw` on a white `width × height` bitmap (embedded font registered) and saves
/// it as a PNG at `path`, atomically.
fn render_png(
    path: &Path,
    (width, height): (u32, u32),
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> std::result::Result<(), String>,
) -> Result<()> {
    let plot_error = |message: String| Error::Plot {
        path: path.to_owned(),
        message,
    };
    ensure_font().map_err(plot_error)?;
    let mut buffer = vec![0u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_error(e.to_string()))?;
        draw(&root).map_err(plot_error)?;
        root.present().map_err(|e| plot_error(e.to_string()))?;
    }
    let image = RgbImage::from_raw(width, height, buffer)
        .ok_or_else(|| plot_error("the pixel buffer has the wrong size".into()))?;
    Ok(garmatnet_core::render::save_png(path, &image)?)
}

/// One line of a chart: a label and `(x, y)` points.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// The legend label.
    pub label: String,
    /// The points, in x order.
    pub points: Vec<(f64, f64)>,
}

/// Draws a line chart of `series` titled `title` and saves it as a PNG at `path`
/// (atomically), `width` × `height` pixels.
///
/// # Errors
/// [`Error::Plot`] if drawing fails; [`Error::Core`] (I/O) if the file cannot be written.
pub fn line_chart(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    (width, height): (u32, u32),
) -> Result<()> {
    render_png(path, (width, height), |root| {
        let all = series.iter().flat_map(|s| s.points.iter());
        let (mut x0, mut x1, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64);
        for &(x, y) in all {
            x0 = x0.min(x);
            x1 = x1.max(x);
            if y.is_finite() {
                y1 = y1.max(y);
            }
        }
        if !x0.is_finite() {
            (x0, x1) = (0.0, 1.0);
        }
        if x1 <= x0 {
            x1 = x0 + 1.0;
        }
        let y1 = if y1 > 0.0 { y1 * 1.1 } else { 1.0 };
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d(x0..x1, 0.0..y1)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(|e| e.to_string())?;
        let colours = [
            RGBColor(40, 90, 200),
            RGBColor(210, 50, 40),
            RGBColor(40, 160, 80),
        ];
        for (i, s) in series.iter().enumerate() {
            let colour = colours[i % colours.len()];
            chart
                .draw_series(LineSeries::new(
                    s.points.iter().copied(),
                    colour.stroke_width(2),
                ))
                .map_err(|e| e.to_string())?
                .label(s.label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour));
            chart
                .draw_series(s.points.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                .map_err(|e| e.to_string())?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(|e| e.to_string())?;
        Ok(())
    })
}

/// One labelled point of a [`pareto_chart`].
#[derive(Debug, Clone, PartialEq)]
pub struct ParetoPoint {
    /// Text drawn next to the point.
    pub label: String,
    /// Index into the chart's group names (colour and legend).
    pub group: usize,
    /// Horizontal value (> 0; the axis is logarithmic).
    pub x: f64,
    /// Vertical value.
    pub y: f64,
    /// Drawn larger and outlined (e.g. on the Pareto front).
    pub highlight: bool,
}

/// Draws labelled points on a logarithmic x axis (run time against error) and saves the PNG
/// at `path` (atomically). Points with a non-positive or non-finite coordinate are left out.
///
/// # Errors
/// [`Error::Plot`] if drawing fails; [`Error::Core`] (I/O) if the file cannot be written.
pub fn pareto_chart(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    points: &[ParetoPoint],
    groups: &[&str],
    (width, height): (u32, u32),
) -> Result<()> {
    let shown: Vec<&ParetoPoint> = points
        .iter()
        .filter(|p| p.x > 0.0 && p.x.is_finite() && p.y.is_finite())
        .collect();
    let (mut x0, mut x1, mut y1) = (f64::INFINITY, 0.0f64, 0.0f64);
    for p in &shown {
        x0 = x0.min(p.x);
        x1 = x1.max(p.x);
        y1 = y1.max(p.y);
    }
    if shown.is_empty() {
        (x0, x1) = (0.1, 10.0);
    }
    // Room on the right for the labels of the slowest points.
    let (x0, x1) = (x0 / 2.0, x1 * 40.0);
    let y1 = if y1 > 0.0 { y1 * 1.12 } else { 1.0 };
    // Label the highlighted points first, then any other whose label would not overlap one
    // already placed (positions in approximate pixels of the plotting area).
    let to_px = |p: &ParetoPoint| {
        let fx = (p.x.ln() - x0.ln()) / (x1.ln() - x0.ln());
        (fx * f64::from(width), (1.0 - p.y / y1) * f64::from(height))
    };
    let mut order: Vec<usize> = (0..shown.len()).collect();
    order.sort_by_key(|&i| !shown[i].highlight);
    let mut boxes: Vec<(f64, f64, f64)> = Vec::new();
    let mut labelled = vec![false; shown.len()];
    for i in order {
        let p = shown[i];
        let (x, y) = to_px(p);
        let w = 6.5 * p.label.chars().count() as f64;
        let clear = boxes
            .iter()
            .all(|&(bx, by, bw)| x + w < bx || bx + bw < x || (y - by).abs() > 14.0);
        if p.highlight || clear {
            boxes.push((x, y, w));
            labelled[i] = true;
        }
    }
    render_png(path, (width, height), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", 22))
            .margin(14)
            .x_label_area_size(44)
            .y_label_area_size(56)
            .build_cartesian_2d((x0..x1).log_scale(), 0.0..y1)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(|e| e.to_string())?;
        let colours = [
            RGBColor(210, 50, 40),
            RGBColor(40, 90, 200),
            RGBColor(40, 160, 80),
            RGBColor(120, 120, 120),
        ];
        for (g, name) in groups.iter().enumerate() {
            let colour = colours[g % colours.len()];
            let members: Vec<&&ParetoPoint> = shown.iter().filter(|p| p.group == g).collect();
            if members.is_empty() {
                continue;
            }
            chart
                .draw_series(members.iter().map(|p| {
                    let size = if p.highlight { 6 } else { 4 };
                    Circle::new((p.x, p.y), size, colour.filled())
                }))
                .map_err(|e| e.to_string())?
                .label(*name)
                .legend(move |(x, y)| Circle::new((x + 8, y), 5, colour.filled()));
            chart
                .draw_series(
                    members
                        .iter()
                        .filter(|p| p.highlight)
                        .map(|p| Circle::new((p.x, p.y), 9, BLACK.stroke_width(1))),
                )
                .map_err(|e| e.to_string())?;
            chart
                .draw_series(
                    shown
                        .iter()
                        .enumerate()
                        .filter(|&(i, p)| p.group == g && labelled[i])
                        .map(|(_, p)| {
                            Text::new(
                                p.label.clone(),
                                (p.x * 1.12, p.y),
                                ("sans-serif", 12).into_font().color(&colour),
                            )
                        }),
                )
                .map_err(|e| e.to_string())?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(|e| e.to_string())?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_chart_renders_points_on_a_log_axis() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("pareto.png");
        let point = |label: &str, group, x, y, highlight| ParetoPoint {
            label: label.into(),
            group,
            x,
            y,
            highlight,
        };
        let points = vec![
            point("simulator", 0, 3000.0, 0.0, true),
            point("GarMatNet full", 1, 5.0, 4.0, true),
            point("baseline", 2, 4.0, 9.0, false),
            point("broken", 1, f64::NAN, 1.0, false),
        ];
        pareto_chart(
            &path,
            "t",
            "ms",
            "mm",
            &points,
            &["simulator", "GarMatNet", "baseline"],
            (640, 400),
        )
        .unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        let red = img.pixels().filter(|p| p.0[0] > 180 && p.0[1] < 90).count();
        let blue = img.pixels().filter(|p| p.0[2] > 180 && p.0[0] < 90).count();
        assert!(
            red > 20 && blue > 20,
            "points missing: red {red}, blue {blue}"
        );
    }

    #[test]
    fn chart_with_text_renders_to_png() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("chart.png");
        let series = vec![
            Series {
                label: "GarMatNet".into(),
                points: vec![(0.0, 3.0), (10.0, 4.0), (20.0, 2.5)],
            },
            Series {
                label: "Baseline".into(),
                points: vec![(0.0, 5.0), (10.0, 6.0), (20.0, 4.5)],
            },
        ];
        line_chart(
            &path,
            "Cashmere",
            "frame",
            "error (mm)",
            &series,
            (480, 320),
        )
        .unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (480, 320));
        let non_white = img.pixels().filter(|p| p.0 != [255, 255, 255]).count();
        assert!(non_white > 1000, "the chart is blank");
    }
}
