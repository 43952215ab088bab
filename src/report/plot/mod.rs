//! Scientific log-log figures as SVG, rasterised to PNG with resvg.
//!
//! Why our own writer instead of a plotting crate: the figures we need (Allan deviations with
//! confidence bands, Welch spectra with marked lines, residual panels) are a handful of primitives,
//! and owning the SVG lets us guarantee what a reviewer signing off a sensor relies on: decade
//! ticks labelled as powers of ten, gaps (never lines to zero) where data are missing or
//! non-positive, byte-identical output for identical input, and a PNG that looks the same on every
//! machine because the only font used for rasterising is the DejaVu Sans embedded in the binary.
//!
//! Layout: a [`Figure`] is a title plus [`Panel`]s stacked vertically, each with its own axes.
//! [`Figure::to_svg`] writes the SVG; [`Figure::to_png`] rasterises exactly that SVG.

mod axes;
mod draw;
mod raster;
mod svg;

/// An sRGB colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Color(pub u8, pub u8, pub u8);

impl Color {
    pub const BLACK: Color = Color(0, 0, 0);
    pub const GRAY: Color = Color(120, 120, 120);

    /// `#rrggbb`, the form every SVG consumer understands.
    pub fn hex(&self) -> String {
        format!("#{:02x}{:02x}{:02x}", self.0, self.1, self.2)
    }
}

/// The Okabe–Ito palette, reordered so that the first colours are the most distinct on white
/// and under the common colour-vision deficiencies; yellow comes last because it is hard to see
/// as a thin line on a white background.
pub const PALETTE: [Color; 8] = [
    Color(0, 114, 178),   // blue
    Color(213, 94, 0),    // vermillion
    Color(0, 158, 115),   // bluish green
    Color(204, 121, 167), // reddish purple
    Color(230, 159, 0),   // orange
    Color(86, 180, 233),  // sky blue
    Color(0, 0, 0),       // black
    Color(240, 228, 66),  // yellow
];

/// Point marker shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    Circle,
    Square,
    Cross,
}

/// How a series is drawn. `width` is the stroke width in px (markers scale with it),
/// `dash` a dash pattern in px, `opacity` the stroke opacity (the fill opacity for a band).
/// Out-of-range values (negative or non-finite widths, opacities outside 0..1) are sanitised
/// when drawing rather than rejected, so a bad style never fails a report.
#[derive(Debug, Clone, PartialEq)]
pub struct Style {
    pub color: Color,
    pub width: f64,
    pub dash: Option<Vec<f64>>,
    pub opacity: f64,
    pub marker: Option<Marker>,
}

impl Style {
    /// A solid 1.5 px line.
    pub fn line(color: Color) -> Style {
        Style {
            color,
            width: 1.5,
            dash: None,
            opacity: 1.0,
            marker: None,
        }
    }
    /// A dashed 1.3 px line, for fitted model terms drawn over the data.
    pub fn dashed(color: Color) -> Style {
        Style {
            width: 1.3,
            dash: Some(vec![6.0, 4.0]),
            ..Style::line(color)
        }
    }
    /// Circle markers (error bars, if any, are drawn 1 px wide).
    pub fn points(color: Color) -> Style {
        Style {
            width: 1.0,
            marker: Some(Marker::Circle),
            ..Style::line(color)
        }
    }
    /// A translucent fill, for confidence bands.
    pub fn band(color: Color) -> Style {
        Style {
            opacity: 0.2,
            ..Style::line(color)
        }
    }
    pub fn with_width(mut self, width: f64) -> Style {
        self.width = width;
        self
    }
    pub fn with_dash(mut self, dash: &[f64]) -> Style {
        self.dash = Some(dash.to_vec());
        self
    }
    pub fn with_opacity(mut self, opacity: f64) -> Style {
        self.opacity = opacity;
        self
    }
    pub fn with_marker(mut self, marker: Marker) -> Style {
        self.marker = Some(marker);
        self
    }
}

/// Axis scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scale {
    #[default]
    Linear,
    Log,
}

/// One thing drawn in a panel. Values that cannot be shown (non-finite, or non-positive on a
/// log axis) are dropped point by point; a `Line` breaks into separate pieces there, so a gap in
/// the data shows as a gap. Lengths of `x`, `y`, `lo`, `hi` may differ: the shortest wins.
#[derive(Debug, Clone, PartialEq)]
pub enum Series {
    Line {
        label: Option<String>,
        x: Vec<f64>,
        y: Vec<f64>,
        style: Style,
    },
    /// points with optional vertical error bars (absolute lo/hi values, not offsets)
    Points {
        label: Option<String>,
        x: Vec<f64>,
        y: Vec<f64>,
        lo: Option<Vec<f64>>,
        hi: Option<Vec<f64>>,
        style: Style,
    },
    /// filled band between lo(x) and hi(x) (a confidence band)
    Band {
        label: Option<String>,
        x: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
        style: Style,
    },
    /// vertical marker line at x with a short text label at the top (e.g. a spectral line found
    /// at 12.5 Hz). The label is written next to the line, so it is not repeated in the legend.
    VLine {
        label: Option<String>,
        x: f64,
        style: Style,
    },
}

impl Series {
    /// A line with a legend label.
    pub fn line(label: &str, x: Vec<f64>, y: Vec<f64>, style: Style) -> Series {
        Series::Line {
            label: Some(label.to_string()),
            x,
            y,
            style,
        }
    }

    /// The legend label, if this series appears in the legend.
    pub fn legend_label(&self) -> Option<&str> {
        match self {
            Series::Line { label, .. }
            | Series::Points { label, .. }
            | Series::Band { label, .. } => label.as_deref(),
            Series::VLine { .. } => None,
        }
    }
}

/// Where the legend sits inside the plot area. `Auto` takes the corner (in the order listed)
/// that hides the fewest data points, for panels whose data may fill the top-right corner.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Corner {
    #[default]
    TopRight,
    TopLeft,
    BottomRight,
    BottomLeft,
    Auto,
}

/// One set of axes. `height` is a relative weight: panels share the figure height in
/// proportion to it. `x_range`/`y_range`, when given and usable on the axis scale, replace the
/// padded data range. `hlines` are drawn under the data, across the whole panel.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    pub title: Option<String>,
    pub x_label: String,
    pub y_label: String,
    pub x_scale: Scale,
    pub y_scale: Scale,
    pub series: Vec<Series>,
    pub height: f64,
    pub x_range: Option<(f64, f64)>,
    pub y_range: Option<(f64, f64)>,
    pub hlines: Vec<(f64, Style)>,
    pub legend: bool,
    pub legend_at: Corner,
}

impl Panel {
    pub fn new(x_label: &str, y_label: &str, x_scale: Scale, y_scale: Scale) -> Panel {
        Panel {
            title: None,
            x_label: x_label.to_string(),
            y_label: y_label.to_string(),
            x_scale,
            y_scale,
            series: Vec::new(),
            height: 1.0,
            x_range: None,
            y_range: None,
            hlines: Vec::new(),
            legend: true,
            legend_at: Corner::TopRight,
        }
    }
    pub fn loglog(x_label: &str, y_label: &str) -> Panel {
        Panel::new(x_label, y_label, Scale::Log, Scale::Log)
    }
    pub fn semilogx(x_label: &str, y_label: &str) -> Panel {
        Panel::new(x_label, y_label, Scale::Log, Scale::Linear)
    }
    pub fn semilogy(x_label: &str, y_label: &str) -> Panel {
        Panel::new(x_label, y_label, Scale::Linear, Scale::Log)
    }
    pub fn linear(x_label: &str, y_label: &str) -> Panel {
        Panel::new(x_label, y_label, Scale::Linear, Scale::Linear)
    }
}

/// A figure: title plus panels stacked top to bottom.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    pub title: String,
    pub width_px: u32,
    pub height_px: u32,
    pub panels: Vec<Panel>,
}

/// Largest PNG side we agree to allocate: 16384² RGBA is 1 GiB, beyond which a typo in a
/// size option should fail cleanly rather than exhaust memory.
pub const MAX_PNG_SIDE: u32 = 16384;

/// Why a figure could not be turned into a PNG. (SVG output cannot fail.)
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("invalid image size {width}x{height} px (each side must be 1..={MAX_PNG_SIDE})")]
    InvalidSize { width: u64, height: u64 },
    #[error("rendering the figure's SVG failed: {0}")]
    Svg(String),
    #[error("encoding the PNG failed: {0}")]
    Encode(String),
}

impl Figure {
    pub fn new(title: &str, width_px: u32, height_px: u32) -> Figure {
        Figure {
            title: title.to_string(),
            width_px,
            height_px,
            panels: Vec::new(),
        }
    }

    /// The figure as a standalone SVG document. Never fails: anything that cannot be drawn is
    /// left out (or noted as "no data"), because a report with one odd plot beats no report.
    pub fn to_svg(&self) -> String {
        draw::render(self)
    }

    /// PNG bytes of [`Figure::to_svg`] rasterised at `width_px` × `height_px`.
    pub fn to_png(&self) -> Result<Vec<u8>, PlotError> {
        self.to_png_scaled(1.0)
    }

    /// As [`Figure::to_png`] at `scale` times the pixel size (e.g. 2.0 for high-DPI screens or
    /// print); the layout is identical, only sharper.
    pub fn to_png_scaled(&self, scale: f32) -> Result<Vec<u8>, PlotError> {
        raster::rasterize(&self.to_svg(), self.width_px, self.height_px, scale)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use resvg::tiny_skia::Pixmap;

    fn parses(svg: &str) {
        if let Err(e) = resvg::usvg::Tree::from_str(svg, &raster::options()) {
            panic!("SVG does not parse: {e}\n{svg}");
        }
    }

    fn png_size(png: &[u8]) -> (u32, u32) {
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(&png[12..16], b"IHDR");
        let be = |i: usize| u32::from_be_bytes([png[i], png[i + 1], png[i + 2], png[i + 3]]);
        (be(16), be(20))
    }

    /// Pixels in rows `y0..y1` satisfying `f(r, g, b)`.
    fn count(pm: &Pixmap, y0: u32, y1: u32, f: impl Fn(u8, u8, u8) -> bool) -> usize {
        let w = pm.width() as usize;
        pm.pixels()[y0 as usize * w..y1.min(pm.height()) as usize * w]
            .iter()
            .filter(|p| f(p.red(), p.green(), p.blue()))
            .count()
    }

    fn line_panel(y: Vec<f64>) -> Panel {
        let x = (1..=y.len()).map(|i| i as f64).collect();
        let mut p = Panel::loglog("x", "y");
        p.series.push(Series::line(
            "data",
            x,
            y,
            Style::line(PALETTE[1]).with_width(3.0),
        ));
        p
    }

    #[test]
    fn svg_parses_escapes_text_and_lists_labelled_series() {
        let mut fig = Figure::new("a < b & c", 640, 480);
        let mut p = line_panel(vec![1.0, 2.0, 3.0]);
        p.title = Some("τ σ √ ² µ ° \"q\"".into());
        p.series.push(Series::Line {
            label: None,
            x: vec![1.0, 3.0],
            y: vec![2.0, 2.0],
            style: Style::dashed(PALETTE[2]),
        });
        p.series.push(Series::Band {
            label: Some("95 % <band>".into()),
            x: vec![1.0, 2.0, 3.0],
            lo: vec![0.5, 1.0, 1.5],
            hi: vec![2.0, 3.0, 4.0],
            style: Style::band(PALETTE[0]),
        });
        fig.panels.push(p);
        let svg = fig.to_svg();
        parses(&svg);
        assert!(svg.contains(">a &lt; b &amp; c</text>"));
        assert!(!svg.contains("a < b"));
        assert!(svg.contains("τ σ √ ² µ ° &quot;q&quot;"));
        assert!(svg.contains(">data</text>") && svg.contains(">95 % &lt;band&gt;</text>"));
        // two lines of one piece each (legend swatches are <line>s, not polylines)
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert_eq!(svg.matches("<text").count(), svg.matches("</text>").count());
        assert!(svg.contains("font-family=\"DejaVu Sans, sans-serif\""));
        assert!(svg.contains("clip-path=\"url(#imn-clip-0)\""));
    }

    #[test]
    fn gaps_break_lines_into_pieces() {
        let mut fig = Figure::new("", 400, 300);
        let mut p = line_panel(vec![1.0, 2.0, 3.0, f64::NAN, -1.0, 4.0, 5.0]);
        p.legend = false;
        fig.panels.push(p);
        let svg = fig.to_svg();
        parses(&svg);
        let lines: Vec<&str> = svg.lines().filter(|l| l.starts_with("<polyline")).collect();
        assert_eq!(lines.len(), 2, "{svg}");
        let npts = |l: &str| {
            l.split("points=\"").nth(1).map_or(0, |s| {
                s.split('"').next().map_or(0, |p| p.split(' ').count())
            })
        };
        assert_eq!((npts(lines[0]), npts(lines[1])), (3, 2));
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
    }

    #[test]
    fn error_bars_reaching_zero_on_log_axis_end_at_panel_bottom() {
        let mut fig = Figure::new("", 400, 300);
        let mut p = Panel::loglog("x", "y");
        p.series.push(Series::Points {
            label: None,
            x: vec![1.0, 10.0],
            y: vec![1.0, 2.0],
            lo: Some(vec![0.0, 1.0]),
            hi: Some(vec![3.0, f64::NAN]),
            style: Style::points(PALETTE[0]),
        });
        fig.panels.push(p);
        let svg = fig.to_svg();
        parses(&svg);
        let bottom = svg
            .split("<clipPath")
            .nth(1)
            .and_then(|s| {
                let attr = |k: &str| {
                    s.split(&format!(" {k}=\""))
                        .nth(1)?
                        .split('"')
                        .next()?
                        .parse::<f64>()
                        .ok()
                };
                Some(attr("y")? + attr("height")?)
            })
            .unwrap_or(f64::NAN);
        let path = svg
            .lines()
            .find(|l| l.starts_with("<path") && l.contains("stroke=\"#0072b2\""))
            .unwrap_or("");
        assert!(
            path.contains(&format!("V{}", svg::num(bottom))),
            "bottom {bottom}: {path}"
        );
        // lower bar of point 0 (to the bottom, uncapped), upper bars of points 0, lower of 1:
        // three bars, two caps
        let d = path
            .split("d=\"")
            .nth(1)
            .and_then(|s| s.split('"').next())
            .unwrap_or("");
        assert_eq!(d.matches('V').count(), 3, "{path}");
        assert_eq!(d.matches('h').count(), 2, "{path}");
    }

    #[test]
    fn png_has_the_figure_size_the_line_colour_and_rendered_text() {
        let mut fig = Figure::new("Allan deviation of gyro X", 500, 360);
        fig.panels
            .push(line_panel(vec![10.0, 3.0, 1.0, 0.5, 0.7, 2.0]));
        let png = fig.to_png().unwrap();
        assert_eq!(png_size(&png), (500, 360));
        let pm = Pixmap::decode_png(&png).unwrap();
        let Color(r0, g0, b0) = PALETTE[1];
        let near = |a: u8, b: u8| (a as i32 - b as i32).abs() < 40;
        let coloured = count(&pm, 0, 360, |r, g, b| {
            near(r, r0) && near(g, g0) && near(b, b0)
        });
        assert!(coloured > 300, "only {coloured} line-coloured pixels");
        // The title occupies the top ~26 px; without a usable font this band is blank.
        let dark = count(&pm, 0, 26, |r, g, b| r < 100 && g < 100 && b < 100);
        assert!(dark > 40, "title not rendered ({dark} dark pixels)");
        let scaled = fig.to_png_scaled(2.0).unwrap();
        assert_eq!(png_size(&scaled), (1000, 720));
    }

    #[test]
    fn degenerate_inputs_give_valid_svg_and_png() {
        let mut all_nan = line_panel(vec![f64::NAN; 4]);
        all_nan.title = Some("all invalid".into());
        let mut empty = Panel::semilogx("x", "y");
        empty.series.push(Series::Line {
            label: Some("e".into()),
            x: vec![],
            y: vec![],
            style: Style::line(PALETTE[0]),
        });
        empty.series.push(Series::Band {
            label: None,
            x: vec![1.0],
            lo: vec![],
            hi: vec![2.0],
            style: Style::band(PALETTE[0]),
        });
        let single = line_panel(vec![5.0]);
        let flat = line_panel(vec![2.0, 2.0, 2.0]);
        let mut lin_flat = Panel::linear("x", "y");
        lin_flat.series.push(Series::line(
            "z",
            vec![0.0, 0.0],
            vec![0.0, 0.0],
            Style::points(PALETTE[3]),
        ));
        let mut bad = line_panel(vec![1.0, 2.0]);
        bad.x_range = Some((-1.0, f64::INFINITY));
        bad.y_range = Some((3.0, 3.0));
        bad.height = f64::NAN;
        bad.series.push(Series::VLine {
            label: Some("50 Hz".into()),
            x: -5.0,
            style: Style::line(PALETTE[4]),
        });
        let mut huge = line_panel(vec![1e-300, 1e300, f64::MIN_POSITIVE, f64::MAX]);
        huge.hlines.push((f64::NAN, Style::line(Color::GRAY)));
        let mut weird_style = line_panel(vec![1.0, 2.0]);
        weird_style.series.push(Series::line(
            "w",
            vec![1.0, 2.0],
            vec![2.0, 1.0],
            Style {
                color: Color::BLACK,
                width: f64::NAN,
                dash: Some(vec![f64::NAN, -1.0]),
                opacity: 7.0,
                marker: Some(Marker::Cross),
            },
        ));
        let panels = [
            all_nan,
            empty,
            single,
            flat,
            lin_flat,
            bad,
            huge,
            weird_style,
        ];
        let mut figs: Vec<Figure> = vec![Figure::new("", 300, 200), Figure::new("tiny", 1, 1)];
        for p in &panels {
            let mut f = Figure::new("degenerate", 320, 240);
            f.panels.push(p.clone());
            figs.push(f);
        }
        let mut crowded = Figure::new("six panels in 60 px", 200, 60);
        crowded.panels = panels.to_vec();
        figs.push(crowded);
        for f in &figs {
            let svg = f.to_svg();
            parses(&svg);
            assert!(!svg.contains("NaN") && !svg.contains("inf"), "{svg}");
            let png = f.to_png().unwrap();
            assert_eq!(png_size(&png), (f.width_px, f.height_px));
        }
        let svg = figs[2].to_svg();
        assert!(svg.contains(">no data</text>"));
        assert!(!figs[5].to_svg().contains(">no data</text>"));
        // single point: drawn as a dot, not an invisible one-point polyline
        assert!(figs[4].to_svg().contains("<circle"));
        assert!(matches!(
            Figure::new("", 0, 10).to_png(),
            Err(PlotError::InvalidSize { .. })
        ));
        assert!(matches!(
            Figure::new("", 100, 100).to_png_scaled(f32::NAN),
            Err(PlotError::InvalidSize { .. })
        ));
        assert!(matches!(
            Figure::new("", 20000, 10).to_png(),
            Err(PlotError::InvalidSize { .. })
        ));
    }

    #[test]
    fn output_is_deterministic() {
        let mut fig = Figure::new("det", 500, 400);
        let mut p = line_panel(
            (1..50)
                .map(|i| (i as f64 * 0.37).sin().abs() + 0.1)
                .collect(),
        );
        p.legend_at = Corner::Auto;
        fig.panels.push(p);
        fig.panels.push(Panel::semilogx("τ [s]", "z"));
        assert_eq!(fig.to_svg(), fig.to_svg());
        assert_eq!(fig.to_png().unwrap(), fig.to_png().unwrap());
    }

    #[test]
    fn stacked_panels_share_the_left_edge() {
        let mut fig = Figure::new("", 600, 500);
        fig.panels.push(line_panel(vec![1e-6, 1e-3, 1e-9]));
        let mut p = Panel::semilogx("x", "z");
        p.series.push(Series::line(
            "r",
            vec![1.0, 2.0],
            vec![-1.0, 1.0],
            Style::line(PALETTE[0]),
        ));
        fig.panels.push(p);
        let svg = fig.to_svg();
        let xs: Vec<&str> = svg
            .split("<clipPath")
            .skip(1)
            .filter_map(|s| s.split(" x=\"").nth(1)?.split('"').next())
            .collect();
        assert_eq!(xs.len(), 2);
        assert_eq!(xs[0], xs[1]);
    }

    #[test]
    fn vline_labels_do_not_collide() {
        let mut fig = Figure::new("", 600, 300);
        let mut p = Panel::loglog("f [Hz]", "PSD");
        p.series.push(Series::line(
            "psd",
            vec![1.0, 100.0],
            vec![1.0, 1.0],
            Style::line(PALETTE[0]),
        ));
        for f in [12.5, 13.0, 50.0] {
            p.series.push(Series::VLine {
                label: Some(format!("{f} Hz")),
                x: f,
                style: Style::dashed(PALETTE[1]),
            });
        }
        fig.panels.push(p);
        let svg = fig.to_svg();
        parses(&svg);
        let y_of = |label: &str| {
            svg.lines()
                .find(|l| l.ends_with(&format!(">{label}</text>")))
                .and_then(|l| {
                    l.split(" y=\"")
                        .nth(1)?
                        .split('"')
                        .next()?
                        .parse::<f64>()
                        .ok()
                })
        };
        let (a, b, c) = (y_of("12.5 Hz"), y_of("13 Hz"), y_of("50 Hz"));
        assert!(a.is_some() && b.is_some() && c.is_some());
        assert_ne!(a, b, "close lines get separate label rows");
        assert_eq!(a, c, "distant lines share the first row");
        // VLines are labelled at the line, not in the legend
        assert_eq!(svg.matches("12.5 Hz").count(), 1);
        // a marker line outside the shown range is clipped, and so is its label
        fig.panels[0].x_range = Some((20.0, 100.0));
        let svg = fig.to_svg();
        assert!(!svg.contains("12.5 Hz") && svg.contains("50 Hz"));
    }
}
