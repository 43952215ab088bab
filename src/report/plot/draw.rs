//! Figure layout and drawing: turns a [`Figure`] into SVG text.
//!
//! Layout is computed from fixed font sizes (px) rather than scaled with the figure, so labels
//! stay readable at any figure size; a larger PNG is made with `to_png_scaled` instead.

use std::fmt::Write;

use super::axes::{self, Axis, Ticks};
use super::svg::{escape, num, text_width, PathData, Tag};
use super::{Color, Corner, Figure, Marker, Panel, Scale, Series, Style};

const TITLE: f64 = 16.0;
const PANEL_TITLE: f64 = 13.0;
const LABEL: f64 = 13.0;
const TICK: f64 = 11.0;
const LEGEND: f64 = 11.0;
const VLINE_TEXT: f64 = 10.0;
const TEXT: &str = "#222";
const GRID: &str = "#e4e4e4";
const TICK_LEN: f64 = 5.0;
const MINOR_LEN: f64 = 3.0;
/// Space under a plot area: ticks, tick labels (room for superscripts), axis label.
const BOTTOM: f64 = 48.0;

/// A panel with its resolved plot area (`x.p0..x.p1` × `y.p1..y.p0`), axes and ticks.
struct Prepared<'a> {
    panel: &'a Panel,
    x: Axis,
    y: Axis,
    xt: Ticks,
    yt: Ticks,
    has_data: bool,
}

pub(super) fn render(fig: &Figure) -> String {
    let (w, h) = (
        f64::from(fig.width_px.max(1)),
        f64::from(fig.height_px.max(1)),
    );
    let mut out = String::with_capacity(16 * 1024);
    let _ = writeln!(
        out,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" \
         viewBox=\"0 0 {w} {h}\" font-family=\"DejaVu Sans, sans-serif\">"
    );
    Tag::new("rect")
        .ns(&[("width", w), ("height", h)])
        .s("fill", "#fff")
        .end(&mut out);
    let mut top = 6.0;
    if !fig.title.trim().is_empty() {
        text(
            &mut out,
            (w / 2.0, top + TITLE),
            TITLE,
            "middle",
            &escape(&fig.title),
        );
        top += TITLE * 1.7;
    }
    for (i, p) in layout(fig, w, h, top).iter().enumerate() {
        draw_panel(&mut out, i, p);
    }
    out.push_str("</svg>\n");
    out
}

fn text(out: &mut String, (x, y): (f64, f64), size: f64, anchor: &str, inner: &str) {
    let tag = Tag::new("text").ns(&[("x", x), ("y", y), ("font-size", size)]);
    tag.ss(&[("text-anchor", anchor), ("fill", TEXT)])
        .wrap(out, inner);
}

/// Min/max accumulator for data extents.
#[derive(Default)]
struct Extent(Option<(f64, f64)>);

impl Extent {
    fn add(&mut self, v: f64) {
        self.0 = Some(self.0.map_or((v, v), |(a, b)| (a.min(v), b.max(v))));
    }
}

fn at(v: &[f64], i: usize) -> f64 {
    v.get(i).copied().unwrap_or(f64::NAN)
}

/// Displayed x and y ranges of a panel, and whether it has anything to show. The y extent only
/// counts points whose x is inside the displayed x range, so zooming x (via `x_range`) also
/// fits y to what is visible.
fn ranges(p: &Panel) -> ((f64, f64), (f64, f64), bool) {
    let (xs, ys) = (p.x_scale, p.y_scale);
    let ok = |v: f64, s: Scale| axes::valid(v, s);
    let mut xe = Extent::default();
    for s in &p.series {
        match s {
            Series::Line { x, y, .. } | Series::Points { x, y, .. } => {
                let pairs = x.iter().zip(y).filter(|(a, b)| ok(**a, xs) && ok(**b, ys));
                pairs.for_each(|(a, _)| xe.add(*a));
            }
            Series::Band { x, lo, hi, .. } => {
                for (i, &a) in x.iter().enumerate() {
                    if ok(a, xs) && (ok(at(lo, i), ys) || ok(at(hi, i), ys)) {
                        xe.add(a);
                    }
                }
            }
            Series::VLine { x, .. } if ok(*x, xs) => xe.add(*x),
            Series::VLine { .. } => {}
        }
    }
    let xr = axes::range(xe.0, p.x_range, xs);
    let inside = |v: f64| ok(v, xs) && v >= xr.0 && v <= xr.1;
    let mut ye = Extent::default();
    let mut add = |v: f64| {
        if ok(v, ys) {
            ye.add(v)
        }
    };
    for s in &p.series {
        match s {
            Series::Line { x, y, .. } => {
                x.iter()
                    .zip(y)
                    .filter(|(a, _)| inside(**a))
                    .for_each(|(_, b)| add(*b));
            }
            Series::Points { x, y, lo, hi, .. } => {
                for (i, (&a, &b)) in x.iter().zip(y).enumerate() {
                    if inside(a) && ok(b, ys) {
                        add(b);
                        [lo, hi].into_iter().flatten().for_each(|v| add(at(v, i)));
                    }
                }
            }
            Series::Band { x, lo, hi, .. } => {
                for i in (0..x.len()).filter(|&i| inside(x[i])) {
                    add(at(lo, i));
                    add(at(hi, i));
                }
            }
            Series::VLine { .. } => {}
        }
    }
    p.hlines.iter().for_each(|(v, _)| add(*v));
    (xr, axes::range(ye.0, p.y_range, ys), xe.0.is_some())
}

/// Ticks with as many labels as fit: start from a density guess and drop labels until
/// neighbouring labels no longer overlap (measured with the label widths on x, the line height
/// on y). This is what keeps tick labels from colliding on small or crowded axes.
fn fit_ticks(scale: Scale, lo: f64, hi: f64, len: f64, horizontal: bool) -> Ticks {
    let axis = Axis {
        scale,
        lo,
        hi,
        p0: 0.0,
        p1: len,
    };
    let mut n = ((len / if horizontal { 60.0 } else { 30.0 }) as usize).clamp(2, 12);
    loop {
        let t = axes::ticks(scale, lo, hi, n);
        let size = |l: &axes::Label| if horizontal { l.width(TICK) } else { TICK };
        let pos: Vec<(f64, f64)> = t.labels().map(|(v, l)| (axis.map(v), size(l))).collect();
        let overlap = pos.windows(2).any(|q| {
            let need = if horizontal {
                (q[0].1 + q[1].1) / 2.0 + 8.0
            } else {
                TICK * 1.4
            };
            (q[1].0 - q[0].0).abs() < need
        });
        if !overlap || n <= 2 {
            return t;
        }
        n -= 1;
    }
}

fn widest_label(t: &Ticks) -> f64 {
    t.labels().map(|(_, l)| l.width(TICK)).fold(0.0, f64::max)
}

fn layout<'a>(fig: &'a Figure, w: f64, h: f64, top: f64) -> Vec<Prepared<'a>> {
    let weight = |p: &Panel| {
        if p.height.is_finite() && p.height > 0.0 {
            p.height
        } else {
            1.0
        }
    };
    let total: f64 = fig.panels.iter().map(weight).sum();
    let avail = (h - top - 4.0).max(0.0);
    let (mut slot_top, mut left) = (top, 0.0_f64);
    let mut prepared = Vec::with_capacity(fig.panels.len());
    for p in &fig.panels {
        let slot = avail * weight(p) / total;
        let t = slot_top
            + if p.title.is_some() {
                PANEL_TITLE + 14.0
            } else {
                12.0
            };
        let b = (slot_top + slot - BOTTOM).max(t + 10.0);
        slot_top += slot;
        let (xr, yr, has_data) = ranges(p);
        let yt = fit_ticks(p.y_scale, yr.0, yr.1, b - t, false);
        let label_room = if p.y_label.trim().is_empty() {
            0.0
        } else {
            LABEL + 8.0
        };
        left = left.max(widest_label(&yt) + TICK_LEN + 10.0 + label_room);
        let x = Axis {
            scale: p.x_scale,
            lo: xr.0,
            hi: xr.1,
            p0: 0.0,
            p1: 0.0,
        };
        let y = Axis {
            scale: p.y_scale,
            lo: yr.0,
            hi: yr.1,
            p0: b,
            p1: t,
        };
        prepared.push(Prepared {
            panel: p,
            x,
            y,
            xt: Ticks::default(),
            yt,
            has_data,
        });
    }
    // One left edge for all panels, so stacked panels line up.
    let left = left.min(0.4 * w);
    for p in &mut prepared {
        let mut right = w - 20.0;
        for _ in 0..2 {
            p.xt = fit_ticks(p.x.scale, p.x.lo, p.x.hi, right - left, true);
            (p.x.p0, p.x.p1) = (left, right);
            // Shrink the plot if the last tick label would stick out of the figure.
            let over =
                p.xt.labels()
                    .map(|(v, l)| p.x.map(v) + l.width(TICK) / 2.0 - (w - 3.0));
            let worst = over.fold(0.0, f64::max);
            if worst <= 0.0 {
                break;
            }
            right -= worst;
        }
    }
    prepared
}

fn width(s: &Style) -> f64 {
    if s.width.is_finite() && s.width >= 0.0 {
        s.width
    } else {
        1.5
    }
}

fn opacity(s: &Style) -> f64 {
    if s.opacity.is_finite() {
        s.opacity.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// The style as a solid line of width `w` (error bars, marker crosses).
fn solid(s: &Style, w: f64) -> Style {
    Style {
        dash: None,
        width: w,
        ..s.clone()
    }
}

/// Stroke attributes of a style (no fill).
fn stroke(tag: Tag, s: &Style) -> Tag {
    let mut tag = tag
        .ss(&[("fill", "none"), ("stroke", &s.color.hex())])
        .n("stroke-width", width(s));
    let dash: Vec<f64> = s
        .dash
        .iter()
        .flatten()
        .copied()
        .filter(|v| *v >= 0.0)
        .collect();
    if dash.iter().sum::<f64>().is_finite() && dash.iter().sum::<f64>() > 0.0 {
        let dash: Vec<String> = dash.into_iter().map(num).collect();
        tag = tag.s("stroke-dasharray", &dash.join(" "));
    }
    if opacity(s) < 1.0 {
        tag = tag.n("stroke-opacity", opacity(s));
    }
    tag
}

/// Fill attributes of a style (no stroke).
fn fill(tag: Tag, s: &Style) -> Tag {
    tag.ss(&[("fill", &s.color.hex()), ("stroke", "none")])
        .n("fill-opacity", opacity(s))
}

fn marker_radius(s: &Style) -> f64 {
    2.0 + 1.5 * width(s).min(4.0)
}

/// All markers of a series as one `<path>` (one element per series, not per point, keeps long
/// series small).
fn markers(out: &mut String, pts: &[(f64, f64)], m: Marker, s: &Style) {
    if pts.is_empty() {
        return;
    }
    let r = marker_radius(s);
    let mut d = PathData::default();
    for &(x, y) in pts {
        match m {
            Marker::Circle => {
                d.cmd('M', &[x - r, y]);
                let (r, r2) = (num(r), num(2.0 * r));
                let _ = write!(d.0, "a{r},{r} 0 1,0 {r2},0a{r},{r} 0 1,0 -{r2},0Z");
            }
            Marker::Square => {
                d.cmd('M', &[x - r, y - r]);
                d.cmd('h', &[2.0 * r]);
                d.cmd('v', &[2.0 * r]);
                d.cmd('h', &[-2.0 * r]);
                d.0.push('Z');
            }
            Marker::Cross => {
                d.cmd('M', &[x - r, y - r]);
                d.cmd('L', &[x + r, y + r]);
                d.cmd('M', &[x - r, y + r]);
                d.cmd('L', &[x + r, y - r]);
            }
        }
    }
    let tag = Tag::new("path").s("d", &d.0);
    match m {
        Marker::Cross => stroke(tag, &solid(s, width(s).max(1.2))),
        _ => fill(tag, s),
    }
    .end(out);
}

/// Splits a line into drawable pieces at points that cannot be shown (non-finite, or
/// non-positive on a log axis): the result is a gap, never a segment to zero or infinity.
pub(super) fn line_pieces(x: &[f64], y: &[f64], xa: &Axis, ya: &Axis) -> Vec<Vec<(f64, f64)>> {
    let mut pieces = vec![Vec::new()];
    for (&a, &b) in x.iter().zip(y) {
        match pieces.last_mut() {
            Some(cur) if xa.valid(a) && ya.valid(b) => cur.push((xa.map(a), ya.map(b))),
            Some(cur) if !cur.is_empty() => pieces.push(Vec::new()),
            _ => {}
        }
    }
    pieces.retain(|p| !p.is_empty());
    pieces
}

/// Thins runs of points falling in the same half-pixel column to their first, lowest, highest
/// and last point. The drawn envelope is unchanged, but a 10⁶-point spectrum no longer makes a
/// multi-megabyte SVG.
fn decimate(piece: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(piece.len().min(8192));
    for run in piece.chunk_by(|a, b| (a.0 * 2.0).floor() == (b.0 * 2.0).floor()) {
        if run.len() <= 4 {
            out.extend_from_slice(run);
            continue;
        }
        let ys = run.iter().enumerate();
        let lo = ys
            .clone()
            .min_by(|a, b| a.1 .1.total_cmp(&b.1 .1))
            .map_or(0, |e| e.0);
        let hi = ys
            .max_by(|a, b| a.1 .1.total_cmp(&b.1 .1))
            .map_or(0, |e| e.0);
        out.extend([run[0], run[lo.min(hi)], run[lo.max(hi)], run[run.len() - 1]]);
    }
    out
}

fn draw_line(out: &mut String, pieces: &[Vec<(f64, f64)>], s: &Style) {
    for piece in pieces {
        if let [(x, y)] = piece.as_slice() {
            // A lone valid point between gaps would be invisible as a polyline.
            let r = (width(s) * 1.2).max(1.5);
            fill(
                Tag::new("circle").ns(&[("cx", *x), ("cy", *y), ("r", r)]),
                s,
            )
            .end(out);
            continue;
        }
        let pts: Vec<String> = decimate(piece)
            .iter()
            .map(|(x, y)| format!("{},{}", num(*x), num(*y)))
            .collect();
        stroke(Tag::new("polyline").s("points", &pts.join(" ")), s).end(out);
    }
}

/// Pixel y of a lower bound: a bound that is non-positive on a log axis (a confidence interval
/// reaching zero) maps to the panel bottom, flagged `false` (unbounded); non-finite is `None`.
fn lower_px(y: &Axis, lo: f64) -> Option<(f64, bool)> {
    if y.valid(lo) {
        Some((y.map(lo), true))
    } else if y.scale == Scale::Log && lo <= 0.0 {
        Some((y.p0, false))
    } else {
        None
    }
}

/// Error bars as one path. Ends clipped to the panel bottom get no cap, so they do not suggest
/// a finite bound; non-finite ends are left out.
fn error_bars(out: &mut String, y: &Axis, pts: &[(f64, f64, f64, f64)], s: &Style) {
    let cap = marker_radius(s).max(3.0);
    let mut d = PathData::default();
    for &(px, py, lo, hi) in pts {
        let hi_px = y.valid(hi).then(|| (y.map(hi), true));
        for (end, capped) in [lower_px(y, lo), hi_px].into_iter().flatten() {
            d.cmd('M', &[px, py]);
            d.cmd('V', &[end]);
            if capped {
                d.cmd('M', &[px - cap, end]);
                d.cmd('h', &[2.0 * cap]);
            }
        }
    }
    if !d.0.is_empty() {
        stroke(
            Tag::new("path").s("d", &d.0),
            &solid(s, width(s).clamp(0.5, 1.5)),
        )
        .end(out);
    }
}

/// Filled band pieces (upper edge forward, lower edge back), split where x or hi is unusable.
/// Returns the vertices, for legend placement.
fn band(
    out: &mut String,
    pr: &Prepared,
    (x, lo, hi): (&[f64], &[f64], &[f64]),
    s: &Style,
) -> Vec<(f64, f64)> {
    let mut pieces: Vec<Vec<(f64, f64, f64)>> = vec![Vec::new()];
    for ((&a, &l), &u) in x.iter().zip(lo).zip(hi) {
        let lp = lower_px(&pr.y, l);
        match (pieces.last_mut(), lp) {
            (Some(cur), Some((lp, _))) if pr.x.valid(a) && pr.y.valid(u) => {
                cur.push((pr.x.map(a), lp, pr.y.map(u)))
            }
            (Some(cur), _) if !cur.is_empty() => pieces.push(Vec::new()),
            _ => {}
        }
    }
    let mut drawn = Vec::new();
    for piece in pieces.iter().filter(|p| p.len() >= 2) {
        let mut d = PathData::default();
        for (i, &(x, _, u)) in piece.iter().enumerate() {
            d.cmd(if i == 0 { 'M' } else { 'L' }, &[x, u]);
        }
        piece
            .iter()
            .rev()
            .for_each(|&(x, l, _)| d.cmd('L', &[x, l]));
        d.0.push('Z');
        fill(Tag::new("path").s("d", &d.0), s).end(out);
        drawn.extend(piece.iter().flat_map(|&(x, l, u)| [(x, l), (x, u)]));
    }
    drawn
}

fn draw_panel(out: &mut String, idx: usize, pr: &Prepared) {
    let p = pr.panel;
    let (l, r, t, b) = (pr.x.p0, pr.x.p1, pr.y.p1, pr.y.p0);
    let id = format!("imn-clip-{idx}");
    let _ = write!(out, "<defs><clipPath id=\"{id}\">");
    Tag::rect(l, t, r - l, b - t).end(out);
    out.push_str("</clipPath></defs>\n");

    // Grid at major ticks (decades on log axes), under everything; snapped to pixel centres.
    let snap = |v: f64| v.round() + 0.5;
    let mut d = PathData::default();
    for (v, _) in &pr.xt.major {
        d.cmd('M', &[snap(pr.x.map(*v)), t]);
        d.cmd('V', &[b]);
    }
    for (v, _) in &pr.yt.major {
        d.cmd('M', &[l, snap(pr.y.map(*v))]);
        d.cmd('H', &[r]);
    }
    let crisp = ("shape-rendering", "crispEdges");
    Tag::new("path")
        .ss(&[("d", &d.0), ("stroke", GRID), crisp])
        .end(out);

    // Data, clipped to the plot area. Bands go first whatever their position in the list, so
    // a translucent band never veils the points and lines it belongs to.
    let clip = format!("url(#{id})");
    Tag::new("g")
        .ss(&[("clip-path", &clip), ("stroke-linejoin", "round")])
        .open(out);
    for (v, s) in p.hlines.iter().filter(|(v, _)| pr.y.valid(*v)) {
        stroke(Tag::line(l, pr.y.map(*v), r, pr.y.map(*v)), s).end(out);
    }
    let mut drawn: Vec<(f64, f64)> = Vec::new(); // pixel positions, for legend placement
    for s in &p.series {
        if let Series::Band {
            x, lo, hi, style, ..
        } = s
        {
            drawn.extend(band(out, pr, (x, lo, hi), style));
        }
    }
    let mut vlabels = Vec::new();
    for s in &p.series {
        match s {
            Series::Line { x, y, style, .. } => {
                let pieces = line_pieces(x, y, &pr.x, &pr.y);
                draw_line(out, &pieces, style);
                if let Some(m) = style.marker {
                    markers(out, &pieces.concat(), m, style);
                }
                drawn.extend(pieces.into_iter().flatten());
            }
            Series::Points {
                x,
                y,
                lo,
                hi,
                style,
                ..
            } => {
                let bound = |v: &Option<Vec<f64>>, i| v.as_deref().map_or(f64::NAN, |v| at(v, i));
                let pts: Vec<(f64, f64, f64, f64)> = (0..x.len().min(y.len()))
                    .filter(|&i| pr.x.valid(x[i]) && pr.y.valid(y[i]))
                    .map(|i| (pr.x.map(x[i]), pr.y.map(y[i]), bound(lo, i), bound(hi, i)))
                    .collect();
                error_bars(out, &pr.y, &pts, style);
                let xy: Vec<(f64, f64)> = pts.iter().map(|q| (q.0, q.1)).collect();
                markers(out, &xy, style.marker.unwrap_or(Marker::Circle), style);
                drawn.extend(xy);
            }
            Series::VLine { label, x, style } if pr.x.valid(*x) => {
                let px = pr.x.map(*x);
                stroke(Tag::line(px, t, px, b), style).end(out);
                match label {
                    // outside a user-given x range the line is clipped away; so is its label
                    Some(label) if px >= l && px <= r => {
                        vlabels.push((px, label.as_str(), style.color))
                    }
                    _ => {}
                }
            }
            Series::Band { .. } | Series::VLine { .. } => {}
        }
    }
    out.push_str("</g>\n");

    let frame = Tag::rect(snap(l), snap(t), (r - l).round(), (b - t).round());
    frame
        .ss(&[("fill", "none"), ("stroke", TEXT), crisp])
        .end(out);
    draw_ticks(out, pr);
    if !p.x_label.trim().is_empty() {
        text(
            out,
            ((l + r) / 2.0, b + BOTTOM - 9.0),
            LABEL,
            "middle",
            &escape(&p.x_label),
        );
    }
    if !p.y_label.trim().is_empty() {
        let (x, y) = (
            (l - TICK_LEN - 13.0 - widest_label(&pr.yt)).max(LABEL),
            (t + b) / 2.0,
        );
        let rotate = format!("rotate(-90 {} {})", num(x), num(y));
        let tag = Tag::new("text").ns(&[("x", x), ("y", y), ("font-size", LABEL)]);
        let tag = tag.ss(&[
            ("text-anchor", "middle"),
            ("fill", TEXT),
            ("transform", &rotate),
        ]);
        tag.wrap(out, &escape(&p.y_label));
    }
    if let Some(title) = &p.title {
        text(
            out,
            ((l + r) / 2.0, t - 8.0),
            PANEL_TITLE,
            "middle",
            &escape(title),
        );
    }
    let vrows = vline_labels(out, pr, &vlabels);
    if !pr.has_data {
        let tag = Tag::new("text").ns(&[
            ("x", (l + r) / 2.0),
            ("y", (t + b) / 2.0 + 4.0),
            ("font-size", 12.0),
        ]);
        tag.ss(&[("text-anchor", "middle"), ("fill", "#888")])
            .wrap(out, "no data");
    }
    if p.legend {
        legend(out, pr, &drawn, 12.0 * vrows as f64);
    }
}

/// Outward ticks on the bottom and left edges, and their labels.
fn draw_ticks(out: &mut String, pr: &Prepared) {
    let snap = |v: f64| v.round() + 0.5;
    let (l, b) = (pr.x.p0, pr.y.p0);
    let mut d = PathData::default();
    let xt = pr
        .xt
        .major
        .iter()
        .map(|(v, _)| (*v, TICK_LEN))
        .chain(pr.xt.minor.iter().map(|v| (*v, MINOR_LEN)));
    for (v, len) in xt {
        d.cmd('M', &[snap(pr.x.map(v)), snap(b)]);
        d.cmd('v', &[len]);
    }
    let yt = pr
        .yt
        .major
        .iter()
        .map(|(v, _)| (*v, TICK_LEN))
        .chain(pr.yt.minor.iter().map(|v| (*v, MINOR_LEN)));
    for (v, len) in yt {
        d.cmd('M', &[snap(l), snap(pr.y.map(v))]);
        d.cmd('h', &[-len]);
    }
    let crisp = ("shape-rendering", "crispEdges");
    Tag::new("path")
        .ss(&[("d", &d.0), ("stroke", TEXT), crisp])
        .end(out);
    for (v, lab) in pr.xt.labels() {
        let pos = (pr.x.map(v), b + TICK_LEN + 6.0 + TICK);
        text(out, pos, TICK, "middle", &lab.markup(TICK));
    }
    for (v, lab) in pr.yt.labels() {
        let pos = (l - TICK_LEN - 4.0, pr.y.map(v) + 0.36 * TICK);
        text(out, pos, TICK, "end", &lab.markup(TICK));
    }
}

/// Labels of vertical marker lines, at the top of the plot area beside their line (on the left
/// of it near the right edge), moved down a row when they would overlap an earlier label so
/// that close spectral lines stay legible. A white halo (`paint-order="stroke"`) keeps them
/// readable over dense spectra. Returns the number of label rows used.
fn vline_labels(out: &mut String, pr: &Prepared, labels: &[(f64, &str, Color)]) -> usize {
    let mut rows: Vec<Vec<(f64, f64)>> = Vec::new();
    for &(px, label, color) in labels {
        let wl = text_width(label, VLINE_TEXT);
        let right = px + 3.0 + wl <= pr.x.p1 - 2.0;
        let x0 = if right { px + 3.0 } else { px - 3.0 - wl };
        let span = (x0 - 3.0, x0 + wl + 3.0);
        let free = |row: &Vec<(f64, f64)>| row.iter().all(|&(a, b)| span.1 < a || span.0 > b);
        let row = rows.iter().position(free).unwrap_or(rows.len()).min(5);
        if row == rows.len() {
            rows.push(Vec::new());
        }
        rows[row].push(span);
        let (x, anchor) = if right {
            (x0, "start")
        } else {
            (x0 + wl, "end")
        };
        let y = pr.y.p1 + 12.0 + 12.0 * row as f64;
        let tag = Tag::new("text").ns(&[("x", x), ("y", y), ("font-size", VLINE_TEXT)]);
        let tag = tag.ss(&[
            ("text-anchor", anchor),
            ("fill", &color.hex()),
            ("stroke", "#fff"),
        ]);
        let tag = tag
            .n("stroke-width", 3.0)
            .ss(&[("stroke-linejoin", "round"), ("paint-order", "stroke")]);
        tag.wrap(out, &escape(label));
    }
    rows.len()
}

/// The legend box inside the plot area. With `Corner::Auto` the corner covering the fewest
/// drawn data points is chosen (ties keep the listed order, top-right first). A top legend
/// starts below the `top_gap` taken by marker-line labels.
fn legend(out: &mut String, pr: &Prepared, drawn: &[(f64, f64)], top_gap: f64) {
    let series = pr.panel.series.iter();
    let entries: Vec<(&Series, &str)> = series
        .filter_map(|s| Some((s, s.legend_label()?)))
        .collect();
    if entries.is_empty() {
        return;
    }
    let (pad, sw, row) = (6.0, 26.0, LEGEND * 1.55);
    let widest = entries
        .iter()
        .map(|(_, l)| text_width(l, LEGEND))
        .fold(0.0, f64::max);
    let (bw, bh) = (
        pad * 2.0 + sw + 6.0 + widest,
        pad * 2.0 + row * entries.len() as f64 - 3.0,
    );
    let (l, r, t, b) = (pr.x.p0, pr.x.p1, pr.y.p1, pr.y.p0);
    let origin = |c: Corner| match c {
        Corner::TopLeft => (l + 8.0, t + 8.0 + top_gap),
        Corner::BottomRight => (r - 8.0 - bw, b - 8.0 - bh),
        Corner::BottomLeft => (l + 8.0, b - 8.0 - bh),
        Corner::TopRight | Corner::Auto => (r - 8.0 - bw, t + 8.0 + top_gap),
    };
    let covered = |c: Corner| {
        let (x0, y0) = origin(c);
        drawn
            .iter()
            .filter(|(x, y)| *x >= x0 && *x <= x0 + bw && *y >= y0 && *y <= y0 + bh)
            .count()
    };
    let corner = match pr.panel.legend_at {
        Corner::Auto => [
            Corner::TopRight,
            Corner::TopLeft,
            Corner::BottomRight,
            Corner::BottomLeft,
        ]
        .into_iter()
        .min_by_key(|c| covered(*c))
        .unwrap_or(Corner::TopRight),
        c => c,
    };
    let (x0, y0) = origin(corner);
    let bg = Tag::rect(x0, y0, bw, bh)
        .n("rx", 2.0)
        .ss(&[("fill", "#fff"), ("stroke", "#bbb")]);
    bg.ns(&[("fill-opacity", 0.85), ("stroke-width", 0.8)])
        .end(out);
    for (i, (s, label)) in entries.iter().enumerate() {
        let cy = y0 + pad + row * (i as f64 + 0.5) - 1.5;
        let (sx, mx) = (x0 + pad, x0 + pad + sw / 2.0);
        match s {
            Series::Line { style, .. } => {
                stroke(Tag::line(sx, cy, sx + sw, cy), style).end(out);
                if let Some(m) = style.marker {
                    markers(out, &[(mx, cy)], m, style);
                }
            }
            Series::Points { style, lo, hi, .. } => {
                if lo.is_some() || hi.is_some() {
                    let bar = solid(style, width(style).clamp(0.5, 1.5));
                    stroke(Tag::line(mx, cy - 6.0, mx, cy + 6.0), &bar).end(out);
                }
                markers(
                    out,
                    &[(mx, cy)],
                    style.marker.unwrap_or(Marker::Circle),
                    style,
                );
            }
            Series::Band { style, .. } => fill(Tag::rect(sx, cy - 5.0, sw, 10.0), style).end(out),
            Series::VLine { .. } => {}
        }
        text(
            out,
            (sx + sw + 6.0, cy + 0.36 * LEGEND),
            LEGEND,
            "start",
            &escape(label),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axes(xs: Scale, ys: Scale) -> (Axis, Axis) {
        let x = Axis {
            scale: xs,
            lo: 0.5,
            hi: 1e4,
            p0: 60.0,
            p1: 560.0,
        };
        let y = Axis {
            scale: ys,
            lo: 0.5,
            hi: 10.0,
            p0: 400.0,
            p1: 40.0,
        };
        (x, y)
    }

    #[test]
    fn nan_and_negative_split_a_log_line_into_two_pieces() {
        let (x, y) = axes(Scale::Log, Scale::Log);
        let xs = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0];
        let ys = [1.0, 2.0, 3.0, f64::NAN, -1.0, 4.0, 5.0];
        let pieces = line_pieces(&xs, &ys, &x, &y);
        assert_eq!(pieces.iter().map(Vec::len).collect::<Vec<_>>(), vec![3, 2]);
        assert!(pieces
            .iter()
            .flatten()
            .all(|(a, b)| a.is_finite() && b.is_finite()));
        // on a linear y axis the negative value is drawable: NaN alone splits
        let (x, y) = axes(Scale::Log, Scale::Linear);
        let pieces = line_pieces(&xs, &ys, &x, &y);
        assert_eq!(pieces.iter().map(Vec::len).collect::<Vec<_>>(), vec![3, 3]);
        // zero x on a log axis, infinite y, mismatched lengths
        let (x, y) = axes(Scale::Log, Scale::Log);
        let pieces = line_pieces(&[0.0, 1.0, 2.0, 3.0], &[1.0, f64::INFINITY, 2.0], &x, &y);
        assert_eq!(pieces.iter().map(Vec::len).collect::<Vec<_>>(), vec![1]);
    }

    #[test]
    fn decimation_keeps_the_envelope_and_shrinks_dense_lines() {
        let n = 100_000;
        let piece: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                (
                    i as f64 * 500.0 / n as f64,
                    200.0 + 50.0 * ((i * 7919) % 101) as f64 / 100.0,
                )
            })
            .collect();
        let d = decimate(&piece);
        assert!(d.len() <= 4 * 1000 + 4, "{}", d.len());
        let ymin = d.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        let ymax = d.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
        assert_eq!((ymin, ymax), (200.0, 250.0));
        assert_eq!(d.first(), piece.first());
        assert_eq!(d.last(), piece.last());
        // sparse lines pass through untouched
        let sparse: Vec<(f64, f64)> = (0..50).map(|i| (i as f64 * 10.0, i as f64)).collect();
        assert_eq!(decimate(&sparse), sparse);
    }

    #[test]
    fn ranges_cover_all_series_and_honour_x_range() {
        let mut p = Panel::loglog("x", "y");
        p.series.push(Series::line(
            "a",
            vec![1.0, 10.0, 100.0],
            vec![5.0, 50.0, 500.0],
            Style::line(super::super::PALETTE[0]),
        ));
        p.series.push(Series::Band {
            label: None,
            x: vec![1.0, 10.0],
            lo: vec![0.0, 1.0],
            hi: vec![8.0, 2000.0],
            style: Style::band(super::super::PALETTE[0]),
        });
        let (xr, yr, has) = ranges(&p);
        assert!(has);
        assert!(xr.0 < 1.0 && xr.1 > 100.0);
        assert!(yr.0 < 1.0 && yr.0 > 0.5 && yr.1 > 2000.0, "{yr:?}");
        p.x_range = Some((50.0, 200.0));
        let (xr, yr, _) = ranges(&p);
        assert_eq!(xr, (50.0, 200.0));
        // only the point at x = 100 is visible: a zero-width extent, widened ×2 either way
        assert_eq!(yr, (250.0, 1000.0));
    }

    #[test]
    fn legend_auto_avoids_data() {
        let mut p = Panel::linear("x", "y");
        // data crowding the top-right corner
        let x: Vec<f64> = (0..100).map(|i| i as f64 / 10.0).collect();
        let y: Vec<f64> = x.iter().map(|v| v * v).collect();
        p.series.push(Series::line(
            "parabola",
            x,
            y,
            Style::line(super::super::PALETTE[0]),
        ));
        p.legend_at = Corner::Auto;
        let fig = Figure {
            title: String::new(),
            width_px: 400,
            height_px: 300,
            panels: vec![p],
        };
        let svg = fig.to_svg();
        let rect = svg
            .lines()
            .find(|l| l.contains("fill-opacity=\"0.85\""))
            .unwrap_or("");
        let x: f64 = rect
            .split(" x=\"")
            .nth(1)
            .and_then(|s| s.split('"').next())
            .and_then(|s| s.parse().ok())
            .unwrap_or(f64::NAN);
        assert!(x < 200.0, "legend should move to the left: {rect}");
    }
}
