//! PNG plots of a run, like the paper's figures 5–7: contact pairs per frame, time per stage
//! per frame, and force/torque over time. Text uses the bundled DejaVu Sans
//! (`assets/fonts/`, Bitstream Vera license), so plots render the same on every machine.

use std::path::{Path, PathBuf};
use std::sync::Once;

use anyhow::{anyhow, Context, Result};
use plotters::prelude::*;
use scene::rt::FrameRecord;

static FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

pub(crate) fn register_font() {
    REGISTER.call_once(|| {
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

const W: u32 = 1200;
const H: u32 = 480;

/// One series: label, colour, values.
pub(crate) struct Series<'a> {
    pub(crate) label: &'a str,
    pub(crate) color: RGBColor,
    pub(crate) values: Vec<(f64, f64)>,
}

fn range(series: &[Series<'_>]) -> (f64, f64, f64, f64) {
    let mut x0 = f64::INFINITY;
    let mut x1 = f64::NEG_INFINITY;
    let mut y0 = f64::INFINITY;
    let mut y1 = f64::NEG_INFINITY;
    for s in series {
        for &(x, y) in &s.values {
            if x.is_finite() && y.is_finite() {
                x0 = x0.min(x);
                x1 = x1.max(x);
                y0 = y0.min(y);
                y1 = y1.max(y);
            }
        }
    }
    if !x0.is_finite() {
        return (0.0, 1.0, 0.0, 1.0);
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    if y1 <= y0 {
        y1 = y0 + 1.0;
    }
    let pad = 0.05 * (y1 - y0);
    (x0, x1, y0 - pad, y1 + pad)
}

/// Draws a line chart into `area`.
pub(crate) fn chart<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let (x0, x1, y0, y1) = range(series);
    let mut ch = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| anyhow!("{e:?}"))?;
    ch.configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|e| anyhow!("{e:?}"))?;
    for s in series {
        let c = s.color;
        ch.draw_series(LineSeries::new(s.values.iter().copied(), c.stroke_width(1)))
            .map_err(|e| anyhow!("{e:?}"))?
            .label(s.label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    if series.len() > 1 {
        ch.configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(|e| anyhow!("{e:?}"))?;
    }
    Ok(())
}

/// One frame at 1 kHz, the engine's default time budget (`budget_us`), µs: the line drawn on
/// every frame-time plot.
pub(crate) const FRAME_BUDGET_US: f64 = 1000.0;

/// The smallest time a frame-time plot shows, µs (a stage that took no time sits on it).
const TIME_FLOOR_US: f64 = 0.1;

/// Draws frame times (µs) into `area` on a logarithmic axis, with the 1 ms frame budget as a
/// dashed red line: a frame's distance below the line is its headroom, whatever its size.
pub(crate) fn time_chart<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    x_label: &str,
    series: &[Series<'_>],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let (x0, x1, _, _) = range(series);
    let mut lo = f64::INFINITY;
    let mut hi = FRAME_BUDGET_US;
    for s in series {
        for &(_, y) in &s.values {
            if y.is_finite() {
                lo = lo.min(y.max(TIME_FLOOR_US));
                hi = hi.max(y);
            }
        }
    }
    if !lo.is_finite() {
        lo = TIME_FLOOR_US;
    }
    let (y0, y1) = (lo / 1.5, hi * 1.5);
    let mut ch = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
        .map_err(|e| anyhow!("{e:?}"))?;
    ch.configure_mesh()
        .x_desc(x_label)
        .y_desc("µs (log scale)")
        .y_label_formatter(&|v| {
            if *v >= 1.0 {
                format!("{v:.0}")
            } else {
                format!("{v:.1}")
            }
        })
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|e| anyhow!("{e:?}"))?;
    for s in series {
        let c = s.color;
        let points = s.values.iter().map(|&(x, y)| (x, y.max(TIME_FLOOR_US)));
        ch.draw_series(LineSeries::new(points, c.stroke_width(1)))
            .map_err(|e| anyhow!("{e:?}"))?
            .label(s.label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    let budget = RED.stroke_width(2);
    ch.draw_series(DashedLineSeries::new(
        [(x0, FRAME_BUDGET_US), (x1, FRAME_BUDGET_US)],
        8,
        6,
        budget,
    ))
    .map_err(|e| anyhow!("{e:?}"))?
    .label("frame budget, 1 ms")
    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], budget));
    ch.configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(|e| anyhow!("{e:?}"))?;
    Ok(())
}

/// Renders to a temporary file next to `path` and renames it into place; a `path` that
/// exists and is not a regular file is refused ([`mesh::check_output_file`]).
pub(crate) fn render_png(
    path: &Path,
    height: u32,
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> Result<()>,
) -> Result<()> {
    mesh::check_output_file(path).with_context(|| format!("writing {}", path.display()))?;
    // The image encoder picks the format from the extension: keep `.png` last.
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp{}.png", std::process::id()));
    {
        let root = BitMapBackend::new(&tmp, (W, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow!("{e:?}"))?;
        draw(&root)?;
        root.present().map_err(|e| anyhow!("{e:?}"))?;
    }
    std::fs::rename(&tmp, path).with_context(|| format!("writing {}", path.display()))
}

/// Writes `pairs.png`, `timing.png` and `force.png` into `dir`; returns their paths.
pub fn write_plots(dir: &Path, frames: &[FrameRecord], title: &str) -> Result<Vec<PathBuf>> {
    register_font();
    let t: Vec<f64> = frames.iter().map(|f| f.t).collect();
    let xy = |f: &dyn Fn(&FrameRecord) -> f64| -> Vec<(f64, f64)> {
        frames.iter().zip(&t).map(|(r, &x)| (x, f(r))).collect()
    };
    let mut written = Vec::new();

    let p = dir.join("pairs.png");
    render_png(&p, H, |root| {
        chart(
            root,
            &format!("{title}: contact pairs per frame"),
            "time (s)",
            "leaf pairs",
            &[Series {
                label: "pairs",
                color: BLUE,
                values: xy(&|r| f64::from(r.frame.pairs)),
            }],
        )
    })?;
    written.push(p);

    let p = dir.join("timing.png");
    render_png(&p, H, |root| {
        time_chart(
            root,
            &format!("{title}: time per stage per frame"),
            "time (s)",
            &[
                Series {
                    label: "total",
                    color: BLACK,
                    values: xy(&|r| r.frame.total_us),
                },
                Series {
                    label: "collision detection",
                    color: RGBColor(230, 120, 0),
                    values: xy(&|r| r.frame.cd_us),
                },
                Series {
                    label: "optimisation",
                    color: RGBColor(0, 150, 60),
                    values: xy(&|r| r.frame.opt_us),
                },
            ],
        )
    })?;
    written.push(p);

    let p = dir.join("force.png");
    render_png(&p, 2 * H, |root| {
        let (top, bottom) = root.split_vertically(H);
        chart(
            &top,
            &format!("{title}: force on the device"),
            "time (s)",
            "N",
            &[
                Series {
                    label: "Fx",
                    color: RED,
                    values: xy(&|r| r.frame.wrench[0]),
                },
                Series {
                    label: "Fy",
                    color: RGBColor(0, 150, 60),
                    values: xy(&|r| r.frame.wrench[1]),
                },
                Series {
                    label: "Fz",
                    color: BLUE,
                    values: xy(&|r| r.frame.wrench[2]),
                },
            ],
        )?;
        chart(
            &bottom,
            &format!("{title}: torque on the device"),
            "time (s)",
            "N·mm",
            &[
                Series {
                    label: "Tx",
                    color: RED,
                    values: xy(&|r| r.frame.wrench[3]),
                },
                Series {
                    label: "Ty",
                    color: RGBColor(0, 150, 60),
                    values: xy(&|r| r.frame.wrench[4]),
                },
                Series {
                    label: "Tz",
                    color: BLUE,
                    values: xy(&|r| r.frame.wrench[5]),
                },
            ],
        )
    })?;
    written.push(p);
    Ok(written)
}
