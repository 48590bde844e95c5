//! Obstacles a range sensor sees, kept as costmap_2d's ObstacleLayer keeps them: each
//! observation first clears the cells its rays pass through (raytracing, up to
//! `raytrace_max_range`), then marks the cells its returns fall in (up to `obstacle_max_range`).
//! What a scan saw stays marked until a later ray passes through it: an open cabinet door is
//! planned around until the robot sees the aisle clear again.
//!
//! The layer is a grid of the map's geometry; [`ObstacleLayer::overlay`] lays its marks on the
//! map as obstacles (100), which the planning grid then inflates like the map's own walls, as
//! costmap_2d's inflation layer inflates the obstacle layer's cells.
//!
//! Pure: the caller brings the sensor's rays already in the map frame ([`scan_rays`] makes them
//! from a laser scan's ranges and the sensor's pose, [`cloud_rays`] from a point cloud's points).

use crate::geometry::{Cell, Point2};
use crate::grid::map::{GridMap, MapInfo};
use crate::grid::raycast::supercover;
use nalgebra::Point3;
use std::collections::HashSet;

/// How the layer reads one observation source: Nav2's ObstacleLayer parameters of a source (its
/// `scan:` block in `observation_sources`), with the layer's own obstacle heights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SourceRules {
    /// Returns nearer than this are not marked (m).
    pub obstacle_min_range: f64,
    /// Returns farther than this are not marked (m).
    pub obstacle_max_range: f64,
    /// Cells nearer the sensor than this are not cleared (m).
    pub raytrace_min_range: f64,
    /// Rays clear cells up to this far (m).
    pub raytrace_max_range: f64,
    /// An infinite range means "nothing up to the sensor's maximum range", and clears up to
    /// it, as Nav2's `inf_is_valid`; otherwise it is no reading.
    pub inf_is_valid: bool,
    /// The source's heights: a return lower or higher than these (m, its z in the map frame)
    /// is dropped, neither clearing nor marking (the floor, the ceiling), as Nav2's
    /// ObservationBuffer drops a source's points outside its `min_obstacle_height` and
    /// `max_obstacle_height`, a scan's returns as a cloud's points.
    pub min_obstacle_height: f64,
    pub max_obstacle_height: f64,
    /// The layer's own heights (ObstacleLayer's `min_obstacle_height` and
    /// `max_obstacle_height`): a return the source keeps but outside these clears its ray and
    /// is not marked, as Nav2's `updateBounds` passes over it when marking.
    pub layer_min_obstacle_height: f64,
    pub layer_max_obstacle_height: f64,
    /// The source's returns mark their cells (Nav2's `marking`).
    pub marking: bool,
    /// The source's rays clear the cells they cross (Nav2's `clearing`).
    pub clearing: bool,
}

impl Default for SourceRules {
    /// The `scan` source of Nav2's nav2_params.yaml (marking and clearing, 0 to 2 m high) on
    /// ObstacleLayer's defaults.
    fn default() -> Self {
        Self {
            obstacle_min_range: 0.0,
            obstacle_max_range: 2.5,
            raytrace_min_range: 0.0,
            raytrace_max_range: 3.0,
            inf_is_valid: false,
            min_obstacle_height: 0.0,
            max_obstacle_height: 2.0,
            layer_min_obstacle_height: 0.0,
            layer_max_obstacle_height: 2.0,
            marking: true,
            clearing: true,
        }
    }
}

impl SourceRules {
    fn height_ok(&self, z: f64) -> bool {
        (self.min_obstacle_height..=self.max_obstacle_height).contains(&z)
    }

    /// One ray to a return at `end` (the map's plane, `z` high), `length` m from the sensor
    /// along the plane, whose point `d` m out is `along(d)`: with `clearing` it clears from
    /// `raytrace_min_range` to `raytrace_max_range`, within its length; with `marking` it
    /// marks `end` when `range` (the return's distance as Nav2 gates it) is from
    /// `obstacle_min_range` up to, not at, `obstacle_max_range` and `z` is within the layer's
    /// heights. `None` for a ray that would neither clear nor mark.
    fn ray(
        &self,
        length: f64,
        range: f64,
        (end, z): (Point2, f64),
        along: impl Fn(f64) -> Point2,
    ) -> Option<Ray> {
        let clear_from = self.raytrace_min_range.min(length);
        let mark = self.marking
            && range >= self.obstacle_min_range
            && range < self.obstacle_max_range
            && (self.layer_min_obstacle_height..=self.layer_max_obstacle_height).contains(&z);
        let ray = Ray {
            clear: self.clearing.then(|| {
                (
                    along(clear_from),
                    along(length.min(self.raytrace_max_range).max(clear_from)),
                )
            }),
            mark: mark.then_some(end),
        };
        (ray.clear.is_some() || ray.mark.is_some()).then_some(ray)
    }
}

/// One ray of an observation, in the map frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Cells are cleared from the first point to the second, the second's cell left as it is
    /// (the return's cell, or the end of the raytrace range); `None` for a source that does
    /// not clear.
    pub clear: Option<(Point2, Point2)>,
    /// The return, when it is to be marked.
    pub mark: Option<Point2>,
}

/// The rays of a planar laser scan (sensor_msgs/LaserScan's fields) as costmap_2d's
/// ObstacleLayer reads them through laser_geometry: ray `i` at `angle_min + i * increment`,
/// a range outside `range_min..range_max` (or NaN) is no reading (a sensor reports its
/// maximum when nothing is there), an infinite one is just under the sensor's maximum range
/// with `inf_is_valid` (clearing, marked only if that is within `obstacle_max_range`), else no
/// reading. Marked (with `marking`): from `obstacle_min_range` up to, not at,
/// `obstacle_max_range`, within the layer's heights. A return outside the source's heights (a
/// tilted scanner seeing the floor) is dropped whole, as Nav2 drops the scan's projected
/// points. A ray that neither clears nor marks is left out. `to_map` carries a point of the
/// sensor's frame (x, y in its scan plane) into the map frame, in three dimensions; the sensor
/// is at its (0, 0).
pub fn scan_rays(
    ranges: &[f32],
    angle_min: f64,
    increment: f64,
    range_min: f64,
    range_max: f64,
    rules: &SourceRules,
    to_map: impl Fn(f64, f64) -> Point3<f64>,
) -> Vec<Ray> {
    let flat = |p: Point3<f64>| Point2::new(p.x, p.y);
    let mut rays = Vec::with_capacity(ranges.len());
    for (i, &r) in ranges.iter().enumerate() {
        let r = f64::from(r);
        let r = if r == f64::INFINITY && rules.inf_is_valid {
            // Nav2 reads it as just under range_max, so laser_geometry keeps the point.
            range_max - 1e-4
        } else if r.is_finite() && r >= range_min && r < range_max {
            r
        } else {
            continue;
        };
        let (sin, cos) = (angle_min + i as f64 * increment).sin_cos();
        let at = |d: f64| to_map(d * cos, d * sin);
        let end = at(r);
        if !rules.height_ok(end.z) {
            continue;
        }
        rays.extend(rules.ray(r, r, (flat(end), end.z), |d| flat(at(d))));
    }
    rays
}

/// The rays of a point cloud (sensor_msgs/PointCloud2 with its points already in the map
/// frame) as costmap_2d's ObservationBuffer and ObstacleLayer read them: a point whose height
/// (its z in the map frame) is outside the source's heights is dropped, as its
/// `min_obstacle_height` and `max_obstacle_height` drop the floor and the ceiling; a kept
/// point is marked (with `marking`) when its distance from the sensor's `origin` (in three
/// dimensions, as Nav2 measures it) is within `obstacle_min_range..obstacle_max_range` and its
/// height within the layer's, and (with `clearing`) clears the cells on the plane from the
/// sensor towards it, between `raytrace_min_range` and `raytrace_max_range`. Points that are
/// not finite, and rays that neither clear nor mark, are left out.
pub fn cloud_rays(
    origin: Point3<f64>,
    points: impl IntoIterator<Item = Point3<f64>>,
    rules: &SourceRules,
) -> Vec<Ray> {
    let flat = |p: &Point3<f64>| Point2::new(p.x, p.y);
    let from = flat(&origin);
    points
        .into_iter()
        .filter(|p| p.iter().all(|v| v.is_finite()) && rules.height_ok(p.z))
        .filter_map(|p| {
            let towards = flat(&p) - from;
            let length = towards.norm();
            let along = |t: f64| {
                if length > 0.0 {
                    from + towards * (t.min(length) / length)
                } else {
                    from
                }
            };
            rules.ray(length, (p - origin).norm(), (flat(&p), p.z), along)
        })
        .collect()
}

/// The cells a range sensor has seen occupied, on a map's grid.
#[derive(Clone, Debug, PartialEq)]
pub struct ObstacleLayer {
    info: MapInfo,
    marked: Vec<bool>,
    count: usize,
}

impl ObstacleLayer {
    /// An empty layer on the grid `info` describes.
    pub fn new(info: MapInfo) -> Self {
        Self {
            marked: vec![false; info.cell_count()],
            info,
            count: 0,
        }
    }

    /// The grid the layer is on.
    pub fn info(&self) -> &MapInfo {
        &self.info
    }

    /// How many cells are marked.
    pub fn marked_count(&self) -> usize {
        self.count
    }

    /// Whether cell `c` (inside the map) is marked.
    pub fn is_marked(&self, c: Cell) -> bool {
        self.marked[self.info.index(c)]
    }

    /// One update from the sources' observations, as costmap_2d's ObstacleLayer makes it:
    /// every observation's rays clear first, then every observation's returns are marked, so a
    /// return is cleared neither by its neighbour's ray nor by another source's (a lidar's rays
    /// passing over a low box a depth camera sees leave it marked); last, the robot's
    /// `footprint` (a disc: centre, radius in m), if given, is cleared, as
    /// `footprint_clearing_enabled` clears it, so that a return off the robot's own body or
    /// off someone brushing past does not leave it standing in an obstacle. Parts of rays off
    /// the map are skipped. Returns whether any cell ends the update otherwise than it began it
    /// (a cell cleared and marked again is no change: the same readings applied again change
    /// nothing, and the grid is not made again for them).
    pub fn observe(&mut self, observations: &[&[Ray]], footprint: Option<(Point2, f64)>) -> bool {
        let mut cleared = HashSet::new();
        let rays = || observations.iter().flat_map(|o| o.iter());
        for (from, to) in rays().filter_map(|r| r.clear) {
            let (a, b) = (self.info.world_to_grid(from), self.info.world_to_grid(to));
            let end = Cell::containing(b);
            supercover(a, b, |c| {
                if c != end && self.info.contains(c) && self.set(c, false) {
                    cleared.insert(self.info.index(c));
                }
                true
            });
        }
        let under_robot: HashSet<usize> = footprint
            .map(|(center, radius)| self.disc(center, radius))
            .unwrap_or_default();
        for &i in &under_robot {
            if self.set(self.info.cell_at(i), false) {
                cleared.insert(i);
            }
        }
        let mut marked = false;
        for p in rays().filter_map(|r| r.mark) {
            if let Some(c) = self.info.world_to_cell(p) {
                let i = self.info.index(c);
                if !under_robot.contains(&i) && self.set(c, true) && !cleared.remove(&i) {
                    marked = true;
                }
            }
        }
        marked || !cleared.is_empty()
    }

    /// The cells (their indices) whose centres are within `radius` (m) of `center` (the map
    /// frame), on the map.
    fn disc(&self, center: Point2, radius: f64) -> HashSet<usize> {
        let Some(c) = self.info.world_to_cell(center) else {
            return HashSet::new();
        };
        let reach = (radius / self.info.resolution).ceil() as i32 + 1;
        (-reach..=reach)
            .flat_map(|dy| (-reach..=reach).map(move |dx| c.offset(dx, dy)))
            .filter(|&cell| {
                self.info.contains(cell)
                    && (self.info.cell_to_world(cell) - center).norm() <= radius
            })
            .map(|cell| self.info.index(cell))
            .collect()
    }

    /// Forgets everything seen (costmap_2d's ClearEntireCostmap on a clearable layer).
    /// Returns whether anything was marked.
    pub fn clear_all(&mut self) -> bool {
        let had = self.count > 0;
        self.marked.fill(false);
        self.count = 0;
        had
    }

    /// Clears the cells strictly inside the axis-aligned square of side `side` (m) centred on
    /// `center` (`inside`), or every cell but those (`!inside`), as costmap_2d's
    /// `CostmapLayer::clearArea` clears a layer for the ClearCostmapAroundRobot and
    /// ClearCostmapExceptRegion services. Returns whether any cell changed.
    pub fn clear_square(&mut self, center: Point2, side: f64, inside: bool) -> bool {
        let half = side / 2.0;
        let corner = |dx: f64, dy: f64| {
            let g = self
                .info
                .world_to_grid(Point2::new(center.x + dx, center.y + dy));
            // costmap_2d's worldToMapNoBounds: truncated toward zero.
            (g.x.trunc(), g.y.trunc())
        };
        let (x0, y0) = corner(-half, -half);
        let (x1, y1) = corner(half, half);
        let mut changed = false;
        for i in 0..self.marked.len() {
            if !self.marked[i] {
                continue;
            }
            let c = self.info.cell_at(i);
            let (x, y) = (f64::from(c.x), f64::from(c.y));
            let within = x > x0 && x < x1 && y > y0 && y < y1;
            if within == inside {
                changed |= self.set(c, false);
            }
        }
        changed
    }

    /// Marks or clears one cell; returns whether it changed.
    fn set(&mut self, c: Cell, on: bool) -> bool {
        let slot = &mut self.marked[self.info.index(c)];
        if *slot == on {
            return false;
        }
        *slot = on;
        if on {
            self.count += 1;
        } else {
            self.count -= 1;
        }
        true
    }

    /// `map` with every marked cell an obstacle (100), or `None` when `map` is not on the
    /// layer's grid (a new map came: the layer must be made again for it).
    pub fn overlay(&self, map: &GridMap) -> Option<GridMap> {
        if *map.info() != self.info {
            return None;
        }
        let data = map
            .data()
            .iter()
            .zip(&self.marked)
            .map(|(&v, &m)| if m { 100 } else { v })
            .collect();
        GridMap::new(self.info, data).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose2;

    /// A 4 m x 2 m grid at 0.1 m, origin at (0, 0).
    fn info() -> MapInfo {
        MapInfo {
            width: 40,
            height: 20,
            resolution: 0.1,
            origin: Pose2::new(0.0, 0.0, 0.0),
        }
    }

    fn rules() -> SourceRules {
        SourceRules::default()
    }

    /// A sensor at (0.55, 1.05), 0.2 m up, facing +x: its frame's (x, y) in the map.
    fn sensor(x: f64, y: f64) -> Point3<f64> {
        Point3::new(0.55 + x, 1.05 + y, 0.2)
    }

    fn cell_at(x: f64, y: f64) -> Cell {
        info().world_to_cell(Point2::new(x, y)).unwrap()
    }

    /// A return is marked; the cells before it along the ray are cleared; a later scan whose
    /// ray passes through the marked cell clears it (the door was closed), and one that ends
    /// in it keeps it.
    #[test]
    fn returns_are_marked_and_rays_clear_what_they_pass() {
        let mut layer = ObstacleLayer::new(info());
        let one = |r: f32| scan_rays(&[r], 0.0, 0.1, 0.05, 10.0, &rules(), sensor);
        assert!(layer.observe(&[&one(1.5)], None));
        assert!(layer.is_marked(cell_at(2.05, 1.05)));
        assert_eq!(layer.marked_count(), 1);
        assert!(
            !layer.observe(&[&one(1.5)], None),
            "the same scan changes nothing"
        );
        assert!(layer.observe(&[&one(2.0)], None));
        assert!(
            !layer.is_marked(cell_at(2.05, 1.05)),
            "a ray through it clears it"
        );
        assert!(layer.is_marked(cell_at(2.55, 1.05)));
        assert_eq!(layer.marked_count(), 1);
    }

    /// Ranges are read as Nav2 reads them: out of the sensor's range or NaN is no reading,
    /// beyond obstacle_max_range clears without marking, infinity clears only with
    /// inf_is_valid, clearing stops at raytrace_max_range and starts at raytrace_min_range.
    #[test]
    fn ranges_are_gated_as_the_obstacle_layer_gates_them() {
        let scan = |ranges: &[f32], rules: &SourceRules| {
            scan_rays(ranges, 0.0, 0.0, 0.1, 3.2, rules, sensor)
        };
        // Below range_min, at or past range_max (nothing there), NaN, infinite, negative.
        assert!(scan(&[0.05, 3.2, 3.5, f32::NAN, f32::INFINITY, -1.0], &rules()).is_empty());
        let edge = scan(&[2.5, 2.4999], &rules());
        assert_eq!(
            edge[0].mark, None,
            "obstacle_max_range itself is not marked"
        );
        assert!(edge[1].mark.is_some());
        let far = scan(&[2.8], &rules());
        assert_eq!(far.len(), 1);
        assert_eq!(
            far[0].mark, None,
            "beyond obstacle_max_range: cleared, not marked"
        );
        let inf_valid = SourceRules {
            inf_is_valid: true,
            ..rules()
        };
        let inf = scan(&[f32::INFINITY], &inf_valid);
        assert_eq!(inf.len(), 1);
        assert_eq!(inf[0].mark, None);
        assert!(
            (inf[0].clear.unwrap().1.x - sensor(3.0, 0.0).x).abs() < 1e-9,
            "up to raytrace_max_range"
        );
        // Pitched down 10 degrees, 0.2 m up: returns past 1.15 m are below the floor, dropped
        // whole (Nav2's min_obstacle_height on the scan's points); the nearer one is kept.
        let (sin, cos) = 10f64.to_radians().sin_cos();
        let pitched = |x: f64, y: f64| Point3::new(0.55 + x * cos, 1.05 + y, 0.2 - x * sin);
        let seen = scan_rays(&[1.0, 1.5], 0.0, 0.0, 0.1, 3.2, &rules(), pitched);
        assert_eq!(seen.len(), 1);
        assert!(seen[0].mark.is_some());
        // A wall of marks along the ray's row.
        let mut layer = ObstacleLayer::new(info());
        for x in 0..40 {
            layer.set(Cell::new(x, 10), true);
        }
        let near_kept = SourceRules {
            raytrace_min_range: 1.0,
            ..rules()
        };
        layer.observe(&[&scan(&[2.8], &near_kept)], None);
        let still: Vec<i32> = (0..40)
            .filter(|&x| layer.is_marked(Cell::new(x, 10)))
            .collect();
        // Cleared from 1.0 m (x 1.55 m, cell 15) to the return at 2.8 m (x 3.35 m, cell 33),
        // whose cell is left as it is.
        assert_eq!(still, (0..15).chain(33..40).collect::<Vec<_>>());
        assert_eq!(layer.marked_count(), still.len());
    }

    /// A cloud's points are kept by height in the map frame, marked by their distance from the
    /// sensor in three dimensions, and clear on the plane towards them up to the raytrace range.
    #[test]
    fn cloud_points_are_filtered_by_height_and_gated_by_range() {
        let origin = Point3::new(0.55, 1.05, 0.5);
        let points = [
            Point3::new(2.05, 1.05, 0.3),  // a box on the floor, 1.5 m ahead: marked
            Point3::new(2.05, 1.05, 2.5),  // the ceiling: dropped
            Point3::new(2.05, 1.05, -0.1), // below the floor (noise): dropped
            Point3::new(5.05, 1.05, 0.5),  // 4.5 m ahead: clears up to 3 m, not marked
            Point3::new(f64::NAN, 1.0, 0.5),
        ];
        let rays = cloud_rays(origin, points, &rules());
        assert_eq!(rays.len(), 2);
        assert_eq!(rays[0].mark, Some(Point2::new(2.05, 1.05)));
        assert_eq!(rays[1].mark, None);
        assert!((rays[1].clear.unwrap().1 - Point2::new(3.55, 1.05)).norm() < 1e-9);
        // 2.4 m straight ahead but 2.6 m away in three dimensions (the point is 1 m below the
        // sensor): beyond obstacle_max_range, as Nav2 measures it.
        let below = SourceRules {
            min_obstacle_height: -1.0,
            ..rules()
        };
        let low = cloud_rays(origin, [Point3::new(2.95, 1.05, -0.5)], &below);
        assert_eq!(low[0].mark, None);
        let mut layer = ObstacleLayer::new(info());
        assert!(layer.observe(&[&rays], None));
        assert!(layer.is_marked(cell_at(2.05, 1.05)));
        assert_eq!(layer.marked_count(), 1);
    }

    /// A source that only marks (a depth camera whose rays should not clear what the scanner
    /// saw) or only clears, and the layer's heights over the source's: a return the source
    /// keeps above the layer's `max_obstacle_height` clears its ray but is not marked.
    #[test]
    fn marking_clearing_and_the_layers_heights_are_each_honoured() {
        let origin = Point3::new(0.55, 1.05, 0.5);
        let box_ahead = [Point3::new(2.05, 1.05, 0.3)];
        let marks_only = SourceRules {
            clearing: false,
            ..rules()
        };
        let rays = cloud_rays(origin, box_ahead, &marks_only);
        assert_eq!(
            (rays[0].clear, rays[0].mark),
            (None, Some(Point2::new(2.05, 1.05)))
        );
        let clears_only = SourceRules {
            marking: false,
            ..rules()
        };
        let rays = cloud_rays(origin, box_ahead, &clears_only);
        assert!(rays[0].clear.is_some() && rays[0].mark.is_none());
        let neither = SourceRules {
            marking: false,
            clearing: false,
            ..rules()
        };
        assert!(cloud_rays(origin, box_ahead, &neither).is_empty());
        // A marked row; a marking-only source's ray across it leaves it.
        let mut layer = ObstacleLayer::new(info());
        layer.set(cell_at(1.55, 1.05), true);
        layer.observe(&[&cloud_rays(origin, box_ahead, &marks_only)], None);
        assert!(layer.is_marked(cell_at(1.55, 1.05)));
        assert!(layer.is_marked(cell_at(2.05, 1.05)));
        // The source keeps up to 3 m, the layer marks up to 1 m: a shelf 1.5 m up clears.
        let high = SourceRules {
            max_obstacle_height: 3.0,
            layer_max_obstacle_height: 1.0,
            ..rules()
        };
        let shelf = cloud_rays(origin, [Point3::new(2.05, 1.05, 1.5)], &high);
        assert!(shelf[0].mark.is_none() && shelf[0].clear.is_some());
        layer.observe(&[&shelf], None);
        assert!(!layer.is_marked(cell_at(1.55, 1.05)), "its ray clears");
        // Scans alike: a level scanner 0.2 m up with the layer's floor at 0.5 m marks nothing.
        let raised = SourceRules {
            layer_min_obstacle_height: 0.5,
            ..rules()
        };
        let scan = scan_rays(&[1.0], 0.0, 0.0, 0.1, 3.2, &raised, sensor);
        assert!(scan[0].mark.is_none() && scan[0].clear.is_some());
    }

    /// Two sources in one update: the lidar's ray passing over a low box the camera sees
    /// leaves it marked, whichever comes first; the lidar alone in a later update clears it (a
    /// 2-D layer, as Nav2's ObstacleLayer).
    #[test]
    fn one_sources_rays_do_not_clear_anothers_returns_in_the_same_update() {
        let camera = cloud_rays(
            Point3::new(0.55, 1.05, 0.5),
            [Point3::new(1.55, 1.05, 0.1)],
            &rules(),
        );
        let lidar = scan_rays(&[2.0], 0.0, 0.0, 0.1, 10.0, &rules(), sensor);
        for update in [[&lidar, &camera], [&camera, &lidar]] {
            let mut layer = ObstacleLayer::new(info());
            let update: Vec<&[Ray]> = update.iter().map(|o| o.as_slice()).collect();
            assert!(layer.observe(&update, None));
            assert!(layer.is_marked(cell_at(1.55, 1.05)), "the box");
            assert!(layer.is_marked(cell_at(2.55, 1.05)), "the lidar's return");
            assert!(
                !layer.observe(&update, None),
                "cleared and marked again: no change"
            );
            layer.observe(&[&lidar], None);
            assert!(!layer.is_marked(cell_at(1.55, 1.05)));
        }
    }

    /// A rotated sensor's rays go where its pose puts them; rays off the map are skipped.
    #[test]
    fn rays_follow_the_sensor_pose_and_stay_on_the_map() {
        let mut layer = ObstacleLayer::new(info());
        // Facing +y from (0.55, 0.55): a return 1 m ahead is at (0.55, 1.55).
        let up = |x: f64, y: f64| Point3::new(0.55 - y, 0.55 + x, 0.2);
        layer.observe(
            &[&scan_rays(&[1.0], 0.0, 0.0, 0.0, 10.0, &rules(), up)],
            None,
        );
        assert!(layer.is_marked(cell_at(0.55, 1.55)));
        // From off the map, through it and off it again.
        let outside = |x: f64, y: f64| Point3::new(-1.0 + x, 1.05 + y, 0.2);
        let long = SourceRules {
            obstacle_max_range: 10.0,
            raytrace_max_range: 10.0,
            ..rules()
        };
        layer.observe(
            &[&scan_rays(&[6.0], 0.0, 0.0, 0.0, 10.0, &long, outside)],
            None,
        );
        assert_eq!(layer.marked_count(), 1, "the return is off the map");
    }

    /// The robot's footprint is cleared last in an update: the cells within its radius, no
    /// others, a return under the robot too (a reading of its own body); the same update again
    /// is no change.
    #[test]
    fn the_footprint_is_cleared() {
        let mut layer = ObstacleLayer::new(info());
        for x in 0..40 {
            layer.set(Cell::new(x, 10), true);
        }
        let robot = Some((Point2::new(2.0, 1.05), 0.3));
        // A return on the robot's body, 0.1 m from its centre.
        let body = [Ray {
            clear: None,
            mark: Some(Point2::new(2.1, 1.05)),
        }];
        // Centres at x = 0.05 + 0.1 k on row 10 (y 1.05): within 0.3 m of (2.0, 1.05) are
        // cells 17..=22 (1.75..2.25 m).
        assert!(layer.observe(&[&body], robot));
        let kept: Vec<i32> = (0..40)
            .filter(|&x| layer.is_marked(Cell::new(x, 10)))
            .collect();
        assert_eq!(kept, (0..17).chain(23..40).collect::<Vec<_>>());
        assert!(!layer.observe(&[&body], robot));
        assert!(
            !layer.observe(&[], Some((Point2::new(-5.0, 1.05), 0.3))),
            "off the map"
        );
    }

    /// The clearing services' regions, as costmap_2d's clearArea takes them: the cells strictly
    /// between the square's corner cells, or all but those; everything.
    #[test]
    fn squares_and_everything_are_cleared_as_costmap_2d_clears_them() {
        let full = || {
            let mut layer = ObstacleLayer::new(info());
            for x in 0..40 {
                layer.set(Cell::new(x, 10), true);
            }
            layer
        };
        let kept = |layer: &ObstacleLayer| -> Vec<i32> {
            (0..40)
                .filter(|&x| layer.is_marked(Cell::new(x, 10)))
                .collect()
        };
        // A 1 m square round (2.0, 1.05): corners in cells 15 and 25, cleared 16..=24.
        let mut around = full();
        assert!(around.clear_square(Point2::new(2.0, 1.05), 1.0, true));
        assert_eq!(kept(&around), (0..16).chain(25..40).collect::<Vec<_>>());
        let mut except = full();
        assert!(except.clear_square(Point2::new(2.0, 1.05), 1.0, false));
        assert_eq!(kept(&except), (16..25).collect::<Vec<_>>());
        assert_eq!(except.marked_count(), 9);
        assert!(except.clear_all());
        assert_eq!(except.marked_count(), 0);
        assert!(!except.clear_all());
    }

    /// The overlay makes marked cells obstacles and leaves the rest of the map as it was;
    /// a map of another geometry gets none.
    #[test]
    fn the_overlay_lays_marks_on_the_map_of_the_same_grid() {
        let mut data = vec![0i8; 800];
        data[5] = -1;
        data[6] = 100;
        let map = GridMap::new(info(), data.clone()).unwrap();
        let mut layer = ObstacleLayer::new(info());
        layer.set(Cell::new(5, 0), true);
        layer.set(Cell::new(7, 0), true);
        let laid = layer.overlay(&map).unwrap();
        data[5] = 100;
        data[7] = 100;
        assert_eq!(laid.data(), &data[..]);
        let other = GridMap::new(
            MapInfo {
                width: 20,
                height: 40,
                ..info()
            },
            vec![0; 800],
        )
        .unwrap();
        assert!(layer.overlay(&other).is_none());
    }
}
