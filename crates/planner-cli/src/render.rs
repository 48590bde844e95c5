//! SVG pictures of a map and paths, for people to check by eye.
//!
//! The map is one embedded PNG (one pixel per cell: obstacles black, unknown grey, the inflated
//! band pink, free cells white shading to orange as their costmap cost rises towards 252), so
//! even a 1000 x 1000 map stays a small file; paths are polylines on top, in grid coordinates
//! with the y axis flipped so north is up. A Pareto front is drawn beside it: length against
//! turning, and with a third objective (safety) its three 2-D projections.

use base64::Engine;
use planner_core::config::PlannerConfig;
use planner_core::geometry::{Cell, Point2};
use planner_core::grid::inflation::PlanningGrid;
use planner_core::grid::map::{GridMap, UNKNOWN};
use std::fmt::Write;

const PALETTE: &[&str] = &[
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
    "#bcbd22",
];

/// Something drawn over the map, in world metres, or beside it.
pub enum Layer {
    Path {
        label: String,
        points: Vec<Point2>,
    },
    Endpoints {
        start: Point2,
        goal: Point2,
    },
    /// A Pareto front (f1 length in m, f2 turning in rad, f3 safety cost in m; f3 all 0 when
    /// safety is off) and the chosen member, drawn as scatter plots beside the map.
    Pareto {
        front: Vec<[f64; 3]>,
        chosen: [f64; 3],
    },
    /// Numbered stops (a patrol route's points): a labelled disc with a tick towards its heading,
    /// or a grey cross for a stop that was skipped.
    Stops(Vec<Stop>),
}

/// One stop of a [`Layer::Stops`].
pub struct Stop {
    pub position: Point2,
    /// Heading (rad) in the map frame.
    pub yaw: f64,
    /// Drawn in the disc (a number).
    pub label: String,
    /// The tooltip (name, why it was skipped).
    pub title: String,
    pub skipped: bool,
}

impl Layer {
    pub fn path(label: &str, points: &[Point2]) -> Self {
        Layer::Path {
            label: label.to_string(),
            points: points.to_vec(),
        }
    }
    pub fn endpoints(start: Point2, goal: Point2) -> Self {
        Layer::Endpoints { start, goal }
    }
    /// Via points, numbered in the order the path passes them, each with a tick along the way
    /// to the next.
    pub fn via(points: &[Point2]) -> Self {
        Layer::Stops(
            points
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let next = points.get(i + 1).unwrap_or(p);
                    Stop {
                        position: *p,
                        yaw: (next.y - p.y).atan2(next.x - p.x),
                        label: (i + 1).to_string(),
                        title: format!("via {} ({:.2}, {:.2})", i + 1, p.x, p.y),
                        skipped: false,
                    }
                })
                .collect(),
        )
    }
}

/// Text made safe inside SVG elements and attributes (labels carry user-given names).
fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Side of the square Pareto panel, in pixels.
const PANEL: f64 = 450.0;

/// The objectives' axis labels.
const AXES: [&str; 3] = [
    "f1 path length (m)",
    "f2 total turning (rad)",
    "f3 safety cost (m at cost 252)",
];

/// The scatter plot of a front's objectives `a` against `b`, as a self-contained `<svg>` at `x`
/// pixels.
fn pareto_panel(front: &[[f64; 3]], chosen: [f64; 3], (a, b): (usize, usize), x: f64) -> String {
    let front: Vec<(f64, f64)> = front.iter().map(|p| (p[a], p[b])).collect();
    let chosen = (chosen[a], chosen[b]);
    let (xa, ya) = (AXES[a], AXES[b]);
    let (margin, size) = (60.0, PANEL - 80.0);
    let span = |v: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| {
            (l.min(x), h.max(x))
        });
        let pad = ((hi - lo) * 0.05).max(1e-3);
        (lo - pad, hi + pad)
    };
    let (x0, x1) = span(&mut front.iter().map(|p| p.0));
    let (y0, y1) = span(&mut front.iter().map(|p| p.1));
    let px = |v: f64| margin + (v - x0) / (x1 - x0) * size;
    let py = |v: f64| 20.0 + size - (v - y0) / (y1 - y0) * size;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg x="{x:.0}" y="0" width="{PANEL}" height="{PANEL}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(
        s,
        r##"<rect x="{margin}" y="20" width="{size}" height="{size}" fill="none" stroke="#444"/>"##
    );
    for &(f1, f2) in &front {
        let _ = writeln!(
            s,
            r##"<circle cx="{:.2}" cy="{:.2}" r="3" fill="#1f77b4"><title>{f1:.3}, {f2:.3}</title></circle>"##,
            px(f1),
            py(f2)
        );
    }
    let _ = writeln!(
        s,
        r##"<circle cx="{:.2}" cy="{:.2}" r="6" fill="none" stroke="#d62728" stroke-width="2"><title>chosen (eq. 19-21): {:.3}, {:.3}</title></circle>"##,
        px(chosen.0),
        py(chosen.1),
        chosen.0,
        chosen.1
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.0}" y="{:.0}" text-anchor="middle">{xa}: {x0:.2} .. {x1:.2}</text>"#,
        margin + size / 2.0,
        size + 45.0
    );
    let _ = writeln!(
        s,
        r#"<text x="14" y="{:.0}" transform="rotate(-90 14 {:.0})" text-anchor="middle">{ya}: {y0:.2} .. {y1:.2}</text>"#,
        20.0 + size / 2.0,
        20.0 + size / 2.0
    );
    let _ = writeln!(
        s,
        r#"<text x="{margin}" y="14">Pareto front: {} solutions, chosen one circled in red</text>"#,
        front.len()
    );
    s.push_str("</svg>\n");
    s
}

pub struct Drawing<'a> {
    map: &'a GridMap,
    grid: &'a PlanningGrid,
    occupied_threshold: i8,
    layers: Vec<Layer>,
}

impl<'a> Drawing<'a> {
    pub fn new(map: &'a GridMap, grid: &'a PlanningGrid, config: &PlannerConfig) -> Self {
        Self {
            map,
            grid,
            occupied_threshold: config.costmap.occupied_threshold,
            layers: Vec::new(),
        }
    }

    pub fn add(&mut self, layer: Layer) {
        self.layers.push(layer);
    }

    fn map_png(&self) -> String {
        let (w, h) = (self.map.width(), self.map.height());
        let img = image::RgbImage::from_fn(w, h, |x, row| {
            let c = Cell::new(x as i32, (h - 1 - row) as i32);
            let v = self.map.value(c);
            image::Rgb(if v == UNKNOWN {
                [158, 158, 158]
            } else if v >= self.occupied_threshold {
                [0, 0, 0]
            } else if !self.grid.is_free(c) {
                [244, 194, 194]
            } else {
                // White at cost 0 shading to orange at 252: the gradient the planners weigh.
                let t = self.grid.cost(c) as f64 / 252.0;
                let mix = |to: f64| (255.0 - t * (255.0 - to)).round() as u8;
                [255, mix(190.0), mix(110.0)]
            })
        });
        let mut png = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .expect("encoding a PNG in memory");
        base64::engine::general_purpose::STANDARD.encode(png)
    }

    /// The map with its paths, as a self-contained `<svg>`, and its width in pixels.
    fn map_svg(&self) -> (String, f64) {
        let info = self.grid.info();
        let (w, h) = (info.width as f64, info.height as f64);
        let scale = 900.0 / w.max(h);
        let stroke = (w.max(h) / 250.0).max(0.15);
        let legend_h = 18.0 * (self.layers.len() as f64 + 1.0);
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{:.0}" height="{:.0}" viewBox="0 0 {w} {}">"#,
            w * scale,
            h * scale + legend_h,
            h + legend_h / scale
        );
        let _ = writeln!(
            s,
            r#"<image x="0" y="0" width="{w}" height="{h}" preserveAspectRatio="none" style="image-rendering:pixelated" href="data:image/png;base64,{}"/>"#,
            self.map_png()
        );
        // Grid coordinates, y flipped.
        let xy = |p: Point2| {
            let g = info.world_to_grid(p);
            (g.x, h - g.y)
        };
        let mut legend = Vec::new();
        let mut colour = PALETTE.iter().cycle();
        for layer in &self.layers {
            match layer {
                Layer::Path { label, points } => {
                    let c = colour.next().unwrap();
                    let pts: Vec<String> = points
                        .iter()
                        .map(|&p| xy(p))
                        .map(|(x, y)| format!("{x:.3},{y:.3}"))
                        .collect();
                    let _ = writeln!(
                        s,
                        r#"<polyline points="{}" fill="none" stroke="{c}" stroke-width="{stroke:.3}" stroke-linejoin="round" opacity="0.9"><title>{}</title></polyline>"#,
                        pts.join(" "),
                        escape(label)
                    );
                    let len: f64 = points.windows(2).map(|p| (p[1] - p[0]).norm()).sum();
                    legend.push((
                        c.to_string(),
                        format!("{label}: {len:.2} m, {} waypoints", points.len()),
                    ));
                }
                Layer::Pareto { .. } => {}
                Layer::Stops(stops) => {
                    let r = stroke * 5.0;
                    for stop in stops {
                        let (x, y) = xy(stop.position);
                        let title = escape(&stop.title);
                        if stop.skipped {
                            let _ = writeln!(
                                s,
                                r##"<path d="M{:.3},{:.3} l{d:.3},{d:.3} m0,-{d:.3} l-{d:.3},{d:.3}" stroke="#777" stroke-width="{:.3}"><title>{title}</title></path>"##,
                                x - r,
                                y - r,
                                stroke * 0.8,
                                d = 2.0 * r
                            );
                            continue;
                        }
                        let reach = 2.4 * r * info.resolution;
                        let (hx, hy) = xy(stop.position
                            + planner_core::geometry::Vector2::new(stop.yaw.cos(), stop.yaw.sin())
                                * reach);
                        let _ = writeln!(
                            s,
                            r##"<line x1="{x:.3}" y1="{y:.3}" x2="{hx:.3}" y2="{hy:.3}" stroke="#222" stroke-width="{:.3}"/>"##,
                            stroke * 0.8
                        );
                        let _ = writeln!(
                            s,
                            r##"<circle cx="{x:.3}" cy="{y:.3}" r="{r:.3}" fill="#fff" stroke="#222" stroke-width="{:.3}"><title>{title}</title></circle>"##,
                            stroke * 0.6
                        );
                        let _ = writeln!(
                            s,
                            r##"<text x="{x:.3}" y="{:.3}" font-size="{:.3}" font-family="sans-serif" text-anchor="middle">{}</text>"##,
                            y + r * 0.4,
                            r * 1.1,
                            escape(&stop.label)
                        );
                    }
                    legend.push((
                        "#222".to_string(),
                        "stops: visiting order, tick towards the heading; grey cross: skipped"
                            .to_string(),
                    ));
                }
                Layer::Endpoints { start, goal } => {
                    for (p, c, name) in [(start, "#00a000", "start"), (goal, "#d00000", "goal")] {
                        let (x, y) = xy(*p);
                        let _ = writeln!(
                            s,
                            r#"<circle cx="{x:.3}" cy="{y:.3}" r="{:.3}" fill="{c}"><title>{name}</title></circle>"#,
                            stroke * 2.5
                        );
                    }
                }
            }
        }
        let font = 12.0 / scale;
        for (i, (c, text)) in legend.iter().enumerate() {
            let y = h + (i as f64 + 1.0) * 18.0 / scale;
            let _ = writeln!(
                s,
                r#"<rect x="{:.3}" y="{:.3}" width="{:.3}" height="{:.3}" fill="{c}"/>"#,
                font * 0.3,
                y - font * 0.8,
                font,
                font * 0.8
            );
            let _ = writeln!(
                s,
                r#"<text x="{:.3}" y="{y:.3}" font-size="{font:.3}" font-family="sans-serif">{}</text>"#,
                font * 1.6,
                escape(text)
            );
        }
        s.push_str("</svg>\n");
        (s, w * scale)
    }

    /// The whole picture: the map, and the Pareto panels beside it when there is a front (one,
    /// length against turning; three projections when the front has a third objective).
    pub fn to_svg(&self) -> String {
        let (map, map_width) = self.map_svg();
        let Some((front, chosen)) = self.layers.iter().find_map(|l| match l {
            Layer::Pareto { front, chosen } => Some((front, *chosen)),
            _ => None,
        }) else {
            return map;
        };
        let pairs: &[(usize, usize)] = if front.iter().any(|p| p[2] > 0.0) {
            &[(0, 1), (0, 2), (1, 2)]
        } else {
            &[(0, 1)]
        };
        let panels: String = pairs
            .iter()
            .enumerate()
            .map(|(k, &pair)| pareto_panel(front, chosen, pair, map_width + k as f64 * PANEL))
            .collect();
        let height = map
            .split("height=\"")
            .nth(1)
            .and_then(|r| r.split('"').next())
            .and_then(|h| h.parse::<f64>().ok())
            .unwrap_or(PANEL)
            .max(PANEL);
        format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{:.0}\" height=\"{height:.0}\">\n{}{}</svg>\n",
            map_width + PANEL * pairs.len() as f64,
            map.replacen("<svg ", "<svg x=\"0\" y=\"0\" ", 1),
            panels
        )
    }
}
