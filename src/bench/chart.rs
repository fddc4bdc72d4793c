//! The bench chart: error against wall time, both axes logarithmic, one
//! panel per scene, one curve per series, points labelled with their
//! setting. The legend says which series show raw solutions (the solve's
//! own vertex values, timed as the solve) and which the default pipeline
//! (final gather, timed as the whole run).
//! Written as SVG (text left to the viewer's fonts) and PNG (text drawn with
//! DejaVu Sans, loaded at run time; without it the PNG is skipped).

use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::element::{Drawable, PointCollection};
use plotters::prelude::*;

use super::{BenchPoint, Sweep};
use crate::error::{Error, Result};

/// Fonts tried for the PNG's text, in order.
pub const FONT_CANDIDATES: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
];

const PANEL_WIDTH: u32 = 620;
const HEIGHT: u32 = 600;
const TITLE_HEIGHT: u32 = 92;
/// Width of one legend entry.
const LEGEND_STEP: i32 = 300;
/// Under the legend: what the series are and what the reference is.
pub const NOTE: &str = "raw: element-by-element solve to 1e-3, the solve's own vertex values (no final gather), time = solve. default: vkrad SCENE (hierarchical hemicube, discontinuity display mesh, final gather), time = whole run. Error over pixels of one lit surface.";
const FONT: &str = "sans-serif";

/// What was written: the SVG always; the PNG, or why not.
pub struct ChartOutcome {
    pub png: std::result::Result<(), String>,
}

/// Registers DejaVu Sans as plotters' `sans-serif` once per process.
/// The font bytes are leaked: plotters needs them `'static`.
pub(crate) fn register_font() -> std::result::Result<(), String> {
    static REGISTERED: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            for path in FONT_CANDIDATES {
                let Ok(bytes) = std::fs::read(path) else {
                    continue;
                };
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                return plotters::style::register_font(FONT, FontStyle::Normal, bytes)
                    .map_err(|_| format!("{path} is not a usable font"));
            }
            Err(format!(
                "no font for the PNG's text (looked for {}); install DejaVu Sans (Debian/Ubuntu: apt-get install fonts-dejavu-core). The SVG has the chart",
                FONT_CANDIDATES.join(", ")
            ))
        })
        .clone()
}

/// Colour, marker and legend name of each series.
fn style(sweep: Sweep) -> (RGBColor, &'static str) {
    match sweep {
        Sweep::Hemicube => (RGBColor(31, 119, 180), "raw hemicube: resolution"),
        Sweep::RayTrace => (RGBColor(214, 39, 40), "raw ray trace: rays per vertex"),
        Sweep::ElementSize => (RGBColor(44, 160, 44), "raw hemicube: element count"),
        Sweep::Default => (RGBColor(255, 127, 14), "default + final gather: edges"),
    }
}

/// The order in which a series' points are joined (cheapest setting
/// first), so the curve follows the sweep even where timings are noisy.
fn sweep_order(sweep: Sweep, p: &BenchPoint) -> usize {
    match sweep {
        Sweep::Hemicube => p.hemicube_res.unwrap_or(0) as usize,
        Sweep::RayTrace => p.rays.unwrap_or(0),
        Sweep::ElementSize => p.elements,
        Sweep::Default => p.display_elements.unwrap_or(p.elements),
    }
}

/// Smallest error drawn when no error is positive.
const ERROR_FLOOR: f64 = 1e-6;

/// Where a panel draws an error of 0 (a run that matches the reference
/// exactly): a quarter of the smallest positive error, so the log axis is
/// not stretched.
fn error_floor(points: &[&BenchPoint]) -> f64 {
    let smallest = points
        .iter()
        .map(|p| p.error)
        .filter(|e| *e > 0.0)
        .fold(f64::INFINITY, f64::min);
    if smallest.is_finite() {
        smallest * 0.25
    } else {
        ERROR_FLOOR
    }
}

/// A point's label: its setting.
fn point_label(p: &BenchPoint) -> String {
    p.setting.clone()
}

/// Pads a positive range by a factor on both sides (log axes).
fn log_range(values: impl Iterator<Item = f64>, floor: f64) -> std::ops::Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
        let v = v.max(floor);
        (lo.min(v), hi.max(v))
    });
    if !lo.is_finite() || hi <= 0.0 {
        return floor..floor * 10.0;
    }
    let (lo, hi) = (lo / 1.6, hi * 1.6);
    if hi / lo < 10.0 {
        let mid = (lo * hi).sqrt();
        (mid / 3.2)..(mid * 3.2)
    } else {
        lo..hi
    }
}

/// Scenes in the order they first appear.
fn scene_names(points: &[BenchPoint]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for p in points {
        if !names.contains(&p.scene) {
            names.push(p.scene.clone());
        }
    }
    names
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    points: &[BenchPoint],
    title: &str,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let (title_area, body) = root.split_vertically(TITLE_HEIGHT);
    title_area.draw(&Text::new(
        title.to_owned(),
        (16, 10),
        (FONT, 22).into_font().color(&BLACK),
    ))?;
    title_area.draw(&Text::new(
        NOTE,
        (16, 68),
        (FONT, 13).into_font().color(&BLACK),
    ))?;
    // One legend for all panels: the series are the same in each.
    let mut x = 16;
    for sweep in Sweep::ALL {
        let (colour, legend) = style(sweep);
        let y = 50;
        title_area.draw(&PathElement::new(
            vec![(x, y), (x + 26, y)],
            colour.stroke_width(2),
        ))?;
        title_area.draw(&marker::<DB, _>(sweep, (x + 13, y), colour.filled()))?;
        title_area.draw(&Text::new(
            legend,
            (x + 32, y - 7),
            (FONT, 14).into_font().color(&BLACK),
        ))?;
        x += LEGEND_STEP;
    }
    let names = scene_names(points);
    let panels = body.split_evenly((1, names.len().max(1)));
    for (name, panel) in names.iter().zip(panels.iter()) {
        let scene_points: Vec<&BenchPoint> = points.iter().filter(|p| &p.scene == name).collect();
        let x_range = log_range(scene_points.iter().map(|p| p.wall_seconds), 1e-3);
        let floor = error_floor(&scene_points);
        let y_range = log_range(scene_points.iter().map(|p| p.error), floor);
        let reference = scene_points
            .first()
            .map(|p| p.reference.clone())
            .unwrap_or_default();
        let elements = scene_points
            .iter()
            .filter(|p| p.method == Sweep::Hemicube)
            .map(|p| p.elements)
            .next()
            .unwrap_or(0);
        let mut chart = ChartBuilder::on(panel)
            .caption(
                format!("{name} (raw: {elements} elements)"),
                (FONT, 19).into_font(),
            )
            .margin(12)
            .x_label_area_size(52)
            .y_label_area_size(72)
            .build_cartesian_2d(x_range.log_scale(), y_range.log_scale())?;
        chart
            .configure_mesh()
            .x_desc("wall time (s)")
            .y_desc(format!(
                "relative RMS image error vs {}",
                short_reference(&reference)
            ))
            .axis_desc_style((FONT, 14))
            .label_style((FONT, 12))
            .x_label_formatter(&|v| tick_label(*v, false))
            .y_label_formatter(&|v| tick_label(*v, true))
            .light_line_style(WHITE.mix(0.0))
            .bold_line_style(BLACK.mix(0.12))
            .draw()?;
        let mut series_by_sweep = Vec::new();
        for sweep in Sweep::ALL {
            let (colour, _) = style(sweep);
            let mut series: Vec<&BenchPoint> = scene_points
                .iter()
                .copied()
                .filter(|p| p.method == sweep)
                .collect();
            if series.is_empty() {
                continue;
            }
            series.sort_by_key(|p| sweep_order(sweep, p));
            let xy = |p: &BenchPoint| (p.wall_seconds.max(1e-3), p.error.max(floor));
            chart.draw_series(LineSeries::new(
                series.iter().map(|p| xy(p)),
                colour.stroke_width(2),
            ))?;
            chart.draw_series(
                series
                    .iter()
                    .map(|p| marker::<DB, _>(sweep, xy(p), colour.filled())),
            )?;
            series_by_sweep.push((sweep, colour, series));
        }
        // Labels: hemicube above-left, rays below-right, elements right, so
        // the curves' labels rarely collide; a label that would overlap one
        // already placed is left out, the ends of each curve placed first.
        let mut placed: Vec<(i32, i32, i32, i32)> = Vec::new();
        let right_edge = chart.plotting_area().get_pixel_range().0.end;
        for (sweep, colour, series) in &series_by_sweep {
            let base_offset = match sweep {
                Sweep::Hemicube => (-8, -16),
                Sweep::RayTrace => (6, 5),
                Sweep::ElementSize => (7, -6),
                Sweep::Default => (8, 4),
            };
            let n = series.len();
            let mut order: Vec<usize> = (0..n).collect();
            order.sort_by_key(|&i| usize::from(i != 0 && i + 1 != n));
            for i in order {
                let p = series[i];
                let label = point_label(p);
                let at = (p.wall_seconds.max(1e-3), p.error.max(floor));
                let (px, py) = chart.backend_coord(&at);
                // Keep the label inside the plot: shift it left if needed.
                let width = 6 * label.chars().count() as i32;
                let mut offset = base_offset;
                offset.0 -= (px + offset.0 + width - right_edge).max(0);
                let (x0, y0) = (px + offset.0, py + offset.1);
                let b = (x0, y0, x0 + width, y0 + 12);
                let overlaps = placed
                    .iter()
                    .any(|q| b.0 < q.2 && q.0 < b.2 && b.1 < q.3 && q.1 < b.3);
                if overlaps {
                    continue;
                }
                placed.push(b);
                chart.draw_series(std::iter::once(
                    EmptyElement::at(at)
                        + Text::new(label, offset, (FONT, 11).into_font().color(colour)),
                ))?;
            }
        }
    }
    root.present()?;
    Ok(())
}

/// `per-pixel gather (...) from ...` -> `per-pixel gather`;
/// `hemicube 1024px, converge 1e-4` -> `hemicube 1024px ref.`.
fn short_reference(kind: &str) -> String {
    if kind.starts_with("per-pixel gather") {
        return "per-pixel gather".into();
    }
    let head = kind.split(',').next().unwrap_or(kind).trim();
    if head.is_empty() {
        "reference".into()
    } else {
        format!("{head} ref.")
    }
}

/// The marker of a sweep's points.
fn marker<DB: DrawingBackend, C: Clone + 'static>(
    sweep: Sweep,
    at: C,
    style: ShapeStyle,
) -> DynElement<'static, DB, C>
where
    Circle<C, i32>: Drawable<DB>,
    TriangleMarker<C, i32>: Drawable<DB>,
    Cross<C, i32>: Drawable<DB>,
    for<'a> &'a Circle<C, i32>: PointCollection<'a, C>,
    for<'a> &'a TriangleMarker<C, i32>: PointCollection<'a, C>,
    for<'a> &'a Cross<C, i32>: PointCollection<'a, C>,
{
    match sweep {
        Sweep::Hemicube => Circle::new(at, 4, style).into_dyn(),
        Sweep::RayTrace => TriangleMarker::new(at, 5, style).into_dyn(),
        Sweep::ElementSize => Cross::new(at, 5, style).into_dyn(),
        Sweep::Default => Circle::new(at, 6, style).into_dyn(),
    }
}

/// Log-axis tick labels at 1, 2 and 5 times a power of ten only (plotters
/// puts a tick at every integer multiple, far too many to label).
pub(crate) fn tick_label(v: f64, scientific: bool) -> String {
    if v.is_nan() || v <= 0.0 {
        return String::new();
    }
    let exponent = v.log10().floor();
    let mantissa = v / 10f64.powf(exponent);
    let nearest = mantissa.round();
    if (mantissa - nearest).abs() > 1e-6 * mantissa || ![1.0, 2.0, 5.0].contains(&nearest) {
        return String::new();
    }
    if scientific {
        format!("{nearest:.0}e{exponent:.0}")
    } else if v >= 1.0 {
        format!("{v:.0}")
    } else {
        let digits = (-exponent) as usize;
        format!("{v:.digits$}")
    }
}

fn chart_size(points: &[BenchPoint]) -> (u32, u32) {
    let panels = scene_names(points).len().max(1) as u32;
    (PANEL_WIDTH * panels, HEIGHT)
}

/// Renders the chart to SVG text. Plotters needs font metrics even for
/// SVG text, so without a font the chart is drawn by [`plain_svg`] instead.
pub fn render_svg(points: &[BenchPoint], title: &str) -> std::result::Result<String, String> {
    if register_font().is_err() {
        return Ok(plain_svg(points, title));
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, chart_size(points)).into_drawing_area();
        draw(&root, points, title).map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

/// Renders the chart to RGB8 pixels; `Err` when no font is available.
pub fn render_png_pixels(
    points: &[BenchPoint],
    title: &str,
) -> std::result::Result<(u32, u32, Vec<u8>), String> {
    register_font()?;
    let (w, h) = chart_size(points);
    let mut pixels = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area();
        draw(&root, points, title).map_err(|e| e.to_string())?;
    }
    Ok((w, h, pixels))
}

/// Writes an 8-bit RGB PNG atomically.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    crate::output::write_atomically(path, |out| {
        use image::ImageEncoder;
        image::codecs::png::PngEncoder::new(out)
            .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
            .map_err(|e| Error::Output {
                path: path.to_owned(),
                what: e.to_string(),
            })
    })
}

/// Writes `svg` (always) and `png` (when a font is found), atomically.
/// A chart that cannot be drawn at all is an error; a PNG that cannot be
/// drawn is reported in the outcome.
pub fn write_charts(
    points: &[BenchPoint],
    title: &str,
    svg: &Path,
    png: &Path,
) -> Result<ChartOutcome> {
    let text = render_svg(points, title).map_err(|what| Error::Output {
        path: svg.to_owned(),
        what,
    })?;
    crate::output::write_atomically(svg, |w| {
        std::io::Write::write_all(w, text.as_bytes()).map_err(|e| Error::io(svg, e))
    })?;
    let outcome = match render_png_pixels(points, title) {
        Ok((w, h, pixels)) => {
            write_png(png, w, h, &pixels)?;
            Ok(())
        }
        Err(why) => Err(why),
    };
    Ok(ChartOutcome { png: outcome })
}

/// Escapes text for SVG.
fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The same chart written directly as SVG, for when no font file is found
/// (text is then laid out by the SVG viewer): panels, log axes with decade
/// ticks, one polyline per sweep, labelled points and a legend.
pub fn plain_svg(points: &[BenchPoint], title: &str) -> String {
    use std::fmt::Write;
    let (width, height) = chart_size(points);
    let mut svg = String::new();
    let _ = write!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif">
<rect width="100%" height="100%" fill="white"/>
<text x="16" y="30" font-size="22">{}</text>
<text x="16" y="80" font-size="13">{}</text>
"#,
        xml(title),
        xml(NOTE)
    );
    let mut lx = 16;
    for sweep in Sweep::ALL {
        let (c, legend) = style(sweep);
        let colour = format!("rgb({},{},{})", c.0, c.1, c.2);
        let _ = writeln!(
            svg,
            r#"<line x1="{lx}" y1="50" x2="{}" y2="50" stroke="{colour}" stroke-width="2"/><circle cx="{}" cy="50" r="4" fill="{colour}"/><text x="{}" y="55" font-size="14">{}</text>"#,
            lx + 26,
            lx + 13,
            lx + 32,
            xml(legend)
        );
        lx += LEGEND_STEP;
    }
    for (i, name) in scene_names(points).iter().enumerate() {
        let scene_points: Vec<&BenchPoint> = points.iter().filter(|p| &p.scene == name).collect();
        let xr = log_range(scene_points.iter().map(|p| p.wall_seconds), 1e-3);
        let floor = error_floor(&scene_points);
        let yr = log_range(scene_points.iter().map(|p| p.error), floor);
        let left = i as f64 * PANEL_WIDTH as f64 + 84.0;
        let right = (i + 1) as f64 * PANEL_WIDTH as f64 - 14.0;
        let (top, bottom) = (TITLE_HEIGHT as f64 + 40.0, height as f64 - 64.0);
        let fx = |v: f64| {
            left + (v.max(1e-3).ln() - xr.start.ln()) / (xr.end.ln() - xr.start.ln())
                * (right - left)
        };
        let fy = |v: f64| {
            bottom
                - (v.max(floor).ln() - yr.start.ln()) / (yr.end.ln() - yr.start.ln())
                    * (bottom - top)
        };
        let reference = scene_points
            .first()
            .map(|p| p.reference.clone())
            .unwrap_or_default();
        let _ = writeln!(
            svg,
            r#"<rect x="{left}" y="{top}" width="{}" height="{}" fill="none" stroke="black"/>
<text x="{}" y="{}" font-size="19" text-anchor="middle">{}</text>
<text x="{}" y="{}" font-size="14" text-anchor="middle">wall time (s)</text>
<text transform="translate({},{}) rotate(-90)" font-size="14" text-anchor="middle">relative RMS image error vs {}</text>"#,
            right - left,
            bottom - top,
            (left + right) / 2.0,
            top - 14.0,
            xml(name),
            (left + right) / 2.0,
            bottom + 44.0,
            left - 62.0,
            (top + bottom) / 2.0,
            xml(&short_reference(&reference))
        );
        for e in (xr.start.log10().ceil() as i32)..=(xr.end.log10().floor() as i32) {
            let v = 10f64.powi(e);
            let x = fx(v);
            let _ = writeln!(
                svg,
                r##"<line x1="{x}" y1="{top}" x2="{x}" y2="{bottom}" stroke="#ddd"/><text x="{x}" y="{}" font-size="12" text-anchor="middle">{}</text>"##,
                bottom + 18.0,
                tick_label(v, false)
            );
        }
        for e in (yr.start.log10().ceil() as i32)..=(yr.end.log10().floor() as i32) {
            let v = 10f64.powi(e);
            let y = fy(v);
            let _ = writeln!(
                svg,
                r##"<line x1="{left}" y1="{y}" x2="{right}" y2="{y}" stroke="#ddd"/><text x="{}" y="{}" font-size="12" text-anchor="end">{}</text>"##,
                left - 6.0,
                y + 4.0,
                tick_label(v, true)
            );
        }
        for sweep in Sweep::ALL {
            let (c, _) = style(sweep);
            let colour = format!("rgb({},{},{})", c.0, c.1, c.2);
            let mut series: Vec<&BenchPoint> = scene_points
                .iter()
                .copied()
                .filter(|p| p.method == sweep)
                .collect();
            series.sort_by_key(|p| sweep_order(sweep, p));
            let path: Vec<String> = series
                .iter()
                .map(|p| format!("{:.1},{:.1}", fx(p.wall_seconds), fy(p.error)))
                .collect();
            let _ = writeln!(
                svg,
                r#"<polyline points="{}" fill="none" stroke="{colour}" stroke-width="2"/>"#,
                path.join(" ")
            );
            for p in &series {
                let (x, y) = (fx(p.wall_seconds), fy(p.error));
                let _ = writeln!(
                    svg,
                    r#"<circle cx="{x:.1}" cy="{y:.1}" r="4" fill="{colour}"/><text x="{:.1}" y="{:.1}" font-size="11" fill="{colour}">{}</text>"#,
                    x + 6.0,
                    y - 6.0,
                    xml(&point_label(p))
                );
            }
        }
    }
    svg.push_str("</svg>\n");
    svg
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(scene: &str, method: Sweep, t: f64, error: f64) -> BenchPoint {
        BenchPoint {
            scene: scene.into(),
            method,
            setting: format!("{t}"),
            hemicube_res: Some(16),
            rays: Some(4),
            max_edge: 1.0,
            elements: 10,
            shots: 10,
            converged: true,
            wall_seconds: t,
            error,
            display_elements: None,
            gathered: method.gathered(),
            reference: "per-pixel gather, 1024 rays".into(),
            repeats: 1,
        }
    }

    #[test]
    fn tick_labels_only_at_1_2_5() {
        assert_eq!(tick_label(0.1, false), "0.1");
        assert_eq!(tick_label(0.02, false), "0.02");
        assert_eq!(tick_label(20.0, false), "20");
        assert_eq!(tick_label(0.03, false), "");
        assert_eq!(tick_label(5e-3, true), "5e-3");
        assert_eq!(tick_label(7e-3, true), "");
    }

    #[test]
    fn plain_svg_has_every_scene_and_setting() {
        let points = vec![
            point("a<b", Sweep::Hemicube, 0.5, 1e-2),
            point("a<b", Sweep::Hemicube, 2.0, 1e-3),
            point("c", Sweep::RayTrace, 0.1, 0.0),
        ];
        let svg = plain_svg(&points, "title & more");
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("a&lt;b") && svg.contains("title &amp; more"));
        assert!(svg.contains("wall time (s)") && svg.contains("final gather"));
        assert!(svg.contains(">0.5<") && svg.contains(">2<"));
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
    }
}
