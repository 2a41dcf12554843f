//! The plots of a sweep (SVG, with `plot`'s helpers): histogram and CDF of
//! deploy time, deploy time against each parameter, and the latch-load
//! distribution per sleeve.

use super::plot::{drawing, padded_range, tick_label, write_svg, FONT, PALETTE};
use crate::sweep::row::Row;
use crate::sweep::stats::{quantile, spearman};
use crate::sweep::Meta;
use plotters::prelude::*;
use plotters::style::FontTransform;
use std::path::Path;

const GRID_LIGHT: RGBColor = RGBColor(238, 238, 238);
const GRID_BOLD: RGBColor = RGBColor(215, 215, 215);

/// Draws every plot into `dir`.
pub fn all(dir: &Path, m: &Meta, rows: &[Row]) -> Result<(), String> {
    deploy_time(&dir.join("deploy_time.svg"), m, rows)?;
    against_params(&dir.join("deploy_time_vs_params.svg"), m, rows)?;
    latch_loads(&dir.join("latch_load_per_sleeve.svg"), m, rows)
}

fn deployed_times(rows: &[Row]) -> Vec<f64> {
    let mut t: Vec<f64> = rows
        .iter()
        .filter(|r| r.deployed)
        .filter_map(|r| r.deploy_time_s)
        .collect();
    t.sort_by(f64::total_cmp);
    t
}

/// Histogram (left) and empirical CDF (right) of the deploy time.
fn deploy_time(path: &Path, m: &Meta, rows: &[Row]) -> Result<(), String> {
    let err = drawing(path);
    let t = deployed_times(rows);
    let (w, h) = (1200u32, 520u32);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(&err)?;
        let title = format!(
            "{}: deploy time of {} deployed of {} samples",
            m.name,
            t.len(),
            rows.len()
        );
        let body = root.titled(&title, (FONT, 22)).map_err(&err)?;
        let (left, right) = body.split_horizontally(w / 2);
        let (lo, hi) = padded_range(t.iter().copied(), 1e-3);
        let bins = ((t.len() as f64).sqrt().ceil() as usize).clamp(5, 40);
        let width = (hi - lo) / bins as f64;
        let mut counts = vec![0u32; bins];
        for v in &t {
            counts[(((v - lo) / width) as usize).min(bins - 1)] += 1;
        }
        let cmax = counts.iter().copied().max().unwrap_or(1).max(1);
        let span = hi - lo;
        let xfmt = move |v: &f64| tick_label(*v, span);
        let mut chart = ChartBuilder::on(&left)
            .margin(12)
            .margin_right(24)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .caption("histogram", (FONT, 18))
            .build_cartesian_2d(lo..hi, 0u32..cmax + cmax / 8 + 1)
            .map_err(&err)?;
        chart
            .configure_mesh()
            .light_line_style(GRID_LIGHT)
            .bold_line_style(GRID_BOLD)
            .x_desc("deploy time (s)")
            .y_desc("samples")
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .x_label_formatter(&xfmt)
            .draw()
            .map_err(&err)?;
        chart
            .draw_series(counts.iter().enumerate().map(|(i, &c)| {
                let x0 = lo + i as f64 * width;
                Rectangle::new([(x0, 0), (x0 + width, c)], PALETTE[0].mix(0.7).filled())
            }))
            .map_err(&err)?;
        chart
            .draw_series(counts.iter().enumerate().map(|(i, &c)| {
                let x0 = lo + i as f64 * width;
                Rectangle::new([(x0, 0), (x0 + width, c)], WHITE.stroke_width(1))
            }))
            .map_err(&err)?;
        let mut cdf = ChartBuilder::on(&right)
            .margin(12)
            .margin_right(24)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .caption(
                "empirical CDF (of all samples: undeployed never reach it)",
                (FONT, 18),
            )
            .build_cartesian_2d(lo..hi, 0.0..1.0)
            .map_err(&err)?;
        cdf.configure_mesh()
            .light_line_style(GRID_LIGHT)
            .bold_line_style(GRID_BOLD)
            .x_desc("deploy time (s)")
            .y_desc("fraction deployed")
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .x_label_formatter(&xfmt)
            .y_label_formatter(&|v: &f64| format!("{v:.1}"))
            .draw()
            .map_err(&err)?;
        let n = rows.len().max(1) as f64;
        let mut steps = vec![(lo, 0.0)];
        for (i, v) in t.iter().enumerate() {
            steps.push((*v, i as f64 / n));
            steps.push((*v, (i + 1) as f64 / n));
        }
        steps.push((hi, t.len() as f64 / n));
        cdf.draw_series(LineSeries::new(steps, PALETTE[1].stroke_width(2)))
            .map_err(&err)?;
    }
    write_svg(path, svg)
}

/// Deploy time against each parameter, one panel each, Spearman's rho in
/// each panel's caption; samples that did not deploy as crosses along the top.
fn against_params(path: &Path, m: &Meta, rows: &[Row]) -> Result<(), String> {
    let err = drawing(path);
    let k = m.keys.len().max(1);
    let cols = k.min(3);
    let nrows = k.div_ceil(cols);
    let (w, h) = (420 * cols as u32 + 40, 340 * nrows as u32 + 50);
    let t = deployed_times(rows);
    let (tlo, thi) = padded_range(t.iter().copied(), 1e-3);
    let thi = thi + 0.08 * (thi - tlo);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(&err)?;
        let body = root
            .titled(
                &format!("{}: deploy time against each parameter", m.name),
                (FONT, 22),
            )
            .map_err(&err)?;
        let panels = body.split_evenly((nrows, cols));
        for (i, key) in m.keys.iter().enumerate() {
            let dep: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| r.deployed)
                .filter_map(|r| r.deploy_time_s.map(|t| (r.params[i], t)))
                .collect();
            let not: Vec<f64> = rows
                .iter()
                .filter(|r| !r.deployed)
                .map(|r| r.params[i])
                .collect();
            let (x, y): (Vec<f64>, Vec<f64>) = dep.iter().copied().unzip();
            let rho = spearman(&x, &y).map_or("-".into(), |r| format!("{r:+.2}"));
            let (xlo, xhi) = padded_range(rows.iter().map(|r| r.params[i]), 1e-12);
            let (xs, ys) = (xhi - xlo, thi - tlo);
            let mut chart = ChartBuilder::on(&panels[i])
                .margin(8)
                .margin_right(18)
                .x_label_area_size(42)
                .y_label_area_size(56)
                .caption(format!("{key}  (rho {rho})"), (FONT, 15))
                .build_cartesian_2d(xlo..xhi, tlo..thi)
                .map_err(&err)?;
            chart
                .configure_mesh()
                .light_line_style(GRID_LIGHT)
                .bold_line_style(GRID_BOLD)
                .y_desc("deploy time (s)")
                .label_style((FONT, 12))
                .axis_desc_style((FONT, 13))
                .x_labels(5)
                .x_label_formatter(&move |v: &f64| tick_label(*v, xs))
                .y_label_formatter(&move |v: &f64| tick_label(*v, ys))
                .draw()
                .map_err(&err)?;
            chart
                .draw_series(
                    dep.iter()
                        .map(|&(x, y)| Circle::new((x, y), 3, PALETTE[0].mix(0.6).filled())),
                )
                .map_err(&err)?;
            chart
                .draw_series(
                    not.iter()
                        .map(|&x| Cross::new((x, thi - 0.03 * ys), 4, PALETTE[1].stroke_width(1))),
                )
                .map_err(&err)?;
        }
    }
    write_svg(path, svg)
}

/// Per sleeve: the spread of its latch load over the samples (peak force of
/// compliant latches, else impulse): whiskers from min to max, a box from
/// the 25 % to the 75 % quantile, the median as a bar; sleeves by median.
fn latch_loads(path: &Path, m: &Meta, rows: &[Row]) -> Result<(), String> {
    let err = drawing(path);
    let compliant = rows
        .iter()
        .any(|r| r.latches.iter().any(|l| l.peak_force_n.is_some()));
    let mut by: std::collections::BTreeMap<&str, Vec<f64>> = Default::default();
    for r in rows {
        for l in &r.latches {
            let v = if compliant {
                l.peak_force_n
            } else {
                Some(l.impulse_ns)
            };
            if let Some(v) = v.filter(|v| v.is_finite()) {
                by.entry(l.name.as_str()).or_default().push(v);
            }
        }
    }
    let mut sleeves: Vec<(&str, Vec<f64>)> = by
        .into_iter()
        .map(|(k, mut v)| {
            v.sort_by(f64::total_cmp);
            (k, v)
        })
        .collect();
    sleeves.sort_by(|a, b| quantile(&a.1, 0.5).total_cmp(&quantile(&b.1, 0.5)));
    let n = sleeves.len().max(1);
    let (w, h) = ((16 * n as u32 + 200).max(800), 620u32);
    let (lo, hi) = padded_range(sleeves.iter().flat_map(|s| s.1.iter().copied()), 1e-9);
    let lo = lo.min(0.0);
    let (ylabel, what) = if compliant {
        ("peak latch force (N)", "peak force")
    } else {
        ("latch impulse (N s)", "impulse")
    };
    let names: Vec<String> = sleeves.iter().map(|s| s.0.to_string()).collect();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(&err)?;
        let body = root
            .titled(
                &format!(
                    "{}: latch {what} per sleeve, {} samples",
                    m.name,
                    rows.len()
                ),
                (FONT, 20),
            )
            .map_err(&err)?;
        let span = hi - lo;
        let mut chart = ChartBuilder::on(&body)
            .margin(12)
            .margin_right(24)
            .x_label_area_size(if n > 1 { 90 } else { 45 })
            .y_label_area_size(80)
            .build_cartesian_2d(-0.7..n as f64 - 0.3, lo..hi)
            .map_err(&err)?;
        let label = move |v: &f64| {
            let i = v.round();
            if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < names.len() {
                names[i as usize].clone()
            } else {
                String::new()
            }
        };
        chart
            .configure_mesh()
            .light_line_style(GRID_LIGHT)
            .bold_line_style(GRID_BOLD)
            .disable_x_mesh()
            .y_desc(ylabel)
            .x_desc("sleeve, by median load (line: min to max; box: quartiles; red: median)")
            .x_labels(n + 1)
            .label_style((FONT, 14))
            .x_label_style(
                TextStyle::from((FONT, 11).into_font()).transform(FontTransform::Rotate90),
            )
            .axis_desc_style((FONT, 16))
            .x_label_formatter(&label)
            .y_label_formatter(&move |v: &f64| tick_label(*v, span))
            .draw()
            .map_err(&err)?;
        for (i, (_, v)) in sleeves.iter().enumerate() {
            let x = i as f64;
            let c = PALETTE[0];
            let (q1, q2, q3) = (quantile(v, 0.25), quantile(v, 0.5), quantile(v, 0.75));
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(x, v[0]), (x, v[v.len() - 1])],
                    c.stroke_width(1),
                )))
                .map_err(&err)?;
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(x - 0.3, q1), (x + 0.3, q3)],
                    c.mix(0.45).filled(),
                )))
                .map_err(&err)?;
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(x - 0.35, q2), (x + 0.35, q2)],
                    PALETTE[1].stroke_width(2),
                )))
                .map_err(&err)?;
        }
    }
    write_svg(path, svg)
}
