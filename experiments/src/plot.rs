//! The experiments' figures: bar charts drawn with plotters as SVG, rendered to PNG by resvg with
//! a font compiled in (no system fonts needed, so a figure looks the same on every machine).

use std::path::Path;

use anyhow::{anyhow, Context};
use plotters::prelude::*;

const SIZE: (u32, u32) = (900, 540);

/// One bar group: its label on the x axis and one value per series (NaN: no bar).
pub struct Group {
    pub label: String,
    pub values: Vec<f64>,
    /// Written above the group (e.g. the synchronisation time), if any.
    pub note: Option<String>,
}

/// A bar chart: groups of bars, one colour per series, and optional line series (one point per
/// group, e.g. a bound) drawn over them.
pub struct Bars<'a> {
    pub title: &'a str,
    pub y_label: &'a str,
    pub x_label: &'a str,
    pub series: &'a [&'a str],
    pub groups: Vec<Group>,
    pub lines: Vec<(&'a str, Vec<f64>)>,
}

const COLOURS: [RGBColor; 6] =
    [RGBColor(52, 101, 164), RGBColor(204, 121, 40), RGBColor(78, 154, 6), RGBColor(117, 80, 123), RGBColor(0, 150, 150), RGBColor(150, 150, 20)];
const LINE_COLOURS: [RGBColor; 2] = [RGBColor(200, 30, 30), RGBColor(40, 40, 40)];

/// Draws `bars` to `path` (PNG).
pub fn bars(path: &Path, bars: &Bars) -> anyhow::Result<()> {
    let svg = svg(bars).map_err(|e| anyhow!("drawing {}: {e}", path.display()))?;
    png(&svg, path)
}

fn svg(b: &Bars) -> Result<String, Box<dyn std::error::Error>> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, SIZE).into_drawing_area();
        root.fill(&WHITE)?;
        let values = b.groups.iter().flat_map(|g| g.values.iter()).chain(b.lines.iter().flat_map(|(_, v)| v.iter()));
        // Headroom for the notes above the bars and the legend in the upper right corner.
        let top = values.copied().filter(|v| v.is_finite()).fold(0.0_f64, f64::max).max(1e-9) * 1.4;
        let n = b.groups.len();
        let k = b.series.len().max(1);
        let mut chart = ChartBuilder::on(&root)
            .caption(b.title, ("sans-serif", 22))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..n as f64, 0.0..top)?;
        let labels: Vec<String> = b.groups.iter().map(|g| g.label.clone()).collect();
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n.max(1) * 2 + 1)
            .x_label_formatter(&|x: &f64| {
                let i = (x - 0.5).round();
                if (x - 0.5 - i).abs() < 1e-6 && i >= 0.0 {
                    labels.get(i as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .x_desc(b.x_label)
            .y_desc(b.y_label)
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 16))
            .draw()?;
        let width = 0.8 / k as f64;
        for (s, name) in b.series.iter().enumerate() {
            let colour = COLOURS[s % COLOURS.len()];
            let rects = b.groups.iter().enumerate().filter(|(_, g)| g.values.get(s).is_some_and(|v| v.is_finite())).map(|(i, g)| {
                let x0 = i as f64 + 0.1 + width * s as f64;
                Rectangle::new([(x0, 0.0), (x0 + width * 0.95, g.values[s])], colour.filled())
            });
            chart.draw_series(rects)?.label(*name).legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 14, y + 6)], colour.filled()));
        }
        for (g, group) in b.groups.iter().enumerate() {
            if let Some(note) = &group.note {
                let high = group.values.iter().copied().filter(|v| v.is_finite()).fold(0.0_f64, f64::max);
                chart.draw_series(std::iter::once(Text::new(note.clone(), (g as f64 + 0.12, high + top * 0.03), ("sans-serif", 13))))?;
            }
        }
        for (l, (name, ys)) in b.lines.iter().enumerate() {
            let colour = LINE_COLOURS[l % LINE_COLOURS.len()];
            let pts: Vec<(f64, f64)> = ys.iter().enumerate().filter(|(_, y)| y.is_finite()).map(|(i, y)| (i as f64 + 0.5, *y)).collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))?
                .label(*name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 14, y)], colour.stroke_width(2)));
            chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 4, colour.filled())))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()?;
        root.present()?;
    }
    Ok(out)
}

/// A time series: name and (t, value) points.
pub type Series<'a> = (&'a str, Vec<(f64, f64)>);

/// Panels stacked over a shared time axis, each with its line series, and events marked by
/// vertical lines labelled at the top.
pub struct Timeline<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    /// (y label, series) per panel, top first.
    pub panels: Vec<(&'a str, Vec<Series<'a>>)>,
    pub events: &'a [(f64, String)],
}

/// Draws `t` to `path` (PNG).
pub fn timeline(path: &Path, t: &Timeline) -> anyhow::Result<()> {
    let svg = timeline_svg(t).map_err(|e| anyhow!("drawing {}: {e}", path.display()))?;
    png(&svg, path)
}

fn timeline_svg(t: &Timeline) -> Result<String, Box<dyn std::error::Error>> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, SIZE).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(t.title, ("sans-serif", 22))?;
        let end =
            t.panels.iter().flat_map(|(_, s)| s.iter().flat_map(|(_, p)| p.iter().map(|p| p.0))).chain(t.events.iter().map(|e| e.0)).fold(1.0_f64, f64::max);
        let areas = root.split_evenly((t.panels.len().max(1), 1));
        for (i, ((y_label, series), area)) in t.panels.iter().zip(&areas).enumerate() {
            let top = series.iter().flat_map(|(_, p)| p.iter().map(|p| p.1)).filter(|v| v.is_finite()).fold(1e-9_f64, f64::max) * 1.25;
            let mut chart = ChartBuilder::on(area).margin(12).x_label_area_size(36).y_label_area_size(64).build_cartesian_2d(0.0..end, 0.0..top)?;
            let last = i + 1 == t.panels.len();
            chart
                .configure_mesh()
                .x_desc(if last { t.x_label } else { "" })
                .y_desc(*y_label)
                .label_style(("sans-serif", 13))
                .axis_desc_style(("sans-serif", 15))
                .draw()?;
            for (s, (name, pts)) in series.iter().enumerate() {
                let colour = COLOURS[s % COLOURS.len()];
                let pts: Vec<(f64, f64)> = pts.iter().copied().filter(|p| p.1.is_finite()).collect();
                chart
                    .draw_series(LineSeries::new(pts, colour.stroke_width(2)))?
                    .label(*name)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 14, y)], colour.stroke_width(2)));
            }
            for (k, (at, what)) in t.events.iter().enumerate() {
                let colour = LINE_COLOURS[0];
                chart.draw_series(std::iter::once(PathElement::new(vec![(*at, 0.0), (*at, top)], colour.stroke_width(1))))?;
                if i == 0 {
                    // Labels staggered so that close events stay readable.
                    let y = top * (0.95 - 0.09 * (k % 3) as f64);
                    chart.draw_series(std::iter::once(Text::new(what.clone(), (*at + end * 0.005, y), ("sans-serif", 13).into_font().color(&colour))))?;
                }
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::LowerRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 13))
                .draw()?;
        }
        root.present()?;
    }
    Ok(out)
}

fn png(svg: &str, path: &Path) -> anyhow::Result<()> {
    let mut opt = resvg::usvg::Options::default();
    let fonts = opt.fontdb_mut();
    fonts.load_font_data(epaint_default_fonts::UBUNTU_LIGHT.to_vec());
    // Hack has the arrows and signs (→, ×, ÷) Ubuntu Light lacks: text falls back to it.
    fonts.load_font_data(epaint_default_fonts::HACK_REGULAR.to_vec());
    fonts.set_sans_serif_family("Ubuntu");
    let tree = resvg::usvg::Tree::from_str(svg, &opt).map_err(|e| anyhow!("figure {}: {e}", path.display()))?;
    let mut pixels = resvg::tiny_skia::Pixmap::new(SIZE.0, SIZE.1).ok_or_else(|| anyhow!("figure {}: no pixmap", path.display()))?;
    resvg::render(&tree, resvg::tiny_skia::Transform::default(), &mut pixels.as_mut());
    let bytes = pixels.encode_png().map_err(|e| anyhow!("figure {}: {e}", path.display()))?;
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_a_png_with_text() {
        let dir = std::env::temp_dir().join(format!("mrmm-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("t.png");
        let groups = vec![
            Group { label: "5".into(), values: vec![10.0, 3.0], note: Some("sync 1.0 s".into()) },
            Group { label: "10→5".into(), values: vec![6.0, f64::NAN], note: None },
        ];
        bars(&path, &Bars { title: "t", y_label: "y", x_label: "x", series: &["a", "b"], groups, lines: vec![("bound", vec![8.0, 4.0])] }).expect("drawn");
        let png = std::fs::read(&path).expect("written");
        assert_eq!(&png[1..4], b"PNG");
        let events = [(3.0, "central killed".to_string())];
        let t = Timeline { title: "t", x_label: "s", panels: vec![("y", vec![("a", vec![(0.0, 1.0), (5.0, 2.0)])]), ("z", vec![])], events: &events };
        timeline(&dir.join("u.png"), &t).expect("drawn");
        assert_eq!(&std::fs::read(dir.join("u.png")).expect("written")[1..4], b"PNG");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
