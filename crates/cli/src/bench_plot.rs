//! Plots of `haptic6d bench`, after the paper's figures 5 and 6: pairs per frame and time per
//! frame per solver for each scene, the average cost per solver as bars, and the two scaling
//! studies (log–log time against pairs, time against depth).

use std::path::Path;

use anyhow::{anyhow, Result};
use engine::SolverKind;
use plotters::prelude::*;

use crate::bench_report::{BenchReport, SceneReplays};
use crate::plot::{chart, register_font, render_png, time_chart, Series};

/// Colour of a solver in every bench plot.
fn solver_color(name: &str) -> RGBColor {
    match name {
        "pqp" => RGBColor(214, 39, 40),
        "pqp-simd" => RGBColor(255, 127, 14),
        "pqp-parallel" => RGBColor(148, 103, 189),
        "active-set" => RGBColor(31, 119, 180),
        _ => RGBColor(44, 160, 44),
    }
}

/// Writes every bench plot into `dir`.
pub fn write_bench_plots(dir: &Path, replays: &[SceneReplays], report: &BenchReport) -> Result<()> {
    register_font();
    for (scene, runs) in replays {
        if let Some((_, dual)) = runs.iter().find(|(k, _)| *k == SolverKind::Dual) {
            let pairs = Series {
                label: "pairs",
                color: RGBColor(0, 0, 0),
                values: dual
                    .iter()
                    .enumerate()
                    .map(|(i, f)| (i as f64, f64::from(f.pairs)))
                    .collect(),
            };
            render_png(&dir.join(format!("bench_pairs_{scene}.png")), 400, |root| {
                chart(
                    root,
                    &format!("{scene}: contact pairs per frame"),
                    "frame",
                    "pairs",
                    &[pairs],
                )
            })?;
        }
        let series: Vec<Series<'_>> = runs
            .iter()
            .map(|(k, frames)| Series {
                label: k.name(),
                color: solver_color(k.name()),
                values: frames
                    .iter()
                    .enumerate()
                    .map(|(i, f)| (i as f64, f.total_us))
                    .collect(),
            })
            .collect();
        render_png(&dir.join(format!("bench_time_{scene}.png")), 480, |root| {
            time_chart(
                root,
                &format!("{scene}: frame time per solver"),
                "frame",
                &series,
            )
        })?;
    }
    render_png(&dir.join("bench_cost.png"), 480, |root| {
        cost_bars(root, report)
    })?;
    if !report.pqp_scaling.is_empty() {
        // Generated QPs only: one size per point, log axes.
        let points = |name: &str, per_iteration: bool| -> Vec<(f64, f64)> {
            report
                .pqp_scaling
                .iter()
                .filter(|r| r.solver == name && r.source == "generated")
                .filter_map(|r| {
                    let s = if per_iteration {
                        &r.iteration_us
                    } else {
                        &r.solve_us
                    };
                    (s.count > 0 && s.p50 > 0.0).then(|| ((r.n as f64).log10(), s.p50.log10()))
                })
                .collect()
        };
        let iteration: Vec<Series<'_>> = ["pqp", "pqp-simd", "pqp-parallel"]
            .iter()
            .map(|&name| Series {
                label: name,
                color: solver_color(name),
                values: points(name, true),
            })
            .collect();
        render_png(&dir.join("bench_pqp_iteration.png"), 480, |root| {
            chart(
                root,
                "PQP: time per iteration against rows (generated QPs, p50)",
                "log10(rows)",
                "log10(µs per iteration)",
                &iteration,
            )
        })?;
        let solve: Vec<Series<'_>> = crate::bench_pqp::VARIANTS
            .iter()
            .map(|&name| Series {
                label: name,
                color: solver_color(name),
                values: points(name, false),
            })
            .collect();
        render_png(&dir.join("bench_pqp_solve.png"), 480, |root| {
            chart(
                root,
                "time per solve against rows (generated QPs, cold, p50)",
                "log10(rows)",
                "log10(µs per solve)",
                &solve,
            )
        })?;
    }
    if !report.scaling_pairs.is_empty() {
        let series: Vec<Series<'_>> = ["pqp", "pqp-parallel", "active-set", "dual"]
            .iter()
            .map(|&name| Series {
                label: name,
                color: solver_color(name),
                values: report
                    .scaling_pairs
                    .iter()
                    .filter(|p| p.solver == name && p.pairs > 0)
                    .map(|p| (f64::from(p.pairs).log10(), p.total_us.p50.max(0.01).log10()))
                    .collect(),
            })
            .collect();
        render_png(&dir.join("bench_scaling_pairs.png"), 480, |root| {
            chart(
                root,
                "frame time against contact pairs (bunny, cold frames, p50)",
                "log10(pairs)",
                "log10(total µs)",
                &series,
            )
        })?;
    }
    if !report.scaling_depth.is_empty() {
        let series: Vec<Series<'_>> = ["pqp", "pqp-parallel", "active-set", "dual"]
            .iter()
            .map(|&name| Series {
                label: name,
                color: solver_color(name),
                values: report
                    .scaling_depth
                    .iter()
                    .filter(|p| p.solver == name)
                    .map(|p| (f64::from(p.depth), p.total_us.mean.max(0.01).log10()))
                    .collect(),
            })
            .collect();
        render_png(&dir.join("bench_scaling_depth.png"), 480, |root| {
            chart(
                root,
                "mean frame time against tree depth (bunny trajectory)",
                "depth",
                "log10(mean total µs)",
                &series,
            )
        })?;
    }
    if !report.speed.is_empty() {
        // Drag against speed: slides (N against mm/s) and turns (N·mm against rad/s), one
        // panel each, a line per tool, solver and geometry mode.
        let lines = |motion: &str| -> Vec<Line> {
            let mut keys: Vec<(String, String, String)> = Vec::new();
            for r in report.speed.iter().filter(|r| r.motion == motion) {
                let k = (r.tool.clone(), r.solver.clone(), r.geometry.clone());
                if !keys.contains(&k) {
                    keys.push(k);
                }
            }
            let modes = report
                .speed
                .iter()
                .any(|r| r.geometry != report.speed[0].geometry);
            keys.into_iter()
                .map(|(tool, solver, geometry)| {
                    let values = report
                        .speed
                        .iter()
                        .filter(|r| {
                            r.motion == motion
                                && r.tool == tool
                                && r.solver == solver
                                && r.geometry == geometry
                        })
                        .map(|r| (r.speed, r.drag))
                        .collect();
                    // Puck and ball apart: a darker shade of the solver's colour for the ball.
                    let c = solver_color(&solver);
                    let color = if tool == "ball" {
                        RGBColor(c.0 / 2, c.1 / 2, c.2 / 2)
                    } else {
                        c
                    };
                    let label = if modes {
                        format!("{tool}, {solver}, {geometry}")
                    } else {
                        format!("{tool}, {solver}")
                    };
                    (label, color, values)
                })
                .collect()
        };
        let slides = lines("slide");
        let turns = lines("turn");
        fn as_series(v: &[Line]) -> Vec<Series<'_>> {
            v.iter()
                .map(|(label, color, values)| Series {
                    label,
                    color: *color,
                    values: values.clone(),
                })
                .collect()
        }
        render_png(&dir.join("bench_speed_drag.png"), 480, |root| {
            let (left, right) = root.split_horizontally(600);
            chart(
                &left,
                "drag sliding on a frictionless plate",
                "hand speed, mm/s",
                "mean force against the motion, N",
                &as_series(&slides),
            )?;
            chart(
                &right,
                "drag turning on a frictionless plate",
                "hand speed, rad/s",
                "mean torque against the motion, N·mm",
                &as_series(&turns),
            )
        })?;
    }
    if let Some(f) = &report.friction {
        // The stick–slip curve: force against the hand's displacement, one line per push.
        let palette = [
            RGBColor(31, 119, 180),
            RGBColor(255, 127, 14),
            RGBColor(44, 160, 44),
            RGBColor(214, 39, 40),
            RGBColor(148, 103, 189),
        ];
        let lines = |surface: &str, motion: &str| -> Vec<(String, Vec<(f64, f64)>)> {
            f.pushes
                .iter()
                .filter(|r| r.surface == surface && r.motion == motion)
                .map(|r| {
                    let unit = if motion == "slide" { "mm/s" } else { "rad/s" };
                    (format!("{} {unit}", r.speed), r.curve.clone())
                })
                .collect()
        };
        let series = |v: &[(String, Vec<(f64, f64)>)]| -> Vec<Line> {
            v.iter()
                .enumerate()
                .map(|(i, (l, c))| (l.clone(), palette[i % palette.len()], c.clone()))
                .collect()
        };
        let panels = [
            (
                "ideal flat",
                "slide",
                "sliding on the ideal flat",
                "hand displacement, mm",
                "force against the motion, N",
            ),
            (
                "ideal flat",
                "turn",
                "turning on the ideal flat",
                "hand turn, rad",
                "torque against the motion, N·mm",
            ),
            (
                "tree plate",
                "slide",
                "sliding on the tree plate",
                "hand displacement, mm",
                "force against the motion, N",
            ),
        ];
        let data: Vec<_> = panels
            .iter()
            .map(|(surface, motion, ..)| series(&lines(surface, motion)))
            .collect();
        render_png(&dir.join("bench_friction_curve.png"), 420, |root| {
            let areas = root.split_evenly((1, 3));
            for (k, area) in areas.iter().enumerate() {
                let (_, _, title, x, y) = panels[k];
                let s: Vec<Series<'_>> = data[k]
                    .iter()
                    .map(|(label, color, values)| Series {
                        label,
                        color: *color,
                        values: values.clone(),
                    })
                    .collect();
                chart(area, title, x, y, &s)?;
            }
            Ok(())
        })?;
    }
    Ok(())
}

/// One line of a drag plot: label, colour, points.
type Line = (String, RGBColor, Vec<(f64, f64)>);

/// Average cost per frame, stacked detection + optimisation, one bar per scene and solver.
fn cost_bars<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    report: &BenchReport,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let rows = &report.replay;
    let top = rows
        .iter()
        .map(|r| r.cd_us.mean + r.opt_us.mean)
        .fold(1.0, f64::max)
        * 1.15;
    let n = rows.len().max(1);
    let mut ch = ChartBuilder::on(root)
        .caption(
            "average cost per frame (µs): detection + optimisation",
            ("sans-serif", 20),
        )
        .margin(10)
        .x_label_area_size(50)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..n as f64, 0.0..top)
        .map_err(|e| anyhow!("{e:?}"))?;
    ch.configure_mesh()
        .disable_x_mesh()
        .x_labels(n)
        .x_label_formatter(&|x| {
            let i = x.floor() as usize;
            rows.get(i)
                .map(|r| format!("{}/{}", r.scene, r.solver))
                .unwrap_or_default()
        })
        .y_desc("µs")
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(|e| anyhow!("{e:?}"))?;
    for (i, r) in rows.iter().enumerate() {
        let x0 = i as f64 + 0.15;
        let x1 = i as f64 + 0.85;
        let color = solver_color(&r.solver);
        ch.draw_series(std::iter::once(Rectangle::new(
            [(x0, 0.0), (x1, r.cd_us.mean)],
            RGBColor(150, 150, 150).filled(),
        )))
        .map_err(|e| anyhow!("{e:?}"))?;
        ch.draw_series(std::iter::once(Rectangle::new(
            [(x0, r.cd_us.mean), (x1, r.cd_us.mean + r.opt_us.mean)],
            color.filled(),
        )))
        .map_err(|e| anyhow!("{e:?}"))?;
    }
    Ok(())
}
