//! SVG pictures for `simulate --plot` (joint coordinate histories with the latch
//! events marked, the paper's Fig. 11 and 14) and `simulate --snapshots` (the truss
//! at several instants in an oblique 3-D projection, Fig. 10 and 13).
//!
//! Drawn with `plotters` into a string (SVG backend only, no font files needed),
//! then written in one go, so a failure to write names the file.

use crate::solver::Model;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::{Path, PathBuf};

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

pub(super) const FONT: &str = "sans-serif";
pub(super) const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];
const LOCK_COLOR: RGBColor = RGBColor(90, 90, 90);
const MEMBER_COLOR: RGBColor = RGBColor(30, 70, 140);
const SLEEVE_COLOR: RGBColor = RGBColor(215, 80, 20);
const REFERENCE_COLOR: RGBColor = RGBColor(200, 200, 200);
/// Lines with more points than this are thinned (every k-th point and the last).
/// (The SVG backend rounds to whole pixels: a line with a point on every pixel
/// column looks like a staircase, so keep about one point per two columns.)
const MAX_POINTS: usize = 500;

fn style(size: u32, h: HPos, v: VPos) -> TextStyle<'static> {
    TextStyle::from((FONT, size).into_font()).pos(Pos::new(h, v))
}

pub(super) fn write_svg(path: &Path, svg: String) -> Result<(), String> {
    super::output::write_atomic(path, svg.as_bytes())
}

pub(super) fn drawing<E: std::fmt::Display>(path: &Path) -> impl Fn(E) -> String + '_ {
    move |e| format!("cannot draw {}: {e}", path.display())
}

/// Joints drawn first get wider lines, so that a later joint on the same
/// coordinate (common in symmetric trusses) leaves the earlier one visible.
fn line_width(j: usize, n: usize) -> u32 {
    (1 + n.saturating_sub(j)).clamp(2, 5) as u32
}

/// Distinct lock times (simultaneous latches grouped): (time, names).
fn group_locks(locks: &[(String, f64)], tol: f64) -> Vec<(f64, Vec<&str>)> {
    let mut sorted: Vec<&(String, f64)> = locks.iter().filter(|l| l.1.is_finite()).collect();
    sorted.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut groups: Vec<(f64, Vec<&str>)> = Vec::new();
    for (name, t) in sorted {
        match groups.last_mut() {
            Some((t0, names)) if (*t - *t0).abs() <= tol => names.push(name),
            _ => groups.push((*t, vec![name])),
        }
    }
    groups
}

fn lock_label(t: f64, names: &[&str]) -> String {
    match names {
        [one] => format!("latch {one}, t = {t:.2} s"),
        _ => format!("{} latches, t = {t:.2} s", names.len()),
    }
}

/// Tick labels with as many decimals as the tick spacing needs, and no "-0".
pub(super) fn tick_label(v: f64, span: f64) -> String {
    let step = span / 6.0;
    let decimals = if step > 0.0 && step.is_finite() {
        (-step.log10().floor()).clamp(0.0, 9.0) as usize
    } else {
        1
    };
    let s = format!("{v:.decimals$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// A range that contains all `values`, padded, at least `min_span` wide.
pub(super) fn padded_range(values: impl Iterator<Item = f64>, min_span: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let span = hi - lo;
    if span < min_span {
        let mid = 0.5 * (lo + hi);
        return (mid - 0.5 * min_span, mid + 0.5 * min_span);
    }
    (lo - 0.06 * span, hi + 0.06 * span)
}

/// Three stacked panels (x, y, z in m against t in s), one line per joint, the
/// latch events as vertical dashed lines (one per distinct time, labelled with
/// the lock's name or the number of simultaneous latches), legend beside the panels.
pub fn histories(
    path: &Path,
    title: &str,
    times: &[f64],
    joints: &[(String, Vec<[f64; 3]>)],
    locks: &[(String, f64)],
) -> Result<(), String> {
    let err = drawing(path);
    let n = times.len();
    let stride = n.div_ceil(MAX_POINTS).max(1);
    let idx: Vec<usize> = (0..n)
        .step_by(stride)
        .chain((n > 0 && !(n - 1).is_multiple_of(stride)).then_some(n - 1))
        .collect();
    let (t0, t1) = match (times.first(), times.last()) {
        (Some(&a), Some(&b)) if b > a => (a, b),
        (Some(&a), _) => (a, a + 1.0),
        _ => (0.0, 1.0),
    };
    let groups = group_locks(locks, 1e-3 * (t1 - t0));
    let t1 = t1 + 0.015 * (t1 - t0);
    // A coordinate that hardly moves gets a range of a tenth of the largest
    // motion (not a magnified view of rounding noise).
    let spans: Vec<f64> = (0..3)
        .map(|k| {
            let v = joints.iter().flat_map(|j| j.1.iter().map(move |p| p[k]));
            let (lo, hi) = v
                .filter(|v| v.is_finite())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(v), b.max(v))
                });
            if hi >= lo {
                hi - lo
            } else {
                0.0
            }
        })
        .collect();
    let min_span = (0.1 * spans.iter().cloned().fold(0.0, f64::max)).max(1e-3);
    let longest = joints
        .iter()
        .map(|j| j.0.chars().count())
        .chain(std::iter::once(14))
        .max()
        .unwrap_or(14);
    let legend_w = (longest as u32 * 9 + 60).min(320);
    let (w, h) = (1000 + legend_w, 860);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(&err)?;
        let body = root.titled(title, (FONT, 22)).map_err(&err)?;
        let (main, legend) = body.split_horizontally(w - legend_w);
        let panels = main.split_evenly((3, 1));
        for (k, panel) in panels.iter().enumerate() {
            let axis = ["x", "y", "z"][k];
            let (lo, hi) = padded_range(
                joints
                    .iter()
                    .flat_map(|j| idx.iter().filter_map(|&i| j.1.get(i).map(|p| p[k]))),
                min_span,
            );
            let (tspan, yspan) = (t1 - t0, hi - lo);
            let (tfmt, yfmt) = (
                move |v: &f64| tick_label(*v, tspan),
                move |v: &f64| tick_label(*v, yspan),
            );
            let mut chart = ChartBuilder::on(panel)
                .margin(6)
                .margin_right(20)
                .margin_top(if k == 0 { 22 } else { 6 })
                .x_label_area_size(if k == 2 { 45 } else { 28 })
                .y_label_area_size(80)
                .build_cartesian_2d(t0..t1, lo..hi)
                .map_err(&err)?;
            let mut mesh = chart.configure_mesh();
            mesh.light_line_style(RGBColor(238, 238, 238))
                .bold_line_style(RGBColor(215, 215, 215))
                .y_desc(format!("{axis} (m)"))
                .label_style((FONT, 15))
                .axis_desc_style((FONT, 17))
                .x_labels(10)
                .y_labels(6)
                .x_label_formatter(&tfmt)
                .y_label_formatter(&yfmt);
            if k == 2 {
                mesh.x_desc("t (s)");
            }
            mesh.draw().map_err(&err)?;
            for (t, _) in &groups {
                chart
                    .draw_series(std::iter::once(DashedPathElement::new(
                        vec![(*t, lo), (*t, hi)],
                        6,
                        4,
                        LOCK_COLOR.stroke_width(1),
                    )))
                    .map_err(&err)?;
            }
            for (j, (_, pos)) in joints.iter().enumerate() {
                let color = PALETTE[j % PALETTE.len()];
                chart
                    .draw_series(LineSeries::new(
                        idx.iter()
                            .filter_map(|&i| Some((*times.get(i)?, pos.get(i)?[k])))
                            .filter(|p| p.1.is_finite()),
                        color.stroke_width(line_width(j, joints.len())),
                    ))
                    .map_err(&err)?;
            }
            if k == 0 {
                // Lock labels above the top panel, just right of their line (left of it
                // near the right edge), staggered when several times are close.
                let (xr, yr) = chart.plotting_area().get_pixel_range();
                let (px0, px1, py0) = (xr.start, xr.end, yr.start);
                let mut last_right = i32::MIN;
                let mut row = 0;
                for (t, names) in &groups {
                    let (x, _) = chart.backend_coord(&(*t, hi));
                    let label = lock_label(*t, names);
                    let width = (label.len() as i32) * 7;
                    let right_side = x + 4 + width <= px1.max(px0 + 1);
                    let (left, anchor, tx) = if right_side {
                        (x + 4, HPos::Left, x + 4)
                    } else {
                        (x - 4 - width, HPos::Right, x - 4)
                    };
                    row = if left <= last_right { (row + 1) % 2 } else { 0 };
                    last_right = left + width;
                    root.draw(&Text::new(
                        label,
                        (tx, py0 - 6 - 14 * row),
                        (FONT, 14)
                            .into_font()
                            .color(&LOCK_COLOR)
                            .pos(Pos::new(anchor, VPos::Bottom)),
                    ))
                    .map_err(&err)?;
                }
            }
        }
        // Legend column: never covers data.
        let (lx, mut ly) = (10, 60);
        legend
            .draw(&Text::new("joints", (lx, ly - 24), (FONT, 16)))
            .map_err(&err)?;
        for (j, (name, _)) in joints.iter().enumerate() {
            let color = PALETTE[j % PALETTE.len()];
            legend
                .draw(&PathElement::new(
                    vec![(lx, ly), (lx + 30, ly)],
                    color.stroke_width(line_width(j, joints.len())),
                ))
                .map_err(&err)?;
            legend
                .draw(&Text::new(
                    name.clone(),
                    (lx + 38, ly),
                    style(15, HPos::Left, VPos::Center),
                ))
                .map_err(&err)?;
            ly += 24;
        }
        if !groups.is_empty() {
            ly += 12;
            legend
                .draw(&DashedPathElement::new(
                    vec![(lx, ly), (lx + 30, ly)],
                    6,
                    4,
                    LOCK_COLOR.stroke_width(1),
                ))
                .map_err(&err)?;
            legend
                .draw(&Text::new(
                    "latch event",
                    (lx + 38, ly),
                    style(15, HPos::Left, VPos::Center),
                ))
                .map_err(&err)?;
        }
        root.present().map_err(&err)?;
    }
    write_svg(path, svg)
}

/// Oblique view: azimuth about z, then elevation; orthographic.
struct Projection {
    right: [f64; 3],
    up: [f64; 3],
}

impl Projection {
    fn new(azimuth_deg: f64, elevation_deg: f64) -> Self {
        let (sa, ca) = azimuth_deg.to_radians().sin_cos();
        let (se, ce) = elevation_deg.to_radians().sin_cos();
        // Viewer at direction (ce*ca, ce*sa, se) from the origin, z up on the page.
        Projection {
            right: [-sa, ca, 0.0],
            up: [-se * ca, -se * sa, ce],
        }
    }
    fn apply(&self, p: &[f64; 3]) -> (f64, f64) {
        let dot = |a: &[f64; 3]| a[0] * p[0] + a[1] * p[1] + a[2] * p[2];
        (dot(&self.right), dot(&self.up))
    }
}

/// A "nice" length (1, 2 or 5 times a power of ten) no longer than `x`.
fn nice_length(x: f64) -> f64 {
    if !(x.is_finite() && x > 0.0) {
        return 1.0;
    }
    let p = 10f64.powf(x.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * p)
        .find(|&v| v <= x)
        .unwrap_or(p)
}

/// A grid of panels, each the truss at one instant (`frames`: time and one
/// position per joint) in the same oblique projection, scale and centre, so the
/// growth is visible. Sleeves are drawn in their own colour; the reference
/// deployed geometry, when given, as a light outline behind.
pub fn snapshots(
    path: &Path,
    title: &str,
    members: &[(usize, usize, bool)],
    frames: &[(String, Vec<[f64; 3]>)],
    reference: Option<(&[[f64; 3]], &str)>,
) -> Result<(), String> {
    let err = drawing(path);
    let (reference, reference_label) = match reference {
        Some((r, l)) => (Some(r), Some(l)),
        None => (None, None),
    };
    let proj = Projection::new(-55.0, 25.0);
    let n = frames.len().max(1);
    let cols = n.min(3);
    let rows = n.div_ceil(cols);

    // Common bounds in projected coordinates.
    let all = frames
        .iter()
        .flat_map(|f| f.1.iter())
        .chain(reference.into_iter().flatten())
        .filter(|p| p.iter().all(|v| v.is_finite()))
        .map(|p| proj.apply(p));
    let (mut u0, mut u1, mut v0, mut v1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (u, v) in all {
        u0 = u0.min(u);
        u1 = u1.max(u);
        v0 = v0.min(v);
        v1 = v1.max(v);
    }
    if !u0.is_finite() {
        (u0, u1, v0, v1) = (-1.0, 1.0, -1.0, 1.0);
    }
    let span = (u1 - u0).max(v1 - v0).max(1e-6);
    let (du, dv) = ((u1 - u0).max(1e-3 * span), (v1 - v0).max(1e-3 * span));
    // Panel height follows the picture's aspect (within limits): a flat ring
    // gets short panels, a tall mast tall ones.
    let (caption_h, margin) = (30.0, 18.0);
    let pw = 420u32;
    let inner_w = pw as f64 - 2.0 * margin;
    let inner_h = (inner_w * dv / du).clamp(160.0, 560.0);
    let ph = (inner_h + caption_h + 2.0 * margin).round() as u32;
    let (title_h, footer_h) = (44u32, 56u32);
    let (w, h) = (pw * cols as u32, title_h + ph * rows as u32 + footer_h);
    let scale = (inner_w / du).min(inner_h / dv);
    let (uc, vc) = (0.5 * (u0 + u1), 0.5 * (v0 + v1));
    let (cx, cy) = (pw as f64 / 2.0, caption_h + margin + inner_h / 2.0);
    let to_px = |p: &[f64; 3]| -> Option<(i32, i32)> {
        if !p.iter().all(|v| v.is_finite()) {
            return None;
        }
        let (u, v) = proj.apply(p);
        Some((
            (cx + (u - uc) * scale).round() as i32,
            (cy - (v - vc) * scale).round() as i32,
        ))
    };

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(&err)?;
        let (top, rest) = root.split_vertically(title_h);
        let (grid, footer) = rest.split_vertically(ph * rows as u32);
        top.draw(&Text::new(
            title.to_string(),
            (w as i32 / 2, title_h as i32 / 2),
            style(22, HPos::Center, VPos::Center),
        ))
        .map_err(&err)?;
        let panels = grid.split_evenly((rows, cols));
        for (panel, (label, x)) in panels.iter().zip(frames) {
            draw_frame(panel, (pw, ph), label, x, members, reference, &to_px).map_err(&err)?;
        }
        draw_footer(&footer, w, scale, reference_label, &proj).map_err(&err)?;
        root.present().map_err(&err)?;
    }
    write_svg(path, svg)
}

/// `analyze --modes-svg`: the first modes (up to 6), each drawn over the
/// undeformed truss with its largest joint displacement a tenth of the
/// truss's size.
pub fn modes_svg(
    path: &Path,
    model: &Model,
    x: &[f64],
    modes: &crate::solver::modes::Modes,
) -> Result<(), String> {
    let base = to_points(x);
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in &base {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max).max(1e-9);
    let amplitude = 0.1 * size;
    let frames: Vec<(String, Vec<[f64; 3]>)> = modes
        .modes
        .iter()
        .take(6)
        .enumerate()
        .map(|(i, m)| {
            let shape = base
                .iter()
                .zip(&m.shape)
                .map(|(p, u)| {
                    [
                        p[0] + amplitude * u[0],
                        p[1] + amplitude * u[1],
                        p[2] + amplitude * u[2],
                    ]
                })
                .collect();
            (
                format!("mode {}: {:.4} Hz, {}", i + 1, m.frequency_hz, m.motion),
                shape,
            )
        })
        .collect();
    snapshots(
        path,
        &format!("{}: natural modes", model.name),
        &members(model),
        &frames,
        Some((&base, "undeformed")),
    )
}

/// Joint position to panel pixel (None for a non-finite position).
type ToPixel<'a> = dyn Fn(&[f64; 3]) -> Option<(i32, i32)> + 'a;

type DrawResult = Result<(), DrawingAreaErrorKind<std::io::Error>>;

fn draw_frame(
    panel: &Area,
    (pw, ph): (u32, u32),
    label: &str,
    x: &[[f64; 3]],
    members: &[(usize, usize, bool)],
    reference: Option<&[[f64; 3]]>,
    to_px: &ToPixel,
) -> DrawResult {
    panel.draw(&Rectangle::new(
        [(4, 4), (pw as i32 - 4, ph as i32 - 4)],
        RGBColor(200, 200, 200).stroke_width(1),
    ))?;
    panel.draw(&Text::new(
        label.to_string(),
        (14, 12),
        style(17, HPos::Left, VPos::Top),
    ))?;
    let segment = |pts: &[[f64; 3]], a: usize, b: usize| -> Option<((i32, i32), (i32, i32))> {
        Some((to_px(pts.get(a)?)?, to_px(pts.get(b)?)?))
    };
    if let Some(r) = reference {
        for &(a, b, _) in members {
            if let Some((p, q)) = segment(r, a, b) {
                panel.draw(&PathElement::new(
                    vec![p, q],
                    REFERENCE_COLOR.stroke_width(1),
                ))?;
            }
        }
    }
    // Bars and rods first, sleeves on top.
    for sleeves in [false, true] {
        for &(a, b, s) in members.iter().filter(|m| m.2 == sleeves) {
            let color = if s { SLEEVE_COLOR } else { MEMBER_COLOR };
            let width = if s && members.len() <= 60 { 2 } else { 1 };
            if let Some((p, q)) = segment(x, a, b) {
                panel.draw(&PathElement::new(vec![p, q], color.stroke_width(width)))?;
            }
        }
    }
    // Joints of members only (cable drums and the like are not part of the truss).
    let mut used = vec![false; x.len()];
    for &(a, b, _) in members {
        for j in [a, b] {
            if let Some(u) = used.get_mut(j) {
                *u = true;
            }
        }
    }
    for p in x
        .iter()
        .zip(&used)
        .filter(|(_, &u)| u)
        .filter_map(|(p, _)| to_px(p))
    {
        panel.draw(&Circle::new(p, 2, BLACK.filled()))?;
    }
    Ok(())
}

fn draw_footer(
    footer: &Area,
    w: u32,
    scale: f64,
    reference: Option<&str>,
    proj: &Projection,
) -> DrawResult {
    let y = 24;
    let mut x = 20;
    let text = |s: &str| (s.to_string(), style(15, HPos::Left, VPos::Center));
    let mut entries: Vec<(RGBColor, u32, &str)> = vec![
        (MEMBER_COLOR, 1, "bars and rods"),
        (SLEEVE_COLOR, 2, "sleeves"),
    ];
    if let Some(label) = reference {
        entries.push((REFERENCE_COLOR, 1, label));
    }
    for (color, width, label) in entries {
        footer.draw(&PathElement::new(
            vec![(x, y), (x + 30, y)],
            color.stroke_width(width + 1),
        ))?;
        let (s, style) = text(label);
        footer.draw(&Text::new(s, (x + 38, y), style))?;
        x += 38 + label.len() as i32 * 8 + 30;
    }
    // Scale bar: a nice length of at most ~120 px.
    let len_m = nice_length(120.0 / scale);
    let len_px = (len_m * scale).round() as i32;
    let x1 = w as i32 - 30;
    let x0 = x1 - len_px;
    let label = if len_m >= 0.01 {
        format!("{} m", tick_label(len_m, len_m * 6.0))
    } else {
        format!("{} mm", tick_label(len_m * 1000.0, len_m * 6000.0))
    };
    // Axis triad, left of the scale bar.
    let origin = (x0 - 110, y + 6);
    for (k, name) in ["x", "y", "z"].iter().enumerate() {
        let mut e = [0.0; 3];
        e[k] = 1.0;
        let (u, v) = proj.apply(&e);
        let end = (
            origin.0 + (u * 20.0).round() as i32,
            origin.1 - (v * 20.0).round() as i32,
        );
        let at = (
            origin.0 + (u * 29.0).round() as i32,
            origin.1 - (v * 29.0).round() as i32,
        );
        footer.draw(&PathElement::new(
            vec![origin, end],
            RGBColor(110, 110, 110).stroke_width(1),
        ))?;
        footer.draw(&Text::new(
            name.to_string(),
            at,
            style(12, HPos::Center, VPos::Center).color(&RGBColor(90, 90, 90)),
        ))?;
    }
    footer.draw(&PathElement::new(
        vec![(x0, y), (x1, y)],
        BLACK.stroke_width(2),
    ))?;
    for xe in [x0, x1] {
        footer.draw(&PathElement::new(
            vec![(xe, y - 5), (xe, y + 5)],
            BLACK.stroke_width(2),
        ))?;
    }
    footer.draw(&Text::new(
        label,
        (x0 - 8, y),
        style(15, HPos::Right, VPos::Center),
    ))?;
    Ok(())
}

/// The members to draw: every element's own (`Constraint::members`: rods of
/// scissors, plate edges, bars, sleeves; constraint-only elements contribute
/// none). `true` marks a member of a lockable element.
pub fn members(model: &Model) -> Vec<(usize, usize, bool)> {
    let mut out = Vec::new();
    for e in &model.elements {
        let j = e.joints();
        let lockable = e.lock_gap(&model.x0).is_some();
        out.extend(e.members().iter().map(|&[a, b]| (j[a], j[b], lockable)));
    }
    out
}

/// Frames kept for `--snapshots`: every `stride`-th state, the stride doubling
/// whenever the buffer fills, so memory stays bounded for any run length and the
/// kept frames stay evenly spaced in steps; the latest state is kept apart.
struct FrameBuffer {
    stride: u64,
    seen: u64,
    frames: Vec<(f64, Vec<f64>)>,
    last: (f64, Vec<f64>),
}

const FRAME_CAP: usize = 240;

impl FrameBuffer {
    fn push(&mut self, t: f64, x: &[f64]) {
        if self.seen.is_multiple_of(self.stride) {
            if self.frames.len() >= FRAME_CAP {
                let mut k = 0;
                self.frames.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
                self.stride *= 2;
            }
            if self.seen.is_multiple_of(self.stride) {
                self.frames.push((t, x.to_vec()));
            }
        }
        self.seen += 1;
        self.last = (t, x.to_vec());
    }

    /// `n` frames evenly spaced in time, first and last included.
    fn pick(&self, n: usize) -> Vec<(f64, Vec<[f64; 3]>)> {
        let mut all: Vec<&(f64, Vec<f64>)> = self.frames.iter().collect();
        if all.last().is_none_or(|f| f.0 < self.last.0) {
            all.push(&self.last);
        }
        let (t0, t1) = (all[0].0, all[all.len() - 1].0);
        let mut chosen: Vec<usize> = Vec::new();
        for i in 0..n {
            let target = t0 + (t1 - t0) * i as f64 / (n - 1).max(1) as f64;
            let best = (0..all.len())
                .min_by(|&a, &b| {
                    (all[a].0 - target)
                        .abs()
                        .total_cmp(&(all[b].0 - target).abs())
                })
                .unwrap_or(0);
            if !chosen.contains(&best) {
                chosen.push(best);
            }
        }
        chosen
            .into_iter()
            .map(|i| (all[i].0, to_points(&all[i].1)))
            .collect()
    }
}

/// Where a sleeve sits along the ring: the first number in its name (bay or frame
/// k of `O_diag{k}`, `R{k}_t`, `S{k}`), and its family, the name without that
/// number (`O_diag`, `R_t`); names without a number go to position 0.
fn sleeve_place(name: &str) -> (usize, String) {
    let start = name.find(|c: char| c.is_ascii_digit());
    match start {
        None => (0, name.to_string()),
        Some(i) => {
            let len = name[i..]
                .find(|c: char| !c.is_ascii_digit())
                .unwrap_or(name.len() - i);
            let k = name[i..i + len].parse().unwrap_or(0);
            (k, format!("{}{}", &name[..i], &name[i + len..]))
        }
    }
}

/// `simulate --latch-plot`: each sleeve's latch time (y) against its place around
/// the ring (x: the bay or frame number in its name), one colour per family of
/// sleeves, the marker's area proportional to the latch's peak force where every
/// latch reports one (compliant latches), else to its impulse. The hardest
/// latch by that measure and the last one are labelled; sleeves that never
/// latched are crosses on the top edge.
pub fn latch_plot(
    path: &Path,
    title: &str,
    sleeves: &[String],
    locks: &[crate::solver::LockEvent],
) -> Result<(), String> {
    let err = drawing(path);
    let places: Vec<(usize, String)> = sleeves.iter().map(|n| sleeve_place(n)).collect();
    let mut families: Vec<&str> = Vec::new();
    for (_, f) in &places {
        if !families.contains(&f.as_str()) {
            families.push(f);
        }
    }
    let nf = families.len().max(1);
    let x_of = |i: usize| {
        let (k, f) = &places[i];
        let g = families.iter().position(|x| x == f).unwrap_or(0);
        *k as f64 + (g as f64 - (nf as f64 - 1.0) / 2.0) * (0.6 / nf as f64)
    };
    let latched: Vec<(usize, &crate::solver::LockEvent)> = locks
        .iter()
        .filter_map(|l| sleeves.iter().position(|n| *n == l.name).map(|i| (i, l)))
        .collect();
    let t_max = latched.iter().map(|(_, l)| l.time_s).fold(0.0, f64::max);
    let t_min = latched
        .iter()
        .map(|(_, l)| l.time_s)
        .fold(f64::INFINITY, f64::min);
    // (what a marker's area shows: the peak force where every latch has one)
    let by_force = !latched.is_empty() && latched.iter().all(|(_, l)| l.peak_force_n.is_some());
    let size = |l: &crate::solver::LockEvent| {
        if by_force {
            l.peak_force_n.unwrap_or(0.0)
        } else {
            l.impulse_ns
        }
    };
    let (size_unit, size_name) = if by_force {
        ("N", "peak force")
    } else {
        ("N s", "impulse")
    };
    let imp_max = latched.iter().map(|(_, l)| size(l)).fold(0.0, f64::max);
    let k_max = places.iter().map(|p| p.0).max().unwrap_or(0) as f64;
    let y_hi = if t_max > 0.0 { t_max * 1.12 } else { 1.0 };
    let (w, h) = (1100u32, 640u32);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(&err)?;
        let spread = if latched.is_empty() {
            "no latch".to_string()
        } else {
            format!(
                "{} of {} sleeves latched from {:.2} s to {:.2} s",
                latched.len(),
                sleeves.len(),
                t_min,
                t_max
            )
        };
        let body = root
            .titled(&format!("{title}: {spread}"), (FONT, 20))
            .map_err(&err)?;
        let (main, legend) = body.split_horizontally(w - 210);
        let mut chart = ChartBuilder::on(&main)
            .margin(10)
            .margin_right(20)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.8..k_max + 0.8, 0.0..y_hi)
            .map_err(&err)?;
        let span = y_hi;
        chart
            .configure_mesh()
            .light_line_style(RGBColor(238, 238, 238))
            .bold_line_style(RGBColor(215, 215, 215))
            .x_desc("bay / frame number (position around the ring)")
            .y_desc("latch time (s)")
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .x_labels((k_max.min(38.0) as usize) + 2)
            .x_label_formatter(&|v: &f64| format!("{}", v.round() as i64))
            .y_label_formatter(&move |v: &f64| tick_label(*v, span))
            .draw()
            .map_err(&err)?;
        let radius = |imp: f64| {
            if imp_max > 0.0 {
                (3.0 + 14.0 * (imp / imp_max).max(0.0).sqrt()).round() as i32
            } else {
                5
            }
        };
        for (i, l) in &latched {
            let g = families
                .iter()
                .position(|x| *x == places[*i].1)
                .unwrap_or(0);
            let c = PALETTE[g % PALETTE.len()];
            chart
                .draw_series(std::iter::once(Circle::new(
                    (x_of(*i), l.time_s),
                    radius(size(l)),
                    c.mix(0.55).filled(),
                )))
                .map_err(&err)?;
            chart
                .draw_series(std::iter::once(Circle::new(
                    (x_of(*i), l.time_s),
                    radius(size(l)),
                    c.stroke_width(1),
                )))
                .map_err(&err)?;
        }
        for i in (0..sleeves.len()).filter(|i| !latched.iter().any(|(j, _)| j == i)) {
            chart
                .draw_series(std::iter::once(Cross::new(
                    (x_of(i), y_hi * 0.985),
                    6,
                    RGBColor(0, 0, 0).stroke_width(2),
                )))
                .map_err(&err)?;
        }
        let hardest = latched
            .iter()
            .max_by(|a, b| size(a.1).total_cmp(&size(b.1)));
        let last = latched
            .iter()
            .max_by(|a, b| a.1.time_s.total_cmp(&b.1.time_s));
        let mut labels = Vec::new();
        if let Some((i, l)) = hardest {
            labels.push((
                *i,
                l.time_s,
                match l.peak_force_n.filter(|_| by_force) {
                    Some(p) => format!(
                        "hardest: {} peak {p:.1} N at {:.2} s (latched {:.2} s)",
                        l.name,
                        l.time_of_peak_s.unwrap_or(l.time_s),
                        l.time_s
                    ),
                    None => format!(
                        "hardest: {} {:.3} N s{} at {:.2} s",
                        l.name,
                        l.impulse_ns,
                        l.peak_force_n
                            .map_or(String::new(), |p| format!(", peak {p:.1} N")),
                        l.time_s
                    ),
                },
            ));
        }
        if let Some((i, l)) = last {
            labels.push((
                *i,
                l.time_s,
                format!("last: {} at {:.2} s", l.name, l.time_s),
            ));
        }
        for (n, (i, t, text)) in labels.iter().enumerate() {
            let x = x_of(*i);
            let right = x < k_max / 2.0;
            let (dx, anchor) = if right {
                (0.5, HPos::Left)
            } else {
                (-0.5, HPos::Right)
            };
            let ty = (t + y_hi * (0.045 + 0.05 * n as f64)).min(y_hi * 0.95);
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(x, *t), (x + dx, ty)],
                    RGBColor(0, 0, 0).stroke_width(1),
                )))
                .map_err(&err)?;
            chart
                .draw_series(std::iter::once(Text::new(
                    text.clone(),
                    (x + dx, ty),
                    style(15, anchor, VPos::Center),
                )))
                .map_err(&err)?;
        }
        // Legend: families, the markers' scale, never latched.
        let mut y = 40;
        legend
            .draw(&Text::new(
                "sleeves",
                (10, y),
                style(16, HPos::Left, VPos::Center),
            ))
            .map_err(&err)?;
        for (g, f) in families.iter().enumerate() {
            y += 26;
            let c = PALETTE[g % PALETTE.len()];
            legend
                .draw(&Circle::new((20, y), 7, c.mix(0.55).filled()))
                .map_err(&err)?;
            legend
                .draw(&Text::new(
                    f.to_string(),
                    (36, y),
                    style(15, HPos::Left, VPos::Center),
                ))
                .map_err(&err)?;
        }
        y += 40;
        legend
            .draw(&Text::new(
                format!("area ~ {size_name}"),
                (10, y),
                style(15, HPos::Left, VPos::Center),
            ))
            .map_err(&err)?;
        for frac in [1.0, 0.25] {
            y += 40;
            legend
                .draw(&Circle::new(
                    (24, y),
                    radius(frac * imp_max),
                    RGBColor(90, 90, 90).stroke_width(1),
                ))
                .map_err(&err)?;
            legend
                .draw(&Text::new(
                    format!("{:.3} {size_unit}", frac * imp_max),
                    (48, y),
                    style(14, HPos::Left, VPos::Center),
                ))
                .map_err(&err)?;
        }
        y += 40;
        legend
            .draw(&Cross::new((20, y), 6, RGBColor(0, 0, 0).stroke_width(2)))
            .map_err(&err)?;
        legend
            .draw(&Text::new(
                "never latched",
                (36, y),
                style(15, HPos::Left, VPos::Center),
            ))
            .map_err(&err)?;
        root.present().map_err(&err)?;
    }
    write_svg(path, svg)
}

fn to_points(x: &[f64]) -> Vec<[f64; 3]> {
    x.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// What `simulate --plot/--snapshots` records during the run; a no-op when
/// neither was asked for.
pub struct Recorder {
    plot: Option<(PathBuf, Vec<usize>)>,
    times: Vec<f64>,
    history: Vec<Vec<[f64; 3]>>,
    snapshots: Option<(PathBuf, FrameBuffer)>,
}

/// Number of instants in `--snapshots`.
pub const SNAPSHOT_FRAMES: usize = 6;

impl Recorder {
    /// Resolves the joint names (unknown names are an error listing the valid
    /// ones; none given: up to 3 joints that move the most from the initial to the
    /// reference geometry, or the last 3 without a reference) and checks that the
    /// output files were checked by the caller (`output::check_outputs`).
    pub fn new(
        model: &Model,
        plot: Option<&Path>,
        joints: &[String],
        snapshots: Option<&Path>,
    ) -> Result<Recorder, String> {
        if plot.is_none() && !joints.is_empty() {
            return Err("--joints selects the joints of --plot FILE.svg; give --plot too".into());
        }
        let plot = match plot {
            None => None,
            Some(p) => Some((p.to_path_buf(), resolve_joints(model, joints)?)),
        };
        // (the output paths are checked by the caller, `output::check_outputs`,
        // without touching a file that is there)
        let n = plot.as_ref().map_or(0, |p| p.1.len());
        Ok(Recorder {
            plot,
            times: Vec::new(),
            history: vec![Vec::new(); n],
            snapshots: snapshots.map(|p| {
                (
                    p.to_path_buf(),
                    FrameBuffer {
                        stride: 1,
                        seen: 0,
                        frames: Vec::new(),
                        last: (0.0, Vec::new()),
                    },
                )
            }),
        })
    }

    /// Call with the initial state and after every step.
    pub fn record(&mut self, t: f64, x: &[f64]) {
        if let Some((_, joints)) = &self.plot {
            self.times.push(t);
            for (h, &j) in self.history.iter_mut().zip(joints) {
                h.push([x[3 * j], x[3 * j + 1], x[3 * j + 2]]);
            }
        }
        if let Some((_, frames)) = &mut self.snapshots {
            frames.push(t, x);
        }
    }

    /// Writes the pictures from what was recorded (also after a failed run).
    pub fn finish(&self, model: &Model, locks: &[(String, f64)]) -> Result<(), String> {
        if let Some((path, joints)) = &self.plot {
            let series: Vec<(String, Vec<[f64; 3]>)> = joints
                .iter()
                .zip(&self.history)
                .map(|(&j, h)| (model.joints[j].name.clone(), h.clone()))
                .collect();
            histories(
                path,
                &format!("{}: joint coordinates", model.name),
                &self.times,
                &series,
                locks,
            )?;
        }
        if let Some((path, frames)) = &self.snapshots {
            if frames.seen > 0 {
                let reference = model.reference.as_deref().map(to_points);
                let frames: Vec<(String, Vec<[f64; 3]>)> = frames
                    .pick(SNAPSHOT_FRAMES)
                    .into_iter()
                    .map(|(t, x)| (format!("t = {t:.2} s"), x))
                    .collect();
                snapshots(
                    path,
                    &format!("{}: deployment", model.name),
                    &members(model),
                    &frames,
                    reference
                        .as_deref()
                        .map(|r| (r, "reference deployed geometry")),
                )?;
            }
        }
        Ok(())
    }
}

fn resolve_joints(model: &Model, names: &[String]) -> Result<Vec<usize>, String> {
    let names: Vec<&str> = names
        .iter()
        .map(|s| s.trim())
        .filter(|s| !s.is_empty())
        .collect();
    if names.is_empty() {
        let n = model.joints.len();
        let mut idx: Vec<usize> = (0..n).collect();
        match &model.reference {
            Some(r) => {
                let moved = |j: usize| -> f64 {
                    (0..3)
                        .map(|c| (r[3 * j + c] - model.x0[3 * j + c]).powi(2))
                        .sum()
                };
                idx.sort_by(|&a, &b| moved(b).total_cmp(&moved(a)).then(a.cmp(&b)));
                idx.truncate(3);
                idx.sort_unstable();
            }
            None => idx = idx.split_off(n.saturating_sub(3)),
        }
        return Ok(idx);
    }
    names
        .iter()
        .map(|name| {
            model
                .joints
                .iter()
                .position(|j| j.name == *name)
                .ok_or_else(|| {
                    let valid: Vec<&str> = model.joints.iter().map(|j| j.name.as_str()).collect();
                    format!(
                        "--joints: model {} has no joint named `{name}`; its joints are: {}",
                        model.name,
                        valid.join(", ")
                    )
                })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn simultaneous_locks_are_grouped() {
        let locks = vec![
            ("a".to_string(), 1.0),
            ("b".to_string(), 1.0 + 1e-9),
            ("c".to_string(), 2.0),
        ];
        let g = group_locks(&locks, 1e-3);
        assert_eq!(g.len(), 2);
        assert_eq!(lock_label(g[0].0, &g[0].1), "2 latches, t = 1.00 s");
        assert_eq!(lock_label(g[1].0, &g[1].1), "latch c, t = 2.00 s");
        assert_eq!(tick_label(-0.0001, 0.5), "0.00");
        assert_eq!(tick_label(0.25, 0.5), "0.25");
        assert_eq!(tick_label(0.5, 3.0), "0.5");
    }

    #[test]
    fn sleeves_are_placed_by_the_number_in_their_name() {
        assert_eq!(sleeve_place("O_diag12"), (12, "O_diag".into()));
        assert_eq!(sleeve_place("R3_t"), (3, "R_t".into()));
        assert_eq!(sleeve_place("S4"), (4, "S".into()));
        assert_eq!(sleeve_place("latch"), (0, "latch".into()));
    }

    #[test]
    fn nice_lengths() {
        assert_eq!(nice_length(0.7), 0.5);
        assert_eq!(nice_length(3.0), 2.0);
        assert_eq!(nice_length(1.0), 1.0);
    }

    #[test]
    fn unwritable_path_is_an_error_naming_it() {
        let p = Path::new("/nonexistent-dir/x.svg");
        let e =
            histories(p, "t", &[0.0, 1.0], &[("J".into(), vec![[0.0; 3]; 2])], &[]).unwrap_err();
        assert!(e.contains("/nonexistent-dir/x.svg"), "{e}");
    }
}
